//! Spindle encoder on TIM4: encoder mode 3 on CH1/CH2 (PB6/PB7, both edges of both channels),
//! and the index pulse on CH3 (PB8) as an input capture of the counter (CC3, `TIM4` interrupt).
//! All the logic (unwrapping, index latch, counts-per-revolution check, angle and speed) is
//! `motion::spindle::timer_encoder::TimerEncoder`; registers only here.

use crate::pac;
use motion::protocol::errors::FaultCode;
use motion::spindle::encoder::{EncoderConfig, EncoderConfigError};
use motion::spindle::timer_encoder::TimerEncoder;
use motion::spindle::SpindleSource;

/// TIM4 and the encoder state it feeds.
pub struct SpindleTimer {
    tim: pac::TIM4,
    enc: TimerEncoder,
}

impl SpindleTimer {
    /// Encoder mode on CH1/CH2, capture on CH3 with its interrupt enabled (the NVIC line stays
    /// masked until an app binds `TIM4`). The counter runs from here on; the encoder logic waits
    /// for [`SpindleTimer::configure`].
    pub fn new(tim: pac::TIM4) -> Self {
        // CC1S/CC2S = 01: IC1 on TI1, IC2 on TI2; filter 0b0011 (8 samples at f_CK_INT = 84 MHz:
        // ~95 ns glitches rejected, far below the shortest quadrature state at any spindle speed).
        // SAFETY: 2-bit CCxS and 4-bit ICxF fields written with values from RM0090 18.4.7.
        tim.ccmr1_input()
            .write(|w| unsafe { w.bits(0b01 | 0b0011 << 4 | 0b01 << 8 | 0b0011 << 12) });
        // CC3S = 01: IC3 on TI3 (the index), same filter, no prescaler (every edge captures).
        // SAFETY: as above, for CCMR2's CC3 fields.
        tim.ccmr2_input().write(|w| unsafe { w.bits(0b01 | 0b0011 << 4) });
        // CC1P/CC2P = 0: non-inverted quadrature; CC3E = 1, CC3P/CC3NP = 0: capture on the
        // index's rising edge.
        tim.ccer().write(|w| w.cc3e().set_bit());
        // SMS = 011: encoder mode 3, the counter counts on every edge of TI1 and TI2.
        // SAFETY: SMS is a 3-bit field; 0b011 is encoder mode 3.
        tim.smcr().write(|w| unsafe { w.bits(0b011) });
        tim.arr().write(|w| w.arr().set(0xffff));
        tim.sr().write(|w| unsafe { w.bits(0) });
        tim.dier().write(|w| w.cc3ie().enabled());
        tim.cr1().write(|w| w.cen().enabled());
        let raw = tim.cnt().read().bits() as u16;
        SpindleTimer { tim, enc: TimerEncoder::new(raw) }
    }

    /// Takes a pending index capture: CC3IF, then CCR3 (reading it clears CC3IF), then CC3OF.
    #[inline]
    fn poll_capture(&mut self) {
        let sr = self.tim.sr().read();
        if sr.cc3if().bit_is_set() {
            let captured = self.tim.ccr3().read().bits() as u16;
            let overcapture = sr.cc3of().bit_is_set();
            if overcapture {
                // SAFETY: SR bits are rc_w0; writing 1 elsewhere leaves the other flags alone.
                self.tim.sr().write(|w| unsafe { w.bits(!(1 << 11)) });
            }
            self.enc.capture(captured, overcapture);
        }
    }

    /// The `TIM4` interrupt (CC3: index edge). Bounded, no division.
    #[inline]
    pub fn on_capture_irq(&mut self) {
        self.poll_capture();
    }

    /// Extended position since start, counts.
    pub fn position_counts(&self) -> i64 {
        self.enc.position_counts()
    }

    /// Index captures overwritten before use (noise on the index line shows here first).
    pub fn lost_index_captures(&self) -> u32 {
        self.enc.lost_index_captures()
    }
}

/// The real spindle is read, never simulated: `Sim(Spindle)` is refused.
impl board_contract::SpindleEncoder for SpindleTimer {
    const SIM: bool = false;

    /// Not honoured on real hardware; false.
    fn set_sim(_speed_turn_q32_per_tick: u32, _index: bool) -> bool {
        false
    }

    /// (Re)starts the encoder logic (counts per revolution, index tolerance, speed window).
    fn configure(&mut self, cfg: EncoderConfig) -> Result<(), EncoderConfigError> {
        self.enc.configure(cfg)
    }

    /// Once per tick, before the Z command reads angle and speed. The capture flag is polled
    /// first and CNT read after it: an index must reach the encoder logic in the tick whose
    /// count has passed it (its revolution check has no slack beyond the index tolerance; see
    /// `timer_encoder`'s tests), whatever the capture interrupt's priority. Bounded, no division.
    #[inline]
    fn update(&mut self) {
        self.poll_capture();
        let raw = self.tim.cnt().read().bits() as u16;
        self.enc.update(raw);
    }
}

impl SpindleSource for SpindleTimer {
    fn angle_turn_q32(&self) -> u32 {
        self.enc.angle_turn_q32()
    }
    fn speed_turn_q32_per_tick(&self) -> i32 {
        self.enc.speed_turn_q32_per_tick()
    }
    fn fault(&self) -> Option<FaultCode> {
        self.enc.fault()
    }
    fn is_referenced(&self) -> bool {
        self.enc.is_referenced()
    }
    fn is_stopped(&self) -> bool {
        self.enc.is_stopped()
    }
}
