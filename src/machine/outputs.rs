//! The machine's non-step outputs as a plain struct the board applies every tick.

/// Mid-scale of the F405's 12-bit DAC: the Z slide's amplifier input for "no motion".
pub const Z_DAC_MID_SCALE: u16 = 2048;

/// Output levels; the board writes them to its pins and DAC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Outputs {
    pub spindle_enable: bool,
    /// Spindle direction: counterclockwise (M4) when set, clockwise (M3) when clear; the
    /// spindle turns only with `spindle_enable`.
    pub spindle_ccw: bool,
    /// Coolant: mist (M7) and flood (M8).
    pub mist: bool,
    pub flood: bool,
    pub wire_power: bool,
    /// Z-slide DAC code (12 bit).
    pub z_dac: u16,
}

impl Outputs {
    /// What an e-stop forces: everything that moves, heats or sprays off (spindle, coolant, wire
    /// power), the spindle direction back to clockwise, the Z slide at rest.
    pub const SAFE: Outputs = Outputs {
        spindle_enable: false,
        spindle_ccw: false,
        mist: false,
        flood: false,
        wire_power: false,
        z_dac: Z_DAC_MID_SCALE,
    };
}

impl Default for Outputs {
    fn default() -> Self {
        Outputs::SAFE
    }
}
