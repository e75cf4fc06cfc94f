//! `motionctl wire table11 [--csv]`: Table 11 with the thesis's IK and the corrected IK side by
//! side, checked through the built binary against the thesis's totals (seed L4483) and the
//! XB1 error of the thesis's IK.

mod wire_support;

use std::process::Command;
use wire_support::{check, scalar};

fn motionctl(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn col(header: &[&str], name: &str) -> usize {
    header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"))
}

#[test]
fn table11_csv_totals_and_xb1_difference() {
    let out = motionctl(&["wire", "table11", "--csv"]);
    let mut lines = out.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let f = |r: &[&str], name: &str| -> f64 { r[col(&header, name)].parse().unwrap() };
    let (total, rows) = rows.split_last().unwrap();
    assert_eq!(total[0], "total");
    // Rows 1-82 as in the thesis (row 82 is the return to the centre).
    assert_eq!(rows.len(), 82);
    assert_eq!(rows[0][0], "1");
    // Table 11 totals (seed L4483): 7523.725 mm^2 and 564.279 s (9 min 24.27 s).
    let (line, a) = scalar("table11_total_area_mm2");
    check(f(total, "total_area_mm2"), &a, "Table 11 total area", line);
    let (line, s) = scalar("table11_total_time_s");
    check(f(total, "total_time_s"), &s, "Table 11 total time", line);
    // The running totals end at the totals line.
    let last = rows.last().unwrap();
    assert_eq!(f(last, "total_area_mm2"), f(total, "total_area_mm2"));
    // Row 1 (seed L4392): alpha 0, beta 7.3057, area 877.5, 65.8125 s; M1 66125 (FIX), M3 -1826.
    let r1 = &rows[0];
    check(f(r1, "beta_deg"), "7.3057", "row 1 beta", 4392);
    check(f(r1, "area_mm2"), "877.5", "row 1 area", 4392);
    check(f(r1, "time_s"), "65.8125", "row 1 time", 4392);
    assert_eq!(f(r1, "m1_thesis"), 66_125.0);
    assert_eq!(f(r1, "m3_thesis"), -1_826.0);
    // XB1: equal wherever ZB1 = 0, up to 0.963 mm apart where it is not (row 19), and the step
    // counts M1 differ there by that much (3333.3 steps/mm).
    let mut worst = (0, 0.0f64);
    let mut differing = 0;
    for r in rows {
        let d = (f(r, "xb1_corrected_mm") - f(r, "xb1_thesis_mm")).abs();
        if f(r, "zb1_mm") == 0.0 {
            assert!(d < 1e-12, "row {}: ZB1 = 0 but XB1 differs by {d}", r[0]);
        } else if d > 1e-3 {
            differing += 1;
        }
        if d > worst.1 {
            worst = (f(r, "row") as usize, d);
        }
    }
    eprintln!(
        "largest XB1 difference {:.4} mm at row {}; {differing} rows differ",
        worst.1, worst.0
    );
    assert_eq!(worst.0, 19);
    assert!((worst.1 - 0.963).abs() < 5e-4, "{worst:?}");
    assert!(differing > 40, "{differing}");
    let r19 = &rows[18];
    let dm1 = f(r19, "m1_corrected") - f(r19, "m1_thesis");
    assert!((dm1.abs() - 0.963 * 5000.0 / 1.5).abs() < 3.0, "{dm1}");
    // The corrected ruled area is the continuous job's (7422.728 mm^2 < 7523.725).
    assert!(f(total, "area_ruled_mm2") < f(total, "total_area_mm2"));
}

#[test]
fn table11_text_has_the_totals_line() {
    let out = motionctl(&["wire", "table11"]);
    assert_eq!(out.lines().count(), 1 + 82 + 2);
    let total = out.lines().find(|l| l.starts_with("total area ")).expect("a totals line");
    let num = |after: &str| -> String {
        total.split(after).nth(1).unwrap().split_whitespace().next().unwrap().to_string()
    };
    let (line, a) = scalar("table11_total_area_mm2");
    check(num("total area ").parse().unwrap(), &a, "Table 11 total area (text)", line);
    let (line, s) = scalar("table11_total_time_s");
    check(num(", time ").parse().unwrap(), &s, "Table 11 total time (text)", line);
    assert!(total.contains("(9 min 24.279 s)"), "{total}");
    let corr = out.lines().find(|l| l.starts_with("corrected ")).expect("a corrected line");
    assert!(corr.contains("largest XB1 difference 0.963 mm at row 19"), "{corr}");
    // Row 19's M1 differs: printed as thesis->corrected.
    let r19 = out.lines().find(|l| l.trim_start().starts_with("19 |")).unwrap();
    assert!(r19.contains("->"), "{r19}");
}
