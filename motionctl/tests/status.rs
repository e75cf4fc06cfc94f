//! `motionctl status` on the simulated board: what the board is, the jobs it runs (from the
//! capability registry and its Hello), its state and counters.

use std::process::Command;

#[test]
fn status_names_the_board_and_the_jobs_it_runs() {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(["status", "--sim"]).output();
    let out = out.expect("motionctl runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    let line = |label: &str| text.lines().find(|l| l.starts_with(label)).map(str::to_owned);
    assert!(line("board ").is_some_and(|l| l.contains("motionctl-sim")), "{text}");
    // The plain simulated board announces no capability's jobs: G-code only.
    assert_eq!(line("jobs ").as_deref(), Some("jobs       G-code"), "{text}");
    assert!(line("state ").is_some_and(|l| l.contains("Ready")), "{text}");
}
