//! The thesis capabilities' subcommands: `motionctl wire ...` (Bhatti continuous jobs) here;
//! `motionctl polar ...` lives in [`crate::polar::cli`], `fourier ...` in
//! [`crate::fourier::cli`], `milling ...` in [`crate::milling::cli`].

pub use crate::fourier::cli::{run_fourier, FourierCmd};
pub use crate::milling::cli::{run_milling, MillingCmd};
use crate::wire::continuous::{self, ContinuousParams};
use anyhow::{Context, Result};
use clap::Subcommand;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct WirePlanArgs {
    /// Wire job file (TOML, version 1: fr_mm2_per_min, tolerance_mm, [backlash] x_steps,
    /// y_steps, beta_steps, alpha_steps); the flags below override it.
    #[arg(long, value_name = "FILE")]
    job: Option<PathBuf>,
    /// Area rate, mm^2/min [default: 800].
    #[arg(long)]
    fr: Option<f64>,
    /// Largest horizontal distance of the wire from the designed ruling line, mm [default: 0.01].
    #[arg(long)]
    tolerance: Option<f64>,
    /// Lash per axis in motor steps, in the wire segments' axis order X,Y,B,A (X, Y, beta,
    /// alpha), e.g. 20,20,250,0: taken up by its own segment at every reversal [default: 0].
    #[arg(long, value_name = "X,Y,B,A", value_parser = parse_backlash)]
    backlash: Option<[u32; 4]>,
    /// Die to cut, one of the thesis's (with its ZT, FR and start point) [default:
    /// circle-complex, plate 4 / Table 11].
    #[arg(long, value_enum, value_name = "NAME")]
    die: Option<crate::wire::dies::ThesisDie>,
    /// A user die from an MDI data file: ZT, N, then N x (XB, YB, XT, YT), numbers separated
    /// by commas or blanks, `#` comment lines; cut from and back to the centre at FR 800.
    #[arg(long, value_name = "FILE", conflicts_with = "die")]
    mdi: Option<PathBuf>,
    /// Workpiece thickness ZT, mm [default: the die's].
    #[arg(long, value_name = "MM")]
    zt: Option<f64>,
    /// Start and end point of the wire on the workpiece, mm [default: the die's: (0, 0), the
    /// gear (0, -60)]; the board's positions count from there.
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    start: Option<crate::wire::Point2>,
    /// --die gear: module, mm [default: 6].
    #[arg(long, value_name = "MM")]
    module: Option<f64>,
    /// --die gear: number of teeth [default: 12, PD = module x teeth].
    #[arg(long, conflicts_with = "pitch_diameter")]
    teeth: Option<u32>,
    /// --die gear: pitch circle diameter, mm [default: 72].
    #[arg(long, value_name = "MM")]
    pitch_diameter: Option<f64>,
    /// --die gear: pressure angle, deg [default: 20].
    #[arg(long, value_name = "DEG")]
    pressure_angle: Option<f64>,
}

