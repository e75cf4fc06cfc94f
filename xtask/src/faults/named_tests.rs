//! Fault cases the repository's tests already inject, run by name and counted: the simulated
//! board's reset, silence and noise (`motionctl/tests/link_sim.rs`), the config record in flash
//! (QEMU has no flash store: the record decoder and the boot are tested on the host over a
//! NOR-flash mock), the board's own faults, and the library-level bad inputs (stream files with
//! dropped or repeated blocks, degenerate contours, a home position that would overflow).

use super::Tally;
use anyhow::{Context, Result};
use std::path::Path;

/// (class, test target, test name).
const TESTS: [(&str, &str, &str); 12] = [
    ("reset mid-job (sim)", "link_sim", "a_board_reset_stops_the_job_with_a_clear_error"),
    ("link drop (sim)", "link_sim", "a_silent_link_is_reopened_and_the_job_resumes"),
    (
        "byte noise (sim)",
        "link_sim",
        "two_thousand_segments_through_one_percent_noise_arrive_once_in_order",
    ),
    (
        "config record corruption",
        "machine_persist",
        "power_cut_at_every_byte_of_a_save_never_yields_garbage",
    ),
    (
        "config record corruption",
        "machine_persist",
        "corrupt_newest_falls_back_and_corrupt_only_reports_corrupt",
    ),
    (
        "config record corruption",
        "machine_persist",
        "boot_with_a_corrupt_record_uses_safe_defaults_and_says_so",
    ),
    (
        "config record corruption",
        "machine_persist",
        "missing_corrupt_and_invalid_each_latch_their_own_code_until_a_valid_config",
    ),
    (
        "unsupported stored tick rate",
        "machine_board_faults",
        "an_unsupported_stored_tick_rate_boots_on_safe_defaults_until_a_valid_config",
    ),
    (
        "rejected segment (feeder)",
        "machine_board_faults",
        "board_faults_stop_the_machine_and_clear_at_once",
    ),
    (
        "position overflow",
        "machine_board_faults",
        "a_home_position_beyond_2_pow_46_steps_is_refused",
    ),
    ("stream file blocks", "polar_dump", "a_dropped_or_duplicated_block_is_named"),
    ("NaN / degenerate geometry", "polar_digitizer", "degenerate_and_unbounded_inputs_are_refused"),
];

/// Runs [`TESTS`] in one `cargo test` (the host-tests step's workspace and profile, so nothing
/// is built again after it) and counts each test as one injection.
pub fn run(root: &Path, tally: &mut Tally) -> Result<()> {
    let mut targets: Vec<&str> = TESTS.iter().map(|t| t.1).collect();
    targets.dedup();
    let mut cargo = crate::cargo(root);
    // Every listed test runs even when one fails (each is its own case).
    cargo
        .args(["test", "--workspace", "--profile", "test-fast", "--no-fail-fast"])
        .args(crate::HOST_EXCLUDES);
    for t in &targets {
        cargo.args(["--test", t]);
    }
    let out = cargo
        .arg("--")
        .arg("--exact")
        .args(TESTS.iter().map(|t| t.2))
        .output()
        .context("running cargo test")?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    for (class, target, name) in TESTS {
        let passed = stdout.contains(&format!("test {name} ... ok"));
        println!("  {class}: {target}::{name} {}", if passed { "ok" } else { "FAILED" });
        let r = if passed {
            Ok(())
        } else {
            let stderr = String::from_utf8_lossy(&out.stderr);
            let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
            Err(anyhow::anyhow!("{target}::{name} did not pass: {}", tail.join(" | ")))
        };
        tally.record(class, 1, 1, r);
    }
    Ok(())
}
