//! The turning table's figure: the Z command against the spindle angle at a few X stations, and
//! the part error (the table, cubic between rows as the board interpolates, against the exact
//! command) along X; lengths in the user's units.

use super::part::Built;
use super::units::Units;
use crate::plot::{Figure, Panel, Series, Style};

/// Stations: these fractions of the table's X range (snapped to the nearest row).
const STATIONS: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
/// Spindle angles per curve.
const PHI_POINTS: usize = 361;

/// The figure of `built` titled `title`; `error` is [`super::part::part_error`]'s profile.
pub fn table_figure(built: &Built, error: &[(f64, f64)], units: Units, title: &str) -> Figure {
    let t = &built.table;
    let u = units.name();
    let mut z = Panel::new(
        "Z command over one revolution",
        "spindle angle, deg",
        format!("Z command, {u}"),
    );
    let last = t.len().saturating_sub(1);
    let mut rows: Vec<usize> =
        STATIONS.iter().map(|f| (f * last as f64).round() as usize).collect();
    rows.dedup();
    for (k, &row) in rows.iter().enumerate() {
        let x = t.x_at(row);
        let points = (0..PHI_POINTS)
            .filter_map(|j| {
                let deg = 360.0 * j as f64 / (PHI_POINTS - 1) as f64;
                t.z_in(x, deg.to_radians()).map(|z| (deg, units.from_in(z)))
            })
            .collect();
        let style = if k % 2 == 0 { Style::Line } else { Style::Dashed };
        z = z.with(Series::styled(format!("X = {:.3} {u}", units.from_in(x)), points, style));
    }
    // Micro-units, or nano-units when the error is far below one.
    let worst = error.iter().fold(0.0f64, |m, p| m.max(p.1));
    let (micro, per_in) =
        if worst * units.micro().1 >= 0.01 { units.micro() } else { units.nano() };
    let err = Panel::new(
        "part error: table (cubic between rows) vs exact command, worst over the revolution",
        format!("X, {u}"),
        format!("error, {micro}"),
    )
    .with(Series::line(
        "|Z table - Z exact|",
        error.iter().map(|&(x, e)| (units.from_in(x), e * per_in)).collect(),
    ))
    .with(Series::styled(
        "table rows",
        (0..t.len())
            .filter_map(|i| {
                let x = t.x_at(i);
                error
                    .iter()
                    .find(|p| (p.0 - x).abs() < 1e-12)
                    .map(|p| (units.from_in(x), p.1 * per_in))
            })
            .collect(),
        Style::Points,
    ));
    Figure::new(title).panel(z).panel(err)
}
