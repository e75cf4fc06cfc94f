//! `cargo xtask gcode-e2e`: real G-code files from the corpus (written by CAM programs and
//! senders, host/gcode/tests/corpus) run end to end: through motion-gcode, the planner and the
//! link protocol to the simulated board, and every file of up to 30 s of machine time to the link
//! firmware in QEMU (`cargo xtask gcode-corpus`'s short set, which also checks the executed path).
//! Each run must execute every segment once, in order, and end at the host model's position,
//! which `motionctl`'s planning already pinned to the program's end point. (The power cut in the
//! middle of [`ON_QEMU`], with `run --resume` on a fresh board, is a case of `cargo xtask
//! faults`.)
//! A probing program (host/gcode/tests/programs) runs on both boards against a simulated probe
//! surface (`run --sim-probe`): its G38.2 must trip, and the rest, planned from where the board
//! stopped, must end where it was planned to.

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use crate::gcode_corpus::MACHINE;
use anyhow::{bail, Result};
use std::path::Path;

/// Short files (a few seconds of machine time each): G10 L2/L20 offsets with G53, and a
/// helical thread mill in G91 with R-form arcs.
const ON_SIM: [&str; 2] = ["linuxcnc-g10-l2-l20.ngc", "cncjs-helical-thread-milling.gcode"];
/// The corpus file the fault suite cuts the power in the middle of.
pub(crate) const ON_QEMU: &str = "cncjs-helical-thread-milling.gcode";
/// Probes a part's top (G38.2, which must trip), makes it the work Z zero, cuts, then a G38.3
/// that misses; the simulated probe surface it runs against, and the probe moves that trip.
const PROBING: &str = "host/gcode/tests/programs/probe_surface.ngc";
const PROBE_SURFACE: &str = "z=-3.2";
const PROBES_TRIPPED: i64 = 1;

pub fn test(root: &Path) -> Result<()> {
    let bin = build_motionctl(root)?;
    let corpus = |f: &str| format!("host/gcode/tests/corpus/{f}");
    let mut runs: Vec<(String, &str, Vec<&str>)> =
        ON_SIM.iter().map(|f| (corpus(f), "--sim", vec![])).collect();
    for board in ["--sim", "--qemu"] {
        runs.push((PROBING.to_string(), board, vec!["--sim-probe", PROBE_SURFACE]));
    }
    for (path, board, extra) in &runs {
        let (path, board) = (path.as_str(), *board);
        let file = path.rsplit('/').next().unwrap_or(path);
        let mut args: Vec<String> = ["run", path, "--machine", MACHINE, board, "--yes"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend(extra.iter().map(|s| s.to_string()));
        let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
        if !ok {
            bail!("{file} on {board}: motionctl failed (output above)");
        }
        let s = summary_ints(&stdout, "motionctl-summary ")?;
        let get = |k: &str| s.get(k).copied().unwrap_or(-1);
        if get("ok") != 1 || get("hash_ok") != 1 || get("positions_ok") != 1 {
            bail!("{file} on {board}: the board's result differs from the host model: {s:?}");
        }
        if !extra.is_empty() && get("probes_tripped") != PROBES_TRIPPED {
            bail!("{file} on {board}: {PROBES_TRIPPED} probe move should have tripped: {s:?}");
        }
        println!(
            "  {file} on {board}: {} segments executed once, in order, at the programmed end; \
             {:.1} s wall",
            get("done"),
            wall.as_secs_f64()
        );
    }
    crate::gcode_corpus::short_set(root)
}
