//! Continuous constant area-rate motion: a [`Path`] -> 4-axis DDA [`Segment`]s with no stops.
//!
//! The thesis interpolated every step in joint space and stopped 2-10 s between points (seed
//! L3897, digest section 1). Joint-space interpolation keeps the ruling line on the wire only at
//! the step's ends; in between the wire drifts off the designed ruled surface. Here every step
//! is split into equal pieces of the ruling-line parameter `u` until the joint-linear motion
//! between the pieces' exact IK solutions keeps the wire within a tolerance of a designed ruling
//! line, measured with the forward kinematics ([`deviation_mm`]). Each piece lasts `60 A / FR`
//! seconds for its exact ruled area `A`, so the area rate is constant; entry and exit rates at
//! every junction keep each axis within its acceleration and junction-jerk limits, and the
//! steps come from the corrected IK rounded to the nearest step at every piece end, so the sum
//! of the segments' steps lands exactly on every point's IK target.

use super::backlash::{insert_takeups, SegmentKind};
use super::ik::{forward_mm, ik_exact, steps_rounded, Joints, Steps};
use super::ik::{STEPS_PER_DEG_ALPHA, STEPS_PER_DEG_BETA, STEPS_PER_MM_XY};
use super::limits::Limits;
use super::path::{ruled_area_mm2, time_s, Path};
use super::{Point2, WireError};
use motion::segment::{Rate, Segment, SegmentError};
use motion::{MachineConfig, MAX_AXES};
use thiserror::Error;

/// Why a path could not be turned into segments.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum JobError {
    #[error(transparent)]
    Wire(#[from] WireError),
    /// A path point the machine cannot reach: refused before any segment is planned.
    #[error(transparent)]
    Limit(Box<LimitViolation>),
    #[error("path step {step}: still off the ruled surface after {pieces} pieces")]
    TooManyPieces { step: usize, pieces: usize },
    #[error("tolerance {tol_mm} mm is not above the step quantisation margin {margin_mm} mm")]
    Tolerance { tol_mm: f64, margin_mm: f64 },
    #[error(
        "segment {index}: axis {axis} needs {steps} steps in {ticks} ticks, faster than it can \
         step: a lower area rate (FR)"
    )]
    AxisRate { index: usize, axis: usize, steps: i64, ticks: u64 },
    #[error(
        "segment {index}: refused by the DDA ({reason:?}): its duration or rates are out of \
         range at this area rate (FR)"
    )]
    Segment { index: usize, reason: SegmentError },
}

/// A path point outside the machine's joint limits: which point, where, its joints (corrected
/// IK) and the rule it breaks.
#[derive(Clone, Debug, PartialEq, Error)]
#[error(
    "path point {index} (bottom ({:.3}, {:.3}) mm, top ({:.3}, {:.3}) mm; X {:.3} mm, \
     Y {:.3} mm, alpha {:.3} deg, beta {:.3} deg) is outside the machine's limits: {source}",
    .bottom.x_mm, .bottom.y_mm, .top.x_mm, .top.y_mm, .joints.x_mm, .joints.y_mm,
    .joints.alpha_rad.to_degrees(), .joints.beta_rad.to_degrees()
)]
pub struct LimitViolation {
    /// Index in the path (0 = the start point).
    pub index: usize,
    pub bottom: Point2,
    pub top: Point2,
    pub joints: Joints,
    /// The rule, from [`Limits::check_point`].
    pub source: WireError,
}

/// What to plan for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContinuousParams {
    /// Largest horizontal distance of the wire from a designed ruling line, at the bottom and the
    /// top face, at any tick (including step quantisation), mm.
    pub tol_mm: f64,
    /// Area rate, mm^2/min.
    pub fr_mm2_per_min: f64,
    /// Most pieces one path step may be split into.
    pub max_pieces: usize,
    /// Joint-linear samples checked inside each piece.
    pub samples_per_piece: usize,
    /// Lash per axis (X, Y, beta, alpha), steps, taken up by its own segment at every reversal
    /// ([`super::backlash`]); all zero plans exactly the uncompensated job. Checked with
    /// [`super::backlash::validate`] by whoever reads it from a user.
    pub backlash_steps: [u32; 4],
    /// Joint limits every path point must satisfy (the thesis's machine by default): checked
    /// with the corrected IK before anything is planned.
    pub limits: Limits,
}

impl Default for ContinuousParams {
    fn default() -> Self {
        Self {
            tol_mm: 0.01,
            fr_mm2_per_min: 800.0,
            max_pieces: 4096,
            samples_per_piece: 32,
            backlash_steps: [0; 4],
            limits: Limits::default(),
        }
    }
}

