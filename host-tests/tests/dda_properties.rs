//! Property tests of the DDA: exact step totals, straight lines, step timing, override and hold,
//! and the driver timing every edge must honour.

use host_tests::{off_the_line, run_segments, Run};
use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::segment::{Rate, Segment};
use motion::Command;
use proptest::prelude::*;

const TICK_HZ: u32 = 100_000;

fn cfg(pulse_ns: u32, setup_ns: u32, hold_ns: u32) -> MachineConfig {
    MachineConfig {
        tick_hz: TICK_HZ,
        timing: StepTiming { pulse_ns, dir_setup_ns: setup_ns, dir_hold_ns: hold_ns },
        axis_count: MAX_AXES as u8,
        axes: [AxisLimits {
            max_rate_hz: TICK_HZ / (2 * pulse_ns.div_ceil(10_000).max(1)),
            accel_steps_per_s2: 1_000_000,
            junction_jerk_hz: 1_000,
        }; MAX_AXES],
    }
}

fn rate(x: f64) -> Rate {
    Rate::from_num(x)
}

/// A valid segment: each axis at most duration / spacing steps so the nominal rate is legal.
fn segment_strategy(spacing: u32) -> impl Strategy<Value = Segment> {
    // `still`: axes held at 0, so segments use the DDA's four-lane kernel as well as all six.
    let still = 0u8..(1 << MAX_AXES);
    (
        20u32..3_000,
        prop::array::uniform6(-1000i32..=1000),
        0.0f64..=1.0,
        0.0f64..=1.0,
        1u32..400,
        still,
    )
        .prop_map(move |(t, frac, entry, exit, accel, still)| {
            // 15/16 of one step per `spacing` ticks: the config's max_rate_hz is
            // tick_hz / spacing rounded down, which a segment at exactly that spacing can exceed.
            let max = (t / spacing) as i32 * 15 / 16;
            let mut steps = [0i32; MAX_AXES];
            for (i, (s, f)) in steps.iter_mut().zip(frac).enumerate() {
                *s = if still >> i & 1 != 0 { 0 } else { f * max / 1000 };
            }
            if steps.iter().all(|&s| s == 0) {
                steps[0] = max.max(1);
            }
            Segment {
                steps,
                duration_ticks: t,
                entry_rate: rate(entry),
                exit_rate: rate(exit),
                accel_per_tick: Rate::from_bits(accel * 1000),
                id: 0,
            }
        })
}

fn command_strategy() -> impl Strategy<Value = (u64, Command)> {
    (
        0u64..40_000,
        prop_oneof![
            (0.0f64..=2.0).prop_map(|r| Command::SetOverride(rate(r))),
            Just(Command::Hold),
            Just(Command::Resume),
        ],
    )
}

fn total(segs: &[Segment]) -> [i64; MAX_AXES] {
    let mut t = [0i64; MAX_AXES];
    for s in segs {
        for i in 0..MAX_AXES {
            t[i] += s.steps[i] as i64;
        }
    }
    t
}

fn abs_total(segs: &[Segment]) -> [u64; MAX_AXES] {
    let mut t = [0u64; MAX_AXES];
    for s in segs {
        for i in 0..MAX_AXES {
            t[i] += s.steps[i].unsigned_abs() as u64;
        }
    }
    t
}

fn assert_clean(run: &Run) {
    assert!(run.pins.violations.is_empty(), "pin timing: {:?}", run.pins.violations);
    assert_eq!(run.position_mismatches, 0, "positions() disagreed with the pins");
}

