//! A reader that goes away (`motionctl ... | head`) ends the output quietly: exit 0, no panic.

use std::process::{Command, Stdio};

fn run_into_closed_pipe(args: &[&str]) -> std::process::Output {
    let (reader, writer) = std::io::pipe().expect("pipe");
    // The reader is gone before the command writes its first byte.
    drop(reader);
    Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(args)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .expect("motionctl runs")
}

#[test]
fn listings_end_quietly_on_a_closed_pipe() {
    // `fourier` is `turning`'s older name, kept for scripts that still type it.
    for args in [&["fourier", "table"][..], &["polar", "dump", "--help"][..]] {
        let out = run_into_closed_pipe(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "motionctl {args:?}: {:?}, stderr: {stderr}", out.status);
        assert!(!stderr.contains("panicked"), "motionctl {args:?} panicked: {stderr}");
    }
}
