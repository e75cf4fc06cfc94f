//! The capability subcommands end to end, through the built binary.

use std::process::Command;

fn motionctl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn wire_plan_runs_the_job_through_the_model() {
    let (ok, out, err) = motionctl(&["wire", "plan"]);
    assert!(ok, "{err}");
    assert!(out.contains("final steps [0, 0, 0, 0]"), "{out}");
    let ppm: f64 = out
        .lines()
        .find(|l| l.contains("host model"))
        .and_then(|l| l.split('(').nth(1))
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .expect("a ppm figure");
    assert!(ppm.abs() < 10_000.0, "{ppm} ppm off 60 A / FR");
    let (ok, _, err) = motionctl(&["wire", "plan", "--fr=0"]);
    assert!(!ok);
    assert!(err.contains("fr"), "{err}");
}

#[test]
fn wire_run_reports_in_json_with_mm_and_degrees() {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["wire", "run", "--segments", "1..3", "--sim", "--json"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // stdout is the JSON object alone.
    let v: serde_json::Value =
        serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: {text}"));
    assert_eq!(v["ok"], true, "{v}");
    for (axis, unit) in [("X", "mm"), ("Y", "mm"), ("B", "deg"), ("A", "deg")] {
        let a = &v["positions"][axis];
        assert!(a[unit].is_f64(), "{axis} in {unit}: {v}");
        assert_eq!(a["steps"], a["model_steps"], "{axis}");
    }
}