/// Ends every command script with resume at 100 % so the job can finish.
fn finishing(mut cmds: Vec<(u64, Command)>) -> Vec<(u64, Command)> {
    cmds.push((40_001, Command::Resume));
    cmds.push((40_001, Command::SetOverride(Rate::ONE)));
    cmds
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Random segments, overrides, holds and resumes: every commanded step comes out, exactly.
    #[test]
    fn totals_are_exact_under_override_and_hold(
        segs in prop::collection::vec(segment_strategy(2), 1..12),
        cmds in prop::collection::vec(command_strategy(), 0..10),
    ) {
        let run = run_segments(&cfg(2_500, 5_000, 5_000), &segs, &finishing(cmds), 5_000_000);
        prop_assert!(run.dda.is_idle(), "did not finish in {} ticks", run.ticks);
        prop_assert_eq!(run.rec.net, total(&segs));
        prop_assert_eq!(run.rec.steps, abs_total(&segs));
        prop_assert_eq!(run.dda.positions(), total(&segs));
        assert_clean(&run);
    }

    /// Longer pulses and DIR times than a tick: still exact, still honoured.
    #[test]
    fn slow_driver_timing_is_honoured(
        segs in prop::collection::vec(segment_strategy(14), 1..8),
        pulse_ticks in 1u32..=7,
        setup in 0u32..=60_000,
        hold in 0u32..=60_000,
    ) {
        let c = cfg(pulse_ticks * 10_000, setup, hold);
        let run = run_segments(&c, &segs, &[], 5_000_000);
        prop_assert!(run.dda.is_idle());
        prop_assert_eq!(run.rec.net, total(&segs));
        assert_clean(&run);
    }

    /// Every step of a straight line lies within half a step (per axis) of the ideal line: some
    /// point k/T of the segment is within 0.5 step of the position on every axis at once.
    #[test]
    fn steps_stay_within_half_a_step_of_the_line(seg in segment_strategy(2), ovr in 0.1f64..=2.0) {
        let run = run_segments(&cfg(2_500, 0, 0), &[seg], &[(0, Command::SetOverride(rate(ovr)))], 5_000_000);
        prop_assert_eq!(off_the_line(&seg, &run.edges), None);
    }

    /// At constant feed (rate exactly 1.0) each step's tick is within one tick of its ideal time.
    #[test]
    fn constant_feed_steps_are_within_one_tick(
        d in prop::array::uniform6(0i32..=1500),
        t in 3_000u32..6_000,
    ) {
        // Segment A accelerates to full feed and hands over at 1.0; B runs at 1.0 throughout.
        let mut steps = d;
        steps[0] = steps[0].max(1);
        let a = Segment { steps, duration_ticks: t, entry_rate: Rate::ZERO, exit_rate: Rate::ONE,
            accel_per_tick: Rate::from_bits(1 << 20), id: 0 };
        let b = Segment { entry_rate: Rate::ONE, exit_rate: Rate::ONE, id: 1, ..a };
        let c = Segment { entry_rate: Rate::ONE, exit_rate: Rate::ZERO, id: 2, ..a };
        let run = run_segments(&cfg(2_500, 0, 0), &[a, b, c], &[], 1_000_000);
        let (a_end, b_end) = (run.segment_ends[0], run.segment_ends[1]);
        prop_assert_eq!(b_end - a_end, t as u64, "B must take exactly T ticks at rate 1.0");
        for i in 0..MAX_AXES {
            let di = steps[i] as f64;
            if di == 0.0 {
                continue;
            }
            let b_steps: Vec<u64> = run.edges.iter()
                .filter(|e| e.0 > a_end && e.0 <= b_end && e.1 & (1 << i) != 0)
                .map(|e| e.0).collect();
            prop_assert_eq!(b_steps.len() as i32, steps[i]);
            for (j, &tick) in b_steps.iter().enumerate() {
                // Ideal: the line reaches step j + 1/2 ... the half-way point between positions.
                let ideal = a_end as f64 + (j as f64 + 0.5) * t as f64 / di;
                prop_assert!((tick as f64 - ideal).abs() <= 1.0,
                    "axis {} step {} at tick {} ideal {:.2}", i, j, tick, ideal);
            }
        }
    }
}

