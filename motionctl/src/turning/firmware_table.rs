//! f64 coefficient tables -> the firmware's fixed-point table
//! ([`motion::turning::CoefficientTable`]): coefficients in inches Q32, X in inches Q24, and the
//! Rust source of the checked-in const table `src/turning/douglass_table.rs`.

use super::accurate::{self, AccurateOptions, AccurateTable};
use super::fit::Harmonics;
use super::paraboloid::OffAxisParaboloid;
use super::table::CoefficientTable as F64Table;
use super::table_file::{Form, ZTable};
use super::{Result, TurningError};
use motion::turning::table::{CoefficientTable, TableForm, MAX_ORDER};
use std::fmt::Write;

/// 2^32: inches -> inches Q32.
pub const IN_Q32: f64 = 4_294_967_296.0;
/// 2^24: inches -> inches Q24.
pub const IN_Q24: f64 = 16_777_216.0;

/// Grid step of the checked-in table, in.
pub const DOUGLASS_DX_IN: f64 = 0.1;

fn q(v: f64, scale: f64, what: &'static str) -> Result<i32> {
    let s = (v * scale).round();
    if s.is_finite() && s.abs() <= i32::MAX as f64 {
        Ok(s as i32)
    } else {
        Err(TurningError::Table(what))
    }
}

fn grid(x0_in: f64, dx_in: f64) -> Result<(i32, i32)> {
    Ok((
        q(x0_in, IN_Q24, "table start X out of range")?,
        q(dx_in, IN_Q24, "table step out of range")?,
    ))
}

fn refused(e: motion::turning::TableError) -> TurningError {
    TurningError::Table(match e {
        motion::turning::TableError::RowCount => "more rows than the fixed-point table holds",
        motion::turning::TableError::Width => "row width does not match the form",
        motion::turning::TableError::Grid => "grid does not fit the fixed-point X range",
        motion::turning::TableError::Coefficient => "a coefficient is above 1/16 in",
    })
}

/// The power form (C00..C03) of an f64 table in fixed point.
pub fn power_table<const ROWS: usize>(t: &F64Table) -> Result<CoefficientTable<ROWS, 4>> {
    let (x0, dx) = grid(t.x0_in(), t.dx_in())?;
    let mut rows = [[0i32; 4]; ROWS];
    if t.len() > ROWS {
        return Err(refused(motion::turning::TableError::RowCount));
    }
    for (dst, r) in rows.iter_mut().zip(t.rows()) {
        for (d, v) in dst.iter_mut().zip(r.as_array()) {
            *d = q(v, IN_Q32, "coefficient out of range")?;
        }
    }
    CoefficientTable::try_new(TableForm::Power, x0, dx, t.len(), rows).map_err(refused)
}

/// The rows of a [`ZTable`] in fixed point, `WIDTH` coefficients each (the table's form must
/// have that width: 4 for the power form, `2 K + 1` for order `K`).
pub fn fixed_table<const ROWS: usize, const WIDTH: usize>(
    t: &ZTable,
) -> Result<CoefficientTable<ROWS, WIDTH>> {
    let form = match t.form {
        Form::Power => TableForm::Power,
        Form::Harmonic(order) => TableForm::Harmonic { order },
    };
    if form.width() != WIDTH {
        return Err(refused(motion::turning::TableError::Width));
    }
    if t.len() > ROWS {
        return Err(refused(motion::turning::TableError::RowCount));
    }
    let (x0, dx) = grid(t.x0_in, t.dx_in)?;
    let mut rows = [[0i32; WIDTH]; ROWS];
    for (dst, r) in rows.iter_mut().zip(&t.rows) {
        if r.len() != WIDTH {
            return Err(refused(motion::turning::TableError::Width));
        }
        for (d, v) in dst.iter_mut().zip(r) {
            *d = q(*v, IN_Q32, "a coefficient is above 1/16 in")?;
        }
    }
    CoefficientTable::try_new(form, x0, dx, t.len(), rows).map_err(refused)
}

