//! End to end, force jobs (issue 4): `motionctl milling run --qemu` runs Case A
//! (`motionctl/examples/case_a_milling.toml`: Fnom 4100 N, b 2.5 -> 10 mm) as a force job on the
//! link firmware in QEMU, whose simulated milling plant cuts; then the same with a stuck force
//! channel injected 5 mm into the cut. Checked here independently of motionctl's own checks,
//! from its `milling-summary` line and its status CSV: Case A ends at the move's end (the
//! segment's steps), no fault, the force (recomputed from the CSV) back within +-10 % of Fnom
//! within 150 ms of the depth step and never above the trip level; the fault run holds with
//! `ForceStuck` alone, inside the move.

use crate::e2e::{build_motionctl, run_motionctl};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motion::force::scenario as sc;
use std::collections::BTreeMap;
use std::path::Path;

const JOB: &str = "motionctl/examples/case_a_milling.toml";

/// `milling-summary k=v ...` -> map of strings.
fn summary(stdout: &str) -> Result<BTreeMap<String, String>> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("milling-summary "))
        .context("motionctl printed no milling-summary line")?;
    Ok(line
        .split_whitespace()
        .skip(1)
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect())
}

/// From the status CSV: (settling after the depth step within the 400 ms window, s; peak, N).
fn settle_from_csv(csv: &str, fnom_n: f64, step_at_steps: i64) -> Result<(Option<f64>, f64)> {
    let mut rows = Vec::new();
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
        let (Some(t), Some(force), Some(x)) = (num(0), num(1), num(5)) else {
            bail!("bad CSV row {line:?}");
        };
        rows.push((t, force, x as i64));
    }
    let peak = rows.iter().map(|r| r.1).fold(0.0, f64::max);
    let Some(&(t0, _, _)) = rows.iter().find(|r| r.2 >= step_at_steps) else {
        return Ok((None, peak));
    };
    let last_out = rows
        .iter()
        .filter(|r| r.0 >= t0 && r.0 - t0 <= 0.4 && (r.1 - fnom_n).abs() > 0.1 * fnom_n)
        .map(|r| r.0 - t0)
        .fold(0.0, f64::max);
    Ok((Some(last_out), peak))
}

/// The `cargo xtask test` step (also `cargo xtask milling-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let job = motionctl::milling::job::parse(&std::fs::read_to_string(root.join(JOB))?)?;
    let fnom_n = job.control.fnom_mn as f64 / 1e3;
    let trip_n = job.control.trip_mn as f64 / 1e3;
    let step_at =
        job.plant.wall_steps + (job.plant.step_at_um as i64 * 1000) / job.plant.nm_per_step as i64;
    let move_steps = sc::segment().steps[0] as i64;
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let csv_path = root.join("target/milling-e2e-case-a.csv");
    let s = |x: &str| x.to_string();
    let base = vec![
        s("milling"),
        s("run"),
        s(JOB),
        s("--qemu"),
        s("--firmware"),
        elf.display().to_string(),
    ];
    let mut problems = Vec::new();

    // Case A.
    let mut args = base.clone();
    args.extend([s("--log-csv"), csv_path.display().to_string()]);
    let (ok, stdout, wall_a) = run_motionctl(root, &bin, &args)?;
    if !ok {
        bail!("motionctl milling run (Case A) failed (see its output above)");
    }
    let m = summary(&stdout)?;
    let get = |k: &str| m.get(k).cloned().unwrap_or_default();
    if get("x") != move_steps.to_string() {
        problems.push(format!("Case A ended at X {} steps, the move is {move_steps}", get("x")));
    }
    if get("faults") != "0x0" {
        problems.push(format!("Case A latched faults {}", get("faults")));
    }
    let (settle, peak) = settle_from_csv(&std::fs::read_to_string(&csv_path)?, fnom_n, step_at)?;
    match settle {
        Some(t) if t <= 0.150 => {}
        other => problems.push(format!("Case A force not back within +-10 % in 150 ms: {other:?}")),
    }
    if peak > trip_n {
        problems.push(format!("Case A force {peak:.0} N above the trip level {trip_n:.0} N"));
    }
    println!(
        "  milling e2e, Case A: X = {} steps == the move; settled {:.0} ms after the depth step \
         (host model {} s); peak {peak:.0} N < trip {trip_n:.0} N; {} control updates, {} \
         statuses; {:.1} s wall",
        get("x"),
        settle.unwrap_or(f64::NAN) * 1e3,
        get("model_settle_s"),
        get("updates"),
        get("points"),
        wall_a.as_secs_f64()
    );

    // A stuck channel 5 mm into the cut: hold with ForceStuck, position inside the move.
    let mut args = base;
    args.extend([s("--fault"), s("stuck0")]);
    let (ok, stdout, wall_f) = run_motionctl(root, &bin, &args)?;
    if !ok {
        bail!("motionctl milling run --fault stuck0 failed (see its output above)");
    }
    let m = summary(&stdout)?;
    let get = |k: &str| m.get(k).cloned().unwrap_or_default();
    if get("fault") != "ForceStuck" {
        problems.push(format!(
            "stuck channel: faults {} ({}), not ForceStuck",
            get("fault"),
            get("faults")
        ));
    }
    let x: i64 = get("x").parse().unwrap_or(-1);
    if !(job.plant.wall_steps..move_steps).contains(&x) {
        problems.push(format!("stuck channel: held at X {x}, outside the cut"));
    }
    println!(
        "  milling e2e, stuck channel: hold with {} at X = {x} steps (inside the cut); {:.1} s wall",
        get("fault"),
        wall_f.as_secs_f64()
    );
    if !problems.is_empty() {
        bail!("milling end to end: {}", problems.join("; "));
    }
    Ok(())
}
