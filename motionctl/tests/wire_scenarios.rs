//! The wire scenarios as the firmware runs them (`motion::wire::scenario`), on the host:
//! (a) the whole circle -> complex job, bit-identical to the host model run of the planner's
//! segments, within 1 % of 60 A / FR; (b) a stall injected mid-job, retraced and recovered with
//! exact final positions and no lost steps.

use motion::scenario::{run_to_end, ScenarioReport};
use motion::wire::scenario::{WireJobScenario, WireStallScenario, STALL_AT_TICK, STALL_TICKS};
use motion::wire::{circle_complex_job as table, machine};
use motionctl::wire::continuous::{circle_complex_path, plan, ContinuousParams};

fn print(r: &ScenarioReport) {
    r.write_lines(|l| eprintln!("{l}"));
}

#[test]
fn job_scenario_matches_the_host_model_and_60a_over_fr() {
    let mut s = WireJobScenario::new().unwrap();
    let r = run_to_end(&mut s, 20_000_000);
    print(&r);
    let f = |n| r.figure(n).unwrap();
    assert_eq!(r.fault, 0);
    assert_eq!((f("done"), f("final_exact"), f("net_equals_positions")), (1, 1, 1));
    assert_eq!(
        [f("pos_x_steps"), f("pos_y_steps"), f("pos_beta_steps"), f("pos_alpha_steps")],
        table::TOTAL_STEPS
    );
    assert_eq!(f("segments_done"), table::SEGMENTS.len() as i64);
    assert_eq!(f("underruns"), 0);
    assert_eq!((f("stalls"), f("wire_off_ticks")), (0, 0));
    assert!(f("time_vs_ref_ppm").abs() < 10_000, "{} ppm", f("time_vs_ref_ppm"));
    // The planner's own figure of 60 A / FR, independent of the table.
    let j = plan(&circle_complex_path().unwrap(), &machine::config(), &ContinuousParams::default())
        .unwrap();
    assert_eq!(f("ref_60a_fr_us"), (j.time_ruled_s * 1e6).round() as i64);
    // Same pins, tick for tick, as the host model fed straight from the planner.
    let mut it = j.segments.iter().copied();
    let m =
        motion::model::run(&machine::config(), || it.next(), &[], 20_000_000, |_, _| {}).unwrap();
    assert_eq!((m.ticks, m.trace_hash), (r.ticks, r.hash));
}

#[test]
fn stall_scenario_recovers_exactly() {
    let mut s = WireStallScenario::new().unwrap();
    let r = run_to_end(&mut s, 20_000_000);
    print(&r);
    let f = |n| r.figure(n).unwrap();
    assert_eq!(r.fault, 0);
    assert_eq!((f("done"), f("final_exact"), f("net_equals_positions")), (1, 1, 1));
    assert_eq!(
        [f("pos_x_steps"), f("pos_y_steps"), f("pos_beta_steps"), f("pos_alpha_steps")],
        WireStallScenario::job_end()
    );
    assert_eq!(f("stalls"), 1);
    assert!(f("retrace_segments") >= 1);
    // The 4 s stall clears while the 5.3 s retrace of the interrupted segment is under way.
    assert_eq!(f("retrace_interrupts"), 1);
    assert!(f("resume_tick") as u64 > STALL_AT_TICK + STALL_TICKS);
    // The same job without the stall, for the cost of the stall.
    let job = &table::SEGMENTS[motion::wire::scenario::STALL_JOB];
    let mut it = job.iter().enumerate().map(|(k, s)| s.segment(k as u32));
    let m =
        motion::model::run(&machine::config(), || it.next(), &[], 20_000_000, |_, _| {}).unwrap();
    eprintln!("without stall: {} ticks; with: {} ticks", m.ticks, r.ticks);
    assert!(r.ticks > m.ticks + STALL_TICKS);
}
