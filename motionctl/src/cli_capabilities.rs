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
    /// y_steps, beta_steps, alpha_steps, [contours] top, bottom, thickness_mm, points,
    /// chord_tolerance_mm); the flags below override it.
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
    /// Workpiece thickness ZT, mm [default: the die's; required with --top/--bottom].
    #[arg(long, visible_alias = "thickness", value_name = "MM")]
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
    #[command(flatten)]
    drawing: Box<DrawingArgs>,
}

/// The die from two drawings, and the plot (boxed: they would make every `motionctl` command
/// as large as the wire's).
#[derive(clap::Args, Debug)]
pub struct DrawingArgs {
    /// Top face (Z = ZT) from a drawing: an SVG path or a DXF contour (LWPOLYLINE, LINE, ARC,
    /// CIRCLE, SPLINE), `FILE` or `FILE#ID` (SVG element id, DXF layer). SVG: 1 user unit = 1
    /// mm unless width/height and viewBox say otherwise, the page's centre at the workpiece
    /// centre, y up; DXF: $INSUNITS, the drawing's origin at the workpiece centre. Needs
    /// --bottom and --thickness.
    #[arg(long, value_name = "FILE", requires = "bottom", conflicts_with_all = ["die", "mdi"])]
    top: Option<String>,
    /// Bottom face (Z = 0) from a drawing, as --top.
    #[arg(long, value_name = "FILE", requires = "top")]
    bottom: Option<String>,
    /// --top/--bottom: points per face after resampling by arc length (each face
    /// counter-clockwise from where the ray from its centroid towards +X leaves it) [default:
    /// 120].
    #[arg(long, value_name = "N")]
    points: Option<usize>,
    /// --top/--bottom: largest distance of a flattened chord from the drawn curve, mm [default:
    /// 0.01].
    #[arg(long, value_name = "MM")]
    chord_tol: Option<f64>,
    /// Draw the job: the ruled surface in 3-D (both faces and every few ruling lines), the two
    /// faces from above, and the four axes against time on the host model (.svg or .png).
    #[arg(long, value_name = "FILE.svg|.png")]
    plot: Option<PathBuf>,
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
    /// The job file's path and text, if one was given.
    fn job_text(&self) -> Result<Option<(&std::path::Path, String)>> {
        match &self.job {
            Some(path) => {
                let src = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                Ok(Some((path.as_path(), src)))
            }
            None => Ok(None),
        }
    }

    /// The die to cut: `--top/--bottom` drawings, else the job file's `[contours]`, else
    /// `--mdi FILE`, else `--die NAME` (default circle-complex), with the overrides; for a
    /// contour die also the contours. Errors name the file.
    fn die(&self) -> Result<(crate::wire::dies::DieJob, Option<crate::wire::cad::ContourPair>)> {
        use crate::wire::cad;
        let spec = match self.job_text()? {
            Some((path, src)) => {
                let base = path.parent().unwrap_or(std::path::Path::new("."));
                crate::wire::job_file::parse_contours(&src, base)
                    .with_context(|| path.display().to_string())?
            }
            None => None,
        };
        let drawings = match (self.drawing.top.as_ref().zip(self.drawing.bottom.as_ref()), &spec) {
            (Some((t, b)), _) => Some((t.clone(), b.clone())),
            (None, Some(s)) => Some((s.top.clone(), s.bottom.clone())),
            (None, None) => None,
        };
        if let Some((top, bottom)) = drawings {
            if spec.is_some() && (self.die.is_some() || self.mdi.is_some()) {
                anyhow::bail!("the job file's [contours] and --die/--mdi name two dies: give one");
            }
            let zt = self.zt.or(spec.as_ref().map(|s| s.thickness_mm)).ok_or_else(|| {
                anyhow::anyhow!(
                    "--top/--bottom need the workpiece thickness: --thickness MM (or \
                     thickness_mm in the job file's [contours])"
                )
            })?;
            let points = self
                .drawing
                .points
                .or(spec.as_ref().and_then(|s| s.points))
                .unwrap_or(cad::DEFAULT_POINTS);
            let tol = self
                .drawing
                .chord_tol
                .or(spec.as_ref().and_then(|s| s.chord_tolerance_mm))
                .unwrap_or(cad::DEFAULT_CHORD_TOL_MM);
            cad::check_chord_tol(tol).map_err(|e| anyhow::anyhow!("--chord-tol: {e}"))?;
            let pair = cad::pair(
                cad::read_contour(&top, tol)?,
                cad::read_contour(&bottom, tol)?,
                zt,
                points,
            )?;
            let o = crate::wire::dies::DieOverrides {
                start: self.start,
                module_mm: self.module,
                teeth: self.teeth,
                pitch_diameter_mm: self.pitch_diameter,
                pressure_angle_deg: self.pressure_angle,
                ..Default::default()
            };
            return Ok((crate::wire::dies::contour_die(&pair, &o)?, Some(pair)));
        }
        if self.drawing.points.is_some() || self.drawing.chord_tol.is_some() {
            anyhow::bail!("--points and --chord-tol apply to --top/--bottom drawings only");
        }
        Ok((self.named_die()?, None))
    }

