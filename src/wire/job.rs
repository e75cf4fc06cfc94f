//! Compact constant segment tables (the generated jobs) and the source that streams them as
//! DDA [`Segment`]s.

use crate::config::MAX_AXES;
use crate::segment::{Rate, Segment};

/// One planned 4-axis segment as stored in flash: 28 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JobSegment {
    /// Signed steps of X, Y, beta, alpha.
    pub steps: [i32; 4],
    pub duration_ticks: u32,
    /// Entry and exit rate, Q2.30 fractions of the segment's nominal speed.
    pub entry_q30: u32,
    pub exit_q30: u32,
    /// Rate change per tick, Q2.30 (> 0).
    pub accel_q30: u32,
}

/// Compact constructor used by the generated tables (one call per line keeps them short).
#[allow(clippy::too_many_arguments)]
pub const fn seg(
    x: i32,
    y: i32,
    beta: i32,
    alpha: i32,
    duration_ticks: u32,
    entry_q30: u32,
    exit_q30: u32,
    accel_q30: u32,
) -> JobSegment {
    JobSegment { steps: [x, y, beta, alpha], duration_ticks, entry_q30, exit_q30, accel_q30 }
}

impl JobSegment {
    /// The DDA segment, tagged `id`.
    pub const fn segment(&self, id: u32) -> Segment {
        let mut steps = [0i32; MAX_AXES];
        steps[0] = self.steps[0];
        steps[1] = self.steps[1];
        steps[2] = self.steps[2];
        steps[3] = self.steps[3];
        Segment {
            steps,
            duration_ticks: self.duration_ticks,
            entry_rate: Rate::from_bits(self.entry_q30),
            exit_rate: Rate::from_bits(self.exit_q30),
            accel_per_tick: Rate::from_bits(self.accel_q30),
            id,
        }
    }
}

/// Sum of every segment's steps: where the job ends, from where it started.
pub fn total_steps(job: &[JobSegment]) -> [i64; 4] {
    let mut t = [0i64; 4];
    for s in job {
        for (t, &d) in t.iter_mut().zip(&s.steps) {
            *t += d as i64;
        }
    }
    t
}

/// Sum of every segment's nominal duration, ticks.
pub fn total_ticks(job: &[JobSegment]) -> u64 {
    job.iter().map(|s| s.duration_ticks as u64).sum()
}
