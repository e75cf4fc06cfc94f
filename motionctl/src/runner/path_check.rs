//! The executed path against the planned one: every status report the board sends while a job
//! runs must put the axes within [`PATH_LIMIT_STEPS`] (per axis) of the straight segment the
//! board is executing.
//!
//! A report's `positions` and `segments_done` are one snapshot (the board takes them under one
//! lock), so segment number `done` (counting from 0 in send order) is the one executing. A report
//! taken on a segment boundary may show the segment just finished or the next one starting, so
//! the segments either side of it are candidates too; the deviation is the least, over the
//! candidates, of the per-axis (Chebyshev) distance from the position to the segment.
//!
//! Only the segments sent and not yet done are kept, with the last [`KEEP_DONE`] done: at most
//! the board's queue and a few more, however long the file.
//!
//! What leaves the planned path on purpose is re-anchored, or not checked:
//! - a probe move (G38.x) stops where the probe trips (decelerating on its path, and its
//!   reports are checked against it) and the rest of the job is planned from where the axes came
//!   to rest: once the move has ended, the check starts again from there;
//! - an abort (Ctrl-C, a file that changed under the run) ends the run at once: nothing after it
//!   is checked.
//!
//! A feed hold (a job's feed command, or the board's own hold while the host is late) stops the
//! axes on the path and a resume goes on along it, and a resume approach (`run --resume`) is
//! segments sent like any others: their reports are checked as they are.

use motion::protocol::Status;
use motion::segment::Segment;
use motion::MAX_AXES;
use std::collections::VecDeque;

/// The executed path may lag the planned one by a step: the DDA holds a step back (and the
/// axis lags by one) while pulse spacing or a DIR change's set-up time does not allow it yet.
pub const PATH_STEP_STEPS: f64 = 1.0;
/// ... plus the Bresenham rounding: the DDA places every step within half a step of the
/// segment's straight line (`src/dda.rs`).
pub const BRESENHAM_ROUNDING_STEPS: f64 = 0.5;
/// Largest per-axis distance of a status report from the planned path.
pub const PATH_LIMIT_STEPS: f64 = PATH_STEP_STEPS + BRESENHAM_ROUNDING_STEPS;
/// Segments kept after they are done (beyond the last): a report overtaken by a newer one (a
/// polled status answered after the stream's next) is still checked against them.
const KEEP_DONE: i64 = 16;

/// What the path check found, for the run's report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PathSummary {
    /// Status reports checked.
    pub samples: u64,
    /// Of those, reports taken during probe moves.
    pub during_probes: u64,
    /// Reports older than one already checked whose segments are no longer kept.
    pub skipped_stale: u64,
    /// The largest per-axis distance from the planned path seen, steps.
    pub max_dev_steps: f64,
    /// Reports further than [`PATH_LIMIT_STEPS`] from the planned path.
    pub off_path: u64,
    /// The first of those, in words (tick, segment, G-code line, axis, deviation).
    pub first_off: Option<String>,
}

impl PathSummary {
    pub fn ok(&self) -> bool {
        self.off_path == 0
    }
}

/// One planned straight segment, absolute board steps.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    from: [i64; MAX_AXES],
    to: [i64; MAX_AXES],
    /// The segment's id; `None` for the point the job (or its replanned rest) starts at.
    id: Option<u32>,
    line: Option<usize>,
}

/// The check during a run.
pub(super) struct PathCheck {
    /// (name) of the job's axes, in order.
    axes: Vec<String>,
    /// The job's file, for messages naming a line of it.
    label: Option<String>,
    /// The last segments done (or the start point) and every segment sent after them.
    window: VecDeque<Span>,
    /// The job's index of `window[0]` (-1: the start point before the first segment).
    first: i64,
    /// Where the next segment sent starts.
    next_from: [i64; MAX_AXES],
    last_tick: Option<u64>,
    summary: PathSummary,
}

