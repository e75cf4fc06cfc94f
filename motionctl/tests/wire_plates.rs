//! Machining area and time `60 A / FR` of the thesis's plates 9, 10, 16 and 19 (seed
//! L5231-5579), MDI files and the other shapes.

mod wire_support;

use motionctl::wire::area::polygon_area_mm2;
use motionctl::wire::csv::{parse_mdi, write_mdi};
use motionctl::wire::path::{joint_targets, totals, Path};
use motionctl::wire::shapes::{circle_for_crescent, circle_uniform, crescent, prismatic, star};
use motionctl::wire::{ik::IkModel, Die, Point2, WireError};
use wire_support::{check, scalar};

fn plate(top: Vec<Point2>, bottom: Vec<Point2>, zt_mm: f64, fr: f64, key: &str) -> f64 {
    plate_rel(top, bottom, zt_mm, fr, key, 0.0)
}

fn plate_rel(
    top: Vec<Point2>,
    bottom: Vec<Point2>,
    zt_mm: f64,
    fr: f64,
    key: &str,
    rel: f64,
) -> f64 {
    let die = Die::new(zt_mm, top, bottom).unwrap();
    let tot = totals(&Path::from_home(&die, Point2::default()).unwrap(), fr).unwrap();
    let (line, a) = scalar(&format!("{key}_area_mm2"));
    wire_support::check_rel(tot.area_mm2, &a, &format!("{key} area"), line, rel);
    tot.time_s
}

#[test]
fn plate9_circle_to_circle() {
    // Appendix C4 circles start at 45 deg (seed L2651); R 25 over R 20, N 80, ZT 49, FR 800.
    let t = plate(
        circle_uniform(25.0, 80, 45.0).unwrap(),
        circle_uniform(20.0, 80, 45.0).unwrap(),
        49.0,
        800.0,
        "plate9",
    );
    let (line, s) = scalar("plate9_time_s");
    check(t, &s, "plate 9 time (11' 24.78\")", line);
}

#[test]
fn plate10_square_to_square() {
    // 50 x 50 over 30 x 30, INT() coordinates as in Appendix C4, N 80, ZT 49, FR 800.
    let t = plate(
        prismatic(50.0, 50.0, 80, true).unwrap(),
        prismatic(30.0, 30.0, 80, true).unwrap(),
        49.0,
        800.0,
        "plate10",
    );
    // Printed 13' 15.88" (seed line 5279); 60 A / FR = 795.889 s, the thesis truncates.
    let (line, s) = scalar("plate10_time_s");
    assert!((795.88..795.89).contains(&t), "plate 10 time {t} (seed line {line}: {s})");
    let exact = plate(
        prismatic(50.0, 50.0, 80, false).unwrap(),
        prismatic(30.0, 30.0, 80, false).unwrap(),
        49.0,
        800.0,
        "plate10",
    );
    assert!((exact - t).abs() < 1e-9, "INT() spacing keeps the perimeter");
}

/// Plate 16: circle R 20 over crescent R 15, N 60, ZT 49, FR 800. The printed area 7609.85
/// (seed line 5507) is reproduced; the printed time 9' 30.37" (L5508) is not 60 A / FR of it
/// (570.74 s = 9' 30.74"): a transposed digit in the thesis.
#[test]
fn plate16_circle_to_crescent() {
    let t = plate(
        circle_for_crescent(20.0, 60).unwrap(),
        crescent(15.0, 60).unwrap(),
        49.0,
        800.0,
        "plate16",
    );
    let (line, s) = scalar("plate16_time_s");
    assert!(!wire_support::within(t, &s), "seed line {line}");
    check(t, "570.74", "plate 16 time, corrected", line);
}

