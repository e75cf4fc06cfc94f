//! The `dda_lane_kernel` scenario: the lane kernel on pseudo-random lanes, one call per tick.
//! The firmware's build runs the Thumb-2 kernel and the host model runs [`lanes::step_portable`],
//! so equal reports prove the two the same on every input drawn: valid Bresenham states (the
//! error in `[-t, 0)`, `d <= t`), the edges where a lane just carries or just does not, and
//! arbitrary words.

use super::lanes::{self, Lane, Lanes};
use crate::config::MAX_AXES;
use crate::scenario::{Scenario, ScenarioReport, TraceHash};

/// Kernel calls in the check.
pub const CALLS: u32 = 24_576;
/// Nominal: the check has no machine time, only calls.
const TICK_HZ: u32 = 50_000;

/// xorshift32: the same sequence on both sides, no division.
#[derive(Clone, Copy)]
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// A value in `0..=max` with a bias towards both ends (no division: masks and clamps).
    fn up_to(&mut self, max: u32) -> u32 {
        match self.next() & 3 {
            0 => 0,
            1 => max,
            _ => (self.next() >> (self.next() & 31)).min(max),
        }
    }
}

pub struct LaneKernelCheck {
    rng: Rng,
    calls: u32,
    hash: TraceHash,
    steps: u32,
    wide_calls: u32,
}

impl Default for LaneKernelCheck {
    fn default() -> Self {
        Self::new()
    }
}

impl LaneKernelCheck {
    pub fn new() -> Self {
        LaneKernelCheck {
            rng: Rng(0x2545_f491),
            calls: 0,
            hash: TraceHash::new(),
            steps: 0,
            wide_calls: 0,
        }
    }

    /// The next call's lanes, width and correction.
    fn draw(&mut self) -> (Lanes, bool, u32) {
        let r = &mut self.rng;
        let kind = r.next() & 3;
        let wide = r.next() & 1 != 0;
        let mut lanes = [Lane::default(); MAX_AXES];
        let minus_t = match kind {
            // Any words at all.
            0 => {
                for l in lanes.iter_mut() {
                    *l = Lane { err: r.next(), d: r.next() };
                }
                r.next()
            }
            // Lanes on a carry edge: e + d lands on 2^32 (carries to 0) or one short.
            1 => {
                let t = r.up_to(i32::MAX as u32).max(1);
                for l in lanes.iter_mut() {
                    let d = r.up_to(t);
                    let short = r.next() & 1;
                    l.err = d.wrapping_neg().wrapping_sub(short);
                    l.d = d;
                }
                t.wrapping_neg()
            }
            // Valid Bresenham states: e in [-t, 0) stored as 2^32 + e, d <= t < 2^31.
            _ => {
                let t = r.up_to(i32::MAX as u32).max(1);
                for l in lanes.iter_mut() {
                    let back = r.up_to(t - 1) + 1;
                    *l = Lane { err: back.wrapping_neg(), d: r.up_to(t) };
                }
                t.wrapping_neg()
            }
        };
        (lanes, wide, minus_t)
    }
}

impl Scenario for LaneKernelCheck {
    fn name(&self) -> &'static str {
        "dda_lane_kernel"
    }

    fn tick_hz(&self) -> u32 {
        TICK_HZ
    }

    fn tick(&mut self) -> bool {
        if self.calls == CALLS {
            return false;
        }
        let (mut lanes, wide, minus_t) = self.draw();
        let mask = lanes::step(&mut lanes, wide, minus_t);
        self.hash.u32(mask);
        for l in &lanes {
            self.hash.u32(l.err);
            self.hash.u32(l.d);
        }
        self.steps += mask.count_ones();
        self.wide_calls += wide as u32;
        self.calls += 1;
        true
    }

    fn report(&self) -> ScenarioReport {
        let mut r = ScenarioReport::new(self.name(), self.calls as u64, self.hash.value(), 0);
        r.push("calls", self.calls as i64);
        r.push("wide_calls", self.wide_calls as i64);
        r.push("lane_steps", self.steps as i64);
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(check: &mut LaneKernelCheck) -> ScenarioReport {
        while check.tick() {}
        check.report()
    }

    /// The check must see both widths and both outcomes of every lane often, or an equal
    /// report would prove little.
    #[test]
    fn check_draws_both_widths_and_both_outcomes() {
        let r = run(&mut LaneKernelCheck::new());
        let calls = r.figure("calls").unwrap();
        assert_eq!(calls, CALLS as i64);
        let wide = r.figure("wide_calls").unwrap();
        assert!(wide > calls / 3 && wide < 2 * calls / 3, "wide calls {wide} of {calls}");
        let steps = r.figure("lane_steps").unwrap();
        // Lanes run per call: 4 or 6, so about 5 on average.
        let lanes_run = 4 * calls + 2 * wide;
        assert!(steps > lanes_run / 5 && steps < 4 * lanes_run / 5, "{steps} of {lanes_run}");
    }

    /// Any kernel that differs from the reference on one lane changes the report.
    #[test]
    fn a_kernel_off_by_one_lane_is_caught() {
        let reference = run(&mut LaneKernelCheck::new());
        let mut check = LaneKernelCheck::new();
        let mut hash = TraceHash::new();
        for _ in 0..CALLS {
            let (mut lanes, wide, minus_t) = check.draw();
            let mut mask = lanes::step_portable(&mut lanes, wide, minus_t);
            // A kernel that forgets lane 5 in the wide case.
            if wide && mask & 1 << 5 != 0 {
                mask &= !(1 << 5);
                lanes[5].err = lanes[5].err.wrapping_sub(minus_t);
            }
            hash.u32(mask);
            for l in &lanes {
                hash.u32(l.err);
                hash.u32(l.d);
            }
        }
        assert_ne!(hash.value(), reference.hash);
    }
}
