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
        home: None,
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
            home_order: Vec::new(),
        },
        items: Vec::new(),
        feed_commands: Vec::new(),
    }
}

/// The thesis's stall handling for a wire job of `segments` segments.
fn stall_params(segments: usize) -> motion::wire::link_messages::WireJobParams {
    use motion::wire::scenario::STALL_PARAMS as P;
    motion::wire::link_messages::WireJobParams {
        debounce_ticks: P.debounce_ticks,
        retrace_limit_steps: P.retrace_limit_steps,
        retrace_override_bits: P.retrace_override.to_bits(),
        resume_override_bits: P.resume_override.to_bits(),
        resume_segments: P.resume_segments,
        segments: segments as u32,
    }
}

/// The job's machine (its start at the path's first point) and the program the board gets:
/// `cfg`, the axes' scales, the host model's final steps.
pub(super) fn board_machine(
    job: &crate::wire::continuous::ContinuousJob,
    report: &motion::report::Report,
    cfg: motion::MachineConfig,
) -> (crate::job::Job, crate::convert::Program) {
    let origin = crate::wire::continuous::joints_from_steps(job.point_steps[0]);
    let parsed = wire_job_machine(
        &cfg,
        [origin.x_mm, origin.y_mm, origin.beta_rad.to_degrees(), origin.alpha_rad.to_degrees()],
    );
    let mut final_steps = [0i64; motion::MAX_AXES];
    final_steps.copy_from_slice(&report.positions[..motion::MAX_AXES]);
    let program = crate::convert::Program {
        config: cfg,
        steps_per_mm: parsed.machine.axes.iter().map(|a| a.steps_per_mm).collect(),
        items: Vec::new(),
        commands: Vec::new(),
        final_steps,
        skipped_moves: 0,
    };
    (parsed, program)
}

/// A wire job as `wire run --job FILE [--segments FROM..TO]` sends it to a board with wire
/// jobs: for a caller with its own link (the grbl bridge's `$WIRE=`).
#[derive(Clone, Debug)]
pub struct WireBoardJob {
    /// The die, e.g. "circle -> complex".
    pub label: String,
    pub fr_mm2_per_min: f64,
    /// Segments of the whole job (`segments` may be a part of it).
    pub job_segments: usize,
    pub segments: Vec<motion::segment::Segment>,
    pub cfg: motion::protocol::LinkConfig,
    pub params: motion::wire::link_messages::WireJobParams,
    /// The host model's final X, Y, beta, alpha steps from the start, and its duration, ticks.
    pub expected: [i64; 4],
    pub model_ticks: u64,
    /// Steps per unit of X, Y (mm), beta, alpha (deg).
    pub steps_per_unit: [f64; 4],
}

/// Plans `job_file` (a wire job TOML, as `wire run --job` reads it), only `range` of its
/// segments if given, and runs it on the host model.
pub fn wire_board_job(
    job_file: &std::path::Path,
    range: Option<std::ops::Range<usize>>,
) -> Result<WireBoardJob> {
    use clap::Parser;
    #[derive(Parser)]
    struct JobOnly {
        #[command(flatten)]
        plan: super::WirePlanArgs,
    }
    let args = [std::ffi::OsStr::new("wire"), "--job".as_ref(), job_file.as_os_str()];
    let plan = JobOnly::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?.plan;
    let (die, _) = plan.die()?;
    let prm = plan.params(die.fr_mm2_per_min)?;
    let cfg = motion::wire::machine::config();
    let mut job = crate::wire::continuous::plan(&die.path()?, &cfg, &prm)?;
    let job_segments = job.segments.len();
    if let Some(r) = &range {
        super::only_segments(&mut job, r, true)?;
    }
    let (report, _) = super::host_model(&cfg, &job, false)?;
    let (parsed, program) = board_machine(&job, &report, cfg);
    let mut expected = [0i64; 4];
    expected.copy_from_slice(&report.positions[..4]);
    let mut steps_per_unit = [0.0; 4];
    for (s, a) in steps_per_unit.iter_mut().zip(&parsed.machine.axes) {
        *s = a.steps_per_mm;
    }
    Ok(WireBoardJob {
        label: die.label.clone(),
        fr_mm2_per_min: prm.fr_mm2_per_min,
        job_segments,
        params: stall_params(job.segments.len()),
        cfg: crate::runner::link_config(&parsed, &program),
        segments: job.segments,
        expected,
        model_ticks: report.ticks,
        steps_per_unit,
    })
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
    let (mut t, qemu_guard) = link.open()?;
    let opts = crate::wire::run::WireRunOptions {
        params: stall_params(segments.len()),
        host: motion::protocol::HostConfig { rto_ms: 100, window: 8 },
        // QEMU's machine has no switches: homing there takes it where it stands.
        home: link.home || link.qemu,
        progress: true,
        stall,
        slack: crate::wire::run::SLACK,
    };
    let mut expected = [0i64; 4];
    expected.copy_from_slice(&model.positions[..4]);
    let cfg = crate::runner::link_config(parsed, program);
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
