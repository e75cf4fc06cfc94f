//! The step-only tick against the full tick: the same steps, faults seen within its bound.

use super::{supervise_ticks, MAX_SUPERVISE_TICKS, STREAM_SAMPLE_STRIDE, SUPERVISE_TICKS};
use crate::dda::{Dda, Preparer, StepOutput};
use crate::machine::{
    homed, BoardConfig, Inputs, Machine, MachineCommand, MachineState, ProbeKind,
};
use crate::planner::{Move, Planner};
use crate::protocol::FaultCode;
use crate::scenarios::faults::{config, Case};

/// A homed machine of `case`'s config running `moves` (steps on X and Y), everything admitted
/// and in the DDA.
fn running(case: Case, moves: &[[i32; 2]]) -> (Machine, Dda, Preparer) {
    running_with(config(case), moves)
}

/// [`running`] on the machine config `cfg`.
fn running_with(cfg: BoardConfig, moves: &[[i32; 2]]) -> (Machine, Dda, Preparer) {
    let (mut m, mut dda, mut prep) = homed(cfg);
    let mut p = Planner::new(&cfg.link.machine);
    for mv in moves {
        p.push(&Move { steps: [mv[0], mv[1], 0, 0, 0, 0], feed_hz: 5_000 }).unwrap();
    }
    p.finish();
    while let Some(seg) = p.pop() {
        m.command(MachineCommand::Queue(&seg), &mut dda).unwrap();
        dda.push(&prep.prepare(&seg).unwrap()).unwrap();
    }
    m.command(MachineCommand::Start, &mut dda).unwrap();
    (m, dda, prep)
}

/// What a run did, tick by tick.
struct Run {
    steps: Vec<StepOutput>,
    fast_ticks: usize,
    /// The first step-only tick.
    first_fast: Option<usize>,
    /// The tick on which the machine left `Running`.
    left_running: Option<usize>,
    /// Held ticks ([`run_strided`]).
    held: usize,
}

/// Ticks `ticks` times as the link firmware does (`fast`: a step-only tick whenever the machine
/// grants one, else a full tick with `inputs(t)`), or with full ticks only.
fn run(
    (mut m, mut dda, mut prep): (Machine, Dda, Preparer),
    ticks: usize,
    fast: bool,
    inputs: impl Fn(usize) -> Inputs,
) -> (Run, Machine) {
    let mut r =
        Run { steps: Vec::new(), fast_ticks: 0, first_fast: None, left_running: None, held: 0 };
    for t in 0..ticks {
        let step = match if fast { m.fast_tick(&mut dda) } else { None } {
            Some(s) => {
                r.fast_ticks += 1;
                r.first_fast.get_or_insert(t);
                s
            }
            None => m.tick(&mut dda, &inputs(t)).step,
        };
        r.steps.push(step);
        if m.state() != MachineState::Running && r.left_running.is_none() {
            r.left_running = Some(t);
        }
        if m.wants_background() {
            m.background(&mut dda, &mut prep);
        }
    }
    (r, m)
}

fn assert_same_pins(a: &[StepOutput], b: &[StepOutput]) {
    assert_eq!(a.len(), b.len());
    if let Some(t) = (0..a.len()).find(|&t| a[t] != b[t]) {
        panic!("the pins differ first on tick {t}: {:?} against {:?}", a[t], b[t]);
    }
}

const JOB: [[i32; 2]; 3] = [[3_000, 1_000], [-500, 2_000], [1_200, -800]];
const JOB_TICKS: usize = 200_000;

#[test]
fn a_quiet_job_steps_exactly_as_with_full_ticks_and_mostly_step_only() {
    let (plain, pm) = run(running(Case::EStop, &JOB), JOB_TICKS, false, |_| Inputs::QUIET);
    let (fast, fm) = run(running(Case::EStop, &JOB), JOB_TICKS, true, |_| Inputs::QUIET);
    assert_eq!(plain.fast_ticks, 0);
    assert_same_pins(&fast.steps, &plain.steps);
    assert_eq!(fm.positions(), pm.positions());
    assert_eq!(fm.state(), MachineState::Ready);
    let (end_plain, end_fast) = (plain.left_running.unwrap(), fast.left_running.unwrap());
    // The job ends on a full tick: at most one supervision period later.
    assert!(end_fast >= end_plain && end_fast - end_plain < SUPERVISE_TICKS as usize);
    // All but one tick in SUPERVISE_TICKS is step-only, running or idle.
    let full = JOB_TICKS - fast.fast_ticks;
    assert!(full <= JOB_TICKS / SUPERVISE_TICKS as usize + 2, "{full} full ticks");
}