impl PathCheck {
    /// A job starting at `start` (the board's positions before it) on axes named `axes`.
    pub(super) fn new(start: [i64; MAX_AXES], axes: Vec<String>, label: Option<String>) -> Self {
        let mut c = PathCheck {
            axes,
            label,
            window: VecDeque::new(),
            first: 0,
            next_from: start,
            last_tick: None,
            summary: PathSummary::default(),
        };
        c.reanchor(start, 0);
        c
    }

    /// `seg` (from G-code line `line`) was sent: the next segment of the job.
    pub(super) fn sent(&mut self, seg: &Segment, line: Option<usize>) {
        let from = self.next_from;
        let mut to = from;
        for (t, &d) in to.iter_mut().zip(&seg.steps) {
            *t += d as i64;
        }
        self.window.push_back(Span { from, to, id: Some(seg.id), line });
        self.next_from = to;
    }

    /// The job goes on from `at` (where a probe move left the axes) with segment number `next`:
    /// what was sent before is done or dropped.
    pub(super) fn reanchor(&mut self, at: [i64; MAX_AXES], next: u32) {
        self.window.clear();
        self.window.push_back(Span { from: at, to: at, id: None, line: None });
        self.first = next as i64 - 1;
        self.next_from = at;
    }

    /// A status report `st` showing `done` segments of the job done; `probing`: a probe move is
    /// under way.
    pub(super) fn observe(&mut self, st: &Status, done: u32, probing: bool) {
        if probing {
            self.summary.during_probes += 1;
        }
        let done = done as i64;
        let newest = self.last_tick.is_none_or(|t| st.tick >= t);
        if newest {
            self.last_tick = Some(st.tick);
            // The segment just done stays a candidate (a report on the boundary), and a few
            // before it for reports overtaken by this one.
            while self.first < done - 1 - KEEP_DONE && self.window.len() > 1 {
                self.window.pop_front();
                self.first += 1;
            }
        }
        let best = (done - 1..=done + 1)
            .filter_map(|i| self.span(i))
            .map(|s| (deviation(&st.positions, s, self.axes.len()), *s))
            .min_by(|a, b| a.0 .0.total_cmp(&b.0 .0));
        if best.is_none() && !newest {
            self.summary.skipped_stale += 1;
            return;
        }
        self.summary.samples += 1;
        let Some(((dev, axis), _)) = best else {
            let sent = self.first + self.window.len() as i64;
            self.off_path(format!(
                "status at board tick {} shows {done} segments done, but only {sent} were sent",
                st.tick
            ));
            return;
        };
        self.summary.max_dev_steps = self.summary.max_dev_steps.max(dev);
        if dev > PATH_LIMIT_STEPS {
            // Name the segment executing (or, once all are done, the last one).
            let seg = self.span(done).or_else(|| self.span(done - 1)).copied();
            let (id, line) = seg.map_or((None, None), |s| (s.id, s.line));
            let id = id.map_or(String::from("the start point"), |id| format!("id {id}"));
            let at = match (line, &self.label) {
                (Some(l), Some(f)) => format!(", {f}:{l}"),
                (Some(l), None) => format!(", line {l}"),
                _ => String::new(),
            };
            let name = self.axes.get(axis).map_or("?", String::as_str);
            self.off_path(format!(
                "status at board tick {} (segment {} of the job, {id}{at}): {name} is {dev:.2} \
                 steps off the planned path at {:?} (limit {PATH_LIMIT_STEPS} steps)",
                st.tick,
                done + 1,
                &st.positions[..self.axes.len()]
            ));
        }
    }

    fn off_path(&mut self, what: String) {
        self.summary.off_path += 1;
        self.summary.first_off.get_or_insert(what);
    }

    /// The job's segment number `i` if it is in the window.
    fn span(&self, i: i64) -> Option<&Span> {
        let k = i.checked_sub(self.first)?;
        usize::try_from(k).ok().and_then(|k| self.window.get(k))
    }

    pub(super) fn summary(&self) -> PathSummary {
        self.summary.clone()
    }
}

