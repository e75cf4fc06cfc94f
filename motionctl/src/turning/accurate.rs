//! Accurate mode: the Table 2-2 computation without the listing's shortcuts. Exact pi, the
//! paraboloid's own constants (`c = 4 p`), the cancellation-free `Z` of
//! [`OffAxisParaboloid::z_in`], the converged tool-nose geometry, a direct DFT
//! ([`super::fit::dft`]) with more samples, and every harmonic up to `max_order` kept so the
//! error of the four-term form can be reported.

use super::fit::{dft, Harmonics};
use super::paraboloid::OffAxisParaboloid;
use super::table::CoefficientTable;
use super::{positive, Result, TurningError};
use std::f64::consts::PI;

/// How the tool-nose radius enters the command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolNoseModel {
    /// Sharp tool: `Z` of the surface at the tool radius (Table 2-1, Chapter 3's maxima).
    None,
    /// FOREX4's model converged: the nose touches the gross arc, at `X1 = X R0 / (R0 - RT)`, and
    /// the command is the surface `Z` there. (The listing stops after three passes, 3.6e-9 in
    /// short of this `X1` at X = 8 in.)
    GrossArc,
    /// The nose circle rolls along the true meridian section `Y_t(., phi)` (the exact envelope
    /// for a nose in the meridian plane); see
    /// [`OffAxisParaboloid::z_tool_centre_envelope_in`].
    MeridianEnvelope,
}

/// Options of the accurate mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccurateOptions {
    /// Samples per revolution (FOREX4: 721).
    pub samples_per_rev: usize,
    /// Highest harmonic computed (Table 2-1: 19).
    pub max_order: usize,
    pub tool_nose: ToolNoseModel,
}

impl Default for AccurateOptions {
    fn default() -> Self {
        Self { samples_per_rev: 1440, max_order: 19, tool_nose: ToolNoseModel::MeridianEnvelope }
    }
}

/// The Z command for the tool centre at radius `x_tool_in` and spindle angle `phi_rad` under a
/// tool-nose model (the tool-nose radius is the paraboloid's).
pub fn z_command_in(
    par: &OffAxisParaboloid,
    x_tool_in: f64,
    phi_rad: f64,
    model: ToolNoseModel,
) -> Result<f64> {
    match model {
        ToolNoseModel::None => par.z_in(x_tool_in, phi_rad),
        ToolNoseModel::GrossArc => par.z_tool_centre_gross_arc_in(x_tool_in, phi_rad),
        ToolNoseModel::MeridianEnvelope => {
            par.z_tool_centre_envelope_in(x_tool_in, phi_rad).map(|(z, _)| z)
        }
    }
}

/// The harmonics of the Z command at tool-centre radius `x_tool_in`.
pub fn harmonics_at(
    par: &OffAxisParaboloid,
    x_tool_in: f64,
    opts: &AccurateOptions,
) -> Result<Harmonics> {
    let n = opts.samples_per_rev;
    let needed = 2 * opts.max_order.max(3) + 1;
    if n < needed {
        return Err(TurningError::TooFewSamples { order: opts.max_order.max(3), needed, got: n });
    }
    let v = (0..n)
        .map(|k| z_command_in(par, x_tool_in, 2.0 * PI * k as f64 / n as f64, opts.tool_nose))
        .collect::<Result<Vec<_>>>()?;
    dft(&v, opts.max_order.max(3))
}

/// An accurate table with the harmonics behind each row.
#[derive(Clone, Debug, PartialEq)]
pub struct AccurateTable {
    pub table: CoefficientTable,
    pub harmonics: Vec<Harmonics>,
    /// Largest [`Harmonics::neglected_in`] over the rows, in.
    pub max_neglected_in: f64,
}

/// The table over `0 <= X <= sector radius` in steps of `dx_in` (the last row is the sector
/// edge; `dx_in` must divide the radius to within 1e-9 in).
pub fn table(par: &OffAxisParaboloid, dx_in: f64, opts: &AccurateOptions) -> Result<AccurateTable> {
    let dx = positive("table step (in)", dx_in)?;
    let cells = par.sector_radius_in() / dx;
    let n = cells.round();
    if (cells - n).abs() * dx > 1e-9 || n < 1.0 {
        return Err(TurningError::Table("the step must divide the sector radius"));
    }
    table_over(par, 0.0, dx, n as usize + 1, opts)
}

/// The table at `x0_in + i dx_in`, `i = 0..rows`; every X must lie within the sector.
pub fn table_over(
    par: &OffAxisParaboloid,
    x0_in: f64,
    dx_in: f64,
    rows: usize,
    opts: &AccurateOptions,
) -> Result<AccurateTable> {
    let mut harmonics = Vec::with_capacity(rows);
    let limit = par.sector_radius_in();
    let table = CoefficientTable::from_fn(x0_in, dx_in, rows, |x| {
        if !(0.0..=limit + 1e-9).contains(&x) {
            return Err(TurningError::OutsideSurface { x_in: x, limit_in: limit });
        }
        let h = harmonics_at(par, x.min(limit), opts)?;
        let r = h.power_row();
        harmonics.push(h);
        Ok(r)
    })?;
    let max_neglected_in = harmonics.iter().map(Harmonics::neglected_in).fold(0.0, f64::max);
    Ok(AccurateTable { table, harmonics, max_neglected_in })
}
