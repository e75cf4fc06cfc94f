//! The dies `motionctl wire plan|run` cut (`--die NAME`, `--mdi FILE`): each thesis die plans
//! and runs through the host model, its trapezoid total is the thesis's printed figure, the
//! default is the checked-in circle -> complex job, MDI errors name the line, and joint limits
//! refuse a die before anything is planned.

mod wire_support;

use motion::wire::{circle_complex_job as table, machine};
use motionctl::wire::continuous::{
    circle_complex_path, plan, ContinuousParams, JobError, LimitViolation,
};
use motionctl::wire::dies::{mdi_die, thesis_die, DieOverrides, ThesisDie};
use motionctl::wire::gear::{gear_profile, GearSpec};
use motionctl::wire::path::{totals, Path};
use motionctl::wire::{Point2, WireError};
use std::process::Command;

fn motionctl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn temp_file(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("motionctl-wire-dies-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Every thesis die passes the joint limits, plans at its thesis feed and runs through the host
/// model back to its start; its trapezoid total is the thesis's printed area (plates 9, 10, 16,
/// 19: seed L5240-5576; gear: Table 12) within the tolerances of `wire_plates` / `wire_gear`.
#[test]
fn every_thesis_die_plans_and_runs() {
    let cfg = machine::config();
    for kind in ThesisDie::ALL {
        let d = thesis_die(kind, &DieOverrides::default()).unwrap();
        let path = d.path().unwrap();
        let prm = ContinuousParams { fr_mm2_per_min: d.fr_mm2_per_min, ..Default::default() };
        let job = plan(&path, &cfg, &prm).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        let mut segs = job.segments.iter().copied();
        let r = motion::model::run(&cfg, || segs.next(), &[], u64::MAX, |_, _| {}).unwrap();
        assert_eq!(&r.positions[..4], &[0; 4], "{kind:?} ends where it started");
        let t = r.ticks as f64 / cfg.tick_hz as f64;
        assert!((t / job.time_ruled_s - 1.0).abs() < 0.01, "{kind:?}: {t} s");
        let key = match kind {
            ThesisDie::CircleComplex => "table11_total_area_mm2",
            ThesisDie::Plate9 => "plate9_area_mm2",
            ThesisDie::Plate10 => "plate10_area_mm2",
            ThesisDie::Plate16 => "plate16_area_mm2",
            ThesisDie::Plate19Stage1 => "plate19_stage1_area_mm2",
            ThesisDie::Plate19Stage2 => "plate19_stage2_area_mm2",
            ThesisDie::Plate19Stage3 => "plate19_stage3_area_mm2",
            ThesisDie::Gear => "table12_total_area_mm2",
        };
        let (line, printed) = wire_support::scalar(key);
        let rel = if kind == ThesisDie::Plate19Stage3 { 3e-5 } else { 0.0 };
        let a = totals(&path, d.fr_mm2_per_min).unwrap().area_mm2;
        wire_support::check_rel(a, &printed, &format!("{kind:?} area"), line, rel);
        eprintln!(
            "{kind:?}: {} segments, ruled {:.3} mm^2, trapezoid {a:.3} mm^2, model {t:.3} s",
            job.segments.len(),
            job.area_ruled_mm2
        );
    }
}

/// The default die is the circle -> complex path, planned exactly as the checked-in firmware
/// table; the gear die is Table 12's path.
#[test]
fn default_die_is_the_checked_in_job_and_gear_is_table12() {
    let d = thesis_die(ThesisDie::CircleComplex, &DieOverrides::default()).unwrap();
    assert_eq!(d.path().unwrap(), circle_complex_path().unwrap());
    let j = plan(&d.path().unwrap(), &machine::config(), &ContinuousParams::default()).unwrap();
    assert_eq!(j.segments.len(), table::SEGMENTS.len());
    for (k, (a, b)) in table::SEGMENTS.iter().zip(&j.segments).enumerate() {
        assert_eq!(a.segment(k as u32), *b, "segment {k}");
    }
    let g = thesis_die(ThesisDie::Gear, &DieOverrides::default()).unwrap();
    let spec = GearSpec { module_mm: 6.0, pitch_diameter_mm: 72.0, pressure_angle_deg: 20.0 };
    let p = gear_profile(spec, 8, 4, 5, Point2::new(0.0, -60.0)).unwrap();
    assert_eq!(g.path().unwrap(), Path::new(30.0, p.clone(), p).unwrap());
    // Overrides: 10 teeth of module 5 (PD 50) start 18 mm outside the 30 mm addendum circle,
    // i.e. still at the thesis's (0, -60).
    let o = DieOverrides { module_mm: Some(5.0), teeth: Some(10), ..Default::default() };
    let g = thesis_die(ThesisDie::Gear, &o).unwrap();
    assert_eq!(g.start, Point2::new(0.0, -60.0));
    assert!(g.label.contains("10 teeth") && g.label.contains("PD 50"), "{}", g.label);
    // Gear parameters on another die, or teeth and pitch diameter both, are errors.
    let o = DieOverrides { module_mm: Some(5.0), ..Default::default() };
    assert!(matches!(
        thesis_die(ThesisDie::Plate9, &o),
        Err(WireError::BadParameter { name: "module_mm", .. })
    ));
    let o = DieOverrides { teeth: Some(10), pitch_diameter_mm: Some(50.0), ..Default::default() };
    assert!(thesis_die(ThesisDie::Gear, &o).is_err());
    let o = DieOverrides { zt_mm: Some(-1.0), ..Default::default() };
    assert!(thesis_die(ThesisDie::Plate10, &o).is_err());
}

/// `wire plan` with no die prints what `--die circle-complex` prints, and its figures are the
/// planner's; every die is reachable from the CLI.
#[test]
fn cli_plans_every_die() {
    let (ok, default, err) = motionctl(&["wire", "plan"]);
    assert!(ok, "{err}");
    let (ok, named, err) = motionctl(&["wire", "plan", "--die", "circle-complex"]);
    assert!(ok, "{err}");
    assert_eq!(default, named);
    let j = plan(&circle_complex_path().unwrap(), &machine::config(), &ContinuousParams::default())
        .unwrap();
    for want in [
        "circle -> complex die, ZT 39 mm, FR 800 mm^2/min, tolerance 0.01 mm\n".to_string(),
        format!("  segments            {}\n", j.segments.len()),
        format!(
            "  ruled area          {:.3} mm^2 (thesis trapezoids {:.3})\n",
            j.area_ruled_mm2, j.area_trapezoid_mm2
        ),
        format!("  60 A / FR           {:.3} s\n", j.time_ruled_s),
        "  points              81 per face, from and back to (0, 0) mm\n".to_string(),
        // Table 7 / Table 8 totals (seed L4117, L4212): 1963.495 and 817.2175 mm^2.
        "  top face            sector area 1963.495 mm^2".to_string(),
        "  bottom face         sector area 817.218 mm^2".to_string(),
        // Table 11's total time (seed L4483), 564.279 s.
        "  thesis 60 A / FR    564.279 s".to_string(),
    ] {
        assert!(default.contains(&want), "missing {want:?} in\n{default}");
    }
    for die in ["plate9", "plate10", "plate16", "plate19-stage1", "plate19-stage2"] {
        let (ok, out, err) = motionctl(&["wire", "plan", "--die", die]);
        assert!(ok, "{die}: {err}");
        assert!(out.contains("final steps [0, 0, 0, 0]"), "{die}: {out}");
    }
    let (ok, out, err) = motionctl(&[
        "wire",
        "plan",
        "--die",
        "gear",
        "--module",
        "5",
        "--teeth",
        "10",
        "--pressure-angle",
        "14.5",
        "--zt",
        "20",
        "--fr",
        "400",
    ]);
    assert!(ok, "{err}");
    assert!(out.starts_with("spur gear m 5 x 10 teeth (PD 50, PA 14.5 deg) die, ZT 20 mm, FR 400"));
    assert!(out.contains("from and back to (0, -60) mm"), "{out}");
    let (ok, _, err) = motionctl(&["wire", "plan", "--die", "plate9", "--teeth", "10"]);
    assert!(!ok && err.contains("teeth") && err.contains("gear die only"), "{err}");
    let (ok, _, err) = motionctl(&["wire", "plan", "--die", "nonsense"]);
    assert!(!ok && err.contains("invalid value 'nonsense' for '--die"), "{err}");
}

/// An MDI file plans from the CLI; a bad one is refused with the file, the line and what is
/// wrong, and never a panic.
#[test]
fn mdi_files_plan_and_bad_ones_name_the_line() {
    // A cone frustum: R 20 at the bottom, R 15 at the top, 40 points, ZT 30.
    let mut text = String::from("# frustum\n30\n40\n");
    for i in 0..=40 {
        let a = std::f64::consts::TAU * i as f64 / 40.0;
        let (c, s) = (a.cos(), a.sin());
        text += &format!("{},{},{},{}\n", 20.0 * c, 20.0 * s, 15.0 * c, 15.0 * s);
    }
    let text = text.replacen("\n40\n", "\n41\n", 1);
    let good = temp_file("frustum.mdi", &text);
    let (ok, out, err) = motionctl(&["wire", "plan", "--mdi", good.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(out.contains("points              41 per face"), "{out}");
    assert!(out.contains("final steps [0, 0, 0, 0]"), "{out}");

    let cases = [
        ("39\n2\n1,2,3,4\n5,6,x,8\n", "line 4: point index 1 field XT: `x` is not a number"),
        ("39\n2\n1,2,3,4\n5,6\n", "point index 1 field XT: missing (the file ends at line 4)"),
        ("# c\n0\n1\n1 1 1 1\n", "line 2: ZT (first number): 0 is not a thickness > 0 mm"),
        ("39\n2.5\n", "line 2: N (second number): 2.5 is not a positive whole number"),
        ("39 1\n1 1 1 1\n\n9\n", "line 4: after point index 0: unexpected extra value `9`"),
        ("39 1\n1 1 1 inf\n", "line 2: point index 0 field YT: `inf` is not finite"),
    ];
    for (k, (text, want)) in cases.iter().enumerate() {
        let e = mdi_die("f", text, &DieOverrides::default()).unwrap_err();
        assert!(e.to_string().contains(want), "case {k}: {e}");
        let p = temp_file(&format!("bad{k}.mdi"), text);
        let (ok, out, err) = motionctl(&["wire", "plan", "--mdi", p.to_str().unwrap()]);
        assert!(!ok && out.is_empty(), "case {k}: {out}");
        assert!(err.contains(&format!("{}: ", p.display())) && err.contains(want), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (ok, _, err) = motionctl(&["wire", "plan", "--mdi", "/nonexistent/x.mdi"]);
    assert!(!ok && err.contains("/nonexistent/x.mdi"), "{err}");
}

/// A die whose point 3 of the path (point index 2 of the file) tilts beta to -59 deg is refused
/// before anything is planned, naming that point, its coordinates and joints; the CLI says the
/// same. The thesis dies pass (see [`every_thesis_die_plans_and_runs`]).
#[test]
fn joint_limits_refuse_a_die_naming_the_point() {
    // Bottom (10, 0) under top (-40, 0) at ZT 30: beta = atan2(-50, 30) = -59.04 deg < -50.
    let text = "30 4\n20,0,20,0\n0,20,0,20\n10,0,-40,0\n0,-20,0,-20\n";
    let d = mdi_die("f", text, &DieOverrides::default()).unwrap();
    let path = d.path().unwrap();
    let e = plan(&path, &machine::config(), &ContinuousParams::default()).unwrap_err();
    let JobError::Limit(v) = &e else {
        panic!("not a limit error: {e}");
    };
    let LimitViolation { index, bottom, top, joints, source } = &**v;
    assert_eq!(*index, 3);
    assert_eq!((*bottom, *top), (Point2::new(10.0, 0.0), Point2::new(-40.0, 0.0)));
    let beta = (-50f64).atan2(30.0).to_degrees();
    assert!((joints.beta_rad.to_degrees() - beta).abs() < 1e-9);
    assert!(matches!(source, WireError::Limit { index: 3, field: "beta_deg", .. }), "{source}");
    let msg = e.to_string();
    for want in ["path point 3", "bottom (10.000, 0.000) mm", "top (-40.000, 0.000) mm"] {
        assert!(msg.contains(want), "{msg}");
    }
    assert!(msg.contains(&format!("beta {beta:.3} deg")) && msg.contains("-50"), "{msg}");
    let p = temp_file("limit.mdi", text);
    let (ok, out, err) = motionctl(&["wire", "plan", "--mdi", p.to_str().unwrap()]);
    assert!(!ok && !out.contains("segments"), "{out}");
    assert!(err.contains("path point 3") && err.contains("beta"), "{err}");
    // Without the rule (beta limit lowered to -65 deg) the same die plans: the check is what
    // refused it.
    let mut prm = ContinuousParams::default();
    prm.limits.beta_min_deg = -65.0;
    assert!(plan(&path, &machine::config(), &prm).is_ok());
    // X travel: a die 55 mm off centre is refused at its first point (path point 1).
    let text = "30 1\n55,0,55,0\n";
    let d = mdi_die("f", text, &DieOverrides::default()).unwrap();
    let e = plan(&d.path().unwrap(), &machine::config(), &ContinuousParams::default());
    let Err(JobError::Limit(v)) = &e else { panic!("{e:?}") };
    assert_eq!(v.index, 1);
    assert!(matches!(v.source, WireError::Limit { index: 1, field: "x_mm", .. }), "{e:?}");
}