/// The ruled patch of one path step: ruling lines from `b(u)` (Z = 0) to `t(u)` (Z = `zt_mm`),
/// `b(u) = b0 + u (b1 - b0)`, `t(u)` likewise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Patch {
    pub b0: Point2,
    pub b1: Point2,
    pub t0: Point2,
    pub t1: Point2,
    pub zt_mm: f64,
}

fn lerp(a: Point2, b: Point2, u: f64) -> Point2 {
    Point2::new(a.x_mm + (b.x_mm - a.x_mm) * u, a.y_mm + (b.y_mm - a.y_mm) * u)
}

impl Patch {
    /// Patch of path step `i` (from point `i - 1` to point `i`), `1 <= i < path.top.len()`.
    pub fn of(path: &Path, i: usize) -> Patch {
        Patch {
            b0: path.bottom[i - 1],
            b1: path.bottom[i],
            t0: path.top[i - 1],
            t1: path.top[i],
            zt_mm: path.zt_mm,
        }
    }

    pub fn bottom(&self, u: f64) -> Point2 {
        lerp(self.b0, self.b1, u)
    }

    pub fn top(&self, u: f64) -> Point2 {
        lerp(self.t0, self.t1, u)
    }

    /// Exact IK of the ruling line at `u`.
    pub fn ik(&self, index: usize, u: f64) -> Result<Joints, WireError> {
        ik_exact(index, self.top(u), self.bottom(u), self.zt_mm)
    }
}

/// Horizontal offsets (machine frame, the wire is x = y = 0) of the bottom and top ends of the
/// ruling line at `u`, at joints `j`.
fn offsets(j: Joints, p: &Patch, u: f64) -> ([f64; 2], [f64; 2]) {
    let (b, t) = (p.bottom(u), p.top(u));
    let fb = forward_mm(j, [b.x_mm, b.y_mm, 0.0]);
    let ft = forward_mm(j, [t.x_mm, t.y_mm, p.zt_mm]);
    ([fb[0], fb[1]], [ft[0], ft[1]])
}

/// How far the wire is from the patch's ruled surface at joints `j`, mm: the larger of the
/// horizontal distances from the wire of the bottom and the top end of the ruling line
/// `u* in [0, 1]` that is closest to the wire. For fixed joints the machine position is affine
/// in the workpiece point and the ruling-line ends are affine in `u`, so the sum of the two
/// squared offsets is a quadratic in `u`, minimised in closed form. 0 at the exact IK of any
/// ruling line of the patch. Returns `(deviation, u*)`.
pub fn deviation_mm(j: Joints, p: &Patch) -> (f64, f64) {
    let (b0, t0) = offsets(j, p, 0.0);
    let (b1, t1) = offsets(j, p, 1.0);
    let db = [b1[0] - b0[0], b1[1] - b0[1]];
    let dt = [t1[0] - t0[0], t1[1] - t0[1]];
    let den = db[0] * db[0] + db[1] * db[1] + dt[0] * dt[0] + dt[1] * dt[1];
    let num = b0[0] * db[0] + b0[1] * db[1] + t0[0] * dt[0] + t0[1] * dt[1];
    let u = if den > 0.0 { (-num / den).clamp(0.0, 1.0) } else { 0.0 };
    let b = [b0[0] + u * db[0], b0[1] + u * db[1]];
    let t = [t0[0] + u * dt[0], t0[1] + u * dt[1]];
    (b[0].hypot(b[1]).max(t[0].hypot(t[1])), u)
}

/// Joints from absolute motor steps `[X, Y, beta, alpha]` (inverse of [`steps_rounded`]:
/// M3 = -250 beta[deg]).
pub fn joints_from_steps(s: [i64; 4]) -> Joints {
    Joints {
        x_mm: s[0] as f64 / STEPS_PER_MM_XY,
        y_mm: s[1] as f64 / STEPS_PER_MM_XY,
        beta_rad: (-(s[2] as f64) / STEPS_PER_DEG_BETA).to_radians(),
        alpha_rad: (s[3] as f64 / STEPS_PER_DEG_ALPHA).to_radians(),
    }
}

fn joint_lerp(a: Joints, b: Joints, s: f64) -> Joints {
    Joints {
        x_mm: a.x_mm + (b.x_mm - a.x_mm) * s,
        y_mm: a.y_mm + (b.y_mm - a.y_mm) * s,
        alpha_rad: a.alpha_rad + (b.alpha_rad - a.alpha_rad) * s,
        beta_rad: a.beta_rad + (b.beta_rad - a.beta_rad) * s,
    }
}

