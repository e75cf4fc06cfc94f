//! Homing: the Cartesian board's and the polar machine's origins land on their switches.

use super::*;

#[test]
fn homing_puts_the_origin_on_the_switches() {
    let r = run(Case::HomingOk);
    assert_eq!(r.figure("homed"), Some(1));
    // Machine position equals the sim's physical position: the origin is exact.
    assert_eq!(r.figure("pos0_steps"), r.figure("phys0_steps"));
    assert_eq!(r.figure("pos1_steps"), r.figure("phys1_steps"));
    // Pulled off by the backoff: 200 steps inside each switch.
    assert_eq!(r.figure("pos0_steps"), Some(SWITCH_MIN + 200));
    assert_eq!(r.figure("pos1_steps"), Some(SWITCH_MAX - 200));
    let r = run(Case::HomingNotFound);
    assert_eq!(r.figure("net0_steps"), Some(-500), "stopped after max_travel");
    assert_eq!(r.figure("homed"), Some(0));
}

#[test]
fn polar_homing_puts_both_origins_on_their_switches() {
    let r = run(Case::HomingPolar);
    let f = |n: &str| r.figure(n).unwrap();
    assert_eq!(f("homed"), 1);
    assert_eq!(f("fault_mask"), 0);
    let h = crate::polar::job::homing_config();
    for (a, start) in [(0usize, POLAR_START_THETA_STEPS), (1, POLAR_START_R_STEPS)] {
        let (pos, phys) = (["pos0_steps", "pos1_steps"][a], ["phys0_steps", "phys1_steps"][a]);
        // The origin is the switch point (theta: the end-stop, r: minimum radius), where
        // the documented home position says: machine position = sim position from there.
        assert_eq!(f(pos), f(phys) + h.axes[a].home_pos_steps, "axis {a}");
        // Pulled off the switch by the back-off.
        assert_eq!(f(pos), h.axes[a].home_pos_steps + h.axes[a].backoff_steps as i64);
        // Net travel: from the start down to the switch, then the back-off out again.
        let net = f(["net0_steps", "net1_steps"][a]);
        assert_eq!(net, -start + h.axes[a].backoff_steps as i64, "axis {a}");
    }
    assert!(r.ticks < MAX_TICKS);
}
