//! The demo run in QEMU against the host model: report and every position snapshot must match.

use crate::firmware::{self, Board, Run};
use anyhow::{bail, Result};
use motion::report::{Report, Snapshot};
use std::collections::BTreeMap;
use std::path::Path;

/// What the firmware printed: its report and snapshots.
pub struct FirmwareResult {
    pub report: Report,
    pub report_lines: usize,
    pub snapshots: Vec<Snapshot>,
}

pub fn parse(run: &Run) -> Result<FirmwareResult> {
    let mut report = Report::default();
    let mut report_lines = 0;
    let mut snapshots = Vec::new();
    for line in run.texts() {
        if line.starts_with("report") {
            if !report.parse_line(line) {
                bail!("unparsable report line: {line}");
            }
            report_lines += 1;
        } else if line.starts_with("snapshot ") {
            match Snapshot::parse_line(line) {
                Some(s) => snapshots.push(s),
                None => bail!("unparsable snapshot line: {line}"),
            }
        }
    }
    if report_lines == 0 {
        bail!("the firmware printed no report");
    }
    if report_lines != 1 + report.axes as usize {
        bail!("expected 1 + {} report lines, got {report_lines}", report.axes);
    }
    Ok(FirmwareResult { report, report_lines, snapshots })
}

/// The host model's report plus its positions at each of `ticks`.
pub fn model(ticks: &[u64]) -> (Report, BTreeMap<u64, [i64; motion::MAX_AXES]>) {
    let mut at = BTreeMap::new();
    let wanted: std::collections::BTreeSet<u64> = ticks.iter().copied().collect();
    let report = motion::model::run_demo(|dda| {
        if wanted.contains(&dda.now()) {
            at.insert(dda.now(), dda.positions());
        }
    });
    (report, at)
}

/// Every difference between the firmware's output and the model, readable; empty if none.
pub fn compare(fw: &FirmwareResult) -> Vec<String> {
    let ticks: Vec<u64> = fw.snapshots.iter().map(|s| s.tick).collect();
    let (host, at) = model(&ticks);
    let mut diffs = report_diff(&fw.report, &host);
    let axes = fw.report.axes.max(host.axes) as usize;
    for s in &fw.snapshots {
        match at.get(&s.tick) {
            None => diffs.push(format!(
                "snapshot at tick {}: the host model never reached this tick (it ended at {})",
                s.tick, host.ticks
            )),
            Some(p) if p[..axes] != s.positions[..axes] => diffs.push(format!(
                "snapshot at tick {}: firmware {:?} != model {:?}",
                s.tick,
                &s.positions[..axes],
                &p[..axes]
            )),
            Some(_) => {}
        }
    }
    diffs
}

fn report_diff(fw: &Report, host: &Report) -> Vec<String> {
    let mut d = Vec::new();
    let mut field = |name: &str, a: String, b: String| {
        if a != b {
            d.push(format!("report.{name}: firmware {a} != model {b}"));
        }
    };
    field("axes", fw.axes.to_string(), host.axes.to_string());
    field("ticks", fw.ticks.to_string(), host.ticks.to_string());
    field("tick_hz", fw.tick_hz.to_string(), host.tick_hz.to_string());
    field("segments", fw.segments.to_string(), host.segments.to_string());
    field("underruns", fw.underruns.to_string(), host.underruns.to_string());
    field("deferred_steps", fw.deferred_steps.to_string(), host.deferred_steps.to_string());
    field("trace_hash", format!("{:016x}", fw.trace_hash), format!("{:016x}", host.trace_hash));
    field("positions", format!("{:?}", fw.positions), format!("{:?}", host.positions));
    field("steps", format!("{:?}", fw.steps), format!("{:?}", host.steps));
    field("peak_rate_hz", format!("{:?}", fw.peak_rate_hz), format!("{:?}", host.peak_rate_hz));
    field("first_step_tick", fw.first_step_tick.to_string(), host.first_step_tick.to_string());
    field("last_step_tick", fw.last_step_tick.to_string(), host.last_step_tick.to_string());
    if d.is_empty() && fw != host {
        d.push(format!("report: firmware {fw:?} != model {host:?}"));
    }
    d
}

