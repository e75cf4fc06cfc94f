//! End to end: `motionctl run` streams a 2000-segment job to the link firmware in QEMU, through
//! a proxy that corrupts or drops 1 % of the bytes both ways, and everything is checked twice:
//! by motionctl itself (segments done == sent, the board's order hash == the hash of the ids
//! sent, final positions == its host model) and here, independently, from the job's own targets,
//! a host-model run of this module's planning, and the status CSV (rate, queue depth).
//!
//! The job is generated here (a deterministic zig-zag of short X/Y moves with Z dips and varied
//! feeds) on a 100 steps/mm machine with targets in 0.01 mm, so every target is a whole step
//! and the final position in steps is known without motionctl's conversion.

use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motion::planner::{Move, PlanError, Planner};
use motion::{AxisLimits, MachineConfig, Segment, StepTiming, MAX_AXES};
use motionctl::convert::feed_hz;
use motionctl::sample_job::{job_toml, targets, to_steps, AXES, TICK_HZ};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Segments in the job (one per move: the moves are short enough never to be split).
pub const SEGMENTS: usize = 2000;
/// The step fails if motionctl takes longer.
const RUN_TIMEOUT: Duration = Duration::from_secs(180);
/// The link firmware's segment queue (credits when empty; firmware/link.rs SEGMENT_QUEUE).
const QUEUE_CAPACITY: u64 = 64;
/// Status period asked for in the noisy run (see `STATUS_NOTE`).
const NOISY_STATUS_MS: u16 = 25;
/// Least status rate received through the noise (board time): 40 Hz sent, of which 1 % byte
/// noise destroys about half (the ~70-byte frames with the Z-slide, force and copy fields).
const NOISY_STATUS_FLOOR_HZ: f64 = 15.0;
/// What the status figures mean, printed with the result.
const STATUS_NOTE: &str = "status rate = CSV rows while streaming / board time (board ticks / \
                           tick_hz); sent rate = from the commonest gap between received rows \
                           (lost frames only lengthen gaps); 1 % byte noise destroys about half \
                           of the ~70-byte status frames, so 40 Hz sent arrive as ~20 Hz";

fn machine() -> MachineConfig {
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    for (lim, (_, spm, rate, accel, jerk, _)) in axes.iter_mut().zip(AXES) {
        *lim = AxisLimits {
            max_rate_hz: (rate * spm) as u32,
            accel_steps_per_s2: (accel * spm) as u32,
            junction_jerk_hz: (jerk * spm) as u32,
        };
    }
    MachineConfig {
        tick_hz: TICK_HZ,
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: 3,
        axes,
    }
}

/// Plans the moves with the firmware's planner and runs them through the host model; returns
/// the segment count and the model's final positions.
pub fn model(moves: &[([i64; 3], f64)]) -> Result<(usize, [i64; 3])> {
    let cfg = machine();
    let mut planner = Planner::new(&cfg);
    let mut segs: Vec<Segment> = Vec::new();
    let mut prev = [0i64; 3];
    for (p, feed) in moves {
        let s = to_steps(*p);
        let mut steps = [0i32; MAX_AXES];
        for a in 0..3 {
            steps[a] = (s[a] - prev[a]) as i32;
        }
        prev = s;
        let steps_per_mm = AXES.map(|axis| axis.1);
        let mv = Move { steps, feed_hz: feed_hz(&steps, &steps_per_mm, *feed) };
        loop {
            match planner.push(&mv) {
                Ok(()) => break,
                Err(PlanError::Full) => match planner.pop() {
                    Some(seg) => segs.push(seg),
                    None => planner.finish(),
                },
                Err(e) => bail!("the planner refused move {mv:?}: {e:?}"),
            }
        }
        while let Some(seg) = planner.pop() {
            segs.push(seg);
        }
    }
    planner.finish();
    while let Some(seg) = planner.pop() {
        segs.push(seg);
    }
    let n = segs.len();
    let mut it = segs.into_iter();
    let report = motion::model::run(&cfg, || it.next(), &[], u64::MAX / 2, |_, _| {})
        .map_err(|e| anyhow::anyhow!("the host model refused a segment: {e:?}"))?;
    Ok((n, [report.positions[0], report.positions[1], report.positions[2]]))
}

