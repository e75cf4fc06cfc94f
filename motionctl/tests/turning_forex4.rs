//! Thesis-exact mode (FOREX4 + FORIF of Douglass 1983, Appendix B-1) against the thesis's own
//! printed numbers, stored verbatim from the seed under `tests/data/turning/`.

use motionctl::turning::forex4::{
    forex4, forex4_table, forif, format_for30, fortran_f, Forex4Params,
};
use motionctl::turning::TurningError;

/// Rows of Table 2-2 as printed (seed l.481-568): `X, C00, C01, C02, C03` strings.
fn table_2_2() -> Vec<[String; 5]> {
    let text = include_str!("data/turning/table_2_2.txt");
    let rows: Vec<[String; 5]> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 5, "malformed Table 2-2 line {l:?}");
            std::array::from_fn(|k| f[k].to_string())
        })
        .collect();
    assert_eq!(rows.len(), 81, "Table 2-2 has 81 rows, X = 0.0 .. 8.0");
    rows
}

/// Our FOR30.DAT lines split into their five fields (FORTRAN pads with blanks; the seed's OCR
/// turned the table into tab-separated fields without them).
fn fields(line: &str) -> [String; 5] {
    let f: Vec<&str> = line.split('|').collect();
    assert_eq!(f.len(), 5);
    std::array::from_fn(|k| f[k].trim().to_string())
}

fn mismatches(params: &Forex4Params) -> Vec<(String, String)> {
    let table = forex4_table(params).unwrap();
    let ours = format_for30(&table);
    let mut bad = vec![];
    for (line, printed) in ours.iter().zip(table_2_2()) {
        let f = fields(line);
        for k in 0..5 {
            if f[k] != printed[k] {
                bad.push((line.clone(), printed.join(" ")));
            }
        }
    }
    bad
}

#[test]
fn table_2_2_is_reproduced_string_exact() {
    // All 81 x 5 fields (81 X values, 324 coefficients) compare equal as printed strings.
    // No value of the seed's Table 2-2 is OCR-damaged.
    //
    // The only subtlety is X = 0, where every coefficient is exactly zero: IEEE arithmetic gives
    // C02 = -2.*C2 = -0.0 and C03 = -4.0*S3 = -0.0 there, which a modern printf prints as
    // "-0.0000000"; the thesis prints "0.0000000" because the DEC formats of 1983 had no negative
    // zero. `fortran_f` prints zero unsigned (and keeps the sign of tiny negatives, which the
    // thesis prints as "-0.0000000" from X = 0.1 on).
    let bad = mismatches(&Forex4Params::listing());
    assert!(bad.is_empty(), "{} fields differ: {bad:#?}", bad.len());
}

#[test]
fn table_2_2_does_not_depend_on_the_literal_precision_or_pi() {
    // The REAL*4 reading of the listing's literals, exact pi, and iterating the tool-nose fixed
    // point to convergence all print the same table.
    assert!(mismatches(&Forex4Params::single_precision_literals()).is_empty());
    assert!(mismatches(&Forex4Params { pi: std::f64::consts::PI, ..Forex4Params::listing() })
        .is_empty());
    assert!(mismatches(&Forex4Params { iterations: 50, ..Forex4Params::listing() }).is_empty());
}

#[test]
fn table_2_2_needs_the_listings_c_and_the_tool_nose_compensation() {
    // c = 4 x 79.15 = 316.6 (the problem statement) or a sharp tool do not give Table 2-2: the
    // printed table is the listing's c = 316.7 with RT = 0.125 in.
    let c_316_6 = mismatches(&Forex4Params { c_in: 316.6, ..Forex4Params::listing() });
    let sharp = mismatches(&Forex4Params { tool_nose_radius_in: 0.0, ..Forex4Params::listing() });
    eprintln!("c = 316.6: {} fields differ; RT = 0: {} fields differ", c_316_6.len(), sharp.len());
    assert!(c_316_6.len() > 100);
    assert!(sharp.len() > 100);
}

