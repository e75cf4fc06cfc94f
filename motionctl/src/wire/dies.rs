//! The dies `motionctl wire plan|run` can cut (`--die NAME` or `--mdi FILE`): the thesis's
//! plates with their thickness, feed and start point (seed L5231-5579, Tables 11 and 12), and
//! user dies from MDI data files ([`super::csv::parse_mdi`]).
//!
//! Every die becomes a [`Path`] from its start point, through its points, back to the start
//! (the thesis starts and ends 3-D dies at the workpiece centre, the gear at (0, -60) mm).

use super::gear::{gear_profile, gear_terms, GearSpec};
use super::path::Path;
use super::shapes::{
    circle_arcs, circle_for_crescent, circle_uniform, complex, crescent, prismatic,
};
use super::{Die, Point2, Result, WireError};

/// A die of the thesis (also `motionctl wire --die NAME`: the doc lines are its help).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ThesisDie {
    /// Plate 4 / Table 11: top circle R 25 (the thesis's arc multipliers), bottom complex shape
    /// RI 20, N 80, ZT 39 mm, FR 800 mm^2/min. The default of `wire plan|run`.
    CircleComplex,
    /// Plate 9: circle R 25 over circle R 20, both from 45 deg, N 80, ZT 49, FR 800.
    Plate9,
    /// Plate 10: square 50 over square 30 with the thesis's `INT()` spacing, N 80, ZT 49, FR 800.
    Plate10,
    /// Plate 16: circle R 20 over crescent R 15, N 60, ZT 49, FR 800.
    Plate16,
    /// Plate 19 (a tapered die) stage 1: R 3.5 over R 3.5, N 60, ZT 49, FR 400.
    Plate19Stage1,
    /// Plate 19 stage 2: R 15 over R 2, the bottom circle from 180 deg, N 60, ZT 49, FR 500.
    Plate19Stage2,
    /// Plate 19 stage 3: R 18 over R 10, the bottom circle from 180 deg, N 60, ZT 49, FR 500.
    Plate19Stage3,
    /// Table 12: Unwin spur gear m 6, PD 72 (12 teeth), PA 20 deg, 8 points per flank, ZT 30,
    /// FR 500, from and back to (0, -60).
    Gear,
}

impl ThesisDie {
    /// Every thesis die, the default first.
    pub const ALL: [ThesisDie; 8] = [
        ThesisDie::CircleComplex,
        ThesisDie::Plate9,
        ThesisDie::Plate10,
        ThesisDie::Plate16,
        ThesisDie::Plate19Stage1,
        ThesisDie::Plate19Stage2,
        ThesisDie::Plate19Stage3,
        ThesisDie::Gear,
    ];
}

/// Parameters a user may override (`None` keeps the thesis's value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DieOverrides {
    /// Workpiece thickness ZT, mm (any die; for an MDI file it replaces the file's ZT).
    pub zt_mm: Option<f64>,
    /// Start and end point of the wire on the workpiece, mm.
    pub start: Option<Point2>,
    /// Gear only: module, mm.
    pub module_mm: Option<f64>,
    /// Gear only: number of teeth (pitch diameter = module x teeth); not with `pitch_diameter_mm`.
    pub teeth: Option<u32>,
    /// Gear only: pitch circle diameter, mm.
    pub pitch_diameter_mm: Option<f64>,
    /// Gear only: pressure angle, deg.
    pub pressure_angle_deg: Option<f64>,
}

/// A die ready to plan.
#[derive(Clone, Debug, PartialEq)]
pub struct DieJob {
    /// What it is, e.g. "circle -> complex" (the title is this plus " die").
    pub label: String,
    pub die: Die,
    /// Where the wire starts and ends on the workpiece.
    pub start: Point2,
    /// The thesis's area rate for this die (the default of `--fr`), mm^2/min.
    pub fr_mm2_per_min: f64,
}

impl DieJob {
    /// The machining path: start, the die's points, start.
    pub fn path(&self) -> Result<Path> {
        Path::from_home(&self.die, self.start)
    }
}

/// Clearance of the gear's start point outside the addendum circle, mm: the thesis's (0, -60)
/// for its 42 mm addendum radius.
const GEAR_START_CLEARANCE_MM: f64 = 18.0;

fn only_gear(o: &DieOverrides) -> Result<()> {
    for (name, v) in [
        ("module_mm", o.module_mm),
        ("teeth", o.teeth.map(f64::from)),
        ("pitch_diameter_mm", o.pitch_diameter_mm),
        ("pressure_angle_deg", o.pressure_angle_deg),
    ] {
        if let Some(value) = v {
            return Err(WireError::BadParameter {
                name,
                value,
                reason: "applies to the gear die only",
            });
        }
    }
    Ok(())
}