/// Bound on how much step quantisation can move the wire off the ruling line, mm: every axis
/// may be one step off the continuous joint-linear motion (half a step from rounding the
/// piece ends, half a step from the DDA's Bresenham line). A step of X or Y shifts both ends by
/// its length; a step of beta or alpha moves a workpiece point by at most its distance from the
/// rotation centre times the angle.
pub fn quantisation_margin_mm(path: &Path) -> f64 {
    let r_mm = path
        .top
        .iter()
        .map(|p| p.norm_mm().hypot(path.zt_mm))
        .chain(path.bottom.iter().map(|p| p.norm_mm()))
        .fold(0.0, f64::max);
    let xy = 2.0 / STEPS_PER_MM_XY;
    let rot = r_mm * (1.0 / STEPS_PER_DEG_BETA + 1.0 / STEPS_PER_DEG_ALPHA).to_radians();
    xy + rot
}

/// One planned piece of a path step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Path step (1-based: from point `step - 1` to point `step`).
    pub step: usize,
    pub u0: f64,
    pub u1: f64,
    /// Exact ruled area of the piece, mm^2.
    pub area_mm2: f64,
    /// Absolute motor steps at the piece's end (rounded corrected IK).
    pub end_steps: Steps,
    /// Largest joint-linear deviation inside the piece before quantisation, mm.
    pub deviation_mm: f64,
}

/// A path turned into segments.
#[derive(Clone, Debug, PartialEq)]
pub struct ContinuousJob {
    pub segments: Vec<Segment>,
    /// For each segment, the pieces it covers (first, last): a piece without any step is merged
    /// into the next segment. A take-up segment has `(p, p)` with `p` the last piece of the cutting
    /// segment before it: the tool stays at that piece's end.
    pub segment_pieces: Vec<(usize, usize)>,
    /// Cutting or lash take-up, per segment (all [`SegmentKind::Path`] without backlash).
    pub kinds: Vec<SegmentKind>,
    /// Sum of the take-up segments' nominal durations, ticks (the DDA ramps them from and to
    /// rest, so they run in about twice this; the junctions around them slow down too).
    pub takeup_ticks: u64,
    pub pieces: Vec<Piece>,
    /// Rounded IK steps of every path point (the exact targets the segments must sum to).
    pub point_steps: Vec<Steps>,
    /// Exact ruled area of the whole path, mm^2.
    pub area_ruled_mm2: f64,
    /// The thesis's trapezoid area of the whole path, mm^2.
    pub area_trapezoid_mm2: f64,
    /// `60 A / FR` for the ruled area, s.
    pub time_ruled_s: f64,
    /// Quantisation margin and the tolerance the joint-linear pieces were planned to, mm.
    pub margin_mm: f64,
    pub plan_tol_mm: f64,
}

