//! A part's Z table from the user's numbers: the off-axis paraboloid of any focal length, offset
//! and tool-nose radius (thesis mode: FOREX4's method; accurate mode: converged), or a non-round
//! profile (see [`super::profile`]), on the user's X grid, in the power or harmonic form, with
//! the exact command the table stands for (for its error).

use super::accurate::{self, AccurateOptions, ToolNoseModel};
use super::fit::{dft, Harmonics};
use super::forex4::{self, Forex4Params, FORIF_PI};
use super::paraboloid::OffAxisParaboloid;
use super::profile::Profile;
use super::table::CoefficientTable;
use super::table_file::{ZTable, MAX_ROWS};
use anyhow::{anyhow, bail, Result};
use std::f64::consts::PI;

/// How the table is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Mode {
    /// FOREX4 (Appendix B-1): the listing's numerical method for any constants (FORIF with
    /// 721 samples and pi = 3.141593, three tool-nose passes); with the thesis's constants it
    /// prints Table 2-2 digit for digit.
    Thesis,
    /// Exact constants, the converged tool-nose envelope, a 1440-sample DFT.
    Accurate,
}

/// The paraboloid's constants, inches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Paraboloid {
    pub focal_length_in: f64,
    pub offset_in: f64,
    pub nose_radius_in: f64,
}

impl Paraboloid {
    /// The problem statement of Chapter 1 (p = 79.15 in) for the accurate mode.
    pub const PROBLEM_FOCAL_LENGTH_IN: f64 = 79.15;
    /// The FOREX4 listing's `C = 316.7` (not 4 x 79.15) as a focal length, for the thesis mode.
    pub const LISTING_FOCAL_LENGTH_IN: f64 = 316.7 / 4.0;
    pub const OFFSET_IN: f64 = 28.0;
    pub const NOSE_RADIUS_IN: f64 = 0.125;
    /// The thesis's sector: X = 0..8 in in steps of 0.1 in.
    pub const X_MAX_IN: f64 = 8.0;
    pub const X_STEP_IN: f64 = 0.1;

    /// The thesis's part for `mode`.
    pub fn thesis(mode: Mode) -> Self {
        Paraboloid {
            focal_length_in: match mode {
                Mode::Thesis => Self::LISTING_FOCAL_LENGTH_IN,
                Mode::Accurate => Self::PROBLEM_FOCAL_LENGTH_IN,
            },
            offset_in: Self::OFFSET_IN,
            nose_radius_in: Self::NOSE_RADIUS_IN,
        }
    }
}

/// What to turn.
#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    Paraboloid(Paraboloid),
    Profile(Profile),
}

/// The X grid: rows at `0, dx, ..., x_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub x_max_in: f64,
    pub dx_in: f64,
}

impl Grid {
    /// Rows of the grid; refused (before anything is allocated) unless `x_max` is a whole
    /// number of steps and the rows fit the board's table.
    pub fn rows(&self) -> Result<usize> {
        let cells = self.x_max_in / self.dx_in;
        if !cells.is_finite() || cells < 0.5 {
            bail!("--x-max must be at least one --x-step");
        }
        if cells > (MAX_ROWS - 1) as f64 + 0.5 {
            bail!(
                "--x-step: {:.0} rows over --x-max; the board's table holds at most {MAX_ROWS} \
                 rows (use --x-step >= {:.6} in, or a shorter --x-max)",
                cells.round() + 1.0,
                self.x_max_in / (MAX_ROWS - 1) as f64
            );
        }
        let n = cells.round();
        if (cells - n).abs() > 1e-6 * n {
            bail!("--x-max must be a whole number of --x-step (got {cells:.6} steps)");
        }
        Ok(n as usize + 1)
    }
}

/// The exact command a table stands for, to measure the table against.
#[derive(Clone, Debug)]
enum Truth {
    /// The exact tool-centre command; `arc_gross`: measured from the tool centre's gross arc
    /// (FOREX4's gross path) instead of the highest point.
    Paraboloid {
        par: OffAxisParaboloid,
        arc_gross: bool,
    },
    Profile {
        profile: Profile,
        x_max_in: f64,
    },
}

/// Samples per revolution of the profile fit, and the highest order computed (for the
/// neglected-harmonics figure).
const PROFILE_SAMPLES: usize = 1440;
const PROFILE_MAX_ORDER: usize = 48;
/// Samples of the dense scan for a profile's gross radius (its largest value per revolution).
const GROSS_SCAN: usize = 8192;

