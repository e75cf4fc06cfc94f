//! The following-error monitor against the sim's lagging plant, with and without a jam.

use super::*;

#[test]
fn following_error_trips_after_the_jam_plus_limit_plus_debounce() {
    let r = run(Case::FollowingError);
    let f = |n: &str| r.figure(n).unwrap();
    // X jammed at INJECT_TICK: the plant stands where the steps put it PLANT_LAG_TICKS
    // earlier. The error passes the limit on the step that makes it limit + 1, and the
    // monitor trips FOLLOWING_DEBOUNCE_TICKS checks later (the last of them included).
    let jam = f("measured0_steps");
    assert!(jam > 0, "moving when the jam came");
    let stop = f("raw0_steps");
    // The trip is the debounce-th check over the limit, counting the first one.
    let over = f("over_tick");
    assert!(over > INJECT_TICK as i64);
    assert_eq!(f("fault_tick"), over + FOLLOWING_DEBOUNCE_TICKS as i64 - 1);
    // X steps at most once per 5 ticks (10 kHz feed, 50 kHz tick), so the debounce adds at
    // most ceil(8 / 5) = 2 steps past the first one over the limit.
    let past = stop - jam - (FOLLOWING_LIMIT_STEPS as i64 + 1);
    assert!((0..=2).contains(&past), "{past} steps past the first over the limit");
    assert_eq!(f("following_worst0_steps"), stop - jam);
    // Y's plant followed (lagging PLANT_LAG_TICKS) and is caught up at rest.
    assert_eq!(f("measured1_steps"), f("raw1_steps"));
    // Before the jam the lagging plant never came near the limit: nothing tripped early.
    assert_eq!(r.fault, FaultCode::FollowingError.code());
    assert_eq!(f("fault_mask"), FaultCode::FollowingError.bit() as i64);
    assert_eq!(f("steps_after_fault"), 0, "immediate stop");
}

/// Without a jam the same plant (lagging 16 ticks, limit 40) never trips, and ClearFault
/// after a trip loses the homing (Idle) and re-zeroes the monitor.
#[test]
fn following_plant_without_jam_never_trips_and_clear_loses_homing() {
    let cfg = config(Case::FollowingError);
    let mut m = Machine::new();
    m.boot(Ok(cfg));
    let mc = cfg.link.machine;
    let (mut dda, mut prep) = (Dda::new(&mc).unwrap(), Preparer::new(&mc).unwrap());
    m.command(MachineCommand::Home, &mut dda).unwrap();
    let mut net = [0i64; MAX_AXES];
    let mut ring = [[0i64; MAX_AXES]; PLANT_LAG_TICKS];
    let mut tick = |m: &mut Machine, dda: &mut Dda, prep: &mut Preparer, t: usize, jam: bool| {
        let out = m.tick(dda, &Inputs::QUIET);
        for a in 0..2 {
            if out.step.rise() & (1 << a) != 0 {
                net[a] += if out.step.dir() & (1 << a) != 0 { -1 } else { 1 };
            }
        }
        let lagged = ring[t % PLANT_LAG_TICKS];
        ring[t % PLANT_LAG_TICKS] = net;
        let mut meas = lagged;
        if jam {
            meas[0] = 0;
        }
        m.feedback(&meas);
        while m.wants_background() {
            m.background(dda, prep);
        }
    };
    for t in 0..10 {
        tick(&mut m, &mut dda, &mut prep, t, false);
    }
    assert_eq!(m.state(), MachineState::Ready);
    let mut p = Planner::new(&mc);
    let mut segs = std::collections::VecDeque::new();
    for mv in STREAM.iter().chain(LONG_X.iter()) {
        while p.push(mv).is_err() {
            segs.push_back(p.pop().unwrap());
        }
    }
    p.finish();
    while let Some(seg) = p.pop() {
        segs.push_back(seg);
    }
    for seg in &segs {
        m.command(MachineCommand::Queue(seg), &mut dda).unwrap();
    }
    m.command(MachineCommand::Start, &mut dda).unwrap();
    let mut t = 10;
    while m.state() == MachineState::Running && t < 200_000 {
        while dda.ready_free() > 0 {
            let Some(seg) = segs.pop_front() else { break };
            dda.push(&prep.prepare(&seg).unwrap()).unwrap();
        }
        tick(&mut m, &mut dda, &mut prep, t, false);
        t += 1;
    }
    assert_eq!(m.faults().mask(), 0, "a plant within the limit never trips");
    let worst = m.following_worst_steps();
    assert!(worst[0] > 0 && worst[0] <= FOLLOWING_LIMIT_STEPS, "worst {worst:?}");
    // Now jam X at 0 while the counters say it moved: trips at once (error >> limit),
    // after the debounce.
    for k in 0..FOLLOWING_DEBOUNCE_TICKS as usize {
        assert_eq!(m.faults().mask(), 0, "tripped before the debounce, check {k}");
        tick(&mut m, &mut dda, &mut prep, t + k, true);
    }
    assert_eq!(m.faults().first(), Some(FaultCode::FollowingError));
    assert!(m.is_homed(), "homing kept while latched (position kept)");
    assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));
    assert!(!m.is_homed());
    // Re-zeroed: the same standing error no longer counts.
    for k in 0..50 {
        tick(&mut m, &mut dda, &mut prep, t + 100 + k, true);
    }
    assert!(m.faults().is_clear());
}
