//! Wire dies from drawings (`wire plan --top FILE --bottom FILE --thickness MM`): the SVG pair
//! and the DXF faces under `tests/data/wire_cad/`, checked against their analytic shapes (areas,
//! perimeters, radii worked out here, not by the reader), the pairing rule (matched counts,
//! start on the +X ray, counter-clockwise, equal spacing), a plan whose ruled area is
//! integrated here over the analytic surface and whose time is 60 A / FR, the plot, the job
//! file's `[contours]`, and one clear error per kind of bad file.
//!
//! Bounds used below, for a convex closed curve of length P flattened within `tol` by chords
//! whose ends lie on (or, for usvg's Bézier arcs, at most `e` outside) the curve: every chord
//! is within `tol` of the curve, so the polygon contains the curve's inner parallel at
//! distance `tol` (area >= A - P tol, length >= P - 2 pi tol) and lies inside its outer
//! parallel at `e` (area <= A + P e + pi e^2, length <= P + 2 pi e). usvg turns every SVG arc
//! into cubic Béziers, four per turn at these radii, which lie at most 2.73e-4 r outside it.

use motionctl::wire::cad::{pair, read_contour, Contour};
use motionctl::wire::Point2;
use std::f64::consts::PI;
use std::path::PathBuf;
use std::process::Command;

const TOL: f64 = 0.01;
/// Radial error of the four-per-turn cubic Bézier circle (outside), per unit radius.
const BEZIER_E: f64 = 2.73e-4;
/// f32 rounding of usvg's coordinates, mm (about 1e-7 relative at 50 mm).
const F32_MM: f64 = 2e-5;

fn data(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/wire_cad")
        .join(name)
        .display()
        .to_string()
}

fn motionctl(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("motionctl-wire-cad-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Shoelace area (signed, counter-clockwise positive) and closed length of `p`.
fn shoelace(p: &[Point2]) -> f64 {
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a.x_mm * b.y_mm - b.x_mm * a.y_mm
        })
        .sum::<f64>()
        / 2.0
}

fn length(p: &[Point2]) -> f64 {
    (0..p.len()).map(|i| p[i].dist_mm(p[(i + 1) % p.len()])).sum()
}

/// Checks `c` against a convex shape of area `a` and length `l` with the bounds of the module
/// doc (`e` = how far outside the curve flattened points may lie).
fn check_convex(c: &Contour, a: f64, l: f64, e: f64) {
    let (area, len) = (shoelace(&c.points), length(&c.points));
    assert!(area > 0.0, "{}: counter-clockwise", c.source);
    assert!(
        area >= a - l * TOL && area <= a + l * e + PI * e * e,
        "{}: area {area} vs analytic {a} (tol {TOL}, e {e})",
        c.source
    );
    assert!(
        len >= l - 2.0 * PI * TOL && len <= l + 2.0 * PI * e,
        "{}: length {len} vs analytic {l}",
        c.source
    );
}

/// Distance from `p` to the rounded square of side `s` and corner radius `r` centred on the
/// origin, signed (negative inside).
fn rounded_square_distance(p: Point2, s: f64, r: f64) -> f64 {
    let h = s / 2.0 - r;
    let (qx, qy) = (p.x_mm.abs() - h, p.y_mm.abs() - h);
    let outside = qx.max(0.0).hypot(qy.max(0.0));
    outside + qx.max(qy).min(0.0) - r
}

#[test]
fn svg_circle_from_two_arcs_is_the_circle_r20() {
    let c = read_contour(&data("circle_r20.svg"), TOL).unwrap();
    let r = 20.0;
    for p in &c.points {
        let d = p.norm_mm();
        assert!(d >= r - F32_MM && d <= r * (1.0 + BEZIER_E) + F32_MM, "point {p:?} at radius {d}");
    }
    check_convex(&c, PI * r * r, 2.0 * PI * r, BEZIER_E * r + F32_MM);
}

