//! A milling job for the constant-force loop: Fnom, thresholds, gains and the impact strategy,
//! plus the cut the simulation runs them against (eq 4.17 plant, a depth step). TOML, version 1:
//!
//! ```toml
//! version = 1
//! [force]
//! fnom_n = 4100          # nominal force
//! contact_n = 45         # tool in the cut above this
//! trip_n = 18000         # feed hold + ForceTrip above this
//! kp_dec = 0.5           # P gain while F > Fnom (faster down) ...
//! kp_inc = 0.5           # ... and while F < Fnom
//! ki_dec_per_s = 40
//! ki_inc_per_s = 20
//! strategy = "direct"    # impact strategy: "direct", "a" (slow, hold, PI), "b" (stop, reduced gain)
//! [cut]
//! k_n_per_mm3 = 205      # eq 4.17 force coefficient
//! a_mm = 20              # radial depth
//! b_before_mm = 2.5      # axial depth, then its step
//! b_after_mm = 10
//! step_at_mm = 10        # penetration where it steps
//! ```
//!
//! The machine (one X axis, 1 um per step, 12.7 mm/s rapid, 500 mm/s^2), spindle (500 rpm, four
//! teeth) and force sensors are those of the Case A scenario (`motion::force::scenario`).

use motion::force::control::{ContactStrategy, ControlParams};
use motion::force::plant::PlantParams;
use motion::force::scenario::{control_params, plant_params};
use motion::segment::Rate;
use serde::Deserialize;

#[derive(Debug, thiserror::Error)]
pub enum MillingJobError {
    #[error("{0}")]
    Toml(String),
    #[error("unsupported milling job version {0} (this motionctl reads version 1)")]
    Version(u32),
    #[error("{field} = {value}: {why}")]
    Field { field: &'static str, value: f64, why: &'static str },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    version: u32,
    force: Force,
    cut: Cut,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Force {
    fnom_n: f64,
    contact_n: f64,
    trip_n: f64,
    kp_dec: f64,
    kp_inc: f64,
    ki_dec_per_s: f64,
    ki_inc_per_s: f64,
    #[serde(default = "direct")]
    strategy: String,
}

fn direct() -> String {
    "direct".into()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cut {
    k_n_per_mm3: f64,
    a_mm: f64,
    b_before_mm: f64,
    b_after_mm: f64,
    step_at_mm: f64,
}

/// A parsed milling job: the control setup and the cut, in the firmware's units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MillingJob {
    pub control: ControlParams,
    pub plant: PlantParams,
}

fn scaled(field: &'static str, value: f64, scale: f64, max: f64) -> Result<u32, MillingJobError> {
    if !value.is_finite() || value < 0.0 {
        return Err(MillingJobError::Field { field, value, why: "must be a finite number >= 0" });
    }
    if value > max {
        return Err(MillingJobError::Field { field, value, why: "too large" });
    }
    Ok((value * scale).round() as u32)
}

/// Parses a milling job; every field is checked, and the control law's own checks (contact <
/// nominal < trip, ...) run when the simulation builds it.
pub fn parse(src: &str) -> Result<MillingJob, MillingJobError> {
    let f: File = toml::from_str(src).map_err(|e| MillingJobError::Toml(e.to_string()))?;
    if f.version != 1 {
        return Err(MillingJobError::Version(f.version));
    }
    let q16 = 65_536.0;
    let mut control = control_params(0);
    control.fnom_mn = scaled("force.fnom_n", f.force.fnom_n, 1e3, 4e6)?;
    control.contact_mn = scaled("force.contact_n", f.force.contact_n, 1e3, 4e6)?;
    control.trip_mn = scaled("force.trip_n", f.force.trip_n, 1e3, 4e6)?;
    control.kp_dec_q16 = scaled("force.kp_dec", f.force.kp_dec, q16, 100.0)?;
    control.kp_inc_q16 = scaled("force.kp_inc", f.force.kp_inc, q16, 100.0)?;
    control.ki_dec_per_s_q16 = scaled("force.ki_dec_per_s", f.force.ki_dec_per_s, q16, 10_000.0)?;
    control.ki_inc_per_s_q16 = scaled("force.ki_inc_per_s", f.force.ki_inc_per_s, q16, 10_000.0)?;
    control.contact = match f.force.strategy.as_str() {
        "direct" => ContactStrategy::Direct,
        // The thesis's settings (src/force/scenario.rs).
        "a" => ContactStrategy::SlowHold { slow: Rate::lit("0.01"), hold_ms: 100 },
        "b" => ContactStrategy::StopReduced {
            stop_ms: 40,
            reduced_ms: 100,
            reduced_gain_q16: (1 << 16) / 3,
        },
        _ => {
            return Err(MillingJobError::Field {
                field: "force.strategy",
                value: f64::NAN,
                why: "must be \"direct\", \"a\" or \"b\"",
            })
        }
    };
    let mut plant = plant_params();
    plant.k_n_per_mm3 = scaled("cut.k_n_per_mm3", f.cut.k_n_per_mm3, 1.0, 100_000.0)?;
    plant.a_um = scaled("cut.a_mm", f.cut.a_mm, 1e3, 1e3)?;
    plant.b_before_um = scaled("cut.b_before_mm", f.cut.b_before_mm, 1e3, 1e3)?;
    plant.b_after_um = scaled("cut.b_after_mm", f.cut.b_after_mm, 1e3, 1e3)?;
    plant.step_at_um = scaled("cut.step_at_mm", f.cut.step_at_mm, 1e3, 1e3)?;
    Ok(MillingJob { control, plant })
}
