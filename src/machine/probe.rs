//! Probe moves (G38.2..G38.5): a plain segment job marked as a probe move with its kind
//! ([`ProbeKind`]). While it runs, the tick watches the debounced probe input: a toward move
//! trips when the input becomes active, an away move when it becomes inactive. On the trip the
//! machine latches every axis's machine position (steps) at that tick, then stops on the path
//! with a feed-hold deceleration and discards the rest of the move, as grbl does (latch at the
//! trigger, then a controlled stop: a probe moving at a feed faster than the motors can stop
//! from at once would otherwise lose steps, and the latched position, not where the axes come to
//! rest, is the measurement). The job then ends (`Running -> Ready`) with the axes where they
//! stopped.
//!
//! Faults, as grbl's alarms: a probe already in its tripped state when the move starts is
//! `ProbeInitial` (grbl ALARM:4; every kind: a trip at the start position would report a
//! contact that never happened), and a move of an error kind (G38.2, G38.4) that ends without a
//! trip is `ProbeFail` (grbl ALARM:5). The non-error kinds (G38.3, G38.5) end as `Missed`.
//!
//! Interrupt rate: the tick tests one flag ([`ProbeRun::watching`]) while no probe move runs;
//! during one, a compare per tick, and the 6-axis copy once at the trip. No division.

use serde::{Deserialize, Serialize};

use crate::config::MAX_AXES;
use crate::protocol::FaultCode;

/// What a probe move looks for (the G-code word), and whether missing it is a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ProbeKind {
    /// G38.2: toward the workpiece, stop on contact; no contact is `ProbeFail`.
    TowardError,
    /// G38.3: toward, stop on contact; no contact is not a fault.
    Toward,
    /// G38.4: away from the workpiece, stop on loss of contact; no loss is `ProbeFail`.
    AwayError,
    /// G38.5: away, stop on loss of contact; no loss is not a fault.
    Away,
}

impl ProbeKind {
    pub const ALL: [ProbeKind; 4] =
        [ProbeKind::TowardError, ProbeKind::Toward, ProbeKind::AwayError, ProbeKind::Away];

    /// The debounced probe level that ends the move (active for a toward move).
    pub const fn trip_level(self) -> bool {
        matches!(self, ProbeKind::TowardError | ProbeKind::Toward)
    }

    /// Ending without a trip is a fault (`ProbeFail`).
    pub const fn errors(self) -> bool {
        matches!(self, ProbeKind::TowardError | ProbeKind::AwayError)
    }

    /// The G-code that asks for it.
    pub const fn gcode(self) -> &'static str {
        match self {
            ProbeKind::TowardError => "G38.2",
            ProbeKind::Toward => "G38.3",
            ProbeKind::AwayError => "G38.4",
            ProbeKind::Away => "G38.5",
        }
    }
}

/// Where the last probe move is (`Status::probe_phase` as u8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ProbePhase {
    /// No probe move since boot.
    #[default]
    None = 0,
    /// Armed: the next `Start` runs the queued segments as a probe move.
    Armed = 1,
    /// The probe move runs; the tick watches the input.
    Moving = 2,
    /// The input tripped: the position is latched (`Status::probe_steps`).
    Tripped = 3,
    /// The move ended without a trip (a fault for G38.2 and G38.4).
    Missed = 4,
    /// The probe was already in its tripped state at the start: `ProbeInitial`, nothing moved.
    Refused = 5,
    /// Abort, a fault, a config change, homing or another kind of job ended it first.
    Dropped = 6,
}

impl ProbePhase {
    pub const ALL: [ProbePhase; 7] = [
        ProbePhase::None,
        ProbePhase::Armed,
        ProbePhase::Moving,
        ProbePhase::Tripped,
        ProbePhase::Missed,
        ProbePhase::Refused,
        ProbePhase::Dropped,
    ];

    /// The phase a `Status::probe_phase` byte names (`None` for an unknown byte).
    pub fn from_u8(b: u8) -> ProbePhase {
        ProbePhase::ALL.get(b as usize).copied().unwrap_or(ProbePhase::None)
    }

    pub const fn name(self) -> &'static str {
        match self {
            ProbePhase::None => "none",
            ProbePhase::Armed => "armed",
            ProbePhase::Moving => "moving",
            ProbePhase::Tripped => "tripped",
            ProbePhase::Missed => "missed",
            ProbePhase::Refused => "refused",
            ProbePhase::Dropped => "dropped",
        }
    }

    /// The probe move is over (its result is final).
    pub const fn ended(self) -> bool {
        !matches!(self, ProbePhase::Armed | ProbePhase::Moving)
    }
}

/// The machine's probe move: armed, watched by the tick, its result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeRun {
    kind: ProbeKind,
    phase: ProbePhase,
    /// A probe move runs: the one flag the tick tests.
    watching: bool,
    /// Tripped, decelerating on the path until the DDA is at rest.
    stopping: bool,
    latched_steps: [i64; MAX_AXES],
    /// The rest of the probe move is to be dropped by whoever holds it (the link's queue).
    discard: bool,
}

impl Default for ProbeRun {
    fn default() -> Self {
        Self::new()
    }
}

impl ProbeRun {
    pub const fn new() -> Self {
        ProbeRun {
            kind: ProbeKind::TowardError,
            phase: ProbePhase::None,
            watching: false,
            stopping: false,
            latched_steps: [0; MAX_AXES],
            discard: false,
        }
    }

