//! The last wire or force job, in one slot: the two never run together, and each is several
//! kilobytes (a wire job's segment ring, a force job's filters and plant), so one slot holds
//! either and the board's RAM pays for the larger only. The job stays for its counts in Status
//! until the next `ArmWire` or `ArmForce` replaces it.

use motion::milling::link_job::ForceJob;
use motion::wire::link_job::WireJob;

// The variants' sizes differ on purpose: one slot for the larger job is the point of the type.
#[allow(clippy::large_enum_variant)]
#[derive(Default)]
pub enum LastJob {
    #[default]
    None,
    Wire(WireJob),
    Force(ForceJob),
}

impl LastJob {
    pub fn wire(&self) -> Option<&WireJob> {
        match self {
            LastJob::Wire(w) => Some(w),
            _ => None,
        }
    }

    #[inline]
    pub fn wire_mut(&mut self) -> Option<&mut WireJob> {
        match self {
            LastJob::Wire(w) => Some(w),
            _ => None,
        }
    }

    pub fn force(&self) -> Option<&ForceJob> {
        match self {
            LastJob::Force(j) => Some(j),
            _ => None,
        }
    }

    #[inline]
    pub fn force_mut(&mut self) -> Option<&mut ForceJob> {
        match self {
            LastJob::Force(j) => Some(j),
            _ => None,
        }
    }
}
