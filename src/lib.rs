//! Pure motion-control logic for the motion board: no hardware types, no allocation, no panics on
//! the interrupt path. The same code runs in the firmware's tick interrupt and in the host model,
//! so a QEMU run and a host run of the same job agree bit for bit.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

pub mod capabilities;
pub mod capability;
pub mod config;
pub mod cycle_histogram;
pub mod dda;
pub mod demo_job;
pub mod fixed_math;
pub mod machine;
pub mod milling;
pub mod model;
pub mod planner;
pub mod polar;
pub mod protocol;
pub mod report;
pub mod scenario;
pub mod scenarios;
pub mod segment;
pub mod spindle;
pub mod trace;
pub mod trig;
pub mod turning;
pub mod wire;

pub use config::{AxisLimits, ConfigError, InputFilterConfig, MachineConfig, StepTiming, MAX_AXES};
pub use dda::{Command, Dda, StepOutput};
pub use segment::{Rate, Segment};
