//! Step edges as a stream of port words: the host model of a step output that does not take an
//! interrupt per tick.
//!
//! A tick interrupt costs its entry, exit and bookkeeping on every tick, so the tick rate, and
//! with it the step rate (one step per axis every other tick), stops where the handler fills
//! the core. The fastest grblHAL and Klipper drivers instead let hardware place the edges. Here:
//! a timer's update event at the *slot* rate requests a DMA transfer of the next word of a
//! circular buffer into the GPIO port's set/reset register (STM32 `BSRR`: the low half sets
//! pins, the high half resets them, set wins), and the DMA's half-transfer interrupt runs the
//! DDA for the half it has just played, one tick per slot, writing one word per tick
//! ([`PortWords::fill`]). The interrupt's cost is then paid once per half buffer, and the DDA
//! runs at the slot rate: 500 kHz slots give 250 kHz per axis.
//!
//! One word applies the tick's falling edges, DIR writes and rising edges at the same instant,
//! where the interrupt port ([`StepOutput`]) applies them in that order. That is the same pin
//! sequence whenever no axis writes DIR and rises in one tick, which the DDA guarantees when
//! the DIR setup time is at least one tick ([`timing`] requires it; a fall and a rise of one
//! axis never share a tick, the rate cap keeping its rises two pulse times apart).
//!
//! Pure logic, no hardware types: the board's driver owns the buffer, the timer and the DMA.

use super::StepOutput;
use crate::config::{ConfigError, MachineConfig, TickTiming, MAX_AXES};

/// Fastest slot (tick) rate of a streamed step output: 250 kHz per axis. The DMA moves a word
/// per slot; the DDA's cost per slot is its step-only tick without the interrupt around it.
pub use crate::config::MAX_STREAM_TICK_HZ;

/// Pins of a port with a 16-bit set/reset register.
const PORT_PINS: u8 = 16;

/// Where the axes' STEP and DIR pins sit on one port: axis `i`'s STEP on pin `step_shift + i`,
/// its DIR on pin `dir_shift + i` (a set DIR bit is the negative direction, as in
/// [`StepOutput::dir`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortWords {
    /// The axes' bits of a [`StepOutput`] byte.
    mask: u32,
    /// Multipliers that place an axis byte on the port's pins: a multiply by `2^shift` is a
    /// shift whose amount needs no masking, and the M4 multiplies (and accumulates) in one
    /// cycle. `_hi`: into the word's reset half.
    step_mul: u32,
    step_mul_hi: u32,
    dir_mul: u32,
    dir_mul_hi: u32,
}

/// A pin layout [`PortWords::new`] refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// No axes, or more than the DDA has.
    AxisCount(u8),
    /// A STEP or DIR pin past the port's last pin.
    OffPort,
    /// A STEP pin and a DIR pin on the same port pin.
    Overlap,
}

impl PortWords {
    pub const fn new(step_shift: u8, dir_shift: u8, axes: u8) -> Result<Self, LayoutError> {
        if axes == 0 || axes as usize > MAX_AXES {
            return Err(LayoutError::AxisCount(axes));
        }
        if step_shift as u32 + axes as u32 > PORT_PINS as u32
            || dir_shift as u32 + axes as u32 > PORT_PINS as u32
        {
            return Err(LayoutError::OffPort);
        }
        let mask = (1u32 << axes) - 1;
        if (mask << step_shift) & (mask << dir_shift) != 0 {
            return Err(LayoutError::Overlap);
        }
        Ok(PortWords {
            mask,
            step_mul: 1 << step_shift,
            step_mul_hi: 1 << (step_shift + PORT_PINS),
            dir_mul: 1 << dir_shift,
            dir_mul_hi: 1 << (dir_shift + PORT_PINS),
        })
    }

    /// The axes' STEP pins on the port.
    pub const fn step_pins(&self) -> u16 {
        (self.mask * self.step_mul) as u16
    }

    /// The axes' DIR pins on the port.
    pub const fn dir_pins(&self) -> u16 {
        (self.mask * self.dir_mul) as u16
    }

    /// One tick's output as one set/reset word: rises set STEP pins, falls reset them, DIR
    /// writes set or reset DIR pins. Masks and multiplies only (slot rate); the four parts
    /// never share a bit (the layout's pins do not overlap), so adding them is or-ing them.
    #[inline(always)]
    pub const fn word(&self, out: StepOutput) -> u32 {
        let m = self.mask;
        let (fall, rise) = (out.fall() as u32 & m, out.rise() as u32 & m);
        let (write, dir) = (out.dir_write() as u32 & m, out.dir() as u32);
        let set =
            rise.wrapping_mul(self.step_mul).wrapping_add((dir & write).wrapping_mul(self.dir_mul));
        let reset = fall
            .wrapping_mul(self.step_mul_hi)
            .wrapping_add((write & !dir).wrapping_mul(self.dir_mul_hi));
        set.wrapping_add(reset)
    }