#[test]
fn chapter_3_maxima_are_the_uncompensated_x_8_row() {
    // Seed l.714-720 gives C00..C03 at X = 8 as -.0001195, -.0016976, -.0060195, .0000514, which
    // differ from Table 2-2's last row: they are FOREX4 with RT = 0 (no tool-nose compensation).
    let text = include_str!("data/turning/ch3_maxima.txt");
    let printed: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with("$$C_{0"))
        .map(|l| l.split('=').nth(1).unwrap().trim().trim_end_matches("$$").to_string())
        .collect();
    assert_eq!(printed.len(), 4);
    let rows =
        forex4(&Forex4Params { tool_nose_radius_in: 0.0, ..Forex4Params::listing() }).unwrap();
    let last = rows.last().unwrap();
    assert_eq!(last.x_in, 8.0);
    for (k, v) in last.power.as_array().iter().enumerate() {
        // The chapter drops FORTRAN's leading zero: "-.0001195".
        let ours = fortran_f(*v, 10, 7).trim().replacen("0.", ".", 1);
        assert_eq!(ours, printed[k], "C0{k}");
    }
}

#[test]
fn listing_contact_radius_at_x_8() {
    // Not printed in the thesis (FOREX4 wrote it to unit 5). Three passes leave X1 = 8.00622349,
    // 3.6e-9 in short of the converged X R0 / (R0 - RT) = 8.00622349(28).
    let rows = forex4(&Forex4Params::listing()).unwrap();
    let r = &rows[80];
    assert_eq!(format!("{:.8}", r.x1_in), "8.00622349");
    assert!((r.xtc_in - 8.0).abs() < 1e-8, "tool centre {}", r.xtc_in);
    let par = motionctl::turning::OffAxisParaboloid::douglass_listing();
    let converged = par.contact_radius_gross_arc_in(8.0).unwrap();
    assert!((converged - r.x1_in) > 0.0 && (converged - r.x1_in) < 1e-8);
}

#[test]
fn forif_recovers_a_trigonometric_polynomial() {
    let f = |x: f64| 0.5 - 0.25 * x.sin() + 0.125 * (2.0 * x).cos() + 1e-3 * (3.0 * x).sin();
    let (a, b) = forif(f, 360, 4, std::f64::consts::PI).unwrap();
    let want_a = [0.5, 0.0, 0.125, 0.0, 0.0];
    let want_b = [0.0, -0.25, 0.0, 1e-3, 0.0];
    for j in 0..5 {
        assert!((a[j] - want_a[j]).abs() < 1e-12, "A({j}) = {}", a[j]);
        assert!((b[j] - want_b[j]).abs() < 1e-12, "B({j}) = {}", b[j]);
    }
    assert!(matches!(forif(f, 3, 4, 3.0), Err(TurningError::Forif { ier: 1, .. })));
}

#[test]
fn fortran_f_format() {
    assert_eq!(fortran_f(-0.0, 10, 7), " 0.0000000");
    assert_eq!(fortran_f(-1e-9, 10, 7), "-0.0000000");
    assert_eq!(fortran_f(5.15e-5, 10, 7), " 0.0000515");
    assert_eq!(fortran_f(8.0, 4, 1), " 8.0");
    assert_eq!(fortran_f(-123.0, 4, 1), "****");
}

#[test]
fn bad_parameters_are_errors() {
    let l = Forex4Params::listing();
    for p in [
        Forex4Params { c_in: -316.7, ..l },
        Forex4Params { c_in: f64::NAN, ..l },
        Forex4Params { offset_in: 0.0, ..l },
        Forex4Params { tool_nose_radius_in: -0.1, ..l },
        Forex4Params { iterations: 0, ..l },
        Forex4Params { rows: 0, ..l },
        Forex4Params { m: 2, ..l },
        Forex4Params { n: 3, m: 4, ..l },
        Forex4Params { x_step_in: 0.0, ..l },
    ] {
        assert!(forex4(&p).is_err(), "{p:?}");
    }
    // X beyond the paraboloid: the square root goes negative; an error, not a NaN table.
    let far = Forex4Params { x_step_in: 10.0, rows: 30, ..l };
    assert!(
        matches!(forex4(&far), Err(TurningError::SurfaceNotFinite { .. })),
        "{:?}",
        forex4(&far).err()
    );
}
