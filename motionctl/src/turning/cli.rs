//! `motionctl turning ...`: the Z-slide coefficient table of the user's part (`table`) and a
//! turning job on the board (`run`).

use super::figure::table_figure;
use super::firmware_table;
use super::forex4::fortran_f;
use super::part::{self, Built, Grid, Mode, Paraboloid, Part};
use super::profile;
use super::run::{self as zrun, ZOutput, ZRunOptions};
use super::table_file::ZTable;
use super::units::Units;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
// Parsed once per process: boxing the link arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum TurningCmd {
    /// The Z-slide coefficient table of a part: an off-axis paraboloid of any focal length,
    /// offset and tool-nose radius (the thesis's by default), or a non-round profile
    /// (--profile); printed, and written for `turning run` and the board (--out, --csv).
    Table(TableArgs),
    /// Run a Z-slide turning job on a board (CAP_TURNING_JOB): upload the table, feed X while
    /// the board computes Z from the spindle angle, and check the result against the host model.
    Run(TurningRunArgs),
}

/// `motionctl turning table`.
#[derive(Args, Debug)]
pub struct TableArgs {
    /// `thesis`: FOREX4's numerical method (Appendix B-1) for any constants; with the defaults
    /// it prints Table 2-2 digit for digit. `accurate`: exact constants, the converged
    /// tool-nose envelope, a 1440-sample DFT.
    #[arg(long, value_enum, default_value_t = Mode::Accurate)]
    pub mode: Mode,
    /// Unit of every length given and printed.
    #[arg(long, value_enum, default_value_t = Units::In)]
    pub units: Units,
    /// Focal length p of the paraboloid z = (x^2 + y^2) / 4p [default: 79.15 in, the thesis's
    /// part; --mode thesis: 79.175 in, the listing's C = 316.7].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub focal_length: Option<f64>,
    /// Offset of the sector's centre from the paraboloid's axis (S_y) [default: 28 in].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub offset: Option<f64>,
    /// Tool-nose radius (0: a sharp tool) [default: 0.125 in].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub nose_radius: Option<f64>,
    /// Last X of the table: the sector radius (paraboloid) or the length (profile)
    /// [default: 8 in].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub x_max: Option<f64>,
    /// Row spacing in X; --x-max must be a whole number of it, at most 96 rows
    /// [default: 0.1 in].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub x_step: Option<f64>,
    /// Harmonic form of order K (1..=8: Z = a0 + sum ak cos k phi + bk sin k phi) instead of
    /// the power form C00..C03 [default: the power form for the paraboloid, 8 for a profile].
    #[arg(long, value_name = "K")]
    pub harmonics: Option<u8>,
    /// A non-round part instead of the paraboloid: an ellipse (.toml: [ellipse] semi_axis_x,
    /// semi_axis_y, centre_x, centre_y, optional *_end and units) or cam points r(theta)
    /// (.csv: theta_deg, r per line).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["focal_length", "offset", "nose_radius"])]
    pub profile: Option<PathBuf>,
    /// Write the table file (what `turning run --table` takes) here; stdout then has the
    /// summary only.
    #[arg(long, short = 'o', value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write the table as CSV here (also readable by `turning run --table`).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Plot the Z command over a revolution at four X stations and the part error along X
    /// (.svg or .png).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Print the summary as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the checked-in firmware table's Rust source (src/turning/douglass_table.rs; the
    /// thesis's part in accurate mode only).
    #[arg(long, value_name = "FILE")]
    pub firmware_rust: Option<PathBuf>,
}

