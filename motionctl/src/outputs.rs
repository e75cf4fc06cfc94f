//! The spindle and coolant a program switches ([`ProgramOutputs`]) in words, for the run's
//! messages: what changed from one state to the next, as the G-code words that switch it.

use crate::link::{describe_rejection, LinkFailure, Session};
use motion::protocol::{ProgramOutputs, Reply, RequestBody, SpindleDir, Status};

/// One switch of a run, as the board showed it right after.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Switched {
    /// The state asked for.
    pub to: ProgramOutputs,
    /// The board's `Status::outputs` read right after the request.
    pub shown: u8,
    /// Segments the board had done then (its `Status::segments_done`, counted from the run's
    /// start): the switch's place among the moves.
    pub segments_done: u32,
}

/// Switches the board's spindle and coolant to `to` (`SetProgramOutputs`; the caller waited for
/// the motion before it) and reads the board's status back (`Status::outputs` is what it
/// drives). The inner error says why the board refused (an e-stop latched: `OutOfState`; a
/// board without these outputs: `Unsupported`).
pub fn switch(s: &mut Session, to: ProgramOutputs) -> Result<Result<Status, String>, LinkFailure> {
    if let Err(r) = s.request(RequestBody::SetProgramOutputs(to))? {
        return Ok(Err(format!(
            "the board refused to switch the {}: {}",
            describe(to),
            describe_rejection(&r)
        )));
    }
    Ok(match s.request(RequestBody::GetStatus)? {
        Ok(Reply::Status(st)) => Ok(st),
        Ok(_) => Err("the board answered GetStatus without a status".into()),
        Err(r) => Err(format!("GetStatus refused: {}", describe_rejection(&r))),
    })
}

/// What changed from `before` to `after`, e.g. "spindle on clockwise (M3), flood on (M8)";
/// "no change" when nothing did.
pub fn describe_change(before: ProgramOutputs, after: ProgramOutputs) -> String {
    let mut parts: Vec<&str> = Vec::new();
    if before.spindle != after.spindle {
        parts.push(match after.spindle {
            SpindleDir::Off => "spindle off (M5)",
            SpindleDir::Cw => "spindle on clockwise (M3)",
            SpindleDir::Ccw => "spindle on counterclockwise (M4)",
        });
    }
    match (before.mist != after.mist, before.flood != after.flood) {
        // Both off at once is what M9 does.
        (true, true) if !after.mist && !after.flood => parts.push("coolant off (M9)"),
        (mist, flood) => {
            if mist {
                parts.push(if after.mist { "mist on (M7)" } else { "mist off (M9)" });
            }
            if flood {
                parts.push(if after.flood { "flood on (M8)" } else { "flood off (M9)" });
            }
        }
    }
    if parts.is_empty() {
        "no change".into()
    } else {
        parts.join(", ")
    }
}

/// The state in words, e.g. "spindle counterclockwise, mist": what the board drives.
pub fn describe(o: ProgramOutputs) -> String {
    let mut parts = vec![match o.spindle {
        SpindleDir::Off => "spindle off",
        SpindleDir::Cw => "spindle clockwise",
        SpindleDir::Ccw => "spindle counterclockwise",
    }];
    match (o.mist, o.flood) {
        (false, false) => parts.push("coolant off"),
        (mist, flood) => {
            if mist {
                parts.push("mist");
            }
            if flood {
                parts.push("flood");
            }
        }
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changes_read_as_the_words_that_make_them() {
        let off = ProgramOutputs::OFF;
        let cw = ProgramOutputs { spindle: SpindleDir::Cw, ..off };
        let cw_flood = ProgramOutputs { flood: true, ..cw };
        assert_eq!(describe_change(off, cw_flood), "spindle on clockwise (M3), flood on (M8)");
        let both = ProgramOutputs { mist: true, ..cw_flood };
        assert_eq!(describe_change(both, cw), "coolant off (M9)");
        assert_eq!(describe_change(cw_flood, cw), "flood off (M9)");
        let ccw = ProgramOutputs { spindle: SpindleDir::Ccw, ..off };
        assert_eq!(describe_change(cw, ccw), "spindle on counterclockwise (M4)");
        assert_eq!(describe_change(ccw, off), "spindle off (M5)");
        assert_eq!(describe_change(off, off), "no change");
        assert_eq!(describe(both), "spindle clockwise, mist, flood");
        assert_eq!(describe(off), "spindle off, coolant off");
    }
}
