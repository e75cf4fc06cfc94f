//! The G-codes of a block (rs274ngc's `convert_g`): dwell, plane, units, modes and motion.

use crate::block::Block;
use crate::canon::{Canon, MotionControl, Plane};
use crate::core::Core;
use crate::diag::{check, fail, At, Res};
use crate::messages as msg;
use crate::modal::{g, group};

impl Core {
    pub(super) fn convert_g(&mut self, b: &mut Block) -> Res<()> {
        if b.g_modes[group::MODAL_0] == g::G4 {
            self.emit(Canon::Dwell(b.p_number))?;
        }
        if b.g_modes[group::PLANE] != -1 {
            self.convert_set_plane(b.g_modes[group::PLANE])?;
        }
        if b.g_modes[group::UNITS] != -1 {
            self.convert_length_units(b.g_modes[group::UNITS])?;
        }
        if b.g_modes[group::LATHE_DIAMETER] != -1 {
            self.convert_lathe_diameter_mode(b)?;
        }
        if b.g_modes[group::CUTTER_COMP] != -1 {
            self.convert_cutter_compensation(b)?;
        }
        if b.g_modes[group::TOOL_LENGTH] != -1 {
            self.convert_tool_length_offset(b.g_modes[group::TOOL_LENGTH], b)?;
        }
        if b.g_modes[group::COORD_SYSTEM] != -1 {
            self.convert_coordinate_system(b.g_modes[group::COORD_SYSTEM])?;
        }
        if b.g_modes[group::CONTROL] != -1 {
            self.convert_control_mode(b.g_modes[group::CONTROL], b.p_number, b.q_number)?;
        }
        if b.g_modes[group::DISTANCE] != -1 {
            let abs = b.g_modes[group::DISTANCE] == g::G90;
            if self.s.absolute != abs {
                let t = if abs { "absolute" } else { "incremental" };
                self.emit(Canon::Comment(format!("interpreter: distance mode changed to {t}")))?;
                self.s.absolute = abs;
            }
        }
        if b.g_modes[group::IJK_DISTANCE] != -1 {
            let abs = b.g_modes[group::IJK_DISTANCE] == g::G90_1;
            if self.s.ijk_absolute != abs {
                let t = if abs { "absolute" } else { "incremental" };
                self.emit(Canon::Comment(format!(
                    "interpreter: IJK distance mode changed to {t}"
                )))?;
                self.s.ijk_absolute = abs;
            }
        }
        if b.g_modes[group::RETRACT] != -1 {
            check(
                self.s.comp_on(),
                "Cannot change retract mode with cutter radius compensation on",
                At::GGroup(group::RETRACT),
            )?;
            let old_z = b.g_modes[group::RETRACT] == g::G98;
            let t = if old_z { "old_z" } else { "r_plane" };
            self.emit(Canon::Comment(format!("interpreter: retract mode set to {t}")))?;
            self.s.retract_old_z = old_z;
        }
        if b.g_modes[group::MODAL_0] != -1 {
            self.convert_modal_0(b.g_modes[group::MODAL_0], b)?;
        }
        if b.g_modes[group::G92_APPLIED] != -1 {
            self.convert_axis_offsets(b.g_modes[group::G92_APPLIED], b)?;
        }
        if b.motion_to_be != -1 {
            self.convert_motion(b.motion_to_be, b)?;
        }
        Ok(())
    }

    fn convert_modal_0(&mut self, code: i32, b: &mut Block) -> Res<()> {
        match code {
            g::G10 => match b.l_number {
                1 | 10 | 11 => self.convert_setup_tool(b),
                0 => {
                    let tno = self.s.tools.entries[0].toolno;
                    if tno > 0 {
                        return fail(format!("G10 L0 not allowed with loaded tool <{tno}>\n"));
                    }
                    self.s.toolchange_flag = true;
                    self.emit(Canon::ReloadTooldata)
                }
                _ => self.convert_setup(b),
            },
            g::G28 | g::G30 => self.convert_home(code, b),
            g::G28_1 | g::G30_1 => self.convert_savehome(code),
            g::G52 | g::G92 => self.convert_axis_offsets(code, b),
            g::G5_3 => self.convert_nurbs(code, b),
            _ => Ok(()),
        }
    }

    fn convert_set_plane(&mut self, code: i32) -> Res<()> {
        let at = At::GGroup(group::PLANE);
        let comp = self.s.comp_on();
        let pl = self.s.plane;
        check(comp && code == g::G17 && pl != Plane::XY, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G18 && pl != Plane::XZ, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G19 && pl != Plane::YZ, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G19, msg::COMP_ONLY_XY_XZ, at)?;
        let plane = match code {
            g::G17 => Plane::XY,
            g::G18 => Plane::XZ,
            g::G19 => Plane::YZ,
            g::G17_1 => Plane::UV,
            g::G18_1 => Plane::UW,
            _ => Plane::VW,
        };
        self.emit(Canon::SelectPlane(plane))?;
        self.s.plane = plane;
        Ok(())
    }

    fn convert_control_mode(&mut self, code: i32, p: f64, q: f64) -> Res<()> {
        check(
            self.s.comp_on(),
            "Cannot change control mode with cutter radius compensation on",
            At::GGroup(group::CONTROL),
        )?;
        match code {
            g::G61 => {
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::ExactPath,
                    tolerance: 0.0,
                })?;
                self.s.control = MotionControl::ExactPath;
            }
            g::G61_1 => {
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::ExactStop,
                    tolerance: 0.0,
                })?;
                self.s.control = MotionControl::ExactStop;
            }
            _ => {
                let tolerance = if p >= 0.0 { p } else { 0.0 };
                self.s.control = MotionControl::Continuous;
                self.s.tolerance = tolerance;
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::Continuous,
                    tolerance,
                })?;
                let naive = if q >= 0.0 {
                    q
                } else if p >= 0.0 {
                    p
                } else {
                    0.0
                };
                self.s.naivecam_tolerance = naive;
                self.emit(Canon::SetNaivecamTolerance(naive))?;
            }
        }
        Ok(())
    }

    fn convert_lathe_diameter_mode(&mut self, b: &mut Block) -> Res<()> {
        let code = b.g_modes[group::LATHE_DIAMETER];
        if code == g::G7 && !self.s.lathe_diameter {
            if let Some(x) = b.x.as_mut() {
                *x /= 2.0;
            }
            self.emit(Canon::Comment(
                "interpreter: Lathe diameter mode changed to diameter".into(),
            ))?;
            self.s.lathe_diameter = true;
        } else if code == g::G8 && self.s.lathe_diameter {
            if let Some(x) = b.x.as_mut() {
                *x *= 2.0;
            }
            self.emit(Canon::Comment("interpreter: Lathe diameter mode changed to radius".into()))?;
            self.s.lathe_diameter = false;
        }
        Ok(())
    }
}