/// The fast runs (cruise and ramps) and the full tick produce the same pins, tick for tick, through ramps,
/// junctions, overrides, holds, commands scheduled ahead and commands applied between ticks.
#[test]
fn cruise_fast_path_equals_the_full_tick() {
    use proptest::test_runner::{Config, TestRunner};
    let strategy = (
        prop::collection::vec(segment_strategy(2), 1..10),
        prop::collection::vec(command_strategy(), 0..8),
        prop::collection::vec(command_strategy(), 0..4),
    );
    let mut runner = TestRunner::new(Config { cases: 96, ..Config::default() });
    let cases_cruising = std::cell::Cell::new(0u32);
    // Cases in which each kind of run (cruise, accelerate, track) ran.
    let cases_by_kind = std::cell::Cell::new([0u32; 3]);
    runner
        .run(&strategy, |(segs, cmds, immediate)| {
            let c = cfg(2_500, 5_000, 5_000);
            let mut fast = motion::Dda::new(&c).unwrap();
            let mut full = motion::Dda::new(&c).unwrap();
            full.disable_cruise_path();
            let mut pf = motion::dda::Preparer::new(&c).unwrap();
            let mut pu = motion::dda::Preparer::new(&c).unwrap();
            for &(at, cmd) in finishing(cmds).iter() {
                fast.schedule(at, cmd).ok();
                full.schedule(at, cmd).ok();
            }
            let mut next = 0;
            let mut cruising = 0u64;
            let mut kinds = [false; 3];
            while fast.now() < 3_000_000 {
                while next < segs.len() && fast.ready_free() > 0 {
                    fast.push(&pf.prepare(&segs[next]).unwrap()).unwrap();
                    full.push(&pu.prepare(&segs[next]).unwrap()).unwrap();
                    next += 1;
                }
                for &(at, cmd) in &immediate {
                    if at == fast.now() {
                        fast.apply(cmd);
                        full.apply(cmd);
                    }
                }
                if next == segs.len() && fast.is_idle() && fast.now() > 40_001 {
                    break;
                }
                let (a, b) = (fast.tick(), full.tick());
                prop_assert_eq!(a, b, "tick {}", fast.now());
                prop_assert_eq!(fast.now(), full.now());
                prop_assert_eq!(fast.rate(), full.rate());
                // Mid-cruise reads: `now`, `remaining` and the budget are derived there.
                if fast.now().is_multiple_of(97) {
                    prop_assert_eq!(fast.positions(), full.positions(), "tick {}", fast.now());
                    prop_assert_eq!(fast.stop_due(10), full.stop_due(10));
                }
                prop_assert!(!full.in_cruise());
                cruising += fast.in_cruise() as u64;
                if let Some(kind) = fast.fast_run() {
                    kinds[kind as usize] = true;
                }
            }
            prop_assert_eq!(fast.positions(), full.positions());
            prop_assert!(fast.is_idle() && full.is_idle());
            if cruising > 0 {
                cases_cruising.set(cases_cruising.get() + 1);
            }
            let mut by_kind = cases_by_kind.get();
            for (n, ran) in by_kind.iter_mut().zip(kinds) {
                *n += ran as u32;
            }
            cases_by_kind.set(by_kind);
            Ok(())
        })
        .unwrap();
    // About a third of these random jobs settle somewhere; the comparison must cover those.
    assert!(cases_cruising.get() >= 24, "fast path ran in only {} cases", cases_cruising.get());
    // Ramps are most of a short segment's ticks: both kinds must be covered as well.
    let [_, up, track] = cases_by_kind.get();
    assert!(up >= 24 && track >= 24, "accelerating runs in {up} cases, tracking in {track}");
}

/// Ticks a buffer at a time (`Dda::ticks_into`, a streamed output's fill) give the same pins as
/// one tick at a time, whatever the buffers' lengths and wherever they start in a run.
#[test]
fn ticks_into_a_buffer_equal_one_tick_at_a_time() {
    use motion::dda::{FastRun, StepOutput};
    use proptest::test_runner::{Config, TestRunner};
    const LONGEST: usize = 48;
    let strategy = (
        prop::collection::vec(segment_strategy(2), 1..10),
        prop::collection::vec(command_strategy(), 0..8),
        prop::collection::vec(1..=LONGEST, 1..12),
    );
    let mut runner = TestRunner::new(Config { cases: 96, ..Config::default() });
    // Cases in which each kind of run (cruise, accelerate, track) ran inside a buffer.
    let cases_by_kind = std::cell::Cell::new([0u32; 3]);
    runner
        .run(&strategy, |(segs, cmds, lengths)| {
            let c = cfg(2_500, 5_000, 5_000);
            let mut many = motion::Dda::new(&c).unwrap();
            let mut one = motion::Dda::new(&c).unwrap();
            let mut pm = motion::dda::Preparer::new(&c).unwrap();
            let mut po = motion::dda::Preparer::new(&c).unwrap();
            for &(at, cmd) in finishing(cmds).iter() {
                many.schedule(at, cmd).ok();
                one.schedule(at, cmd).ok();
            }
            let mut buf = [StepOutput::new(0, 0, 0, 0); LONGEST];
            let mut next = 0;
            let mut kinds = [false; 3];
            for &len in lengths.iter().cycle() {
                // Segments go in between buffers, to both alike.
                while next < segs.len() && one.ready_free() > 0 {
                    many.push(&pm.prepare(&segs[next]).unwrap()).unwrap();
                    one.push(&po.prepare(&segs[next]).unwrap()).unwrap();
                    next += 1;
                }
                if (next == segs.len() && one.is_idle() && one.now() > 40_001)
                    || one.now() >= 3_000_000
                {
                    break;
                }
                if let Some(kind) = many.fast_run() {
                    kinds[kind as usize] |= len > 1;
                }
                many.ticks_into(&mut buf[..len], &mut |w: &mut StepOutput, s| *w = s);
                for got in &buf[..len] {
                    let want = one.tick();
                    prop_assert_eq!(*got, want, "tick {}", one.now());
                }
                prop_assert_eq!(many.now(), one.now());
                prop_assert_eq!(many.rate(), one.rate());
                prop_assert_eq!(many.fast_run(), one.fast_run());
                prop_assert_eq!(many.positions(), one.positions(), "tick {}", one.now());
            }
            prop_assert!(many.is_idle());
            let mut by_kind = cases_by_kind.get();
            for (n, ran) in by_kind.iter_mut().zip(kinds) {
                *n += ran as u32;
            }
            cases_by_kind.set(by_kind);
            Ok(())
        })
        .unwrap();
    let [cruise, up, track] = cases_by_kind.get();
    assert_eq!([FastRun::Cruise as usize, FastRun::Accelerate as usize], [0, 1]);
    assert!(
        cruise >= 24 && up >= 24 && track >= 24,
        "buffers began in a cruise in {cruise} cases, a climb in {up}, tracking in {track}"
    );
}