/// A built table and what it stands for.
#[derive(Clone, Debug)]
pub struct Built {
    pub table: ZTable,
    /// Sum of the magnitudes of every harmonic the table's form drops, largest over the rows,
    /// inches: how far the surface is from what the generator can produce.
    pub max_neglected_in: f64,
    /// One line on the method.
    pub method: String,
    /// The gross path at each row (paraboloid: the axial arc Y(X) at the tool centre; profile:
    /// the largest radius), inches.
    pub gross_in: Vec<f64>,
    truth: Truth,
}

impl Built {
    /// The exact command at `x_in` for each of `phis`, inches (`None` outside the part).
    pub fn truth_in(&self, x_in: f64, phis: &[f64]) -> Option<Vec<f64>> {
        match &self.truth {
            Truth::Paraboloid { par, arc_gross } => {
                let shift = if *arc_gross {
                    par.gross_y_tool_centre_in(x_in).ok()?
                        - par.gross_y_tool_centre_arc_in(x_in).ok()?
                } else {
                    0.0
                };
                phis.iter()
                    .map(|&phi| {
                        accurate::z_command_in(par, x_in, phi, ToolNoseModel::MeridianEnvelope)
                            .ok()
                            .map(|z| z + shift)
                    })
                    .collect()
            }
            Truth::Profile { profile, x_max_in } => {
                let t = (x_in / x_max_in).clamp(0.0, 1.0);
                let gross = profile_gross_in(profile, t);
                Some(phis.iter().map(|&phi| profile.radius_in(t, phi) - gross).collect())
            }
        }
    }
}

