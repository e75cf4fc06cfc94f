//! `motionctl polar ...`: digitize a contour into a step-event stream file, dump a stream, and
//! optimise the machine pole. Lengths in inches, angles in radians (the thesis's listing units).
//! The lead wires [`PolarCmd`] into the main command line.

use super::contour::{serpentine, witch, Circle, Contour, Limacon, Polar, Scaled, Spline};
use super::digitize::{digitize, DigitizeError, FeedAt, Setup};
use super::pole::{self, Constraints, HookeJeeves, Pole, MM2_PER_IN2};
use super::work_area::WorkArea;
use super::{Resolution, DR_IN, DTHETA_RAD};
use crate::units::Units;
use anyhow::{bail, Context};
use motion::polar::playback::SizeScale;
use motion::polar::stream::BlockEncoder;

/// Default event tick (the playback's DDA tick).
pub const DEFAULT_TICK_HZ: u32 = motion::polar::scenario::TICK_HZ;

/// Which contour, parsed from a spec: `circle:A`, `limacon:B,A` (r1 = B + A cos), `witch:A,X0,X1`,
/// `serpentine:A,B,X0,X1`, or a path to a CSV of Cartesian points `x,y` per line (an open cubic
/// spline through them; `#` comments and a non-numeric header line are skipped).
pub fn parse_contour(spec: &str) -> anyhow::Result<Box<dyn Contour>> {
    let nums = |rest: &str, n: usize| -> anyhow::Result<Vec<f64>> {
        let v: Vec<f64> = rest
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("bad numbers in {spec:?}"))?;
        if v.len() != n || v.iter().any(|x| !x.is_finite()) {
            bail!("{spec:?}: expected {n} finite numbers");
        }
        Ok(v)
    };
    if let Some((name, rest)) = spec.split_once(':') {
        match name {
            "circle" => {
                let v = nums(rest, 1)?;
                return Ok(Box::new(Polar::closed(Circle { a: v[0] })));
            }
            "limacon" => {
                let v = nums(rest, 2)?;
                return Ok(Box::new(Polar::closed(Limacon { b: v[0], a: v[1] })));
            }
            "witch" => {
                let v = nums(rest, 3)?;
                return Ok(Box::new(witch(v[0], v[1], v[2])));
            }
            "serpentine" => {
                let v = nums(rest, 4)?;
                return Ok(Box::new(serpentine(v[0], v[1], v[2], v[3])));
            }
            _ => {}
        }
    }
    let text = std::fs::read_to_string(spec)
        .with_context(|| format!("{spec:?} is neither a built-in contour nor a readable CSV"))?;
    let mut pts = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut f = line.split(',').map(|t| t.trim().parse::<f64>());
        match (f.next(), f.next()) {
            (Some(Ok(x)), Some(Ok(y))) if x.is_finite() && y.is_finite() => pts.push([x, y]),
            _ if pts.is_empty() && i == 0 => continue,
            _ => bail!("{spec}:{}: expected x,y", i + 1),
        }
    }
    match Spline::new(&pts) {
        Some(s) => Ok(Box::new(s)),
        None => bail!("{spec}: need at least 3 points, no two consecutive equal"),
    }
}

/// `--feed-at`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FeedAtArg {
    Contact,
    Centre,
}

impl From<FeedAtArg> for FeedAt {
    fn from(a: FeedAtArg) -> FeedAt {
        match a {
            FeedAtArg::Contact => FeedAt::Contact,
            FeedAtArg::Centre => FeedAt::Centre,
        }
    }
}

/// Machine resolutions and pole options shared by the subcommands.
#[derive(clap::Args, Debug, Clone)]
pub struct ResArgs {
    /// Radial resolution dR, in --units where the command has them, else in [default: the
    /// machine's 0.001 in].
    #[arg(long)]
    pub dr: Option<f64>,
    /// Angular resolution dTheta, rad (default 2 pi / 16000).
    #[arg(long, default_value_t = DTHETA_RAD)]
    pub dtheta: f64,
}

impl ResArgs {
    fn res(&self) -> anyhow::Result<Resolution> {
        self.res_in(Units::In)
    }

    /// With `--dr` given in `units`.
    fn res_in(&self, units: Units) -> anyhow::Result<Resolution> {
        let dr_in = self.dr.map_or(DR_IN, |d| units.to_in(d));
        if !(dr_in > 0.0 && self.dtheta > 0.0) {
            bail!("resolutions must be > 0 (--dr {:?}, --dtheta {})", self.dr, self.dtheta);
        }
        Ok(Resolution { dr_in, dtheta_rad: self.dtheta })
    }
}

