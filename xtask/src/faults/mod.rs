//! `cargo xtask faults`: the fault-injection suite. Every case injects one kind of trouble and
//! checks the documented end: the safe state (the fault code and state in the board's status,
//! outputs off, motion stopped) or a clean finish, nothing executed twice (the order hash of the
//! segments done, the final positions against the host model, the journal's line), nothing lost
//! silently (a refused input exits non-zero with a message naming it, never a panic).
//!
//! | class | where | how |
//! | --- | --- | --- |
//! | board faults, noisy switches | host model | every `fault_*` scenario of `src/scenarios/faults/` run to its end and checked ([`motion::scenarios::faults::broken_promise`]); the same scenarios run in QEMU in the `scenarios` step |
//! | reset, link drop, noise (sim) | simulated board | the `link_sim` tests: reset at segment 50, 2.5 s of silence, 1 % byte noise |
//! | power cut, reset, link drop 2 s, USART overrun bursts, config record corruption | link firmware in QEMU | [`qemu_cases`]: a G-code job through a TCP proxy that drops or mangles bytes, QEMU reset from its monitor or killed, the stored record corrupted (`Sim(CorruptConfig)`) before a reset |
//! | config record corruption, stored tick rate, home position overflow | host | the record decoder's and the boot's tests (`machine_persist`, `machine_board_faults`) |
//! | bad inputs | `motionctl` | [`inputs`]: every bad-input class run as a command, plus generated garbage (fixed seeds) |
//!
//! The counts go to `target/faults.json`; `cargo xtask bench` puts them in BENCHMARKS.md.

mod inputs;
mod named_tests;
mod proxy;
mod qemu_cases;
pub mod report;

use anyhow::{bail, Result};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// Where the counts are written.
pub const JSON: &str = "target/faults.json";

/// One class of faults: how many inputs were tried, faults injected, and how many of those
/// ended as documented.
#[derive(Clone, Debug, Default)]
pub struct Count {
    pub inputs: u64,
    pub injected: u64,
    pub survived: u64,
}

/// The counts by class, and what failed.
#[derive(Default)]
pub struct Tally {
    pub classes: BTreeMap<&'static str, Count>,
    pub failures: Vec<String>,
}

impl Tally {
    /// Records a case of `class`: `inputs` tried, `injected` faults, `Ok` if it ended as
    /// documented (every injected fault survived), else why not.
    pub fn record(&mut self, class: &'static str, inputs: u64, injected: u64, r: Result<()>) {
        let c = self.classes.entry(class).or_default();
        c.inputs += inputs;
        c.injected += injected;
        match r {
            Ok(()) => c.survived += injected,
            Err(e) => {
                println!("  FAILED ({class}): {e:#}");
                self.failures.push(format!("{class}: {e:#}"));
            }
        }
    }

    pub fn total(&self) -> Count {
        let mut t = Count::default();
        for c in self.classes.values() {
            t.inputs += c.inputs;
            t.injected += c.injected;
            t.survived += c.survived;
        }
        t
    }

    fn json(&self, seconds: f64) -> serde_json::Value {
        let count = |c: &Count| serde_json::json!({ "inputs": c.inputs, "injected": c.injected, "survived": c.survived });
        let classes: serde_json::Map<String, serde_json::Value> =
            self.classes.iter().map(|(k, c)| (k.to_string(), count(c))).collect();
        serde_json::json!({
            "classes": classes,
            "total": count(&self.total()),
            "failures": self.failures,
            "seconds": (seconds * 10.0).round() / 10.0,
        })
    }
}

/// The suite's parts, by the names `--only` takes.
pub const PARTS: [&str; 4] = ["scenarios", "tests", "inputs", "qemu"];

/// The whole suite (or the `only` parts, for local use); writes [`JSON`] and fails if any
/// injected fault did not end as documented.
pub fn run(root: &Path, only: &[String]) -> Result<()> {
    let t0 = Instant::now();
    let mut tally = Tally::default();
    let wanted = |part: &str, what: &str| {
        let on = only.is_empty() || only.iter().any(|o| o == part);
        if on {
            println!("  -- {what} ({:.1} s in)", t0.elapsed().as_secs_f64());
        }
        on
    };
    if wanted("scenarios", "board faults on the host model") {
        board_scenarios(&mut tally);
    }
    if wanted("tests", "existing tests of the simulated board, the config record and the boot") {
        named_tests::run(root, &mut tally)?;
    }
    let bin = crate::e2e::build_motionctl(root)?;
    if wanted("inputs", "bad inputs to motionctl") {
        inputs::run(root, &bin, &mut tally)?;
    }
    if wanted("qemu", "the link firmware in QEMU") {
        qemu_cases::run(root, &bin, &mut tally)?;
    }
    let seconds = t0.elapsed().as_secs_f64();
    std::fs::write(root.join(JSON), serde_json::to_string_pretty(&tally.json(seconds))? + "\n")?;
    println!("\n  {:<34} {:>7} {:>9} {:>9}", "class", "inputs", "injected", "survived");
    for (name, c) in &tally.classes {
        println!("  {name:<34} {:>7} {:>9} {:>9}", c.inputs, c.injected, c.survived);
    }
    let t = tally.total();
    println!("  {:<34} {:>7} {:>9} {:>9}", "total", t.inputs, t.injected, t.survived);
    println!("  ({seconds:.1} s; written to {JSON})");
    if !tally.failures.is_empty() {
        bail!(
            "{} fault case(s) did not end as documented:\n  {}",
            tally.failures.len(),
            tally.failures.join("\n  ")
        );
    }
    Ok(())
}

/// Every fault scenario on the host model: each injects its cause once.
fn board_scenarios(tally: &mut Tally) {
    use motion::scenarios::faults::{broken_promise, run_case, Case, CASES};
    for case in CASES {
        let class = match case {
            Case::LimitNoise => "noisy switches",
            _ => "board faults (scenarios)",
        };
        let r = match run_case(case) {
            None => Err(anyhow::anyhow!("{}: the scenario could not be built", case.name())),
            Some(rep) => match broken_promise(case, &rep) {
                None => Ok(()),
                Some(why) => Err(anyhow::anyhow!("{}: {why}", case.name())),
            },
        };
        tally.record(class, 1, 1, r);
    }
    let c = &tally.classes;
    let done: u64 = c.values().map(|c| c.survived).sum();
    println!("  {} fault scenarios, {done} ended as documented", CASES.len());
}

/// What [`JSON`] holds: the totals, the rows by class, the failures.
pub struct Counts {
    pub total: Count,
    pub rows: Vec<(String, Count)>,
    pub failures: Vec<String>,
}

/// Reads [`JSON`].
pub fn read_counts(root: &Path) -> Result<Counts> {
    let text = std::fs::read_to_string(root.join(JSON))?;
    let v: serde_json::Value = serde_json::from_str(&text)?;
    let count = |c: &serde_json::Value| Count {
        inputs: c["inputs"].as_u64().unwrap_or(0),
        injected: c["injected"].as_u64().unwrap_or(0),
        survived: c["survived"].as_u64().unwrap_or(0),
    };
    let rows = v["classes"]
        .as_object()
        .map(|m| m.iter().map(|(k, c)| (k.clone(), count(c))).collect())
        .unwrap_or_default();
    let strings = |key: &str| -> Vec<String> {
        v[key]
            .as_array()
            .map(|a| a.iter().filter_map(|g| g.as_str().map(str::to_string)).collect())
            .unwrap_or_default()
    };
    Ok(Counts { total: count(&v["total"]), rows, failures: strings("failures") })
}