/// The largest radius of a profile over a revolution at feed fraction `t`.
fn profile_gross_in(profile: &Profile, t: f64) -> f64 {
    (0..GROSS_SCAN)
        .map(|k| profile.radius_in(t, 2.0 * PI * k as f64 / GROSS_SCAN as f64))
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Sum of `|Ci| + |Si|` over the orders above `order`.
fn neglected_above(h: &Harmonics, order: usize) -> f64 {
    (order + 1..h.cos_in.len()).map(|i| h.cos_in[i].abs() + h.sin_in[i].abs()).sum()
}

/// The table of `part` on `grid` by `mode`, power form (`harmonics` = None) or harmonic of that
/// order (1..=8).
pub fn build(part: &Part, mode: Mode, grid: Grid, harmonics: Option<u8>) -> Result<Built> {
    let rows = grid.rows()?;
    if let Some(k) = harmonics {
        if !(1..=super::table_file::MAX_ORDER).contains(&k) {
            bail!("--harmonics must be within 1..=8 (the board's largest order); got {k}");
        }
    }
    match part {
        Part::Paraboloid(p) => {
            let par = OffAxisParaboloid::new(
                p.focal_length_in,
                p.offset_in,
                2.0 * grid.x_max_in,
                p.nose_radius_in,
            )
            .map_err(|e| anyhow!("the paraboloid on --x-max {} in: {e}", grid.x_max_in))?;
            match mode {
                Mode::Thesis => thesis(p, par, grid, rows, harmonics),
                Mode::Accurate => accurate_paraboloid(par, grid, rows, harmonics),
            }
        }
        Part::Profile(profile) => {
            if mode == Mode::Thesis {
                bail!("--mode thesis is FOREX4, the paraboloid's program: use --mode accurate");
            }
            profile_table(profile, grid, rows, harmonics.unwrap_or(super::table_file::MAX_ORDER))
        }
    }
}

fn thesis(
    p: &Paraboloid,
    par: OffAxisParaboloid,
    grid: Grid,
    rows: usize,
    harmonics: Option<u8>,
) -> Result<Built> {
    if harmonics.is_some() {
        bail!("--harmonics needs --mode accurate (FOREX4 computes the power form C00..C03)");
    }
    let prm = Forex4Params {
        c_in: 4.0 * p.focal_length_in,
        offset_in: p.offset_in,
        tool_nose_radius_in: p.nose_radius_in,
        x_step_in: grid.dx_in,
        rows,
        ..Forex4Params::listing()
    };
    let out = forex4::forex4(&prm)?;
    let max_neglected_in = out
        .iter()
        .map(|r| Harmonics { cos_in: r.cos_in.clone(), sin_in: r.sin_in.clone() }.neglected_in())
        .fold(0.0, f64::max);
    let gross_in = out.iter().map(|r| r.ytc_in - p.nose_radius_in).collect();
    let table = CoefficientTable::new(0.0, grid.dx_in, out.into_iter().map(|r| r.power).collect())?;
    Ok(Built {
        table: ZTable::from_power(&table),
        max_neglected_in,
        method: format!(
            "thesis (FOREX4: FORIF with {} samples/rev, pi = {FORIF_PI}, {} tool-nose passes)",
            2 * prm.n + 1,
            prm.iterations
        ),
        gross_in,
        truth: Truth::Paraboloid { par, arc_gross: true },
    })
}

fn accurate_paraboloid(
    par: OffAxisParaboloid,
    grid: Grid,
    rows: usize,
    harmonics: Option<u8>,
) -> Result<Built> {
    let opts = AccurateOptions::default();
    let acc = accurate::table_over(&par, 0.0, grid.dx_in, rows, &opts)?;
    let (table, max_neglected_in) = match harmonics {
        None => (ZTable::from_power(&acc.table), acc.max_neglected_in),
        Some(k) => (
            ZTable::from_harmonics(0.0, grid.dx_in, &acc.harmonics, &[], k),
            acc.harmonics.iter().map(|h| neglected_above(h, k as usize)).fold(0.0, f64::max),
        ),
    };
    let gross_in = (0..rows)
        .map(|i| {
            let x = i as f64 * grid.dx_in;
            par.gross_y_tool_centre_in(x.min(grid.x_max_in)).map(|y| y - par.tool_nose_radius_in())
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    Ok(Built {
        table,
        max_neglected_in,
        method: format!(
            "accurate (converged tool-nose envelope, {}-sample DFT)",
            opts.samples_per_rev
        ),
        gross_in,
        truth: Truth::Paraboloid { par, arc_gross: false },
    })
}

fn profile_table(profile: &Profile, grid: Grid, rows: usize, order: u8) -> Result<Built> {
    let mut harmonics = Vec::with_capacity(rows);
    let mut gross_in = Vec::with_capacity(rows);
    for i in 0..rows {
        let t = (i as f64 * grid.dx_in / grid.x_max_in).min(1.0);
        let samples: Vec<f64> = (0..PROFILE_SAMPLES)
            .map(|k| profile.radius_in(t, 2.0 * PI * k as f64 / PROFILE_SAMPLES as f64))
            .collect();
        harmonics.push(dft(&samples, PROFILE_MAX_ORDER)?);
        gross_in.push(profile_gross_in(profile, t));
    }
    let max_neglected_in =
        harmonics.iter().map(|h| neglected_above(h, order as usize)).fold(0.0, f64::max);
    Ok(Built {
        table: ZTable::from_harmonics(0.0, grid.dx_in, &harmonics, &gross_in, order),
        max_neglected_in,
        method: format!(
            "profile fit ({PROFILE_SAMPLES}-sample DFT of r(phi) less its largest value)"
        ),
        gross_in,
        truth: Truth::Profile { profile: profile.clone(), x_max_in: grid.x_max_in },
    })
}

/// The table's error against the exact command: `(X, largest |error| over the spindle angle)`
/// at `points_per_cell` points per grid cell, `phi_samples` angles, cubic between rows as the
/// board does. Inches.
pub fn part_error(built: &Built, points_per_cell: usize, phi_samples: usize) -> Vec<(f64, f64)> {
    let t = &built.table;
    let phis: Vec<f64> =
        (0..phi_samples.max(1)).map(|j| 2.0 * PI * j as f64 / phi_samples.max(1) as f64).collect();
    let per = points_per_cell.max(1);
    let mut out = Vec::with_capacity(t.len() * per);
    for i in 0..t.len() {
        let steps = if i + 1 < t.len() { per } else { 1 };
        for k in 0..steps {
            let x = t.x_at(i) + t.dx_in * k as f64 / per as f64;
            let (Some(c), Some(truth)) = (t.coefficients_at(x), built.truth_in(x, &phis)) else {
                continue;
            };
            let worst = phis
                .iter()
                .zip(&truth)
                .map(|(&phi, z)| (ZTable::eval_row(t.form, &c, phi) - z).abs())
                .fold(0.0, f64::max);
            out.push((x, worst));
        }
    }
    out
}
