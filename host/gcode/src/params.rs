//! Parameters: the numbered ones (`#1`..`#5601`, LinuxCNC's RS274NGC_MAX_PARAMETERS) and the
//! named ones (`#<name>` local to a subroutine call level, `#<_name>` global), with rs274ngc's
//! read-only and predefined parameters.

use crate::diag::{At, Fault, Res};
use crate::messages as msg;
use std::collections::HashMap;

/// Numbered parameters run from 1 to this, exclusive (rs274ngc's RS274NGC_MAX_PARAMETERS).
pub const MAX_PARAMETERS: usize = 5602;
/// Subroutine call levels, 0 being the main program (rs274ngc's INTERP_SUB_ROUTINE_LEVELS).
pub const CALL_LEVELS: usize = 10;
/// Arguments a subroutine call passes in `#1`..`#30` (INTERP_SUB_PARAMS).
pub const SUB_PARAMS: usize = 30;

/// Read-only numbered parameters: the current tool (5400..5413) and the current position
/// (5420..5428).
pub fn is_readonly(index: usize) -> bool {
    (5400..=5413).contains(&index) || (5420..=5428).contains(&index)
}

/// What a predefined named parameter reports (rs274ngc's `lookup_named_param`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    Line,
    MotionMode,
    Plane,
    CComp,
    Metric,
    Imperial,
    Absolute,
    Incremental,
    InverseTime,
    UnitsPerMinute,
    UnitsPerRev,
    CoordSystem,
    ToolOffset,
    RetractRPlane,
    RetractOldZ,
    SpindleRpmMode,
    SpindleCssMode,
    IjkAbsoluteMode,
    LatheDiameterMode,
    LatheRadiusMode,
    SpindleOn,
    SpindleCw,
    Mist,
    Flood,
    SpeedOverride,
    FeedOverride,
    AdaptiveFeed,
    FeedHold,
    Feed,
    Rpm,
    CurrentTool,
    CurrentPocket,
    SelectedPocket,
    SelectedTool,
    /// Current position in the active system, axis 0..=8 (X Y Z A B C U V W).
    Axis(u8),
    /// Position without offsets, axis 0..=5.
    AbsAxis(u8),
    Value,
    ValueReturned,
    Task,
    CallLevel,
    RemapLevel,
}

/// The interpreter state the predefined named parameters report.
pub trait Lookups {
    fn lookup(&self, what: Lookup) -> f64;
}

const PREDEFINED: &[(&str, Lookup)] = &[
    ("_line", Lookup::Line),
    ("_motion_mode", Lookup::MotionMode),
    ("_plane", Lookup::Plane),
    ("_ccomp", Lookup::CComp),
    ("_metric", Lookup::Metric),
    ("_imperial", Lookup::Imperial),
    ("_absolute", Lookup::Absolute),
    ("_incremental", Lookup::Incremental),
    ("_inverse_time", Lookup::InverseTime),
    ("_units_per_minute", Lookup::UnitsPerMinute),
    ("_units_per_rev", Lookup::UnitsPerRev),
    ("_coord_system", Lookup::CoordSystem),
    ("_tool_offset", Lookup::ToolOffset),
    ("_retract_r_plane", Lookup::RetractRPlane),
    ("_retract_old_z", Lookup::RetractOldZ),
    ("_spindle_rpm_mode", Lookup::SpindleRpmMode),
    ("_spindle_css_mode", Lookup::SpindleCssMode),
    ("_ijk_absolute_mode", Lookup::IjkAbsoluteMode),
    ("_lathe_diameter_mode", Lookup::LatheDiameterMode),
    ("_lathe_radius_mode", Lookup::LatheRadiusMode),
    ("_spindle_on", Lookup::SpindleOn),
    ("_spindle_cw", Lookup::SpindleCw),
    ("_mist", Lookup::Mist),
    ("_flood", Lookup::Flood),
    ("_speed_override", Lookup::SpeedOverride),
    ("_feed_override", Lookup::FeedOverride),
    ("_adaptive_feed", Lookup::AdaptiveFeed),
    ("_feed_hold", Lookup::FeedHold),
    ("_feed", Lookup::Feed),
    ("_rpm", Lookup::Rpm),
    ("_current_tool", Lookup::CurrentTool),
    ("_current_pocket", Lookup::CurrentPocket),
    ("_selected_pocket", Lookup::SelectedPocket),
    ("_selected_tool", Lookup::SelectedTool),
    ("_x", Lookup::Axis(0)),
    ("_y", Lookup::Axis(1)),
    ("_z", Lookup::Axis(2)),
    ("_a", Lookup::Axis(3)),
    ("_b", Lookup::Axis(4)),
    ("_c", Lookup::Axis(5)),
    ("_u", Lookup::Axis(6)),
    ("_v", Lookup::Axis(7)),
    ("_w", Lookup::Axis(8)),
    ("_abs_x", Lookup::AbsAxis(0)),
    ("_abs_y", Lookup::AbsAxis(1)),
    ("_abs_z", Lookup::AbsAxis(2)),
    ("_abs_a", Lookup::AbsAxis(3)),
    ("_abs_b", Lookup::AbsAxis(4)),
    ("_abs_c", Lookup::AbsAxis(5)),
    ("_value", Lookup::Value),
    ("_value_returned", Lookup::ValueReturned),
    ("_task", Lookup::Task),
    ("_call_level", Lookup::CallLevel),
    ("_remap_level", Lookup::RemapLevel),
];

