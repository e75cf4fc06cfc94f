//! Thesis Tables 7-10 (Bhatti 1991) reproduced by the shape generators and the sector-area
//! bookkeeping. Oracles are the printed tables transcribed verbatim in `tests/data/wire/`.

mod wire_support;

use motionctl::wire::area::{
    intermediate_section, polygon_area_mm2, reduction_percent, sector_table, truncate_significant,
    SectorRow,
};
use motionctl::wire::shapes::{circle_arcs, complex, crescent, COMPLEX_ARCS};
use motionctl::wire::Point2;
use wire_support::{check, scalar, table, within};

fn compare_rows(
    t: &[&wire_support::Row],
    pts: &[Point2],
    rows: &[SectorRow],
    skip: &[(usize, usize)],
    rel: [f64; 6],
) {
    wire_support::SOFT.with(|s| *s.borrow_mut() = Some(Vec::new()));
    for r in t {
        let (p, s) = (pts[r.row - 1], rows[r.row - 1]);
        for (k, v) in
            [p.x_mm, p.y_mm, s.r_mean_mm, s.theta_deg, s.sector_mm2, s.total_mm2].iter().enumerate()
        {
            if skip.contains(&(r.row, k)) {
                assert!(
                    !within(*v, &r.cells[k]),
                    "row {} col {k} is listed as a typo but matches",
                    r.row
                );
                continue;
            }
            if k == 4 {
                // A sector depends on two points printed to 0.001 mm: allow what a 0.001 mm
                // change of either point does to r_mean^2 dtheta / 2.
                let d = 1e-3;
                let dth = (s.sector_mm2 * 2.0 / (s.r_mean_mm * s.r_mean_mm).max(1e-9)).abs();
                let slack = s.r_mean_mm * d + s.r_mean_mm * dth * d;
                let printed: f64 = r.cells[k].parse().unwrap();
                if (v - printed).abs() <= wire_support::tolerance(&r.cells[k]) + slack {
                    continue;
                }
            }
            wire_support::check_rel(
                *v,
                &r.cells[k],
                &format!("row {} col {k}", r.row),
                r.line,
                rel[k],
            );
        }
    }
    let fails = wire_support::SOFT.with(|s| s.borrow_mut().take()).unwrap_or_default();
    assert!(fails.is_empty(), "{} mismatches:\n{}", fails.len(), fails.join("\n"));
}

/// Compares a generated profile and its sector table with a printed Tables 7-10 layout
/// (X, Y, RESULTANT, THETA, SECTOR, TOTAL). `skip` lists (row, column) cells that are thesis
/// typos, checked separately by the caller.
fn compare(name: &str, pts: &[Point2], rows: &[SectorRow], skip: &[(usize, usize)], rel: [f64; 6]) {
    let t = table(name);
    assert_eq!(t.len(), pts.len(), "{name}: row count");
    let refs: Vec<_> = t.iter().collect();
    compare_rows(&refs, pts, rows, skip, rel);
}

#[test]
fn table7_circle_top() {
    let top = circle_arcs(25.0, 80).unwrap();
    let rows = sector_table(&top);
    compare("table7_circle_top.tsv", &top, &rows, &[], [0.0; 6]);
    let (line, total) = scalar("table7_total_area_mm2");
    check(rows[80].total_mm2, &total, "Table 7 total", line);
    // Exact polygon area of the same 81 points is smaller (chords cut the arcs).
    let exact = polygon_area_mm2(&top[..80]);
    assert!((exact - 1959.19).abs() < 0.01, "shoelace {exact}");
}