/// The per-axis (Chebyshev) distance of `p` from the straight segment `s` over the first
/// `n_axes` axes, and the axis where it is largest: min over `u` in [0, 1] of
/// max_i |p_i - from_i - u d_i|. That is a convex piecewise-linear function of `u`, so its minimum
/// lies at an end of [0, 1] or at a kink: where one term is 0, or two are equal in size.
fn deviation(p: &[i64; MAX_AXES], s: &Span, n_axes: usize) -> (f64, usize) {
    let n = n_axes.min(MAX_AXES);
    let e: Vec<f64> = (0..n).map(|i| (p[i] - s.from[i]) as f64).collect();
    let d: Vec<f64> = (0..n).map(|i| (s.to[i] - s.from[i]) as f64).collect();
    let at = |u: f64| -> (f64, usize) {
        (0..n).map(|i| ((e[i] - u * d[i]).abs(), i)).fold((0.0, 0), |best, x| {
            if x.0 > best.0 {
                x
            } else {
                best
            }
        })
    };
    let mut candidates = vec![0.0, 1.0];
    for i in 0..n {
        if d[i] != 0.0 {
            candidates.push(e[i] / d[i]);
        }
        for j in i + 1..n {
            if d[i] != d[j] {
                candidates.push((e[i] - e[j]) / (d[i] - d[j]));
            }
            if d[i] + d[j] != 0.0 {
                candidates.push((e[i] + e[j]) / (d[i] + d[j]));
            }
        }
    }
    candidates
        .into_iter()
        .map(|u| at(u.clamp(0.0, 1.0)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((0.0, 0))
}

#[cfg(test)]
mod tests {
    use super::{PathCheck, PATH_LIMIT_STEPS};
    use motion::protocol::Status;
    use motion::segment::{Rate, Segment};
    use motion::MAX_AXES;

    fn seg(id: u32, x: i32, y: i32) -> Segment {
        Segment {
            steps: [x, y, 0, 0, 0, 0],
            duration_ticks: 1_000,
            entry_rate: Rate::ONE,
            exit_rate: Rate::ONE,
            accel_per_tick: Rate::ONE,
            id,
        }
    }

    fn status(tick: u64, x: i64, y: i64) -> Status {
        let mut positions = [0; MAX_AXES];
        positions[..2].copy_from_slice(&[x, y]);
        Status { tick, positions, ..Status::default() }
    }

    /// A job from (100, 50): 1000 steps in X, then 300 in X and 600 in Y (lines 7 and 8).
    fn check() -> PathCheck {
        let mut start = [0; MAX_AXES];
        start[..2].copy_from_slice(&[100, 50]);
        let mut c = PathCheck::new(start, vec!["X".into(), "Y".into()], Some("f.ngc".into()));
        c.sent(&seg(10, 1000, 0), Some(7));
        c.sent(&seg(11, 300, 600), Some(8));
        c
    }

    #[test]
    fn positions_on_the_path_pass_at_segment_ends_and_between() {
        let mut c = check();
        // (position, segments done): the start, mid-way, both ends of the diagonal, the end.
        let on = [
            ((100, 50), 0),
            ((600, 50), 0),
            // A step behind in Y on the X move (a step held back): one step off.
            ((600, 51), 0),
            ((1100, 50), 0),
            ((1100, 50), 1),
            ((1250, 350), 1),
            // A step beside the diagonal in Y, as Bresenham rounding may put it: a third of a
            // step from its nearest point in both axes.
            ((1175, 201), 1),
            ((1400, 650), 1),
            ((1400, 650), 2),
        ];
        for (k, ((x, y), done)) in on.into_iter().enumerate() {
            c.observe(&status(k as u64, x, y), done, false);
        }
        let s = c.summary();
        assert!(s.ok(), "{s:?}");
        assert_eq!(s.samples, 9);
        assert!((s.max_dev_steps - 1.0).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn a_point_two_steps_off_the_path_is_caught_and_named() {
        let mut c = check();
        c.observe(&status(1, 600, 50), 0, false);
        // Two steps beside the diagonal's middle (1250, 350) in both axes, across it.
        c.observe(&status(2, 1252, 348), 1, false);
        let s = c.summary();
        assert!(!s.ok());
        assert_eq!(s.off_path, 1);
        assert!((s.max_dev_steps - 2.0).abs() < 1e-9, "{s:?}");
        assert!(s.max_dev_steps > PATH_LIMIT_STEPS);
        let what = s.first_off.unwrap();
        for part in ["tick 2", "segment 2 of the job", "id 11", "f.ngc:8", "steps off"] {
            assert!(what.contains(part), "{part:?} not in {what:?}");
        }
    }

    #[test]
    fn an_axis_two_steps_behind_on_a_straight_move_is_caught() {
        let mut c = check();
        // Mid-way along X but two steps off in Y: no point of the X move is nearer.
        c.observe(&status(1, 600, 48), 0, false);
        let s = c.summary();
        assert_eq!(s.off_path, 1);
        assert!((s.max_dev_steps - 2.0).abs() < 1e-9, "{s:?}");
        assert!(s.first_off.unwrap().contains("Y is 2.00 steps off"));
    }

    #[test]
    fn a_position_of_the_wrong_segment_is_caught() {
        let mut c = check();
        // The end of the diagonal while the board says the first segment is still running:
        // segment 2 is a neighbour, so it is on the path ...
        c.observe(&status(1, 1400, 650), 0, false);
        assert!(c.summary().ok());
        // ... but a third segment on from there is not.
        let mut c = check();
        c.sent(&seg(12, -1400, 0), Some(9));
        c.observe(&status(1, 600, 650), 0, false);
        assert_eq!(c.summary().off_path, 1);
    }

    #[test]
    fn a_probe_move_is_checked_to_where_it_stopped_and_the_rest_from_there() {
        let mut c = check();
        c.observe(&status(1, 1100, 50), 1, false);
        // The diagonal is a probe move that stops a third of the way, on its path ...
        c.observe(&status(2, 1200, 250), 1, true);
        c.observe(&status(3, 1202, 248), 1, true);
        assert_eq!(c.summary().off_path, 1, "off the probe move's path is caught");
        let mut rest = [0; MAX_AXES];
        rest[..2].copy_from_slice(&[1200, 250]);
        // ... its last two thirds were dropped (counted done), and the rest starts from there.
        c.reanchor(rest, 2);
        c.sent(&seg(20, 0, -250), Some(12));
        c.observe(&status(4, 1200, 250), 2, false);
        c.observe(&status(5, 1200, 100), 2, false);
        c.observe(&status(6, 1200, 0), 3, false);
        let s = c.summary();
        assert_eq!((s.samples, s.during_probes, s.off_path), (6, 2, 1), "{s:?}");
        // Off the replanned rest is caught too.
        c.observe(&status(7, 1203, 0), 3, false);
        assert_eq!(c.summary().off_path, 2);
    }

    #[test]
    fn an_older_report_after_a_newer_one_is_checked_while_its_segments_are_kept() {
        let mut c = check();
        // 40 more segments of 10 steps in Y from (1400, 650).
        for k in 0..40 {
            c.sent(&seg(100 + k, 0, 10), Some(20));
        }
        c.observe(&status(100, 1400, 1050), 42, false);
        // Overtaken reports: one of a segment still kept, on and off the path ...
        c.observe(&status(90, 1400, 905), 27, false);
        c.observe(&status(91, 1402, 905), 27, false);
        // ... and one of a segment no longer kept: skipped, not misread.
        c.observe(&status(5, 600, 50), 0, false);
        let s = c.summary();
        assert_eq!((s.samples, s.off_path, s.skipped_stale), (3, 1, 1), "{s:?}");
        assert!(s.first_off.unwrap().contains("tick 91"));
    }

    #[test]
    fn more_segments_done_than_sent_is_a_failure() {
        let mut c = check();
        c.observe(&status(1, 1400, 650), 4, false);
        let s = c.summary();
        assert_eq!(s.off_path, 1);
        assert!(s.first_off.unwrap().contains("only 2 were sent"));
    }
}
