//! End to end, Z-slide jobs: `motionctl turning run --qemu` runs the built-in
//! Douglass table on the link firmware in QEMU twice: 360 rpm with the Z axis's step/dir output,
//! then with the DAC output and a +20 % spindle speed step 0.25 s (board time) after the start.
//! X feeds 0 -> 0.5 in at 1 in/s (a short feed: the whole step stays well under a minute of
//! wall time). Each run is checked here too, independently of motionctl's own check, against the
//! host model computed here (the firmware's `Machine` + `ZJob` + encoder logic on the host):
//! final X and Z steps equal, no fault, the job finished (z_state 3), the largest following
//! error near the model's (the spindle's phase at the start is the board's), and after the step
//! the board senses the stepped speed (the command tracks it: no fault, the same end).

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use crate::firmware::{self, Board};
use anyhow::{bail, Result};
use motionctl::turning::run::{self as zrun, LinkTableBytes, ZOutput, ZRunOptions};
use std::path::Path;

/// The `cargo xtask test` step (also `cargo xtask turning-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let table = LinkTableBytes::douglass()?;
    let runs: [(ZOutput, Option<(f64, f64)>); 2] =
        [(ZOutput::Steps, None), (ZOutput::Dac, Some((0.25, 0.2)))];
    let mut problems = Vec::new();
    for (output, step) in runs {
        let o = ZRunOptions { output, speed_step: step, ..ZRunOptions::default() };
        let s = |x: &str| x.to_string();
        let mut args = vec![
            s("turning"),
            s("run"),
            s("--qemu"),
            s("--firmware"),
            elf.display().to_string(),
            s("--rpm"),
            format!("{}", o.rpm_milli as f64 / 1e3),
            s("--x-end"),
            format!("{}", o.x_end_in),
            s("--feed"),
            format!("{}", o.feed_in_per_s),
            s("--output"),
            s(if output == ZOutput::Dac { "dac" } else { "steps" }),
        ];
        if let Some((at, frac)) = step {
            args.extend([
                s("--speed-step-at"),
                format!("{at}"),
                s("--speed-step-pct"),
                format!("{}", frac * 100.0),
            ]);
        }
        let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
        if !ok {
            bail!("motionctl turning run ({output:?}) failed (see its output above)");
        }
        let m = summary_ints(&stdout, "turning-summary ")?;
        let get = |k: &str| m.get(k).copied().unwrap_or(i64::MIN);
        let cfg = zrun::machine_config(o.tick_hz);
        let spec = zrun::job_spec(&o)?;
        let step_model = match step {
            Some((_, frac)) if get("step_at_tick") >= 0 => Some((
                get("step_at_tick") as u64,
                (o.rpm_milli as f64 * (1.0 + frac)).round() as u32,
            )),
            Some(_) => {
                problems.push(format!("{output:?}: the speed step was not sent"));
                None
            }
            None => None,
        };
        let model =
            zrun::model(&cfg, &table, &spec, o.rpm_milli, step_model, 10 * o.tick_hz as u64)?;
        let mut p = Vec::new();
        if (get("x_steps"), get("z_steps")) != (model.x_steps, model.z_steps) {
            p.push(format!(
                "final (X, Z) steps ({}, {}) != host model ({}, {})",
                get("x_steps"),
                get("z_steps"),
                model.x_steps,
                model.z_steps
            ));
        }
        if get("faults") != 0 || get("z_state") != 3 || !model.finished {
            p.push(format!(
                "faults {:#x}, z_state {} (want 0 and 3), model finished {}",
                get("faults"),
                get("z_state"),
                model.finished
            ));
        }
        let fe = get("max_following_nin");
        let tol = ((model.max_following_nin as f64 * zrun::FOLLOWING_TOLERANCE) as i64)
            .max(zrun::FOLLOWING_SLACK_NIN);
        if (fe - model.max_following_nin).abs() > tol {
            p.push(format!("max following {fe} nin, model {} nin", model.max_following_nin));
        }
        if let Some((_, frac)) = step {
            let want = o.rpm_milli as f64 * (1.0 + frac);
            let got = get("final_rpm_milli") as f64;
            if (got - want).abs() > want * 0.01 {
                p.push(format!("the board senses {got} milli-rpm after the step, not {want}"));
            }
        }
        println!(
            "  turning e2e ({output:?}{}): (X, Z) = ({}, {}) steps == host model; max following \
             {:.3} uin (model {:.3}); board {} ticks, model {}; {:.1} s wall",
            if step.is_some() { ", +20 % speed step" } else { "" },
            get("x_steps"),
            get("z_steps"),
            fe as f64 / 1e3,
            model.max_following_nin as f64 / 1e3,
            get("board_ticks"),
            model.ticks,
            wall.as_secs_f64()
        );
        problems.extend(p.into_iter().map(|x| format!("{output:?}: {x}")));
    }
    if !problems.is_empty() {
        bail!("Z-slide end to end: {}", problems.join("; "));
    }
    Ok(())
}
