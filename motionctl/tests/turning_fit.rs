//! Generic mode: harmonics of any surface z(x, y), from a function or a grid.

use motionctl::turning::accurate::{table, AccurateOptions, ToolNoseModel};
use motionctl::turning::fit::{dft, fit_ring, table_from_surface, GrossPath, SurfaceFitOptions};
use motionctl::turning::{CartesianGrid, OffAxisParaboloid, PowerRow, TurningError};

fn sharp() -> OffAxisParaboloid {
    OffAxisParaboloid::douglass_listing().with_tool_nose_radius(0.0).unwrap()
}

fn max_row_diff(a: &[PowerRow], b: &[PowerRow]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.as_array().into_iter().zip(y.as_array()).map(|(u, v)| (u - v).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn paraboloid_as_a_function_of_x_y_gives_the_accurate_table() {
    // The surface from the direct transform (eqs 2-1..2-3 solved for z3), fitted as an arbitrary
    // z(x, y) with the thesis's gross path (the maximum over a revolution), gives the accurate
    // mode's sharp-tool table.
    let p = sharp();
    let fit =
        table_from_surface(|x, y| p.direct_z3_in(x, y), &SurfaceFitOptions::default()).unwrap();
    let opts = AccurateOptions { tool_nose: ToolNoseModel::None, ..Default::default() };
    let acc = table(&p, 0.1, &opts).unwrap();
    let d = max_row_diff(fit.table.rows(), acc.table.rows());
    assert!(d < 1e-12, "{d:e}");
    // the gross path found is eq 2-14
    for (i, y) in fit.gross_y_in.iter().enumerate() {
        let x = i as f64 * 0.1;
        assert!((y - p.gross_y_in(x).unwrap()).abs() < 1e-13, "X = {x}");
    }
    assert!(fit.max_neglected_in < 6e-8);
}

#[test]
fn paraboloid_sampled_on_a_grid() {
    // The same surface known only on a 0.05 in square grid: bicubic interpolation of the grid
    // costs well under a microinch on the coefficients.
    let p = sharp();
    let h = 0.05;
    let n = 333; // -8.3 .. 8.3 in
    let grid = CartesianGrid::sample(-8.3, -8.3, h, h, n, n, |x, y| p.direct_z3_in(x, y)).unwrap();
    let opts =
        SurfaceFitOptions { dx_in: 2.0, rows: 5, samples_per_rev: 720, ..Default::default() };
    let fit = table_from_surface(|x, y| grid.eval_in(x, y), &opts).unwrap();
    let exact = table_from_surface(|x, y| p.direct_z3_in(x, y), &opts).unwrap();
    let d = max_row_diff(fit.table.rows(), exact.table.rows());
    eprintln!("grid 0.05 in: coefficients within {:.1e} uin", d * 1e6);
    assert!(d < 0.01e-6, "{d:e}");
    // Off the grid is an error, not an extrapolation.
    let wide = SurfaceFitOptions { dx_in: 9.0, rows: 2, ..opts };
    assert!(matches!(
        table_from_surface(|x, y| grid.eval_in(x, y), &wide),
        Err(TurningError::OutsideGrid { .. })
    ));
}

#[test]
fn gross_path_choices() {
    // z = 1e-3 (x^2 - y^2) + 2e-4 y: C2 = 1e-3 X^2, S1 = 2e-4 X.
    let z = |x: f64, y: f64| Ok(1e-3 * (x * x - y * y) + 2e-4 * y);
    let x = 3.0;
    let h = fit_ring(z, x, 64, 4).unwrap();
    assert!((h.cos_in[2] - 1e-3 * x * x).abs() < 1e-15);
    assert!((h.sin_in[1] - 2e-4 * x).abs() < 1e-15);
    assert!(h.neglected_in() < 1e-15);
    let c2 = 1e-3 * x * x;
    let s1 = 2e-4 * x;
    for (gross, want_c00) in [
        // C00 = C0 + C2 with C0 = 0
        (GrossPath::None, c2),
        (GrossPath::Mean, c2),
        // max of C2 cos 2phi + S1 sin phi = C2 (1 - 2 s^2) + S1 s is C2 + S1^2 / (8 C2)
        (GrossPath::MaxOverPhi, -s1 * s1 / (8.0 * c2)),
    ] {
        let opts = SurfaceFitOptions {
            x0_in: x,
            rows: 1,
            samples_per_rev: 64,
            max_order: 4,
            gross,
            ..Default::default()
        };
        let r = table_from_surface(z, &opts).unwrap().table.rows()[0];
        assert!((r.c00_in - want_c00).abs() < 1e-15, "{gross:?}: {} vs {want_c00}", r.c00_in);
    }
}

#[test]
fn terms_the_power_form_cannot_carry_are_reported() {
    // A tilted plane needs C1 (cos phi), which sin-power form cannot produce.
    let t = table_from_surface(
        |x, _| Ok(1e-4 * x),
        &SurfaceFitOptions {
            rows: 3,
            dx_in: 1.0,
            samples_per_rev: 32,
            max_order: 4,
            ..Default::default()
        },
    )
    .unwrap();
    assert!((t.max_neglected_in - 2e-4).abs() < 1e-15);
}

#[test]
fn bad_input_is_an_error() {
    assert!(matches!(dft(&[1.0, 2.0, 3.0], 2), Err(TurningError::TooFewSamples { .. })));
    assert!(dft(&[1.0, f64::NAN, 3.0, 4.0, 5.0], 2).is_err());
    assert!(fit_ring(|_, _| Ok(f64::INFINITY), 1.0, 16, 3).is_err());
    assert!(fit_ring(|_, _| Ok(0.0), -1.0, 16, 3).is_err());
    assert!(CartesianGrid::new(0.0, 0.0, 1.0, 1.0, 3, 3, vec![0.0; 8]).is_err());
    assert!(CartesianGrid::new(0.0, 0.0, 1.0, 1.0, 2, 2, vec![0.0; 4]).is_err());
    assert!(CartesianGrid::new(0.0, 0.0, -1.0, 1.0, 3, 3, vec![0.0; 9]).is_err());
    assert!(CartesianGrid::new(0.0, 0.0, 1.0, 1.0, 3, 3, vec![f64::NAN; 9]).is_err());
    let g = CartesianGrid::new(0.0, 0.0, 1.0, 1.0, 3, 3, vec![0.0; 9]).unwrap();
    assert!(g.eval_in(2.5, 1.0).is_err());
    assert!(g.eval_in(f64::NAN, 1.0).is_err());
    let opts = SurfaceFitOptions { x0_in: -1.0, ..Default::default() };
    assert!(table_from_surface(|_, _| Ok(0.0), &opts).is_err());
}

#[test]
fn grid_interpolation_reproduces_quadratics() {
    let f = |x: f64, y: f64| 0.3 + 0.1 * x - 0.2 * y + 0.05 * x * x - 0.07 * x * y + 0.02 * y * y;
    let g = CartesianGrid::sample(-1.0, -2.0, 0.5, 0.25, 5, 17, |x, y| Ok(f(x, y))).unwrap();
    for (x, y) in [(-1.0, -2.0), (-0.9, -1.9), (0.3, 0.1), (1.0, 2.0), (0.77, 1.93)] {
        assert!((g.eval_in(x, y).unwrap() - f(x, y)).abs() < 1e-13, "({x}, {y})");
    }
}