/// LinuxCNC's version as `_vmajor`/`_vminor` report it for the reference build (2.9.0~pre1).
pub const VMAJOR: f64 = 2.9;
pub const VMINOR: f64 = 0.0;

#[derive(Clone, Debug, PartialEq)]
struct Named {
    value: f64,
    readonly: bool,
    lookup: Option<Lookup>,
}

/// All parameters.
#[derive(Clone, Debug)]
pub struct Params {
    numbered: Vec<f64>,
    /// Named parameters per call level; level 0 also holds the globals.
    named: Vec<HashMap<String, Named>>,
}

impl Default for Params {
    fn default() -> Self {
        Params::new(&[])
    }
}

impl Params {
    /// Numbered parameters from `(index, value)` pairs (a LinuxCNC `.var` file), the rest 0;
    /// the predefined named parameters.
    pub fn new(initial: &[(usize, f64)]) -> Self {
        let mut numbered = vec![0.0; MAX_PARAMETERS];
        for &(i, v) in initial {
            if i < MAX_PARAMETERS {
                numbered[i] = v;
            }
        }
        let mut globals = HashMap::new();
        let mut put = |name: &str, value: f64, lookup| {
            globals.insert(name.to_string(), Named { value, readonly: true, lookup });
        };
        put("_vmajor", VMAJOR, None);
        put("_vminor", VMINOR, None);
        // No INI file: rs274's inicheck() reports -1.
        put("_metric_machine", -1.0, None);
        for &(name, l) in PREDEFINED {
            put(name, 0.0, Some(l));
        }
        let mut named = vec![HashMap::new(); CALL_LEVELS];
        named[0] = globals;
        Params { numbered, named }
    }

    /// `#index` with rs274's range check.
    pub fn get(&self, index: i32) -> Res<f64> {
        match usize::try_from(index) {
            Ok(i) if (1..MAX_PARAMETERS).contains(&i) => Ok(self.numbered[i]),
            _ => Err(Fault::line(msg::PARAMETER_OUT_OF_RANGE)),
        }
    }

    /// Direct access for the interpreter's own bookkeeping (no range or read-only checks).
    pub fn num(&self, index: usize) -> f64 {
        self.numbered[index]
    }

    pub fn set_num(&mut self, index: usize, value: f64) {
        self.numbered[index] = value;
    }

    fn level_of(name: &str, call_level: usize) -> usize {
        if name.starts_with('_') {
            0
        } else {
            call_level.min(CALL_LEVELS - 1)
        }
    }

    /// `find_named_param`: the value, or `None` when the name does not exist at its scope.
    pub fn find_named(&self, name: &str, call_level: usize, st: &dyn Lookups) -> Option<f64> {
        let p = self.named[Self::level_of(name, call_level)].get(name)?;
        Some(match p.lookup {
            Some(l) => st.lookup(l),
            None => p.value,
        })
    }

    /// `add_named_param`: creates the name (value 0) at its scope unless it exists.
    pub fn add_named(&mut self, name: &str, call_level: usize) {
        let level = Self::level_of(name, call_level);
        self.named[level].entry(name.to_string()).or_insert(Named {
            value: 0.0,
            readonly: false,
            lookup: None,
        });
    }

    /// `store_named_param`.
    pub fn store_named(&mut self, name: &str, value: f64, call_level: usize) -> Res<()> {
        let level = Self::level_of(name, call_level);
        match self.named[level].get_mut(name) {
            None => Err(Fault::line(format!("Internal error: Could not assign #<{name}>"))),
            Some(p) if p.readonly => {
                Err(Fault::new(format!("Cannot assign to read-only parameter #<{name}>"), At::Line))
            }
            Some(p) => {
                p.value = value;
                Ok(())
            }
        }
    }

    /// Drops the named parameters of a call level (on return from a subroutine).
    pub fn clear_level(&mut self, level: usize) {
        if level > 0 && level < CALL_LEVELS {
            self.named[level].clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoState;
    impl Lookups for NoState {
        fn lookup(&self, what: Lookup) -> f64 {
            match what {
                Lookup::Line => 7.0,
                _ => 0.0,
            }
        }
    }

    #[test]
    fn named_parameters_scope_by_leading_underscore() {
        let mut p = Params::default();
        p.add_named("depth", 1);
        p.store_named("depth", 2.5, 1).unwrap();
        assert_eq!(p.find_named("depth", 1, &NoState), Some(2.5));
        assert_eq!(p.find_named("depth", 0, &NoState), None);
        p.add_named("_g", 1);
        p.store_named("_g", 4.0, 1).unwrap();
        assert_eq!(p.find_named("_g", 0, &NoState), Some(4.0));
        assert_eq!(p.find_named("_line", 3, &NoState), Some(7.0));
        assert!(p.store_named("_vmajor", 1.0, 0).is_err());
        p.clear_level(1);
        assert_eq!(p.find_named("depth", 1, &NoState), None);
    }

    #[test]
    fn numbered_parameters_check_their_range() {
        let p = Params::new(&[(5220, 1.0)]);
        assert_eq!(p.get(5220).unwrap(), 1.0);
        assert!(p.get(0).is_err());
        assert!(p.get(5602).is_err());
        assert!(is_readonly(5420) && !is_readonly(5419));
    }
}
