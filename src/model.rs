//! The host model of the firmware's pipeline: segments -> preparer -> DDA ready queue -> tick ->
//! pins, with the ready queue kept full as the firmware's feeder task keeps it.

use crate::config::MachineConfig;
use crate::dda::{Command, Dda, Preparer};
use crate::demo_job::{self, DemoJob};
use crate::report::Report;
use crate::segment::{Segment, SegmentError};
use crate::trace::StepRecorder;

/// Runs `segments` to completion and reports what the pins did. `on_tick` sees the DDA after
/// every tick. Stops early (with the report so far) after `max_ticks`.
pub fn run(
    cfg: &MachineConfig,
    mut segments: impl FnMut() -> Option<Segment>,
    commands: &[(u64, Command)],
    max_ticks: u64,
    mut on_tick: impl FnMut(&Dda, &crate::dda::StepOutput),
) -> Result<Report, SegmentError> {
    // A configuration the DDA rejects has nothing to run; callers validate first.
    let Ok(mut dda) = Dda::new(cfg) else {
        return Err(SegmentError::Duration);
    };
    let Ok(mut prep) = Preparer::new(cfg) else {
        return Err(SegmentError::Duration);
    };
    for &(at, cmd) in commands {
        // More commands than the DDA's schedule holds would be a job bug, not a run-time event.
        let _ = dda.schedule(at, cmd);
    }
    let mut rec = StepRecorder::new();
    let mut source_done = false;
    while dda.now() < max_ticks {
        while !source_done && dda.ready_free() > 0 {
            match segments() {
                Some(seg) => {
                    let p = prep.prepare(&seg)?;
                    // ready_free() > 0 was just checked.
                    let _ = dda.push(&p);
                }
                None => source_done = true,
            }
        }
        if source_done && dda.is_idle() {
            break;
        }
        let out = dda.tick();
        rec.record(dda.now(), &out);
        on_tick(&dda, &out);
    }
    Ok(Report::from_run(&dda, &rec, cfg.axis_count, cfg.tick_hz))
}

/// Longest the demo may run before the model gives up (10 s of machine time).
pub const DEMO_MAX_TICKS: u64 = 10 * demo_job::TICK_HZ as u64;

/// The built-in demo job, exactly as the firmware runs it.
pub fn run_demo(mut on_tick: impl FnMut(&Dda)) -> Report {
    let mut job = DemoJob::new();
    let cfg = demo_job::config();
    let report =
        run(&cfg, || job.next_segment(), demo_job::commands(), DEMO_MAX_TICKS, |d, _| on_tick(d));
    // The demo's segments come from the planner for this config; a refusal is caught by tests.
    report.unwrap_or_default()
}
