//! The `[MSG:...]` lines a capability command answers with once its job ended: what it did in
//! the job's own units (mm, deg, rpm, s, N), against the host model, and whether its checks
//! passed.

use super::jobs::{polar_mm, turning_mm};
use crate::milling::run::MillingRunReport;
use crate::polar::run::PolarReport;
use crate::runner::fault_names;
use crate::turning::run::{ZRunOptions, ZRunReport};
use crate::units::MM_PER_IN;
use crate::wire::cli::WireBoardJob;
use crate::wire::run::WireRunReport;
use motion::protocol::Status;

/// `[MSG:...]` texts summing up a milling job in the job's units.
pub fn milling_summary(name: &str, r: &MillingRunReport, fnom_n: f64) -> Vec<String> {
    let tick_hz = motion::milling::scenario::TICK_HZ as f64;
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.0} ms", v * 1e3));
    let forces: Vec<f64> = r.trace.iter().map(|p| p.force_n).collect();
    let mean =
        if forces.is_empty() { 0.0 } else { forces.iter().sum::<f64>() / forces.len() as f64 };
    let mut out = vec![
        format!(
            "MILL {name}: X {:.3} mm of {:.3} mm in {:.3} s of board time ({:.1} s wall)",
            r.x_steps as f64 / 1e3,
            r.expected_x_steps as f64 / 1e3,
            r.board_ticks as f64 / tick_hz,
            r.seconds
        ),
        format!(
            "MILL force: mean {mean:.0} N, peak {:.0} N, Fnom {fnom_n:.0} N, back within +-10 % \
             {} after the depth step (host model {}); {} control updates",
            r.peak_n,
            ms(r.settle_s),
            ms(r.model_settle_s),
            r.updates
        ),
    ];
    if r.faults != 0 {
        out.push(format!("MILL faults: {}", fault_names(r.faults)));
    }
    out.extend(r.problems.iter().map(|p| format!("MILL check failed: {p}")));
    if r.ok() {
        out.push("MILL checks: ok (position and force as the host model)".into());
    }
    out
}

/// `[MSG:...]` texts summing up a polar playback.
pub fn polar_summary(name: &str, r: &PolarReport) -> Vec<String> {
    let tick_hz = motion::polar::job::link_config().machine.tick_hz as f64;
    let at = |p: [i64; 2]| {
        let st = Status { positions: [p[0], p[1], 0, 0, 0, 0], ..Status::default() };
        let v = polar_mm(&st);
        format!("theta {:.3} deg, r {:.3} mm", v[0], v[1])
    };
    let mut out = vec![
        format!(
            "POLAR {name}: {} of {} events in {} blocks, {:.3} s of board time ({:.1} s wall)",
            r.events_fired,
            r.events,
            r.blocks,
            r.board_ticks as f64 / tick_hz,
            r.seconds
        ),
        format!("POLAR end: {}; host model {}", at(r.positions), at(r.expected_positions)),
    ];
    out.extend(r.problems.iter().map(|p| format!("POLAR check failed: {p}")));
    if r.ok() {
        out.push("POLAR checks: ok (every event once, the host model's end)".into());
    }
    out
}

/// `[MSG:...]` texts summing up a Z-slide turning job (X the radial feed, Z the slide), mm.
pub fn turning_summary(name: &str, o: &ZRunOptions, r: &ZRunReport) -> Vec<String> {
    let at = |x_steps: i64, z_steps: i64| {
        let mut st = Status::default();
        st.positions[crate::turning::run::X_AXIS as usize] = x_steps;
        st.positions[crate::turning::run::Z_AXIS as usize] = z_steps;
        let v = turning_mm(&st);
        format!("X {:.4} mm, Z {:+.5} mm", v[0], v[2])
    };
    // Nanoinches to micrometres.
    let um = |nin: i64| nin as f64 * MM_PER_IN * 1e-6;
    let mut out = vec![
        format!(
            "TURN {name}: X {:.3} -> {:.3} mm at {:.3} mm/s, {:.1} rpm; {:.3} s of board time \
             ({:.1} s wall)",
            o.x_start_in * MM_PER_IN,
            o.x_end_in * MM_PER_IN,
            o.feed_in_per_s * MM_PER_IN,
            o.rpm_milli as f64 / 1e3,
            r.board_ticks as f64 / o.tick_hz.max(1) as f64,
            r.seconds
        ),
        format!(
            "TURN end: {}; host model {}",
            at(r.x_steps, r.z_steps),
            at(r.model.x_steps, r.model.z_steps)
        ),
        format!(
            "TURN following: max {:.3} um; host model {:.3} um",
            um(r.max_following_nin),
            um(r.model.max_following_nin)
        ),
    ];
    if r.faults != 0 {
        out.push(format!("TURN faults: {}", fault_names(r.faults)));
    }
    out.extend(r.problems.iter().map(|p| format!("TURN check failed: {p}")));
    if r.ok() {
        out.push("TURN checks: ok (X and Z as the host model, the job finished)".into());
    }
    out
}

/// `[MSG:...]` texts summing up a wire job: X, Y in mm, beta and alpha in degrees, from the
/// job's start.
pub fn wire_summary(name: &str, job: &WireBoardJob, r: &WireRunReport) -> Vec<String> {
    let at = |steps: [i64; 4]| {
        let v: Vec<f64> =
            steps.iter().zip(job.steps_per_unit).map(|(&s, k)| s as f64 / k).collect();
        format!("X {:.3} mm, Y {:.3} mm, beta {:.3} deg, alpha {:.3} deg", v[0], v[1], v[2], v[3])
    };
    let mut out = vec![
        format!(
            "WIRE {name}: {} die, {} of its {} segments at FR {:.0} mm^2/min ({:.2} mm^2/s); \
             {:.3} s of board time ({:.1} s wall)",
            job.label,
            r.segments,
            job.job_segments,
            job.fr_mm2_per_min,
            job.fr_mm2_per_min / 60.0,
            r.board_ticks as f64 / job.cfg.machine.tick_hz.max(1) as f64,
            r.seconds
        ),
        format!("WIRE end: {}; host model {}", at(r.positions), at(r.expected_positions)),
        format!(
            "WIRE stall: {} stalls, {} retrace and {} return segments",
            r.stalls, r.retraces, r.returns
        ),
    ];
    out.extend(r.problems.iter().map(|p| format!("WIRE check failed: {p}")));
    if r.ok() {
        out.push("WIRE checks: ok (the host model's end, no fault, the wire power off)".into());
    }
    out
}
