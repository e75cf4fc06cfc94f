//! `cargo xtask gcode-e2e`: real G-code files from the corpus (written by CAM programs and
//! senders, host/gcode/tests/corpus) run end to end: through motion-gcode, the planner and the
//! link protocol to the simulated board, and one to the link firmware in QEMU. Each run must
//! execute every segment once, in order, and end at the host model's position, which
//! `motionctl`'s planning already pinned to the program's end point. (The power cut in the middle
//! of the QEMU file, with `run --resume` on a fresh board, is a case of `cargo xtask faults`.)

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use anyhow::{bail, Result};
use std::path::Path;

pub(crate) const MACHINE: &str = "motionctl/examples/corpus-machine.toml";
/// Short files (a few seconds of machine time each): G10 L2/L20 offsets with G53, and a
/// helical thread mill in G91 with R-form arcs.
const ON_SIM: [&str; 2] = ["linuxcnc-g10-l2-l20.ngc", "cncjs-helical-thread-milling.gcode"];
pub(crate) const ON_QEMU: &str = "cncjs-helical-thread-milling.gcode";

pub fn test(root: &Path) -> Result<()> {
    let bin = build_motionctl(root)?;
    let runs = ON_SIM.iter().map(|f| (*f, "--sim")).chain([(ON_QEMU, "--qemu")]);
    for (file, board) in runs {
        let path = format!("host/gcode/tests/corpus/{file}");
        let args: Vec<String> = ["run", &path, "--machine", MACHINE, board, "--yes"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
        if !ok {
            bail!("{file} on {board}: motionctl failed (output above)");
        }
        let s = summary_ints(&stdout, "motionctl-summary ")?;
        let get = |k: &str| s.get(k).copied().unwrap_or(-1);
        if get("ok") != 1 || get("hash_ok") != 1 || get("positions_ok") != 1 {
            bail!("{file} on {board}: the board's result differs from the host model: {s:?}");
        }
        println!(
            "  {file} on {board}: {} segments executed once, in order, at the programmed end; \
             {:.1} s wall",
            get("done"),
            wall.as_secs_f64()
        );
    }
    Ok(())
}
