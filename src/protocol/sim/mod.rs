//! The simulator side of the protocol, apart from the production messages:
//!
//! * [`messages`]: [`SimRequest`], the test hooks a simulator board (QEMU's netduinoplus2,
//!   `CAP_SIM_INPUTS`) takes in `RequestBody::Sim`, and the simulated milling plant's
//!   parameters ([`SimMillingParams`], [`SimForceFault`]). The plant types are always compiled:
//!   the force job's simulated sample source (`crate::milling::link_job`) is built from them.
//! * [`SimTarget`] and [`CopySim`]: hardware-free `LinkTarget`s for tests, fuzzing and
//!   `motionctl`'s loopback boards.
//!
//! Everything but the plant types needs the `sim-inputs` feature (the tests of this crate get
//! the targets without it), so the real board's firmware, built without it, carries neither
//! the hooks nor their session handling.

pub mod messages;

#[cfg(any(test, feature = "sim-inputs"))]
mod copy;
#[cfg(any(test, feature = "sim-inputs"))]
mod target;

#[cfg(any(test, feature = "sim-inputs"))]
pub use copy::CopySim;
#[cfg(feature = "sim-inputs")]
pub use messages::SimRequest;
pub use messages::{SimForceFault, SimMillingParams, SimProbeSurface};
#[cfg(any(test, feature = "sim-inputs"))]
pub use target::{SimTarget, SIM_EVENT_BLOCKS, SIM_QUEUE_MAX};

#[cfg(test)]
mod tests;