/// A `<prefix>k=v ...` line of motionctl's output -> map of the whole-number values (a
/// decimal one truncated; other values left out).
pub(crate) fn summary_ints(
    stdout: &str,
    prefix: &str,
) -> Result<std::collections::BTreeMap<String, i64>> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(prefix))
        .with_context(|| format!("motionctl printed no {}line", prefix))?;
    let mut m = std::collections::BTreeMap::new();
    for kv in line.split_whitespace().skip(1) {
        if let Some((k, v)) = kv.split_once('=') {
            let x = v.parse::<i64>().ok().or_else(|| v.parse::<f64>().ok().map(|x| x as i64));
            if let Some(x) = x {
                m.insert(k.to_string(), x);
            }
        }
    }
    Ok(m)
}

/// `motionctl-summary k=v ...` -> map.
pub(crate) fn summary(stdout: &str) -> Result<std::collections::BTreeMap<String, f64>> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("motionctl-summary "))
        .context("motionctl printed no summary line")?;
    let mut m = std::collections::BTreeMap::new();
    for kv in line.split_whitespace().skip(1) {
        let (k, v) = kv.split_once('=').with_context(|| format!("bad summary field {kv}"))?;
        m.insert(k.to_string(), v.parse::<f64>().with_context(|| format!("bad value {kv}"))?);
    }
    Ok(m)
}

/// What the status CSV shows.
pub struct CsvFacts {
    pub rows_streaming: usize,
    pub status_hz_board: f64,
    /// The board's send rate: board time over the commonest gap between received rows.
    pub status_sent_hz: f64,
    pub status_hz_wall: f64,
    pub max_queue_depth: u64,
    pub max_credits: u64,
    pub final_steps: [i64; 3],
    pub final_done: u64,
}

/// Rows from the first `Moving` one to the first with every segment done.
pub fn read_csv(path: &Path, total: u64) -> Result<CsvFacts> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().context("empty CSV")?.split(',').collect();
    let col = |name: &str| {
        head.iter().position(|h| *h == name).with_context(|| format!("no column {name}"))
    };
    let (c_wall, c_tick, c_state, c_depth, c_done) = (
        col("wall_ms")?,
        col("board_tick")?,
        col("state")?,
        col("queue_depth")?,
        col("job_segments_done")?,
    );
    let c_credits = col("credits")?;
    let c_pos = [col("X_steps")?, col("Y_steps")?, col("Z_steps")?];
    let mut window: Vec<(f64, f64)> = Vec::new();
    let mut streaming = false;
    let mut facts = CsvFacts {
        rows_streaming: 0,
        status_hz_board: 0.0,
        status_sent_hz: 0.0,
        status_hz_wall: 0.0,
        max_queue_depth: 0,
        max_credits: 0,
        final_steps: [0; 3],
        final_done: 0,
    };
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let num = |c: usize| -> Result<f64> {
            f.get(c)
                .context("short CSV row")?
                .parse::<f64>()
                .with_context(|| format!("bad CSV row {line}"))
        };
        let done = num(c_done)? as u64;
        facts.max_queue_depth = facts.max_queue_depth.max(num(c_depth)? as u64);
        let credits = num(c_credits)?;
        if credits < 0.0 {
            bail!("negative credits in the CSV: {line}");
        }
        facts.max_credits = facts.max_credits.max(credits as u64);
        for a in 0..3 {
            facts.final_steps[a] = num(c_pos[a])? as i64;
        }
        facts.final_done = done;
        if f.get(c_state) == Some(&"Moving") {
            streaming = true;
        }
        if streaming && window.last().is_none_or(|_| done <= total) {
            window.push((num(c_wall)?, num(c_tick)?));
            if done >= total {
                streaming = false;
                window.push((f64::NAN, f64::NAN));
            }
        }
    }
    window.retain(|w| !w.0.is_nan());
    facts.rows_streaming = window.len();
    // Gaps in whole board milliseconds; the commonest one is the send period.
    let mut gaps: std::collections::BTreeMap<u64, usize> = std::collections::BTreeMap::new();
    for w in window.windows(2) {
        let ms = ((w[1].1 - w[0].1) * 1000.0 / TICK_HZ as f64).round() as u64;
        if ms > 0 {
            *gaps.entry(ms).or_default() += 1;
        }
    }
    if let Some((ms, _)) = gaps.iter().max_by_key(|(ms, n)| (**n, std::cmp::Reverse(**ms))) {
        facts.status_sent_hz = 1000.0 / *ms as f64;
    }
    if let (Some(first), Some(last)) = (window.first(), window.last()) {
        let n = window.len().saturating_sub(1) as f64;
        let board_s = (last.1 - first.1) / TICK_HZ as f64;
        let wall_s = (last.0 - first.0) / 1000.0;
        facts.status_hz_board = if board_s > 0.0 { n / board_s } else { 0.0 };
        facts.status_hz_wall = if wall_s > 0.0 { n / wall_s } else { 0.0 };
    }
    Ok(facts)
}

