//! `motionctl wire ...`: the wire manipulator's (Bhatti) continuous jobs planned, run through
//! the host model, streamed to the board, and Table 11.

mod board_run;
mod plan_args;
mod report;

pub use board_run::{wire_board_job, WireBoardJob};
pub use plan_args::{DrawingArgs, WirePlanArgs};

use crate::wire::continuous::{self, ContinuousJob, ContinuousParams};
use crate::wire::dies::DieJob;
use anyhow::Result;
use clap::Subcommand;
use report::IkBound;
use std::path::PathBuf;

/// Prints a line of the text report, unless `$json` (a JSON summary keeps stdout for itself).
macro_rules! say {
    ($json:expr, $($t:tt)*) => {
        if !$json {
            crate::outln!($($t)*);
        }
    };
}

#[derive(Subcommand, Debug)]
// Parsed once per process: boxing the link arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum WireCmd {
    /// Plan the circle -> complex die (Bhatti Table 11) as one continuous 4-axis job and run it
    /// through the host model of the firmware.
    Plan {
        #[command(flatten)]
        plan: WirePlanArgs,
        /// The report as JSON (mm, mm^2, s, deg) instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Plan the circle -> complex die and stream it to the board (4 axes: X, Y in mm; beta,
    /// alpha in degrees), checked against the host model at the end.
    Run {
        #[command(flatten)]
        plan: WirePlanArgs,
        #[command(flatten)]
        link: crate::board_link::LinkArgs,
        /// Write every board status report to this CSV file (plain-segment runs only; also
        /// `--log-csv`).
        #[arg(long = "csv", alias = "log-csv", value_name = "FILE")]
        log_csv: Option<PathBuf>,
        /// Run the job as plain segments even on a board with wire jobs (no stall handling).
        #[arg(long)]
        plain: bool,
        /// Only the job's segments FROM..TO (0-based, TO exclusive), e.g. a short QEMU test.
        #[arg(long, value_name = "FROM..TO", value_parser = parse_range)]
        segments: Option<std::ops::Range<usize>>,
        /// With --qemu: close the simulated wire-stall switch this many seconds of machine time
        /// after the start ...
        #[arg(long, value_name = "S", requires = "stall_for")]
        stall_at: Option<f64>,
        /// ... for this many seconds.
        #[arg(long, value_name = "S", requires = "stall_at")]
        stall_for: Option<f64>,
        /// Print the run's summary as one JSON object instead of text (mm, deg, s).
        #[arg(long = "json")]
        run_json: bool,
    },
    /// Bhatti Table 11 (circle -> complex, ZT 39, FR 800) side by side: per row the thesis's IK
    /// values (alpha, beta, trapezoid area, time, totals) and the corrected IK's (ZB1, XB1,
    /// motor steps rounded, ruled area), then the totals.
    Table11 {
        /// CSV (full precision) instead of the aligned table.
        #[arg(long)]
        csv: bool,
    },
}

pub fn parse_range(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s.split_once("..").ok_or("expected FROM..TO")?;
    let a: usize = a.parse().map_err(|e| format!("{e}"))?;
    let b: usize = b.parse().map_err(|e| format!("{e}"))?;
    if a >= b {
        return Err("FROM must be below TO".into());
    }
    Ok(a..b)
}

