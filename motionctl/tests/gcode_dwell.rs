//! G4 dwell in a G-code job, and `dwell_s` in a TOML job: planned as a stop at rest, counted in
//! the plan's summary, and executed by `run`: the machine stands still at the end of the motion
//! before it for at least the dwell, then carries on (and `run --json` reports the run).

use std::path::{Path, PathBuf};
use std::process::Command;

fn motionctl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn machine() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/corpus-machine.toml").display().to_string()
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gcode_dwell_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_dwell_stops_the_machine_at_rest_for_its_time_between_the_moves() {
    let dir = temp("run");
    let file = dir.join("dwell.ngc");
    // 10 mm at 600 mm/min, stand 0.7 s (spindle spin-up, as CAM writes after M3), 10 mm more.
    std::fs::write(&file, "G21 G90\nG1 X10 F600\nM3 S1000\nG4 P0.7\nG1 X20\nM5\nM2\n").unwrap();
    let f = file.to_str().unwrap();
    let m = machine();
    let (ok, out, err) = motionctl(&["plan", f, "--machine", &m]);
    assert!(ok, "{err}");
    assert!(out.contains("dwells     1 (G4), 0.700 s at rest"), "{out}");
    assert!(!err.contains("dwell"), "no longer a warning: {err}");
    let csv = dir.join("status.csv");
    let (ok, out, err) =
        motionctl(&["run", f, "--machine", &m, "--sim", "--yes", "--csv", csv.to_str().unwrap()]);
    assert!(ok, "{out}\n{err}");
    assert!(err.contains("dwell (G4) 0.700 s at rest"), "{err}");
    // From the status log: when X first reads 10 mm, and when it first leaves it.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (wall, x) = (col("wall_ms"), col("X_mm"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (v[wall].parse().unwrap(), v[x].parse().unwrap())
        })
        .collect();
    let arrived = rows.iter().find(|r| (r.1 - 10.0).abs() < 1e-9).expect("X reaches 10 mm").0;
    let left = rows.iter().find(|r| r.1 > 10.0 + 1e-9 && r.0 > arrived).expect("X goes on").0;
    // At least the dwell, less one status period (the log's resolution, 40 ms).
    assert!(left - arrived >= 700.0 - 40.0, "stood {} ms at X 10", left - arrived);
    assert!((rows.last().unwrap().1 - 20.0).abs() < 1e-9);
    // The same run's summary for scripts: one JSON object on stdout, positions in mm.
    let (ok, out, err) = motionctl(&["run", f, "--machine", &m, "--sim", "--yes", "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value =
        serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}"));
    assert_eq!((v["ok"].as_bool(), v["positions_ok"].as_bool()), (Some(true), Some(true)), "{v}");
    assert_eq!(v["positions"]["X"]["mm"].as_f64(), Some(20.0), "{v}");
    assert_eq!(v["positions"]["X"]["steps"], v["positions"]["X"]["model_steps"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_toml_job_dwells_with_dwell_s_and_refuses_a_bad_one() {
    let dir = temp("toml");
    let src = std::fs::read_to_string(machine()).unwrap();
    let job = |entry: &str| {
        format!("{src}\n[[moves]]\nto = {{ X = 5 }}\nfeed_mm_min = 300\n\n[[moves]]\n{entry}\n\n[[moves]]\nto = {{ X = 0 }}\n")
    };
    let file = dir.join("job.toml");
    std::fs::write(&file, job("dwell_s = 1.25")).unwrap();
    let (ok, out, err) = motionctl(&["plan", file.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(out.contains("dwells     1 (G4), 1.250 s at rest"), "{out}");
    for (bad, says) in [
        ("dwell_s = -1", "moves[1].dwell_s"),
        ("dwell_s = 4000", "moves[1].dwell_s"),
        ("dwell_s = 1\nfeed_mm_min = 100", "take no feed_mm_min"),
        ("dwell_s = 1\npause = true", "exactly one of"),
    ] {
        std::fs::write(&file, job(bad)).unwrap();
        let (ok, _, err) = motionctl(&["plan", file.to_str().unwrap()]);
        assert!(!ok && err.contains(says), "{bad}: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