/// Splits path step `i` into the fewest equal pieces of `u` whose joint-linear motion stays
/// within `tol_mm` of the ruled surface.
fn split_step(
    path: &Path,
    i: usize,
    tol_mm: f64,
    prm: &ContinuousParams,
) -> Result<Vec<Piece>, JobError> {
    let patch = Patch::of(path, i);
    let mut n = 1usize;
    loop {
        let mut pieces = Vec::with_capacity(n);
        let mut worst = 0.0f64;
        let mut ja = patch.ik(i, 0.0)?;
        for k in 0..n {
            let (u0, u1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
            let jb = patch.ik(i, u1)?;
            let mut dev = 0.0f64;
            for m in 1..prm.samples_per_piece {
                let s = m as f64 / prm.samples_per_piece as f64;
                dev = dev.max(deviation_mm(joint_lerp(ja, jb, s), &patch).0);
            }
            worst = worst.max(dev);
            let area_mm2 = ruled_area_mm2(
                patch.bottom(u0),
                patch.bottom(u1),
                patch.top(u0),
                patch.top(u1),
                path.zt_mm,
            );
            pieces.push(Piece {
                step: i,
                u0,
                u1,
                area_mm2,
                end_steps: steps_rounded(jb),
                deviation_mm: dev,
            });
            ja = jb;
        }
        if worst <= tol_mm {
            return Ok(pieces);
        }
        // Deviation falls with the square of the piece length.
        let grow = (n as f64 * (worst / tol_mm).sqrt()).ceil() as usize;
        n = grow.max(n + 1);
        if n > prm.max_pieces {
            return Err(JobError::TooManyPieces { step: i, pieces: n });
        }
    }
}

/// Checks every point of `path` (corrected IK) against `limits`; the first violation is
/// returned with the point's index, coordinates and joints.
pub fn check_limits(path: &Path, limits: &Limits) -> Result<(), JobError> {
    for (index, (&top, &bottom)) in path.top.iter().zip(&path.bottom).enumerate() {
        let joints = ik_exact(index, top, bottom, path.zt_mm)?;
        limits.check_point(index, bottom, path.zt_mm, joints).map_err(|source| {
            JobError::Limit(Box::new(LimitViolation { index, bottom, top, joints, source }))
        })?;
    }
    Ok(())
}

/// Plans `path` for the machine `cfg`: every point within `prm.limits`, pieces, per-piece durations at constant area rate,
/// junction and acceleration limits, as DDA segments with ids 0, 1, ...
pub fn plan(
    path: &Path,
    cfg: &MachineConfig,
    prm: &ContinuousParams,
) -> Result<ContinuousJob, JobError> {
    super::positive("fr_mm2_per_min", prm.fr_mm2_per_min)?;
    super::positive("tol_mm", prm.tol_mm)?;
    check_limits(path, &prm.limits)?;
    let margin_mm = quantisation_margin_mm(path);
    let plan_tol_mm = prm.tol_mm - margin_mm;
    if plan_tol_mm <= 0.0 {
        return Err(JobError::Tolerance { tol_mm: prm.tol_mm, margin_mm });
    }
    let mut pieces = Vec::new();
    for i in 1..path.top.len() {
        pieces.extend(split_step(path, i, plan_tol_mm, prm)?);
    }
    let point_steps = path
        .top
        .iter()
        .zip(&path.bottom)
        .enumerate()
        .map(|(i, (&t, &b))| ik_exact(i, t, b, path.zt_mm).map(steps_rounded))
        .collect::<Result<Vec<_>, _>>()?;
    let area_ruled_mm2: f64 = pieces.iter().map(|p| p.area_mm2).sum();
    let area_trapezoid_mm2 = super::path::totals(path, prm.fr_mm2_per_min)?.area_mm2;
    let time_ruled_s = time_s(area_ruled_mm2, prm.fr_mm2_per_min)?;

    // Durations from the cumulative time, rounded once, so the total is the rounded total.
    let tick_hz = cfg.tick_hz as f64;
    let mut segments: Vec<Segment> = Vec::new();
    let mut segment_pieces: Vec<(usize, usize)> = Vec::new();
    let (mut cum_s, mut cum_ticks, mut prev) = (0.0, 0u64, point_steps[0]);
    let mut first_piece = 0;
    for (k, p) in pieces.iter().enumerate() {
        cum_s += time_s(p.area_mm2, prm.fr_mm2_per_min)?;
        let d: Vec<i64> = (0..4).map(|a| p.end_steps[a] - prev[a]).collect();
        let is_last = k + 1 == pieces.len();
        if d.iter().all(|&v| v == 0) && !is_last {
            continue;
        }
        let end_ticks = (cum_s * tick_hz).round() as u64;
        let ticks = end_ticks - cum_ticks;
        let mut steps = [0i32; MAX_AXES];
        for a in 0..4 {
            steps[a] = i32::try_from(d[a]).map_err(|_| JobError::AxisRate {
                index: segments.len(),
                axis: a,
                steps: d[a],
                ticks,
            })?;
        }
        if d.iter().all(|&v| v == 0) {
            // A trailing piece without steps: its time goes to the previous segment.
            if let Some(last) = segments.last_mut() {
                last.duration_ticks += ticks as u32;
                if let Some(sp) = segment_pieces.last_mut() {
                    *sp = (sp.0, k);
                }
            }
        } else {
            segments.push(Segment {
                steps,
                duration_ticks: u32::try_from(ticks).unwrap_or(u32::MAX),
                entry_rate: Rate::ZERO,
                exit_rate: Rate::ZERO,
                accel_per_tick: Rate::ONE,
                id: segments.len() as u32,
            });
            segment_pieces.push((first_piece, k));
        }
        first_piece = k + 1;
        cum_ticks = end_ticks;
        prev = p.end_steps;
    }
    let (mut segments, kinds, origin) = insert_takeups(&segments, prm.backlash_steps, cfg);
    let segment_pieces: Vec<(usize, usize)> = origin
        .iter()
        .zip(&kinds)
        .map(|(&k, kind)| match kind {
            SegmentKind::Path => segment_pieces[k],
            // Before cutting segment k (never the first: a reversal needs an earlier move), the
            // tool rests at the end of cutting segment k - 1.
            SegmentKind::TakeUp => {
                let p = segment_pieces[k.saturating_sub(1)].1;
                (p, p)
            }
        })
        .collect();
    let takeup_ticks = segments
        .iter()
        .zip(&kinds)
        .filter(|(_, k)| **k == SegmentKind::TakeUp)
        .map(|(s, _)| s.duration_ticks as u64)
        .sum();
    plan_rates(&mut segments, cfg);
    for (index, s) in segments.iter().enumerate() {
        s.check(cfg).map_err(|reason| match reason {
            SegmentError::AxisRate { axis } => JobError::AxisRate {
                index,
                axis: axis as usize,
                steps: s.steps[axis as usize] as i64,
                ticks: s.duration_ticks as u64,
            },
            reason => JobError::Segment { index, reason },
        })?;
    }
    Ok(ContinuousJob {
        segments,
        segment_pieces,
        kinds,
        takeup_ticks,
        pieces,
        point_steps,
        area_ruled_mm2,
        area_trapezoid_mm2,
        time_ruled_s,
        margin_mm,
        plan_tol_mm,
    })
}

const Q30: f64 = (1u64 << 30) as f64;

/// Rate change per tick (Q2.30 bits) that keeps every axis of `s` within its acceleration:
/// axis speed at rate r is `r d / T` steps per tick, so `dr d / T * tick_hz^2 <= a`.
fn accel_bits(s: &Segment, cfg: &MachineConfig) -> u32 {
    let t = s.duration_ticks as f64;
    let f2 = (cfg.tick_hz as f64).powi(2);
    let mut dr = 1.0f64;
    for (a, &d) in s.steps.iter().enumerate() {
        if d != 0 {
            dr = dr.min(cfg.axes[a].accel_steps_per_s2 as f64 * t / (d.unsigned_abs() as f64 * f2));
        }
    }
    ((dr * Q30).floor() as u32).clamp(1, 1 << 30)
}

/// Axis speeds at rate 1.0, steps/s.
fn nominal_hz(s: &Segment, cfg: &MachineConfig) -> [f64; MAX_AXES] {
    s.steps.map(|d| d as f64 * cfg.tick_hz as f64 / s.duration_ticks.max(1) as f64)
}

/// Junction and ramp planning. At a junction both segments run at the same fraction `f` of
/// their nominal speed (the area rate is continuous), limited so that no axis's speed jumps by
/// more than its `junction_jerk_hz`; the job starts and ends at rest. A backward and a forward
/// pass then cap every junction to what the segments' ramps (rate^2 changes by `2 dr` per
/// virtual tick, as the DDA's deceleration budget) can reach.
pub fn plan_rates(segments: &mut [Segment], cfg: &MachineConfig) {
    let n = segments.len();
    if n == 0 {
        return;
    }
    let dr: Vec<f64> = segments
        .iter_mut()
        .map(|s| {
            let bits = accel_bits(s, cfg);
            s.accel_per_tick = Rate::from_bits(bits);
            bits as f64 / Q30
        })
        .collect();
    let mut j = vec![0.0f64; n + 1];
    for k in 1..n {
        let (va, vb) = (nominal_hz(&segments[k - 1], cfg), nominal_hz(&segments[k], cfg));
        let mut f = 1.0f64;
        for a in 0..MAX_AXES {
            let jump = (va[a] - vb[a]).abs();
            if jump > 0.0 {
                f = f.min(cfg.axes[a].junction_jerk_hz as f64 / jump);
            }
        }
        j[k] = f;
    }
    let reach = |k: usize, from: f64| {
        (from * from + 2.0 * dr[k] * segments[k].duration_ticks as f64).sqrt()
    };
    for k in (0..n).rev() {
        j[k] = j[k].min(reach(k, j[k + 1]));
    }
    for k in 0..n {
        j[k + 1] = j[k + 1].min(reach(k, j[k]));
    }
    let bits = |f: f64| Rate::from_bits(((f * Q30).floor() as u32).min(1 << 30));
    for (k, s) in segments.iter_mut().enumerate() {
        s.entry_rate = bits(j[k]);
        s.exit_rate = bits(j[k + 1]);
    }
}

/// The circle -> complex die of the thesis's plate 4 / Table 11 (top circle R 25, bottom complex
/// shape RI 20, N 80, ZT 39) as a path from and back to the centre.
pub fn circle_complex_path() -> Result<Path, WireError> {
    let die = super::Die::new(
        39.0,
        super::shapes::circle_arcs(25.0, 80)?,
        super::shapes::complex(20.0, 80)?,
    )?;
    Path::from_home(&die, Point2::default())
}