/// Builds motionctl (test-fast profile, shared with the host tests) and returns its path.
pub(crate) fn build_motionctl(root: &Path) -> Result<PathBuf> {
    crate::run_status(
        "motionctl build",
        crate::cargo(root).args(["build", "-p", "motionctl", "--profile", "test-fast"]),
    )?;
    Ok(root.join("target/test-fast/motionctl"))
}

/// Runs motionctl with a timeout; stdout is captured (and echoed), stderr passes through.
pub(crate) fn run_motionctl(
    root: &Path,
    bin: &Path,
    args: &[String],
) -> Result<(bool, String, Duration)> {
    println!("  $ motionctl {}", args.join(" "));
    let start = Instant::now();
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .with_context(|| format!("could not start {}", bin.display()))?;
    let out = child.stdout.take().context("motionctl stdout")?;
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            println!("  ctl| {line}");
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let status = wait_at_most(&mut child, start, RUN_TIMEOUT)?;
    let stdout = reader.join().unwrap_or_default();
    let Some(status) = status else {
        bail!("motionctl did not finish within {} s; stopped it", RUN_TIMEOUT.as_secs());
    };
    Ok((status.success(), stdout, start.elapsed()))
}

/// Waits for a motionctl `child` started at `start`; after `limit`, stops it (`None`).
pub(crate) fn wait_at_most(
    child: &mut Child,
    start: Instant,
    limit: Duration,
) -> Result<Option<ExitStatus>> {
    loop {
        if let Some(s) = child.try_wait()? {
            return Ok(Some(s));
        }
        if start.elapsed() > limit {
            // SIGINT first: motionctl aborts the board and kills its QEMU on the way out.
            let _ = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
            std::thread::sleep(Duration::from_secs(3));
            let _ = child.kill();
            let _ = child.wait();
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

struct Prepared {
    bin: PathBuf,
    elf: PathBuf,
    job: PathBuf,
    expected: [i64; 3],
}

fn prepare(root: &Path) -> Result<Prepared> {
    let moves = targets(SEGMENTS);
    let (n, model_pos) = model(&moves)?;
    if n != SEGMENTS {
        bail!("the generated job plans to {n} segments, not {SEGMENTS}");
    }
    let expected = to_steps(moves[moves.len() - 1].0);
    if model_pos != expected {
        bail!("host model ends at {model_pos:?} steps but the job's last target is {expected:?}");
    }
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let job = root.join("target/e2e-job.toml");
    std::fs::write(&job, job_toml(&moves))?;
    Ok(Prepared { bin, elf, job, expected })
}

fn base_args(p: &Prepared) -> Vec<String> {
    let s = |x: &str| x.to_string();
    vec![
        s("run"),
        p.job.display().to_string(),
        s("--qemu"),
        s("--firmware"),
        p.elf.display().to_string(),
        s("--yes"),
    ]
}

/// The `cargo xtask test` step.
pub fn test(root: &Path) -> Result<()> {
    let p = prepare(root)?;
    let csv = root.join("target/e2e-status.csv");
    let mut args = base_args(&p);
    for a in ["--noise", "0.01", "--seed", "7", "--log-csv"] {
        args.push(a.into());
    }
    args.push(csv.display().to_string());
    args.push("--status-ms".into());
    args.push(NOISY_STATUS_MS.to_string());
    let (ok, stdout, wall) = run_motionctl(root, &p.bin, &args)?;
    if !ok {
        bail!("motionctl run failed (see its output above)");
    }
    let m = summary(&stdout)?;
    let get = |k: &str| m.get(k).copied().unwrap_or(f64::NAN);
    let mut problems = Vec::new();
    for (k, want) in
        [("ok", 1.0), ("hash_ok", 1.0), ("positions_ok", 1.0), ("queue_full_naks", 0.0)]
    {
        if get(k) != want {
            problems.push(format!("motionctl reported {k}={}", get(k)));
        }
    }
    for k in ["segments", "acked", "done"] {
        if get(k) != SEGMENTS as f64 {
            problems.push(format!("motionctl reported {k}={}, want {SEGMENTS}", get(k)));
        }
    }
    let facts = read_csv(&csv, SEGMENTS as u64)?;
    if facts.final_steps != p.expected {
        problems.push(format!(
            "last status at {:?} steps, job ends at {:?}",
            facts.final_steps, p.expected
        ));
    }
    if facts.final_done != SEGMENTS as u64 {
        problems.push(format!("last status shows {} segments done", facts.final_done));
    }
    // Credits = free slots of the board's queue: above the capacity would mean a negative
    // fill, i.e. an overflow. (queue_depth also counts the DDA's own ready queue.)
    if facts.max_credits > QUEUE_CAPACITY || get("max_credits") > QUEUE_CAPACITY as f64 {
        problems.push(format!("credits {} above capacity {QUEUE_CAPACITY}", facts.max_credits));
    }
    if facts.status_sent_hz < 20.0 {
        problems
            .push(format!("status sent at {:.1} Hz (board time) < 20 Hz", facts.status_sent_hz));
    }
    if facts.status_hz_board < NOISY_STATUS_FLOOR_HZ {
        problems.push(format!(
            "status received at {:.1} Hz (board time) < {NOISY_STATUS_FLOOR_HZ} Hz",
            facts.status_hz_board
        ));
    }
    println!(
        "  2000 segments in {:.1} s wall ({:.1} s streaming); {} retransmissions, {} link NAKs, \
         {} garbled frames in; status {:.1} Hz sent, {:.1} Hz received board time / {:.1} Hz \
         wall ({} rows); deepest queue {}",
        wall.as_secs_f64(),
        get("stream_seconds"),
        get("retransmissions"),
        get("link_naks"),
        get("bad_frames_in"),
        facts.status_sent_hz,
        facts.status_hz_board,
        facts.status_hz_wall,
        facts.rows_streaming,
        facts.max_queue_depth
    );
    println!("  ({STATUS_NOTE})");
    if !problems.is_empty() {
        bail!("end-to-end check failed: {}", problems.join("; "));
    }
    Ok(())
}

/// Where the link firmware built with the streamed step output goes.
pub const STREAM_FW_DIR: &str = "target/fw-netduinoplus2-link-stream";

/// The link firmware with the streamed step output (`step-stream`), for the QEMU board.
pub fn stream_firmware(root: &Path) -> Result<PathBuf> {
    firmware::build_into(root, "link", Board::Netduinoplus2, &["step-stream"], STREAM_FW_DIR)
}

/// The `cargo xtask test` step for the streamed step output: the same 2000 segments on the link
/// firmware built with `step-stream`, its slot clock at the stream's fastest (500 kHz), no
/// noise: every segment once, in order, and the end positions the host model's.
pub fn stream_test(root: &Path) -> Result<()> {
    let p = prepare(root)?;
    let elf = stream_firmware(root)?;
    let from = format!("tick_hz = {TICK_HZ}\n");
    let toml = std::fs::read_to_string(&p.job)?;
    if !toml.contains(&from) {
        bail!("the sample job has no `{}` line to raise", from.trim());
    }
    let slot_hz = motion::config::MAX_STREAM_TICK_HZ;
    let job = root.join("target/e2e-stream-job.toml");
    std::fs::write(&job, toml.replacen(&from, &format!("tick_hz = {slot_hz}\n"), 1))?;
    let p = Prepared { job, elf, ..p };
    let (ok, stdout, wall) = run_motionctl(root, &p.bin, &base_args(&p))?;
    if !ok {
        bail!("motionctl run on the streamed firmware failed (see its output above)");
    }
    let m = summary(&stdout)?;
    let get = |k: &str| m.get(k).copied().unwrap_or(f64::NAN);
    let mut problems = Vec::new();
    for (k, want) in [
        ("ok", 1.0),
        ("hash_ok", 1.0),
        ("positions_ok", 1.0),
        ("segments", SEGMENTS as f64),
        ("done", SEGMENTS as f64),
    ] {
        if get(k) != want {
            problems.push(format!("motionctl reported {k}={}, want {want}", get(k)));
        }
    }
    println!(
        "  {SEGMENTS} segments at a {} kHz slot clock in {:.1} s wall; positions equal the host \
         model's",
        slot_hz / 1000,
        wall.as_secs_f64()
    );
    if !problems.is_empty() {
        bail!("streamed-output check failed: {}", problems.join("; "));
    }
    Ok(())
}

/// `cargo xtask bench` figures: sustained segments/s acknowledged over the QEMU link (no noise)
/// and the status rate (board time) at the default 40 ms period.
pub fn bench(root: &Path) -> Result<Vec<(&'static str, f64)>> {
    let p = prepare(root)?;
    let (ok, stdout, _) = run_motionctl(root, &p.bin, &base_args(&p))?;
    if !ok {
        bail!("motionctl run (bench) failed");
    }
    let m = summary(&stdout)?;
    let v = |k: &str| m.get(k).copied().with_context(|| format!("no {k} in the summary"));
    Ok(vec![
        ("link_segments_per_s", v("acked_per_s")?.round()),
        ("link_status_hz", (v("status_hz_board")? * 100.0).round() / 100.0),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_send_rate_comes_from_the_commonest_gap_whatever_the_losses() {
        // Sent every 25 ms of board time (500 ticks at 20 kHz); rows 1, 4, 5 and 8 lost.
        let mut csv = String::from(
            "wall_ms,board_tick,state,queue_depth,job_segments_done,credits,X_steps,Y_steps,Z_steps\n",
        );
        for i in [0u64, 2, 3, 6, 7, 9, 10] {
            let done = if i == 10 { 4 } else { i / 3 };
            csv += &format!("{},{},Moving,3,{done},60,{i},0,0\n", i * 60, 1_000 + i * 500);
        }
        let path = std::env::temp_dir().join(format!("e2e-gaps-{}.csv", std::process::id()));
        std::fs::write(&path, csv).unwrap();
        let f = read_csv(&path, 4).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(f.status_sent_hz, 40.0);
        // 7 rows over 10 periods (0.25 s): 6 gaps / 0.25 s.
        assert!((f.status_hz_board - 24.0).abs() < 1e-9, "{}", f.status_hz_board);
        assert_eq!(f.final_done, 4);
    }

    #[test]
    fn the_generated_job_is_2000_segments_and_ends_on_its_last_target() {
        let moves = targets(SEGMENTS);
        let (n, pos) = model(&moves).unwrap();
        assert_eq!(n, SEGMENTS);
        assert_eq!(pos, to_steps(moves[SEGMENTS - 1].0));
    }
}