/// `motionctl turning run`.
#[derive(Args, Debug)]
pub struct TurningRunArgs {
    #[command(flatten)]
    pub link: crate::board_link::LinkArgs,
    /// Spindle speed, rpm (QEMU: the simulated spindle's; a real spindle must turn at it).
    #[arg(long, default_value_t = 360.0, allow_negative_numbers = true)]
    pub rpm: f64,
    /// Table file, as `turning table --out` (or --csv) writes it, in inches or mm
    /// [default: the built-in thesis table, accurate mode].
    #[arg(long, value_name = "FILE")]
    pub table: Option<PathBuf>,
    /// Unit of --x-start, --x-end, --blend (and --feed per second) and of the printed figures.
    #[arg(long, value_enum, default_value_t = Units::In)]
    pub units: Units,
    /// X feed: from --x-start to --x-end at --feed per second; the disengage blends over the
    /// last --blend [defaults: 0, 0.5 in, 1 in/s, 0.1 in].
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub x_start: Option<f64>,
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub x_end: Option<f64>,
    #[arg(long, value_name = "LEN_PER_S", allow_negative_numbers = true)]
    pub feed: Option<f64>,
    #[arg(long, value_name = "LEN", allow_negative_numbers = true)]
    pub blend: Option<f64>,
    /// A spindle speed step at this many seconds of board time after the start (QEMU only).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub speed_step_at: Option<f64>,
    /// The step's size, percent.
    #[arg(
        long,
        value_name = "PCT",
        default_value_t = 20.0,
        requires = "speed_step_at",
        allow_negative_numbers = true
    )]
    pub speed_step_pct: f64,
    /// Z output: the Z axis's step/dir or the DAC.
    #[arg(long, value_enum, default_value_t = ZOutputArg::Steps)]
    pub output: ZOutputArg,
    /// The board's tick rate for the job, Hz (the generator updates every 1, 2 or 4 ticks, at
    /// 20 kHz or more) [default: the Douglass scenario's 50 000].
    #[arg(long, value_name = "HZ")]
    pub tick_hz: Option<u32>,
    /// Print the summary as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ZOutputArg {
    Steps,
    Dac,
}

pub fn run_turning(cmd: TurningCmd) -> Result<()> {
    match cmd {
        TurningCmd::Table(args) => turning_table(&args),
        TurningCmd::Run(args) => turning_run(&args),
    }
}

/// A length flag, checked: finite and within `lo_in..=hi_in` (`lo_open`: `lo` excluded), in the
/// user's units; the value in inches (`default_in` when the flag is absent).
fn length(
    flag: &str,
    value: Option<f64>,
    default_in: f64,
    units: Units,
    (lo_in, lo_open): (f64, bool),
    hi_in: f64,
) -> Result<f64> {
    let Some(v) = value else { return Ok(default_in) };
    let v_in = units.to_in(v);
    let low_ok = if lo_open { v_in > lo_in } else { v_in >= lo_in };
    if !(v.is_finite() && low_ok && v_in <= hi_in) {
        let u = units.name();
        bail!(
            "{flag} must be a finite length within {}{}, {}] {u} (got {v} {u})",
            if lo_open { "(" } else { "[" },
            units.from_in(lo_in),
            units.from_in(hi_in)
        );
    }
    Ok(v_in)
}

/// Largest X of a table (the board's X is inches Q24 in an i32: below 128 in).
const X_MAX_LIMIT_IN: f64 = 100.0;
/// Upper bounds that only catch typing errors.
const FOCAL_LIMIT_IN: f64 = 1e5;
const NOSE_LIMIT_IN: f64 = 10.0;

/// The part and grid the flags describe.
fn request(a: &TableArgs) -> Result<(Part, Grid)> {
    let u = a.units;
    let x_max = length("--x-max", a.x_max, Paraboloid::X_MAX_IN, u, (0.0, true), X_MAX_LIMIT_IN)?;
    let dx = length("--x-step", a.x_step, Paraboloid::X_STEP_IN, u, (0.0, true), x_max)?;
    let grid = Grid { x_max_in: x_max, dx_in: dx };
    let part = match &a.profile {
        Some(path) => Part::Profile(profile::read(path, u)?),
        None => {
            let d = Paraboloid::thesis(a.mode);
            Part::Paraboloid(Paraboloid {
                focal_length_in: length(
                    "--focal-length",
                    a.focal_length,
                    d.focal_length_in,
                    u,
                    (0.0, true),
                    FOCAL_LIMIT_IN,
                )?,
                offset_in: length(
                    "--offset",
                    a.offset,
                    d.offset_in,
                    u,
                    (0.0, true),
                    FOCAL_LIMIT_IN,
                )?,
                nose_radius_in: length(
                    "--nose-radius",
                    a.nose_radius,
                    d.nose_radius_in,
                    u,
                    (0.0, false),
                    NOSE_LIMIT_IN,
                )?,
            })
        }
    };
    Ok((part, grid))
}

