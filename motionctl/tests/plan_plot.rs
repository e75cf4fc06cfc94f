//! `plan --plot`: the programmed toolpath of a CAM file and of a TOML job, drawn with rapids told
//! apart from feed moves and axes in mm.

use std::path::Path;
use std::process::Command;

fn plan_plot(job: &str, machine: Option<&str>, out: &Path) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_motionctl"));
    cmd.arg("plan").arg(root.join(job)).arg("--no-model").arg("--plot").arg(out);
    if let Some(m) = machine {
        cmd.arg("--machine").arg(root.join(m));
    }
    let o = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    assert!(err.contains("wrote"), "{err}");
    err
}

#[test]
fn a_cam_file_and_a_toml_job_are_drawn_with_rapids_apart() {
    let dir = std::env::temp_dir().join(format!("plan_plot_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (job, machine, name) in [
        (
            "../host/gcode/tests/corpus/linuxcnc-hole-circle-g81.ngc",
            Some("examples/corpus-machine.toml"),
            "holes.svg",
        ),
        ("examples/square.toml", None, "square.svg"),
    ] {
        let out = dir.join(name);
        let err = plan_plot(job, machine, &out);
        let svg = std::fs::read_to_string(&out).unwrap();
        assert!(svg.len() > 1000 && svg.contains("<svg"), "{name}");
        if !err.contains("unlabelled") {
            for text in ["toolpath", "feed moves", "rapids", "X, mm", "Y, mm", "Z, mm"] {
                assert!(svg.contains(text), "{name}: {text} missing");
            }
        }
    }
    // Not an image name: refused before anything is written.
    let o = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["plan", concat!(env!("CARGO_MANIFEST_DIR"), "/examples/square.toml"), "--plot"])
        .arg(dir.join("square.jpg"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains(".svg or .png"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plan_json_gives_the_totals_and_the_final_position_in_mm() {
    let dir = std::env::temp_dir().join(format!("plan_json_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("part.ngc");
    std::fs::write(&file, "G21 G90\nG0 Z5\nG1 X12.5 Y-3 F900\nG4 P1.5\nG1 Z-1\nM2\n").unwrap();
    let machine = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/corpus-machine.toml");
    for extra in [&[][..], &["--no-model"][..]] {
        let o = Command::new(env!("CARGO_BIN_EXE_motionctl"))
            .arg("plan")
            .arg(&file)
            .args(["--machine", machine, "--json"])
            .args(extra)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        assert_eq!((v["moves"].as_u64(), v["dwells"].as_u64()), (Some(3), Some(1)), "{v}");
        assert_eq!(v["dwell_s"].as_f64(), Some(1.5));
        let end = [("X", 12.5), ("Y", -3.0), ("Z", -1.0)];
        for (axis, mm) in end {
            assert_eq!(v["axes"][axis]["final_mm"].as_f64(), Some(mm), "{axis}: {v}");
        }
        // The model's time only when it ran.
        assert_eq!(v["model_s"].is_f64(), extra.is_empty(), "{v}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
