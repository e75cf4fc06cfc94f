//! Switch debouncing on a board's pins. The pure logic ([`Debouncer`], [`DebouncedBank`]) is the
//! machine's (`motion::machine::debounce`), which debounces the limit switches and the e-stop
//! with the configured time for every board; [`Debounced`] reads an `InputPin` through a
//! [`Debouncer`] for inputs a board filters itself (the probe), and resolves its active level
//! (an unreadable pin reads tripped).

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

pub use motion::machine::debounce::{DebouncedBank, Debouncer};

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

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};

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
}
