//! The suite's checker: runs a case on the host and names what its report breaks of the
//! documented end (the xtask fault suite and this crate's tests share it).

use super::case::Case;
use super::scenario::FaultScenario;
use super::MAX_TICKS;
use crate::machine::MachineState;
use crate::scenario::ScenarioReport;

/// Runs `case` to its end on the host (the same code the firmware's tick and control tasks run).
pub fn run_case(case: Case) -> Option<ScenarioReport> {
    let mut s = FaultScenario::new(case)?;
    Some(crate::scenario::run_to_end(&mut s, MAX_TICKS + 1))
}

/// What the report `r` of `case` breaks of the documented end, `None` when nothing: the state and
/// fault code of [`Case::expected`], settled before the safety net; the machine's counters equal
/// to the DDA's positions and to the steps the pins made (nothing lost, nothing twice); after a
/// fault that stops at once no step more; after one that kills, the outputs off.
pub fn broken_promise(case: Case, r: &ScenarioReport) -> Option<&'static str> {
    use crate::machine::{reaction, Reaction};
    let f = |n: &str| r.figure(n);
    let (state, code) = case.expected();
    if f("state") != Some(state as i64) {
        return Some("ended in another state than documented");
    }
    if r.fault != code.map_or(0, |c| c.code()) {
        return Some("reported another fault code than documented");
    }
    if r.ticks >= MAX_TICKS {
        return Some("did not settle");
    }
    for a in 0..2 {
        let raw = f(["raw0_steps", "raw1_steps"][a]);
        if raw.is_none()
            || raw != f(["dda0_steps", "dda1_steps"][a])
            || raw != f(["net0_steps", "net1_steps"][a])
        {
            return Some("machine counters, DDA positions and pin steps disagree");
        }
    }
    if let Some(code) = code.filter(|_| state == MachineState::Fault) {
        match reaction(code) {
            Reaction::Hold => {}
            Reaction::Kill if f("spindle") != Some(0) || f("wire_power") != Some(0) => {
                return Some("outputs left on after a kill")
            }
            _ if f("steps_after_fault") != Some(0) => {
                return Some("stepped after an immediate stop")
            }
            _ => {}
        }
    }
    None
}
