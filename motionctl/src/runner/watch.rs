//! Limits on a running job (or homing): board time, and wall time without progress.

use std::time::{Duration, Instant};

/// Watches a running job against two limits: `limit_ticks` of board time since the first
/// check, and `stuck_after` of wall time without the job's progress marker moving.
///
/// Board time bounds the job's length, not wall time: on a loaded host a simulator's clock runs
/// far slower than the wall clock (CI measured QEMU at about 1/11 of real time), while a real
/// board's clock is real time. The wall clock only catches a job that stopped moving.
#[derive(Debug)]
pub struct JobWatch {
    limit_ticks: u64,
    stuck_after: Duration,
    start_tick: Option<u64>,
    marker: (u64, Instant),
}

/// Why [`JobWatch::check`] gave up on a job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Overdue {
    /// The job ran `ticks` of board time, more than `limit` allows.
    BoardTime { ticks: u64, limit: u64 },
    /// The progress marker did not move for this long (wall clock).
    Stuck(Duration),
}

impl std::fmt::Display for Overdue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Overdue::BoardTime { ticks, limit } => {
                write!(f, "ran {ticks} board ticks, more than its limit of {limit}")
            }
            Overdue::Stuck(d) => write!(f, "made no progress for {} s", d.as_secs()),
        }
    }
}

impl JobWatch {
    /// A limit of `planned_ticks` times `slowdown` plus `slack_ticks` of board time.
    pub fn new(planned_ticks: u64, slowdown: f64, slack_ticks: u64, stuck_after: Duration) -> Self {
        JobWatch {
            limit_ticks: (planned_ticks as f64 * slowdown) as u64 + slack_ticks,
            stuck_after: crate::link::patient(stuck_after),
            start_tick: None,
            marker: (0, Instant::now()),
        }
    }

    pub fn limit_ticks(&self) -> u64 {
        self.limit_ticks
    }

    /// Board time that was not the job's (a hold its driver asked for): added to the budget,
    /// and the progress marker's wall clock starts again.
    pub fn extend(&mut self, ticks: u64) {
        self.limit_ticks = self.limit_ticks.saturating_add(ticks);
        self.marker.1 = Instant::now();
    }

    /// Checks the board's `tick` and the job's progress `marker` (any count that moves while the
    /// job does); the first call starts the board-time budget.
    pub fn check(&mut self, tick: u64, marker: u64) -> Result<(), Overdue> {
        let start = *self.start_tick.get_or_insert(tick);
        let ticks = tick.saturating_sub(start);
        if ticks > self.limit_ticks {
            return Err(Overdue::BoardTime { ticks, limit: self.limit_ticks });
        }
        if marker != self.marker.0 {
            self.marker = (marker, Instant::now());
        } else if self.marker.1.elapsed() > self.stuck_after {
            return Err(Overdue::Stuck(self.stuck_after));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{JobWatch, Overdue};
    use std::time::Duration;

    #[test]
    fn job_watch_bounds_board_time_not_wall_time() {
        let mut w = JobWatch::new(1000, 2.0, 500, Duration::from_secs(60));
        assert_eq!(w.limit_ticks(), 2500);
        // Started at tick 10_000; a slow clock is fine as long as the job moves.
        for (i, tick) in (10_000..=12_500).step_by(100).enumerate() {
            assert_eq!(w.check(tick, i as u64), Ok(()));
        }
        assert_eq!(w.check(12_501, 99), Err(Overdue::BoardTime { ticks: 2501, limit: 2500 }));
    }

    #[test]
    fn job_watch_calls_a_job_stuck_only_while_its_marker_stands_still() {
        let mut w = JobWatch::new(1000, 1.0, 0, Duration::from_millis(20));
        assert_eq!(w.check(0, 1), Ok(()));
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(w.check(1, 2), Ok(()), "the marker moved: not stuck");
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(w.check(2, 2), Err(Overdue::Stuck(Duration::from_millis(20))));
    }
}
