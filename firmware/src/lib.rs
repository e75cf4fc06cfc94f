//! The motion board firmware's shared glue. The binaries in `src/bin/` are RTIC 2 apps whose
//! tasks only call into this crate and `motion`:
//!
//! * `link` (the product): serves the host link on USART1 (`src/protocol/PROTOCOL.md`) and
//!   runs the jobs the host sends through `motion::machine::Machine` ([`link`]).
//! * `demo`: the built-in demo job through the same planner, preparer and DDA as the host
//!   model, with position snapshots and the end-of-job report over defmt.
//! * `bench`: the DDA and capability micro-benchmarks ([`bench`]).
//! * `scenarios`: every closed-loop scenario of `motion::scenarios` in the TIM2 tick.
//!
//! The board comes from a cargo feature ([`board`]); the panic and HardFault handlers are
//! here ([`panic`]). The `isr-cycles` feature measures the link firmware's tick handler on the
//! board itself ([`isr_cycles`]).
#![no_std]

pub mod bench;
pub mod board;
pub mod isr_cycles;
pub mod link;
pub mod panic;
pub mod step;
