//! Coefficient tables: power form, interpolation and its error figures (Douglass 1983, end of
//! Chapter 2 and Chapter 3), export.

use motionctl::turning::accurate::{z_command_in, ToolNoseModel};
use motionctl::turning::forex4::{forex4_table, Forex4Params};
use motionctl::turning::table::InterpolationError;
use motionctl::turning::{
    CoefficientTable, Interpolation, OffAxisParaboloid, PowerRow, TurningError,
};
use std::f64::consts::PI;

/// FOREX4 table on a `step_in` grid over 0..8 in, and the error of interpolating it against
/// the exact command of the same tool-nose model.
fn error_on_grid(
    step_in: f64,
    rt_in: f64,
    interp: Interpolation,
    round_to_7: bool,
) -> InterpolationError {
    let rows = (8.0 / step_in).round() as usize + 1;
    let params = Forex4Params {
        x_step_in: step_in,
        rows,
        tool_nose_radius_in: rt_in,
        ..Forex4Params::listing()
    };
    let mut t = forex4_table(&params).unwrap();
    if round_to_7 {
        t = t.rounded(1e-7).unwrap();
    }
    let p = OffAxisParaboloid::douglass_listing().with_tool_nose_radius(rt_in).unwrap();
    let model = if rt_in == 0.0 { ToolNoseModel::None } else { ToolNoseModel::GrossArc };
    t.interpolation_error(|x, phi| z_command_in(&p, x, phi, model), interp, 360, 10).unwrap()
}

fn uin(v: f64) -> String {
    format!("{:.2}", v * 1e6)
}

#[test]
fn linear_interpolation_error_on_the_thesis_grid() {
    // Seed l.578: "The maximum deviation from theoretical Z(X,phi) is seen to be 0.1 microinch at
    // the interpolation endpoints ... the maximum error occurs approximately midway between the
    // interpolation endpoints and varies up to slightly less than one-half microinch."
    for rt in [0.0, 0.125] {
        let exact = error_on_grid(0.1, rt, Interpolation::Linear, false);
        let printed = error_on_grid(0.1, rt, Interpolation::Linear, true);
        eprintln!(
            "RT = {rt}: nodes {} uin (table rounded to 7 decimals: {}), mid-cell {} uin ({}), \
             worst at X = {:.3}, phi = {:.0} deg",
            uin(exact.max_at_nodes_in),
            uin(printed.max_at_nodes_in),
            uin(exact.max_mid_interval_in),
            uin(printed.max_mid_interval_in),
            exact.worst_x_in,
            exact.worst_phi_rad.to_degrees()
        );
        // At the nodes only the dropped harmonics (C4 = 5.5e-8 at X = 8) and, for the printed
        // table, the 7-decimal rounding remain: ~0.1 uin.
        assert!(exact.max_at_nodes_in < 0.06e-6);
        assert!(printed.max_at_nodes_in > 0.05e-6 && printed.max_at_nodes_in < 0.2e-6);
        // Mid-cell: slightly less than half a microinch.
        assert!(exact.max_mid_interval_in > 0.35e-6 && exact.max_mid_interval_in < 0.5e-6);
        assert!(printed.max_mid_interval_in < 0.5e-6);
        assert_eq!(exact.max_in, exact.max_mid_interval_in.max(exact.max_in));
        assert!((exact.worst_x_in - 7.95).abs() < 0.051);
    }
}

#[test]
fn coarser_grids_exceed_one_microinch() {
    // Seed l.738: "Excess errors (greater than 1 microinch) were found for interval widths of .25
    // and .2 inch". The digest recomputed 1.75 and 2.76 uin (sharp tool, unrounded table).
    let e2 = error_on_grid(0.2, 0.0, Interpolation::Linear, false);
    let e25 = error_on_grid(0.25, 0.0, Interpolation::Linear, false);
    assert!(e2.max_in > 1e-6 && e25.max_in > 1e-6);
    assert_eq!(uin(e2.max_in), "1.75");
    assert_eq!(uin(e25.max_in), "2.76");
}

#[test]
fn cubic_interpolation_leaves_only_the_series_truncation() {
    // Not in the thesis: four-point cubic interpolation of the same 0.1 in table is as good as
    // the nodes, and even a 0.25 in grid stays below 0.06 uin.
    for step in [0.1, 0.25] {
        let e = error_on_grid(step, 0.125, Interpolation::Cubic, false);
        eprintln!("cubic, {step} in grid: {} uin", uin(e.max_in));
        assert!(e.max_in < 0.06e-6, "{step}: {:e}", e.max_in);
    }
}

