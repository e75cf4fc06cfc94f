//! Conditions the firmware used to panic on become faults: a stored tick rate the board's timer
//! cannot make, a segment the DDA refuses, a peripheral that refuses its setup, a panic before
//! the last reset. Each latches its own code with a stop, and clears as documented.

use motion::dda::Dda;
use motion::machine::{BoardConfig, BootConfig, Machine, MachineCommand, MachineState, Refusal};
use motion::protocol::{FaultCode, FixedStr, PANIC_FILE_LEN};
use motion::scenarios::faults::{config, Case};

#[test]
fn an_unsupported_stored_tick_rate_boots_on_safe_defaults_until_a_valid_config() {
    let good = config(Case::EStop);
    let mut m = Machine::new();
    let loaded = Err(BootConfig::UnsupportedTickRate { tick_hz: 123_457 });
    assert_eq!(m.boot(loaded), MachineState::Fault);
    assert_eq!(m.faults().mask(), FaultCode::TickRate.bit(), "exactly its own code");
    assert_eq!(*m.config(), BoardConfig::safe_default());
    assert_eq!(m.active_causes(), FaultCode::TickRate.bit(), "a level until a valid config");
    let mut dda = Dda::new(&m.config().link.machine).unwrap();
    assert_eq!(
        m.command(MachineCommand::ClearFault, &mut dda),
        Err(Refusal::CauseActive(FaultCode::TickRate))
    );
    assert!(m.command(MachineCommand::Home, &mut dda).is_err(), "no motion on the defaults");
    m.set_config(&good).unwrap();
    assert_eq!(m.active_causes(), 0);
    assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));
}

#[test]
fn board_faults_stop_the_machine_and_clear_at_once() {
    let cfg = config(Case::EStop);
    for code in [FaultCode::SegmentRejected, FaultCode::BoardSetup, FaultCode::Panicked] {
        let mut m = Machine::new();
        assert_eq!(m.boot(Ok(cfg)), MachineState::Idle);
        m.board_fault(code);
        assert_eq!(m.state(), MachineState::Fault, "{code:?}");
        assert_eq!(m.faults().first(), Some(code));
        assert!(!m.may_feed(), "{code:?}: nothing more is fed");
        let mut dda = Dda::new(&cfg.link.machine).unwrap();
        assert!(m.command(MachineCommand::Home, &mut dda).is_err(), "{code:?}: no motion");
        assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));
    }
}

#[test]
fn a_panic_site_keeps_the_tail_of_a_long_path() {
    let long = "/home/user/.cargo/registry/src/some-crate-1.2.3/src/deep/module/file.rs";
    let site = FixedStr::<PANIC_FILE_LEN>::tail(long);
    assert_eq!(site.len(), PANIC_FILE_LEN);
    assert!(long.ends_with(site.as_str()));
    assert!(site.ends_with("module/file.rs"));
    // A multi-byte character straddling the cut is dropped whole, never split.
    let s = format!("{}{}", "é".repeat(PANIC_FILE_LEN), "x");
    let t = FixedStr::<PANIC_FILE_LEN>::tail(&s);
    assert!(t.len() <= PANIC_FILE_LEN && s.ends_with(t.as_str()));
    assert_eq!(FixedStr::<PANIC_FILE_LEN>::tail("link.rs").as_str(), "link.rs");
}

/// A home position near i64's end would overflow the position sums (raw + offset): refused by
/// validation with the field and axis, at the limit accepted.
#[test]
fn a_home_position_beyond_2_pow_46_steps_is_refused() {
    use motion::machine::MAX_HOME_POS_STEPS;
    let mut cfg = config(Case::HomingOk);
    let a = cfg.home_order[0] as usize;
    for bad in [i64::MIN, i64::MAX, MAX_HOME_POS_STEPS + 1, -MAX_HOME_POS_STEPS - 1] {
        cfg.home[a].home_pos_steps = bad;
        let e = cfg.validate().expect_err("refused");
        assert_eq!((e.field, e.axis), ("home_pos_steps", Some(a as u8)), "{bad}");
    }
    for ok in [MAX_HOME_POS_STEPS, -MAX_HOME_POS_STEPS, 0] {
        cfg.home[a].home_pos_steps = ok;
        assert!(cfg.validate().is_ok(), "{ok}");
    }
}
