//! Board faults and refused moves as grbl alarms and errors.

use super::{Bridge, Pending};
use crate::grbl::pipeline::MoveError;
use crate::grbl::protocol::{alarm, error};
use crate::runner::fault_names;
use motion::protocol::FaultCode;

impl Bridge<'_> {
    /// A board fault becomes a grbl alarm.
    pub(super) fn on_faults(&mut self, bits: u32) {
        let new = bits & !self.faults_seen;
        self.faults_seen = bits;
        if new == 0 {
            return;
        }
        self.fault_alarm(new);
        self.probe_faulted();
        // The board dropped its queue.
        self.pending.retain(|_, p| !matches!(p, Pending::Batch { .. }));
        self.rebase();
    }

    /// The alarm for the faults `bits` (the first of them in code order): raised, said with a
    /// `[MSG:]` naming them.
    pub(super) fn fault_alarm(&mut self, bits: u32) {
        let first = FaultCode::ALL.iter().copied().find(|f| bits & f.bit() != 0);
        let n = match first {
            Some(FaultCode::LimitSwitch) => alarm::HARD_LIMIT,
            Some(FaultCode::SoftLimit) => alarm::SOFT_LIMIT,
            Some(FaultCode::HomingFailed) => alarm::HOMING_FAIL_RESET,
            Some(FaultCode::EStop) => alarm::ESTOP,
            Some(FaultCode::ProbeInitial) => alarm::PROBE_FAIL_INITIAL,
            Some(FaultCode::ProbeFail) => alarm::PROBE_FAIL_CONTACT,
            Some(f) => alarm::BOARD_FAULT_BASE + f.bit().trailing_zeros() as u8,
            None => alarm::ABORT_CYCLE,
        };
        self.alarm = Some(n);
        self.say(&format!("ALARM:{n}"));
        let names = fault_names(bits);
        let why = first.map(|f| f.description()).unwrap_or("");
        eprintln!("motionctl: ALARM:{n}: board fault {names}: {why}");
        self.say(&format!("[MSG:board fault {names}: {why}]"));
    }

    /// Says what a refused move raised; grbl's error number for its line.
    pub(super) fn refuse_move(&mut self, e: MoveError) -> u8 {
        match e {
            MoveError::SoftLimit(m) if !self.check => {
                eprintln!("motionctl: soft limit: {m}");
                // What is queued stops: the program cannot continue past this block.
                let _ = self.stop_motion();
                self.alarm = Some(alarm::SOFT_LIMIT);
                self.say(&format!("ALARM:{}", alarm::SOFT_LIMIT));
                self.say(&format!("[MSG:{m}]"));
                error::SYSTEM_GC_LOCK
            }
            MoveError::SoftLimit(m) | MoveError::Invalid(m) => {
                eprintln!("motionctl: {m}");
                error::INVALID_TARGET
            }
        }
    }
}