/// `--start X,Y`: two numbers, mm.
fn parse_point(s: &str) -> Result<crate::wire::Point2, String> {
    let (x, y) = s.split_once(',').ok_or("expected X,Y (mm)")?;
    let num = |t: &str| match t.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{t}` is not a finite number")),
    };
    Ok(crate::wire::Point2::new(num(x)?, num(y)?))
}

/// `--backlash X,Y,B,A`: four integers, each checked as a job file's `[backlash]` field is.
fn parse_backlash(s: &str) -> Result<[u32; 4], String> {
    let v = s
        .split(',')
        .map(|t| t.trim().parse::<i64>().map_err(|e| format!("`{t}`: {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let steps: [i64; 4] =
        v.try_into().map_err(|v: Vec<i64>| format!("{} values, want 4 (X,Y,B,A)", v.len()))?;
    crate::wire::backlash::validate(steps, ["backlash X", "backlash Y", "backlash B", "backlash A"])
        .map_err(|e| e.to_string())
}

impl WirePlanArgs {
    /// The die to cut: `--mdi FILE`, else `--die NAME` (default circle-complex), with the
    /// overrides. Errors name the file and its line.
    fn die(&self) -> Result<crate::wire::dies::DieJob> {
        use crate::wire::dies;
        let o = dies::DieOverrides {
            zt_mm: self.zt,
            start: self.start,
            module_mm: self.module,
            teeth: self.teeth,
            pitch_diameter_mm: self.pitch_diameter,
            pressure_angle_deg: self.pressure_angle,
        };
        match &self.mdi {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                dies::mdi_die(&path.display().to_string(), &text, &o)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
            }
            None => {
                let kind = self.die.unwrap_or(crate::wire::dies::ThesisDie::CircleComplex);
                Ok(dies::thesis_die(kind, &o)?)
            }
        }
    }

    /// The planning parameters: the die's feed, the job file's settings, then the flags.
    fn params(&self, die_fr_mm2_per_min: f64) -> Result<ContinuousParams> {
        let defaults =
            ContinuousParams { fr_mm2_per_min: die_fr_mm2_per_min, ..ContinuousParams::default() };
        let mut prm = match &self.job {
            Some(path) => {
                let src = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                crate::wire::job_file::parse_spec_with(&src, defaults)
                    .with_context(|| path.display().to_string())?
            }
            None => defaults,
        };
        prm.fr_mm2_per_min = self.fr.unwrap_or(prm.fr_mm2_per_min);
        prm.tol_mm = self.tolerance.unwrap_or(prm.tol_mm);
        prm.backlash_steps = self.backlash.unwrap_or(prm.backlash_steps);
        Ok(prm)
    }
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
    },
    /// Plan the circle -> complex die and stream it to the board (4 axes: X, Y in mm; beta,
    /// alpha in degrees), checked against the host model at the end.
    Run {
        #[command(flatten)]
        plan: WirePlanArgs,
        #[command(flatten)]
        link: crate::board_link::LinkArgs,
        /// Write every board status report to this CSV file (plain-segment runs only).
        #[arg(long, value_name = "FILE")]
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

fn parse_range(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s.split_once("..").ok_or("expected FROM..TO")?;
    let a: usize = a.parse().map_err(|e| format!("{e}"))?;
    let b: usize = b.parse().map_err(|e| format!("{e}"))?;
    if a >= b {
        return Err("FROM must be below TO".into());
    }
    Ok(a..b)
}

/// The wire manipulator as a job's machine: the DDA's axes 0..3 with their step scales
/// (src/wire/machine.rs); rotary axes in degrees. Soft limits from the thesis's travel, counted
/// from the job's start `origin` (X, Y mm, beta, alpha deg: the joints of the path's first
/// point, where the board's positions are zero).
fn wire_job_machine(cfg: &motion::MachineConfig, origin: [f64; 4]) -> crate::job::Job {
    use crate::wire::ik::{STEPS_PER_DEG_ALPHA, STEPS_PER_DEG_BETA, STEPS_PER_MM_XY};
    use motion::wire::machine as m;
    let axis = |name: &str, steps_per_unit: f64, min: f64, max: f64| crate::job::Axis {
        name: name.into(),
        steps_per_mm: steps_per_unit,
        max_rate_mm_s: m::MAX_RATE_HZ as f64 / steps_per_unit,
        accel_mm_s2: m::ACCEL_STEPS_PER_S2 as f64 / steps_per_unit,
        junction_jerk_mm_s: m::JUNCTION_JERK_HZ as f64 / steps_per_unit,
        min_mm: min,
        max_mm: max,
    };
    crate::job::Job {
        machine: crate::job::Machine {
            tick_hz: cfg.tick_hz,
            timing: cfg.timing,
            axes: vec![
                axis("X", STEPS_PER_MM_XY, -50.0 - origin[0], 50.0 - origin[0]),
                axis("Y", STEPS_PER_MM_XY, -60.0 - origin[1], 60.0 - origin[1]),
                axis("B", STEPS_PER_DEG_BETA, -65.0 - origin[2], 65.0 - origin[2]),
                axis("A", STEPS_PER_DEG_ALPHA, -70.0 - origin[3], 70.0 - origin[3]),
            ],
            switch_debounce_ms: crate::job::DEFAULT_SWITCH_DEBOUNCE_MS,
            arc_tolerance_mm: crate::job::DEFAULT_ARC_TOLERANCE_MM,
        },
        items: Vec::new(),
        feed_commands: Vec::new(),
    }
}

pub fn run_wire(cmd: WireCmd) -> Result<()> {
    let plan = match &cmd {
        WireCmd::Plan { plan } | WireCmd::Run { plan, .. } => plan,
        WireCmd::Table11 { csv } => {
            use crate::wire::table11;
            let t = table11::table11(&continuous::circle_complex_path()?, 800.0)?;
            let text = if *csv { table11::render_csv(&t) } else { table11::render_text(&t) };
            crate::out!("{text}");
            return Ok(());
        }
    };
    let die = plan.die()?;
    let prm = plan.params(die.fr_mm2_per_min)?;
    let (fr, tolerance) = (prm.fr_mm2_per_min, prm.tol_mm);
    let path = die.path()?;
    let cfg = motion::wire::machine::config();
    let mut job = continuous::plan(&path, &cfg, &prm)?;
    if let WireCmd::Run { segments: Some(r), .. } = &cmd {
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
        crate::outln!("  only segments       {r:?} of {n}");
    }
    crate::outln!(
        "{} die, ZT {} mm, FR {fr} mm^2/min, tolerance {tolerance} mm",
        die.label,
        die.die.zt_mm
    );
    print_die_figures(&die);
    crate::outln!("  segments            {}", job.segments.len());
    crate::outln!(
        "  ruled area          {:.3} mm^2 (thesis trapezoids {:.3})",
        job.area_ruled_mm2,
        job.area_trapezoid_mm2
    );
    crate::outln!("  60 A / FR           {:.3} s", job.time_ruled_s);
    crate::outln!(
        "  thesis 60 A / FR    {:.3} s (its trapezoid areas (RB + RT) ZT / 2, not the ruled area)",
        crate::wire::path::time_s(job.area_trapezoid_mm2, fr)?
    );
    let run_model = |segments: &[motion::segment::Segment]| {
        let mut segs = segments.iter().copied();
        motion::model::run(&cfg, || segs.next(), &[], u64::MAX, |_, _| {})
            .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))
    };
    let report = run_model(&job.segments)?;
    let t = report.ticks as f64 / cfg.tick_hz as f64;
    crate::outln!(
        "  host model          {t:.3} s ({:+.0} ppm), {} segments, final steps {:?}",
        (t / job.time_ruled_s - 1.0) * 1e6,
        report.segments,
        &report.positions[..4]
    );
    if prm.backlash_steps != [0; 4] {
        let takeups =
            job.kinds.iter().filter(|k| **k == crate::wire::backlash::SegmentKind::TakeUp).count();
        // The same job without compensation, for what the take-ups cost in machine time.
        let bare =
            continuous::plan(&path, &cfg, &ContinuousParams { backlash_steps: [0; 4], ..prm })?;
        let bare_s = run_model(&bare.segments)?.ticks as f64 / cfg.tick_hz as f64;
        crate::outln!(
            "  backlash            {:?} steps (X, Y, beta, alpha): {takeups} take-up segments, \
             {:.3} s nominal; +{:.3} s on the host model ({:.3} s without)",
            prm.backlash_steps,
            job.takeup_ticks as f64 / cfg.tick_hz as f64,
            t - bare_s,
            bare_s
        );
    }
    let WireCmd::Run { link, log_csv, plain, stall_at, stall_for, .. } = cmd else {
        return Ok(());
    };
    let origin = continuous::joints_from_steps(job.point_steps[0]);
    let parsed = wire_job_machine(
        &cfg,
        [origin.x_mm, origin.y_mm, origin.beta_rad.to_degrees(), origin.alpha_rad.to_degrees()],
    );
    let mut final_steps = [0i64; motion::MAX_AXES];
    final_steps.copy_from_slice(&report.positions[..motion::MAX_AXES]);
    let program = crate::convert::Program {
        config: cfg,
        steps_per_mm: parsed.machine.axes.iter().map(|a| a.steps_per_mm).collect(),
        items: Vec::new(),
        commands: Vec::new(),
        final_steps,
        skipped_moves: 0,
    };
    // Every board link gets the wire mode (stall retrace on the board) unless asked for plain
    // segments; the in-process sim board has no wire jobs.
    if !plain && !link.sim {
        let stall = stall_at.zip(stall_for).map(|(at, len)| crate::wire::run::SimStall {
            at_ticks: (at * cfg.tick_hz as f64).round() as u64,
            for_ticks: (len * cfg.tick_hz as f64).round() as u64,
        });
        return run_wire_job(&parsed, &program, &job.segments, &report, &link, stall);
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
        log_csv.as_deref(),
        true,
        crate::runner::DEFAULT_STATUS_PERIOD_MS,
    )
}

/// The die's points, start and face areas (the thesis's sector method and the exact polygon).
fn print_die_figures(die: &crate::wire::dies::DieJob) {
    use crate::wire::area::{polygon_area_mm2, sector_area_mm2};
    let (s, d) = (die.start, &die.die);
    crate::outln!(
        "  points              {} per face, from and back to ({}, {}) mm",
        d.top.len(),
        s.x_mm,
        s.y_mm
    );
    for (name, face) in [("top face", &d.top), ("bottom face", &d.bottom)] {
        crate::outln!(
            "  {name:<19} sector area {:.3} mm^2, polygon {:.3} mm^2",
            sector_area_mm2(face),
            polygon_area_mm2(face)
        );
    }
}

/// `wire run` on a board link: the job as a wire job (stall retrace on the board), checked
/// against the host model.
fn run_wire_job(
    parsed: &crate::job::Job,
    program: &crate::convert::Program,
    segments: &[motion::segment::Segment],
    model: &motion::report::Report,
    link: &crate::board_link::LinkArgs,
    stall: Option<crate::wire::run::SimStall>,
) -> Result<()> {
    use motion::wire::scenario::STALL_PARAMS as P;
    let (mut t, qemu_guard) = link.open()?;
    let opts = crate::wire::run::WireRunOptions {
        params: motion::protocol::WireJobParams {
            debounce_ticks: P.debounce_ticks,
            retrace_limit_steps: P.retrace_limit_steps,
            retrace_override_bits: P.retrace_override.to_bits(),
            resume_override_bits: P.resume_override.to_bits(),
            resume_segments: P.resume_segments,
            segments: segments.len() as u32,
        },
        host: motion::protocol::HostConfig { rto_ms: 100, window: 8 },
        // QEMU's machine has no switches: homing there takes it where it stands.
        home: link.home || link.qemu,
        progress: true,
        stall,
        slack: crate::wire::run::SLACK,
    };
    let mut expected = [0i64; 4];
    expected.copy_from_slice(&model.positions[..4]);
    let cfg = crate::runner::wire_config(parsed, program);
    let result = crate::wire::run::run(&mut *t, cfg, segments, expected, model.ticks, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    crate::outln!(
        "wire job   {} segments, {:.2} s wall, {} board ticks",
        r.segments,
        r.seconds,
        r.board_ticks
    );
    crate::outln!("positions  {:?} steps; host model {:?}", r.positions, r.expected_positions);
    crate::outln!(
        "stall      {} stalls, {} retrace and {} return segments, largest retrace {} steps",
        r.stalls,
        r.retraces,
        r.returns,
        r.max_retrace_steps
    );
    // One machine-readable line for scripts (xtask wire-e2e).
    crate::outln!(
        "wire-summary x={} y={} beta={} alpha={} stalls={} retraces={} returns={} \
         max_retrace_steps={} board_ticks={} segments={}",
        r.positions[0],
        r.positions[1],
        r.positions[2],
        r.positions[3],
        r.stalls,
        r.retraces,
        r.returns,
        r.max_retrace_steps,
        r.board_ticks,
        r.segments
    );
    if !r.ok() {
        for p in &r.problems {
            eprintln!("motionctl: {p}");
        }
        anyhow::bail!("the wire job failed {} check(s)", r.problems.len());
    }
    crate::outln!("result     OK");
    Ok(())
}