#[test]
fn a_faster_tick_keeps_the_supervision_period_in_time_up_to_its_cap() {
    assert_eq!(supervise_ticks(10_000), SUPERVISE_TICKS);
    assert_eq!(supervise_ticks(100_000), SUPERVISE_TICKS);
    assert_eq!(supervise_ticks(150_000), 12);
    assert_eq!(supervise_ticks(250_000), 20);
    assert_eq!(supervise_ticks(500_000), MAX_SUPERVISE_TICKS);
    assert_eq!(supervise_ticks(u32::MAX), MAX_SUPERVISE_TICKS);
}

#[test]
fn at_a_250_khz_tick_a_quiet_job_takes_a_full_tick_every_20_and_steps_the_same() {
    let mut cfg = config(Case::EStop);
    cfg.link.machine.tick_hz = 250_000;
    let job = || running_with(cfg, &JOB);
    let period = supervise_ticks(250_000) as usize;
    // The same steps take 2.5 times the ticks.
    let ticks = JOB_TICKS * 3;
    let (plain, _) = run(job(), ticks, false, |_| Inputs::QUIET);
    let (fast, fm) = run(job(), ticks, true, |_| Inputs::QUIET);
    assert_same_pins(&fast.steps, &plain.steps);
    assert_eq!(fm.state(), MachineState::Ready);
    let (end_plain, end_fast) = (plain.left_running.unwrap(), fast.left_running.unwrap());
    assert!(end_fast >= end_plain && end_fast - end_plain < period);
    let full = ticks - fast.fast_ticks;
    assert!(full <= ticks / period + 2, "{full} full ticks");
    assert!(full > ticks / (period + 1), "{full} full ticks: the run is longer than granted");
}

#[test]
fn a_limit_switch_is_seen_within_one_supervision_period() {
    for close_at in [1_000usize, 1_003, 1_007, 5_555] {
        let inputs =
            |t: usize| Inputs { limit_max: if t >= close_at { 1 } else { 0 }, ..Inputs::QUIET };
        let (plain, pm) = run(running(Case::EStop, &JOB), 20_000, false, inputs);
        let (fast, fm) = run(running(Case::EStop, &JOB), 20_000, true, inputs);
        for m in [&pm, &fm] {
            assert_eq!(m.state(), MachineState::Fault);
            assert!(m.faults().has(FaultCode::LimitSwitch));
        }
        let (tp, tf) = (plain.left_running.unwrap(), fast.left_running.unwrap());
        assert!(tf >= tp && tf - tp < SUPERVISE_TICKS as usize, "close {close_at}: {tp} {tf}");
        assert_same_pins(&fast.steps[..tp], &plain.steps[..tp]);
    }
}

#[test]
fn a_command_makes_the_next_tick_a_full_one() {
    let (mut m, mut dda, _) = running(Case::EStop, &JOB);
    m.tick(&mut dda, &Inputs::QUIET);
    assert!(m.fast_tick(&mut dda).is_some());
    m.command(MachineCommand::Hold, &mut dda).unwrap();
    assert!(m.fast_tick(&mut dda).is_none(), "a hold waits for no step-only tick");
    m.tick(&mut dda, &Inputs::QUIET);
    assert_eq!(m.state(), MachineState::Holding);
    // Holding on the path is quiet too.
    assert!(m.fast_tick(&mut dda).is_some());
}

