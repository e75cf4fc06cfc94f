use super::*;
use crate::dda::MotionState;
use crate::trace::StepRecorder;
use crate::wire::job::seg;
use crate::wire::machine;

const ONE: u32 = 1 << 30;

/// Six 4-axis segments, 2000 ticks each, meeting at full speed.
fn job() -> [JobSegment; 6] {
    // Full speed to rest in 400 ticks.
    let a = ONE / 400;
    [
        seg(400, 100, 20, -50, 2000, 0, ONE, a),
        seg(400, 200, 10, -50, 2000, ONE, ONE, a),
        seg(300, 300, 0, -50, 2000, ONE, ONE, a),
        seg(200, 400, -10, -50, 2000, ONE, ONE, a),
        seg(100, 400, -20, -50, 2000, ONE, ONE, a),
        seg(0, 400, -30, -50, 2000, ONE, 0, a),
    ]
}

fn params() -> StallParams {
    StallParams {
        debounce_ticks: 5,
        retrace_limit_steps: 100_000,
        retrace_override: Rate::ONE,
        resume_override: Rate::lit("0.5"),
        resume_segments: 2,
    }
}

struct Outcome {
    phase: Phase,
    positions: [i64; 4],
    net: [i64; 4],
    stats: StallStats,
    /// Wire power seen while the debounced stall was asserted / while retracing.
    power_while_retracing: bool,
    min_x_after_stall: i64,
    ticks: u64,
}

fn run(
    job: &[JobSegment],
    p: StallParams,
    stall: impl Fn(u64) -> bool,
    estop: impl Fn(u64) -> bool,
) -> Outcome {
    let mut c = WireController::new(&machine::config(), job, p).unwrap();
    let mut rec = StepRecorder::new();
    let mut power_while_retracing = false;
    let mut min_x_after_stall = i64::MAX;
    let mut n = 0u64;
    while !c.is_finished() && n < 1_000_000 {
        c.feed().unwrap();
        let out = c.tick(stall(n), estop(n));
        n += 1;
        rec.record(c.dda().now(), &out);
        if matches!(c.phase(), Phase::Retracing | Phase::RetraceStopping) {
            power_while_retracing |= c.wire_power();
        }
        if c.stats().stalls > 0 && out.rise() & 1 != 0 {
            min_x_after_stall = min_x_after_stall.min(c.dda().positions()[0]);
        }
    }
    let p = c.dda().positions();
    Outcome {
        phase: c.phase(),
        positions: [p[0], p[1], p[2], p[3]],
        net: [rec.net[0], rec.net[1], rec.net[2], rec.net[3]],
        stats: c.stats(),
        power_while_retracing,
        min_x_after_stall,
        ticks: n,
    }
}

fn end(job: &[JobSegment]) -> [i64; 4] {
    crate::wire::job::total_steps(job)
}

#[test]
fn runs_the_job_without_stall() {
    let j = job();
    let o = run(&j, params(), |_| false, |_| false);
    assert_eq!(o.phase, Phase::Done);
    assert_eq!(o.positions, end(&j));
    assert_eq!(o.net, o.positions);
    assert_eq!(o.stats.stalls, 0);
}

#[test]
fn stall_retraces_backwards_then_finishes_exactly() {
    let j = job();
    // Stalled for 3000 ticks from the middle of segment 2.
    let o = run(&j, params(), |t| (5000..8000).contains(&t), |_| false);
    assert_eq!(o.phase, Phase::Done);
    assert_eq!(o.positions, end(&j));
    assert_eq!(o.net, o.positions, "steps on the pins == DDA positions");
    assert_eq!(o.stats.stalls, 1);
    assert!(o.stats.retrace_segments >= 2, "{:?}", o.stats);
    assert!(o.stats.return_segments >= 2, "{:?}", o.stats);
    assert!(!o.power_while_retracing);
    // X went back below where it was at the stall (~1000 steps into the job).
    assert!(o.min_x_after_stall < 800, "{}", o.min_x_after_stall);
    // The whole job at nominal speed is 12 000 ticks; the stall costs time.
    assert!(o.ticks > 12_000 + 3_000);
}

#[test]
fn debouncer_ignores_short_glitches() {
    let j = job();
    let o = run(&j, params(), |t| t % 1000 < 3, |_| false);
    assert_eq!(o.phase, Phase::Done);
    assert_eq!(o.stats.stalls, 0);
}

#[test]
fn stall_clearing_mid_retrace_returns_from_there() {
    let j = job();
    // Stall late in segment 4; it clears 1500 ticks later, in the middle of retracing.
    let o = run(&j, params(), |t| (9000..10_500).contains(&t), |_| false);
    assert_eq!(o.phase, Phase::Done);
    assert_eq!(o.stats.retrace_interrupts, 1, "{:?}", o.stats);
    assert_eq!(o.positions, end(&j));
    assert_eq!(o.net, o.positions);
    assert_eq!(o.stats.stalls, 1);
}

