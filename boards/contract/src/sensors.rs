//! The capability sensors and the cycle counter.

use motion::milling::sample_timer::SampleRateError;
use motion::spindle::encoder::{EncoderConfig, EncoderConfigError};
use motion::spindle::SpindleSource;

/// The spindle angle source of Z-slide and force jobs.
pub trait SpindleEncoder: SpindleSource {
    /// The host drives a simulated spindle (`Sim(Spindle)`).
    const SIM: bool;
    /// Sets the simulated speed and index pulses; false where not honoured.
    fn set_sim(speed_turn_q32_per_tick: u32, index: bool) -> bool;
    /// (Re)starts the encoder logic.
    fn configure(&mut self, cfg: EncoderConfig) -> Result<(), EncoderConfigError>;
    /// Once per tick, before the angle and speed are read. Bounded, no division.
    fn update(&mut self);
    /// [`SpindleEncoder::update`] would change nothing until something outside the tick moves
    /// the spindle (a simulated spindle standing still): a step-only tick may skip it. A
    /// hardware counter can move any time, hence the default.
    fn at_rest(&self) -> bool {
        false
    }
}

/// The copy-mode template encoders (arm, carriage).
pub trait CopyEncoders {
    /// Their inputs are wired: copy jobs are possible.
    const ROUTED: bool;
    /// Sets the simulated encoders' target counts; false where not honoured.
    fn set_sim_target(counts: [i32; 2]) -> bool;
    /// (arm, carriage) counts, once per tick. Bounded, no division.
    fn read(&mut self) -> [i32; 2];
}

/// Force channels in one frame (Fx, Fy, Fz).
pub const FORCE_CHANNEL_COUNT: usize = 3;
/// One scan of the force channels, raw counts.
pub type ForceFrame = [u16; FORCE_CHANNEL_COUNT];

/// A DMA-fed force ADC: frames arrive a half buffer per interrupt.
pub trait ForceAdc {
    /// (Re)starts sampling; the rate the timer gives.
    fn start(&mut self, sample_hz: u32) -> Result<u32, SampleRateError>;
    /// The interrupt: the half buffer just filled, or `None` (spurious, or an overrun).
    fn on_dma_irq(&mut self) -> Option<&[ForceFrame]>;
    /// An overrun is latched (sampling stopped).
    fn overrun(&self) -> bool;
}

/// A board without a force ADC: no value of this type exists.
pub enum NoForceAdc {}

impl ForceAdc for NoForceAdc {
    fn start(&mut self, _sample_hz: u32) -> Result<u32, SampleRateError> {
        match *self {}
    }
    fn on_dma_irq(&mut self) -> Option<&[ForceFrame]> {
        match *self {}
    }
    fn overrun(&self) -> bool {
        match *self {}
    }
}

/// A free-running counter for benchmarks (core cycles; under QEMU, instructions).
pub trait CycleCounter {
    fn now(&self) -> u32;
}
