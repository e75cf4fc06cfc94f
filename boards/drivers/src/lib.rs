//! embedded-hal 1.0 drivers for the motion boards' sensors: chip protocols only, no MCU types,
//! each tested on the host against embedded-hal-mock.
//!
//! * [`ad2s1210`]: SPI resolver-to-digital converter (spindle angle and speed).
//! * [`ads131m04`]: SPI 4-channel simultaneous-sampling 24-bit ADC (force sensors).
//! * [`quadrature`]: quadrature encoders behind one trait: a timer counter in encoder mode
//!   (the F405's) and a software decoder of A/B levels (the simulated board's).
#![no_std]

#[cfg(test)]
extern crate std;

pub mod ad2s1210;
pub mod ads131m04;
pub mod quadrature;
