//! The stop codes (rs274ngc's `convert_stop`): M0, M1, M60, and M2/M30's program end.

use super::Outcome;
use crate::block::Block;
use crate::canon::{Canon, Plane};
use crate::core::Core;
use crate::diag::{At, Fault, Res};
use crate::modal::{g, mgroup};
use crate::state::{rotate_xy, FeedMode, Spindle};

impl Core {
    /// M0, M1, M2, M30, M60, M99.
    pub(super) fn convert_stop(&mut self, b: &Block) -> Res<Outcome> {
        let m = b.m_modes[mgroup::STOP];
        // rs274 reads the cutter compensation position here, which exists only in XY and XZ.
        if !matches!(self.s.plane, Plane::XY | Plane::XZ) {
            return Err(Fault::new(
                "BUG: Invalid plane in comp_get_current",
                At::MGroup(mgroup::STOP),
            ));
        }
        match m {
            0 => self.emit(Canon::ProgramStop)?,
            60 => {
                self.emit(Canon::PalletShuttle)?;
                self.emit(Canon::ProgramStop)?;
            }
            1 => self.emit(Canon::OptionalProgramStop)?,
            _ => {
                self.program_end(b.f.unwrap_or(0.0), m == 30)?;
                return Ok(Outcome::Exit);
            }
        }
        Ok(Outcome::Ok)
    }

    /// M2/M30's resets (convert_stop's steps 1 to 10).
    fn program_end(&mut self, f: f64, pallet: bool) -> Res<()> {
        let s = &mut self.s;
        rotate_xy(&mut s.cur, s.rotation_xy);
        for i in 0..6 {
            s.cur[i] += s.origin[i];
        }
        s.origin_index = 1;
        self.params.set_num(5220, 1.0);
        let mut origin = [0.0; 6];
        for (i, o) in origin.iter_mut().enumerate() {
            let v = self.params.num(5221 + i);
            *o = if i < 3 { self.s.user_to_program(v) } else { v };
        }
        let s = &mut self.s;
        s.origin = origin;
        s.rotation_xy = self.params.num(5230);
        for i in 0..6 {
            s.cur[i] -= s.origin[i];
        }
        rotate_xy(&mut s.cur, -s.rotation_xy);
        self.emit(Canon::SetG5xOffset { index: 1, offset: origin })?;
        self.emit(Canon::SetXyRotation(self.s.rotation_xy))?;
        if self.s.plane != Plane::XY {
            self.emit(Canon::SelectPlane(Plane::XY))?;
            self.s.plane = Plane::XY;
        }
        self.s.absolute = true;
        self.s.feed_mode = FeedMode::UnitsPerMinute;
        self.emit(Canon::SetFeedMode { spindle: 0, mode: 0 })?;
        self.s.feed_rate = f;
        self.emit(Canon::SetFeedRate(0.0))?;
        if !self.s.feed_override {
            self.emit(Canon::EnableFeedOverride)?;
            self.s.feed_override = true;
        }
        self.s.comp_side = crate::state::Side::Off;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.s.spindle = Spindle::Stopped;
        self.s.speed_override = true;
        self.emit(Canon::SetSpindleMode { spindle: 0, mode: 0.0 })?;
        self.s.motion_mode = g::G1;
        if self.s.mist {
            self.emit(Canon::MistOff)?;
            self.s.mist = false;
        }
        if self.s.flood {
            self.emit(Canon::FloodOff)?;
            self.s.flood = false;
        }
        if pallet {
            self.emit(Canon::PalletShuttle)?;
        }
        self.emit(Canon::ProgramEnd)
    }
}
