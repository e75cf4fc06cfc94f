//! The force job as the link firmware runs it (`link_tick` around `Machine::tick`), on the host.

use super::*;
use crate::dda::Dda;
use crate::machine::{BoardConfig, MachineCommand};
use crate::machine::{Inputs, Machine, MachineState, TickOut};
use crate::milling::link_params::ForceStrategy;
use crate::milling::scenario::{self as sc, MillingScenario, Variant};
use crate::protocol::MAX_OVERRIDE_BITS;
use crate::protocol::{AxisScale, HomingConfig, LinkConfig};
use crate::scenario::run_to_end;

fn board() -> BoardConfig {
    let scale =
        AxisScale { steps_per_unit_milli: 1_000_000, soft_min: i64::MIN, soft_max: i64::MAX };
    let link = LinkConfig {
        machine: sc::machine(),
        scale: [scale; crate::config::MAX_AXES],
        inputs: crate::config::InputFilterConfig::DEFAULT,
    };
    BoardConfig::with_homing(link, &HomingConfig::NONE)
}

fn ready() -> (Machine, Dda, crate::dda::Preparer) {
    crate::machine::homed(board())
}

/// What a run on the link's tick showed.
#[derive(Debug, Default)]
struct Outcome {
    state: Option<MachineState>,
    faults: u32,
    /// Steps counted from the tick's outputs, and the machine's position.
    steps: i64,
    position: i64,
    updates: u32,
    peak_mn: u32,
    /// Ticks from the depth step to the last reading outside Fnom +- 10 % (400 ms window).
    settle_ticks: Option<u64>,
    /// Feed (um/s) over 300..400 ms after the step.
    feed_after_um_s: i64,
    phase: ForcePhase,
    active_force_causes: u32,
}

const FORCE_BITS: u32 = FaultCode::ForceSaturated.bit()
    | FaultCode::ForceStuck.bit()
    | FaultCode::ForceTrip.bit()
    | FaultCode::SpindleStopped.bit();

/// Queue the Case A move, arm `job` with the sim plant `sim`, start, and tick with full ticks
/// only until the job ends (or 5 s).
fn run(job: ForceJobParams, sim: SimMillingParams) -> Outcome {
    run_with(job, sim, false).0
}

/// One tick like the link firmware: a step-only tick when `step_only` and the machine grants
/// one, else a full one; the sample after it when due. The pins, and whether it was step-only.
fn firmware_tick(
    m: &mut Machine,
    dda: &mut Dda,
    fj: &mut ForceJob,
    step_only: bool,
) -> (crate::dda::StepOutput, bool) {
    if step_only {
        if let Some((step, due)) = link_step_only_deferred(m, dda, fj) {
            if due {
                link_sample(m, dda, fj);
            }
            return (step, true);
        }
    }
    (link_tick(m, dda, &Inputs::QUIET, fj).step, false)
}

