//! `motionctl check FILE`: every error of the file with file:line:column, the word and rs274's
//! wording, then a summary; exit 1 when there is an error, 0 when there is none.

use std::process::Command;

fn check(src: &str, extra: &[&str]) -> (i32, String) {
    let dir = std::env::temp_dir().join(format!("motionctl-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("p{}.ngc", src.len()));
    std::fs::write(&file, src).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .arg("check")
        .arg(&file)
        .args(extra)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text.replace(&file.display().to_string(), "F"))
}

#[test]
fn every_error_is_listed_with_its_place_and_the_exit_is_non_zero() {
    let (code, text) = check("G21 G90\nG1 X10 F100\nG2 X20 Y0\nG0 X1 X2\nG1 Y5 F-3\nM2\n", &[]);
    assert_eq!(code, 1, "{text}");
    // The interpreter goes on after an error (as `rs274 -n 0`), so all three are reported.
    for want in [
        "F:3:1: error: R i j k words all missing for arc (word G2)",
        "F:4:7: error: Multiple x words on one line (word X)",
        "F:5:7: error: Negative f word used (word F-3)",
    ] {
        assert!(text.contains(want), "missing {want:?} in:\n{text}");
    }
    assert!(text.contains("3 errors"), "{text}");
}

#[test]
fn a_clean_file_passes_with_a_summary() {
    let (code, text) = check("G21 G90 G0 X0 Y0\nG1 X10 F200\nG3 X20 Y0 R5\nM2\n", &[]);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("F: 4 lines, 3 moves, 0 errors, 0 warnings"), "{text}");
}

#[test]
fn with_a_machine_soft_limits_and_missing_axes_are_errors() {
    let machine = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/machine.toml");
    let (code, text) =
        check("G21 G90 G0 X10 Y10\nG1 X400 F300\nG0 A5\nM2\n", &["--machine", machine]);
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("F:2:1: error: axis X target 400.0000 mm is above its soft limit"),
        "{text}"
    );
    assert!(
        text.contains("F:3:1: error: moves A to 5.0000 but the machine has no A axis"),
        "{text}"
    );
}
