//! Machine safety: one state machine and one fault model for every capability.
//!
//! * [`state`]: the states, the commands and the one table of which command each state accepts
//!   (rendered as Markdown and a Mermaid diagram for the docs: [`markdown`]).
//! * [`faults`]: the fault latch and the reaction per fault class.
//! * [`machine`]: [`Machine`], which the tick and control tasks drive.
//! * [`homing`], [`limits`], [`outputs`]: homing sequencer, soft limits, safe outputs.
//! * [`debounce`]: limit switches, e-stop and probe filtered before the machine acts on them.
//! * [`probe`]: probe moves (G38.x): the trip, the latched position, the probe faults.
//! * [`following`]: the following-error monitor (commanded vs measured, axes with feedback).
//! * [`watchdog`]: watchdog feeding gate and tick-overrun detector.
//! * [`reset_cause`]: why the MCU reset (RCC_CSR), so a watchdog reset boots into a fault.
//! * [`persist`]: the config record in NOR flash (version, CRC, two slots), and [`ram_flash`],
//!   a RAM NOR-flash with real NOR rules for tests and the QEMU scenarios.

pub mod config;
pub mod debounce;
pub mod faults;
pub mod following;
pub mod homing;
pub mod jog_off;
pub mod limits;
#[allow(clippy::module_inception)]
pub mod machine;
pub mod outputs;
pub mod persist;
pub mod probe;
pub mod ram_flash;
pub mod reset_cause;
pub mod state;
pub mod watchdog;

pub use config::{BoardConfig, HomeAxis, MAX_HOME_POS_STEPS};
pub use debounce::SwitchFilter;
pub use faults::{reaction, FaultLatch, Reaction};
pub use following::{FollowingConfig, FollowingMonitor};
pub use machine::{
    BootConfig, DdaSource, Inputs, Machine, MachineCommand, Refusal, SourceJob, StepSource,
    TickOut, STREAM_SAMPLE_STRIDE,
};
pub use outputs::{Outputs, Z_DAC_MID_SCALE};
pub use probe::{ProbeKind, ProbePhase, ProbeRun};
pub use reset_cause::ResetCause;
pub use state::{cell, Cell, CommandKind, MachineState};
pub use watchdog::{OverrunDetector, WatchdogGate};

/// The machine documentation, generated: the command table, the state diagram (Mermaid) and the
/// fault reactions. `src/machine/MACHINE.md` holds this text; a test keeps them equal.
pub fn markdown(out: &mut impl core::fmt::Write) -> core::fmt::Result {
    out.write_str("### Commands by state\n\n")?;
    state::markdown_table(out)?;
    out.write_str("\n### State diagram\n\n```mermaid\n")?;
    state::mermaid_diagram(out)?;
    out.write_str("```\n\n### Faults and reactions\n\n")?;
    faults::markdown_reactions(out)
}

/// Test rig: a machine booted with `cfg` (no homing switches), homed to `Ready`, with its DDA
/// and preparer; the setup every job's host tests start from.
#[cfg(test)]
pub(crate) fn homed(cfg: BoardConfig) -> (Machine, crate::dda::Dda, crate::dda::Preparer) {
    cfg.validate().unwrap();
    let mut m = Machine::new();
    m.boot(Ok(cfg));
    let mut dda = crate::dda::Dda::new(&cfg.link.machine).unwrap();
    let mut prep = crate::dda::Preparer::new(&cfg.link.machine).unwrap();
    m.command(MachineCommand::Home, &mut dda).unwrap();
    for _ in 0..10 {
        m.tick(&mut dda, &Inputs::QUIET);
        if m.wants_background() {
            m.background(&mut dda, &mut prep);
        }
    }
    assert_eq!(m.state(), MachineState::Ready);
    (m, dda, prep)
}

#[cfg(test)]
mod tests {
    #[test]
    fn machine_doc_has_the_current_tables() {
        let mut s = String::new();
        super::markdown(&mut s).unwrap();
        let doc = include_str!("MACHINE.md");
        if std::env::var_os("MACHINE_DOC_PRINT").is_some() {
            println!("{s}");
        }
        assert!(doc.contains(&s), "src/machine/MACHINE.md is out of date; its tables are:\n{s}");
    }
}
