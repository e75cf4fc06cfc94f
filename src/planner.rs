//! Lookahead planner: straight moves in step space -> [`Segment`]s with junction speeds and ramp
//! slopes the DDA can follow within every axis's rate, acceleration and junction-jerk limit.
//!
//! Integer arithmetic only, so the firmware and the host plan the same job to the same bits.
//! Speeds are path speeds in step space (Euclidean length of the step vector per second), Q16.

use crate::config::{MachineConfig, MAX_AXES};
use crate::fixed_math::isqrt_u128;
use crate::segment::{Rate, Segment, MAX_SEGMENT_TICKS};
use heapless::Deque;

/// Moves the planner looks ahead over. The last planned move always ends at rest, so a longer
/// window only helps jobs of many short moves.
pub const LOOKAHEAD: usize = 16;
const Q16: u32 = 16;

/// A straight move: signed steps per axis at a path feed in step-space steps per second.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Move {
    pub steps: [i32; MAX_AXES],
    pub feed_hz: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanError {
    /// No axis moves.
    Empty,
    /// Feed is zero.
    Feed,
    /// An axis outside the configured `axis_count` moves.
    UnusedAxis { axis: u8 },
    /// The planner holds a full window; pop segments first.
    Full,
    /// The move would last longer than `LOOKAHEAD / 2` maximal segments (about a day at
    /// 100 kHz); split it before planning.
    TooLong,
}

#[derive(Clone, Copy, Debug)]
struct Planned {
    steps: [i32; MAX_AXES],
    len: u64,
    ticks: u64,
    /// Nominal speed the DDA runs at rate 1.0, Q16 steps/s (from `ticks`, so exact for the DDA).
    v_nom: u64,
    /// Path acceleration, Q16 steps/s^2.
    accel: u64,
    /// Highest entry speed the junction with the previous move allows, Q16.
    v_junction: u64,
    v_entry: u64,
    v_exit: u64,
    /// Entry speed of the backward pass (from rest at the window's end), once computed: the
    /// forward pass caps each exit by the next piece's.
    v_back: Option<u64>,
}

pub struct Planner {
    cfg: MachineConfig,
    window: Deque<Planned, LOOKAHEAD>,
    /// Exit speed of the last emitted segment: the fixed entry of the window's first move.
    emitted_exit: u64,
    emitted_nom: u64,
    last_steps: Option<([i32; MAX_AXES], u64)>,
    flushing: bool,
    next_id: u32,
}

impl Planner {
    pub fn new(cfg: &MachineConfig) -> Self {
        Planner {
            cfg: *cfg,
            window: Deque::new(),
            emitted_exit: 0,
            emitted_nom: 0,
            last_steps: None,
            flushing: false,
            next_id: 0,
        }
    }

    /// Room for moves; each move may take several slots when it is split.
    pub fn is_full(&self) -> bool {
        self.window.is_full()
    }

    /// Pieces in the window, waiting to be emitted (a long move takes several).
    pub fn queued(&self) -> usize {
        self.window.len()
    }

    /// Adds a move, split into pieces of at most `MAX_SEGMENT_TICKS`. Fails without change when the
    /// move is invalid or the window lacks room for all its pieces.
    pub fn push(&mut self, mv: &Move) -> Result<(), PlanError> {
        if mv.feed_hz == 0 {
            return Err(PlanError::Feed);
        }
        let mut moving = false;
        for (i, &s) in mv.steps.iter().enumerate() {
            if s != 0 {
                moving = true;
                if i >= self.cfg.axis_count as usize {
                    return Err(PlanError::UnusedAxis { axis: i as u8 });
                }
            }
        }
        if !moving {
            return Err(PlanError::Empty);
        }
        let whole = self.measure(&mv.steps, mv.feed_hz);
        let pieces = whole.ticks.div_ceil(MAX_SEGMENT_TICKS as u64 / 2).max(1);
        if pieces as usize > LOOKAHEAD / 2 {
            return Err(PlanError::TooLong);
        }
        if pieces as usize > LOOKAHEAD - self.window.len() {
            return Err(PlanError::Full);
        }
        self.flushing = false;
        let mut done = [0i64; MAX_AXES];
        for k in 1..=pieces {
            let mut piece = [0i32; MAX_AXES];
            for i in 0..MAX_AXES {
                let upto = mv.steps[i] as i64 * k as i64 / pieces as i64;
                piece[i] = (upto - done[i]) as i32;
                done[i] = upto;
            }
            if piece.iter().all(|&s| s == 0) {
                continue;
            }
            let mut p = self.measure(&piece, mv.feed_hz);
            // Entry speed: within the junction's jerk limit and both pieces' nominal speeds.
            p.v_junction = match (self.last_steps, self.window.back()) {
                (Some((prev, prev_len)), Some(last)) => {
                    self.junction_limit(&prev, prev_len, &piece, p.len).min(last.v_nom).min(p.v_nom)
                }
                (Some((prev, prev_len)), None) => self
                    .junction_limit(&prev, prev_len, &piece, p.len)
                    .min(self.emitted_nom)
                    .min(p.v_nom),
                (None, _) => 0,
            };
            self.last_steps = Some((piece, p.len));
            // The window has room: checked above.
            let _ = self.window.push_back(p);
        }
        self.replan();
        Ok(())
    }