#[test]
fn hold_stops_on_the_path_and_resumes_from_the_exact_position() {
    let seg = Segment {
        steps: [20_000, -15_000, 5_000, 0, 0, 0],
        duration_ticks: 60_000,
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ZERO,
        accel_per_tick: Rate::from_bits(1 << 17),
        id: 7,
    };
    let cmds = [(20_000, Command::Hold), (40_000, Command::Resume)];
    let run = run_segments(&cfg(2_500, 5_000, 5_000), &[seg], &cmds, 1_000_000);
    assert_eq!(run.rec.net, total(&[seg]));
    assert_clean(&run);
    // Stopped well before the resume, and never moved while held.
    let held: Vec<_> = run.edges.iter().filter(|e| e.0 > 30_000 && e.0 <= 40_000).collect();
    assert!(held.is_empty(), "steps while held: {held:?}");
    // Decelerated rather than stopping dead: step intervals grow before the stop.
    let x: Vec<u64> = run
        .edges
        .iter()
        .filter(|e| e.0 > 15_000 && e.0 <= 30_000 && e.1 & 1 != 0)
        .map(|e| e.0)
        .collect();
    let gaps: Vec<u64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(gaps.len() > 10 && gaps.last() > gaps.first(), "no deceleration: {gaps:?}");
    // The same job without the hold ends in the same place.
    let plain = run_segments(&cfg(2_500, 5_000, 5_000), &[seg], &[], 1_000_000);
    assert_eq!(plain.dda.positions(), run.dda.positions());
    assert!(run.ticks > plain.ticks + 15_000);
}

#[test]
fn override_takes_effect_on_the_next_tick() {
    let seg = Segment {
        steps: [4_000, 0, 0, 0, 0, 0],
        duration_ticks: 40_000,
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ZERO,
        accel_per_tick: Rate::from_bits(1 << 16),
        id: 0,
    };
    let mut dda = motion::Dda::new(&cfg(2_500, 0, 0)).unwrap();
    let mut prep = motion::dda::Preparer::new(&cfg(2_500, 0, 0)).unwrap();
    dda.push(&prep.prepare(&seg).unwrap()).unwrap();
    while dda.rate() < Rate::ONE {
        dda.tick();
    }
    dda.apply(Command::SetOverride(rate(0.5)));
    let before = dda.rate();
    dda.tick();
    assert!(dda.rate() < before, "rate must start falling on the next tick");
    // It ramps down at the segment's acceleration (2^16 / 2^30 per tick), then settles.
    for _ in 0..(1 << 13) + 1 {
        dda.tick();
    }
    assert_eq!(dda.rate(), rate(0.5));
    dda.apply(Command::SetOverride(Rate::ZERO));
    for _ in 0..(1 << 13) + 1 {
        dda.tick();
    }
    assert_eq!(dda.rate(), Rate::ZERO);
    let parked = dda.positions();
    for _ in 0..1000 {
        dda.tick();
    }
    assert_eq!(dda.positions(), parked, "override 0 parks the axis");
    assert_eq!(dda.state(), motion::dda::MotionState::Moving);
}

