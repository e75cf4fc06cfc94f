//! End to end, wire jobs: `motionctl wire run --qemu` runs segments 1..5 of the planned
//! circle -> complex die (4 segments, ~39 s of machine time) as a wire job on the link
//! firmware in QEMU, closes the simulated wire-stall switch (`Sim(Inject)`) 8 s after the start
//! for 3 s, and the result is checked here too, independently of motionctl's own check: the
//! board saw one stall, retraced and returned, and the final X, Y, beta, alpha steps == the sum
//! of the segments' steps (a lost or extra step anywhere in the stop, retrace or return shows).
//! QEMU runs the idle 10 kHz tick well ahead of the wall clock: ~20 s of wall time.

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Segments of the planned job run (the first is the circle's start-up move).
const SEGMENTS: std::ops::Range<usize> = 1..5;
const STALL_AT_S: &str = "8";
const STALL_FOR_S: &str = "3";

/// The `cargo xtask test` step (also `cargo xtask wire-e2e`).
pub fn test(root: &Path) -> Result<()> {
    use motionctl::wire::continuous::{circle_complex_path, plan, ContinuousParams};
    let cfg = motion::wire::machine::config();
    let job = plan(&circle_complex_path()?, &cfg, &ContinuousParams::default())?;
    let part = job.segments.get(SEGMENTS).context("the planned job is too short")?;
    let mut end = [0i64; 4];
    for s in part {
        for (e, &d) in end.iter_mut().zip(&s.steps) {
            *e += d as i64;
        }
    }
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let s = |x: &str| x.to_string();
    let args = vec![
        s("wire"),
        s("run"),
        s("--qemu"),
        s("--firmware"),
        elf.display().to_string(),
        s("--segments"),
        format!("{}..{}", SEGMENTS.start, SEGMENTS.end),
        s("--stall-at"),
        s(STALL_AT_S),
        s("--stall-for"),
        s(STALL_FOR_S),
    ];
    let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
    if !ok {
        bail!("motionctl wire run failed (see its output above)");
    }
    let m = summary_ints(&stdout, "wire-summary ")?;
    let get = |k: &str| m.get(k).copied().unwrap_or(i64::MIN);
    let pos = [get("x"), get("y"), get("beta"), get("alpha")];
    let mut problems = Vec::new();
    if pos != end {
        problems.push(format!("final X, Y, beta, alpha {pos:?} != sum of the segments {end:?}"));
    }
    if get("stalls") != 1 || get("retraces") < 1 || get("returns") < 1 {
        problems.push(format!(
            "stalls {} retraces {} returns {}: expected one stall, retraced and returned",
            get("stalls"),
            get("retraces"),
            get("returns")
        ));
    }
    println!(
        "  wire e2e: {} segments with a stall at {STALL_AT_S} s for {STALL_FOR_S} s: {} stall, {} \
         retrace / {} return segments, largest retrace {} steps; final {pos:?} == sum of the \
         segments; board {} ticks; {:.1} s wall",
        part.len(),
        get("stalls"),
        get("retraces"),
        get("returns"),
        get("max_retrace_steps"),
        get("board_ticks"),
        wall.as_secs_f64()
    );
    if !problems.is_empty() {
        bail!("wire end to end: {}", problems.join("; "));
    }
    Ok(())
}