pub fn run_wire(cmd: WireCmd) -> Result<()> {
    let plan = match &cmd {
        WireCmd::Plan { plan, .. } | WireCmd::Run { plan, .. } => plan,
        WireCmd::Table11 { csv } => {
            use crate::wire::table11;
            let t = table11::table11(&continuous::circle_complex_path()?, 800.0)?;
            let text = if *csv { table11::render_csv(&t) } else { table11::render_text(&t) };
            crate::out!("{text}");
            return Ok(());
        }
    };
    // A JSON summary (plan's, or run's at the end) keeps stdout for itself.
    let json =
        matches!(cmd, WireCmd::Plan { json: true, .. } | WireCmd::Run { run_json: true, .. });
    let (die, contours) = plan.die()?;
    let prm = plan.params(die.fr_mm2_per_min)?;
    let path = die.path()?;
    let cfg = motion::wire::machine::config();
    let mut job = continuous::plan(&path, &cfg, &prm)?;
    if let WireCmd::Run { segments: Some(r), .. } = &cmd {
        only_segments(&mut job, r, json)?;
    }
    let bound = IkBound::of(&job);
    let thesis_time_s = print_plan(&die, contours.as_ref(), &job, &prm, &bound, json)?;
    let (report, samples) = host_model(&cfg, &job, plan.drawing.plot.is_some())?;
    let t = report.ticks as f64 / cfg.tick_hz as f64;
    say!(
        json,
        "  host model          {t:.3} s ({:+.0} ppm), {} segments, final steps {:?}",
        (t / job.time_ruled_s - 1.0) * 1e6,
        report.segments,
        &report.positions[..4]
    );
    if prm.backlash_steps != [0; 4] {
        print_backlash(&path, &cfg, &prm, &job, t, json)?;
    }
    if let Some(p) = &plan.drawing.plot {
        let verb = if matches!(cmd, WireCmd::Run { .. }) { "run" } else { "plan" };
        let title = format!(
            "wire {verb}: {} die, ZT {} mm, FR {} mm^2/min",
            die.label, die.die.zt_mm, prm.fr_mm2_per_min
        );
        plot(p, &title, &die, &job, &report, &samples, cfg.tick_hz)?;
    }
    if matches!(cmd, WireCmd::Plan { json: true, .. }) {
        let j =
            report::plan_json(&die, contours.as_ref(), &job, &prm, &bound, t, thesis_time_s, plan);
        crate::outln!("{}", serde_json::to_string_pretty(&j)?);
    }
    run_on_board(cmd, &die, &job, &report, cfg)
}

/// `--segments FROM..TO`: only that part of the job, starting and ending at rest.
fn only_segments(job: &mut ContinuousJob, r: &std::ops::Range<usize>, json: bool) -> Result<()> {
    let n = job.segments.len();
    let mut part = job
        .segments
        .get(r.clone())
        .ok_or_else(|| anyhow::anyhow!("--segments {r:?} outside the job's {n} segments"))?
        .to_vec();
    // A part of the job ends at rest like the whole one.
    if let Some(last) = part.last_mut() {
        last.exit_rate = motion::segment::Rate::ZERO;
    }
    if let Some(first) = part.first_mut() {
        first.entry_rate = motion::segment::Rate::ZERO;
    }
    job.segments = part;
    say!(json, "  only segments       {r:?} of {n}");
    Ok(())
}

/// The plan's text report: the die, the drawings, the job's segments, areas, times and IK
/// error bound. Returns the thesis's time for the job (its trapezoid areas), s.
fn print_plan(
    die: &DieJob,
    contours: Option<&crate::wire::cad::ContourPair>,
    job: &ContinuousJob,
    prm: &ContinuousParams,
    bound: &IkBound,
    json: bool,
) -> Result<f64> {
    let (fr, tolerance) = (prm.fr_mm2_per_min, prm.tol_mm);
    say!(
        json,
        "{} die, ZT {} mm, FR {fr} mm^2/min, tolerance {tolerance} mm",
        die.label,
        die.die.zt_mm
    );
    if !json {
        report::print_die_figures(die);
        if let Some(c) = contours {
            report::print_contour_figures(c);
        }
    }
    say!(json, "  segments            {}", job.segments.len());
    say!(
        json,
        "  ruled area          {:.3} mm^2 (thesis trapezoids {:.3})",
        job.area_ruled_mm2,
        job.area_trapezoid_mm2
    );
    say!(json, "  60 A / FR           {:.3} s", job.time_ruled_s);
    let thesis_time_s = crate::wire::path::time_s(job.area_trapezoid_mm2, fr)?;
    say!(
        json,
        "  thesis 60 A / FR    {:.3} s (its trapezoid areas (RB + RT) ZT / 2, not the ruled area)",
        thesis_time_s
    );
    say!(
        json,
        "  IK error bound      {:.4} mm: wire off the ruled surface at most (joint-linear {:.4} + \
         step quantisation {:.4}; tolerance {tolerance})",
        bound.total_mm,
        bound.joint_linear_mm,
        bound.quantisation_mm
    );
    Ok(thesis_time_s)
}

/// Joint samples of the host model for a plot.
type Samples = Vec<(u64, [i64; 4])>;

/// The job on the host model of the firmware, with joint samples for the plot when `plot`:
/// about 2000 over the job.
fn host_model(
    cfg: &motion::MachineConfig,
    job: &ContinuousJob,
    plot: bool,
) -> Result<(motion::report::Report, Samples)> {
    let stride = if plot {
        ((job.time_ruled_s * cfg.tick_hz as f64 / 2000.0) as u64).max(1)
    } else {
        u64::MAX
    };
    let mut samples: Samples = Vec::new();
    let mut segs = job.segments.iter().copied();
    let report = motion::model::run(
        cfg,
        || segs.next(),
        &[],
        u64::MAX,
        |dda, _| {
            if dda.now() % stride == 0 {
                let p = dda.positions();
                samples.push((dda.now(), [p[0], p[1], p[2], p[3]]));
            }
        },
    )
    .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))?;
    Ok((report, samples))
}