/// Builds and runs the demo firmware; the decoded log and the parsed result.
fn run_demo_firmware(root: &Path, extra: &[&str]) -> Result<(Run, FirmwareResult)> {
    let elf = firmware::build(root, Board::Netduinoplus2, extra)?;
    println!("running {} in QEMU", elf.display());
    let run = firmware::run_qemu(&elf)?;
    let fw = match parse(&run) {
        Ok(fw) => fw,
        Err(e) => {
            run.print("  fw| ");
            return Err(e);
        }
    };
    Ok((run, fw))
}

/// `cargo xtask demo`.
pub fn demo(root: &Path) -> Result<()> {
    let (run, fw) = run_demo_firmware(root, &[])?;
    run.print("  fw| ");
    let r = &fw.report;
    let secs = r.ticks as f64 / r.tick_hz.max(1) as f64;
    println!();
    println!("demo job on QEMU netduinoplus2 ({:.1} s wall time)", run.wall.as_secs_f64());
    println!("  axes        {}", r.axes);
    println!("  duration    {} ticks / {} Hz = {secs:.3} s", r.ticks, r.tick_hz);
    println!("  segments    {}", r.segments);
    println!("  underruns   {}   deferred steps {}", r.underruns, r.deferred_steps);
    println!(
        "  steps       first at tick {}, last at tick {}",
        r.first_step_tick, r.last_step_tick
    );
    println!("  trace hash  {:016x}", r.trace_hash);
    println!("  snapshots   {}", fw.snapshots.len());
    println!("  {:<5} {:>12} {:>12} {:>12}", "axis", "steps", "position", "peak Hz");
    for i in 0..r.axes as usize {
        println!("  {:<5} {:>12} {:>12} {:>12}", i, r.steps[i], r.positions[i], r.peak_rate_hz[i]);
    }
    let diffs = compare(&fw);
    if diffs.is_empty() {
        println!("firmware == host model: report and all {} snapshots match", fw.snapshots.len());
        Ok(())
    } else {
        for d in &diffs {
            println!("  DIFF {d}");
        }
        bail!("firmware != host model ({} differences)", diffs.len())
    }
}

/// `cargo xtask test` step: the demo firmware must match the model exactly.
pub fn golden(root: &Path) -> Result<()> {
    let (run, fw) = run_demo_firmware(root, &[])?;
    if fw.snapshots.is_empty() {
        bail!("the firmware printed no snapshots");
    }
    let diffs = compare(&fw);
    if !diffs.is_empty() {
        run.print("  fw| ");
        for d in &diffs {
            println!("  DIFF {d}");
        }
        bail!("firmware != host model ({} differences)", diffs.len());
    }
    println!(
        "firmware == host model: {} report lines, {} snapshots, hash {:016x}, {} ticks ({:.1} s wall)",
        fw.report_lines,
        fw.snapshots.len(),
        fw.report.trace_hash,
        fw.report.ticks,
        run.wall.as_secs_f64()
    );
    Ok(())
}

/// `cargo xtask test` step: a firmware whose tick path is perturbed once must fail the
/// comparison, or the comparison proves nothing.
pub fn tamper(root: &Path) -> Result<()> {
    let (_, fw) = run_demo_firmware(root, &["tamper"])?;
    let diffs = compare(&fw);
    if diffs.is_empty() {
        bail!("the tampered firmware matched the host model: the golden comparison has no teeth");
    }
    println!(
        "tampered firmware differs from the model as it must ({} differences), e.g.:",
        diffs.len()
    );
    for d in diffs.iter().take(3) {
        println!("  {d}");
    }
    Ok(())
}
