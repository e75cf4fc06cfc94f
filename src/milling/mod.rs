//! Constant-force adaptive feed for milling (Elbestawi 1980, issue #4): the force sensor chain,
//! the control law that turns force into a DDA feed override, the milling plant the simulation
//! drives, and the closed-loop scenarios.
//!
//! Rates: the chain's [`chain::ForceChain::sample`] runs per ADC sample (10 kHz in the scenario),
//! every [`chain::DECIMATION`]th sample yields a reading for [`control::ForceController::update`]
//! (2 kHz). Both are integer-only and division-free; setup code divides.

pub mod biquad;
pub mod chain;
pub mod control;
pub mod dma_frames;
pub mod link_job;
pub mod link_messages;
pub mod link_params;
pub mod peak;
pub mod plant;
pub mod sample_timer;
pub mod scenario;

use crate::capability::Capability;
use crate::protocol::FaultCode;

/// Constant-force milling's registry entry. It runs no source job of its own: a force job is a
/// plain segment job whose feed override the force loop sets.
pub const CAPABILITY: Capability = Capability {
    name: "milling",
    title: "constant-force milling (Elbestawi 1980): a feed override that holds the cutting \
            force at its nominal value, with impact strategies",
    hello_bits: crate::protocol::CAP_MILLING_JOB,
    jobs: &[],
    faults: &[FaultCode::ForceSaturated, FaultCode::ForceStuck, FaultCode::ForceTrip],
};