#[test]
fn repeated_stalls_lose_no_steps() {
    let j = job();
    let o = run(
        &j,
        params(),
        |t| (2500..3500).contains(&t) || (9000..9500).contains(&t) || (14_000..16_000).contains(&t),
        |_| false,
    );
    assert_eq!(o.phase, Phase::Done);
    assert_eq!(o.positions, end(&j));
    assert_eq!(o.net, o.positions);
    assert!(o.stats.stalls >= 2, "{:?}", o.stats);
}

#[test]
fn permanent_stall_faults_at_the_limit() {
    let j = job();
    let p = StallParams { retrace_limit_steps: 1_000, ..params() };
    let o = run(&j, p, |t| t >= 7000, |_| false);
    assert_eq!(o.phase, Phase::Faulted(FaultCode::WireStall));
    assert!(o.stats.max_retrace_steps <= 1_000);
    assert_eq!(o.net, o.positions);
    // Without a limit it runs out of history (back at the start) and faults the same way.
    let p = StallParams { retrace_limit_steps: u64::MAX, ..params() };
    let o = run(&j, p, |t| t >= 7000, |_| false);
    assert_eq!(o.phase, Phase::Faulted(FaultCode::WireStall));
    assert_eq!(o.positions, [0; 4]);
}

/// After a stall the job resumes at the scenarios' `resume_override` (0.5) for
/// `resume_segments` (2) job segments, then at 1.0: the DDA's override is 0.5 through the
/// return and the first two job segments after it, 1.0 from the completion of the second
/// on; the first of them takes about twice its nominal 2000 ticks, the third its nominal.
#[test]
fn resumes_at_reduced_feed_for_two_segments() {
    use crate::wire::scenario::STALL_PARAMS;
    let j = job();
    // Retrace distinct from the resume override, so the three phases can be told apart.
    let p = StallParams { retrace_override: Rate::lit("0.75"), ..STALL_PARAMS };
    let mut c = WireController::new(&machine::config(), &j, p).unwrap();
    let half = STALL_PARAMS.resume_override;
    assert_eq!(half, Rate::lit("0.5"));
    assert_eq!(STALL_PARAMS.resume_segments, 2);
    // (job segment index, completion tick) after the return, and the override seen while
    // each job segment after the return was running.
    let mut done_after: Vec<(u32, u64)> = Vec::new();
    let mut seen = [None::<Rate>; 6];
    let (mut last_done, mut returned, mut n) = (0u32, false, 0u64);
    let (mut saw_retrace, mut saw_return) = (false, false);
    while !c.is_finished() && n < 1_000_000 {
        c.feed().unwrap();
        c.tick((5000..6000).contains(&n), false);
        n += 1;
        let ovr = c.dda().feed_override();
        match c.phase() {
            Phase::Retracing => {
                saw_retrace = true;
                assert_eq!(ovr, p.retrace_override, "retracing, tick {n}");
            }
            Phase::Returning => {
                saw_return = true;
                returned = true;
                assert_eq!(ovr, half, "returning, tick {n}");
            }
            _ => {}
        }
        if c.dda().segments_done() != last_done {
            last_done = c.dda().segments_done();
            let id = c.dda().last_done_id().unwrap();
            if returned && id & RECOVERY_ID == 0 {
                done_after.push((id, n));
            }
        }
        // The job segment in progress after the return: the override it runs at (the
        // change lands at a completion, so sample mid-way through the segment).
        if returned && c.phase() == Phase::Running && c.dda().state() == MotionState::Moving {
            let k = done_after.len();
            let since = done_after.last().map_or(c.stats().first_resume_tick, |d| d.1);
            if n == since + 500 && k < seen.len() {
                seen[k] = Some(ovr);
            }
        }
    }
    assert_eq!(c.phase(), Phase::Done);
    assert!(saw_retrace && saw_return);
    assert_eq!(c.stats().stalls, 1);
    assert_eq!(c.dda().feed_override(), Rate::ONE, "back to 1.0 at the end");
    // Stalled in segment 2: segments 3, 4, 5 run after the return.
    let ids: Vec<u32> = done_after.iter().map(|d| d.0).collect();
    assert_eq!(ids, [3, 4, 5], "{done_after:?}");
    assert_eq!(seen[..3], [Some(half), Some(half), Some(Rate::ONE)], "{seen:?}");
    // Durations: segment 4 (between two reduced-feed completions) runs at half speed, segment
    // 5 at full speed to rest (2000 ticks plus its ramp down).
    let d4 = done_after[1].1 - done_after[0].1;
    let d5 = done_after[2].1 - done_after[1].1;
    std::eprintln!("after the return: {done_after:?}; segment 4 {d4} ticks, 5 {d5} ticks");
    assert!((3_800..=4_200).contains(&d4), "segment 4 took {d4} ticks at 0.5");
    assert!((2_000..=2_600).contains(&d5), "segment 5 took {d5} ticks at 1.0");
}

#[test]
fn estop_cuts_wire_power_at_once() {
    let j = job();
    let mut c = WireController::new(&machine::config(), &j, params()).unwrap();
    for n in 0..4000 {
        c.feed().unwrap();
        c.tick(false, false);
        assert!(c.wire_power(), "tick {n}");
    }
    c.tick(false, true);
    assert!(!c.wire_power());
    assert_eq!(c.fault_code(), Some(FaultCode::EStop));
    assert!(c.dda().is_idle());
}