/// A figure title: the part in a few words and the mode.
fn title(part: &Part, mode: Mode, units: Units) -> String {
    let f = |v: f64| format!("{} {}", (units.from_in(v) * 1e4).round() / 1e4, units.name());
    let what = match part {
        Part::Paraboloid(p) => format!(
            "paraboloid p = {}, S_y = {}, nose {}",
            f(p.focal_length_in),
            f(p.offset_in),
            f(p.nose_radius_in)
        ),
        Part::Profile(profile::Profile::Ellipse(e)) => {
            format!("ellipse {} x {}", f(e.start_in.0), f(e.start_in.1))
        }
        Part::Profile(profile::Profile::Cam(_)) => "cam profile".to_string(),
    };
    let mode = match mode {
        Mode::Thesis => "thesis mode",
        Mode::Accurate => "accurate mode",
    };
    format!("Z table: {what} ({mode})")
}

fn describe(part: &Part, units: Units) -> (&'static str, String) {
    let f = |v: f64| format!("{:.4} {}", units.from_in(v), units.name());
    match part {
        Part::Paraboloid(p) => (
            "paraboloid",
            format!(
                "off-axis paraboloid, focal length {}, offset {}, tool-nose radius {}",
                f(p.focal_length_in),
                f(p.offset_in),
                f(p.nose_radius_in)
            ),
        ),
        Part::Profile(pr) => (
            match pr {
                profile::Profile::Ellipse(_) => "ellipse",
                profile::Profile::Cam(_) => "cam",
            },
            pr.describe(units),
        ),
    }
}

/// Points per grid cell and spindle angles of the part-error scan.
const ERROR_POINTS_PER_CELL: usize = 8;
const ERROR_PHI_SAMPLES: usize = 360;

