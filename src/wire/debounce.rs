//! Debounced digital input (the wire-lag micro-switch), sampled once per tick.

/// Follows a raw input once it has disagreed with the debounced state for `ticks` consecutive
/// samples: a contact bounce shorter than that never shows. Integer compare and add per sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Debouncer {
    state: bool,
    disagree_ticks: u16,
    ticks: u16,
}

impl Debouncer {
    /// Starts released (`false`); `ticks` = 0 behaves as 1 (follows the next sample).
    pub const fn new(ticks: u16) -> Self {
        Debouncer { state: false, disagree_ticks: 0, ticks: if ticks == 0 { 1 } else { ticks } }
    }

    /// Feeds one raw sample; returns the debounced state.
    #[inline]
    pub fn sample(&mut self, raw: bool) -> bool {
        if raw == self.state {
            self.disagree_ticks = 0;
        } else {
            self.disagree_ticks += 1;
            if self.disagree_ticks >= self.ticks {
                self.state = raw;
                self.disagree_ticks = 0;
            }
        }
        self.state
    }

    pub const fn state(&self) -> bool {
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn needs_n_agreeing_samples_each_way() {
        let mut d = Debouncer::new(3);
        assert!(!d.sample(true));
        assert!(!d.sample(true));
        assert!(d.sample(true));
        assert!(d.sample(false));
        assert!(d.sample(false));
        assert!(!d.sample(false));
    }

    #[test]
    fn bounces_shorter_than_n_are_ignored() {
        let mut d = Debouncer::new(4);
        for _ in 0..10 {
            for raw in [true, true, true, false] {
                assert!(!d.sample(raw));
            }
        }
    }

    proptest! {
        /// The debounced state changes only after exactly `n` consecutive samples of the new
        /// level, and always then.
        #[test]
        fn matches_a_run_length_model(n in 1u16..8, raw in proptest::collection::vec(any::<bool>(), 0..200)) {
            let mut d = Debouncer::new(n);
            let mut state = false;
            let mut run = 0usize;
            for &r in &raw {
                if r == state { run = 0 } else { run += 1 }
                if run == n as usize { state = r; run = 0; }
                prop_assert_eq!(d.sample(r), state);
            }
        }
    }
}
