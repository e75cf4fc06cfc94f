//! The simulated spindle of the QEMU board (QEMU models no timer encoder mode): a
//! `motion::spindle::SimSpindle` turned with the tick count at the speed the host set with
//! `Sim(Spindle)` (by the ticks since its last reading, as a real spindle turns with time),
//! read through the same encoder logic (`QuadratureEncoder`) the real board's TIM4 feeds, with
//! or without index pulses (index loss -> `EncoderIndex`).

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use motion::protocol::errors::FaultCode;
use motion::spindle::encoder::{EncoderConfig, EncoderConfigError};
use motion::spindle::{QuadratureEncoder, SimSpindle, SpindleSource};

/// Speed (2^-32 turn per tick) and index pulses on/off: written by the USART task, read by the
/// tick.
static SIM_SPEED_TURN_Q32_PER_TICK: AtomicU32 = AtomicU32::new(0);
static SIM_INDEX: AtomicBool = AtomicBool::new(true);

/// The sim spindle and its encoder (configured by [`Spindle::configure`]).
pub struct Spindle {
    sim: SimSpindle,
    enc: Option<QuadratureEncoder>,
    /// The tick count ([`crate::tick_timer::ticks`]) the sim was last turned to.
    turned_at: u32,
}

/// Most ticks the sim catches up in one reading (a step-only run of the tick reads it once per
/// full tick): one `advance` must stay under a turn for its zero crossing to be an index pulse.
const MAX_CATCH_UP_TICKS: u32 = 8;

impl Spindle {
    pub const fn new() -> Self {
        Spindle { sim: SimSpindle::new(0), enc: None, turned_at: 0 }
    }
}

impl Default for Spindle {
    fn default() -> Self {
        Self::new()
    }
}

impl board_contract::SpindleEncoder for Spindle {
    /// The host drives this spindle (`Sim(Spindle)`).
    const SIM: bool = true;

    /// (Re)starts the encoder logic.
    fn configure(&mut self, cfg: EncoderConfig) -> Result<(), EncoderConfigError> {
        let count = self.sim.encoder(cfg.counts_per_rev).0;
        self.enc = Some(QuadratureEncoder::new(cfg, count)?);
        Ok(())
    }

    /// Sets the simulated speed and index pulses from the next tick on; true (honoured).
    fn set_sim(speed_turn_q32_per_tick: u32, index: bool) -> bool {
        SIM_SPEED_TURN_Q32_PER_TICK.store(speed_turn_q32_per_tick, Relaxed);
        SIM_INDEX.store(index, Relaxed);
        true
    }

    /// Once per tick: turn the sim by the ticks since it was last turned (as a real spindle
    /// turns with time: a second reading in one tick finds it where the first did), read its
    /// encoder. Bounded, multiplies only; a few loads while the spindle stands still.
    #[inline]
    fn update(&mut self) {
        let now = crate::tick_timer::ticks();
        if self.at_rest() {
            self.turned_at = now;
            return;
        }
        let passed = now.wrapping_sub(self.turned_at).min(MAX_CATCH_UP_TICKS);
        self.turned_at = now;
        let speed = SIM_SPEED_TURN_Q32_PER_TICK.load(Relaxed);
        self.sim.advance(speed.wrapping_mul(passed));
        if let Some(e) = self.enc.as_mut() {
            let (count, index) = self.sim.encoder(e.config().counts_per_rev);
            e.update(count, if SIM_INDEX.load(Relaxed) { index } else { None });
        }
    }

    /// A still sim spindle whose encoder has seen a whole window of still counts: nothing
    /// would change (as a real timer encoder's count would not).
    #[inline]
    fn at_rest(&self) -> bool {
        SIM_SPEED_TURN_Q32_PER_TICK.load(Relaxed) == 0
            && !self.sim.crossed_zero()
            && self.enc.as_ref().is_none_or(|e| e.is_still())
    }
}

impl SpindleSource for Spindle {
    fn angle_turn_q32(&self) -> u32 {
        self.enc.as_ref().map_or(0, |e| e.angle_turn_q32())
    }
    fn speed_turn_q32_per_tick(&self) -> i32 {
        self.enc.as_ref().map_or(0, |e| e.speed_turn_q32_per_tick())
    }
    fn fault(&self) -> Option<FaultCode> {
        self.enc.as_ref().and_then(|e| e.fault())
    }
    fn is_referenced(&self) -> bool {
        self.enc.as_ref().is_some_and(|e| e.is_referenced())
    }
    fn is_stopped(&self) -> bool {
        self.enc.as_ref().is_none_or(|e| e.is_stopped())
    }
}
