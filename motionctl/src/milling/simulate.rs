//! Runs a milling job through the closed-loop force simulation (the Case A scenario's code with
//! the job's parameters) and keeps a trace per control update for CSV and PNG output.

use super::job::MillingJob;
use motion::force::scenario::{ForceScenario, RAPID_STEPS_PER_S, TICK_HZ};
use motion::scenario::{Scenario, ScenarioReport};
use plotters::prelude::*;
use std::path::Path;

/// One control update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    pub t_s: f64,
    pub force_n: f64,
    /// Feed override, 0..2.
    pub override_: f64,
    /// Feed actually run, mm/s: X travel over the last [`FEED_WINDOW`] updates (one update moves
    /// only a few 1 um steps, too coarse to read alone).
    pub feed_mm_s: f64,
}

/// Control updates the feed is measured over (5 ms at 2 kHz).
pub const FEED_WINDOW: usize = 10;

/// Runs the job to its end; the scenario's report and the trace.
pub fn run(job: &MillingJob) -> anyhow::Result<(ScenarioReport, Vec<TracePoint>)> {
    let mut s = ForceScenario::custom(job.control, job.plant).map_err(|_| {
        anyhow::anyhow!("the control setup was refused (need 0 < contact < Fnom < trip)")
    })?;
    let mut trace = Vec::new();
    let mut seen = 0;
    let mut window: std::collections::VecDeque<(u64, i64)> = Default::default();
    let steps_per_mm = 1000.0;
    while s.tick() {
        let (n, (tick, force_mn, ovr_q30, x)) = s.last_update();
        if n == seen {
            continue;
        }
        seen = n;
        let feed = match window.front() {
            Some(&(t0, x0)) if tick > t0 => {
                (x - x0) as f64 / steps_per_mm / ((tick - t0) as f64 / TICK_HZ as f64)
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
            feed_mm_s: feed,
        });
    }
    Ok((s.report(), trace))
}

pub fn write_csv(path: &Path, trace: &[TracePoint]) -> anyhow::Result<()> {
    let mut out = String::from("t_s,force_n,override,feed_mm_s\n");
    for p in trace {
        out.push_str(&format!(
            "{:.5},{:.1},{:.4},{:.3}\n",
            p.t_s, p.force_n, p.override_, p.feed_mm_s
        ));
    }
    std::fs::write(path, out)?;
    Ok(())
}

/// A system TrueType font for the labels, if the machine has one.
fn find_font() -> Option<&'static [u8]> {
    const CANDIDATES: [&str; 4] = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/usr/share/fonts/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    ];
    CANDIDATES.iter().find_map(|p| std::fs::read(p).ok()).map(|b| &*Box::leak(b.into_boxed_slice()))
}

/// One plot panel: caption, y range top, colour, and the value it shows.
type Panel = (&'static str, f64, RGBColor, fn(&TracePoint) -> f64);

/// Force (N, top), feed (mm/s, middle) and override (bottom) against time, as a PNG. Labels need
/// a system font; without one the panels are drawn unlabelled (force red, feed blue, override
/// green) and `Ok(false)` says so.
pub fn write_png(path: &Path, trace: &[TracePoint], fnom_n: f64) -> anyhow::Result<bool> {
    let labelled = match find_font() {
        Some(font) => plotters::style::register_font("sans-serif", FontStyle::Normal, font).is_ok(),
        None => false,
    };
    let t_end = trace.last().map_or(1.0, |p| p.t_s).max(1e-3);
    let root = BitMapBackend::new(path, (1000, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((3, 1));
    let max_f = trace.iter().map(|p| p.force_n).fold(fnom_n, f64::max) * 1.1;
    let max_v =
        trace.iter().map(|p| p.feed_mm_s).fold(RAPID_STEPS_PER_S as f64 / 1e3, f64::max) * 1.1;
    let series: [Panel; 3] = [
        ("force, N", max_f, RED, |p| p.force_n),
        ("feed, mm/s", max_v, BLUE, |p| p.feed_mm_s),
        ("feed override", 2.0, GREEN, |p| p.override_),
    ];
    for (area, (name, y_max, color, get)) in panels.iter().zip(series) {
        let mut b = ChartBuilder::on(area);
        b.margin(10);
        if labelled {
            b.caption(name, ("sans-serif", 18)).x_label_area_size(30).y_label_area_size(60);
        }
        let mut chart = b.build_cartesian_2d(0.0..t_end, 0.0..y_max)?;
        let mut mesh = chart.configure_mesh();
        if labelled {
            mesh.x_desc("time, s");
        } else {
            mesh.disable_x_mesh().disable_y_mesh().x_labels(0).y_labels(0);
        }
        mesh.draw()?;
        chart.draw_series(LineSeries::new(trace.iter().map(|p| (p.t_s, get(p))), color))?;
        if name.starts_with("force") {
            chart.draw_series(LineSeries::new([(0.0, fnom_n), (t_end, fnom_n)], BLACK))?;
        }
    }
    root.present()?;
    Ok(labelled)
}
