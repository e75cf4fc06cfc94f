//! End to end, force jobs: `motionctl milling run --qemu` runs Case A
//! (`motionctl/examples/case_a_milling.toml`: Fnom 4100 N, b 2.5 -> 10 mm) as a force job on the
//! link firmware in QEMU, whose simulated milling plant cuts; then a job of other numbers
//! (`pocket_wall_1500n.toml`: 1500 N, 800 rpm, 3 teeth); then Case A with a stuck force channel
//! injected 5 mm into the cut. Checked here independently of motionctl's own checks, from its
//! `milling-summary` line and its status CSV: the jobs end at the move's end (the segment's
//! steps), no fault, the force (recomputed from the CSV) back within +-10 % of the job's Fnom
//! within 150 ms of the depth step, averaging Fnom over 300..400 ms after it, never above the
//! trip level; the fault run holds with `ForceStuck` alone, inside the move.

use crate::e2e::{build_motionctl, run_motionctl};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::path::Path;

const JOB: &str = "motionctl/examples/case_a_milling.toml";
/// A job that is not the thesis's: 1500 N, 800 rpm, 3 teeth, Kc 2150.5 N/mm^2.
const USER_JOB: &str = "motionctl/examples/pocket_wall_1500n.toml";

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

/// From the status CSV: (settling after the depth step within the 400 ms window, s; peak, N;
/// mean force over the last 100 ms of the window, N).
fn settle_from_csv(
    csv: &str,
    fnom_n: f64,
    step_at_steps: i64,
) -> Result<(Option<f64>, f64, Option<f64>)> {
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
        return Ok((None, peak, None));
    };
    let last_out = rows
        .iter()
        .filter(|r| r.0 >= t0 && r.0 - t0 <= 0.4 && (r.1 - fnom_n).abs() > 0.1 * fnom_n)
        .map(|r| r.0 - t0)
        .fold(0.0, f64::max);
    let late: Vec<f64> =
        rows.iter().filter(|r| r.0 - t0 > 0.3 && r.0 - t0 <= 0.4).map(|r| r.1).collect();
    let mean = (!late.is_empty()).then(|| late.iter().sum::<f64>() / late.len() as f64);
    Ok((Some(last_out), peak, mean))
}

/// A job without a fault: it ends at the move's end with no fault, the force (from the CSV)
/// back within +-10 % of Fnom within 150 ms of the depth step, averaging Fnom within 3 % over
/// 300..400 ms after it, never above the trip level. Problems are added to `problems`.
fn settling_run(
    root: &Path,
    bin: &Path,
    base: &[String],
    job_file: &str,
    tag: &str,
    problems: &mut Vec<String>,
) -> Result<()> {
    let job = motionctl::milling::job::parse(&std::fs::read_to_string(root.join(job_file))?)?;
    let (fnom_n, trip_n) = (job.fnom_n, job.trip_n);
    let move_steps = job.setup.segment().steps[0] as i64;
    let csv_path = root.join(format!("target/milling-e2e-{tag}.csv"));
    let mut args = vec!["milling".to_string(), "run".into(), job_file.into()];
    args.extend(base.iter().cloned());
    args.extend(["--csv".to_string(), csv_path.display().to_string()]);
    let (ok, stdout, wall) = run_motionctl(root, bin, &args)?;
    if !ok {
        bail!("motionctl milling run {job_file} failed (see its output above)");
    }
    let m = summary(&stdout)?;
    let get = |k: &str| m.get(k).cloned().unwrap_or_default();
    if get("x") != move_steps.to_string() {
        problems.push(format!("{tag} ended at X {} steps, the move is {move_steps}", get("x")));
    }
    if get("faults") != "0x0" {
        problems.push(format!("{tag} latched faults {}", get("faults")));
    }
    let csv = std::fs::read_to_string(&csv_path)?;
    let (settle, peak, late) = settle_from_csv(&csv, fnom_n, job.step_at_steps())?;
    match settle {
        Some(t) if t <= 0.150 => {}
        other => problems.push(format!("{tag} force not back within +-10 % in 150 ms: {other:?}")),
    }
    match late {
        Some(f) if (f - fnom_n).abs() <= 0.03 * fnom_n => {}
        other => problems
            .push(format!("{tag} force 300..400 ms after the step {other:?} N, Fnom {fnom_n} N")),
    }
    if peak > trip_n {
        problems.push(format!("{tag} force {peak:.0} N above the trip level {trip_n:.0} N"));
    }
    println!(
        "  milling e2e, {tag} (Fnom {fnom_n:.0} N): X = {} steps == the move; settled {:.0} ms \
         after the depth step (host model {} s), then {:.0} N; peak {peak:.0} N < trip \
         {trip_n:.0} N; {} control updates, {} statuses; {:.1} s wall",
        get("x"),
        settle.unwrap_or(f64::NAN) * 1e3,
        get("model_settle_s"),
        late.unwrap_or(f64::NAN),
        get("updates"),
        get("points"),
        wall.as_secs_f64()
    );
    Ok(())
}

/// The `cargo xtask test` step (also `cargo xtask milling-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let s = |x: &str| x.to_string();
    let base = vec![s("--qemu"), s("--firmware"), elf.display().to_string()];
    let mut problems = Vec::new();
    settling_run(root, &bin, &base, JOB, "case-a", &mut problems)?;
    settling_run(root, &bin, &base, USER_JOB, "1500n", &mut problems)?;

    // A stuck channel 5 mm into the cut: hold with ForceStuck, position inside the move.
    let job = motionctl::milling::job::parse(&std::fs::read_to_string(root.join(JOB))?)?;
    let move_steps = job.setup.segment().steps[0] as i64;
    let mut args = vec![s("milling"), s("run"), s(JOB)];
    args.extend(base);
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
    if !(job.setup.plant.wall_steps..move_steps).contains(&x) {
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
