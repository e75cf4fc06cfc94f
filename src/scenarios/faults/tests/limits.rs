//! Limit switches: the stop past the switch, jogging off, chatter and the soft limits.

use super::*;

#[test]
fn limits_stop_one_debounce_past_the_switch() {
    // The switch closes on the step onto it; the machine believes it `debounce` ticks later
    // and stops at once: the axis, cruising at 12 kHz, goes on for debounce - 1 ticks.
    let d = debounce_ticks();
    assert_eq!(d, 100, "2 ms at 50 kHz");
    let feed_hz = TO_X_MIN[0].feed_hz as u64;
    let least = (d - 1) * feed_hz / TICK_HZ as u64;
    let most = ((d - 1) * feed_hz).div_ceil(TICK_HZ as u64);
    for (c, axis, at) in [
        (Case::LimitMin(0), 0, SWITCH_MIN),
        (Case::LimitMax(0), 0, SWITCH_MAX),
        (Case::LimitMin(1), 1, SWITCH_MIN),
        (Case::LimitMax(1), 1, SWITCH_MAX),
    ] {
        let r = run(c);
        let phys = r.figure(["phys0_steps", "phys1_steps"][axis]).unwrap();
        let over = (phys - at).unsigned_abs();
        assert!((least..=most).contains(&over), "{}: {over} steps past the switch", r.name);
        assert_eq!(r.figure(["pos0_steps", "pos1_steps"][axis]), Some(phys), "{}", r.name);
        assert_eq!(r.figure("clear_refused_nak"), Some(10), "{}", r.name);
    }
}

#[test]
fn without_a_debounce_limits_stop_on_the_switch() {
    for (c, axis, at) in [(Case::LimitMin(0), 0, SWITCH_MIN), (Case::LimitMax(1), 1, SWITCH_MAX)] {
        let mut s = FaultScenario::new(c).unwrap();
        let mut cfg = *s.machine.config();
        cfg.link.inputs.switch_debounce_us = 0;
        s.machine = Machine::new();
        s.machine.boot(Ok(cfg));
        let r = run_to_end(&mut s, MAX_TICKS + 1);
        assert_eq!(r.figure(["phys0_steps", "phys1_steps"][axis]), Some(at), "{}", r.name);
    }
}

#[test]
fn jog_off_a_limit_then_clear_keeps_the_position() {
    let r = run(Case::LimitJogOff);
    // ClearFault was refused while the switch was closed ...
    assert_eq!(r.figure("clear_refused_nak"), Some(10));
    assert_eq!(r.figure("jog_sent"), Some(1));
    assert_eq!(r.figure("refusal_nak"), Some(0), "JogOff and the second ClearFault accepted");
    // ... the jog stopped once the switch had stayed open for the debounce: after the
    // first step off it (min switch closed at <= -3000), at most debounce ticks at the jog
    // rate (an eighth of the max rate, still accelerating),
    let jog_hz = AXIS.max_rate_hz as u64 / crate::machine::jog_off::JOG_RATE_DIVISOR as u64;
    let past = r.figure("phys0_steps").unwrap() - (SWITCH_MIN + 1);
    let most = (debounce_ticks() * jog_hz).div_ceil(TICK_HZ as u64) as i64;
    assert!((0..=most).contains(&past), "{past} steps past the first step off the switch");
    assert_eq!(r.figure("pos0_steps"), r.figure("phys0_steps"), "position kept exactly");
    // ... and the machine is back in Ready with nothing latched, homing still trusted.
    assert_eq!(r.figure("fault_mask"), Some(0));
    assert_eq!(r.figure("cleared"), Some(FaultCode::LimitSwitch.code() as i64));
    assert_eq!(r.figure("homed"), Some(1));
}

#[test]
fn jog_off_is_refused_without_a_limit_fault() {
    // An e-stop fault: not a limit, nothing to jog off; the refusal changes nothing.
    let mut s = FaultScenario::new(Case::EStop).unwrap();
    let _ = run_to_end(&mut s, MAX_TICKS + 1);
    let before = (s.machine.state(), s.machine.faults().mask(), s.machine.positions());
    let r = s.machine.command(MachineCommand::JogOff, &mut s.dda);
    assert_eq!(r, Err(Refusal::NotOnLimit));
    assert_eq!((s.machine.state(), s.machine.faults().mask(), s.machine.positions()), before);
    assert!(!s.machine.is_jogging());
}

#[test]
fn soft_limits_at_queue_and_at_run_time() {
    let r = run(Case::SoftLimitQueue);
    assert_eq!(
        r.figure("refusal_nak"),
        Some(crate::protocol::ErrorCode::InvalidSegment.code() as i64)
    );
    assert_eq!(r.figure("fault_mask"), Some(0), "a refused segment latches nothing");
    assert_eq!(r.figure("pos0_steps"), Some(INSIDE[0].steps[0] as i64));
    let r = run(Case::SoftLimitRun);
    assert_eq!(r.figure("pos0_steps"), Some(SOFT_LIMIT + 1), "stopped on the first step outside");
}

#[test]
fn switch_chatter_shorter_than_the_debounce_is_not_a_limit() {
    let r = run(Case::LimitNoise);
    assert_eq!(r.fault, 0);
    assert_eq!(r.figure("state"), Some(MachineState::Ready as i64));
    assert_eq!(r.figure("phys0_steps"), Some(LONG_X[0].steps[0] as i64), "the whole move");
    // Raw, the same chatter trips the limit.
    let mut s = FaultScenario::new(Case::LimitNoise).unwrap();
    let mut cfg = *s.machine.config();
    cfg.link.inputs.switch_debounce_us = 0;
    s.machine = Machine::new();
    s.machine.boot(Ok(cfg));
    let r = run_to_end(&mut s, MAX_TICKS + 1);
    assert_eq!(r.fault, FaultCode::LimitSwitch.code());
}