    /// A probe move runs: the tick watches the input (the one flag it tests otherwise).
    #[inline(always)]
    pub const fn watching(&self) -> bool {
        self.watching
    }

    /// Tripped and still decelerating.
    pub const fn stopping(&self) -> bool {
        self.stopping
    }

    pub const fn kind(&self) -> ProbeKind {
        self.kind
    }

    pub const fn phase(&self) -> ProbePhase {
        self.phase
    }

    /// Machine position of every axis at the trip (meaningful in `Tripped`).
    pub const fn latched_steps(&self) -> [i64; MAX_AXES] {
        self.latched_steps
    }

    /// The next `Start` runs a probe move of `kind` (a new result: the last one is forgotten).
    pub fn arm(&mut self, kind: ProbeKind) {
        *self = ProbeRun { kind, phase: ProbePhase::Armed, ..ProbeRun::new() };
    }

    /// The job starts with the debounced probe input at `level`: an armed probe starts watching,
    /// or refuses with `ProbeInitial` when the input already reads the level that would end it.
    pub fn start(&mut self, level: bool) -> Result<(), FaultCode> {
        if self.phase != ProbePhase::Armed {
            return Ok(());
        }
        if level == self.kind.trip_level() {
            self.phase = ProbePhase::Refused;
            return Err(FaultCode::ProbeInitial);
        }
        self.phase = ProbePhase::Moving;
        self.watching = true;
        Ok(())
    }

    /// The input reads `level` this tick: true if it trips the move now.
    #[inline(always)]
    pub fn trips(&self, level: bool) -> bool {
        !self.stopping && level == self.kind.trip_level()
    }

    /// The trip, with every axis's machine position this tick: the stop begins.
    pub fn trip(&mut self, positions: [i64; MAX_AXES]) {
        self.latched_steps = positions;
        self.phase = ProbePhase::Tripped;
        self.stopping = true;
    }

    /// The axes are at rest after the trip: the watch ends and the rest of the move goes.
    pub fn stopped(&mut self) {
        self.stopping = false;
        self.watching = false;
        self.discard = true;
    }

    /// The job ended: a probe move still watching missed; the fault for an error kind.
    pub fn job_end(&mut self) -> Option<FaultCode> {
        if self.phase != ProbePhase::Moving {
            return None;
        }
        self.watching = false;
        self.phase = ProbePhase::Missed;
        self.kind.errors().then_some(FaultCode::ProbeFail)
    }

    /// Something else ended the job (abort, fault, config, homing, another job kind): an armed
    /// or running probe move is dropped; a result already there stays.
    pub fn drop_move(&mut self) {
        if !self.phase.ended() {
            self.phase = ProbePhase::Dropped;
        }
        self.watching = false;
        self.stopping = false;
    }

    /// True once after a trip stopped the move: the caller drops the segments of it it still
    /// holds (the machine's own bookkeeping was reset by the abort).
    pub fn take_discard(&mut self) -> bool {
        core::mem::take(&mut self.discard)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_trip_on_their_level_and_fail_only_when_error_kinds() {
        let trip: Vec<_> = ProbeKind::ALL.iter().map(|k| k.trip_level()).collect();
        assert_eq!(trip, [true, true, false, false]);
        let errs: Vec<_> = ProbeKind::ALL.iter().map(|k| k.errors()).collect();
        assert_eq!(errs, [true, false, true, false]);
    }

    #[test]
    fn a_run_starts_trips_stops_and_discards_once() {
        let mut p = ProbeRun::new();
        // Not armed: a start changes nothing.
        assert_eq!(p.start(true), Ok(()));
        assert!(!p.watching);
        p.arm(ProbeKind::Toward);
        assert_eq!(p.start(false), Ok(()));
        assert!(p.watching && !p.trips(false) && p.trips(true));
        p.trip([1, 2, 3, 0, 0, 0]);
        assert!(!p.trips(true), "stopping: no second trip");
        p.stopped();
        assert!(!p.watching);
        assert_eq!((p.phase(), p.latched_steps()), (ProbePhase::Tripped, [1, 2, 3, 0, 0, 0]));
        assert!(p.take_discard());
        assert!(!p.take_discard());
        assert_eq!(p.job_end(), None);
    }

    #[test]
    fn initial_state_and_missed_moves() {
        let mut p = ProbeRun::new();
        p.arm(ProbeKind::AwayError);
        // An away move needs the probe in contact at the start.
        assert_eq!(p.start(false), Err(FaultCode::ProbeInitial));
        assert_eq!(p.phase(), ProbePhase::Refused);
        p.arm(ProbeKind::AwayError);
        assert_eq!(p.start(true), Ok(()));
        assert_eq!(p.job_end(), Some(FaultCode::ProbeFail));
        assert_eq!(p.phase(), ProbePhase::Missed);
        p.arm(ProbeKind::Away);
        p.start(true).unwrap();
        assert_eq!(p.job_end(), None);
        assert_eq!(p.phase(), ProbePhase::Missed);
        p.arm(ProbeKind::Toward);
        p.drop_move();
        assert_eq!(p.phase(), ProbePhase::Dropped);
        assert_eq!(ProbePhase::from_u8(3), ProbePhase::Tripped);
        assert_eq!(ProbePhase::from_u8(200), ProbePhase::None);
    }
}