    /// `--mdi FILE`, else `--die NAME` (default circle-complex), with the overrides. Errors
    /// name the file and its line.
    fn named_die(&self) -> Result<crate::wire::dies::DieJob> {
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
        let mut prm = match self.job_text()? {
            Some((path, src)) => crate::wire::job_file::parse_spec_with(&src, defaults)
                .with_context(|| path.display().to_string())?,
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
    // The text report, unless JSON was asked for.
    macro_rules! say {
        ($($t:tt)*) => {
            if !json {
                crate::outln!($($t)*);
            }
        };
    }
    let (die, contours) = plan.die()?;
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
        say!("  only segments       {r:?} of {n}");
    }
    say!("{} die, ZT {} mm, FR {fr} mm^2/min, tolerance {tolerance} mm", die.label, die.die.zt_mm);
    if !json {
        print_die_figures(&die);
        if let Some(c) = &contours {
            print_contour_figures(c);
        }
    }
    let bound = IkBound::of(&job);
    say!("  segments            {}", job.segments.len());
    say!(
        "  ruled area          {:.3} mm^2 (thesis trapezoids {:.3})",
        job.area_ruled_mm2,
        job.area_trapezoid_mm2
    );
    say!("  60 A / FR           {:.3} s", job.time_ruled_s);
    let thesis_time_s = crate::wire::path::time_s(job.area_trapezoid_mm2, fr)?;
    say!(
        "  thesis 60 A / FR    {:.3} s (its trapezoid areas (RB + RT) ZT / 2, not the ruled area)",
        thesis_time_s
    );
    say!(
        "  IK error bound      {:.4} mm: wire off the ruled surface at most (joint-linear {:.4} + \
         step quantisation {:.4}; tolerance {tolerance})",
        bound.total_mm,
        bound.joint_linear_mm,
        bound.quantisation_mm
    );
    // Joint samples of the host model for the plot: about 2000 over the job.
    let stride = if plan.drawing.plot.is_some() {
        ((job.time_ruled_s * cfg.tick_hz as f64 / 2000.0) as u64).max(1)
    } else {
        u64::MAX
    };
    let mut samples: Vec<(u64, [i64; 4])> = Vec::new();
    let report = {
        let mut segs = job.segments.iter().copied();
        motion::model::run(
            &cfg,
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
        .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))?
    };
    let run_model = |segments: &[motion::segment::Segment]| {
        let mut segs = segments.iter().copied();
        motion::model::run(&cfg, || segs.next(), &[], u64::MAX, |_, _| {})
            .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))
    };
    let t = report.ticks as f64 / cfg.tick_hz as f64;
    say!(
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
        say!(
            "  backlash            {:?} steps (X, Y, beta, alpha): {takeups} take-up segments, \
             {:.3} s nominal; +{:.3} s on the host model ({:.3} s without)",
            prm.backlash_steps,
            job.takeup_ticks as f64 / cfg.tick_hz as f64,
            t - bare_s,
            bare_s
        );
    }
    if let Some(p) = &plan.drawing.plot {
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
                (*tick as f64 / cfg.tick_hz as f64, continuous::joints_from_steps(abs))
            })
            .collect();
        let title = format!(
            "wire {}: {} die, ZT {} mm, FR {fr} mm^2/min",
            if matches!(cmd, WireCmd::Run { .. }) { "run" } else { "plan" },
            die.label,
            die.die.zt_mm
        );
        crate::wire::figure::figure(&title, &die.die, &joints).save(p)?;
    }
    if matches!(cmd, WireCmd::Plan { json: true, .. }) {
        let j = plan_json(&die, contours.as_ref(), &job, &prm, &bound, t, thesis_time_s, plan);
        crate::outln!("{}", serde_json::to_string_pretty(&j)?);
    }
    let WireCmd::Run { link, log_csv, plain, stall_at, stall_for, run_json, .. } = cmd else {
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
        return run_wire_job(&parsed, &program, &job.segments, &report, &link, stall, run_json);
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
        },
    )
}

/// How far the wire can be from the designed ruled surface: the planner's largest
/// joint-linear deviation inside a piece plus the step quantisation margin, mm.
struct IkBound {
    joint_linear_mm: f64,
    quantisation_mm: f64,
    total_mm: f64,
}

impl IkBound {
    fn of(job: &continuous::ContinuousJob) -> Self {
        let joint_linear_mm = job.pieces.iter().map(|p| p.deviation_mm).fold(0.0, f64::max);
        IkBound {
            joint_linear_mm,
            quantisation_mm: job.margin_mm,
            total_mm: joint_linear_mm + job.margin_mm,
        }
    }
}

/// Length of the closed polyline through `face` (a die face repeats its first point), mm.
fn face_perimeter_mm(face: &[crate::wire::Point2]) -> f64 {
    crate::wire::cad::perimeter_mm(face)
}