#[test]
fn table8_complex_bottom() {
    let bottom = complex(20.0, 80).unwrap();
    let rows = sector_table(&bottom);
    compare("table8_complex_bottom.tsv", &bottom, &rows, &[], [0.0; 6]);
    let (line, total) = scalar("table8_total_area_mm2");
    check(rows[80].total_mm2, &total, "Table 8 total", line);
    let top_total = sector_table(&circle_arcs(25.0, 80).unwrap())[80].total_mm2;
    // BASIC 2620 divides by the variables TAREA and BAREA after the print formatting
    // truncated them to 5 significant digits (1963.4 and 817.21).
    let (line, red) = scalar("table8_reduction_percent");
    let (ta, ba) =
        (truncate_significant(top_total, 5), truncate_significant(rows[80].total_mm2, 5));
    check(reduction_percent(ta, ba), &red, "Table 8 reduction", line);
    assert!(!within(reduction_percent(top_total, rows[80].total_mm2), &red));
    // The sector method counts the turned-back parts with their sign, as the exact area does.
    let exact = polygon_area_mm2(&bottom[..80]);
    assert!((exact - 814.43).abs() < 0.01, "shoelace {exact} vs sector {}", rows[80].total_mm2);
}

/// The DATA statements of the complex shape as OCR'd (seed L2403-2426), with the repairs that
/// [`COMPLEX_ARCS`] documents, give exactly the 120 numbers of [`COMPLEX_ARCS`].
#[test]
fn complex_data_repairs() {
    let text =
        std::fs::read_to_string(wire_support::data_path("complex_data_seed_l2403.txt")).unwrap();
    let repairs: [(usize, &str, &str); 10] = [
        (2406, ".4270375 0", ".4270375,0"),     // missing comma
        (2407, ",02840379", ",.02840379"),      // lost '.'
        (2409, "-.0696 .1565", "-.0696,.1565"), // missing comma
        (2411, ",-54,", ",-.54,"),              // lost '.'
        (2418, "-.4687486 -.8984189", "-.4687486,-.8984189"),
        (2419, "-.6605 -.75", "-.6605,-.75"),
        (2422, "-.3478 -.3304", "-.3478,-.3304"),
        (2423, "-.0696 -.313", "-.0696,-.313"),
        (2423, ".034", ".0348"), // arc 17 ends where arc 18 starts (0.0348)
        (2424, "-.663 .4174", "-.663,.4174"),
    ];
    let mut nums = Vec::new();
    for l in text.lines().filter(|l| !l.starts_with('#')) {
        let (line, body) = l.split_once('\t').unwrap();
        let line: usize = line.parse().unwrap();
        let mut body = body.split_once("DATA").unwrap().1.to_string();
        for (rl, from, to) in repairs {
            if rl == line {
                assert!(body.contains(from), "repair at seed line {line} does not apply");
                body = body.replacen(from, to, 1);
            }
        }
        nums.extend(
            body.split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|s| s.parse::<f64>().unwrap()),
        );
    }
    let flat: Vec<f64> = COMPLEX_ARCS.iter().flatten().copied().collect();
    // Arc 5's last point is printed 0.250094 and arc 6's first 0.2500941 (both kept).
    assert_eq!(nums, flat);
}

