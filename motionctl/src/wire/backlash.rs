//! Backlash compensation of a continuous wire job: take-up segments at axis reversals, and a
//! dead-band model of the mechanism to check them against.
//!
//! The thesis compensated beta only, by adding 250 steps (1 deg, its 18:1 gearbox's lash) to the
//! absolute target of every move against the first move's direction (BASIC 5980-6050, see
//! [`super::ik::backlash_thesis_beta`]). A continuous job cannot add the lash to a cutting
//! segment without dragging the wire off the ruled surface while the lash is taken up, so here
//! every reversal of an axis gets its own short segment in which only the reversing axes move,
//! by exactly their lash. The cutting segments keep their steps and nominal durations; the
//! motor (commanded) position is the planned (effective) position plus the lash taken up so far.
//!
//! Convention (the thesis's and [`super::ik::compensate_backlash`]'s): at the start of a job
//! each axis is engaged in the direction of its first move (the operator sets the home by
//! approaching it that way), so the first move of an axis needs no take-up.

use motion::segment::{Rate, Segment};
use motion::{MachineConfig, MAX_AXES};
use thiserror::Error;

/// Axes of a wire job (X, Y, beta, alpha), as in every wire segment.
pub const AXES: usize = 4;

/// Largest accepted lash per axis, steps: one motor revolution (5000 steps/rev: 1.5 mm on X/Y,
/// 20 deg on beta, 3.6 deg on alpha). A mechanism with more play than a whole motor turn is
/// broken, and the value is far more likely a unit mistake (um or arc-seconds for steps).
pub const MAX_BACKLASH_STEPS: i64 = 5000;

/// Field names of the lash per axis in a wire job file (`[backlash]` table).
pub const FIELD_NAMES: [&str; AXES] =
    ["backlash.x_steps", "backlash.y_steps", "backlash.beta_steps", "backlash.alpha_steps"];

/// A lash value that is not accepted; `field` names where it came from.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("{field} = {value}: {why}")]
pub struct BacklashError {
    pub field: String,
    pub value: i64,
    pub why: &'static str,
}

/// Checks lash values `steps` (X, Y, beta, alpha) named by `fields`: each must be in
/// `0..=MAX_BACKLASH_STEPS`.
pub fn validate(steps: [i64; AXES], fields: [&str; AXES]) -> Result<[u32; AXES], BacklashError> {
    let mut out = [0u32; AXES];
    for (a, (&v, name)) in steps.iter().zip(fields).enumerate() {
        let why = if v < 0 {
            "backlash must be >= 0 steps"
        } else if v > MAX_BACKLASH_STEPS {
            "backlash above 5000 steps (one motor revolution) is not a mechanism's play"
        } else {
            out[a] = v as u32;
            continue;
        };
        return Err(BacklashError { field: name.to_string(), value: v, why });
    }
    Ok(out)
}

/// What a segment of a compensated job does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentKind {
    /// A planned cutting segment: moves the effective (post-backlash) position.
    Path,
    /// Lash take-up: only reversing axes move, the effective position stays put.
    TakeUp,
}

/// Nominal ticks of a take-up of `steps` (all axes at rest before and after): per axis the
/// fastest triangle its acceleration allows, peak speed `sqrt(accel * d)` capped at
/// `max_rate_hz`; the segment lasts as long as its slowest axis needs. The DDA ramps from and to
/// rest at the segment's acceleration, so it runs in about twice these ticks.
pub fn takeup_ticks(steps: [i32; MAX_AXES], cfg: &MachineConfig) -> u32 {
    let mut ticks = 1u32;
    for (a, &d) in steps.iter().enumerate() {
        if d == 0 {
            continue;
        }
        let d = d.unsigned_abs() as f64;
        let lim = &cfg.axes[a];
        let v_hz = (lim.accel_steps_per_s2 as f64 * d).sqrt().min(lim.max_rate_hz as f64);
        if v_hz > 0.0 {
            // Ceil keeps the nominal rate at or below v_hz (and so below max_rate_hz).
            ticks = ticks.max((d * cfg.tick_hz as f64 / v_hz).ceil() as u32);
        }
    }
    ticks
}

/// The cutting segments `path` (in order, steps only; rates are planned afterwards) with a
/// take-up segment before every segment in which an axis with lash reverses. Returns the
/// segments, their kinds, and for every segment the index in `path` of the cutting segment it
/// is or precedes. With no lash (all zero) the result is `path` itself.
pub fn insert_takeups(
    path: &[Segment],
    backlash_steps: [u32; AXES],
    cfg: &MachineConfig,
) -> (Vec<Segment>, Vec<SegmentKind>, Vec<usize>) {
    let mut segs = Vec::with_capacity(path.len());
    let mut kinds = Vec::with_capacity(path.len());
    let mut origin = Vec::with_capacity(path.len());
    // Direction of each axis's last move, 0 before its first.
    let mut last_dir = [0i32; AXES];
    for (k, s) in path.iter().enumerate() {
        let mut take = [0i32; MAX_AXES];
        for a in 0..AXES {
            let dir = s.steps[a].signum();
            if dir == 0 {
                continue;
            }
            if last_dir[a] != 0 && dir != last_dir[a] {
                // validate() caps the lash at 5000, so it fits an i32.
                take[a] = dir * backlash_steps[a] as i32;
            }
            last_dir[a] = dir;
        }
        if take.iter().any(|&d| d != 0) {
            segs.push(Segment {
                steps: take,
                duration_ticks: takeup_ticks(take, cfg),
                entry_rate: Rate::ZERO,
                exit_rate: Rate::ZERO,
                accel_per_tick: Rate::ONE,
                id: 0,
            });
            kinds.push(SegmentKind::TakeUp);
            origin.push(k);
        }
        segs.push(*s);
        kinds.push(SegmentKind::Path);
        origin.push(k);
    }
    for (id, s) in segs.iter_mut().enumerate() {
        s.id = id as u32;
    }
    (segs, kinds, origin)
}