fn turning_table(a: &TableArgs) -> Result<()> {
    let (part, grid) = request(a)?;
    let built = part::build(&part, a.mode, grid, a.harmonics)?;
    let u = a.units;
    let (kind, description) = describe(&part, u);
    let error = part::part_error(&built, ERROR_POINTS_PER_CELL, ERROR_PHI_SAMPLES);
    let (worst_x_in, worst_in) =
        error.iter().fold((0.0, 0.0), |m, p| if p.1 > m.1 { *p } else { m });
    let board = zrun::LinkTableBytes::from_ztable(&built.table).err().map(|e| format!("{e:#}"));
    let t = &built.table;
    let un = u.name();
    let gross = built
        .gross_in
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let comments = vec![
        format!("motionctl turning table: {description}"),
        format!("mode {}; {}", built.method, t.form.describe()),
        format!(
            "X 0 .. {:.4} {un} in steps of {:.4} {un}: {} rows",
            u.from_in(grid.x_max_in),
            u.from_in(grid.dx_in),
            t.len()
        ),
        format!(
            "largest neglected harmonics {}; part error (table, cubic between rows, vs the \
             exact command) at most {}, at X = {:.4} {un}",
            u.small(built.max_neglected_in),
            u.small(worst_in),
            u.from_in(worst_x_in)
        ),
        format!(
            "gross path (the other slide's) {:.6} .. {:.6} {un}; largest coefficient {:.6} {un}",
            u.from_in(gross.0),
            u.from_in(gross.1),
            u.from_in(t.largest_coefficient_in())
        ),
        match &board {
            None => format!(
                "board: fits ({} of {} rows, coefficients <= 1/16 in)",
                t.len(),
                super::table_file::MAX_ROWS
            ),
            Some(e) => format!("board: refused: {e}"),
        },
    ];
    // Thesis mode in inches prints as Table 2-2 does (F10.7); otherwise to well below the
    // board's resolution.
    let thesis_print = a.mode == Mode::Thesis && u == Units::In;
    let cd = u.coefficient_decimals();
    let coefficient = move |v: f64| {
        if thesis_print {
            fortran_f(v, 10, 7).trim().to_string()
        } else {
            format!("{v:.cd$}")
        }
    };
    let text = t.render(u, &comments, &coefficient);
    write_outputs(a, &built, &error, &text, &title(&part, a.mode, u))?;
    if a.json {
        let mut j = json!({
            "part": kind,
            "description": description,
            "mode": match a.mode { Mode::Thesis => "thesis", Mode::Accurate => "accurate" },
            "units": un,
            "rows": t.len(),
            "form": match t.form { super::table_file::Form::Power => "power", _ => "harmonic" },
            "harmonic_order": match t.form { super::table_file::Form::Harmonic(k) => Some(k), _ => None },
            "board_ok": board.is_none(),
            "board_error": board,
            "out": a.out.as_ref().map(|p| p.display().to_string()),
            "csv": a.csv.as_ref().map(|p| p.display().to_string()),
            "plot": a.plot.as_ref().map(|p| p.display().to_string()),
        });
        let mut put = |k: String, v_in: f64| j[k] = json!(u.from_in(v_in));
        if let Part::Paraboloid(p) = &part {
            put(format!("focal_length_{un}"), p.focal_length_in);
            put(format!("offset_{un}"), p.offset_in);
            put(format!("nose_radius_{un}"), p.nose_radius_in);
        }
        put(format!("x_max_{un}"), grid.x_max_in);
        put(format!("x_step_{un}"), grid.dx_in);
        put(format!("max_neglected_harmonics_{un}"), built.max_neglected_in);
        put(format!("part_error_max_{un}"), worst_in);
        put(format!("part_error_worst_x_{un}"), worst_x_in);
        put(format!("largest_coefficient_{un}"), t.largest_coefficient_in());
        put(format!("gross_min_{un}"), gross.0);
        put(format!("gross_max_{un}"), gross.1);
        crate::outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if a.out.is_some() {
        for c in &comments {
            crate::outln!("# {c}");
        }
    } else {
        crate::out!("{text}");
    }
    Ok(())
}

fn write_outputs(
    a: &TableArgs,
    built: &Built,
    error: &[(f64, f64)],
    text: &str,
    title: &str,
) -> Result<()> {
    let write = |p: &Path, s: &str| {
        std::fs::write(p, s).with_context(|| format!("writing {}", p.display()))
    };
    if let Some(p) = &a.out {
        write(p, text)?;
        eprintln!("motionctl: wrote {}", p.display());
    }
    if let Some(p) = &a.csv {
        write(p, &built.table.render_csv(a.units))?;
        eprintln!("motionctl: wrote {}", p.display());
    }
    if let Some(p) = &a.plot {
        table_figure(built, error, a.units, title).save(p)?;
    }
    if let Some(p) = &a.firmware_rust {
        let defaults = a.mode == Mode::Accurate
            && a.profile.is_none()
            && a.harmonics.is_none()
            && [a.focal_length, a.offset, a.nose_radius, a.x_max, a.x_step]
                .iter()
                .all(Option::is_none);
        if !defaults {
            bail!(
                "--firmware-rust writes the checked-in thesis table: --mode accurate and the \
                 default part only"
            );
        }
        let acc = firmware_table::douglass_accurate()?;
        let fixed = firmware_table::power_table::<
            { motion::turning::douglass_table::DOUGLASS_ROWS },
        >(&acc.table)?;
        write(p, &firmware_table::render_power_table(&fixed))?;
        eprintln!("motionctl: wrote {}", p.display());
    }
    Ok(())
}

/// The feed flags in inches, checked against each other and the table.
fn run_options(a: &TurningRunArgs, table: Option<&ZTable>) -> Result<ZRunOptions> {
    let d = ZRunOptions::default();
    let u = a.units;
    if !(a.rpm.is_finite() && a.rpm > 0.0 && a.rpm < 100_000.0) {
        bail!("--rpm must be within (0, 100000) rpm (got {} rpm)", a.rpm);
    }
    let big = X_MAX_LIMIT_IN;
    let x_start = length("--x-start", a.x_start, d.x_start_in, u, (0.0, false), big)?;
    let x_end = length("--x-end", a.x_end, d.x_end_in, u, (0.0, true), big)?;
    let feed = length("--feed", a.feed, d.feed_in_per_s, u, (0.0, true), 100.0)?;
    let blend = length("--blend", a.blend, d.blend_in, u, (0.0, false), big)?;
    let un = u.name();
    if x_end <= x_start {
        bail!(
            "--x-end ({} {un}) must be beyond --x-start ({} {un})",
            u.from_in(x_end),
            u.from_in(x_start)
        );
    }
    if blend > x_end - x_start {
        bail!("--blend must be at most the feed's length ({} {un})", u.from_in(x_end - x_start));
    }
    if let Some(t) = table {
        let tol = 1e-9 * t.dx_in;
        if x_start < t.x0_in - tol || x_end > t.last_x_in() + tol {
            bail!(
                "--x-start .. --x-end ({} .. {} {un}) must lie within the table's X {} .. {} {un}",
                u.from_in(x_start),
                u.from_in(x_end),
                u.from_in(t.x0_in),
                u.from_in(t.last_x_in())
            );
        }
    }
    if let Some(at) = a.speed_step_at {
        if !(at.is_finite() && at >= 0.0) {
            bail!("--speed-step-at must be a finite time >= 0 s (got {at} s)");
        }
        if !(a.speed_step_pct.is_finite() && a.speed_step_pct > -90.0 && a.speed_step_pct <= 100.0)
        {
            bail!("--speed-step-pct must be within (-90, 100] % (got {} %)", a.speed_step_pct);
        }
    }
    let tick_hz = a.tick_hz.unwrap_or(d.tick_hz);
    if !(motion::config::MIN_TICK_HZ..=motion::config::MAX_TICK_HZ).contains(&tick_hz) {
        bail!(
            "--tick-hz must be within {} .. {} Hz (got {tick_hz} Hz)",
            motion::config::MIN_TICK_HZ,
            motion::config::MAX_TICK_HZ
        );
    }
    Ok(ZRunOptions {
        tick_hz,
        rpm_milli: (a.rpm * 1000.0).round() as u32,
        x_start_in: x_start,
        x_end_in: x_end,
        feed_in_per_s: feed,
        blend_in: blend,
        output: match a.output {
            ZOutputArg::Steps => ZOutput::Steps,
            ZOutputArg::Dac => ZOutput::Dac,
        },
        speed_step: a.speed_step_at.map(|at| (at, a.speed_step_pct / 100.0)),
        // QEMU's machine has no switches: homing there takes it where it stands.
        home: a.link.home || a.link.qemu || a.link.sim,
        progress: !a.json,
        ..d
    })
}

/// `--table`'s table, else the built-in one.
fn table_of(a: &TurningRunArgs) -> Result<(Option<ZTable>, zrun::LinkTableBytes)> {
    Ok(match &a.table {
        Some(p) => {
            let (t, w) = zrun::read_table(p)?;
            (Some(t), w)
        }
        None => (None, zrun::LinkTableBytes::douglass()?),
    })
}

/// A Z-slide job as `turning run` would run it with these flags (`--table`, `--rpm`,
/// `--x-start` ...; `run`'s, without the link's): the table and the options, checked as
/// `turning run` checks them, for a caller with its own link (the grbl bridge's `$TURN=`).
pub fn turn_job(flags: &[String]) -> Result<(zrun::LinkTableBytes, ZRunOptions)> {
    use clap::Parser;
    #[derive(Parser)]
    struct RunOnly {
        #[command(flatten)]
        run: TurningRunArgs,
    }
    let args = std::iter::once("run").chain(flags.iter().map(String::as_str));
    let a = RunOnly::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?.run;
    let (ztable, table) = table_of(&a)?;
    Ok((table, run_options(&a, ztable.as_ref())?))
}

/// `turning run`: the job on the board, the figures and the `turning-summary` line.
fn turning_run(a: &TurningRunArgs) -> Result<()> {
    let (ztable, table) = table_of(a)?;
    let opts = run_options(a, ztable.as_ref())?;
    let (mut t, qemu_guard) = a.link.open()?;
    let say = |m: &str| eprintln!("motionctl: {m}");
    let result = zrun::run(&mut *t, &table, &opts, &say);
    let r = crate::qemu::finish(qemu_guard, result)?;
    let u = a.units;
    let un = u.name();
    let (micro, per_in) = u.micro();
    let following = |nin: i64| nin as f64 * 1e-9 * per_in;
    let board_s = r.board_ticks as f64 / opts.tick_hz as f64;
    if a.json {
        let j = json!({
            "table": a.table.as_ref().map(|p| p.display().to_string()),
            "rows": table.header.rows,
            "units": un,
            format!("x_start_{un}"): u.from_in(opts.x_start_in),
            format!("x_end_{un}"): u.from_in(opts.x_end_in),
            format!("feed_{un}_per_s"): u.from_in(opts.feed_in_per_s),
            "spindle_rpm": a.rpm,
            "output": match a.output { ZOutputArg::Steps => "steps", ZOutputArg::Dac => "dac" },
            "x_steps": r.x_steps,
            "z_steps": r.z_steps,
            "model_x_steps": r.model.x_steps,
            "model_z_steps": r.model.z_steps,
            format!("max_following_{micro}"): following(r.max_following_nin),
            format!("model_max_following_{micro}"): following(r.model.max_following_nin),
            "faults": r.faults,
            "z_state": r.z_state,
            "board_s": board_s,
            "wall_s": r.seconds,
            "speed_step_at_s": r.step_at_tick.map(|t| t as f64 / opts.tick_hz as f64),
            "final_spindle_rpm": r.final_rpm_milli as f64 / 1e3,
            "ok": r.ok(),
            "problems": r.problems,
        });
        crate::outln!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        crate::outln!(
            "z job      X {:.4} -> {:.4} {un} at {:.4} {un}/s, {} rpm, {:?} output; {board_s:.3} s \
             of board time, {:.2} s wall",
            u.from_in(opts.x_start_in),
            u.from_in(opts.x_end_in),
            u.from_in(opts.feed_in_per_s),
            a.rpm,
            a.output,
            r.seconds
        );
        crate::outln!(
            "steps      X {} Z {}; host model X {} Z {}",
            r.x_steps,
            r.z_steps,
            r.model.x_steps,
            r.model.z_steps
        );
        crate::outln!(
            "following  max {:.3} {micro}; host model {:.3} {micro}",
            following(r.max_following_nin),
            following(r.model.max_following_nin)
        );
        if let Some(at) = r.step_at_tick {
            crate::outln!(
                "speed step {:+} % at {:.3} s of board time; final {:.3} rpm",
                a.speed_step_pct,
                at as f64 / opts.tick_hz as f64,
                r.final_rpm_milli as f64 / 1e3
            );
        }
        crate::outln!(
            "faults     {}",
            if r.faults == 0 { "none".to_string() } else { crate::runner::fault_names(r.faults) }
        );
        // One machine-readable line for scripts (xtask turning-e2e).
        crate::outln!(
            "turning-summary x_steps={} z_steps={} model_x_steps={} model_z_steps={} \
             max_following_nin={} model_max_following_nin={} faults={} z_state={} \
             board_ticks={} model_ticks={} step_at_tick={} final_rpm_milli={}",
            r.x_steps,
            r.z_steps,
            r.model.x_steps,
            r.model.z_steps,
            r.max_following_nin,
            r.model.max_following_nin,
            r.faults,
            r.z_state,
            r.board_ticks,
            r.model.ticks,
            r.step_at_tick.map_or(-1, |t| t as i64),
            r.final_rpm_milli
        );
    }
    if !r.ok() {
        for p in &r.problems {
            eprintln!("motionctl: {p}");
        }
        bail!("the Z-slide job failed {} check(s)", r.problems.len());
    }
    if !a.json {
        crate::outln!("result     OK");
    }
    Ok(())
}
