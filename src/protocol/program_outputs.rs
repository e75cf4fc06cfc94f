//! The outputs a program switches (spindle direction, coolant): the `SetProgramOutputs` request's
//! body and the `Status::outputs` bit set, with their mapping onto the machine's [`Outputs`].

use serde::{Deserialize, Serialize};

use crate::machine::Outputs;

/// `Status::outputs` bit: the spindle turns (enable).
pub const OUT_SPINDLE: u8 = 1 << 0;
/// `Status::outputs` bit: the spindle's direction is counterclockwise (M4); clear = clockwise.
/// Only meaningful with [`OUT_SPINDLE`].
pub const OUT_SPINDLE_CCW: u8 = 1 << 1;
/// `Status::outputs` bit: mist coolant (M7).
pub const OUT_MIST: u8 = 1 << 2;
/// `Status::outputs` bit: flood coolant (M8).
pub const OUT_FLOOD: u8 = 1 << 3;

/// Spindle state as G-code switches it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SpindleDir {
    /// M5.
    #[default]
    Off,
    /// M3.
    Cw,
    /// M4.
    Ccw,
}

impl SpindleDir {
    /// From an enable and a direction level: a direction without the enable is a stopped spindle.
    pub const fn of(on: bool, ccw: bool) -> SpindleDir {
        match (on, ccw) {
            (false, _) => SpindleDir::Off,
            (true, false) => SpindleDir::Cw,
            (true, true) => SpindleDir::Ccw,
        }
    }
}

/// Every output a program switches, as one state (`SetProgramOutputs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ProgramOutputs {
    pub spindle: SpindleDir,
    pub mist: bool,
    pub flood: bool,
}

impl ProgramOutputs {
    /// Spindle stopped, coolant off.
    pub const OFF: ProgramOutputs =
        ProgramOutputs { spindle: SpindleDir::Off, mist: false, flood: false };

    /// The `Status::outputs` bits (`OUT_*`).
    pub const fn bits(self) -> u8 {
        let spindle = match self.spindle {
            SpindleDir::Off => 0,
            SpindleDir::Cw => OUT_SPINDLE,
            SpindleDir::Ccw => OUT_SPINDLE | OUT_SPINDLE_CCW,
        };
        spindle | (self.mist as u8 * OUT_MIST) | (self.flood as u8 * OUT_FLOOD)
    }

    /// Reads `Status::outputs` bits; a direction bit without the enable bit is a stopped spindle.
    pub const fn from_bits(bits: u8) -> ProgramOutputs {
        ProgramOutputs {
            spindle: SpindleDir::of(bits & OUT_SPINDLE != 0, bits & OUT_SPINDLE_CCW != 0),
            mist: bits & OUT_MIST != 0,
            flood: bits & OUT_FLOOD != 0,
        }
    }

    /// What the machine's outputs say.
    pub const fn of(o: &Outputs) -> ProgramOutputs {
        ProgramOutputs {
            spindle: SpindleDir::of(o.spindle_enable, o.spindle_ccw),
            mist: o.mist,
            flood: o.flood,
        }
    }

    /// `o` with these spindle and coolant levels; the wire power and the Z DAC stay as they are
    /// (other jobs own them). A stopped spindle keeps the clockwise level on its direction pin.
    pub const fn applied_to(self, o: Outputs) -> Outputs {
        Outputs {
            spindle_enable: !matches!(self.spindle, SpindleDir::Off),
            spindle_ccw: matches!(self.spindle, SpindleDir::Ccw),
            mist: self.mist,
            flood: self.flood,
            ..o
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_round_trip_and_apply_keeps_wire_and_dac() {
        for spindle in [SpindleDir::Off, SpindleDir::Cw, SpindleDir::Ccw] {
            for (mist, flood) in [(false, false), (true, false), (false, true), (true, true)] {
                let p = ProgramOutputs { spindle, mist, flood };
                assert_eq!(ProgramOutputs::from_bits(p.bits()), p);
                let base = Outputs { wire_power: true, z_dac: 1234, ..Outputs::SAFE };
                let o = p.applied_to(base);
                assert_eq!(ProgramOutputs::of(&o), p);
                assert!(o.wire_power);
                assert_eq!(o.z_dac, 1234);
            }
        }
        assert_eq!(ProgramOutputs::OFF.bits(), 0);
        assert_eq!(ProgramOutputs::of(&Outputs::SAFE), ProgramOutputs::OFF);
        assert_eq!(ProgramOutputs::from_bits(OUT_SPINDLE_CCW).spindle, SpindleDir::Off);
    }
}