/// The backlash take-ups: how many, and what they cost in machine time (the same job planned
/// without compensation, on the host model).
fn print_backlash(
    path: &crate::wire::path::Path,
    cfg: &motion::MachineConfig,
    prm: &ContinuousParams,
    job: &ContinuousJob,
    t: f64,
    json: bool,
) -> Result<()> {
    let takeups =
        job.kinds.iter().filter(|k| **k == crate::wire::backlash::SegmentKind::TakeUp).count();
    let bare = continuous::plan(path, cfg, &ContinuousParams { backlash_steps: [0; 4], ..*prm })?;
    let mut segs = bare.segments.iter().copied();
    let bare_ticks = motion::model::run(cfg, || segs.next(), &[], u64::MAX, |_, _| {})
        .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))?
        .ticks;
    let bare_s = bare_ticks as f64 / cfg.tick_hz as f64;
    say!(
        json,
        "  backlash            {:?} steps (X, Y, beta, alpha): {takeups} take-up segments, \
         {:.3} s nominal; +{:.3} s on the host model ({:.3} s without)",
        prm.backlash_steps,
        job.takeup_ticks as f64 / cfg.tick_hz as f64,
        t - bare_s,
        bare_s
    );
    Ok(())
}

/// Draws the job to `p`: the die and the joints of the host model's samples and its end.
fn plot(
    p: &std::path::Path,
    title: &str,
    die: &DieJob,
    job: &ContinuousJob,
    report: &motion::report::Report,
    samples: &Samples,
    tick_hz: u32,
) -> Result<()> {
    let origin = job.point_steps.first().copied().unwrap_or([0; 4]);
    let joints: Vec<(f64, crate::wire::ik::Joints)> = samples
        .iter()
        .chain(std::iter::once(&(report.ticks, {
            let mut f = [0i64; 4];
            f.copy_from_slice(&report.positions[..4]);
            f
        })))
        .map(|(tick, s)| {
            let abs = [s[0] + origin[0], s[1] + origin[1], s[2] + origin[2], s[3] + origin[3]];
            (*tick as f64 / tick_hz as f64, continuous::joints_from_steps(abs))
        })
        .collect();
    crate::wire::figure::figure(title, &die.die, &joints).save(p)?;
    Ok(())
}

/// `wire run`: the job on the board link, as a wire job (stall retrace on the board) or, with
/// `--plain` or on the in-process sim board, as plain segments. Nothing for `wire plan`.
fn run_on_board(
    cmd: WireCmd,
    die: &DieJob,
    job: &ContinuousJob,
    report: &motion::report::Report,
    cfg: motion::MachineConfig,
) -> Result<()> {
    let WireCmd::Run { link, log_csv, plain, stall_at, stall_for, run_json, .. } = cmd else {
        return Ok(());
    };
    let (parsed, program) = board_run::board_machine(job, report, cfg);
    let final_steps = program.final_steps;
    // Every board link gets the wire mode (stall retrace on the board) unless asked for plain
    // segments; the in-process sim board has no wire jobs.
    if !plain && !link.sim {
        let stall = stall_at.zip(stall_for).map(|(at, len)| crate::wire::run::SimStall {
            at_ticks: (at * cfg.tick_hz as f64).round() as u64,
            for_ticks: (len * cfg.tick_hz as f64).round() as u64,
        });
        return board_run::run_wire_job(
            &parsed,
            &program,
            &job.segments,
            report,
            &link,
            stall,
            run_json,
        );
    }
    let outputs: Vec<crate::plan::Output> =
        job.segments.iter().map(|s| crate::plan::Output::Segment(*s)).collect();
    crate::board_link::stream(
        &format!("{} (wire)", die.label),
        &parsed,
        &program,
        &outputs,
        &final_steps,
        &link,
        crate::board_link::Reporting {
            log_csv: log_csv.as_deref(),
            yes: true,
            status_ms: crate::runner::DEFAULT_STATUS_PERIOD_MS,
            json: run_json,
            journal: None,
            sim_probe: None,
        },
    )
}
