//! The wire job's files: the versioned TOML a user writes for `motionctl wire plan|run --job`
//! ([`parse_spec`]), and the no_std constant table the firmware links
//! (`src/wire/circle_complex_job.rs`, [`render`]): per segment the step deltas, nominal ticks
//! and the Q2.30 entry, exit and acceleration rates, plus the job's reference figures as
//! integers.
//!
//! TOML, version 1 (every field but `version` optional):
//!
//! ```toml
//! version = 1
//! fr_mm2_per_min = 800     # area rate (default 800, Table 11)
//! tolerance_mm = 0.01      # wire off the designed ruling line, at most (default 0.01)
//! [backlash]               # lash per axis in motor steps, taken up at every reversal (default 0)
//! x_steps = 20
//! y_steps = 20
//! beta_steps = 250         # the thesis's 1 deg of the 18:1 gearbox
//! alpha_steps = 0
//! [contours]               # a die from two drawings instead of --die / --mdi (see wire::cad)
//! top = "top.svg"          # FILE or FILE#ID (SVG path id, DXF layer); relative to this file
//! bottom = "bottom.dxf#outer"
//! thickness_mm = 30        # workpiece thickness ZT (required with [contours])
//! points = 120             # points per face after resampling (default 120)
//! chord_tolerance_mm = 0.01  # curve flattening (default 0.01)
//! ```

use super::backlash::{self, BacklashError};
use super::continuous::{ContinuousJob, ContinuousParams};
use motion::MachineConfig;
use serde::Deserialize;
use std::fmt::Write;

/// Why a wire job file was refused.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum WireJobFileError {
    #[error("{0}")]
    Toml(String),
    #[error("unsupported wire job version {0} (this motionctl reads version 1)")]
    Version(u32),
    #[error("{field} = {value}: must be a finite number > 0")]
    Field { field: &'static str, value: f64 },
    #[error(transparent)]
    Backlash(#[from] BacklashError),
    #[error("contours.points = {0}: must be a whole number 3 .. 100000")]
    Points(i64),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    version: u32,
    fr_mm2_per_min: Option<f64>,
    tolerance_mm: Option<f64>,
    #[serde(default)]
    backlash: BacklashTable,
    contours: Option<ContoursTable>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ContoursTable {
    top: String,
    bottom: String,
    thickness_mm: f64,
    points: Option<i64>,
    chord_tolerance_mm: Option<f64>,
}

/// The `[contours]` table of a wire job file: the drawings of the two faces.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourSpec {
    /// `FILE` or `FILE#ID`, resolved against the job file's folder.
    pub top: String,
    pub bottom: String,
    pub thickness_mm: f64,
    pub points: Option<usize>,
    pub chord_tolerance_mm: Option<f64>,
}

/// The `[contours]` table of `src`, if any; relative drawing paths are taken from `base` (the
/// job file's folder).
pub fn parse_contours(
    src: &str,
    base: &std::path::Path,
) -> Result<Option<ContourSpec>, WireJobFileError> {
    let f: File = toml::from_str(src).map_err(|e| WireJobFileError::Toml(e.to_string()))?;
    if f.version != 1 {
        return Err(WireJobFileError::Version(f.version));
    }
    let Some(c) = f.contours else { return Ok(None) };
    let resolve = |s: &str| {
        let p = std::path::Path::new(s);
        if p.is_absolute() {
            s.to_string()
        } else {
            base.join(p).display().to_string()
        }
    };
    let positive = |field: &'static str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(WireJobFileError::Field { field, value: v })
        }
    };
    let points = match c.points {
        Some(n) if (3..=super::cad::MAX_POINTS as i64).contains(&n) => Some(n as usize),
        Some(n) => return Err(WireJobFileError::Points(n)),
        None => None,
    };
    Ok(Some(ContourSpec {
        top: resolve(&c.top),
        bottom: resolve(&c.bottom),
        thickness_mm: positive("contours.thickness_mm", c.thickness_mm)?,
        points,
        chord_tolerance_mm: c
            .chord_tolerance_mm
            .map(|v| positive("contours.chord_tolerance_mm", v))
            .transpose()?,
    }))
}

