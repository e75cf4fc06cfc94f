//! End to end, event jobs: `motionctl polar run` plays the first [`BLOCKS`] blocks of the
//! built-in limacon step-event stream (`motion::polar::limacon_stream`: 156 blocks, 19036
//! events; the first 24 are an open arc, so the final position is not the start and checks
//! something, and three times the board's block queue, so the stream must flow) on the link
//! firmware in QEMU at speed 2 and size 3:2, and the result is checked here too, independently
//! of motionctl's own check: events fired == events in the stream, and the final (theta, r)
//! steps == the host model (the firmware's `Playback` run on the host with the same scale and
//! speed). QEMU's idle round trip at every 100 kHz tick makes board time run ~14x slower than
//! real time here (the 80-block arc, 9.2 s of board time, took 129 s; CI's machine is slower
//! still): 24 blocks keep the step under a minute.

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motion::polar::limacon_stream::BYTES;
use motion::polar::playback::SizeScale;
use motion::polar::stream::decode_all;
use motion::Rate;
use std::path::Path;

const SPEED: &str = "2";
/// Blocks of the limacon stream played (an open arc; see the module doc).
const BLOCKS: usize = 24;
const SIZE: (u8, u8) = (3, 2);

/// The `cargo xtask test` step (also `cargo xtask polar-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let scale = SizeScale::new(SIZE.0, SIZE.1).context("size")?;
    let arc = motionctl::polar::run::first_blocks(BYTES, BLOCKS)?;
    let mut events = 0u32;
    decode_all(&arc, |_| events += 1).map_err(|e| anyhow::anyhow!("built-in stream: {e}"))?;
    let model = motionctl::polar::run::model(&arc, Rate::lit(SPEED), scale)?;
    if model.positions == [0, 0] {
        bail!("the arc returns to its start: the position check would be weak");
    }
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let stream = root.join("target/polar-e2e-limacon-arc.bin");
    std::fs::write(&stream, &arc)?;
    let s = |x: &str| x.to_string();
    let args = vec![
        s("polar"),
        s("run"),
        stream.display().to_string(),
        s("--qemu"),
        s("--firmware"),
        elf.display().to_string(),
        s("--speed"),
        s(SPEED),
        s("--size"),
        format!("{}:{}", SIZE.0, SIZE.1),
    ];
    let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
    if !ok {
        bail!("motionctl polar run failed (see its output above)");
    }
    let m = summary_ints(&stdout, "polar-summary ")?;
    let get = |k: &str| m.get(k).copied().unwrap_or(i64::MIN);
    let mut problems = Vec::new();
    if get("events_fired") != events as i64 {
        problems.push(format!("{} events fired, {events} in the stream", get("events_fired")));
    }
    if [get("theta"), get("r")] != model.positions {
        problems.push(format!(
            "final (theta, r) ({}, {}) != host model {:?}",
            get("theta"),
            get("r"),
            model.positions
        ));
    }
    if model.events != events {
        problems.push(format!("host model fired {} of {events}", model.events));
    }
    println!(
        "  polar e2e: {events} events fired in QEMU == stream; (theta, r) = ({}, {}) steps == host \
         model; model {} ticks ({:.2} s at speed {SPEED}), board ~{} ticks; {:.1} s wall, \
         {} frames out, {} retransmitted",
        get("theta"),
        get("r"),
        model.ticks,
        model.ticks as f64 / motion::polar::scenario::TICK_HZ as f64,
        get("board_ticks"),
        wall.as_secs_f64(),
        get("frames_out"),
        get("retransmissions"),
    );
    if !problems.is_empty() {
        bail!("polar end to end: {}", problems.join("; "));
    }
    Ok(())
}
