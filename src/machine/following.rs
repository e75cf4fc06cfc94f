//! Following error where feedback exists: the commanded position (the machine's step counters,
//! exact by construction) against the measured one (an encoder or scale the board reads), per
//! axis. An error above the axis's limit for `debounce_ticks` consecutive checks trips the
//! monitor, and the machine latches `FollowingError`.
//!
//! Why relative to a reference: the feedback counter and the step counters need not start at the
//! same number (an encoder is zeroed at power-up, a scale may be absolute). The monitor takes the
//! difference the first time it runs (and again after [`FollowingMonitor::resync`]: boot, and
//! `ClearFault` after a trip, when the operator accepted where the axis stands) and watches how
//! far the difference moves from there. Why a debounce: a quadrature edge jittering on a line,
//! or a plant lagging a tick at a reversal, is one tick over; a stall or a jam stays over.

use crate::config::{ConfigError, MAX_AXES};

/// Largest limit: far beyond any real following error, and small enough that the compare of an
/// i64 error never meets it by wrapping.
pub const MAX_FOLLOWING_LIMIT_STEPS: u32 = 1 << 30;
/// Longest debounce (ticks).
pub const MAX_FOLLOWING_DEBOUNCE_TICKS: u16 = 10_000;

/// The following-error limits, part of the board config.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FollowingConfig {
    /// Largest |commanded - measured| per axis, steps (measured converted to steps by the board
    /// at setup). 0 = the axis has no feedback: not checked.
    pub limit_steps: [u32; MAX_AXES],
    /// Consecutive checks over the limit before the fault (1 = the first one trips).
    pub debounce_ticks: u16,
}

impl FollowingConfig {
    /// No axis has feedback: the monitor checks nothing.
    pub const OFF: FollowingConfig =
        FollowingConfig { limit_steps: [0; MAX_AXES], debounce_ticks: 0 };

    /// Some axis is checked.
    pub const fn enabled(&self) -> bool {
        let mut i = 0;
        while i < MAX_AXES {
            if self.limit_steps[i] != 0 {
                return true;
            }
            i += 1;
        }
        false
    }

    /// Limits only on axes in use and within range; a debounce of 1..=10000 when any is set.
    pub fn validate(&self, axis_count: u8) -> Result<(), ConfigError> {
        for (a, &limit) in self.limit_steps.iter().enumerate() {
            let axis = Some(a as u8);
            if limit != 0 && a >= axis_count as usize {
                return Err(ConfigError {
                    field: "following_limit_steps",
                    axis,
                    reason: "axis not in use",
                });
            }
            if limit > MAX_FOLLOWING_LIMIT_STEPS {
                return Err(ConfigError {
                    field: "following_limit_steps",
                    axis,
                    reason: "must be within 0..=2^30",
                });
            }
        }
        if self.enabled()
            && (self.debounce_ticks == 0 || self.debounce_ticks > MAX_FOLLOWING_DEBOUNCE_TICKS)
        {
            return Err(ConfigError {
                field: "following_debounce_ticks",
                axis: None,
                reason: "must be within 1..=10000 when a limit is set",
            });
        }
        Ok(())
    }
}

/// The monitor's state: the reference difference per axis and the ticks over the limit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FollowingMonitor {
    /// commanded - measured at the last (re)sync.
    base: [i64; MAX_AXES],
    /// Consecutive checks over the limit.
    over: [u16; MAX_AXES],
    synced: bool,
    /// Largest |error| since the last resync, steps (a status figure).
    worst_steps: [u32; MAX_AXES],
}

impl FollowingMonitor {
    pub const fn new() -> Self {
        FollowingMonitor {
            base: [0; MAX_AXES],
            over: [0; MAX_AXES],
            synced: false,
            worst_steps: [0; MAX_AXES],
        }
    }

    /// The next check takes the current difference as the reference (errors start at 0).
    pub fn resync(&mut self) {
        self.synced = false;
    }

    /// One check (interrupt rate): the first axis (lowest index) whose error has now been over
    /// its limit for `debounce_ticks` consecutive checks, if any. A bounded loop over 6 axes of
    /// subtract, absolute value, compare and a saturating count: no division, no float.
    #[inline]
    pub fn check(
        &mut self,
        cfg: &FollowingConfig,
        commanded: &[i64; MAX_AXES],
        measured: &[i64; MAX_AXES],
    ) -> Option<u8> {
        if !self.synced {
            for i in 0..MAX_AXES {
                self.base[i] = commanded[i].wrapping_sub(measured[i]);
            }
            *self = FollowingMonitor { base: self.base, synced: true, ..FollowingMonitor::new() };
            return None;
        }
        let debounce = cfg.debounce_ticks.max(1);
        let mut tripped = None;
        for i in 0..MAX_AXES {
            let limit = cfg.limit_steps[i];
            if limit == 0 {
                continue;
            }
            let err = commanded[i].wrapping_sub(measured[i]).wrapping_sub(self.base[i]);
            let err_steps = err.unsigned_abs().min(u32::MAX as u64) as u32;
            self.worst_steps[i] = self.worst_steps[i].max(err_steps);
            if err_steps > limit {
                self.over[i] = self.over[i].saturating_add(1);
                if self.over[i] >= debounce && tripped.is_none() {
                    tripped = Some(i as u8);
                }
            } else {
                self.over[i] = 0;
            }
        }
        tripped
    }