/// The drawn contours: each face's drawing, its flattened and resampled length and area, and
/// how far the resampled polygon cuts the drawn one.
fn print_contour_figures(c: &crate::wire::cad::ContourPair) {
    for (name, contour, r) in [
        ("top drawing", &c.top, &c.top_resampled),
        ("bottom drawing", &c.bottom, &c.bottom_resampled),
    ] {
        crate::outln!(
            "  {name:<19} {}: {} points flattened, perimeter {:.3} mm, area {:.3} mm^2; \
             resampled perimeter {:.3} mm, at most {:.4} mm inside the drawing",
            contour.source,
            contour.points.len(),
            contour.perimeter_mm(),
            contour.area_mm2(),
            crate::wire::cad::perimeter_mm(&r.points),
            r.deviation_mm
        );
    }
}

/// The `wire plan --json` report (mm, mm^2, s, deg).
#[allow(clippy::too_many_arguments)]
fn plan_json(
    die: &crate::wire::dies::DieJob,
    contours: Option<&crate::wire::cad::ContourPair>,
    job: &continuous::ContinuousJob,
    prm: &ContinuousParams,
    bound: &IkBound,
    host_model_s: f64,
    thesis_time_s: f64,
    plan: &WirePlanArgs,
) -> serde_json::Value {
    use crate::wire::area::{polygon_area_mm2, sector_area_mm2};
    use serde_json::json;
    let face =
        |pts: &[crate::wire::Point2],
         drawn: Option<(&crate::wire::cad::Contour, &crate::wire::cad::Resampled)>| {
            let mut f = json!({
                "polygon_area_mm2": polygon_area_mm2(pts),
                "sector_area_mm2": sector_area_mm2(pts),
                "perimeter_mm": face_perimeter_mm(pts),
            });
            if let Some((c, r)) = drawn {
                f["source"] = json!(c.source);
                f["drawn_points"] = json!(c.points.len());
                f["drawn_perimeter_mm"] = json!(c.perimeter_mm());
                f["drawn_area_mm2"] = json!(c.area_mm2());
                f["resampling_deviation_mm"] = json!(r.deviation_mm);
            }
            f
        };
    let (dt, db) = match contours {
        Some(c) => (Some((&c.top, &c.top_resampled)), Some((&c.bottom, &c.bottom_resampled))),
        None => (None, None),
    };
    json!({
        "die": die.label,
        "zt_mm": die.die.zt_mm,
        "fr_mm2_per_min": prm.fr_mm2_per_min,
        "tolerance_mm": prm.tol_mm,
        "points_per_face": die.die.top.len(),
        "start_mm": [die.start.x_mm, die.start.y_mm],
        "top": face(&die.die.top, dt),
        "bottom": face(&die.die.bottom, db),
        "segments": job.segments.len(),
        "ruled_area_mm2": job.area_ruled_mm2,
        "trapezoid_area_mm2": job.area_trapezoid_mm2,
        "cut_time_s": job.time_ruled_s,
        "thesis_time_s": thesis_time_s,
        "host_model_time_s": host_model_s,
        "ik_error_bound_mm": bound.total_mm,
        "ik_joint_linear_mm": bound.joint_linear_mm,
        "ik_quantisation_mm": bound.quantisation_mm,
        "plot": plan.drawing.plot.as_ref().map(|p| p.display().to_string()),
    })
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
    json: bool,
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
    // X, Y in mm, beta and alpha in degrees: the job machine's axes.
    let units = |steps: &[i64]| -> Vec<(String, f64)> {
        parsed
            .machine
            .axes
            .iter()
            .zip(steps)
            .map(|(a, &s)| (a.name.clone(), s as f64 / a.steps_per_mm))
            .collect()
    };
    if json {
        let pos: serde_json::Map<String, serde_json::Value> =
            units(&r.positions).into_iter().map(|(n, v)| (n, serde_json::json!(v))).collect();
        let v = serde_json::json!({
            "ok": r.ok(),
            "segments": r.segments,
            "wall_s": r.seconds,
            "board_s": r.board_ticks as f64 / program.config.tick_hz.max(1) as f64,
            "positions_mm_deg": pos,
            "positions_steps": r.positions,
            "model_positions_steps": r.expected_positions,
            "stalls": r.stalls,
            "retraces": r.retraces,
            "returns": r.returns,
            "max_retrace_steps": r.max_retrace_steps,
            "problems": r.problems,
        });
        crate::outln!("{v}");
        if !r.ok() {
            anyhow::bail!("the wire job failed {} check(s)", r.problems.len());
        }
        return Ok(());
    }
    let shown: Vec<String> = units(&r.positions)
        .iter()
        .zip(&parsed.machine.axes)
        .map(|((n, v), a)| {
            let unit = if a.name.eq_ignore_ascii_case("X") || a.name.eq_ignore_ascii_case("Y") {
                "mm"
            } else {
                "deg"
            };
            format!("{n} {v:.4} {unit}")
        })
        .collect();
    crate::outln!("moved      {} (from the job's start)", shown.join(", "));
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