    /// Fills `words` with one word per tick of `tick` (the DDA's step-only tick, or the full
    /// tick when the machine asks for one), in order: the half buffer the DMA plays next.
    #[inline(always)]
    pub fn fill(&self, words: &mut [u32], mut tick: impl FnMut() -> StepOutput) {
        for w in words.iter_mut() {
            *w = self.word(tick());
        }
    }
}

/// A fill's words, put by the DDA ([`Dda::ticks_into`](super::Dda::ticks_into)) or the
/// machine around it.
impl super::TickSink<u32> for PortWords {
    #[inline(always)]
    fn put(&mut self, slot: &mut u32, step: StepOutput) {
        *slot = self.word(step);
    }
}

/// The port's pin levels after the set/reset register is written with `word` (set wins where a
/// word both sets and resets a pin, as on the STM32).
#[inline]
pub const fn apply(levels: u16, word: u32) -> u16 {
    (levels & !((word >> PORT_PINS) as u16)) | word as u16
}

/// The configuration's timing for a streamed step output: [`MachineConfig::validate`], and a
/// DIR setup time of at least one tick at any rate (a DIR write never shares a word with a
/// rise of its axis).
pub fn timing(cfg: &MachineConfig) -> Result<TickTiming, ConfigError> {
    let t = cfg.validate()?;
    if t.setup_ticks == 0 {
        return Err(ConfigError {
            field: "dir_setup_ns",
            axis: None,
            reason: "must be > 0 for a streamed step output (DIR and STEP change in one word)",
        });
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_off_the_port_overlapping_or_without_axes_are_refused() {
        assert_eq!(PortWords::new(0, 6, 0), Err(LayoutError::AxisCount(0)));
        assert_eq!(PortWords::new(0, 6, 7), Err(LayoutError::AxisCount(7)));
        assert_eq!(PortWords::new(12, 0, 6), Err(LayoutError::OffPort));
        assert_eq!(PortWords::new(0, 11, 6), Err(LayoutError::OffPort));
        assert_eq!(PortWords::new(0, 5, 6), Err(LayoutError::Overlap));
        // The F405 motion board: STEP on PC0..PC5, DIR on PC6..PC11.
        let p = PortWords::new(0, 6, 6).unwrap();
        assert_eq!((p.step_pins(), p.dir_pins()), (0x003f, 0x0fc0));
    }

    #[test]
    fn one_word_sets_rises_resets_falls_and_writes_dir_both_ways() {
        let p = PortWords::new(0, 6, 6).unwrap();
        // Axis 0 falls; axis 1's DIR goes negative (set), axis 3's positive (reset); axes 2
        // and 4 rise. Bits of axes past the layout are ignored.
        let out = StepOutput::new(0b0000_0001, 0b0000_1010, 0b1000_0010, 0b1001_0100);
        let w = p.word(out);
        assert_eq!(w & 0xffff, 0b0001_0100 | 0b0010 << 6);
        assert_eq!(w >> 16, 0b0000_0001 | 0b1000 << 6);
        // On a port with every STEP high and DIR 3 negative: axis 0 low, axis 1 negative,
        // axis 3 positive, the rest as they were.
        let before = 0x003f | 0b1000 << 6;
        assert_eq!(apply(before, w), 0x003e | 0b0010 << 6);
    }

    #[test]
    fn a_word_that_sets_and_resets_a_pin_leaves_it_set() {
        assert_eq!(apply(0, 1 | 1 << 16), 1);
        assert_eq!(apply(1, 1 << 16), 0);
    }

    #[test]
    fn streamed_timing_takes_ticks_to_500_khz_and_wants_a_dir_setup_tick() {
        let mut cfg = crate::config::tests::cfg();
        cfg.axis_count = 4;
        cfg.tick_hz = 500_000;
        cfg.timing.pulse_ns = 1_000;
        cfg.timing.dir_setup_ns = 0;
        for a in cfg.axes.iter_mut() {
            a.max_rate_hz = 250_000;
        }
        assert_eq!(timing(&cfg).unwrap_err().field, "dir_setup_ns");
        // At a tick interrupt's rate the config itself takes no DIR setup; a stream still
        // wants one.
        let mut slow = cfg;
        slow.tick_hz = 100_000;
        slow.axes.iter_mut().for_each(|a| a.max_rate_hz = 50_000);
        assert!(slow.validate().is_ok());
        assert_eq!(timing(&slow).unwrap_err().field, "dir_setup_ns");
        cfg.timing.dir_setup_ns = 200;
        let t = timing(&cfg).unwrap();
        assert_eq!(
            (t.tick_ns, t.pulse_ticks, t.setup_ticks, t.min_spacing_ticks),
            (2_000, 1, 1, 2)
        );
        cfg.tick_hz = 1_000_000;
        assert_eq!(timing(&cfg).unwrap_err().field, "tick_hz");
    }
}
