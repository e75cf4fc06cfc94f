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
fn fourier_thesis_table_prints_table_2_2() {
    let (ok, out, err) = motionctl(&["fourier", "table", "--mode", "thesis"]);
    assert!(ok, "{err}");
    // Table 2-2 of the thesis, row X = 8.0 (digest oracle A).
    let row = out.lines().find(|l| l.trim_start().starts_with("8.0|")).expect("an X = 8.0 row");
    for v in ["-0.0001199", "-0.0017015", "-0.0060288", "0.0000515"] {
        assert!(row.contains(v), "{row} lacks {v}");
    }
}

#[test]
fn fourier_firmware_table_needs_the_accurate_mode() {
    let (ok, _, err) = motionctl(&["fourier", "table", "--mode", "thesis", "--firmware-rust", "x"]);
    assert!(!ok);
    assert!(err.contains("--mode accurate"), "{err}");
}

#[test]
fn fourier_accurate_table_writes_the_firmware_table() {
    let dir = std::env::temp_dir().join(format!("motionctl-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("table.rs");
    let (ok, out, err) =
        motionctl(&["fourier", "table", "--firmware-rust", path.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(out.contains("81 rows"), "{out}");
    // The same source as the checked-in firmware table.
    let written = std::fs::read_to_string(&path).unwrap();
    let checked_in = include_str!("../../src/zslide/douglass_table.rs");
    assert_eq!(written.trim(), checked_in.trim());
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