/// [`run`], with step-only ticks where granted (`step_only`); also the pins of every tick
/// and how many ticks were step-only.
fn run_with(
    job: ForceJobParams,
    sim: SimMillingParams,
    step_only: bool,
) -> (Outcome, std::vec::Vec<crate::dda::StepOutput>, u64) {
    let (mut m, mut dda, mut prep) = ready();
    let seg = sc::segment();
    m.command(MachineCommand::Queue(&seg), &mut dda).unwrap();
    let mut fj = ForceJob::new(&job, sc::TICK_HZ, true, Some(&sim)).unwrap();
    assert_eq!(fj.telemetry().phase, ForcePhase::Armed);
    m.command(MachineCommand::Start, &mut dda).unwrap();
    dda.push(&prep.prepare(&seg).unwrap()).unwrap();
    fj.start(m.positions()[0]);
    let fnom = job.fnom_mn;
    let step_at = sim.wall_steps + (sim.step_at_um as i64 * 1000) / sim.nm_per_step as i64;
    let window = sc::TICK_HZ as u64 * 2 / 5;
    let mut o = Outcome::default();
    let (mut t, mut seen, mut step_tick, mut last_out) = (0u64, 0u32, None::<u64>, 0u64);
    let (mut x300, mut x400) = (0i64, 0i64);
    let (mut pins, mut step_only_ticks) = (std::vec::Vec::new(), 0u64);
    while t < sc::TICK_HZ as u64 * 5 {
        let (step, was_step_only) = firmware_tick(&mut m, &mut dda, &mut fj, step_only);
        pins.push(step);
        step_only_ticks += u64::from(was_step_only);
        let out = TickOut { step, outputs: m.outputs() };
        t += 1;
        if out.step.rise() & 1 != 0 {
            o.steps += if out.step.dir() & 1 != 0 { -1 } else { 1 };
        }
        let tel = fj.telemetry();
        if tel.updates != seen {
            seen = tel.updates;
            o.peak_mn = o.peak_mn.max(tel.force_mn);
            let x = m.positions()[0];
            match step_tick {
                None if x >= step_at => step_tick = Some(t),
                Some(s) if t - s <= window && tel.force_mn.abs_diff(fnom) > fnom / 10 => {
                    last_out = t;
                }
                _ => {}
            }
        }
        if let Some(s) = step_tick {
            if t - s == window * 3 / 4 {
                x300 = m.positions()[0];
            }
            if t - s == window {
                x400 = m.positions()[0];
            }
        }
        if !fj.is_running() && m.state() != MachineState::Running {
            break;
        }
    }
    // A few more ticks: a held DDA must stay put.
    for _ in 0..500 {
        let (step, _) = firmware_tick(&mut m, &mut dda, &mut fj, step_only);
        if step.rise() & 1 != 0 {
            o.steps += if step.dir() & 1 != 0 { -1 } else { 1 };
        }
    }
    o.state = Some(m.state());
    o.faults = m.faults().mask();
    o.position = m.positions()[0];
    o.updates = seen;
    o.settle_ticks = step_tick.map(|s| last_out.saturating_sub(s));
    o.feed_after_um_s = (x400 - x300) * 10;
    o.phase = fj.telemetry().phase;
    o.active_force_causes = m.active_causes() & FORCE_BITS;
    (o, pins, step_only_ticks)
}

#[test]
fn step_only_ticks_run_case_a_as_full_ticks_do() {
    let (full, full_pins, none) = run_with(case_a_job(), case_a_sim(SimForceFault::None), false);
    let (fast, fast_pins, step_only) =
        run_with(case_a_job(), case_a_sim(SimForceFault::None), true);
    assert_eq!(none, 0);
    // The same pins on every tick of the job (the step-only run sees its end up to 7 ticks
    // later, with nothing left to step).
    let n = full_pins.len().min(fast_pins.len());
    assert_eq!(full_pins[..n], fast_pins[..n]);
    assert_eq!(
        (fast.state, fast.faults, fast.position, fast.steps, fast.phase, fast.updates),
        (full.state, full.faults, full.position, full.steps, full.phase, full.updates)
    );
    eprintln!("{step_only} of {} ticks step-only", fast_pins.len());
    assert!(step_only * 8 >= fast_pins.len() as u64 * 7 - 64, "{step_only}/{}", fast_pins.len());
}

