//! `motionctl wire plan|run`'s job arguments ([`WirePlanArgs`], the drawings' [`DrawingArgs`]) and
//! how they become the die and the planner's parameters (job file, then flags).

use crate::wire::continuous::ContinuousParams;
use anyhow::{Context, Result};
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
    pub(super) drawing: Box<DrawingArgs>,
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
    pub(super) plot: Option<PathBuf>,
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
    pub(super) fn die(
        &self,
    ) -> Result<(crate::wire::dies::DieJob, Option<crate::wire::cad::ContourPair>)> {
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
    pub(super) fn params(&self, die_fr_mm2_per_min: f64) -> Result<ContinuousParams> {
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
