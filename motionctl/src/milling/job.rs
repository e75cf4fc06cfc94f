//! A milling job for the constant-force loop: the nominal force, thresholds, gains and impact
//! strategy, the spindle and cutter, and the cut the simulation (or a simulator board) runs them
//! against (eq 4.17's plant with a depth step). TOML, version 2:
//!
//! ```toml
//! version = 2
//! name = "slot, 2.5 -> 10 mm"  # optional: the plots' and summaries' title [default: the file]
//! [force]
//! fnom_n = 4100          # nominal force, N
//! contact_n = 45         # tool in the cut above this, N
//! trip_n = 18000         # feed hold + ForceTrip above this, N
//! kp_dec = 0.5           # P gain while F > Fnom (faster down) ...
//! kp_inc = 0.5           # ... and while F < Fnom
//! ki_dec_per_s = 40      # I gains, 1/s
//! ki_inc_per_s = 20
//! strategy = "direct"    # impact strategy: "direct", "a" (slow, hold, PI), "b" (stop, reduced gain)
//! [spindle]
//! rpm = 500
//! min_rpm = 120          # optional: below it the feed holds (SpindleStopped) [default: rpm / 4]
//! [cutter]
//! diameter_mm = 20
//! teeth = 4
//! feed_per_tooth_mm = 0.381  # the programmed feed f_t z N (override 1.0): here 762 mm/min
//! [cut]
//! kc_n_per_mm2 = 4100    # cutting constant: force per mm^2 of chip (axial depth x chip per
//!                        # tooth); eq 4.17's K a = 205 N/mm^3 x 20 mm
//! b_before_mm = 2.5      # axial depth, then its step
//! b_after_mm = 10
//! step_at_mm = 10        # penetration where it steps
//! ```
//!
//! The machine is the Case A scenario's (`motion::milling::scenario`): one X axis, 1 um per step,
//! 500 mm/s^2, the tool starting 2 mm before the wall; the force chain is its 3-channel 12-bit
//! dynamometer (9.77 N per count) at 10 kHz, the control law at 2 kHz.

use motion::milling::control::{ContactStrategy, ControlParams};
use motion::milling::scenario::{
    chain_config, control_params, plant_params, MillingSetup, TICK_HZ, WALL_STEPS,
};
use motion::segment::Rate;
use serde::Deserialize;

