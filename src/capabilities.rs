//! The capability registry: the one list of capability entries ([`REGISTRY`]) that the layers
//! around the capabilities walk instead of naming them, and the lookups over it. A fifth
//! capability adds one line here.

use crate::capability::Capability;
use crate::machine::SourceJob;
use crate::protocol::FaultCode;

/// Every capability the board and its host tools know, in the order they are listed to users.
pub const REGISTRY: [&Capability; 4] = [
    &crate::polar::CAPABILITY,
    &crate::turning::CAPABILITY,
    &crate::milling::CAPABILITY,
    &crate::wire::CAPABILITY,
];

/// Every `HelloInfo` bit of every capability in [`REGISTRY`]: what a board that has every
/// capability's hardware announces for them.
pub const fn hello_bits() -> u32 {
    let mut bits = 0;
    let mut i = 0;
    while i < REGISTRY.len() {
        bits |= REGISTRY[i].hello_bits;
        i += 1;
    }
    bits
}

/// The entry named `name` in [`REGISTRY`].
pub fn by_name(name: &str) -> Option<&'static Capability> {
    REGISTRY.iter().copied().find(|c| c.name == name)
}

/// The capability that owns source job `job`.
pub fn owner_of_job(job: SourceJob) -> Option<&'static Capability> {
    REGISTRY.iter().copied().find(|c| c.jobs.contains(&job))
}

/// The capability whose jobs raise `fault` (`None`: a machine fault, any job can raise it).
pub fn owner_of_fault(fault: FaultCode) -> Option<&'static Capability> {
    REGISTRY.iter().copied().find(|c| c.faults.contains(&fault))
}

/// The capabilities a board runs, from its `HelloInfo::capabilities`.
pub fn on_board(hello_capabilities: u32) -> impl Iterator<Item = &'static Capability> {
    REGISTRY.iter().copied().filter(move |c| c.on_board(hello_capabilities))
}

pub mod requests;

#[cfg(test)]
mod tests;