    /// No more moves for now: the last one ends at rest and everything may be emitted.
    pub fn finish(&mut self) {
        self.flushing = true;
        self.last_steps = None;
    }

    /// The next segment whose plan is final: when the window is full, or after [`finish`].
    ///
    /// [`finish`]: Planner::finish
    pub fn pop(&mut self) -> Option<Segment> {
        if !(self.flushing || self.window.is_full()) {
            return None;
        }
        let p = self.window.pop_front()?;
        self.emitted_exit = p.v_exit;
        self.emitted_nom = p.v_nom;
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        let tick_hz = self.cfg.tick_hz as u64;
        let frac = |v: u64| -> Rate {
            let r = ((v as u128) << Rate::FRAC_NBITS) / p.v_nom.max(1) as u128;
            Rate::from_bits(r.min(Rate::ONE.to_bits() as u128) as u32)
        };
        // Rate change per tick = accel / v_nom / tick_hz.
        let dr =
            ((p.accel as u128) << Rate::FRAC_NBITS) / (p.v_nom.max(1) as u128 * tick_hz as u128);
        let dr = dr.clamp(1, Rate::ONE.to_bits() as u128) as u32;
        Some(Segment {
            steps: p.steps,
            // Pieces are at most MAX_SEGMENT_TICKS / 2 (+ rounding) long: see `push`.
            duration_ticks: p.ticks.min(MAX_SEGMENT_TICKS as u64) as u32,
            entry_rate: frac(p.v_entry),
            exit_rate: frac(p.v_exit),
            accel_per_tick: Rate::from_bits(dr),
            id,
        })
    }

    /// Length, duration, nominal speed and path acceleration of one piece.
    fn measure(&self, steps: &[i32; MAX_AXES], feed_hz: u32) -> Planned {
        let sq: u128 = steps.iter().map(|&s| (s as i128 * s as i128) as u128).sum();
        let len = (isqrt_u128(sq) as u64).max(1);
        let tick_hz = self.cfg.tick_hz as u64;
        // Feed capped so no axis exceeds its max rate: v <= max_rate * len / |d|.
        let mut v = (feed_hz as u64) << Q16;
        let mut accel = u64::MAX;
        for (i, &s) in steps.iter().enumerate() {
            let d = s.unsigned_abs() as u64;
            if d == 0 {
                continue;
            }
            let lim = &self.cfg.axes[i];
            v = v.min((((lim.max_rate_hz as u128) << Q16) * len as u128 / d as u128) as u64);
            accel = accel
                .min((((lim.accel_steps_per_s2 as u128) << Q16) * len as u128 / d as u128) as u64);
        }
        let ticks = (((len as u128) << Q16) * tick_hz as u128).div_ceil(v.max(1) as u128);
        let ticks = ticks.clamp(1, u64::MAX as u128) as u64;
        // The DDA runs the piece in exactly `ticks`: that defines its nominal speed.
        let v_nom = (((len as u128) << Q16) * tick_hz as u128 / ticks as u128) as u64;
        Planned {
            steps: *steps,
            len,
            ticks,
            v_nom,
            accel,
            v_junction: 0,
            v_entry: 0,
            v_exit: 0,
            v_back: None,
        }
    }

    /// Highest path speed at the junction for which no axis's velocity jumps by more than its
    /// `junction_jerk_hz`: |v (a_i / La - b_i / Lb)| <= jerk_i.
    fn junction_limit(&self, a: &[i32; MAX_AXES], la: u64, b: &[i32; MAX_AXES], lb: u64) -> u64 {
        let mut v = u64::MAX;
        for i in 0..MAX_AXES {
            let diff = (a[i] as i128 * lb as i128 - b[i] as i128 * la as i128).unsigned_abs();
            if diff == 0 {
                continue;
            }
            let jerk = (self.cfg.axes[i].junction_jerk_hz as u128) << Q16;
            let lim = jerk * la as u128 * lb as u128 / diff;
            v = v.min(lim.min(u64::MAX as u128) as u64);
        }
        v
    }