/// The gear of `o` (Table 12's unless overridden).
pub fn gear_spec(o: &DieOverrides) -> Result<GearSpec> {
    let module_mm = o.module_mm.unwrap_or(6.0);
    let pitch_diameter_mm = match (o.teeth, o.pitch_diameter_mm) {
        (Some(_), Some(pd)) => {
            return Err(WireError::BadParameter {
                name: "pitch_diameter_mm",
                value: pd,
                reason: "give the number of teeth or the pitch diameter, not both",
            });
        }
        (Some(t), None) => module_mm * f64::from(t),
        (None, Some(pd)) => pd,
        // Table 12 has 12 teeth; a changed module keeps the tooth count.
        (None, None) => module_mm * 12.0,
    };
    Ok(GearSpec {
        module_mm,
        pitch_diameter_mm,
        pressure_angle_deg: o.pressure_angle_deg.unwrap_or(20.0),
    })
}

/// The thesis die `kind` with the overrides `o`.
pub fn thesis_die(kind: ThesisDie, o: &DieOverrides) -> Result<DieJob> {
    use ThesisDie::*;
    if kind != Gear {
        only_gear(o)?;
    }
    let zt = |thesis_mm: f64| o.zt_mm.unwrap_or(thesis_mm);
    let centre = Point2::default();
    let (label, zt_mm, top, bottom, start, fr) = match kind {
        CircleComplex => (
            "circle -> complex".to_string(),
            zt(39.0),
            circle_arcs(25.0, 80)?,
            complex(20.0, 80)?,
            centre,
            800.0,
        ),
        Plate9 => (
            "plate 9: circle R 25 -> circle R 20".to_string(),
            zt(49.0),
            circle_uniform(25.0, 80, 45.0)?,
            circle_uniform(20.0, 80, 45.0)?,
            centre,
            800.0,
        ),
        Plate10 => (
            "plate 10: square 50 -> square 30".to_string(),
            zt(49.0),
            prismatic(50.0, 50.0, 80, true)?,
            prismatic(30.0, 30.0, 80, true)?,
            centre,
            800.0,
        ),
        Plate16 => (
            "plate 16: circle R 20 -> crescent R 15".to_string(),
            zt(49.0),
            circle_for_crescent(20.0, 60)?,
            crescent(15.0, 60)?,
            centre,
            800.0,
        ),
        Plate19Stage1 | Plate19Stage2 | Plate19Stage3 => {
            let (stage, rt, rb, b0, fr) = match kind {
                Plate19Stage1 => (1, 3.5, 3.5, 0.0, 400.0),
                Plate19Stage2 => (2, 15.0, 2.0, 180.0, 500.0),
                _ => (3, 18.0, 10.0, 180.0, 500.0),
            };
            (
                format!("plate 19 stage {stage}: circle R {rt} -> circle R {rb}"),
                zt(49.0),
                circle_uniform(rt, 60, 0.0)?,
                circle_uniform(rb, 60, b0)?,
                centre,
                fr,
            )
        }
        Gear => {
            let spec = gear_spec(o)?;
            let g = gear_terms(spec)?;
            let start_y = -(g.outside_diameter_mm / 2.0 + GEAR_START_CLEARANCE_MM).max(60.0);
            let start = Point2::new(0.0, start_y);
            let p = gear_profile(spec, 8, 4, 5, start)?;
            // gear_profile runs start, profile, start; the path adds the start itself.
            let face = p.get(1..p.len().saturating_sub(1)).unwrap_or_default().to_vec();
            (
                format!(
                    "spur gear m {} x {} teeth (PD {}, PA {} deg)",
                    spec.module_mm, g.teeth, spec.pitch_diameter_mm, spec.pressure_angle_deg
                ),
                zt(30.0),
                face.clone(),
                face,
                start,
                500.0,
            )
        }
    };
    Ok(DieJob {
        label,
        die: Die::new(zt_mm, top, bottom)?,
        start: o.start.unwrap_or(start),
        fr_mm2_per_min: fr,
    })
}

/// A user die from an MDI data file's text (`name` labels it): from and back to the centre
/// (or `o.start`), at the default feed 800 mm^2/min. Errors name the file's line.
pub fn mdi_die(name: &str, text: &str, o: &DieOverrides) -> Result<DieJob> {
    only_gear(o)?;
    let mut die = super::csv::parse_mdi(text)?;
    if let Some(zt) = o.zt_mm {
        die = Die::new(zt, die.top, die.bottom)?;
    }
    Ok(DieJob {
        label: format!("MDI file {name}"),
        die,
        start: o.start.unwrap_or_default(),
        fr_mm2_per_min: 800.0,
    })
}

/// A user die from two drawn contours ([`super::cad::pair`]): from and back to the centre (or
/// `o.start`), at the default feed 800 mm^2/min. `o.zt_mm` is required (the drawings carry no
/// thickness).
pub fn contour_die(pair: &super::cad::ContourPair, o: &DieOverrides) -> Result<DieJob> {
    only_gear(o)?;
    Ok(DieJob {
        label: format!("contours {} -> {}", pair.top.source, pair.bottom.source),
        die: pair.die.clone(),
        start: o.start.unwrap_or_default(),
        fr_mm2_per_min: 800.0,
    })
}
