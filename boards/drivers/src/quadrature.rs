//! Quadrature encoders behind one trait ([`Quadrature`]): a hardware counter in encoder mode
//! ([`TimerEncoder`], over any 16-bit [`Counter16`], e.g. an STM32 timer with SMS = 011), and a
//! software x4 decoder of the A/B levels ([`SoftDecoder`], over two `InputPin`s, for boards
//! without an encoder-mode timer, such as the simulated one).
//!
//! Both count every edge of both channels (x4), up when A leads B. Both are bounded,
//! division-free and meant to run once per tick.

use embedded_hal::digital::InputPin;

/// A quadrature position source.
pub trait Quadrature {
    /// Samples the encoder; the position in counts since start (wrapping i32).
    fn update(&mut self) -> i32;
    /// The position the last [`Quadrature::update`] returned.
    fn position(&self) -> i32;
    /// Transitions that skipped a state (both channels changed at once: the encoder moved
    /// faster than it was sampled, or noise). Always 0 for a hardware counter.
    fn errors(&self) -> u32 {
        0
    }
}

/// A free-running 16-bit counter (a timer in encoder mode).
pub trait Counter16 {
    fn count(&mut self) -> u16;
}

/// A 16-bit hardware counter extended to i32: exact while it moves less than 32768 counts
/// between two updates.
pub struct TimerEncoder<C> {
    counter: C,
    last: u16,
    position: i32,
}

impl<C: Counter16> TimerEncoder<C> {
    /// Starts counting from the counter's value now (position 0).
    pub fn new(mut counter: C) -> Self {
        let last = counter.count();
        TimerEncoder { counter, last, position: 0 }
    }

    pub fn counter(&mut self) -> &mut C {
        &mut self.counter
    }
}

impl<C: Counter16> Quadrature for TimerEncoder<C> {
    #[inline]
    fn update(&mut self) -> i32 {
        let raw = self.counter.count();
        let delta = raw.wrapping_sub(self.last) as i16;
        self.last = raw;
        self.position = self.position.wrapping_add(delta as i32);
        self.position
    }

    fn position(&self) -> i32 {
        self.position
    }
}

/// Position change for (previous state, new state), states as Gray code index
/// `(a << 1) | b` mapped to the cycle 00 -> 10 -> 11 -> 01 (A leads B: forward).
/// `None`: both channels changed (a skipped state).
const fn step(prev: u8, next: u8) -> Option<i32> {
    // Cycle position of each AB state.
    const PHASE: [u8; 4] = [0, 3, 1, 2];
    let d = (PHASE[next as usize & 3] + 4 - PHASE[prev as usize & 3]) % 4;
    match d {
        0 => Some(0),
        1 => Some(1),
        3 => Some(-1),
        _ => None,
    }
}

/// Software x4 decoding of two `InputPin`s sampled once per [`Quadrature::update`]. A read
/// error of a pin counts as a skipped state and keeps the last position.
pub struct SoftDecoder<A, B> {
    a: A,
    b: B,
    state: u8,
    position: i32,
    errors: u32,
}

impl<A: InputPin, B: InputPin> SoftDecoder<A, B> {
    /// Starts from the levels now (position 0).
    pub fn new(mut a: A, mut b: B) -> Self {
        let state = read(&mut a, &mut b).unwrap_or(0);
        SoftDecoder { a, b, state, position: 0, errors: 0 }
    }

    pub fn release(self) -> (A, B) {
        (self.a, self.b)
    }

    /// The pins (a simulated encoder drives its lines through them).
    pub fn pins_mut(&mut self) -> (&mut A, &mut B) {
        (&mut self.a, &mut self.b)
    }
}

fn read<A: InputPin, B: InputPin>(a: &mut A, b: &mut B) -> Option<u8> {
    let a = a.is_high().ok()? as u8;
    let b = b.is_high().ok()? as u8;
    Some(a << 1 | b)
}