/// Effective (post-backlash) position at the end of every segment: the running sum of the
/// cutting segments' steps only (take-ups do not move the tool).
pub fn effective_ends(segments: &[Segment], kinds: &[SegmentKind]) -> Vec<[i64; AXES]> {
    let mut pos = [0i64; AXES];
    segments
        .iter()
        .zip(kinds)
        .map(|(s, k)| {
            if *k == SegmentKind::Path {
                for (p, &d) in pos.iter_mut().zip(&s.steps) {
                    *p += d as i64;
                }
            }
            pos
        })
        .collect()
}

/// Commanded (motor) position at the end of every segment: the running sum of all steps.
pub fn commanded_ends(segments: &[Segment]) -> Vec<[i64; AXES]> {
    let mut pos = [0i64; AXES];
    segments
        .iter()
        .map(|s| {
            for (p, &d) in pos.iter_mut().zip(&s.steps) {
                *p += d as i64;
            }
            pos
        })
        .collect()
}

/// A mechanism with lash (a dead band per axis) between motor and tool, for simulation: the
/// tool moves only while the motor pushes it at one face of the band; reversing, the motor first
/// crosses the band (`backlash_steps`) without moving the tool. At the start each axis is engaged
/// in the direction of its first move (the job convention above).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeadBand {
    backlash_steps: [i64; AXES],
    /// Motor position, steps.
    motor: [i64; AXES],
    /// Tool (effective) position, steps.
    tool: [i64; AXES],
    /// Allowed range of `motor - tool`; set at an axis's first move.
    band: [Option<(i64, i64)>; AXES],
}

impl DeadBand {
    /// Motor and tool at 0 on every axis.
    pub fn new(backlash_steps: [u32; AXES]) -> Self {
        Self {
            backlash_steps: backlash_steps.map(i64::from),
            motor: [0; AXES],
            tool: [0; AXES],
            band: [None; AXES],
        }
    }

    /// Moves the motors to `motor` (each axis monotonically from where it is).
    pub fn move_to(&mut self, motor: [i64; AXES]) {
        for (a, &m) in motor.iter().enumerate() {
            let d = m - self.motor[a];
            if d == 0 {
                continue;
            }
            let b = self.backlash_steps[a];
            // Engaged in the first move's direction: the gap may open only behind it.
            let (lo, hi) = *self.band[a].get_or_insert(if d > 0 { (-b, 0) } else { (0, b) });
            let gap = m - self.tool[a];
            if gap > hi {
                self.tool[a] += gap - hi;
            } else if gap < lo {
                self.tool[a] += gap - lo;
            }
            self.motor[a] = m;
        }
    }

    /// Tool (effective) position, steps.
    pub fn tool(&self) -> [i64; AXES] {
        self.tool
    }

    /// Motor (commanded) position, steps.
    pub fn motor(&self) -> [i64; AXES] {
        self.motor
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_band_loses_the_lash_on_reversal_only() {
        let mut m = DeadBand::new([3, 0, 0, 0]);
        m.move_to([10, 0, 0, 0]);
        assert_eq!(m.tool()[0], 10);
        // Back 2: inside the band, the tool stays.
        m.move_to([8, 0, 0, 0]);
        assert_eq!(m.tool()[0], 10);
        m.move_to([5, 0, 0, 0]);
        assert_eq!(m.tool()[0], 8);
        // Forward again: 3 steps of play first.
        m.move_to([8, 0, 0, 0]);
        assert_eq!(m.tool()[0], 8);
        m.move_to([9, 0, 0, 0]);
        assert_eq!(m.tool()[0], 9);
    }

    #[test]
    fn validate_names_the_field() {
        assert_eq!(validate([1, 2, 250, 0], FIELD_NAMES), Ok([1, 2, 250, 0]));
        let e = validate([1, -2, 0, 0], FIELD_NAMES).unwrap_err();
        assert_eq!(e.field, "backlash.y_steps");
        let e = validate([0, 0, 0, MAX_BACKLASH_STEPS + 1], FIELD_NAMES).unwrap_err();
        assert!(e.to_string().starts_with("backlash.alpha_steps = 5001"), "{e}");
    }
}