/// Plate 19, circular tapered die, N 60, ZT 49: stage 1 R 3.5 over R 3.5 (FR 400), stages 2
/// and 3 with the bottom circle starting at 180 deg (seed L2534): 15 over 2 and 18 over 10
/// (FR 500). Stage 3 comes out 5680.296 mm^2 against the printed 5680.16 (seed line 5576):
/// 2.4e-5 relative, the size of the thesis's single-precision drift seen in Table 9; not
/// explained further, checked with 3e-5 relative.
#[test]
fn plate19_taper_stages() {
    let stages = [(3.5, 3.5, 0.0, 400.0), (15.0, 2.0, 180.0, 500.0), (18.0, 10.0, 180.0, 500.0)];
    for (k, (rt, rb, b0, fr)) in stages.into_iter().enumerate() {
        let key = format!("plate19_stage{}", k + 1);
        let rel = if k == 2 { 3e-5 } else { 0.0 };
        let t = plate_rel(
            circle_uniform(rt, 60, 0.0).unwrap(),
            circle_uniform(rb, 60, b0).unwrap(),
            49.0,
            fr,
            &key,
            rel,
        );
        let (line, s) = scalar(&format!("{key}_time_s"));
        check(t, &s, &format!("{key} time"), line);
    }
}

#[test]
fn mdi_round_trip_and_errors() {
    let text = "# straight to curved\n39, 4\n20,0,25,0\n0 20 0 25\n-20,0,-25,0\n0,-20,0,-25\n";
    let die = parse_mdi(text).unwrap();
    assert_eq!(die.zt_mm, 39.0);
    assert_eq!(die.bottom[1], Point2::new(0.0, 20.0));
    assert_eq!(die.top[3], Point2::new(0.0, -25.0));
    assert_eq!(parse_mdi(&write_mdi(&die)).unwrap(), die);
    let e = parse_mdi("39 2 1 2 3 4 5 6 x 8").unwrap_err();
    assert!(matches!(&e, WireError::Parse(m) if m.contains("point index 1 field XT")), "{e}");
    let e = parse_mdi("39 2 1 2 3 4 5").unwrap_err();
    assert!(e.to_string().contains("point index 1 field YB"), "{e}");
    assert!(parse_mdi("39 2.5").is_err());
    assert!(parse_mdi("0 1 1 1 1 1").is_err());
    assert!(parse_mdi("39 1 1 1 1 1 9").unwrap_err().to_string().contains("extra"));
    assert!(parse_mdi("").is_err());
}

#[test]
fn star_and_ruled_area() {
    let s = star(30.0, 12.0, 5, 80).unwrap();
    assert_eq!(s.len(), 81);
    assert_eq!(s[0], s[80]);
    // Area of a 5-point star polygon: 10 triangles of sides 30 and 12 at 36 deg.
    let expect = 10.0 * 0.5 * 30.0 * 12.0 * 36f64.to_radians().sin();
    assert!((polygon_area_mm2(&s[..80]) - expect).abs() < 1e-9);
    assert!(star(30.0, 12.0, 5, 81).is_err());
    // Ruled area equals the trapezoid area for a vertical (prismatic) wall.
    let c = circle_uniform(20.0, 60, 0.0).unwrap();
    let p = Path::new(30.0, c.clone(), c).unwrap();
    for t in joint_targets(&p, IkModel::Exact).unwrap() {
        assert!((t.area_ruled_mm2 - t.area_trapezoid_mm2).abs() < 1e-9);
    }
    // A twisted patch (the trapezoid formula is no bound there): Gauss 8x8 vs a fine midpoint sum.
    let (b0, b1, t0, t1) = (
        Point2::new(0.0, 0.0),
        Point2::new(10.0, 0.0),
        Point2::new(0.0, 8.0),
        Point2::new(-6.0, -3.0),
    );
    let z = 20.0;
    let q = motionctl::wire::path::ruled_area_mm2(b0, b1, t0, t1, z);
    let n = 400;
    let mut brute = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let du = [
                (1.0 - v) * (b1.x_mm - b0.x_mm) + v * (t1.x_mm - t0.x_mm),
                (1.0 - v) * (b1.y_mm - b0.y_mm) + v * (t1.y_mm - t0.y_mm),
                0.0,
            ];
            let dv = [
                (1.0 - u) * (t0.x_mm - b0.x_mm) + u * (t1.x_mm - b1.x_mm),
                (1.0 - u) * (t0.y_mm - b0.y_mm) + u * (t1.y_mm - b1.y_mm),
                z,
            ];
            let c = [
                du[1] * dv[2] - du[2] * dv[1],
                du[2] * dv[0] - du[0] * dv[2],
                du[0] * dv[1] - du[1] * dv[0],
            ];
            brute += (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() / (n * n) as f64;
        }
    }
    assert!((q - brute).abs() < 1e-4 * brute, "{q} vs {brute}");
}