    /// Largest |commanded - measured| per axis since the last resync, steps.
    pub const fn worst_steps(&self) -> [u32; MAX_AXES] {
        self.worst_steps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cfg(limit: u32, debounce: u16) -> FollowingConfig {
        let mut c = FollowingConfig::OFF;
        c.limit_steps[0] = limit;
        c.limit_steps[1] = limit;
        c.debounce_ticks = debounce;
        c
    }

    fn at(x: i64, y: i64) -> [i64; MAX_AXES] {
        [x, y, 0, 0, 0, 0]
    }

    #[test]
    fn trips_on_the_debounce_th_check_over_the_limit_not_before() {
        let c = cfg(10, 5);
        let mut m = FollowingMonitor::new();
        // The first check takes the reference: counters and encoder start 1000 apart.
        assert_eq!(m.check(&c, &at(1_000, 0), &at(0, 0)), None);
        // 11 steps commanded past a stuck axis: over the limit; trips on the 5th check.
        let mut trips = std::vec::Vec::new();
        for k in 1..=6 {
            trips.push((k, m.check(&c, &at(1_011, 0), &at(0, 0))));
        }
        let first = trips.iter().find(|(_, t)| t.is_some()).map(|(k, _)| *k);
        assert_eq!(first, Some(c.debounce_ticks as i32));
        assert_eq!(m.worst_steps()[0], 11);
        // Exactly at the limit is not over.
        let mut m = FollowingMonitor::new();
        m.check(&c, &at(0, 0), &at(0, 0));
        for _ in 0..100 {
            assert_eq!(m.check(&c, &at(0, 10), &at(0, 0)), None);
        }
    }

    #[test]
    fn an_excursion_shorter_than_the_debounce_resets_the_count() {
        let c = cfg(3, 4);
        let mut m = FollowingMonitor::new();
        m.check(&c, &at(0, 0), &at(0, 0));
        for _ in 0..50 {
            for _ in 0..3 {
                assert_eq!(m.check(&c, &at(0, 0), &at(0, 9)), None);
            }
            assert_eq!(m.check(&c, &at(0, 0), &at(0, 0)), None);
        }
        // Four in a row: trips, on axis 1.
        let t: std::vec::Vec<_> = (0..4).map(|_| m.check(&c, &at(0, 0), &at(0, 9))).collect();
        assert_eq!(t, [None, None, None, Some(1)]);
    }

    #[test]
    fn limit_zero_means_no_feedback_and_resync_takes_a_new_reference() {
        let c = FollowingConfig::OFF;
        let mut m = FollowingMonitor::new();
        m.check(&c, &at(0, 0), &at(0, 0));
        for _ in 0..100 {
            assert_eq!(m.check(&c, &at(1 << 40, -(1 << 40)), &at(0, 0)), None);
        }
        let c = cfg(5, 1);
        let mut m = FollowingMonitor::new();
        m.check(&c, &at(0, 0), &at(0, 0));
        assert_eq!(m.check(&c, &at(100, 0), &at(0, 0)), Some(0));
        m.resync();
        assert_eq!(m.check(&c, &at(100, 0), &at(0, 0)), None);
        assert_eq!(m.check(&c, &at(105, 0), &at(0, 0)), None);
        assert_eq!(m.check(&c, &at(106, 0), &at(0, 0)), Some(0));
    }

    #[test]
    fn validation_names_the_field() {
        assert!(FollowingConfig::OFF.validate(2).is_ok());
        assert!(cfg(10, 1).validate(2).is_ok());
        assert_eq!(cfg(10, 0).validate(2).unwrap_err().field, "following_debounce_ticks");
        assert_eq!(cfg(10, 1).validate(1).unwrap_err().axis, Some(1));
        assert_eq!(
            cfg(MAX_FOLLOWING_LIMIT_STEPS + 1, 1).validate(2).unwrap_err().field,
            "following_limit_steps"
        );
    }

    proptest! {
        /// A plant that follows the commanded path with a lag of up to `lag` ticks, at most one
        /// step per tick, never trips a limit of `lag` steps, whatever the path.
        #[test]
        fn a_plant_that_follows_within_the_limit_never_trips(
            moves in prop::collection::vec(-1i64..=1, 1..400),
            lag in 1usize..16,
            offset in -1_000_000i64..1_000_000,
        ) {
            let c = cfg(lag as u32, 1);
            let mut m = FollowingMonitor::new();
            let mut path = std::vec![0i64];
            for d in &moves {
                let last = *path.last().unwrap();
                path.push(last + d);
            }
            for t in 0..path.len() {
                let seen = path[t.saturating_sub(lag)];
                let r = m.check(&c, &at(path[t], -path[t]), &at(seen + offset, -seen - offset));
                prop_assert_eq!(r, None, "tick {}", t);
            }
            prop_assert!(m.worst_steps()[0] <= lag as u32);
        }

        /// A jam: the measured position stops while the command keeps going one step a tick.
        /// The trip comes exactly `debounce` checks after the error first exceeds the limit.
        #[test]
        fn a_jam_trips_exactly_after_limit_plus_debounce(limit in 1u32..200, debounce in 1u16..50) {
            let c = cfg(limit, debounce);
            let mut m = FollowingMonitor::new();
            m.check(&c, &at(0, 0), &at(0, 0));
            let mut trip_at = None;
            for k in 1..=(limit as i64 + debounce as i64 + 10) {
                if m.check(&c, &at(k, 0), &at(0, 0)).is_some() && trip_at.is_none() {
                    trip_at = Some(k);
                }
            }
            // Over the limit from step limit+1; the debounce-th such check trips.
            prop_assert_eq!(trip_at, Some(limit as i64 + debounce as i64));
        }
    }
}
