//! Switch debouncing, in ticks (pure logic, no division per sample).
//!
//! A [`Debouncer`] takes a new level once it has read it on `ticks` consecutive samples.
//! [`Debouncer::trips_at_once`] makes one level (the tripped one) immediate and debounces
//! only the release: an e-stop or a probe must never wait, but must not chatter back either.
//! [`Debounced`] wraps an `InputPin`; [`DebouncedBank`] debounces up to 32 switches read as
//! one word (a port's input register), with a fast path when nothing is changing.

use embedded_hal::digital::InputPin;

/// Default debounce time of mechanical switches (limits; the release of e-stop and probe).
pub const SWITCH_MS: u32 = 2;

/// Ticks in `ms` at `tick_hz`, at least 1 for a non-zero time (configuration, not the tick).
pub const fn ticks_for_ms(ms: u32, tick_hz: u32) -> u16 {
    let t = (ms as u64 * tick_hz as u64).div_ceil(1000);
    if t > u16::MAX as u64 {
        u16::MAX
    } else {
        t as u16
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Debouncer {
    stable: bool,
    count: u16,
    ticks: u16,
    /// The level taken at once, if any.
    instant: Option<bool>,
}

impl Debouncer {
    /// Both edges debounced over `ticks` samples (0: no debouncing), starting at `initial`.
    pub const fn new(ticks: u16, initial: bool) -> Self {
        Debouncer { stable: initial, count: 0, ticks, instant: None }
    }

    /// `true` (tripped) is taken at once; `false` only after `ticks` samples.
    pub const fn trips_at_once(release_ticks: u16, initial: bool) -> Self {
        Debouncer { stable: initial, count: 0, ticks: release_ticks, instant: Some(true) }
    }

    /// One sample; the debounced level.
    #[inline]
    pub fn update(&mut self, raw: bool) -> bool {
        if raw == self.stable {
            self.count = 0;
        } else if self.instant == Some(raw) {
            self.stable = raw;
            self.count = 0;
        } else {
            self.count += 1;
            if self.count >= self.ticks {
                self.stable = raw;
                self.count = 0;
            }
        }
        self.stable
    }

    pub const fn level(&self) -> bool {
        self.stable
    }
}

/// An `InputPin` read through a [`Debouncer`]; `active_high` says which level is `true`. A read
/// error counts as the tripped (`true`) level: a switch that cannot be read is not trusted.
pub struct Debounced<P> {
    pin: P,
    active_high: bool,
    debouncer: Debouncer,
}

impl<P: InputPin> Debounced<P> {
    pub fn new(pin: P, active_high: bool, debouncer: Debouncer) -> Self {
        Debounced { pin, active_high, debouncer }
    }

    /// One sample; the debounced, active-resolved level.
    #[inline]
    pub fn update(&mut self) -> bool {
        let raw = self.pin.is_high().map_or(true, |h| h == self.active_high);
        self.debouncer.update(raw)
    }

    pub fn release(self) -> P {
        self.pin
    }
}

/// Up to 32 switches sampled as one word, each debounced over `ticks` samples on both edges.
/// Costs a compare per sample while no bit differs from its debounced level.
#[derive(Clone, Debug)]
pub struct DebouncedBank {
    stable: u32,
    /// Bits whose raw level differs from `stable` and are being timed.
    pending: u32,
    counts: [u16; 32],
    ticks: u16,
}

impl DebouncedBank {
    pub const fn new(ticks: u16, initial: u32) -> Self {
        DebouncedBank { stable: initial, pending: 0, counts: [0; 32], ticks }
    }

    /// One sample of every bit; the debounced word.
    #[inline]
    pub fn update(&mut self, raw: u32) -> u32 {
        let differ = raw ^ self.stable;
        if differ == 0 && self.pending == 0 {
            return self.stable;
        }
        // Bits back at their stable level stop timing.
        let mut bits = differ | self.pending;
        self.pending = 0;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let bit = 1u32 << i;
            if differ & bit == 0 {
                self.counts[i] = 0;
                continue;
            }
            self.counts[i] += 1;
            if self.counts[i] >= self.ticks {
                self.stable ^= bit;
                self.counts[i] = 0;
            } else {
                self.pending |= bit;
            }
        }
        self.stable
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};
    use std::vec::Vec;

    fn run(d: &mut Debouncer, raw: &[u8]) -> Vec<u8> {
        raw.iter().map(|&r| d.update(r != 0) as u8).collect()
    }

    #[test]
    fn a_bouncing_close_is_taken_after_the_last_bounce() {
        // 3 ticks (3 ms at 1 kHz): bounces shorter than that are ignored.
        let mut d = Debouncer::new(3, false);
        let raw = [0, 1, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1];
        let out = run(&mut d, &raw);
        assert_eq!(out, [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]);
    }

    #[test]
    fn zero_ticks_passes_every_level_through() {
        let mut d = Debouncer::new(0, false);
        let raw = [0, 1, 0, 1, 1, 0];
        assert_eq!(run(&mut d, &raw), raw);
    }

    #[test]
    fn the_estop_trips_at_once_and_releases_only_after_the_debounce() {
        let mut d = Debouncer::trips_at_once(ticks_for_ms(SWITCH_MS, 1_000), false);
        let raw = [0, 1, 0, 1, 0, 0, 1, 0, 0, 0];
        // Trips on the first high sample; chatter keeps it tripped; two clear samples release.
        assert_eq!(run(&mut d, &raw), [0, 1, 1, 1, 1, 0, 1, 1, 0, 0]);
        assert!(!d.level());
    }

    #[test]
    fn ticks_round_up_from_milliseconds() {
        assert_eq!(ticks_for_ms(2, 100_000), 200);
        assert_eq!(ticks_for_ms(2, 1_500), 3);
        assert_eq!(ticks_for_ms(0, 100_000), 0);
        assert_eq!(ticks_for_ms(1_000, 100_000), u16::MAX);
    }

    #[test]
    fn a_pin_is_read_active_low_and_an_error_counts_as_tripped() {
        use embedded_hal_mock::eh1::MockError;
        let err = MockError::Io(std::io::ErrorKind::Other);
        let pin = Mock::new(&[
            T::get(State::High),
            T::get(State::Low),
            T::get(State::Low).with_error(err),
            T::get(State::High),
        ]);
        let mut d = Debounced::new(pin, false, Debouncer::new(0, false));
        assert!(!d.update());
        assert!(d.update());
        assert!(d.update(), "an unreadable switch reads tripped");
        assert!(!d.update());
        d.release().done();
    }

    #[test]
    fn a_bank_debounces_each_bit_on_its_own() {
        let mut b = DebouncedBank::new(2, 0);
        // Bit 0 closes cleanly; bit 1 bounces once and then closes; bit 2 only glitches.
        let raw = [0b000, 0b111, 0b001, 0b011, 0b011, 0b001, 0b001, 0b000, 0b000];
        let out: Vec<u32> = raw.iter().map(|&r| b.update(r)).collect();
        assert_eq!(out, [0b000, 0b000, 0b001, 0b001, 0b011, 0b011, 0b001, 0b001, 0b000]);
        // Quiet: nothing pending.
        assert_eq!(b.pending, 0);
    }
}