#[test]
fn a_force_trip_on_step_only_ticks_holds_within_a_supervision_period() {
    let job = ForceJobParams { trip_mn: 12_000_000, ..case_a_job() };
    let sim = case_a_sim(SimForceFault::None);
    let (full, full_pins, _) = run_with(job, sim, false);
    let (fast, fast_pins, _) = run_with(job, sim, true);
    for o in [&full, &fast] {
        assert_eq!(o.state, Some(MachineState::Fault));
        assert_eq!(o.faults & FORCE_BITS, FaultCode::ForceTrip.bit());
        assert_eq!(o.steps, o.position, "position intact");
    }
    // The trip is latched at most 7 ticks later: the pins agree until the full-tick run's
    // freeze, and the step-only run's position is at most those ticks further on.
    let frozen = full_pins.iter().rposition(|s| s.rise() != 0).unwrap_or(0);
    assert_eq!(full_pins[..frozen], fast_pins[..frozen]);
    let extra = fast.position - full.position;
    assert!((0..u64::from(crate::machine::machine::SUPERVISE_TICKS) as i64).contains(&extra));
}

#[test]
fn case_a_link_params_are_the_scenarios_setup() {
    let p = case_a_job();
    assert_eq!(control_params(&p), Ok(sc::control_params(18_000_000)));
    assert_eq!(chain_config(&p), Ok(sc::chain_config()));
    assert_eq!(p.sample_hz, sc::TICK_HZ / sc::TICKS_PER_SAMPLE);
    assert_eq!(check_job(&p), Ok(()));
    let sim = case_a_sim(SimForceFault::None);
    assert_eq!(check_sim(&sim), Ok(()));
    assert_eq!(plant_params(&sim, &p), sc::plant_params());
}