    /// Backward pass from rest at the window's end, then forward pass from the fixed entry.
    ///
    /// Incremental, with the result of a full pass over the window: a piece's backward entry
    /// depends only on the next piece's, so once a piece's comes out as it was before the new
    /// pieces, every earlier piece's is unchanged too, and so is its forward entry (the fixed
    /// entry moves only as pieces are emitted, each emitted exit being the next piece's entry).
    /// The forward pass then starts at that piece, whose exit cap (the next piece's backward
    /// entry) may have changed.
    fn replan(&mut self) {
        let n = self.window.len();
        let mut start = 0;
        let mut next_entry_max = 0u64;
        for (k, p) in self.window.iter_mut().rev().enumerate() {
            p.v_exit = next_entry_max;
            let back = p.v_junction.min(reachable(p.v_exit, p.accel, p.len));
            let same = p.v_back == Some(back);
            p.v_back = Some(back);
            next_entry_max = back;
            if same {
                start = n - 1 - k;
                break;
            }
        }
        let mut entry = self.emitted_exit;
        for (j, p) in self.window.iter_mut().enumerate().skip(start) {
            if j == start && start > 0 {
                entry = p.v_entry;
            }
            p.v_entry = entry;
            p.v_exit = p.v_exit.min(reachable(entry, p.accel, p.len));
            entry = p.v_exit;
        }
        #[cfg(test)]
        self.check_replan();
    }

    /// The full pass the incremental one must equal (tests only).
    #[cfg(test)]
    fn check_replan(&self) {
        let mut full: heapless::Vec<(u64, u64), LOOKAHEAD> = heapless::Vec::new();
        let mut next_entry_max = 0u64;
        let mut back: heapless::Vec<(u64, u64), LOOKAHEAD> = heapless::Vec::new();
        for p in self.window.iter().rev() {
            let exit = next_entry_max;
            let entry = p.v_junction.min(reachable(exit, p.accel, p.len));
            let _ = back.push((entry, exit));
            next_entry_max = entry;
        }
        back.reverse();
        let mut entry = self.emitted_exit;
        for (p, &(_, exit)) in self.window.iter().zip(back.iter()) {
            let x = exit.min(reachable(entry, p.accel, p.len));
            let _ = full.push((entry, x));
            entry = x;
        }
        for (i, (p, &(e, x))) in self.window.iter().zip(full.iter()).enumerate() {
            assert_eq!((p.v_entry, p.v_exit), (e, x), "piece {i} of {}", self.window.len());
        }
    }
}

/// Speed reachable from `v0` over `len` steps at `accel`: sqrt(v0^2 + 2 a len), all Q16.
fn reachable(v0: u64, accel: u64, len: u64) -> u64 {
    let v0 = v0 as u128;
    let sq = v0 * v0 + ((2 * accel as u128 * len as u128) << Q16);
    isqrt_u128(sq).min(u64::MAX as u128) as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{AxisLimits, StepTiming};
    use proptest::prelude::*;

    fn config() -> MachineConfig {
        let mut axes = [AxisLimits::UNUSED; MAX_AXES];
        for (i, a) in axes.iter_mut().take(3).enumerate() {
            *a = AxisLimits {
                max_rate_hz: 20_000 - 5_000 * i as u32,
                accel_steps_per_s2: 160_000 / (i as u32 + 1),
                junction_jerk_hz: 800 / (i as u32 + 1),
            };
        }
        let timing = StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 };
        MachineConfig { tick_hz: 100_000, timing, axis_count: 3, axes }
    }

    proptest! {
        /// Every replan (checked against the full pass inside `replan`) over random short and
        /// long moves, emitted as the window fills, with occasional ends at rest.
        #[test]
        fn incremental_replan_equals_the_full_pass(
            moves in prop::collection::vec(
                ((-400i32..400, -400i32..400, -60i32..60), 1u32..30_000, 0u8..40),
                1..200,
            )
        ) {
            let mut p = Planner::new(&config());
            let mut steps = [0i64; 3];
            let mut emitted = [0i64; 3];
            for ((x, y, z), feed, r) in moves {
                // One in 40 a long move (split into pieces), one in 40 an end at rest.
                let k = if r == 0 { 200 } else { 1 };
                let mv = Move { steps: [x * k, y * k, z, 0, 0, 0], feed_hz: feed };
                loop {
                    match p.push(&mv) {
                        Ok(()) | Err(PlanError::Empty) => break,
                        Err(PlanError::Full) => {
                            p.finish();
                            while let Some(s) = p.pop() {
                                for i in 0..3 { emitted[i] += s.steps[i] as i64; }
                            }
                        }
                        Err(e) => prop_assert!(false, "{e:?}"),
                    }
                }
                for i in 0..3 { steps[i] += mv.steps[i] as i64; }
                if r == 1 {
                    p.finish();
                }
                while let Some(s) = p.pop() {
                    for i in 0..3 { emitted[i] += s.steps[i] as i64; }
                }
            }
            p.finish();
            while let Some(s) = p.pop() {
                for i in 0..3 { emitted[i] += s.steps[i] as i64; }
            }
            prop_assert_eq!(emitted, steps);
        }
    }
}
