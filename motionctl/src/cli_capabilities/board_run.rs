//! `motionctl wire run` on a board: the wire manipulator as the job's machine, and the job run
//! as a wire job (stall retrace on the board) checked against the host model.

use anyhow::Result;

/// The wire manipulator as a job's machine: the DDA's axes 0..3 with their step scales
/// (src/wire/machine.rs); rotary axes in degrees. Soft limits from the thesis's travel, counted
/// from the job's start `origin` (X, Y mm, beta, alpha deg: the joints of the path's first
/// point, where the board's positions are zero).
pub(super) fn wire_job_machine(cfg: &motion::MachineConfig, origin: [f64; 4]) -> crate::job::Job {
    use crate::wire::ik::{STEPS_PER_DEG_ALPHA, STEPS_PER_DEG_BETA, STEPS_PER_MM_XY};
    use motion::wire::machine as m;
    let axis = |name: &str, steps_per_unit: f64, min: f64, max: f64| crate::job::Axis {
        name: name.into(),
        steps_per_mm: steps_per_unit,
        max_rate_mm_s: m::MAX_RATE_HZ as f64 / steps_per_unit,
        accel_mm_s2: m::ACCEL_STEPS_PER_S2 as f64 / steps_per_unit,
        junction_jerk_mm_s: m::JUNCTION_JERK_HZ as f64 / steps_per_unit,
        min_mm: min,
        max_mm: max,
    };
    crate::job::Job {
        machine: crate::job::Machine {
            tick_hz: cfg.tick_hz,
            timing: cfg.timing,
            axes: vec![
                axis("X", STEPS_PER_MM_XY, -50.0 - origin[0], 50.0 - origin[0]),
                axis("Y", STEPS_PER_MM_XY, -60.0 - origin[1], 60.0 - origin[1]),
                axis("B", STEPS_PER_DEG_BETA, -65.0 - origin[2], 65.0 - origin[2]),
                axis("A", STEPS_PER_DEG_ALPHA, -70.0 - origin[3], 70.0 - origin[3]),
            ],
            switch_debounce_ms: crate::job::DEFAULT_SWITCH_DEBOUNCE_MS,
            arc_tolerance_mm: crate::job::DEFAULT_ARC_TOLERANCE_MM,
        },
        items: Vec::new(),
        feed_commands: Vec::new(),
    }
}

/// `wire run` on a board link: the job as a wire job (stall retrace on the board), checked
/// against the host model.
pub(super) fn run_wire_job(
    parsed: &crate::job::Job,
    program: &crate::convert::Program,
    segments: &[motion::segment::Segment],
    model: &motion::report::Report,
    link: &crate::board_link::LinkArgs,
    stall: Option<crate::wire::run::SimStall>,
    json: bool,
) -> Result<()> {
    use motion::wire::scenario::STALL_PARAMS as P;
    let (mut t, qemu_guard) = link.open()?;
    let opts = crate::wire::run::WireRunOptions {
        params: motion::protocol::WireJobParams {
            debounce_ticks: P.debounce_ticks,
            retrace_limit_steps: P.retrace_limit_steps,
            retrace_override_bits: P.retrace_override.to_bits(),
            resume_override_bits: P.resume_override.to_bits(),
            resume_segments: P.resume_segments,
            segments: segments.len() as u32,
        },
        host: motion::protocol::HostConfig { rto_ms: 100, window: 8 },
        // QEMU's machine has no switches: homing there takes it where it stands.
        home: link.home || link.qemu,
        progress: true,
        stall,
        slack: crate::wire::run::SLACK,
    };
    let mut expected = [0i64; 4];
    expected.copy_from_slice(&model.positions[..4]);
    let cfg = crate::runner::wire_config(parsed, program);
    let result = crate::wire::run::run(&mut *t, cfg, segments, expected, model.ticks, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if json {
        print_run_json(parsed, program, &r)
    } else {
        print_run_text(parsed, &r)
    }
}

/// X, Y in mm, beta and alpha in degrees: the job machine's axes, with their names.
fn positions_in_units(parsed: &crate::job::Job, steps: &[i64]) -> Vec<(String, f64)> {
    parsed
        .machine
        .axes
        .iter()
        .zip(steps)
        .map(|(a, &s)| (a.name.clone(), s as f64 / a.steps_per_mm))
        .collect()
}

/// The run's summary as one JSON object; an error if a check failed.
fn print_run_json(
    parsed: &crate::job::Job,
    program: &crate::convert::Program,
    r: &crate::wire::run::WireRunReport,
) -> Result<()> {
    let pos: serde_json::Map<String, serde_json::Value> = positions_in_units(parsed, &r.positions)
        .into_iter()
        .map(|(n, v)| (n, serde_json::json!(v)))
        .collect();
    let v = serde_json::json!({
        "ok": r.ok(),
        "segments": r.segments,
        "wall_s": r.seconds,
        "board_s": r.board_ticks as f64 / program.config.tick_hz.max(1) as f64,
        "positions_mm_deg": pos,
        "positions_steps": r.positions,
        "model_positions_steps": r.expected_positions,
        "stalls": r.stalls,
        "retraces": r.retraces,
        "returns": r.returns,
        "max_retrace_steps": r.max_retrace_steps,
        "problems": r.problems,
    });
    crate::outln!("{v}");
    if !r.ok() {
        anyhow::bail!("the wire job failed {} check(s)", r.problems.len());
    }
    Ok(())
}

/// The run's summary as text, and the one `wire-summary` line for scripts; an error if a check
/// failed.
fn print_run_text(parsed: &crate::job::Job, r: &crate::wire::run::WireRunReport) -> Result<()> {
    let shown: Vec<String> = positions_in_units(parsed, &r.positions)
        .iter()
        .zip(&parsed.machine.axes)
        .map(|((n, v), a)| {
            let unit = if a.name.eq_ignore_ascii_case("X") || a.name.eq_ignore_ascii_case("Y") {
                "mm"
            } else {
                "deg"
            };
            format!("{n} {v:.4} {unit}")
        })
        .collect();
    crate::outln!("moved      {} (from the job's start)", shown.join(", "));
    crate::outln!(
        "wire job   {} segments, {:.2} s wall, {} board ticks",
        r.segments,
        r.seconds,
        r.board_ticks
    );
    crate::outln!("positions  {:?} steps; host model {:?}", r.positions, r.expected_positions);
    crate::outln!(
        "stall      {} stalls, {} retrace and {} return segments, largest retrace {} steps",
        r.stalls,
        r.retraces,
        r.returns,
        r.max_retrace_steps
    );
    // One machine-readable line for scripts (xtask wire-e2e).
    crate::outln!(
        "wire-summary x={} y={} beta={} alpha={} stalls={} retraces={} returns={} \
         max_retrace_steps={} board_ticks={} segments={}",
        r.positions[0],
        r.positions[1],
        r.positions[2],
        r.positions[3],
        r.stalls,
        r.retraces,
        r.returns,
        r.max_retrace_steps,
        r.board_ticks,
        r.segments
    );
    if !r.ok() {
        for p in &r.problems {
            eprintln!("motionctl: {p}");
        }
        anyhow::bail!("the wire job failed {} check(s)", r.problems.len());
    }
    crate::outln!("result     OK");
    Ok(())
}
