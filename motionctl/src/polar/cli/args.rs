//! The `polar` command line: the subcommands, their shared options and the value parsers.

use crate::polar::contour::{serpentine, witch, Circle, Contour, Limacon, Polar, Spline};
use crate::polar::digitize::FeedAt;
use crate::polar::{Resolution, DR_IN, DTHETA_RAD};
use crate::units::Units;
use anyhow::{bail, Context};
use motion::polar::playback::SizeScale;

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
    pub(super) fn res(&self) -> anyhow::Result<Resolution> {
        self.res_in(Units::In)
    }

    /// With `--dr` given in `units`.
    pub(super) fn res_in(&self, units: Units) -> anyhow::Result<Resolution> {
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
