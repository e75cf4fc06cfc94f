//! What each machine-tool capability (polar contouring, turning, milling, wire) declares about
//! itself, in one entry next to its logic ([`Capability`]), and the check of a registry of them
//! ([`check`]); the registry itself is `crate::capabilities::REGISTRY`.
//!
//! An entry says the capability's one name (its folder in `src/`, its `motionctl` subcommand,
//! the prefix of its scenarios), the `HelloInfo` bits a board sets when it runs its jobs, the
//! source jobs it runs through the machine ([`SourceJob`] tags: the machine runs every source
//! job by the same rules and keeps only the tag) and the fault codes only it raises. A fifth
//! capability adds its folder, its entry, and one line in the registry; [`check`] (run by the tests on
//! this list and on any list a test builds) refuses two entries that claim the same name, tag,
//! bit or fault.

use crate::machine::SourceJob;
use crate::protocol::FaultCode;

/// One capability's declaration.
#[derive(Debug)]
pub struct Capability {
    /// One name in every layer: `[a-z]+`.
    pub name: &'static str,
    /// What it is, and the work it comes from.
    pub title: &'static str,
    /// `HelloInfo::capabilities` bits of its jobs: a board that sets none of them runs none of
    /// this capability's jobs.
    pub hello_bits: u32,
    /// The source jobs it starts (`MachineCommand::StartQueued` / `StartSource`), tagged.
    pub jobs: &'static [SourceJob],
    /// The fault codes only its jobs raise.
    pub faults: &'static [FaultCode],
}

impl Capability {
    /// A board that announced `hello_capabilities` runs at least one of this capability's jobs.
    pub const fn on_board(&self, hello_capabilities: u32) -> bool {
        hello_capabilities & self.hello_bits != 0
    }

    /// Scenario `name` is one of this capability's (`<name>_...`).
    pub fn owns_scenario(&self, scenario: &str) -> bool {
        scenario.len() > self.name.len()
            && scenario.starts_with(self.name)
            && scenario.as_bytes()[self.name.len()] == b'_'
    }
}

/// Two entries of a registry that claim the same thing, or a malformed entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RegistryError {
    /// A name that is empty or not `[a-z]+`.
    BadName(&'static str),
    /// Two entries with one name.
    SameName(&'static str),
    /// An entry with no `HelloInfo` bit (no board could announce it).
    NoHelloBit(&'static str),
    /// `HelloInfo` bits claimed by both entries.
    SameHelloBit(&'static str, &'static str),
    /// A source-job tag claimed twice.
    SameJob(&'static str, &'static str, SourceJob),
    /// A fault code claimed twice.
    SameFault(&'static str, &'static str, FaultCode),
}

/// Checks that every entry of `registry` is well formed and that no two claim the same name,
/// `HelloInfo` bit, source-job tag or fault code.
pub fn check(registry: &[&Capability]) -> Result<(), RegistryError> {
    for (i, a) in registry.iter().enumerate() {
        if a.name.is_empty() || !a.name.bytes().all(|b| b.is_ascii_lowercase()) {
            return Err(RegistryError::BadName(a.name));
        }
        if a.hello_bits == 0 {
            return Err(RegistryError::NoHelloBit(a.name));
        }
        let own_jobs = a.jobs.iter().enumerate();
        if let Some((_, &j)) = own_jobs.clone().find(|&(k, j)| a.jobs[..k].contains(j)) {
            return Err(RegistryError::SameJob(a.name, a.name, j));
        }
        for b in &registry[..i] {
            if a.name == b.name {
                return Err(RegistryError::SameName(a.name));
            }
            if a.hello_bits & b.hello_bits != 0 {
                return Err(RegistryError::SameHelloBit(b.name, a.name));
            }
            if let Some(&j) = a.jobs.iter().find(|j| b.jobs.contains(j)) {
                return Err(RegistryError::SameJob(b.name, a.name, j));
            }
            if let Some(&f) = a.faults.iter().find(|f| b.faults.contains(f)) {
                return Err(RegistryError::SameFault(b.name, a.name, f));
            }
        }
    }
    Ok(())
}
