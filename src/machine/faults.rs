//! The fault latch (every latched `FaultCode` as a bit, plus the first one) and the reaction each
//! fault class gets. The reaction table is code, rendered for the docs by [`markdown_reactions`].

use crate::protocol::FaultCode;
use core::fmt::Write;

/// What the machine does when a fault is raised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reaction {
    /// Immediate step stop (no deceleration), every queued segment dropped, outputs to their safe
    /// values (spindle off, wire power off, Z DAC mid-scale); homing no longer trusted.
    Kill,
    /// Immediate step stop (no deceleration), every queued segment dropped; positions kept.
    Stop,
    /// Feed hold: decelerate and stop on the path; positions kept.
    Hold,
}

impl Reaction {
    pub const fn name(self) -> &'static str {
        match self {
            Reaction::Kill => {
                "immediate stop, outputs off, homing lost; steps may be lost mechanically but the counters are exact"
            }
            Reaction::Stop => "immediate stop (abort), position kept",
            Reaction::Hold => "feed hold (controlled stop on the path)",
        }
    }
}

/// The reaction to `code`.
pub const fn reaction(code: FaultCode) -> Reaction {
    match code {
        FaultCode::EStop => Reaction::Kill,
        FaultCode::LimitSwitch
        | FaultCode::SoftLimit
        | FaultCode::ConfigMissing
        | FaultCode::ConfigCorrupt
        | FaultCode::FollowingError
        | FaultCode::HomingFailed
        | FaultCode::WatchdogReset
        | FaultCode::SegmentRejected
        | FaultCode::BoardSetup
        | FaultCode::TickRate
        | FaultCode::Panicked
        | FaultCode::ProbeInitial
        | FaultCode::ProbeFail => Reaction::Stop,
        FaultCode::QueueUnderrun
        | FaultCode::TickOverrun
        | FaultCode::LinkLost
        | FaultCode::SensorFault
        | FaultCode::ForceSaturated
        | FaultCode::ForceStuck
        | FaultCode::ForceTrip
        | FaultCode::SpindleStopped
        | FaultCode::EncoderIndex
        | FaultCode::ResolverLoss
        | FaultCode::ZSlideLimit
        | FaultCode::WireStall => Reaction::Hold,
    }
}

/// What must be true before `ClearFault` is accepted for `code`.
pub const fn cause_gone_when(code: FaultCode) -> &'static str {
    match code {
        FaultCode::EStop => "e-stop input released",
        FaultCode::LimitSwitch => "every limit switch released",
        FaultCode::LinkLost => "link back",
        FaultCode::ConfigMissing | FaultCode::ConfigCorrupt | FaultCode::TickRate => {
            "a valid SetConfig accepted"
        }
        FaultCode::SoftLimit
        | FaultCode::QueueUnderrun
        | FaultCode::TickOverrun
        | FaultCode::HomingFailed
        | FaultCode::WatchdogReset
        | FaultCode::SegmentRejected
        | FaultCode::BoardSetup
        | FaultCode::Panicked
        | FaultCode::ProbeInitial
        | FaultCode::ProbeFail => "at once (an event, not a level)",
        FaultCode::SensorFault => "sensor input clear",
        FaultCode::FollowingError => {
            "at once from the machine's monitor (it re-zeroes), else the sensor's bit clear; homing lost (home again)"
        }
        _ => "the sensor's fault bit clear",
    }
}

/// Every latched fault and the first one since the last clear.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultLatch {
    mask: u32,
    first: Option<FaultCode>,
}

impl FaultLatch {
    pub const fn new() -> Self {
        FaultLatch { mask: 0, first: None }
    }

    /// Latches `code`; true if it was not latched before (its reaction is then due).
    #[inline]
    pub fn raise(&mut self, code: FaultCode) -> bool {
        let bit = code.bit();
        if self.mask & bit != 0 {
            return false;
        }
        self.mask |= bit;
        if self.first.is_none() {
            self.first = Some(code);
        }
        true
    }

    /// Bit n set = `FaultCode` n latched (the link's `Status::faults`).
    pub const fn mask(&self) -> u32 {
        self.mask
    }

    /// The fault that latched first (the cause; later ones are often consequences).
    pub const fn first(&self) -> Option<FaultCode> {
        self.first
    }

    pub const fn has(&self, code: FaultCode) -> bool {
        self.mask & code.bit() != 0
    }

    pub const fn is_clear(&self) -> bool {
        self.mask == 0
    }

    pub fn clear(&mut self) {
        *self = FaultLatch::new();
    }
}

/// The fault table with each fault's reaction and clear condition, as Markdown.
pub fn markdown_reactions(out: &mut impl Write) -> core::fmt::Result {
    out.write_str("| Code | Fault | Reaction | Clearable when |\n|---:|---|---|---|\n")?;
    for &f in FaultCode::ALL {
        writeln!(
            out,
            "| {} | {} | {} | {} |",
            f.code(),
            f.name(),
            reaction(f).name(),
            cause_gone_when(f)
        )?;
    }
    Ok(())
}