#[test]
fn a_switch_being_timed_keeps_every_tick_full() {
    let (mut m, mut dda, _) = running(Case::EStop, &JOB);
    let c = m.config().link;
    let debounce = c.inputs.debounce_ticks(c.machine.tick_hz);
    assert!(debounce > 2);
    // Closed for less than the debounce: timed on every tick, then forgotten.
    for _ in 0..debounce - 1 {
        m.tick(&mut dda, &Inputs { limit_min: 1, ..Inputs::QUIET });
        assert!(m.fast_tick(&mut dda).is_none(), "a switch being timed");
    }
    m.tick(&mut dda, &Inputs::QUIET);
    assert_eq!(m.state(), MachineState::Running);
    assert!(m.fast_tick(&mut dda).is_some());
}

/// A running machine whose DDA was handed a longer move than the one admitted inside the soft
/// limits, as a wrong segment would be.
fn past_the_soft_limit(cfg: BoardConfig) -> (Machine, Dda, Preparer) {
    let (mut m, mut dda, mut prep) = homed(cfg);
    let mut p = Planner::new(&cfg.link.machine);
    p.push(&Move { steps: [10, 0, 0, 0, 0, 0], feed_hz: 5_000 }).unwrap();
    p.finish();
    m.command(MachineCommand::Queue(&p.pop().unwrap()), &mut dda).unwrap();
    let mut p = Planner::new(&cfg.link.machine);
    p.push(&Move { steps: [1_000_000, 0, 0, 0, 0, 0], feed_hz: 5_000 }).unwrap();
    p.finish();
    dda.push(&prep.prepare(&p.pop().unwrap()).unwrap()).unwrap();
    m.command(MachineCommand::Start, &mut dda).unwrap();
    (m, dda, prep)
}

#[test]
fn a_soft_limit_crossed_in_a_quiet_job_latches_on_the_tick_it_is_crossed() {
    // Admitted inside the limits; the DDA is handed a longer move, as a wrong segment would be.
    // The step-only runs shorten as the axis nears the limit (they do not check it), down to
    // full ticks, which do.
    let cfg = config(Case::SoftLimitRun);
    let build = || past_the_soft_limit(cfg);
    let (plain, pm) = run(build(), 200_000, false, |_| Inputs::QUIET);
    let (fast, fm) = run(build(), 200_000, true, |_| Inputs::QUIET);
    assert!(pm.faults().has(FaultCode::SoftLimit) && fm.faults().has(FaultCode::SoftLimit));
    assert_eq!(fast.left_running, plain.left_running);
    assert_eq!(fm.positions(), pm.positions());
    assert!(fast.fast_ticks > 0);
}

#[test]
fn a_probe_move_keeps_every_tick_full_and_trips_as_with_full_ticks() {
    let cfg = config(Case::EStop);
    let build = || {
        let (mut m, mut dda, mut prep) = homed(cfg);
        m.arm_probe(ProbeKind::TowardError, &dda).unwrap();
        let mut p = Planner::new(&cfg.link.machine);
        p.push(&Move { steps: [0, -4_000, 0, 0, 0, 0], feed_hz: 2_000 }).unwrap();
        p.finish();
        let seg = p.pop().unwrap();
        m.command(MachineCommand::Queue(&seg), &mut dda).unwrap();
        dda.push(&prep.prepare(&seg).unwrap()).unwrap();
        m.command(MachineCommand::Start, &mut dda).unwrap();
        (m, dda, prep)
    };
    // The probe touches after 5 000 ticks and stays in contact.
    let inputs = |t: usize| Inputs { probe: t >= 5_000, ..Inputs::QUIET };
    let (plain, pm) = run(build(), 60_000, false, inputs);
    let (fast, fm) = run(build(), 60_000, true, inputs);
    assert_same_pins(&fast.steps, &plain.steps);
    assert_eq!(fm.probe().latched_steps(), pm.probe().latched_steps());
    assert_eq!(fm.state(), MachineState::Ready);
    // None while the probe is watched (the move and its stop after the trip), then the job
    // ends within a supervision period of the full-tick run.
    let stopped = fm.probe().latched_steps();
    assert_ne!(stopped, [0; 6]);
    let first_fast = fast.first_fast.unwrap();
    assert!(first_fast > 5_000, "a step-only tick at {first_fast}, during the probe move");
    let (end_plain, end_fast) = (plain.left_running.unwrap(), fast.left_running.unwrap());
    assert!(end_fast >= end_plain && end_fast - end_plain < SUPERVISE_TICKS as usize);
}

