//! What the plant and the control law predict for a milling job at steady state: the force of
//! eq 4.17 at a constant feed, `F = Kc b v tau`, and the feed the PI settles to (`F = Fnom`:
//! its integrator stops only there) unless the feed clamps (override 1.0 = the programmed feed,
//! or the lowest feed) hold it off.

use super::job::MillingJob;

/// The steady state at one axial depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Steady {
    pub feed_mm_min: f64,
    pub force_n: f64,
}

/// Lowest feed the controller commands, as a fraction of the programmed feed.
const FEED_MIN: f64 = 0.01;

/// The steady state at axial depth `b_mm`.
pub fn at_depth(job: &MillingJob, b_mm: f64) -> Steady {
    let tau = job.tooth_period_s();
    let v_prog = job.programmed_feed_mm_min() / 60.0;
    let force = |v_mm_s: f64| job.kc_n_per_mm2 * b_mm * v_mm_s * tau;
    let v = (job.fnom_n / (job.kc_n_per_mm2 * b_mm * tau)).clamp(FEED_MIN * v_prog, v_prog);
    Steady { feed_mm_min: v * 60.0, force_n: force(v) }
}

/// Before the depth step, the force right at it (the feed not yet changed), after it.
pub fn predict(job: &MillingJob) -> (Steady, f64, Steady) {
    let before = at_depth(job, job.b_before_mm);
    let at_step =
        job.kc_n_per_mm2 * job.b_after_mm * before.feed_mm_min / 60.0 * job.tooth_period_s();
    (before, at_step, at_depth(job, job.b_after_mm))
}