#[test]
fn table9_crescent() {
    let bottom = crescent(15.0, 60).unwrap();
    let rows = sector_table(&bottom);
    let t = table("table9_crescent.tsv");
    // TOTAL column typos (each printed total minus the next printed sector gives the next
    // printed total, so one digit is wrong): row 36 435.66 for 436.66 (seed line 4258), row 42
    // 385.04 for 385.08 (L4264), row 47 348.03 for 348.33 (L4269), row 49 333.52 for 333.62
    // (L4271). The printed running total also drifts low by up to 2.4e-5 relative (row 31
    // prints 490.862 for the exact 250-deg sector 490.874), the thesis's single-precision sum.
    let typos = [(36, 5), (42, 5), (47, 5), (49, 5)];
    let rows60 = &rows[..60];
    let t60: Vec<_> = t.iter().filter(|r| r.row <= 60).collect();
    assert_eq!(t60.len(), 60);
    compare_rows(&t60, &bottom, rows60, &typos, [0.0, 0.0, 0.0, 0.0, 0.0, 3e-5]);
    // Row 61 (seed line 4284): the point (15, 0) and its mean radius agree, but the printed
    // sector -11.291 repeats row 60's; the true closing sector (mean radius 14.767, dtheta
    // -6.164 deg) is -11.73. The printed total 220.7149 (seed L4286) is the sum with the
    // repeated sector, so the thesis's crescent program double-counted row 60.
    let r61 = t.iter().find(|r| r.row == 61).unwrap();
    check(bottom[60].x_mm, &r61.cells[0], "Table 9 row 61 X", r61.line);
    check(rows[60].r_mean_mm, &r61.cells[2], "Table 9 row 61 RESULTANT", r61.line);
    assert!(
        (rows[60].sector_mm2 - (-11.73)).abs() < 0.01,
        "closing sector {}",
        rows[60].sector_mm2
    );
    let thesis_total = rows[59].total_mm2 + rows[59].sector_mm2;
    let (line, total) = scalar("table9_total_area_mm2");
    check(thesis_total, &total, "Table 9 total (thesis: row 60 sector counted twice)", line);
    assert!(!within(rows[60].total_mm2, &total));
    // Reduction ratio against a 20 mm circle (1256.637 mm^2, seed L2608).
    let (line, red) = scalar("table9_reduction_percent");
    let circle20 = sector_table(&motionctl::wire::shapes::circle_for_crescent(20.0, 60).unwrap())
        [60]
    .total_mm2;
    assert!(
        (circle20 - 1256.637).abs() < 1e-3,
        "20 mm circle {circle20} (seed L2608 prints 1256.637)"
    );
    let red_ours =
        reduction_percent(truncate_significant(circle20, 5), truncate_significant(thesis_total, 5));
    check(red_ours, &red, "Table 9 reduction (5-digit truncated areas as in BASIC 2620)", line);
    // Corrected figures: sector method 220.27 mm^2, exact polygon area:
    let exact = polygon_area_mm2(&bottom[..60]);
    assert!(
        (rows[60].total_mm2 - 220.27).abs() < 0.01 && (exact - rows[60].total_mm2).abs() < 3.0,
        "{exact}"
    );
}

#[test]
fn table10_intermediate_section_z10() {
    let top = circle_arcs(25.0, 80).unwrap();
    let bottom = complex(20.0, 80).unwrap();
    let sec = intermediate_section(&top, &bottom, 0.0, 39.0, 10.0);
    let rows = sector_table(&sec);
    // Thesis typos: each was checked against its own row's neighbours (total[i-1] + sector[i]
    // = total[i]). SECTOR: row 9 20.399 for 20.999 (seed line 4308), row 25 2.732 for 2.782
    // (L4324), row 30 3.066 for 3.086 (L4329), row 39 29.328 for 29.928 (L4338), row 46 18.55
    // for 18.65 (L4346). TOTAL: row 24 308.51 for 308.52 (L4323), row 38 579.26 for 379.26
    // (L4337), row 39 404.19 for 409.19 (L4338), row 40 409.59 for 439.59 (L4339).
    let typos = [(9, 4), (25, 4), (30, 4), (39, 4), (46, 4), (24, 5), (38, 5), (39, 5), (40, 5)];
    compare("table10_intermediate_z10.tsv", &sec, &rows, &typos, [0.0; 6]);
    let (line, total) = scalar("table10_total_area_mm2");
    check(rows[80].total_mm2, &total, "Table 10 total", line);
    let top_total = sector_table(&top)[80].total_mm2;
    let (line, red) = scalar("table10_reduction_percent");
    // BASIC 3380: truncated TAREA (1963.4), full-precision IAREA.
    check(
        reduction_percent(truncate_significant(top_total, 5), rows[80].total_mm2),
        &red,
        "Table 10 reduction",
        line,
    );
}