/// `motionctl polar ...`
#[derive(clap::Subcommand, Debug)]
pub enum PolarCmd {
    /// Digitize a contour into timed single-axis step events and write the stream file.
    Digitize {
        /// circle:A | limacon:B,A | witch:A,X0,X1 | serpentine:A,B,X0,X1 | points.csv (lengths
        /// in --units).
        contour: String,
        /// Machine pole distance C from the contour pole (Table 4.1's C), in --units.
        #[arg(long)]
        pole_c: f64,
        /// Machine pole angle beta in the contour frame, rad (Table 4.1's beta).
        #[arg(long)]
        pole_beta: f64,
        /// Tool radius, in --units.
        #[arg(long, default_value_t = 0.0)]
        tool_radius: f64,
        /// Tangential speed Vt, --units per second, held where --feed-at says.
        #[arg(long)]
        vt: f64,
        /// Unit of every length given and printed: `in` (the thesis's) or `mm`; --dr too.
        #[arg(long, value_enum, default_value_t = Units::In)]
        units: Units,
        /// Where Vt is held: `contact` (the cutting point on the contour: the thesis's Vt) or
        /// `centre` (the tool centre, a machine's programmed feed).
        #[arg(long, value_enum, default_value_t = FeedAtArg::Contact)]
        feed_at: FeedAtArg,
        #[command(flatten)]
        res: ResArgs,
        /// Event time quantum, Hz.
        #[arg(long, default_value_t = DEFAULT_TICK_HZ)]
        tick_hz: u32,
        /// Only warn above the curvature speed limit (default: slow down to it, with a warning).
        #[arg(long)]
        no_cap: bool,
        /// Machine file whose `[polar]` table gives the work area (default: Fahim's machine,
        /// 3 < r < 13 in, 0 < theta < 2.8 rad).
        #[arg(long, value_name = "FILE")]
        machine: Option<std::path::PathBuf>,
        /// Stream file to write.
        #[arg(long, short)]
        out: Option<std::path::PathBuf>,
        /// Draw the contour, the tool path, the machine's steps and the work area (in the plane
        /// and in (theta, r)) and the axes against time: FILE.svg or FILE.png.
        #[arg(long, value_name = "FILE")]
        plot: Option<std::path::PathBuf>,
        /// The summary as one JSON object on stdout instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print a stream file: block headers, one line per event or run with cumulative time.
    Dump {
        file: std::path::PathBuf,
        #[arg(long, default_value_t = DEFAULT_TICK_HZ)]
        tick_hz: u32,
    },
    /// Find the machine pole that minimises F1 within the work area (pole outside a closed
    /// contour), and print its area error.
    Pole {
        contour: String,
        #[command(flatten)]
        res: ResArgs,
        /// Bound only the pole's coordinates to +-HALF in (the thesis program's limits) instead of
        /// the work area.
        #[arg(long, value_name = "HALF")]
        box_only: Option<f64>,
        /// Machine file whose `[polar]` table gives the work area (default: Fahim's machine).
        #[arg(long, value_name = "FILE")]
        machine: Option<std::path::PathBuf>,
        /// Print the result as one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Play a stream file on the board as an event job (through the host link), then check
    /// the events fired and the final (theta, r) steps against the host model.
    Run {
        file: std::path::PathBuf,
        #[command(flatten)]
        link: crate::board_link::LinkArgs,
        /// Speed scale (the feed override), 0.25..=2.
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
        /// Radial size scale M:K (M radial steps per K recorded ones), each 1..=4.
        #[arg(long, default_value = "1:1", value_parser = parse_size)]
        size: SizeScale,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Copy mode: the arm and carriage encoders drive theta and r live (radial size M:K);
    /// with --teach, record the encoder events and save them as a stream file for `polar run`.
    /// On a simulator board (--qemu) the host moves the simulated encoders along --template.
    Copy {
        #[command(flatten)]
        link: crate::board_link::LinkArgs,
        /// Radial size scale M:K (M radial steps per K encoder counts), each 1..=4.
        #[arg(long, default_value = "1:1", value_parser = parse_size)]
        size: SizeScale,
        /// Record and save the taught stream here (also `--out`, `-o`).
        #[arg(long, short = 'o', alias = "out", value_name = "OUT.bin")]
        teach: Option<std::path::PathBuf>,
        /// Template for a simulator board: `limacon[:THETA_END_RAD]` (built in: r = 3 + 2 cos
        /// theta in, from theta 0) or a file of `arm_counts,carriage_counts` waypoints.
        #[arg(long, value_name = "TRACE")]
        template: Option<String>,
        /// On a real board: how long to copy (the operator moves the arm meanwhile).
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// `M:K` with M, K in 1..=4.
pub fn parse_size(s: &str) -> Result<SizeScale, String> {
    let (m, k) = s.split_once(':').ok_or_else(|| format!("expected M:K, found {s:?}"))?;
    let num = |t: &str| t.trim().parse::<u8>().map_err(|_| format!("bad number in {s:?}"));
    SizeScale::new(num(m)?, num(k)?).ok_or_else(|| format!("M and K must be 1..=4, got {s}"))
}

/// `polar run`: opens the link (QEMU, serial, TCP or the simulated board), plays the stream.
/// Theta steps from home in degrees, r steps in inches (the polar machine's scales).
fn deg(theta_steps: i64) -> f64 {
    theta_steps as f64 * 360.0 / motion::polar::job::THETA_STEPS_PER_REV as f64
}
fn inches(r_steps: i64) -> f64 {
    r_steps as f64 / motion::polar::job::R_STEPS_PER_IN as f64
}

fn run_stream(
    file: &std::path::Path,
    link: &crate::board_link::LinkArgs,
    speed: f64,
    size: SizeScale,
    json: bool,
) -> anyhow::Result<()> {
    use crate::transport::Transport;
    let bytes = std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
    // The whole file checked before a board is touched: a cut, corrupt or v1 file names itself.
    motion::polar::stream::decode_all(&bytes, |_| {})
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let target = link.target()?;
    let host = link.host_config(&target);
    let (mut t, qemu_guard): (Box<dyn Transport>, _) = if link.sim {
        let sim = super::sim::EventSim::new(super::sim::SIM_SPEED);
        if link.noise > 0.0 {
            eprintln!(
                "motionctl: noise proxy: {:.2} % of bytes corrupted or dropped, seed {}",
                link.noise * 100.0,
                link.seed
            );
            (Box::new(crate::noise::Noisy::new(sim, link.noise, link.seed)), None)
        } else {
            (Box::new(sim), None)
        }
    } else {
        link.open()?
    };
    let opts = super::run::PolarRunOptions {
        speed,
        scale: size,
        host,
        home: link.home || link.qemu || link.sim,
        progress: true,
    };
    let result = super::run::run(&mut t, &bytes, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "events": r.events,
            "events_fired": r.events_fired,
            "blocks": r.blocks,
            "theta_deg": deg(r.positions[0]),
            "r_in": inches(r.positions[1]),
            "theta_steps": r.positions[0],
            "r_steps": r.positions[1],
            "model_theta_steps": r.expected_positions[0],
            "model_r_steps": r.expected_positions[1],
            "board_s": r.board_ticks as f64 / motion::polar::scenario::TICK_HZ as f64,
            "wall_s": r.seconds,
            "retransmissions": r.retransmissions,
            "ok": r.ok(),
            "problems": r.problems,
        });
        crate::outln!("{v}");
        if !r.ok() {
            bail!("verification failed: {}", r.problems.join("; "));
        }
        return Ok(());
    }
    crate::outln!(
        "events     {} fired, {} in {} ({} blocks)",
        r.events_fired,
        r.events,
        file.display(),
        r.blocks
    );
    crate::outln!(
        "positions  theta {:.3} deg, r {:.4} in ({} and {} steps); host model {} and {} steps",
        deg(r.positions[0]),
        inches(r.positions[1]),
        r.positions[0],
        r.positions[1],
        r.expected_positions[0],
        r.expected_positions[1]
    );
    crate::outln!(
        "time       {:.2} s wall; model {} ticks, board ~{} ticks (status-resolution)",
        r.seconds,
        r.model_ticks,
        r.board_ticks
    );
    crate::outln!(
        "link       {} frames out, {} retransmitted, {} link NAKs, {} garbled frames in",
        r.frames_out,
        r.retransmissions,
        r.link_naks,
        r.bad_frames_in
    );
    crate::outln!("{}", r.machine_line());
    if !r.ok() {
        bail!("verification failed: {}", r.problems.join("; "));
    }
    crate::outln!("result     OK: every event fired once; positions match the host model");
    Ok(())
}

/// `--template`: the built-in limacon piece or a waypoint file.
fn template(spec: &str) -> anyhow::Result<super::copy::Trace> {
    if let Some(rest) = spec.strip_prefix("limacon") {
        let end = match rest.strip_prefix(':') {
            Some(t) => {
                t.parse::<f64>().map_err(|_| anyhow::anyhow!("bad THETA_END in {spec:?}"))?
            }
            None if rest.is_empty() => 0.5,
            None => bail!("expected limacon[:THETA_END_RAD], found {spec:?}"),
        };
        if !(0.0..=super::THETA_MAX_RAD).contains(&end) {
            bail!("THETA_END must be within 0..={} rad", super::THETA_MAX_RAD);
        }
        return Ok(super::copy::limacon_trace(end, 40));
    }
    let text = std::fs::read_to_string(spec).with_context(|| format!("reading {spec}"))?;
    super::copy::parse_trace(&text)
}

/// `polar copy`: opens the link, copies, saves the taught stream, prints the summary.
fn run_copy(
    link: &crate::board_link::LinkArgs,
    size: SizeScale,
    teach: Option<&std::path::Path>,
    template_spec: Option<&str>,
    seconds: f64,
    json: bool,
) -> anyhow::Result<()> {
    use crate::transport::Transport;
    let target = link.target()?;
    let host = link.host_config(&target);
    let simulated = link.sim || link.qemu;
    let trace = match (template_spec, simulated) {
        (Some(t), _) => Some(template(t)?),
        (None, true) => Some(template("limacon")?),
        (None, false) => None,
    };
    let (mut t, qemu_guard): (Box<dyn Transport>, _) = if link.sim {
        (Box::new(super::copy_sim::CopySimBoard::new(super::sim::SIM_SPEED)), None)
    } else {
        link.open()?
    };
    let opts = super::copy::CopyOptions {
        scale: size,
        teach: teach.is_some(),
        host,
        home: link.home || simulated,
        progress: true,
        trace,
        seconds,
    };
    let result = super::copy::copy(&mut t, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if let Some(path) = teach {
        std::fs::write(path, &r.stream).with_context(|| format!("writing {}", path.display()))?;
    }
    if json {
        let v = serde_json::json!({
            "ok": r.ok(),
            "waypoints": r.waypoints,
            "encoder_moves": r.encoder_moves,
            "theta_deg": deg(r.positions[0]),
            "r_in": inches(r.positions[1]),
            "theta_steps": r.positions[0],
            "r_steps": r.positions[1],
            "model_theta_steps": r.model.positions[0],
            "model_r_steps": r.model.positions[1],
            "size": format!("{}:{}", size.m, size.k),
            "taught_events": teach.map(|_| r.stream_events),
            "taught_blocks": teach.map(|_| r.blocks),
            "lost_events": r.lost_events,
            "problems": r.problems,
        });
        crate::outln!("{v}");
        if !r.ok() {
            bail!("verification failed: {}", r.problems.join("; "));
        }
        return Ok(());
    }
    crate::outln!(
        "copy       {} waypoints; encoders moved arm {} carriage {} counts",
        r.waypoints,
        r.encoder_moves[0],
        r.encoder_moves[1]
    );
    crate::outln!(
        "positions  theta {:.3} deg, r {:.4} in ({} and {} steps, size {}:{}); host model {} and {} \
         steps",
        deg(r.positions[0]),
        inches(r.positions[1]),
        r.positions[0],
        r.positions[1],
        size.m,
        size.k,
        r.model.positions[0],
        r.model.positions[1]
    );
    if let Some(path) = teach {
        crate::outln!(
            "teach      {} events in {} blocks -> {} ({} lost)",
            r.stream_events,
            r.blocks,
            path.display(),
            r.lost_events
        );
    }
    crate::outln!("{}", r.machine_line());
    if !r.ok() {
        bail!("verification failed: {}", r.problems.join("; "));
    }
    crate::outln!("result     OK");
    Ok(())
}

/// The work area of `--machine FILE`, or Fahim's machine.
fn work_area(machine: Option<&std::path::Path>) -> anyhow::Result<WorkArea> {
    machine.map_or(Ok(WorkArea::FAHIM_1983), WorkArea::from_file)
}

/// For a contour that leaves the work area: a machine pole (from the pole optimiser, checked by
/// digitizing with it) that keeps it inside, as the flags to give, or why there is none.
fn suggest_pole(contour: &dyn Contour, setup: &Setup, units: Units) -> String {
    // The contour must stay a tool radius inside for the tool centre to be inside.
    let opt = setup.area.inset(setup.tool_radius_in).and_then(|inner| {
        pole::optimise(contour, &setup.res, Constraints::WorkArea(inner), &HookeJeeves::default())
    });
    let fits = opt.filter(|o| {
        let (pole_r_in, pole_angle_rad) = o.pole.digitizer_pole();
        digitize(contour, &Setup { pole_r_in, pole_angle_rad, ..*setup }).is_ok()
    });
    match fits {
        Some(o) => format!(
            "a pole that fits: --pole-c {:.4} --pole-beta {:.4} (C {:.2} mm; least area error \
             F1 {:.4})",
            units.from_in(o.pole.c_in),
            o.pole.beta_rad,
            o.pole.c_in * 25.4,
            o.f1.f1
        ),
        None => "no machine pole fits it in this work area: the contour (with the tool) is too \
                 large for it"
            .to_string(),
    }
}

/// Runs one `polar` subcommand, printing to stdout.
pub fn run(cmd: PolarCmd) -> anyhow::Result<()> {
    match cmd {
        PolarCmd::Digitize {
            contour,
            pole_c,
            pole_beta,
            tool_radius,
            vt,
            units,
            feed_at,
            res,
            tick_hz,
            no_cap,
            machine,
            out,
            plot,
            json,
        } => {
            let c = Scaled::new(parse_contour(&contour)?, units.to_in(1.0));
            let area = work_area(machine.as_deref())?;
            let (pole_r_in, pole_angle_rad) =
                Pole { c_in: units.to_in(pole_c), beta_rad: pole_beta }.digitizer_pole();
            let res = res.res_in(units)?;
            let setup = Setup {
                pole_r_in,
                pole_angle_rad,
                tool_radius_in: units.to_in(tool_radius),
                vt_in_per_s: units.to_in(vt),
                feed_at: feed_at.into(),
                res,
                tick_hz,
                cap_speed: !no_cap,
                area,
            };
            let d = match digitize(&c, &setup) {
                Err(e @ DigitizeError::OutsideWorkArea { .. }) => {
                    bail!("{e}; {}", suggest_pole(&c, &setup, units))
                }
                r => r?,
            };
            let ticks: u64 = d.events.iter().map(|e| e.dt_ticks as u64).sum();
            let radial = d.events.iter().filter(|e| e.axis == 1).count();
            // Where the machine starts: the tool centre's (r, theta) about the machine pole,
            // on the digitizer's grids.
            let start_r_in = d.start_r_steps as f64 * setup.res.dr_in;
            let start_theta_deg = d.theta0_rad.to_degrees();
            let duration_s = ticks as f64 / tick_hz as f64;
            // The cut's time from its length: the stream must last this (to a tick per event).
            let expected_s = d.feed_length_in / d.vt_in_per_s;
            let feed_name = match setup.feed_at {
                FeedAt::Contact => "contact",
                FeedAt::Centre => "centre",
            };
            let u = units.name();
            let len = |v_in: f64| units.from_in(v_in);
            if json {
                let mut v = serde_json::json!({
                    "units": u,
                    "events": d.events.len(),
                    "radial_events": radial,
                    "angular_events": d.events.len() - radial,
                    "feed_at": feed_name,
                    "duration_s": duration_s,
                    "expected_s": expected_s,
                    "start_theta_deg": start_theta_deg,
                    "warnings": d.warnings.len(),
                });
                for (key, v_in) in [
                    ("path", d.length_in),
                    ("contact_path", d.contact_length_in),
                    ("start_r", start_r_in),
                    ("min_radius_of_curvature", d.min_rho_in),
                ] {
                    v[format!("{key}_{u}")] = serde_json::json!(len(v_in));
                }
                v[format!("vt_{u}_per_s")] = serde_json::json!(len(d.vt_in_per_s));
                crate::outln!("{v}");
            } else {
                crate::outln!(
                    "start      r {:.4} {u}, theta {start_theta_deg:.3} deg (tool centre about the \
                     machine pole)",
                    len(start_r_in)
                );
                crate::outln!(
                    "{} events ({radial} radial, {} angular), min radius of curvature {:.4} {u}",
                    d.events.len(),
                    d.events.len() - radial,
                    len(d.min_rho_in)
                );
                crate::outln!(
                    "path       contact {:.4} {u}, tool centre {:.4} {u}; Vt {:.4} {u}/s held at \
                     the {}",
                    len(d.contact_length_in),
                    len(d.length_in),
                    len(d.vt_in_per_s),
                    if setup.feed_at == FeedAt::Contact { "contact point" } else { "tool centre" }
                );
                crate::outln!(
                    "time       {duration_s:.4} s ({:.4} {u} / {:.4} {u}/s = {expected_s:.4} s)",
                    len(d.feed_length_in),
                    len(d.vt_in_per_s)
                );
            }
            for w in &d.warnings {
                eprintln!("motionctl: warning: {w}");
            }
            if let Some(p) = &plot {
                let u = units.name();
                let title = format!(
                    "polar digitize {contour} ({u}): tool radius {tool_radius} {u}, Vt {vt} {u}/s, \
                     pole C {pole_c} {u} at beta {pole_beta} rad"
                );
                super::figure::digitized_figure(&c, &setup, &d, &title).save(p)?;
            }
            if let Some(path) = out {
                let mut bytes = Vec::new();
                let mut enc = BlockEncoder::new();
                for &e in &d.events {
                    enc.push(e, &mut |b: &[u8]| bytes.extend_from_slice(b))
                        .map_err(|e| anyhow::anyhow!("encoding: {e:?}"))?;
                }
                enc.finish(&mut |b: &[u8]| bytes.extend_from_slice(b));
                std::fs::write(&path, &bytes)
                    .with_context(|| format!("writing {}", path.display()))?;
                eprintln!(
                    "motionctl: wrote {} ({} bytes, {} blocks)",
                    path.display(),
                    bytes.len(),
                    enc.blocks()
                );
            }
            Ok(())
        }
        PolarCmd::Dump { file, tick_hz } => {
            let bytes =
                std::fs::read(&file).with_context(|| format!("reading {}", file.display()))?;
            let mut text = String::new();
            let r = super::dump::dump(&bytes, tick_hz, &mut text);
            crate::out!("{text}");
            // The dump's own error line says where and what (the listing may have gone to a
            // closed pipe or a file): the same words on stderr.
            r.map(|_| ()).map_err(|e| {
                let line = text.lines().rev().find_map(|l| l.strip_prefix("error: "));
                let why = line.map_or_else(|| format!("{e:?}"), str::to_string);
                anyhow::anyhow!("{}: {why}", file.display())
            })
        }
        PolarCmd::Run { file, link, speed, size, json } => {
            run_stream(&file, &link, speed, size, json)
        }
        PolarCmd::Copy { link, size, teach, template, seconds, json } => {
            run_copy(&link, size, teach.as_deref(), template.as_deref(), seconds, json)
        }
        PolarCmd::Pole { contour, res, box_only, machine, json } => {
            let c = parse_contour(&contour)?;
            let res = res.res()?;
            let work = work_area(machine.as_deref())?;
            let constraints = match box_only {
                Some(half_in) => Constraints::Box { centre: [0.0, 0.0], half_in },
                None => Constraints::WorkArea(work),
            };
            let Some(o) = pole::optimise(c.as_ref(), &res, constraints, &HookeJeeves::default())
            else {
                bail!("no feasible pole found for {contour}");
            };
            let area = pole::area_error_in2(c.as_ref(), o.pole.xy(), &res, 4);
            let fits = pole::check(c.as_ref(), o.pole.xy(), &work);
            if json {
                let v = serde_json::json!({
                    "pole_c_in": o.pole.c_in,
                    "pole_c_mm": o.pole.c_in * 25.4,
                    "pole_beta_rad": o.pole.beta_rad,
                    "f1": o.f1.f1,
                    "f_dif": o.f1.f_dif,
                    "f_sum": o.f1.f_sum,
                    "evaluations": o.evals,
                    "area_error_in2": area,
                    "area_error_mm2": area * MM2_PER_IN2,
                    "in_work_area": fits.is_ok(),
                });
                crate::outln!("{v}");
                return Ok(());
            }
            crate::outln!(
                "pole C = {:.4} in ({:.3} cm), beta = {:.4} rad; F1 = {:.5} (F_dif {:.1}, F_sum {:.1}, {} evaluations)",
                o.pole.c_in,
                o.pole.c_in * super::CM_PER_IN,
                o.pole.beta_rad,
                o.f1.f1,
                o.f1.f_dif,
                o.f1.f_sum,
                o.evals
            );
            crate::outln!(
                "area error {:.6} in^2 = {:.3} mm^2; constraints: {:?}",
                area,
                area * MM2_PER_IN2,
                fits
            );
            crate::outln!(
                "digitize with --pole-c {:.4} --pole-beta {:.4} (work area {work})",
                o.pole.c_in,
                o.pole.beta_rad
            );
            Ok(())
        }
    }
}
