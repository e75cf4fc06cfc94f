//! `cargo xtask isr-cycles`: the link firmware built with its `isr-cycles` feature (the board
//! times its own TIM2 handler with its cycle counter, `firmware/src/isr_cycles.rs`) runs the
//! profile's jobs in QEMU at full speed, and its logged figures are set beside the traced
//! profile's. Under `-icount shift=0` the netduinoplus2's counter (TIM5 at 1 GHz) ticks once per
//! instruction, so the board's own figure is instructions from its first to its last reading:
//! an independent check, by other means, of the instruction counts the trace measures. On an
//! F405 the same build logs real cycles (DWT CYCCNT).

use super::jobs;
use crate::e2e::build_motionctl;
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::{Command, Stdio};

/// What the board logged last for one job.
#[derive(Clone, Debug, PartialEq)]
pub struct Logged {
    pub job: &'static str,
    pub runs: u64,
    pub mean: u64,
    pub p50: u64,
    pub p99: u64,
    pub max: u64,
}

/// Builds the feature firmware, runs every job (or those whose name contains one of `only`),
/// prints and returns the board's last `isr-cycles since boot` line per job.
pub fn run(root: &Path, only: &[String]) -> Result<Vec<Logged>> {
    let elf = firmware::build_into(
        root,
        "link",
        Board::Netduinoplus2,
        &["isr-cycles"],
        "target/fw-netduinoplus2-link-isr-cycles",
    )?;
    let bin = build_motionctl(root)?;
    let work = root.join("target/isr-cycles");
    std::fs::create_dir_all(&work)?;
    let mut out = Vec::new();
    // The tick interrupt's jobs: the streamed output's fill is the trace's alone.
    for job in jobs(root, &work, &elf, &elf)?.into_iter().filter(|j| !j.stream) {
        if !only.is_empty() && !only.iter().any(|o| job.name.contains(o.as_str())) {
            continue;
        }
        // A job that would take an hour single-stepped runs whole here: it is not traced.
        let tmp = work.join(job.name.replace([' ', '(', ')'], "_"));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp)?;
        println!("{}: motionctl {}", job.name, job.args.join(" "));
        let status = Command::new(&bin)
            .args(&job.args)
            .current_dir(root)
            // motionctl puts QEMU's log (the firmware's defmt bytes) in the temp dir.
            .env("TMPDIR", &tmp)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .status()
            .with_context(|| format!("could not start {}", bin.display()))?;
        if !status.success() {
            bail!("{}: motionctl failed ({status})", job.name);
        }
        let log = std::fs::read_dir(&tmp)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .find(|p| {
                p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("motionctl-qemu"))
            })
            .with_context(|| format!("{}: no QEMU log in {}", job.name, tmp.display()))?;
        let bytes = std::fs::read(&log)?;
        let lines = firmware::decode_text(&elf, &bytes)?;
        let last = lines
            .iter()
            .rev()
            .find(|l| l.starts_with("isr-cycles since boot"))
            .with_context(|| format!("{}: the firmware logged no isr-cycles line", job.name))?;
        let logged =
            parse(job.name, last).with_context(|| format!("{}: cannot read {last:?}", job.name))?;
        println!(
            "  board's own count: {} runs, mean {}, p50 {}, p99 {}, max {} (instructions under QEMU)",
            logged.runs, logged.mean, logged.p50, logged.p99, logged.max
        );
        out.push(logged);
    }
    Ok(out)
}

/// Reads `isr-cycles since boot: N runs, mean M, p50 A, p99 B, max C, ...`.
fn parse(job: &'static str, line: &str) -> Option<Logged> {
    let rest = line.split_once(": ")?.1;
    let num = |key: &str| -> Option<u64> {
        rest.split(", ").find_map(|part| {
            let part = part.trim();
            if key == "runs" {
                part.strip_suffix(" runs")?.parse().ok()
            } else {
                part.strip_prefix(key)?.trim().parse().ok()
            }
        })
    };
    Some(Logged {
        job,
        runs: num("runs")?,
        mean: num("mean")?,
        p50: num("p50")?,
        p99: num("p99")?,
        max: num("max")?,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_firmware_line_parses() {
        let l = super::parse(
            "j",
            "isr-cycles since boot: 47489 runs, mean 612, p50 576, p99 1056, max 1444, cpu 364 \
             per mille at 100000 Hz",
        )
        .unwrap();
        assert_eq!((l.runs, l.mean, l.p50, l.p99, l.max), (47_489, 612, 576, 1_056, 1_444));
        assert!(super::parse("j", "isr-cycles since boot: garbage").is_none());
    }
}