#[test]
fn every_bad_parameter_is_named() {
    type Bad = (fn(&mut ForceJobParams), &'static str);
    let bad: [Bad; 18] = [
        (|p| p.contact_mn = 0, "contact_mn"),
        (|p| p.trip_mn = p.fnom_mn, "contact_mn"),
        (|p| p.kp_dec_q16 = 101 << 16, "kp_dec_q16"),
        (|p| p.ki_inc_per_s_q16 = u32::MAX, "ki_inc_per_s_q16"),
        (|p| p.feed_max_bits = MAX_OVERRIDE_BITS + 1, "feed_max_bits"),
        (|p| p.feed_min_bits = MAX_OVERRIDE_BITS, "feed_min_bits"),
        (|p| p.sample_hz = 10_001, "sample_hz"),
        (|p| p.sample_hz = 1_000, "sample_hz"),
        (|p| p.flutes = 0, "flutes"),
        (|p| p.channels = 1, "channels"),
        (|p| p.tare_shift = 17, "tare_shift"),
        (|p| p.cal[1].mn_per_count_q16 = 0, "cal.mn_per_count_q16"),
        (|p| p.steps_per_s_at_one = 0, "steps_per_s_at_one"),
        (|p| p.axis = 6, "axis"),
        (|p| p.spindle_mrev_s = 0, "spindle_mrev_s"),
        (|p| p.stuck_samples = 0, "stuck_samples"),
        (
            |p| {
                p.strategy =
                    ForceStrategy::StopReduced { stop_ms: 1, reduced_ms: 1, reduced_gain_q16: 0 }
            },
            "strategy.reduced_gain_q16",
        ),
        (
            |p| p.strategy = ForceStrategy::SlowHold { slow_bits: u32::MAX, hold_ms: 1 },
            "strategy.slow_bits",
        ),
    ];
    for (f, field) in bad {
        let mut p = case_a_job();
        f(&mut p);
        assert_eq!(check_job(&p), Err(field), "{p:?}");
        assert_eq!(ForceJob::new(&p, sc::TICK_HZ, true, None).err(), Some(JobError { field }));
    }
    // A sample rate that does not divide the tick: refused only where the tick samples.
    let p = ForceJobParams { sample_hz: 15_000, ..case_a_job() };
    assert_eq!(check_job(&p), Ok(()));
    assert_eq!(
        ForceJob::new(&p, sc::TICK_HZ, true, None).err(),
        Some(JobError { field: "sample_hz" })
    );
    assert!(ForceJob::new(&p, sc::TICK_HZ, false, None).is_ok());
    let mut s = case_a_sim(SimForceFault::Stuck { channel: 3 });
    assert_eq!(check_sim(&s), Err("fault.channel"));
    s.fault = SimForceFault::None;
    s.nm_per_step = 0;
    assert_eq!(check_sim(&s), Err("nm_per_step"));
}

/// Case A on the link's tick: the force (as the board reports it, the chain's reading) is back
/// within +-10 % of Fnom within 150 ms of the depth step, never above the trip level, no fault,
/// and the position ends exactly at the move's end with no step lost. The host scenario (the
/// same library code driven without the machine) settles alike.
#[test]
fn case_a_on_the_link_tick_holds_fnom() {
    let o = run(case_a_job(), case_a_sim(SimForceFault::None));
    let settle_ms = o.settle_ticks.unwrap() as f64 * 1e3 / sc::TICK_HZ as f64;
    let mut s = MillingScenario::new(Variant::CaseA).unwrap();
    let r = run_to_end(&mut s, u64::MAX);
    let scenario_ms = r.figure("settle_us").unwrap() as f64 / 1e3;
    println!(
        "link tick: settle {settle_ms:.1} ms (scenario {scenario_ms:.1} ms), peak {} N, \
         feed after {} um/s (scenario {:?}), updates {}",
        o.peak_mn / 1000,
        o.feed_after_um_s,
        r.figure("feed_after_step_um_s"),
        o.updates
    );
    assert_eq!(o.state, Some(MachineState::Ready));
    assert_eq!(o.faults, 0);
    assert!(settle_ms <= 150.0, "settled in {settle_ms} ms");
    assert!(o.peak_mn < case_a_job().trip_mn);
    assert_eq!(o.position, sc::MOVE_STEPS as i64);
    assert_eq!(o.steps, o.position, "every step reached the pins");
    assert_eq!(o.phase, ForcePhase::Ended);
    // The thesis's static oracle: after the step F = C v with C four times larger, so the
    // feed is a quarter of 12.7 mm/s scaled by Fnom / 3900 N (4100/15600 x 12.7 = 3.338 mm/s).
    let oracle = 4_100.0 / 15_600.0 * 12_700.0;
    let err = (o.feed_after_um_s as f64 - oracle).abs() / oracle;
    assert!(err < 0.05, "feed after the step {} um/s vs {oracle:.0}", o.feed_after_um_s);
    // About 2 kHz control for the run.
    assert!(o.updates > 1_000);
}

fn assert_fault_hold(sim: SimForceFault, job: ForceJobParams, code: FaultCode) {
    let o = run(job, case_a_sim(sim));
    println!("{sim:?}: {o:?}");
    assert_eq!(o.state, Some(MachineState::Fault), "{sim:?}");
    assert_eq!(o.faults & FORCE_BITS, code.bit(), "{sim:?}");
    assert_eq!(o.steps, o.position, "position intact");
    assert!(o.position < sc::MOVE_STEPS as i64, "held before the end");
    assert_eq!(o.phase, ForcePhase::Faulted);
    // The job ended with the hold: its cause is gone, so ClearFault is possible.
    assert_eq!(o.active_force_causes, 0);
}

#[test]
fn stuck_channel_holds_the_feed() {
    assert_fault_hold(SimForceFault::Stuck { channel: 0 }, case_a_job(), FaultCode::ForceStuck);
}

#[test]
fn saturated_channel_holds_the_feed() {
    assert_fault_hold(
        SimForceFault::Saturated { channel: 1 },
        case_a_job(),
        FaultCode::ForceSaturated,
    );
}

#[test]
fn spindle_stop_holds_the_feed() {
    assert_fault_hold(SimForceFault::SpindleStop, case_a_job(), FaultCode::SpindleStopped);
}

#[test]
fn force_above_trip_holds_the_feed() {
    let job = ForceJobParams { trip_mn: 12_000_000, ..case_a_job() };
    assert_fault_hold(SimForceFault::None, job, FaultCode::ForceTrip);
}

proptest::proptest! {
    /// Whatever the host sends, the checks never panic, a job they accept is built (no later
    /// refusal on an interrupt-paced board), and a few thousand samples of it run without a
    /// panic or an override above 2.0.
    #[test]
    fn any_params_are_checked_without_panic(
        fnom in 0u32..20_000_000, contact_pct in 0u32..110, trip_extra in 0u32..20_000_000,
        kp in 0u32..(110 << 16), sample_hz in proptest::sample::select(vec![7u32, 5_000, 10_000, 50_000, 600_000]),
        flutes in 0u8..9, spindle in 0u32..20_000, channels in 1u8..4, gain in proptest::num::i32::ANY,
        tare_shift in 0u8..18, steps in 0u32..40_000, counts in 0u16..4096,
    ) {
        let mut p = case_a_job();
        p.fnom_mn = fnom;
        // Mostly ordered thresholds (so most cases get past the checks), sometimes not.
        p.contact_mn = ((fnom as u64 * contact_pct as u64) / 100) as u32;
        p.trip_mn = fnom.saturating_add(trip_extra);
        p.kp_dec_q16 = kp;
        p.sample_hz = sample_hz;
        p.flutes = flutes;
        p.spindle_mrev_s = spindle;
        p.channels = channels;
        p.cal[0].mn_per_count_q16 = gain;
        p.tare_shift = tare_shift;
        p.steps_per_s_at_one = steps;
        if check_job(&p).is_ok() {
            let mut j = ForceJob::new(&p, sc::TICK_HZ, false, None).unwrap();
            j.start(0);
            for i in 0..3_000u32 {
                let c = counts.wrapping_add((i % 7) as u16) & 0x0fff;
                let t = j.sample(&[c, 2048, 2048], i as i64);
                if let Some(r) = t.set_override {
                    proptest::prop_assert!(r.to_bits() <= MAX_OVERRIDE_BITS);
                }
            }
        }
    }
}

#[test]
fn the_encoder_speed_becomes_mrev_per_s_rounded_either_way_round() {
    // 360 rpm at a 50 kHz tick and 500 rpm at 100 kHz, as the spindle sources give them.
    for (rpm, tick_hz) in [(360.0f64, 50_000u32), (500.0, 100_000)] {
        let q32 = (rpm / 60.0 / tick_hz as f64 * 2f64.powi(32)).round() as i32;
        let want = (rpm / 60.0 * 1000.0).round() as u32;
        assert_eq!(mrev_s_from_turn_q32_per_tick(q32, tick_hz), want);
        assert_eq!(mrev_s_from_turn_q32_per_tick(-q32, tick_hz), want);
    }
    assert_eq!(mrev_s_from_turn_q32_per_tick(0, 50_000), 0);
    // Out-of-range inputs saturate instead of wrapping.
    assert_eq!(mrev_s_from_turn_q32_per_tick(i32::MIN, u32::MAX), u32::MAX);
}

#[test]
fn a_measured_spindle_stop_holds_the_feed_on_a_real_board_job() {
    // The real board's path: no simulated plant, samples from the ADC, the speed from the
    // spindle encoder. Air readings at the zero counts; the spindle stops after a while.
    let job = case_a_job();
    let mut fj = ForceJob::new(&job, sc::TICK_HZ, false, None).unwrap();
    fj.start(0);
    let zero = SIM_ZERO_COUNTS;
    let mut faults = 0;
    for n in 0..20_000u32 {
        let mrev_s = if n < 10_000 { job.spindle_mrev_s } else { 0 };
        fj.set_spindle_mrev_s(mrev_s);
        faults = fj.sample(&zero, 0).fault_bits;
        if faults != 0 {
            assert!(n >= 10_000, "a fault before the spindle stopped: {faults:#x} at {n}");
            break;
        }
    }
    assert_eq!(faults, FaultCode::SpindleStopped.bit());
}
