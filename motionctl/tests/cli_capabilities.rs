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
