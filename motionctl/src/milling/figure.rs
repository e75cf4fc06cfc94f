//! The milling figure: force (with the nominal band), feed and feed override against time,
//! titled with the job, through the shared plot module.

use super::job::MillingJob;
use super::steady;
use crate::plot::{Figure, Panel, Series, Style};

/// One curve's samples: (time s, force N, feed mm/min, override).
pub type Sample = (f64, f64, f64, f64);

/// A trace to draw: its legend name, samples and style.
pub struct Trace<'a> {
    pub label: &'a str,
    pub samples: &'a [Sample],
    pub style: Style,
}

/// Force, feed and override against time for `traces` (e.g. the board and the host model).
pub fn figure(job: &MillingJob, what: &str, traces: &[Trace<'_>]) -> Figure {
    let fnom = job.fnom_n;
    let title = format!("{what}: {}", job.name);
    let force_title = format!(
        "cutting force: Fnom {fnom:.0} N, {} rpm, {} teeth, Kc {} N/mm^2, b {} -> {} mm at {} mm",
        job.spindle_rpm,
        job.teeth,
        job.kc_n_per_mm2,
        job.b_before_mm,
        job.b_after_mm,
        job.step_at_mm
    );
    let series = |t: &Trace<'_>, name: &str, f: fn(&Sample) -> f64| {
        Series::styled(
            format!("{name}, {}", t.label),
            t.samples.iter().map(|s| (s.0, f(s))).collect(),
            t.style,
        )
    };
    let mut force = Panel::new(force_title, "time, s", "force, N").band(
        format!("Fnom {fnom:.0} N +-10 %"),
        0.9 * fnom,
        1.1 * fnom,
    );
    let (_, _, after) = steady::predict(job);
    let mut feed = Panel::new("feed", "time, s", "feed, mm/min")
        .band(
            format!("programmed {:.0} mm/min", job.programmed_feed_mm_min()),
            job.programmed_feed_mm_min(),
            job.programmed_feed_mm_min(),
        )
        .band(
            format!("steady after the step {:.0} mm/min", after.feed_mm_min),
            after.feed_mm_min,
            after.feed_mm_min,
        );
    let mut ovr = Panel::new("feed override", "time, s", "override (1 = programmed feed)");
    for t in traces {
        force = force.with(series(t, "force", |s| s.1));
        feed = feed.with(series(t, "feed", |s| s.2));
        ovr = ovr.with(series(t, "override", |s| s.3));
    }
    Figure::new(title).panel(force).panel(feed).panel(ovr)
}

/// Writes the figure, saying on stderr where (and if it lacks labels).
pub fn write(fig: &Figure, path: &std::path::Path) -> anyhow::Result<()> {
    fig.save(path)
}
