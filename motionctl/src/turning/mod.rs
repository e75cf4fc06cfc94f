//! Coefficient tables for the Z slide (fast tool servo) of non-axisymmetric turning, after
//! Douglass (1983), "Turning nonaxisymmetric surfaces" (seed `001_9e11c93b2d4b1fed.txt`).
//!
//! The Z slide follows `Z(X, phi) = C00(X) + C01(X) s + C02(X) s^2 + C03(X) s^3`, `s = sin(phi)`,
//! with the four coefficients looked up in a table over the radial position `X` (eq 2-19). This
//! module builds such tables on the host:
//!
//! * [`paraboloid`]: the off-axis paraboloid of the thesis (focal length, offset, sector size,
//!   tool-nose radius), eqs 2-1..2-15 in a cancellation-free form, and tool-nose compensation.
//! * [`forex4`]: the FORTRAN program FOREX4 of Appendix B-1 (with the SSP routine FORIF)
//!   transcribed statement by statement; it reproduces Table 2-2 digit for digit.
//! * [`accurate`]: the same table computed accurately (exact constants, converged tool-nose
//!   geometry, cancellation-free evaluation, more samples).
//! * [`fit`]: harmonic fit of any surface `z(x, y)`, given as a function or as a grid.
//! * [`table`]: tables over `X` on a uniform grid, the power form C00..C03, linear and cubic
//!   interpolation with their error figures, the thesis print format and a firmware export.
//!
//! * [`csmp`]: the Z-servo CSMP runs of Appendix C (a small linear-system simulator).
//!
//! Units: lengths in inches (`_in`), angles in radians (`_rad`) unless a name says otherwise.

pub mod accurate;
pub mod cli;
pub mod csmp;
pub mod figure;
pub mod firmware_table;
pub mod fit;
pub mod forex4;
pub mod paraboloid;
pub mod part;
pub mod profile;
pub mod run;
pub mod table;
pub mod table_file;
pub use crate::units;

pub use accurate::{AccurateOptions, ToolNoseModel};
pub use fit::{CartesianGrid, Harmonics};
pub use paraboloid::OffAxisParaboloid;
pub use table::{CoefficientTable, ExportRow, ExportTable, Interpolation, PowerRow};

/// Everything that can go wrong while building a table. No function of this module panics on
/// bad input; it returns one of these.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TurningError {
    #[error("{name} must be finite and > 0 (got {value})")]
    NotPositive { name: &'static str, value: f64 },
    #[error("{name} must be finite and >= 0 (got {value})")]
    Negative { name: &'static str, value: f64 },
    #[error("{name} must be finite (got {value})")]
    NotFinite { name: &'static str, value: f64 },
    #[error(
        "radius {x_in} in is outside the paraboloid sector (the surface is defined for \
         0 <= X <= {limit_in} in)"
    )]
    OutsideSurface { x_in: f64, limit_in: f64 },
    #[error("tool-nose radius {tool_nose_radius_in} in does not fit the surface ({reason})")]
    ToolNose { tool_nose_radius_in: f64, reason: &'static str },
    #[error("tool-nose compensation did not converge at X = {x_in} in")]
    NoConvergence { x_in: f64 },
    #[error("harmonic order {order} needs at least {needed} samples per revolution (got {got})")]
    TooFewSamples { order: usize, needed: usize, got: usize },
    #[error("FORIF: M = {m} must satisfy 0 <= M <= N = {n} (IER = {ier})")]
    Forif { n: usize, m: usize, ier: u8 },
    #[error("grid: {0}")]
    Grid(&'static str),
    #[error("point ({x_in}, {y_in}) in is outside the grid")]
    OutsideGrid { x_in: f64, y_in: f64 },
    #[error("surface function returned a non-finite value at X = {x_in} in, phi = {phi_rad} rad")]
    SurfaceNotFinite { x_in: f64, phi_rad: f64 },
    #[error("table: {0}")]
    Table(&'static str),
    #[error("X = {x_in} in is outside the table ({first_in} .. {last_in} in)")]
    OutsideTable { x_in: f64, first_in: f64, last_in: f64 },
}

pub type Result<T> = core::result::Result<T, TurningError>;

pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(TurningError::NotPositive { name, value })
    }
}

pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(TurningError::Negative { name, value })
    }
}

pub(crate) fn finite(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(TurningError::NotFinite { name, value })
    }
}