#[test]
fn svg_rounded_square_through_transform_and_viewbox_units() {
    // 1 user unit = 0.1 mm (50 mm over 500 units) and a translate(-100 50) undoing the path
    // data's offset: the square is centred on the origin with side 36 mm.
    let c = read_contour(&(data("rounded_square_36.svg") + "#bottom"), TOL).unwrap();
    let (s, r) = (36.0, 6.0);
    for p in &c.points {
        let d = rounded_square_distance(*p, s, r);
        assert!(d.abs() <= BEZIER_E * r + F32_MM, "point {p:?} is {d} mm off the square");
    }
    let e = BEZIER_E * r + F32_MM;
    check_convex(&c, s * s - (4.0 - PI) * r * r, 4.0 * (s - 2.0 * r) + 2.0 * PI * r, e);
}

/// Real units over a viewBox: 4 in over 400 units is 0.254 mm a unit, and the page's centre
/// (200, 200) is the workpiece centre; without a page the user origin is.
#[test]
fn svg_units_and_page_centre() {
    let dir = temp_dir("units");
    let inch = dir.join("inch.svg");
    std::fs::write(
        &inch,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"4in\" height=\"4in\" \
         viewBox=\"0 0 400 400\"><circle cx=\"200\" cy=\"200\" r=\"100\"/></svg>",
    )
    .unwrap();
    let bare = dir.join("bare.svg");
    std::fs::write(
        &bare,
        "<svg xmlns=\"http://www.w3.org/2000/svg\"><circle cx=\"3\" cy=\"-4\" r=\"10\"/></svg>",
    )
    .unwrap();
    for (p, centre, r) in [(&inch, (0.0, 0.0), 25.4), (&bare, (3.0, 4.0), 10.0)] {
        let c = read_contour(p.to_str().unwrap(), TOL).unwrap();
        for q in &c.points {
            let d = (q.x_mm - centre.0).hypot(q.y_mm - centre.1);
            assert!(d >= r - F32_MM && d <= r * (1.0 + BEZIER_E) + F32_MM, "{p:?}: {q:?}");
        }
        check_convex(&c, PI * r * r, 2.0 * PI * r, BEZIER_E * r + F32_MM);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn dxf_faces_match_their_analytic_shapes() {
    let file = data("faces.dxf");
    // LWPOLYLINE with two bulge-1 spans: a 20 x 10 slot, every point 5 mm from its core
    // segment (-10, 0)..(10, 0).
    let slot = read_contour(&format!("{file}#slot"), TOL).unwrap();
    for p in &slot.points {
        let d = (p.x_mm.clamp(-10.0, 10.0) - p.x_mm).hypot(p.y_mm);
        assert!((d - 5.0).abs() <= 1e-9, "slot point {p:?} is {d} from the core");
    }
    check_convex(&slot, 200.0 + PI * 25.0, 40.0 + 10.0 * PI, 1e-9);
    // CIRCLE R 22.
    let disk = read_contour(&format!("{file}#disk"), TOL).unwrap();
    for p in &disk.points {
        assert!((p.norm_mm() - 22.0).abs() <= 1e-9, "disk point {p:?}");
    }
    check_convex(&disk, PI * 22.0 * 22.0, 2.0 * PI * 22.0, 1e-9);
    // Half disk R 18: an ARC, a LINE written against the loop's direction and a rational
    // quadratic SPLINE (the exact quarter circle: with its weights ignored its middle would sit
    // 6 % outside), listed out of order.
    let half = read_contour(&format!("{file}#half"), TOL).unwrap();
    for p in &half.points {
        let on_line = p.y_mm.abs() <= 1e-9 && p.x_mm.abs() <= 18.0 + 1e-9;
        let on_arc = p.y_mm >= -1e-9 && (p.norm_mm() - 18.0).abs() <= 1e-9;
        assert!(on_line || on_arc, "half-disk point {p:?}");
    }
    assert!(half.points.iter().any(|p| p.x_mm > 1.0 && p.y_mm > 1.0), "the spline's quarter");
    assert!(half.points.iter().any(|p| p.x_mm < -1.0 && p.y_mm > 1.0), "the arc's quarter");
    check_convex(&half, PI * 18.0 * 18.0 / 2.0, PI * 18.0 + 36.0, 1e-9);
    // The same layers through `wire plan`: the disk over the slot, 64 points a face.
    let (top, bottom) = (format!("{file}#disk"), format!("{file}#slot"));
    let (code, out, err) = motionctl(&[
        "wire",
        "plan",
        "--top",
        &top,
        "--bottom",
        &bottom,
        "--thickness",
        "25",
        "--points",
        "64",
        "--json",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let j = json_of(&out);
    assert_eq!(j["points_per_face"].as_u64(), Some(65));
    let (a, l) = (PI * 22.0 * 22.0, 2.0 * PI * 22.0);
    let drawn = f(&j, &["top", "drawn_area_mm2"]);
    assert!(drawn <= a && drawn >= a - l * TOL, "disk {drawn} vs {a}");
    let (a, l) = (200.0 + 25.0 * PI, 40.0 + 10.0 * PI);
    let drawn = f(&j, &["bottom", "drawn_area_mm2"]);
    assert!(drawn <= a && drawn >= a - l * TOL, "slot {drawn} vs {a}");
    // 64 points on the flattened circle R 22 (each between R - tol and R): the regular 64-gon
    // within the circle's length times tol.
    let an = 32.0 * 22.0 * 22.0 * (2.0 * PI / 64.0).sin();
    let resampled = f(&j, &["top", "polygon_area_mm2"]);
    assert!((resampled - an).abs() <= 2.0 * PI * 22.0 * TOL, "{resampled} vs {an}");
}

#[test]
fn pairing_matches_counts_starts_on_the_x_ray_and_spaces_equally() {
    let top = read_contour(&data("circle_r20.svg"), TOL).unwrap();
    let bottom = read_contour(&(data("rounded_square_36.svg") + "#bottom"), TOL).unwrap();
    let n = 90;
    let p = pair(top, bottom, 30.0, n).unwrap();
    // n points and the first again: the cut closes.
    assert_eq!(p.die.top.len(), n + 1);
    assert_eq!(p.die.bottom.len(), n + 1);
    assert_eq!(p.die.top[0], p.die.top[n]);
    assert_eq!(p.die.bottom[0], p.die.bottom[n]);
    // Both start where the +X ray from their centre (the origin) leaves them.
    let e = BEZIER_E * 20.0 + F32_MM;
    assert!(p.die.top[0].dist_mm(Point2::new(20.0, 0.0)) <= e, "{:?}", p.die.top[0]);
    assert!(p.die.bottom[0].dist_mm(Point2::new(18.0, 0.0)) <= 1e-6, "{:?}", p.die.bottom[0]);
    for (name, face) in [("top", &p.die.top[..n]), ("bottom", &p.die.bottom[..n])] {
        assert!(shoelace(face) > 0.0, "{name}: counter-clockwise");
        assert!(face[1].y_mm > 0.0, "{name}: goes up from +X first");
    }
    // The top: a regular 90-gon of radius 20 (every point on the flattened circle, which lies
    // between R - tol and R (1 + e)); its length and area independently.
    let top = &p.die.top[..n];
    for q in top {
        assert!(q.norm_mm() >= 20.0 - TOL && q.norm_mm() <= 20.0 + e, "{q:?}");
    }
    let k = PI / n as f64;
    let (ln, an) = (2.0 * n as f64 * 20.0 * k.sin(), n as f64 / 2.0 * 400.0 * (2.0 * k).sin());
    assert!((length(top) - ln).abs() <= 2.0 * PI * (TOL + e), "{} vs {ln}", length(top));
    assert!((shoelace(top) - an).abs() <= length(top) * (TOL + e), "{} vs {an}", shoelace(top));
    // Equally spaced along the drawing: every chord the same within the flattening's bends.
    let chords: Vec<f64> = (0..n).map(|i| top[i].dist_mm(top[(i + 1) % n])).collect();
    let (lo, hi) = chords.iter().fold((f64::MAX, 0.0f64), |(a, b), &c| (a.min(c), b.max(c)));
    assert!(hi / lo < 1.001, "top chords {lo} .. {hi}");
    // The bottom: on the rounded square within tol, and its area within the chord bound: a
    // resampled chord of length <= P / n across a corner of radius r has sagitta <= s^2 / 8r.
    let bottom = &p.die.bottom[..n];
    let (s, r) = (36.0, 6.0);
    let (a, l) = (s * s - (4.0 - PI) * r * r, 4.0 * (s - 2.0 * r) + 2.0 * PI * r);
    for q in bottom {
        let d = rounded_square_distance(*q, s, r);
        assert!(d <= BEZIER_E * r + F32_MM && d >= -TOL, "{q:?} is {d} off");
    }
    let sag = (l / n as f64).powi(2) / (8.0 * r);
    let area = shoelace(bottom);
    assert!(area <= a + l * BEZIER_E * r && area >= a - l * (TOL + sag), "bottom {area} vs {a}");
    // Mismatched shapes pair all the same, and a count below 3 is refused.
    let top = read_contour(&data("circle_r20.svg"), TOL).unwrap();
    let bottom = read_contour(&format!("{}#slot", data("faces.dxf")), TOL).unwrap();
    assert!(pair(top.clone(), bottom.clone(), 30.0, 2).is_err());
    let q = pair(top, bottom, 30.0, 7).unwrap();
    assert_eq!((q.die.top.len(), q.die.bottom.len()), (8, 8));
}

/// The circle R 20 (top) and the rounded square 36 / r 6 (bottom) at arc-length fraction `u`
/// from their +X points, counter-clockwise: the analytic faces of the SVG pair.
fn analytic_faces(u: f64) -> (Point2, Point2) {
    let a = 2.0 * PI * u;
    let top = Point2::new(20.0 * a.cos(), 20.0 * a.sin());
    let (h, r) = (12.0, 6.0);
    let l = 8.0 * h + 2.0 * PI * r;
    // The square's boundary from (18, 0): half an edge, then per quarter a corner and an edge.
    // d runs from (18, -12), the start of the right edge's straight part.
    let mut d = (u * l + h).rem_euclid(l);
    let mut pts = Point2::default();
    for q in 0..4 {
        let (c, s) = ((q as f64 * PI / 2.0).cos(), (q as f64 * PI / 2.0).sin());
        let rot = |x: f64, y: f64| Point2::new(c * x - s * y, s * x + c * y);
        if d <= 2.0 * h {
            pts = rot(h + r, -h + d);
            break;
        }
        d -= 2.0 * h;
        if d <= PI / 2.0 * r {
            let t = d / r;
            pts = rot(h + r * t.cos(), h + r * t.sin());
            break;
        }
        d -= PI / 2.0 * r;
    }
    (top, pts)
}

/// Area of the analytic ruled surface between the faces, by the midpoint rule in u (the
/// surface is linear in v, so |S_u x S_v| is integrated exactly enough by 8-point Gauss).
fn analytic_ruled_area(zt: f64) -> f64 {
    let m = 20_000;
    let g: [(f64, f64); 4] = [
        (0.069_431_844_202_973_7, 0.173_927_422_568_726_9),
        (0.330_009_478_207_571_9, 0.326_072_577_431_273_1),
        (0.669_990_521_792_428_1, 0.326_072_577_431_273_1),
        (0.930_568_155_797_026_3, 0.173_927_422_568_726_9),
    ];
    let du = 1.0 / m as f64;
    let mut sum = 0.0;
    for i in 0..m {
        let u = (i as f64 + 0.5) * du;
        let (t0, b0) = analytic_faces(u - du / 2.0);
        let (t1, b1) = analytic_faces(u + du / 2.0);
        let (t, b) = analytic_faces(u);
        for (v, w) in g {
            // S(u, v) = (1 - v) b(u) + v t(u) + (0, 0, v zt).
            let su = [
                ((1.0 - v) * (b1.x_mm - b0.x_mm) + v * (t1.x_mm - t0.x_mm)) / du,
                ((1.0 - v) * (b1.y_mm - b0.y_mm) + v * (t1.y_mm - t0.y_mm)) / du,
                0.0,
            ];
            let sv = [t.x_mm - b.x_mm, t.y_mm - b.y_mm, zt];
            let c = [
                su[1] * sv[2] - su[2] * sv[1],
                su[2] * sv[0] - su[0] * sv[2],
                su[0] * sv[1] - su[1] * sv[0],
            ];
            sum += w * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() * du;
        }
    }
    sum
}

fn json_of(out: &str) -> serde_json::Value {
    serde_json::from_str(out).unwrap_or_else(|e| panic!("not JSON ({e}): {out}"))
}

fn f(j: &serde_json::Value, path: &[&str]) -> f64 {
    let mut v = j;
    for k in path {
        v = &v[*k];
    }
    v.as_f64().unwrap_or_else(|| panic!("{path:?} missing in {j}"))
}

#[test]
fn wire_plan_on_the_svg_pair_reports_area_time_and_ik_bound() {
    let (zt, fr, n) = (30.0, 1000.0, 150);
    let top = data("circle_r20.svg");
    let bottom = data("rounded_square_36.svg") + "#bottom";
    let args = [
        "wire",
        "plan",
        "--top",
        &top,
        "--bottom",
        &bottom,
        "--thickness",
        "30",
        "--fr",
        "1000",
        "--points",
        "150",
        "--json",
    ];
    let (code, out, err) = motionctl(&args);
    assert_eq!(code, Some(0), "{err}");
    let j = json_of(&out);
    assert_eq!(j["points_per_face"].as_u64(), Some(n as u64 + 1));
    assert_eq!(f(&j, &["zt_mm"]), zt);
    // Face areas: the regular 150-gon of radius 20, and the rounded square within its bounds.
    let k = PI / n as f64;
    let an = n as f64 / 2.0 * 400.0 * (2.0 * k).sin();
    let e = BEZIER_E * 20.0 + F32_MM;
    let top_area = f(&j, &["top", "polygon_area_mm2"]);
    assert!((top_area - an).abs() <= 2.0 * PI * 20.0 * (TOL + e), "{top_area} vs {an}");
    let (a, l) = (1296.0 - (4.0 - PI) * 36.0, 96.0 + 12.0 * PI);
    let sag = (l / n as f64).powi(2) / 48.0;
    let bottom_area = f(&j, &["bottom", "polygon_area_mm2"]);
    assert!(
        bottom_area <= a + l * BEZIER_E * 6.0 && bottom_area >= a - l * (TOL + sag),
        "{bottom_area} vs {a}"
    );
    assert!((f(&j, &["top", "drawn_area_mm2"]) - PI * 400.0).abs() <= 2.0 * PI * 20.0 * (TOL + e));
    // The ruled area: the analytic surface integrated here plus the lead-in and lead-out
    // (plane trapezoids from the centre to (20, 0) on top and (18, 0) below: (20 + 18) / 2 zt
    // each). The planned faces are chords of the analytic ones (150 points, within tol and the
    // corners' sagitta (P / n)^2 / 8r = 0.017 mm): about 2e-4 of the area, which 1e-3 allows
    // five times over.
    let expected = analytic_ruled_area(zt) + 2.0 * (20.0 + 18.0) / 2.0 * zt;
    let ruled = f(&j, &["ruled_area_mm2"]);
    assert!((ruled / expected - 1.0).abs() < 1e-3, "ruled {ruled} vs analytic {expected}");
    // Cut time at the area rate, and the host model within 1 % of it.
    let t = f(&j, &["cut_time_s"]);
    assert!((t - 60.0 * ruled / fr).abs() <= 1e-9 * t, "{t} s vs 60 A / FR");
    assert!((t / (60.0 * expected / fr) - 1.0).abs() < 1e-3);
    assert!((f(&j, &["host_model_time_s"]) / t - 1.0).abs() < 0.01);
    // The IK error bound is the planner's joint-linear deviation plus quantisation, within
    // the tolerance.
    let bound = f(&j, &["ik_error_bound_mm"]);
    let parts = f(&j, &["ik_joint_linear_mm"]) + f(&j, &["ik_quantisation_mm"]);
    assert!(bound > 0.0 && bound <= f(&j, &["tolerance_mm"]), "{bound}");
    assert!((bound - parts).abs() < 1e-12);
    // The text report names the same figures with their units.
    let args: Vec<&str> = args.iter().copied().filter(|a| *a != "--json").collect();
    let (code, text, err) = motionctl(&args);
    assert_eq!(code, Some(0), "{err}");
    for want in ["top drawing", "mm^2", "60 A / FR", "IK error bound", "final steps [0, 0, 0, 0]"] {
        assert!(text.contains(want), "{want} missing:\n{text}");
    }
}

#[test]
fn job_file_contours_plan_the_same_die() {
    let dir = temp_dir("job");
    for name in ["circle_r20.svg", "rounded_square_36.svg"] {
        std::fs::copy(data(name), dir.join(name)).unwrap();
    }
    let job = dir.join("job.toml");
    std::fs::write(
        &job,
        "version = 1\nfr_mm2_per_min = 1000\n[contours]\ntop = \"circle_r20.svg\"\n\
         bottom = \"rounded_square_36.svg#bottom\"\nthickness_mm = 30\npoints = 150\n",
    )
    .unwrap();
    let (code, out, err) = motionctl(&["wire", "plan", "--job", job.to_str().unwrap(), "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let from_job = json_of(&out);
    let (top, bottom) = (data("circle_r20.svg"), data("rounded_square_36.svg") + "#bottom");
    let (code, out, err) = motionctl(&[
        "wire",
        "plan",
        "--top",
        &top,
        "--bottom",
        &bottom,
        "--thickness",
        "30",
        "--fr",
        "1000",
        "--points",
        "150",
        "--json",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let from_flags = json_of(&out);
    for key in ["ruled_area_mm2", "cut_time_s", "ik_error_bound_mm"] {
        assert_eq!(from_job[key], from_flags[key], "{key}");
    }
    // A [contours] table without its thickness is refused with the field's name.
    std::fs::write(&job, "version = 1\n[contours]\ntop = \"a.svg\"\nbottom = \"b.svg\"\n").unwrap();
    let (code, _, err) = motionctl(&["wire", "plan", "--job", job.to_str().unwrap()]);
    assert_eq!(code, Some(1));
    assert!(err.contains("job.toml") && err.contains("thickness_mm"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn plot_draws_the_surface_and_the_axes_with_labels() {
    let dir = temp_dir("plot");
    let (top, bottom) = (data("circle_r20.svg"), data("rounded_square_36.svg") + "#bottom");
    for ext in ["svg", "png"] {
        let file = dir.join(format!("wire.{ext}"));
        let (code, _, err) = motionctl(&[
            "wire",
            "plan",
            "--top",
            &top,
            "--bottom",
            &bottom,
            "--thickness",
            "30",
            "--plot",
            file.to_str().unwrap(),
        ]);
        assert_eq!(code, Some(0), "{err}");
        let bytes = std::fs::read(&file).unwrap();
        assert!(bytes.len() > 1000, "{ext}: {} bytes", bytes.len());
        if ext == "png" {
            assert_eq!(&bytes[1..4], b"PNG");
            continue;
        }
        let svg = String::from_utf8(bytes).unwrap();
        assert!(svg.contains("<polyline") || svg.contains("<path"), "no lines drawn");
        if err.contains("no system font") {
            continue;
        }
        for want in [
            "wire plan: contours",
            "circle_r20.svg",
            "ruled surface",
            "ruling lines",
            "top face, Z = 30 mm",
            "X, mm",
            "Z, mm",
            "time, s",
            "position, mm",
            "angle, deg",
            "beta (about Y), deg",
            "alpha (about X), deg",
        ] {
            assert!(svg.contains(want), "{want} missing from the SVG");
        }
    }
    let (code, _, err) = motionctl(&[
        "wire",
        "plan",
        "--top",
        &top,
        "--bottom",
        &bottom,
        "--thickness",
        "30",
        "--plot",
        dir.join("wire.jpg").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1));
    assert!(err.contains("wire.jpg") && err.contains(".svg or .png"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

fn svg_with(d: &str) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"-50 -50 100 100\">\
         <path d=\"{d}\"/></svg>"
    )
}

#[test]
fn bad_drawings_are_refused_with_the_file_and_the_reason() {
    let dir = temp_dir("bad");
    let good = data("circle_r20.svg");
    let dxf_circle_nan =
        "0\nSECTION\n2\nENTITIES\n0\nCIRCLE\n8\n0\n10\n0.0\n20\nnan\n30\n0.0\n40\n\
                          5.0\n0\nENDSEC\n0\nEOF\n";
    let dxf_open = "0\nSECTION\n2\nENTITIES\n0\nLINE\n8\n0\n10\n0\n20\n0\n30\n0\n11\n10\n21\n0\n31\n\
                    0\n0\nLINE\n8\n0\n10\n10\n20\n0\n30\n0\n11\n10\n21\n10\n31\n0\n0\nENDSEC\n0\nEOF\n";
    let cases: Vec<(&str, String, &str)> = vec![
        ("empty.svg", "<svg xmlns=\"http://www.w3.org/2000/svg\"/>".into(), "no path found"),
        ("open.svg", svg_with("M 0 0 L 10 0 L 10 10"), "open contour"),
        ("bowtie.svg", svg_with("M 0 0 L 10 10 L 10 0 L 0 10 Z"), "crosses itself"),
        ("flat.svg", svg_with("M 0 0 L 10 0 L 20 0 Z"), "encloses no area"),
        ("two.svg", svg_with("M 0 0 H 5 V 5 Z M 10 10 H 15 V 15 Z"), "more than one subpath"),
        ("garbage.svg", "this is not xml <".into(), "not a readable SVG"),
        ("garbage.dxf", "hello\nworld\n".into(), "DXF"),
        ("nan.dxf", dxf_circle_nan.into(), "not finite"),
        ("open.dxf", dxf_open.into(), "open contour"),
        ("shape.txt", "1 2 3".into(), "must end in .svg or .dxf"),
    ];
    for (name, text, want) in &cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let p = p.to_str().unwrap();
        let (code, _, err) =
            motionctl(&["wire", "plan", "--top", p, "--bottom", &good, "--thickness", "30"]);
        assert_eq!(code, Some(1), "{name}: exit code (stderr {err})");
        assert!(err.contains(name) && err.contains(want), "{name}: want `{want}`: {err}");
    }
    // Selectors that name nothing, a file that is not there, and the whole DXF (three loops).
    let faces = data("faces.dxf");
    for (arg, want) in [
        (format!("{good}#nope"), "no path with id `nope`".to_string()),
        (data("rounded_square_36.svg"), "path `guide` is an open contour".into()),
        (format!("{faces}#nope"), "on layer `nope`".into()),
        (faces.clone(), "3 closed contours".into()),
        (dir.join("missing.svg").display().to_string(), "cannot read".into()),
    ] {
        let (code, _, err) =
            motionctl(&["wire", "plan", "--top", &good, "--bottom", &arg, "--thickness", "30"]);
        assert_eq!(code, Some(1), "{arg}: {err}");
        assert!(err.contains(&want), "{arg}: want `{want}`: {err}");
    }
    // A thin C (1 mm wide, opening towards +X): 40 points cut across its slot, 80 do not.
    let c = dir.join("thin_c.svg");
    std::fs::write(
        &c,
        svg_with("M 20 -20 L -20 -20 L -20 20 L 20 20 L 20 19 L -19 19 L -19 -19 L 20 -19 Z"),
    )
    .unwrap();
    let c = c.to_str().unwrap();
    let run = |n: &str| {
        motionctl(&[
            "wire",
            "plan",
            "--top",
            c,
            "--bottom",
            &good,
            "--thickness",
            "30",
            "--points",
            n,
        ])
    };
    let (code, _, err) = run("40");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("thin_c.svg") && err.contains("crosses itself"), "{err}");
    let (code, _, err) = run("80");
    assert_eq!(code, Some(0), "{err}");
    // Missing thickness, a bad point count or chord tolerance.
    for (extra, want) in [
        (vec![], "--thickness"),
        (vec!["--thickness", "30", "--points", "2"], "points"),
        (vec!["--thickness", "30", "--chord-tol", "0"], "chord"),
    ] {
        let mut args = vec!["wire", "plan", "--top", &good, "--bottom", &good];
        args.extend(extra);
        let (code, _, err) = motionctl(&args);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: want `{want}`: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `wire run` streams a contour die like any other: two of its segments on the in-process
/// simulated board end where the host model says, in order, and the plot is titled as a run.
#[test]
fn wire_run_streams_the_svg_pair_to_the_sim_board() {
    let dir = temp_dir("run");
    let plot = dir.join("run.svg");
    let (top, bottom) = (data("circle_r20.svg"), data("rounded_square_36.svg") + "#bottom");
    let (code, out, err) = motionctl(&[
        "wire",
        "run",
        "--sim",
        "--top",
        &top,
        "--bottom",
        &bottom,
        "--thickness",
        "30",
        "--points",
        "60",
        "--segments",
        "1..3",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("hash_ok=1") && out.contains("positions_ok=1"), "{out}");
    assert!(out.contains("result     OK"), "{out}");
    let svg = std::fs::read_to_string(&plot).unwrap();
    if !err.contains("no system font") {
        assert!(svg.contains("wire run: contours"), "run title missing");
    }
    std::fs::remove_dir_all(&dir).ok();
}
