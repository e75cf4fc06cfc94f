//! End to end, copy mode: `motionctl polar copy --qemu` drives the link firmware's
//! simulated encoders along a piece of the limacon template (r = 3 + 2 cos theta in, theta
//! 0..0.6 rad: 1528 arm and 349 carriage counts) with the copy at size 3:2 and teach on, and
//! saves the taught stream; then `motionctl polar run` replays that stream at speed 2, size 1:1.
//! Checked here, independently of motionctl's own checks: the taught file decodes, holds the
//! board's taught count with nothing lost, its net counts are the template's; the board's copy
//! steps equal the host model (`CopyMode` on the host fed the counts the stream records, at
//! 3:2); the replay fires every event and ends on the copied positions at 1:1.

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motion::polar::playback::SizeScale;
use std::path::Path;

const TEMPLATE: &str = "limacon:0.6";
const THETA_END_RAD: f64 = 0.6;
const SIZE: (u8, u8) = (3, 2);
const REPLAY_SPEED: &str = "2";

/// The `cargo xtask test` step (also `cargo xtask copy-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let scale = SizeScale::new(SIZE.0, SIZE.1).context("size")?;
    let trace = motionctl::polar::copy::limacon_trace(THETA_END_RAD, 40);
    let end = *trace.last().context("empty template")?;
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let taught = root.join("target/copy-e2e-taught.bin");
    let _ = std::fs::remove_file(&taught);
    let s = |x: &str| x.to_string();
    let fw = elf.display().to_string();
    let copy_args = vec![
        s("polar"),
        s("copy"),
        s("--qemu"),
        s("--firmware"),
        fw.clone(),
        s("--size"),
        format!("{}:{}", SIZE.0, SIZE.1),
        s("--teach"),
        taught.display().to_string(),
        s("--template"),
        s(TEMPLATE),
    ];
    let (ok, stdout, copy_wall) = run_motionctl(root, &bin, &copy_args)?;
    if !ok {
        bail!("motionctl polar copy failed (see its output above)");
    }
    let c = summary_ints(&stdout, "copy-summary ")?;
    let get = |k: &str| c.get(k).copied().unwrap_or(i64::MIN);
    let bytes = std::fs::read(&taught).with_context(|| format!("reading {}", taught.display()))?;
    let model = motionctl::polar::copy::model(&bytes, scale)?;
    let mut problems = Vec::new();
    if get("lost") != 0 {
        problems.push(format!("{} taught events lost", get("lost")));
    }
    if model.events as i64 != get("taught") {
        problems.push(format!(
            "{} events in the file, the board taught {}",
            model.events,
            get("taught")
        ));
    }
    if model.counts != [end[0] as i64, end[1] as i64]
        || [get("arm"), get("carriage")] != model.counts
    {
        problems.push(format!(
            "net counts: file {:?}, encoders ({}, {}), template {end:?}",
            model.counts,
            get("arm"),
            get("carriage")
        ));
    }
    if [get("theta"), get("r")] != model.positions {
        problems.push(format!(
            "copy (theta, r) ({}, {}) != host model {:?}",
            get("theta"),
            get("r"),
            model.positions
        ));
    }
    let run_args = vec![
        s("polar"),
        s("run"),
        taught.display().to_string(),
        s("--qemu"),
        s("--firmware"),
        fw,
        s("--speed"),
        s(REPLAY_SPEED),
    ];
    let (ok, stdout, run_wall) = run_motionctl(root, &bin, &run_args)?;
    if !ok {
        bail!("motionctl polar run of the taught stream failed (see its output above)");
    }
    let r = summary_ints(&stdout, "polar-summary ")?;
    let rget = |k: &str| r.get(k).copied().unwrap_or(i64::MIN);
    if rget("events_fired") != model.events as i64 {
        problems.push(format!("replay fired {} of {}", rget("events_fired"), model.events));
    }
    if [rget("theta"), rget("r")] != model.counts {
        problems.push(format!(
            "replay (theta, r) ({}, {}) != copied counts at 1:1 {:?}",
            rget("theta"),
            rget("r"),
            model.counts
        ));
    }
    println!(
        "  copy e2e: template {TEMPLATE} = {end:?} counts; copy at {}:{} -> (theta, r) = ({}, {}) \
         == host model; {} events taught, 0 lost, {} blocks; replay at speed {REPLAY_SPEED} -> \
         ({}, {}) == copied at 1:1; {:.1} s + {:.1} s wall",
        SIZE.0,
        SIZE.1,
        get("theta"),
        get("r"),
        model.events,
        get("blocks"),
        rget("theta"),
        rget("r"),
        copy_wall.as_secs_f64(),
        run_wall.as_secs_f64(),
    );
    if !problems.is_empty() {
        bail!("copy end to end: {}", problems.join("; "));
    }
    Ok(())
}