#[test]
fn the_8080_update_scheme_adds_little() {
    // Appendix A: C02 every 0.0005 in, C01 every 0.001 in, C00 and C03 every 0.010 in.
    let e = error_on_grid(0.1, 0.125, Interpolation::ThesisUpdates, true);
    eprintln!("8080 updates: {} uin", uin(e.max_in));
    assert!(e.max_in < 0.6e-6, "{:e}", e.max_in);
    // Between update points the coefficients hold: just below an update point they lag.
    let t = forex4_table(&Forex4Params::listing()).unwrap();
    let held = t.coefficients_at(7.9004, Interpolation::ThesisUpdates).unwrap();
    let at = t.coefficients_at(7.9000, Interpolation::Linear).unwrap();
    assert_eq!(held.c00_in, at.c00_in);
    assert_eq!(held.c01_in, at.c01_in);
    assert_eq!(held.c02_in, at.c02_in);
    let stepped = t.coefficients_at(7.9005, Interpolation::ThesisUpdates).unwrap();
    let lin = t.coefficients_at(7.9005, Interpolation::Linear).unwrap();
    assert!((stepped.c02_in - lin.c02_in).abs() < 1e-15);
}

#[test]
fn power_form_is_the_four_term_series() {
    // Eqs 2-20..2-23: C00 = C0 + C2, C01 = S1 + 3 S3, C02 = -2 C2, C03 = -4 S3.
    let (c0, s1, c2, s3) = (-3.1e-3, -1.6e-3, 3.0e-3, -1.3e-5);
    let r = PowerRow::from_harmonics(c0, s1, c2, s3);
    assert_eq!(
        r,
        PowerRow { c00_in: c0 + c2, c01_in: s1 + 3.0 * s3, c02_in: -2.0 * c2, c03_in: -4.0 * s3 }
    );
    for k in 0..64 {
        let phi = 2.0 * PI * k as f64 / 64.0;
        let series = c0 + s1 * phi.sin() + c2 * (2.0 * phi).cos() + s3 * (3.0 * phi).sin();
        assert!((r.eval_in(phi.sin()) - series).abs() < 1e-17);
    }
    let (a, b, c, d) = r.to_harmonics();
    assert!((a - c0).abs() < 1e-18 && (b - s1).abs() < 1e-18 && c == c2 && d == s3);
}

#[test]
fn export_round_trip_and_range_checks() {
    let t = forex4_table(&Forex4Params::listing()).unwrap();
    let e = t.export();
    assert_eq!(e.rows.len(), 81);
    assert_eq!(e.rows[80].x_in, 8.0);
    assert_eq!(e.rows[40].c02_in, t.rows()[40].c02_in);
    assert_eq!(e.to_table().unwrap(), t);
    let mut bent = e.clone();
    bent.rows[3].x_in += 0.01;
    assert!(bent.to_table().is_err());

    assert!(matches!(
        t.coefficients_at(8.01, Interpolation::Linear),
        Err(TurningError::OutsideTable { .. })
    ));
    assert!(t.coefficients_at(-0.01, Interpolation::Cubic).is_err());
    assert!(t.coefficients_at(f64::NAN, Interpolation::Linear).is_err());
    assert!(t.z_in(1.0, f64::INFINITY, Interpolation::Linear).is_err());
    // Nodes are returned exactly by every scheme.
    for interp in [Interpolation::Linear, Interpolation::Cubic, Interpolation::ThesisUpdates] {
        assert_eq!(t.coefficients_at(8.0, interp).unwrap(), t.rows()[80]);
        let r = t.coefficients_at(t.x_at(37), interp).unwrap();
        for (a, b) in r.as_array().iter().zip(t.rows()[37].as_array()) {
            assert!((a - b).abs() < 1e-18, "{interp:?}");
        }
    }
    assert!(CoefficientTable::new(0.0, 0.0, vec![PowerRow::default()]).is_err());
    assert!(CoefficientTable::new(0.0, 0.1, vec![]).is_err());
    assert!(CoefficientTable::new(
        0.0,
        0.1,
        vec![PowerRow { c00_in: f64::NAN, ..Default::default() }]
    )
    .is_err());
    let d = t.decimated(2).unwrap();
    assert_eq!((d.len(), d.dx_in()), (41, 0.2));
}