/// The board reads its once-per-tick sensor (the spindle) through `fast_tick_sensing`: on every
/// granted step-only tick exactly once, and never on a tick the machine refuses, which the full
/// tick then runs (and reads it itself). A job as the link firmware ticks it: every tick reads
/// the sensor once.
#[test]
fn the_sensor_is_read_once_on_every_tick_whichever_path_runs_it() {
    use crate::machine::DdaSource;
    let (mut m, mut dda, mut prep) = running(Case::EStop, &JOB);
    let (mut reads, mut fast_ticks, mut full_ticks) = (0usize, 0usize, 0usize);
    for _ in 0..20_000 {
        let before = reads;
        match m.fast_tick_sensing(&mut dda, &mut DdaSource, || reads += 1) {
            Some(_) => {
                fast_ticks += 1;
                assert_eq!(reads, before + 1, "a granted step-only tick reads the sensor once");
            }
            None => {
                assert_eq!(
                    reads, before,
                    "a refused step-only tick must leave the read to the full tick"
                );
                // The full tick's own read, as the firmware's full path does.
                reads += 1;
                full_ticks += 1;
                m.tick(&mut dda, &Inputs::QUIET);
            }
        }
        if m.wants_background() {
            m.background(&mut dda, &mut prep);
        }
    }
    assert_eq!(reads, fast_ticks + full_ticks);
    assert!(fast_ticks > 0 && full_ticks > 0, "{fast_ticks} step-only, {full_ticks} full ticks");
}

/// Full ticks at most every `stride` ticks, as a streamed output's fill runs them: step-only
/// ticks as many in a row as granted ([`Machine::fast_fill`]), else a full tick once `stride`
/// ticks have passed since the last one, and held ticks between. The background (an abort after
/// an immediate stop) runs after each fill of [`FILL_TICKS`], as the feeder task does: a frozen
/// machine stays frozen through the held ticks up to there.
fn run_strided(
    (mut m, mut dda, mut prep): (Machine, Dda, Preparer),
    ticks: usize,
    stride: usize,
    inputs: impl Fn(usize) -> Inputs,
) -> (Run, Machine) {
    m.set_sample_stride(stride as u8);
    let mut r =
        Run { steps: Vec::new(), fast_ticks: 0, first_fast: None, left_running: None, held: 0 };
    let mut since_full = stride;
    let mut fill = [StepOutput::new(0, 0, 0, 0); FILL_TICKS];
    for start in (0..ticks).step_by(FILL_TICKS) {
        let slots = &mut fill[..FILL_TICKS.min(ticks - start)];
        let mut slot = 0;
        while slot < slots.len() {
            let n =
                m.fast_fill(&mut dda, &mut slots[slot..], || {}, &mut |w: &mut StepOutput, s| {
                    *w = s
                });
            (r.fast_ticks, since_full, slot) = (r.fast_ticks + n, since_full + n, slot + n);
            if slot == slots.len() {
                break;
            }
            let t = start + slot;
            slots[slot] = if since_full >= stride {
                since_full = 1;
                m.tick(&mut dda, &inputs(t)).step
            } else {
                since_full += 1;
                r.held += 1;
                m.held_tick(&mut dda)
            };
            slot += 1;
            // Step-only ticks leave the state as it is.
            if m.state() != MachineState::Running && r.left_running.is_none() {
                r.left_running = Some(t);
            }
        }
        r.steps.extend_from_slice(slots);
        if m.wants_background() {
            m.background(&mut dda, &mut prep);
        }
    }
    (r, m)
}

const STRIDE: usize = STREAM_SAMPLE_STRIDE as usize;
/// Slots per fill of the streamed output.
const FILL_TICKS: usize = 40;