/// The harmonic form `[a0, a1, b1, ..., aK, bK]` (`WIDTH = 2 K + 1`, `K <= 8`) from the
/// harmonics of each row (missing orders count as zero).
pub fn harmonic_table<const ROWS: usize, const WIDTH: usize>(
    x0_in: f64,
    dx_in: f64,
    harmonics: &[Harmonics],
) -> Result<CoefficientTable<ROWS, WIDTH>> {
    let order = (WIDTH - 1) / 2;
    if WIDTH.is_multiple_of(2) || order == 0 || order > MAX_ORDER {
        return Err(refused(motion::turning::TableError::Width));
    }
    if harmonics.len() > ROWS {
        return Err(refused(motion::turning::TableError::RowCount));
    }
    let (x0, dx) = grid(x0_in, dx_in)?;
    let mut rows = [[0i32; WIDTH]; ROWS];
    for (dst, h) in rows.iter_mut().zip(harmonics) {
        let c = |i: usize| h.cos_in.get(i).copied().unwrap_or(0.0);
        let s = |i: usize| h.sin_in.get(i).copied().unwrap_or(0.0);
        dst[0] = q(c(0), IN_Q32, "coefficient out of range")?;
        for k in 1..=order {
            dst[2 * k - 1] = q(c(k), IN_Q32, "coefficient out of range")?;
            dst[2 * k] = q(s(k), IN_Q32, "coefficient out of range")?;
        }
    }
    CoefficientTable::try_new(
        TableForm::Harmonic { order: order as u8 },
        x0,
        dx,
        harmonics.len(),
        rows,
    )
    .map_err(refused)
}

/// The accurate Douglass table (problem constants p = 79.15 in, S_y = 28 in, 16 in sector,
/// 0.125 in tool nose; meridian-envelope tool-centre command; 1440 samples per revolution) on
/// the 0.1 in grid, X = 0..8 in: 81 rows.
pub fn douglass_accurate() -> Result<AccurateTable> {
    accurate::table(
        &OffAxisParaboloid::douglass_problem(),
        DOUGLASS_DX_IN,
        &AccurateOptions::default(),
    )
}

/// Rows of the checked-in table.
pub const DOUGLASS_ROWS: usize = 81;

/// Rust source of `src/turning/douglass_table.rs` for a power-form table.
pub fn render_power_table<const ROWS: usize>(t: &CoefficientTable<ROWS, 4>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "//! GENERATED by motionctl (`turning::firmware_table`); do not edit. Regenerate with\n\
         //! `REGENERATE=1 cargo test -p motionctl --profile test-fast --test turning_firmware_table`.\n\
         //!\n\
         //! The accurate Douglass table (p = 79.15 in, S_y = 28 in, 16 in sector, 0.125 in tool\n\
         //! nose, tool-centre command on the meridian envelope, 1440 samples/rev), power form\n\
         //! `[C00, C01, C02, C03]` in inches Q32 at X = 0, 0.1, ..., 8.0 in (X in inches Q24).\n\
         \n\
         use super::table::{{CoefficientTable, TableForm}};\n\
         \n\
         /// Rows of [`DOUGLASS_POWER`].\n\
         pub const DOUGLASS_ROWS: usize = {};\n\
         \n\
         /// The Douglass coefficient table, power form, cubic-interpolation grade on 0.1 in.\n\
         #[rustfmt::skip]\n\
         pub static DOUGLASS_POWER: CoefficientTable<DOUGLASS_ROWS, 4> = match CoefficientTable::try_new(\n    \
         TableForm::Power,\n    {},\n    {},\n    {},\n    [",
        ROWS,
        t.x0_in_q24(),
        t.dx_in_q24(),
        t.len()
    );
    for i in 0..ROWS {
        let r = t.row(i).copied().unwrap_or([0; 4]);
        let _ = writeln!(s, "        [{}, {}, {}, {}],", r[0], r[1], r[2], r[3]);
    }
    let _ = writeln!(
        s,
        "    ],\n) {{\n    Ok(t) => t,\n    Err(_) => panic!(\"generated Douglass table is invalid\"),\n}};"
    );
    s
}
