//! Runs a milling job through the closed-loop force simulation (the Case A scenario's code on
//! the job's setup) and keeps a trace per control update for the CSV and the plot.

use super::job::MillingJob;
use motion::milling::scenario::{MillingScenario, TICK_HZ};
use motion::scenario::{Scenario, ScenarioReport};
use std::path::Path;

/// One control update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    pub t_s: f64,
    pub force_n: f64,
    /// Feed override, 0..2.
    pub override_: f64,
    /// Feed actually run, mm/min: X travel over the last [`FEED_WINDOW`] updates (one update
    /// moves only a few 1 um steps, too coarse to read alone).
    pub feed_mm_min: f64,
}

/// Control updates the feed is measured over (5 ms at 2 kHz).
pub const FEED_WINDOW: usize = 10;
/// The simulated X axis: steps per mm.
const STEPS_PER_MM: f64 = 1000.0;

/// Runs the job to its end; the scenario's report and the trace.
pub fn run(job: &MillingJob) -> anyhow::Result<(ScenarioReport, Vec<TracePoint>)> {
    let mut s = MillingScenario::custom(&job.setup).map_err(|_| {
        anyhow::anyhow!("the milling job's setup was refused by the force loop (a bug: the job file's checks passed)")
    })?;
    let mut trace = Vec::new();
    let mut seen = 0;
    let mut window: std::collections::VecDeque<(u64, i64)> = Default::default();
    while s.tick() {
        let (n, (tick, force_mn, ovr_q30, x)) = s.last_update();
        if n == seen {
            continue;
        }
        seen = n;
        let feed = match window.front() {
            Some(&(t0, x0)) if tick > t0 => {
                (x - x0) as f64 / STEPS_PER_MM / ((tick - t0) as f64 / TICK_HZ as f64) * 60.0
            }
            _ => 0.0,
        };
        if window.len() == FEED_WINDOW {
            window.pop_front();
        }
        window.push_back((tick, x));
        trace.push(TracePoint {
            t_s: tick as f64 / TICK_HZ as f64,
            force_n: force_mn as f64 / 1e3,
            override_: ovr_q30 as f64 / (1u64 << 30) as f64,
            feed_mm_min: feed,
        });
    }
    Ok((s.report(), trace))
}

/// The trace as CSV: time (s), force (N), override, feed (mm/min).
pub fn write_csv(path: &Path, trace: &[TracePoint]) -> anyhow::Result<()> {
    let mut out = String::from("t_s,force_n,override,feed_mm_min\n");
    for p in trace {
        out.push_str(&format!(
            "{:.5},{:.1},{:.4},{:.2}\n",
            p.t_s, p.force_n, p.override_, p.feed_mm_min
        ));
    }
    std::fs::write(path, out).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
    Ok(())
}