#[test]
fn with_full_ticks_every_5th_a_job_steps_exactly_as_with_full_ticks() {
    let (plain, pm) = run(running(Case::EStop, &JOB), JOB_TICKS, false, |_| Inputs::QUIET);
    let (held, hm) = run_strided(running(Case::EStop, &JOB), JOB_TICKS, STRIDE, |_| Inputs::QUIET);
    assert_same_pins(&held.steps, &plain.steps);
    assert_eq!(hm.positions(), pm.positions());
    assert_eq!(hm.state(), MachineState::Ready);
}

#[test]
fn with_full_ticks_every_5th_a_limit_switch_is_seen_within_a_supervision_period_and_stops_all() {
    for close_at in [1_000usize, 1_003, 5_557] {
        let inputs =
            |t: usize| Inputs { limit_max: if t >= close_at { 1 } else { 0 }, ..Inputs::QUIET };
        // No debounce: the switch acts on the sample that reads it.
        let mut cfg = config(Case::EStop);
        cfg.link.inputs.switch_debounce_us = 0;
        let (plain, pm) = run(running_with(cfg, &JOB), 20_000, false, inputs);
        let (held, hm) = run_strided(running_with(cfg, &JOB), 20_000, STRIDE, inputs);
        for m in [&pm, &hm] {
            assert_eq!(m.state(), MachineState::Fault);
            assert!(m.faults().has(FaultCode::LimitSwitch));
        }
        let (tp, th) = (plain.left_running.unwrap(), held.left_running.unwrap());
        // A step-only run granted just before may delay the full tick that sees it.
        let bound = SUPERVISE_TICKS as usize;
        assert!(th >= tp && th - tp < bound, "close {close_at}: {tp} {th}");
        assert_same_pins(&held.steps[..tp], &plain.steps[..tp]);
        assert!(held.steps[th + 1..].iter().all(|s| s.rise() == 0), "close {close_at}");
        assert!(held.held > 0, "close {close_at}: no held tick");
    }
}

#[test]
fn with_full_ticks_every_5th_a_soft_limit_latches_on_the_tick_it_is_crossed() {
    let cfg = config(Case::SoftLimitRun);
    let build = || past_the_soft_limit(cfg);
    let (plain, pm) = run(build(), 200_000, false, |_| Inputs::QUIET);
    let (held, hm) = run_strided(build(), 200_000, STRIDE, |_| Inputs::QUIET);
    assert!(pm.faults().has(FaultCode::SoftLimit) && hm.faults().has(FaultCode::SoftLimit));
    assert_eq!(held.left_running, plain.left_running);
    assert_eq!(hm.positions(), pm.positions());
    // Near the limit no step-only run is granted: the held ticks check the steps.
    assert!(held.held > 0);
}

#[test]
fn with_full_ticks_every_5th_the_switch_debounce_keeps_its_time() {
    let (m, _, _) = running(Case::EStop, &JOB);
    let c = m.config().link;
    let debounce = c.inputs.debounce_ticks(c.machine.tick_hz) as usize;
    assert!(debounce > 4 * STRIDE);
    // Closed two strides short of the debounce time (its samples are a stride apart):
    // forgotten. Closed for good: a fault, seen within two strides of when full ticks alone
    // see it.
    let closed = |from: usize, to: usize| {
        move |t: usize| Inputs { limit_min: u8::from((from..to).contains(&t)), ..Inputs::QUIET }
    };
    let short = closed(2_000, 2_000 + debounce - 2 * STRIDE);
    let (_, hm) = run_strided(running(Case::EStop, &JOB), 20_000, STRIDE, short);
    assert!(!hm.faults().has(FaultCode::LimitSwitch), "a short closure tripped");
    assert_ne!(hm.state(), MachineState::Fault);
    let long = closed(2_000, 20_000);
    let (plain, _) = run(running(Case::EStop, &JOB), 20_000, false, long);
    let (held, hm) = run_strided(running(Case::EStop, &JOB), 20_000, STRIDE, long);
    assert!(hm.faults().has(FaultCode::LimitSwitch));
    assert!(held.held > 0);
    let (tp, th) = (plain.left_running.unwrap(), held.left_running.unwrap());
    assert!(th + STRIDE >= tp && th < tp + 2 * STRIDE, "full ticks {tp}, strided {th}");
}
