//! The closed-loop scenarios in QEMU against the host model: the scenario firmware runs every
//! scenario of `motion::scenarios` with the sim board in the loop, and each report must equal
//! the host's run of the same scenario, figure for figure and hash for hash.

use crate::firmware::{self, Board};
use anyhow::{bail, Result};
use motion::scenario::ScenarioReport;
use motion::scenarios;
use std::path::Path;
use std::time::{Duration, Instant};

/// Each scenario's name and its report lines, in run order.
type Reports = Vec<(String, Vec<String>)>;

/// The scenario firmware's whole run; far above what it needs (about a minute).
const TIMEOUT: Duration = Duration::from_secs(600);

/// Every scenario's report lines from the host model, in firmware order.
pub fn host_lines() -> Result<Reports> {
    let mut out = Vec::new();
    for i in 0..scenarios::COUNT {
        let Some(mut s) = scenarios::build(i) else { bail!("scenario {i} does not build") };
        let t = Instant::now();
        let report = motion::scenario::run_to_end(&mut s, scenarios::HOST_MAX_TICKS);
        let mut lines = Vec::new();
        report.write_lines(|l| lines.push(l.to_string()));
        println!("  host: {} in {:.2} s", report.name, t.elapsed().as_secs_f64());
        out.push((report.name.to_string(), lines));
    }
    Ok(out)
}

/// Prints a report as a readable block.
pub fn print_report(r: &ScenarioReport) {
    println!("  {} ({} ticks, fault {}, hash {:016x})", r.name, r.ticks, r.fault, r.hash);
    for f in &r.figures {
        println!("    {:<28} {}", f.name, f.value);
    }
}

/// Builds and runs the scenario firmware; its report lines per scenario, and the wall time.
pub fn firmware_lines(root: &Path) -> Result<(Reports, Duration)> {
    let elf = firmware::build_bin(root, "scenarios", Board::Netduinoplus2, &[])?;
    let timeout = std::env::var("SCENARIO_TIMEOUT_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .map_or(TIMEOUT, Duration::from_secs);
    let run = firmware::run_qemu_for(&elf, timeout)?;
    let mut out: Reports = Vec::new();
    for line in run.texts() {
        if let Some(rest) = line.strip_prefix("scenario name=") {
            let name = rest.split_whitespace().next().unwrap_or_default().to_string();
            out.push((name, vec![line.to_string()]));
        } else if line.starts_with("scenario_fig ") {
            match out.last_mut() {
                Some((_, lines)) => lines.push(line.to_string()),
                None => bail!("figure line before any scenario line: {line}"),
            }
        }
    }
    if !run.texts().any(|l| l == "scenarios done") {
        run.print("  fw| ");
        bail!("the scenario firmware did not finish");
    }
    Ok((out, run.wall))
}

/// Firmware == host for every scenario.
pub fn test(root: &Path) -> Result<()> {
    let host = host_lines()?;
    let (fw, wall) = firmware_lines(root)?;
    println!("  QEMU ran {} scenarios in {:.1} s", fw.len(), wall.as_secs_f64());
    let mut diffs = Vec::new();
    if fw.len() != host.len() {
        diffs.push(format!("firmware reported {} scenarios, host {}", fw.len(), host.len()));
    }
    for (h, f) in host.iter().zip(&fw) {
        if h.0 != f.0 {
            diffs.push(format!("scenario order: host {} vs firmware {}", h.0, f.0));
            continue;
        }
        if h.1 != f.1 {
            let n = h.1.len().max(f.1.len());
            for i in 0..n {
                let a = h.1.get(i).map(String::as_str).unwrap_or("<missing>");
                let b = f.1.get(i).map(String::as_str).unwrap_or("<missing>");
                if a != b {
                    diffs.push(format!("{}: host `{a}` != firmware `{b}`", h.0));
                }
            }
        } else {
            println!("  {}: firmware == host ({} lines)", h.0, h.1.len());
        }
    }
    if !diffs.is_empty() {
        for d in &diffs {
            println!("  DIFF {d}");
        }
        bail!("{} differences between the scenario firmware and the host model", diffs.len());
    }
    Ok(())
}

/// `cargo xtask scenarios`: run them and print each report readably.
pub fn show(root: &Path) -> Result<()> {
    test(root)?;
    for i in 0..scenarios::COUNT {
        if let Some(mut s) = scenarios::build(i) {
            let r = motion::scenario::run_to_end(&mut s, scenarios::HOST_MAX_TICKS);
            print_report(&r);
        }
    }
    Ok(())
}
