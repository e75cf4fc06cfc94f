//! The fault suite's tests: every case against its documented end, then each family's details
//! (limits, homing, following error) in its own file; the single-case ones are here.

mod following;
mod homing;
mod limits;

use super::*;
use crate::config::MAX_AXES;
use crate::dda::{Dda, Preparer};
use crate::machine::{reaction, Inputs, Machine, MachineCommand, MachineState, Refusal};
use crate::planner::Planner;
use crate::protocol::FaultCode;
use crate::scenario::{run_to_end, ScenarioReport};

#[test]
fn every_case_ends_documented_with_exact_counters() {
    for c in CASES {
        let r = run(c);
        assert_eq!(broken_promise(c, &r), None, "{}: {:?}", r.name, r.figures);
    }
}

fn run(c: Case) -> ScenarioReport {
    run_case(c).unwrap()
}

#[test]
fn estop_switches_outputs_off_and_refuses_clear_while_pressed() {
    let r = run(Case::EStop);
    assert_eq!(r.figure("fault_tick"), Some(INJECT_TICK as i64));
    assert_eq!(r.figure("spindle"), Some(0));
    assert_eq!(r.figure("wire_power"), Some(0));
    assert_eq!(r.figure("z_dac"), Some(crate::machine::Z_DAC_MID_SCALE as i64));
    assert_eq!(r.figure("homed"), Some(0));
    assert_eq!(
        r.figure("clear_refused_nak"),
        Some(crate::protocol::ErrorCode::OutOfState.code() as i64)
    );
    assert!(r.figure("net0_steps").unwrap() > 0, "moving when the e-stop came");
    // The report says the counters are exact, and the documented reaction says so too.
    assert_eq!(r.figure("counters_exact"), Some(1));
    assert!(reaction(FaultCode::EStop).name().contains("the counters are exact"));
}

/// The switch debounce of the cases, ticks.
fn debounce_ticks() -> u64 {
    config(Case::LimitMin(0)).link.inputs.debounce_ticks(TICK_HZ) as u64
}

#[test]
fn a_late_host_pauses_the_job_on_the_path_and_it_resumes() {
    let r = run(Case::QueueStarved);
    let f = |n: &str| r.figure(n).unwrap();
    // Two 300-step segments fed at speed, then nothing: the hold ramps down inside the
    // second (no abrupt stop at its end, no fault), stands still for the host's absence,
    // and the rest of the stream runs to its end once the host feeds again.
    assert_eq!(f("dda_underruns"), 0);
    assert_eq!(f("starve_holds"), 1);
    let held = f("held_at0_steps");
    assert!(held > 300 && held <= 600, "held at {held} steps, inside the second segment");
    assert_eq!(f("held_ticks"), STARVED_TICKS as i64);
    assert_eq!(r.fault, 0);
    assert_eq!(f("state"), MachineState::Ready as i64);
    let total: i64 = STREAM.iter().map(|m| m.steps[0] as i64).sum();
    assert_eq!(f("net0_steps"), total, "every step of the stream, none twice");
}

#[test]
fn config_missing_refuses_motion() {
    let r = run(Case::ConfigMissing);
    assert_eq!(r.figure("home_refused"), Some(1));
    assert_eq!(r.figure("net0_steps"), Some(0));
    assert_eq!(r.figure("clear_refused_nak"), Some(10));
}
