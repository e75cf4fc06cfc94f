//! `motionctl polar digitize` on parts other than the thesis's, as a user runs it: the start
//! point, the path lengths and the cut time of a contour cut with a tool radius, with Vt held at
//! the contact point (the default) or the tool centre; a user's work area from a machine file,
//! a contour that leaves it refused with the point and the miss, and the pole it suggests
//! digitizing. Expected values come from the geometry, computed here independently of the
//! digitizer (closed forms for a circle, a fine polyline for a limacon).

use std::f64::consts::PI;
use std::process::Command;

fn motionctl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(args: &[&str]) -> serde_json::Value {
    let mut a = args.to_vec();
    a.push("--json");
    let (ok, out, err) = motionctl(&a);
    assert!(ok, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// Machine pole C = 8 in at beta = 260 deg in the contour frame: the part sits at about 80 deg,
/// 8 in out, inside Fahim's work area.
const POLE: [&str; 4] = ["--pole-c", "8", "--pole-beta", "4.537856"];

#[test]
fn a_circle_with_a_tool_lasts_its_contact_length_over_vt_and_starts_where_the_geometry_says() {
    let (a, tool, vt) = (2.0, 0.25, 0.4);
    let base = ["polar", "digitize", "circle:2", POLE[0], POLE[1], POLE[2], POLE[3]];
    let mut args = base.to_vec();
    args.extend(["--tool-radius", "0.25", "--vt", "0.4"]);
    let contact = json(&args);
    // The contact point runs on the circle, the tool centre on the circle of radius a + R.
    let (l_contact, l_centre) = (2.0 * PI * a, 2.0 * PI * (a + tool));
    assert!((num(&contact, "contact_path_in") / l_contact - 1.0).abs() < 1e-6, "{contact}");
    assert!((num(&contact, "path_in") / l_centre - 1.0).abs() < 1e-6, "{contact}");
    assert_eq!(contact["feed_at"], "contact");
    let t = num(&contact, "duration_s");
    assert!((t / (l_contact / vt) - 1.0).abs() < 1e-3, "{t} s vs {} s", l_contact / vt);
    // Held at the tool centre the same cut lasts (a + R) / a as long.
    args.extend(["--feed-at", "centre"]);
    let centre = json(&args);
    let tc = num(&centre, "duration_s");
    assert!((tc / (l_centre / vt) - 1.0).abs() < 1e-3, "{tc} s vs {} s", l_centre / vt);
    // The start: the contour's point at theta1 = 0 is (a, 0) moving +y; the tool centre is R
    // to its right, (a + R, 0); about the machine pole at C (cos beta, sin beta) that is:
    let beta = 4.537856f64;
    let (x, y) = (a + tool - 8.0 * beta.cos(), -8.0 * beta.sin());
    let (r, th) = (x.hypot(y), y.atan2(x).to_degrees());
    assert!((num(&contact, "start_r_in") - r).abs() <= 0.0005 + 1e-9, "{contact} vs r {r}");
    assert!((num(&contact, "start_theta_deg") - th).abs() < 1e-6, "{contact} vs theta {th}");
}

#[test]
fn a_limacon_with_a_tool_in_a_dimple_lasts_its_contour_length_over_vt() {
    // r = 4 + 2.5 cos(theta1): not convex (a dimple at theta1 = pi), length by a fine polyline.
    let (b, a, tool, vt) = (4.0, 2.5, 0.1, 0.75);
    let n = 400_000;
    let p = |t: f64| {
        let r = b + a * t.cos();
        [r * t.cos(), r * t.sin()]
    };
    let length: f64 = (0..n)
        .map(|i| {
            let (p0, p1) =
                (p(2.0 * PI * i as f64 / n as f64), p(2.0 * PI * (i + 1) as f64 / n as f64));
            (p1[0] - p0[0]).hypot(p1[1] - p0[1])
        })
        .sum();
    let v = json(&[
        "polar",
        "digitize",
        "limacon:4,2.5",
        "--pole-c",
        "6",
        "--pole-beta",
        "4.066",
        "--tool-radius",
        "0.1",
        "--vt",
        "0.75",
    ]);
    assert!((num(&v, "contact_path_in") / length - 1.0).abs() < 1e-6, "{v} vs {length}");
    // A simple closed curve turns once: the offset path is longer by 2 pi R.
    let centre = length + 2.0 * PI * tool;
    assert!((num(&v, "path_in") / centre - 1.0).abs() < 1e-6, "{v} vs {centre}");
    let t = num(&v, "duration_s");
    assert!((t / (length / vt) - 1.0).abs() < 1e-3, "{t} s vs {} s", length / vt);
    assert!((num(&v, "expected_s") / (length / vt) - 1.0).abs() < 1e-6, "{v}");
}

#[test]
fn a_users_work_area_refuses_a_contour_outside_it_and_suggests_a_pole_that_fits() {
    let dir = std::env::temp_dir().join(format!("polar_user_area_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let machine = dir.join("machine.toml");
    // 100..300 mm, 120 degrees: smaller than Fahim's arm.
    std::fs::write(&machine, "[polar]\nr_min_mm = 100\nr_max_mm = 300\ntheta_span_deg = 120\n")
        .unwrap();
    let m = machine.to_str().unwrap();
    let part = ["polar", "digitize", "limacon:3,2", "--tool-radius", "0.125", "--vt", "0.5"];
    let with = |pole: [&str; 2]| {
        let mut a = part.to_vec();
        a.extend(["--pole-c", pole[0], "--pole-beta", pole[1], "--machine", m]);
        motionctl(&a)
    };
    // Fits Fahim's machine (the README's pole) but comes within 3.7 in of the pole here.
    let (ok, _, err) = with(["6.5", "4.363"]);
    assert!(!ok);
    assert!(err.contains("leaves the work area (3.9370 < r < 11.8110 in"), "{err}");
    assert!(err.contains("at r = ") && err.contains("mm) outside"), "{err}");
    // The miss it reports is how far that point is inside r_min.
    let r: f64 = err.split("at r = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    let miss: f64 = err
        .split("deg (contour parameter")
        .nth(1)
        .unwrap()
        .split("it is ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((miss - (100.0 / 25.4 - r)).abs() < 1e-3, "{err}");
    // The suggested pole digitizes inside this work area.
    let s = err.split("a pole that fits: --pole-c ").nth(1).unwrap_or_else(|| panic!("{err}"));
    let c = s.split(' ').next().unwrap();
    let b = s.split("--pole-beta ").nth(1).unwrap().split(' ').next().unwrap();
    let (ok, out, err) = with([c, b]);
    assert!(ok, "suggested pole {c} {b}: {err}");
    assert!(out.contains("start      r "), "{out}");
    // Its plot: the part, the tool path, the steps and the work area, labelled with units.
    let svg = dir.join("part.svg");
    let mut a = part.to_vec();
    a.extend(["--pole-c", c, "--pole-beta", b, "--machine", m, "--plot", svg.to_str().unwrap()]);
    let (ok, _, err) = motionctl(&a);
    assert!(ok, "{err}");
    let drawn = std::fs::read_to_string(&svg).unwrap();
    if !err.contains("unlabelled") {
        for text in ["polar digitize limacon:3,2", "x, in", "theta, deg", "time, s", "work area"] {
            assert!(drawn.contains(text), "{text} not in the plot");
        }
    }
    // A contour no pole can fit: named as such.
    let mut big = part.to_vec();
    big[2] = "circle:6";
    big.extend(["--pole-c", "8", "--pole-beta", "4.5", "--machine", m]);
    let (ok, _, err) = motionctl(&big);
    assert!(!ok && err.contains("no machine pole fits it"), "{err}");
    // A work area that is not one.
    std::fs::write(&machine, "[polar]\nr_min_in = 5\nr_max_in = 4\ntheta_span_deg = 90\n").unwrap();
    let (ok, _, err) = with(["6.5", "4.363"]);
    assert!(!ok && err.contains("machine.toml: [polar]") && err.contains("r_max"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_users_part_plays_on_the_simulated_board_in_its_cut_time() {
    let dir = std::env::temp_dir().join(format!("polar_user_run_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = dir.join("part.bin");
    let b = bin.to_str().unwrap();
    let d = json(&[
        "polar",
        "digitize",
        "circle:2",
        POLE[0],
        POLE[1],
        POLE[2],
        POLE[3],
        "--tool-radius",
        "0.25",
        "--vt",
        "1.5",
        "-o",
        b,
    ]);
    let r = json(&["polar", "run", b, "--sim"]);
    assert_eq!(r["ok"], true, "{r}");
    assert_eq!(r["events_fired"], d["events"], "{r} vs {d}");
    // Back where it started (a closed contour), in degrees and inches.
    assert_eq!((num(&r, "theta_deg"), num(&r, "r_in")), (0.0, 0.0), "{r}");
    // The board's time is the stream's (to the status period, 40 ms by default).
    let (board, stream) = (num(&r, "board_s"), num(&d, "duration_s"));
    assert!((board - stream).abs() < 0.05, "board {board} s vs stream {stream} s");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_same_part_in_millimetres_gives_the_same_stream() {
    let inch = json(&[
        "polar",
        "digitize",
        "limacon:2,1.2",
        "--tool-radius",
        "0.1",
        "--vt",
        "0.75",
        "--pole-c",
        "5.1935",
        "--pole-beta",
        "3.6443",
    ]);
    let mm = json(&[
        "polar",
        "digitize",
        "limacon:50.8,30.48",
        "--tool-radius",
        "2.54",
        "--vt",
        "19.05",
        "--pole-c",
        "131.9149",
        "--pole-beta",
        "3.6443",
        "--units",
        "mm",
    ]);
    assert_eq!(mm["units"], "mm");
    assert_eq!((&mm["events"], &mm["radial_events"]), (&inch["events"], &inch["radial_events"]));
    assert!((num(&mm, "duration_s") - num(&inch, "duration_s")).abs() < 1e-3, "{mm} vs {inch}");
    for key in ["contact_path", "path", "min_radius_of_curvature"] {
        let (a, b) = (num(&mm, &format!("{key}_mm")), num(&inch, &format!("{key}_in")));
        assert!((a / (b * 25.4) - 1.0).abs() < 1e-9, "{key}: {a} mm vs {b} in");
    }
    // The radial resolution stays the machine's (0.001 in) unless --dr is given, in mm then.
    let fine = json(&[
        "polar",
        "digitize",
        "circle:50",
        "--vt",
        "10",
        "--pole-c",
        "200",
        "--pole-beta",
        "4.5",
        "--units",
        "mm",
        "--dr",
        "0.0127",
    ]);
    let coarse = json(&[
        "polar",
        "digitize",
        "circle:50",
        "--vt",
        "10",
        "--pole-c",
        "200",
        "--pole-beta",
        "4.5",
        "--units",
        "mm",
    ]);
    let (f, c) = (num(&fine, "radial_events"), num(&coarse, "radial_events"));
    assert!((f / c - 2.0).abs() < 0.01, "half the dR, twice the radial events: {f} vs {c}");
}

#[test]
fn the_pole_search_answers_in_json_with_the_flags_to_use() {
    let v = json(&["polar", "pole", "limacon:3,2"]);
    let (c, beta) = (num(&v, "pole_c_in"), num(&v, "pole_beta_rad"));
    assert_eq!(v["in_work_area"], true, "{v}");
    assert!((num(&v, "pole_c_mm") / (c * 25.4) - 1.0).abs() < 1e-12);
    // The pole it finds digitizes the contour inside the work area.
    let (c, beta) = (format!("{c:.4}"), format!("{beta:.4}"));
    let d = json(&[
        "polar",
        "digitize",
        "limacon:3,2",
        "--vt",
        "0.5",
        "--pole-c",
        &c,
        "--pole-beta",
        &beta,
    ]);
    assert!(num(&d, "events") > 0.0, "{d}");
}

#[test]
fn copy_mode_reports_in_json_with_degrees_and_inches() {
    let v = json(&["polar", "copy", "--sim", "--template", "limacon:0.6"]);
    assert_eq!(v["ok"], true, "{v}");
    let (th, r) = (num(&v, "theta_steps"), num(&v, "r_steps"));
    assert!(th != 0.0 && r != 0.0, "the arm moved: {v}");
    assert!((num(&v, "theta_deg") - th * 360.0 / 16000.0).abs() < 1e-9, "{v}");
    assert!((num(&v, "r_in") - r / 1000.0).abs() < 1e-12, "{v}");
}