/// Direction reversals with slow drivers: the DDA delays the first step rather than violate the
/// driver's DIR timing, and releases every held-back step.
#[test]
fn reversal_with_long_dir_times_defers_and_keeps_every_step() {
    let c = cfg(20_000, 65_000, 65_000);
    let fwd = Segment {
        steps: [2, 0, 0, 0, 0, 0],
        duration_ticks: 9,
        entry_rate: Rate::ONE,
        exit_rate: Rate::ONE,
        accel_per_tick: Rate::ONE,
        id: 0,
    };
    let back = Segment { steps: [-2, 0, 0, 0, 0, 0], ..fwd };
    let segs = [fwd, back, fwd, back, fwd];
    let run = run_segments(&c, &segs, &[], 100_000);
    assert!(run.dda.is_idle());
    assert_eq!(run.rec.net, total(&segs));
    assert_eq!(run.rec.steps[0], 10);
    assert_clean(&run);
}

/// Three segments of ~6e7 steps on each of six axes: 1.08e9 steps, not one gained or lost.
#[test]
fn no_drift_over_a_billion_steps() {
    let c = cfg(2_500, 0, 0);
    let t = 120_000_000u32;
    let mut segs = Vec::new();
    for k in 0..3 {
        let sign = if k % 2 == 0 { 1 } else { -1 };
        let mut steps = [0i32; MAX_AXES];
        for (i, s) in steps.iter_mut().enumerate() {
            *s = sign * (t / 2 - 1_000 * i as u32) as i32 * if i % 2 == 0 { 1 } else { -1 };
        }
        segs.push(Segment {
            steps,
            duration_ticks: t,
            entry_rate: Rate::ONE,
            exit_rate: Rate::ONE,
            accel_per_tick: Rate::ONE,
            id: k,
        });
    }
    let mut dda = motion::Dda::new(&c).unwrap();
    let mut prep = motion::dda::Preparer::new(&c).unwrap();
    let mut net = [0i64; MAX_AXES];
    let mut next = 0;
    loop {
        while next < segs.len() && dda.ready_free() > 0 {
            dda.push(&prep.prepare(&segs[next]).unwrap()).unwrap();
            next += 1;
        }
        if next == segs.len() && dda.is_idle() {
            break;
        }
        let out = dda.tick();
        if out.rise() != 0 {
            for (i, n) in net.iter_mut().enumerate() {
                if out.rise() & (1 << i) != 0 {
                    *n += if out.dir() & (1 << i) != 0 { -1 } else { 1 };
                }
            }
        }
    }
    let expect = total(&segs);
    let stepped: u64 = abs_total(&segs).iter().sum();
    assert!(stepped > 1_000_000_000);
    assert_eq!(net, expect);
    assert_eq!(dda.positions(), expect);
}

/// A starved job's last segment (exit rate > 0, nothing behind it): `stop_due` says when a hold
/// must start for the ramp to end inside the segment. Held from that moment it stops on the
/// path; run on instead, the DDA reaches the end at speed and underruns (so the check can fail).
/// With and without the cruise fast path, which keeps the budget stale until it leaves.
#[test]
fn stop_due_leaves_room_to_ramp_down_inside_the_last_segment() {
    let c = cfg(2_500, 0, 0);
    for cruise in [true, false] {
        for (len, exit) in [(20_000, 0.6), (4_000, 0.3), (60_000, 0.9)] {
            let seg = Segment {
                steps: [len, len / 3, 0, 0, 0, 0],
                duration_ticks: len as u32 * 2,
                entry_rate: Rate::ZERO,
                exit_rate: rate(exit),
                accel_per_tick: Rate::from_bits(1 << 16),
                id: 1,
            };
            let run = |hold: bool| {
                let mut dda = motion::Dda::new(&c).unwrap();
                if !cruise {
                    dda.disable_cruise_path();
                }
                let mut prep = motion::dda::Preparer::new(&c).unwrap();
                dda.push(&prep.prepare(&seg).unwrap()).unwrap();
                let mut held_at = None;
                for t in 0..10 * seg.duration_ticks as u64 {
                    if hold && held_at.is_none() && dda.stop_due(64) {
                        dda.apply(Command::Hold);
                        held_at = Some(t);
                    }
                    dda.tick();
                    if dda.is_idle() || dda.state() == motion::dda::MotionState::Held {
                        break;
                    }
                }
                (dda.segments_done(), dda.underruns(), held_at, dda.state())
            };
            let (done, underruns, held_at, state) = run(true);
            let why = format!("cruise {cruise}, {len} steps, exit {exit}");
            assert!(held_at.is_some(), "{why}: stop_due never fired");
            assert_eq!((done, underruns), (0, 0), "{why}: the hold ended inside the segment");
            assert_eq!(state, motion::dda::MotionState::Held, "{why}");
            let (done, underruns, _, _) = run(false);
            assert_eq!((done, underruns), (1, 1), "{why}: unheld, it ends at speed and underruns");
        }
    }
}