impl<A: InputPin, B: InputPin> Quadrature for SoftDecoder<A, B> {
    #[inline]
    fn update(&mut self) -> i32 {
        let Some(next) = read(&mut self.a, &mut self.b) else {
            self.errors = self.errors.saturating_add(1);
            return self.position;
        };
        // Most samples see the lines where they were.
        if next == self.state {
            return self.position;
        }
        match step(self.state, next) {
            Some(d) => self.position = self.position.wrapping_add(d),
            None => self.errors = self.errors.saturating_add(1),
        }
        self.state = next;
        self.position
    }

    fn position(&self) -> i32 {
        self.position
    }

    fn errors(&self) -> u32 {
        self.errors
    }
}

/// The A/B levels of an ideal encoder at `count` (x4): what [`SoftDecoder`] decodes back to
/// `count`. Simulated encoders drive their pins with this.
pub const fn levels(count: i32) -> (bool, bool) {
    // Forward cycle 00 -> 10 -> 11 -> 01.
    match count.rem_euclid(4) {
        0 => (false, false),
        1 => (true, false),
        2 => (true, true),
        _ => (false, true),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock as Pin, State, Transaction as T};
    use std::vec::Vec;

    fn state(level: bool) -> State {
        if level {
            State::High
        } else {
            State::Low
        }
    }

    /// Pin expectations that read the levels of `counts` in turn (the first is `new`'s).
    fn pins(counts: &[i32]) -> (Pin, Pin) {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &c in counts {
            let (la, lb) = levels(c);
            a.push(T::get(state(la)));
            b.push(T::get(state(lb)));
        }
        (Pin::new(&a), Pin::new(&b))
    }

    #[test]
    fn soft_decoder_counts_every_edge_both_ways() {
        let path = [0, 1, 2, 3, 4, 5, 4, 3, 2, 1, 0, -1, -2, -3, -4, -5, -5, -4];
        let (a, b) = pins(&path);
        let mut d = SoftDecoder::new(a, b);
        for &want in &path[1..] {
            assert_eq!(d.update(), want);
        }
        assert_eq!(d.errors(), 0);
        let (mut a, mut b) = d.release();
        a.done();
        b.done();
    }

    #[test]
    fn soft_decoder_reports_a_skipped_state_and_does_not_guess() {
        // 0 -> 2 changes both channels: direction unknown, counted as an error.
        let (a, b) = pins(&[0, 1, 3, 4]);
        let mut d = SoftDecoder::new(a, b);
        assert_eq!(d.update(), 1);
        assert_eq!(d.update(), 1, "a skipped state leaves the position");
        assert_eq!(d.errors(), 1);
        assert_eq!(d.update(), 2, "decoding resumes from the new state");
        let (mut a, mut b) = d.release();
        a.done();
        b.done();
    }

    #[test]
    fn soft_decoder_survives_a_bouncing_edge() {
        // A chattering A edge between counts 0 and 1 nets out.
        let path = [0, 1, 0, 1, 0, 1, 2];
        let (a, b) = pins(&path);
        let mut d = SoftDecoder::new(a, b);
        let got: Vec<i32> = (1..path.len()).map(|_| d.update()).collect();
        assert_eq!(got, &path[1..]);
        let (mut a, mut b) = d.release();
        a.done();
        b.done();
    }

    struct Fake(std::vec::IntoIter<u16>);
    impl Counter16 for Fake {
        fn count(&mut self) -> u16 {
            self.0.next().unwrap()
        }
    }

    #[test]
    fn timer_encoder_extends_across_the_wrap_both_ways() {
        // Up across 0xFFFF -> 0, a long step up, down, then down across 0 -> 0xFFFF.
        let raw = std::vec![65_530u16, 65_535, 4, 30_000, 100, 65_000];
        let mut e = TimerEncoder::new(Fake(raw.into_iter()));
        let got: Vec<i32> = (0..5).map(|_| e.update()).collect();
        assert_eq!(got, [5, 10, 30_006, 106, -530]);
        assert_eq!(e.position(), -530);
        assert_eq!(e.errors(), 0);
    }
}