#[derive(Debug, thiserror::Error)]
pub enum MillingJobError {
    #[error("{0}")]
    Toml(String),
    #[error(
        "unsupported milling job version {0}: this motionctl reads version 2 (version 1 fixed \
         the spindle at 500 rpm and 4 teeth: add [spindle] rpm, [cutter] diameter_mm, teeth, \
         feed_per_tooth_mm, and give [cut] kc_n_per_mm2 = k_n_per_mm3 x a_mm)"
    )]
    Version(u32),
    #[error("{field} = {value}: must be {range}")]
    Field { field: &'static str, value: f64, range: String },
    #[error("{0}")]
    Relation(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    version: u32,
    name: Option<String>,
    force: Force,
    spindle: Spindle,
    cutter: Cutter,
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
struct Spindle {
    rpm: f64,
    min_rpm: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cutter {
    diameter_mm: f64,
    teeth: i64,
    feed_per_tooth_mm: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cut {
    kc_n_per_mm2: f64,
    b_before_mm: f64,
    b_after_mm: f64,
    step_at_mm: f64,
}

/// A parsed milling job: the loop's setup in the firmware's units and the job's own numbers
/// in user units (for the summaries).
#[derive(Clone, Debug, PartialEq)]
pub struct MillingJob {
    pub name: String,
    pub setup: MillingSetup,
    pub strategy: String,
    pub fnom_n: f64,
    pub contact_n: f64,
    pub trip_n: f64,
    pub spindle_rpm: f64,
    pub min_spindle_rpm: f64,
    pub teeth: u32,
    pub cutter_diameter_mm: f64,
    pub feed_per_tooth_mm: f64,
    pub kc_n_per_mm2: f64,
    pub b_before_mm: f64,
    pub b_after_mm: f64,
    pub step_at_mm: f64,
}

impl MillingJob {
    /// The programmed feed (override 1.0): `f_t z N`, mm/min.
    pub fn programmed_feed_mm_min(&self) -> f64 {
        self.feed_per_tooth_mm * self.teeth as f64 * self.spindle_rpm
    }

    /// Tooth period `tau = 1 / (z N)`, s.
    pub fn tooth_period_s(&self) -> f64 {
        60.0 / (self.teeth as f64 * self.spindle_rpm)
    }

    /// Cutting speed `pi d N`, m/min.
    pub fn cutting_speed_m_min(&self) -> f64 {
        std::f64::consts::PI * self.cutter_diameter_mm * self.spindle_rpm / 1000.0
    }

    /// X steps from the start to the depth step (the wall is [`WALL_STEPS`] ahead).
    pub fn step_at_steps(&self) -> i64 {
        self.setup.plant.wall_steps
            + (self.setup.plant.step_at_um as i64 * 1000) / self.setup.plant.nm_per_step as i64
    }
}

/// Limits of the simulated machine and force chain the job runs on.
pub mod limits {
    /// The X axis: 1 um per step at most 20 000 steps/s, less the planner's margin.
    pub const MAX_FEED_MM_MIN: f64 = 1080.0;
    pub const MIN_FEED_MM_MIN: f64 = 6.0;
    /// The force chain's range: 2047 counts of 9.77 N on a channel.
    pub const MAX_FORCE_N: f64 = 20_000.0;
    /// Tooth period: at least one control update (0.5 ms at 2 kHz), at most the plant's tooth
    /// delay line (1023 samples at 10 kHz).
    pub const MIN_TOOTH_PERIOD_S: f64 = 0.0005;
    pub const MAX_TOOTH_PERIOD_S: f64 = 0.1023;
    pub const MAX_TEETH: i64 = 64;
    pub const MAX_RPM: f64 = 60_000.0;
    pub const MAX_DEPTH_MM: f64 = 1000.0;
    pub const MAX_KC_N_PER_MM2: f64 = 100_000.0;
    pub const MAX_DIAMETER_MM: f64 = 1000.0;
    /// Travel after the depth step: at least this, and long enough for the settling window at
    /// the steady feed.
    pub const MIN_AFTER_STEP_MM: f64 = 3.0;
    pub const AFTER_STEP_S: f64 = 0.6;
    /// Longest move, in machine time at the steady feeds (the host model simulates it).
    pub const MAX_MACHINE_S: f64 = 120.0;
}

/// `value` checked against `lo..=hi` (`lo` excluded when `lo_open`), in `unit`.
fn check(
    field: &'static str,
    value: f64,
    (lo, lo_open): (f64, bool),
    hi: f64,
    unit: &str,
) -> Result<f64, MillingJobError> {
    let low_ok = if lo_open { value > lo } else { value >= lo };
    if value.is_finite() && low_ok && value <= hi {
        Ok(value)
    } else {
        let range = format!(
            "a finite number within {}{lo}, {hi}]{}{unit}",
            if lo_open { "(" } else { "[" },
            if unit.is_empty() { "" } else { " " }
        );
        Err(MillingJobError::Field { field, value, range })
    }
}

fn contact_strategy(name: &str) -> Result<ContactStrategy, MillingJobError> {
    Ok(match name {
        "direct" => ContactStrategy::Direct,
        // The thesis's settings (src/milling/scenario.rs).
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
                range: "\"direct\", \"a\" or \"b\"".into(),
            })
        }
    })
}

/// The control law's setup: thresholds, gains, strategy, the feed at override 1.0.
fn control(
    f: &Force,
    feed_steps_per_s: u32,
    min_mrev_s: u32,
) -> Result<ControlParams, MillingJobError> {
    use limits::MAX_FORCE_N;
    let fnom = check("force.fnom_n", f.fnom_n, (0.0, true), MAX_FORCE_N, "N")?;
    let contact = check("force.contact_n", f.contact_n, (0.0, true), fnom, "N")?;
    let trip = check("force.trip_n", f.trip_n, (fnom, true), MAX_FORCE_N, "N")?;
    if contact >= fnom {
        return Err(MillingJobError::Relation(format!(
            "force.contact_n = {contact} must be below force.fnom_n = {fnom}"
        )));
    }
    let q16 = |field, v: f64, hi: f64, unit| -> Result<u32, MillingJobError> {
        Ok((check(field, v, (0.0, false), hi, unit)? * 65_536.0).round() as u32)
    };
    let mut c = control_params(0);
    c.fnom_mn = (fnom * 1e3).round() as u32;
    c.contact_mn = (contact * 1e3).round() as u32;
    c.trip_mn = (trip * 1e3).round() as u32;
    c.kp_dec_q16 = q16("force.kp_dec", f.kp_dec, 100.0, "")?;
    c.kp_inc_q16 = q16("force.kp_inc", f.kp_inc, 100.0, "")?;
    c.ki_dec_per_s_q16 = q16("force.ki_dec_per_s", f.ki_dec_per_s, 10_000.0, "1/s")?;
    c.ki_inc_per_s_q16 = q16("force.ki_inc_per_s", f.ki_inc_per_s, 10_000.0, "1/s")?;
    c.contact = contact_strategy(&f.strategy)?;
    c.steps_per_s_at_one = feed_steps_per_s;
    c.min_spindle_mrev_s = min_mrev_s;
    Ok(c)
}

/// Parses a milling job; every field is checked against its range (naming the field), and
/// the relations between them (contact < nominal < trip, the tooth period, the feed).
pub fn parse(src: &str) -> Result<MillingJob, MillingJobError> {
    use limits::*;
    let version: Option<u32> = toml::from_str::<toml::Table>(src)
        .ok()
        .and_then(|t| t.get("version").and_then(|v| v.as_integer()))
        .and_then(|v| u32::try_from(v).ok());
    if let Some(v) = version.filter(|&v| v != 2) {
        return Err(MillingJobError::Version(v));
    }
    let f: File = toml::from_str(src).map_err(|e| MillingJobError::Toml(e.to_string()))?;
    if f.version != 2 {
        return Err(MillingJobError::Version(f.version));
    }
    let rpm = check("spindle.rpm", f.spindle.rpm, (0.0, true), MAX_RPM, "rpm")?;
    let min_rpm = match f.spindle.min_rpm {
        Some(v) => check("spindle.min_rpm", v, (0.0, false), rpm, "rpm")?,
        None => rpm / 4.0,
    };
    if f.cutter.teeth < 1 || f.cutter.teeth > MAX_TEETH {
        return Err(MillingJobError::Field {
            field: "cutter.teeth",
            value: f.cutter.teeth as f64,
            range: format!("a whole number within [1, {MAX_TEETH}]"),
        });
    }
    let teeth = f.cutter.teeth as u32;
    let d = check("cutter.diameter_mm", f.cutter.diameter_mm, (0.0, true), MAX_DIAMETER_MM, "mm")?;
    let ft = check("cutter.feed_per_tooth_mm", f.cutter.feed_per_tooth_mm, (0.0, true), d, "mm")?;
    let tau = 60.0 / (teeth as f64 * rpm);
    if !(MIN_TOOTH_PERIOD_S..=MAX_TOOTH_PERIOD_S).contains(&tau) {
        return Err(MillingJobError::Relation(format!(
            "spindle.rpm = {rpm} with cutter.teeth = {teeth}: a tooth period of {:.3} ms; the \
             force chain needs {} .. {} ms (rpm x teeth within {:.0} .. {:.0})",
            tau * 1e3,
            MIN_TOOTH_PERIOD_S * 1e3,
            MAX_TOOTH_PERIOD_S * 1e3,
            60.0 / MAX_TOOTH_PERIOD_S,
            60.0 / MIN_TOOTH_PERIOD_S
        )));
    }
    let feed = ft * teeth as f64 * rpm;
    if !(MIN_FEED_MM_MIN..=MAX_FEED_MM_MIN).contains(&feed) {
        return Err(MillingJobError::Relation(format!(
            "cutter.feed_per_tooth_mm = {ft} x {teeth} teeth x {rpm} rpm is a programmed feed of \
             {feed:.1} mm/min; the simulated X axis (1 um per step) runs {MIN_FEED_MM_MIN} .. \
             {MAX_FEED_MM_MIN} mm/min"
        )));
    }
    let kc =
        check("cut.kc_n_per_mm2", f.cut.kc_n_per_mm2, (0.0, true), MAX_KC_N_PER_MM2, "N/mm^2")?;
    let b0 = check("cut.b_before_mm", f.cut.b_before_mm, (0.0, true), MAX_DEPTH_MM, "mm")?;
    let b1 = check("cut.b_after_mm", f.cut.b_after_mm, (0.0, true), MAX_DEPTH_MM, "mm")?;
    let step_at = check("cut.step_at_mm", f.cut.step_at_mm, (0.0, false), MAX_DEPTH_MM, "mm")?;
    let mrev_s = |r: f64| (r * 1000.0 / 60.0).round() as u32;
    let feed_steps_per_s = (feed / 60.0 * 1000.0).round() as u32;
    let control = control(&f.force, feed_steps_per_s, mrev_s(min_rpm))?;
    let chain = motion::milling::chain::ChainConfig {
        teeth,
        nominal_spindle_mrev_s: mrev_s(rpm),
        ..chain_config()
    };
    let mut plant = plant_params();
    plant.kc_mn_per_mm2 = (kc * 1e3).round() as u32;
    plant.b_before_um = (b0 * 1e3).round() as u32;
    plant.b_after_um = (b1 * 1e3).round() as u32;
    plant.step_at_um = (step_at * 1e3).round() as u32;
    plant.teeth = teeth;
    plant.spindle_mrev_s = mrev_s(rpm);
    // Travel after the step: long enough for the settling window at the steady feed there.
    let steady_after_mm_s = (f.force.fnom_n / (kc * b1 * tau)).min(feed / 60.0);
    let after_mm = MIN_AFTER_STEP_MM.max(AFTER_STEP_S * steady_after_mm_s);
    let move_mm = WALL_STEPS as f64 / 1e3 + step_at + after_mm;
    let move_steps = (move_mm * 1e3).round() as i32;
    // Machine time: the move at a tenth of the slower steady feed, and 5 s to spare.
    let steady_before_mm_s = (f.force.fnom_n / (kc * b0 * tau)).min(feed / 60.0);
    let slowest = steady_before_mm_s.min(steady_after_mm_s).max(MIN_FEED_MM_MIN / 60.0);
    if move_mm / slowest > MAX_MACHINE_S {
        return Err(MillingJobError::Relation(format!(
            "the move ({move_mm:.1} mm: 2 mm to the wall, cut.step_at_mm = {step_at}, then \
             {after_mm:.1} mm) takes about {:.0} s of machine time at the steady feeds; a job runs \
             at most {MAX_MACHINE_S:.0} s (a shorter cut.step_at_mm or a higher feed)",
            move_mm / slowest
        )));
    }
    let max_s = 5.0 + 10.0 * move_mm / slowest;
    let setup = MillingSetup {
        control,
        chain,
        plant,
        move_steps,
        max_ticks: (max_s * TICK_HZ as f64) as u64,
    };
    Ok(MillingJob {
        name: f.name.unwrap_or_default(),
        setup,
        strategy: f.force.strategy.clone(),
        fnom_n: f.force.fnom_n,
        contact_n: f.force.contact_n,
        trip_n: f.force.trip_n,
        spindle_rpm: rpm,
        min_spindle_rpm: min_rpm,
        teeth,
        cutter_diameter_mm: d,
        feed_per_tooth_mm: ft,
        kc_n_per_mm2: kc,
        b_before_mm: b0,
        b_after_mm: b1,
        step_at_mm: step_at,
    })
}

/// Reads a job file; an unnamed job takes the file's stem as its name.
pub fn read(path: &std::path::Path) -> anyhow::Result<MillingJob> {
    use anyhow::Context;
    let src =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut job = parse(&src).with_context(|| path.display().to_string())?;
    if job.name.is_empty() {
        job.name = path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    }
    Ok(job)
}