// Signed, so that a negative lash is refused with the field's name rather than a type error.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct BacklashTable {
    #[serde(default)]
    x_steps: i64,
    #[serde(default)]
    y_steps: i64,
    #[serde(default)]
    beta_steps: i64,
    #[serde(default)]
    alpha_steps: i64,
}

/// Parses a wire job file into planning parameters (defaults from
/// [`ContinuousParams::default`] for what it leaves out).
pub fn parse_spec(src: &str) -> Result<ContinuousParams, WireJobFileError> {
    parse_spec_with(src, ContinuousParams::default())
}

/// [`parse_spec`] with `defaults` for what the file leaves out (e.g. a die's own feed).
pub fn parse_spec_with(
    src: &str,
    defaults: ContinuousParams,
) -> Result<ContinuousParams, WireJobFileError> {
    let f: File = toml::from_str(src).map_err(|e| WireJobFileError::Toml(e.to_string()))?;
    if f.version != 1 {
        return Err(WireJobFileError::Version(f.version));
    }
    let mut prm = defaults;
    for (field, value, slot) in [
        ("fr_mm2_per_min", f.fr_mm2_per_min, &mut prm.fr_mm2_per_min),
        ("tolerance_mm", f.tolerance_mm, &mut prm.tol_mm),
    ] {
        if let Some(v) = value {
            if !(v.is_finite() && v > 0.0) {
                return Err(WireJobFileError::Field { field, value: v });
            }
            *slot = v;
        }
    }
    let b = &f.backlash;
    prm.backlash_steps = backlash::validate(
        [b.x_steps, b.y_steps, b.beta_steps, b.alpha_steps],
        backlash::FIELD_NAMES,
    )?;
    Ok(prm)
}

/// Rust source of the job table. `generator` names what produced it (for the header).
pub fn render(
    job: &ContinuousJob,
    cfg: &MachineConfig,
    fr_mm2_per_min: f64,
    generator: &str,
) -> String {
    let mut s = String::new();
    let total: Vec<i64> =
        (0..4).map(|a| job.segments.iter().map(|g| g.steps[a] as i64).sum()).collect();
    // Writing to a String cannot fail.
    let _ = write!(
        s,
        "//! GENERATED by {generator}; do not edit (REGENERATE=1 rewrites it).\n\
         //! The circle -> complex die (top circle R 25, bottom complex RI 20, N 80, ZT 39 mm) from\n\
         //! and back to the centre at FR {fr_mm2_per_min} mm^2/min, continuous, at {tick} Hz: {n} segments.\n\
         \n\
         use super::job::{{seg, JobSegment}};\n\
         \n\
         /// DDA tick the durations are counted in.\n\
         pub const TICK_HZ: u32 = {tick};\n\
         /// Exact ruled area of the path, 1e-6 mm^2.\n\
         pub const AREA_RULED_MM2_E6: u64 = {area};\n\
         /// 60 A / FR for that area, microseconds.\n\
         pub const TIME_RULED_US: u64 = {time_us};\n\
         /// Sum of the segments' steps (X, Y, beta, alpha).\n\
         pub const TOTAL_STEPS: [i64; 4] = [{t0}, {t1}, {t2}, {t3}];\n\
         \n\
         /// seg(x, y, beta, alpha, duration_ticks, entry_q30, exit_q30, accel_q30).\n\
         #[rustfmt::skip]\n\
         pub const SEGMENTS: [JobSegment; {n}] = [\n",
        tick = cfg.tick_hz,
        n = job.segments.len(),
        area = (job.area_ruled_mm2 * 1e6).round() as u64,
        time_us = (job.time_ruled_s * 1e6).round() as u64,
        t0 = total[0],
        t1 = total[1],
        t2 = total[2],
        t3 = total[3],
    );
    for g in &job.segments {
        let _ = writeln!(
            s,
            "    seg({}, {}, {}, {}, {}, {}, {}, {}),",
            g.steps[0],
            g.steps[1],
            g.steps[2],
            g.steps[3],
            g.duration_ticks,
            g.entry_rate.to_bits(),
            g.exit_rate.to_bits(),
            g.accel_per_tick.to_bits()
        );
    }
    s.push_str("];\n");
    s
}
