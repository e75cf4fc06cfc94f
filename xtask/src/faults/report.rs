//! The suite's counts in BENCHMARKS.md (its reliability section, between its own markers) and
//! in `target/bench.json` (`faults_injected`, `faults_survived`).

use super::Counts;
use anyhow::Result;
use std::path::Path;

/// Where the reliability section sits in BENCHMARKS.md.
pub const MARKERS: (&str, &str) = ("<!-- faults:begin -->", "<!-- faults:end -->");

const HOW: &str = "Measured by `cargo xtask faults` (a step of `cargo xtask test`), which writes
`target/faults.json`; `cargo xtask bench` (or `cargo xtask bench-faults` alone) runs it and
rewrites this section. A fault survived when the case ended as documented: the safe state (the
fault code and state the board reports, outputs off, motion stopped) or a clean finish, nothing
executed twice (segment order hash, final positions against the host model, the resume journal's
line), nothing lost silently (a refused input exits non-zero naming it, never a panic). Where:
the board faults and noisy switches on the host model of the machine (the same scenarios run in
QEMU in the `scenarios` step); reset, power cut, 2 s link drop and USART overrun bursts (16 bytes
to the board lost of every 1500) on the link firmware in QEMU through a fault proxy, each reset
or cut job finished with `run --resume`; the config record in flash on the host (QEMU has no
flash store: the record decoder and the boot over a NOR-flash mock); bad inputs as `motionctl`
commands, the generated ones from fixed seeds. Inputs: commands, files, jobs or scenarios tried;
a case with several faults (the overrun bursts) counts each.
";

fn section(c: &Counts) -> String {
    let (total, rows) = (&c.total, &c.rows);
    let mut t = String::from(
        "## Reliability: fault injection\n\n| class | inputs tried | faults injected | survived |\n\
         | --- | ---: | ---: | ---: |\n",
    );
    for (name, c) in rows {
        t += &format!("| {name} | {} | {} | {} |\n", c.inputs, c.injected, c.survived);
    }
    t += &format!(
        "| **total** | **{}** | **{}** | **{}** |\n\n",
        total.inputs, total.injected, total.survived
    );
    if !c.failures.is_empty() {
        t += "Failed in this run (injected, not survived):\n\n";
        for f in &c.failures {
            t += &format!("- {}\n", f.lines().next().unwrap_or(""));
        }
        t += "\n";
    }
    t + HOW
}

/// Runs the suite: BENCHMARKS.md's reliability section (between [`MARKERS`]) and the
/// bench.json keys. `cargo xtask bench` writes both.
pub fn bench(root: &Path) -> Result<(String, Vec<(&'static str, f64)>)> {
    super::run(root, &[])?;
    let counts = super::read_counts(root)?;
    Ok((
        section(&counts),
        vec![
            ("faults_injected", counts.total.injected as f64),
            ("faults_survived", counts.total.survived as f64),
        ],
    ))
}
