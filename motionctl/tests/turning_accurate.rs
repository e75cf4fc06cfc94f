//! Accurate mode against Table 2-1 and against the thesis-exact mode.

use motionctl::turning::accurate::{harmonics_at, table, AccurateOptions, ToolNoseModel};
use motionctl::turning::forex4::{forex4_table, format_for30, Forex4Params};
use motionctl::turning::{OffAxisParaboloid, TurningError};

/// Table 2-1 as printed (seed l.413-436): `(i, C_i, S_i)`; `S_0` is blank.
fn table_2_1() -> Vec<(usize, f64, Option<f64>)> {
    let parse = |s: &str| -> f64 { s.replace(' ', "").parse().unwrap() };
    let rows: Vec<_> = include_str!("data/turning/table_2_1.txt")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let s = f.get(2).map(|s| s.trim()).filter(|s| !s.is_empty()).map(parse);
            (f[0].parse().unwrap(), parse(f[1]), s)
        })
        .collect();
    assert_eq!(rows.len(), 20);
    rows
}

#[test]
fn table_2_1_at_x_8() {
    // Table 2-1: X = 8, sharp tool (eq 2-15), c = 316.7, N = 19. The thesis's library routine ran
    // in lower precision: every entry except C0, S1, C2, S3 and C4 is noise of about 1e-9 (the
    // true values are < 3e-10). Checks: every printed value within 5e-8 of ours; the significant
    // ones closer (C0 is the loosest: 2.5e-8, printed -3.129212e-3, ours -3.129237e-3); the
    // noise entries below 2e-9 in both.
    let p = OffAxisParaboloid::douglass_listing().with_tool_nose_radius(0.0).unwrap();
    let opts =
        AccurateOptions { samples_per_rev: 1440, max_order: 19, tool_nose: ToolNoseModel::None };
    let h = harmonics_at(&p, 8.0, &opts).unwrap();
    let significant_tol = |kind: char, i: usize| match (kind, i) {
        ('C', 0) => Some(3e-8),
        ('S', 1) => Some(5e-9),
        ('C', 2) | ('S', 3) | ('C', 4) => Some(1e-9),
        _ => None,
    };
    for (i, c_printed, s_printed) in table_2_1() {
        for (kind, printed, ours) in
            [('C', Some(c_printed), h.cos_in[i]), ('S', s_printed, h.sin_in[i])]
        {
            let Some(printed) = printed else { continue };
            let d = (printed - ours).abs();
            eprintln!("{kind}{i}: printed {printed:e}, ours {ours:e}, diff {d:.1e}");
            assert!(d < 5e-8, "{kind}{i}");
            match significant_tol(kind, i) {
                Some(tol) => assert!(d < tol, "{kind}{i}: {d:e}"),
                None => assert!(printed.abs() < 2e-9 && ours.abs() < 2e-9, "{kind}{i}"),
            }
        }
    }
    // C1 and S2 vanish identically (Z(phi) = Z(pi - phi)): ours are rounding-level.
    assert!(h.cos_in[1].abs() < 1e-15 && h.sin_in[2].abs() < 1e-15);
}

#[test]
fn accurate_gross_arc_mode_agrees_with_the_thesis_exact_mode() {
    // Same model as FOREX4 (c = 316.7, gross-arc tool nose) but converged, exact pi, direct DFT
    // of 1440 samples: the coefficients agree to 1e-9 in and print Table 2-2 identically.
    let p = OffAxisParaboloid::douglass_listing();
    let opts = AccurateOptions { tool_nose: ToolNoseModel::GrossArc, ..Default::default() };
    let acc = table(&p, 0.1, &opts).unwrap();
    let thesis = forex4_table(&Forex4Params::listing()).unwrap();
    assert_eq!(acc.table.len(), 81);
    let worst = acc
        .table
        .rows()
        .iter()
        .zip(thesis.rows())
        .flat_map(|(a, b)| a.as_array().into_iter().zip(b.as_array()).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "{worst:e}");
    assert_eq!(format_for30(&acc.table), format_for30(&thesis));
    // The four-term form drops 5.5e-8 in at most (C4 at X = 8).
    assert!(acc.max_neglected_in < 6e-8, "{:e}", acc.max_neglected_in);
}

#[test]
fn accurate_envelope_mode_moves_the_table_by_less_than_two_tenths_of_a_microinch() {
    let p = OffAxisParaboloid::douglass_listing();
    let acc = table(&p, 0.1, &AccurateOptions::default()).unwrap();
    let thesis = forex4_table(&Forex4Params::listing()).unwrap();
    let worst = acc
        .table
        .rows()
        .iter()
        .zip(thesis.rows())
        .flat_map(|(a, b)| a.as_array().into_iter().zip(b.as_array()).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    eprintln!("envelope vs Table 2-2 model: {:.3} uin", worst * 1e6);
    assert!(worst < 0.2e-6, "{worst:e}");
}

#[test]
fn problem_statement_focal_length_gives_a_different_table() {
    // p = 79.15 (c = 316.6) as the problem statement says; the listing's c = 316.7 is 0.03 %
    // off, up to 5.6 uin on C02 at X = 8.
    let a =
        table(&OffAxisParaboloid::douglass_problem(), 0.1, &AccurateOptions::default()).unwrap();
    let b =
        table(&OffAxisParaboloid::douglass_listing(), 0.1, &AccurateOptions::default()).unwrap();
    let d = (a.table.rows()[80].c02_in - b.table.rows()[80].c02_in).abs();
    assert!(d > 5e-6 && d < 6e-6, "{d:e}");
}

#[test]
fn accurate_mode_rejects_bad_requests() {
    let p = OffAxisParaboloid::douglass_listing();
    let few = AccurateOptions { samples_per_rev: 8, ..Default::default() };
    assert!(matches!(harmonics_at(&p, 1.0, &few), Err(TurningError::TooFewSamples { .. })));
    assert!(table(&p, 0.3, &AccurateOptions::default()).is_err()); // does not divide 8 in
    assert!(table(&p, -0.1, &AccurateOptions::default()).is_err());
    assert!(harmonics_at(&p, -1.0, &AccurateOptions::default()).is_err());
    assert!(harmonics_at(&p, 500.0, &AccurateOptions::default()).is_err());
}
