//! The alternative path (issue item 3, second half): instead of timed single-axis events, the
//! digitizer emits short polar linear segments (theta and r steps per segment, duration from Vt)
//! that the DDA interpolates linearly in (theta, r) like any other move; and the contour error both
//! paths are judged by (largest distance of the machine's tool centre from the ideal tool path).

use super::contour::Contour;
use super::digitize::{contact_speed, gauss4, DigitizeError, FeedAt, Setup, ToolPath};
use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::polar::playback::{Playback, SizeScale};
use motion::polar::StepEvent;
use motion::segment::{Rate, Segment};
use std::f64::consts::PI;

/// Polar segments for the DDA, with where they start.
#[derive(Clone, Debug, Default)]
pub struct SegmentPath {
    /// Axis 0 = theta steps, axis 1 = r steps; constant speed (entry = exit = 1, no ramps, like
    /// the event stream).
    pub segments: Vec<Segment>,
    pub start_r_steps: i64,
    pub theta0_rad: f64,
    /// Length of the path Vt is held on (`Setup::feed_at`).
    pub length_in: f64,
}

/// The tool path in machine polar coordinates, sampled densely by arc length: the ideal the
/// contour error is measured against, and the source of segment end points.
#[derive(Clone, Debug, Default)]
pub struct DensePath {
    /// Cartesian tool-centre points in the machine frame.
    pub xy: Vec<[f64; 2]>,
    /// Unwrapped machine angle at each point.
    pub theta: Vec<f64>,
    /// Arc length at each point along the path Vt is held on (`Setup::feed_at`: the contact
    /// point's or the tool centre's).
    pub s_in: Vec<f64>,
}

/// Samples the tool-centre path at `n` equal parameter steps (n + 1 points).
pub fn dense_path<C: Contour + ?Sized>(contour: &C, setup: &Setup, n: usize) -> DensePath {
    let path = ToolPath::new(contour, setup);
    let (u0, u1) = contour.range();
    let n = n.max(1);
    let speed = |u: f64| {
        let (_, dx, kappa) = path.eval(u);
        let centre = dx[0].hypot(dx[1]);
        match setup.feed_at {
            FeedAt::Centre => centre,
            FeedAt::Contact => contact_speed(centre, setup.tool_radius_in, kappa),
        }
    };
    let mut out = DensePath::default();
    let (mut s, mut th_prev, mut th_unw) = (0.0, 0.0, 0.0);
    for i in 0..=n {
        let u = u0 + (u1 - u0) * i as f64 / n as f64;
        if i > 0 {
            s += gauss4(u - (u1 - u0) / n as f64, u, speed);
        }
        let (x, ..) = path.eval(u);
        let th = x[1].atan2(x[0]);
        th_unw = if i == 0 { th } else { th_unw + (th - th_prev + PI).rem_euclid(2.0 * PI) - PI };
        th_prev = th;
        out.xy.push(x);
        out.theta.push(th_unw);
        out.s_in.push(s);
    }
    out
}

/// Splits the tool path into polar linear segments of about `seg_len_in` of arc length each.
/// Segment ends are the grid points nearest the ideal path (the same rounding the event path's
/// machine follows); durations are whole ticks of the cumulative arc length over Vt, so time does
/// not drift. A stretch with no step on either axis is merged into the next.
pub fn polar_segments<C: Contour + ?Sized>(
    contour: &C,
    setup: &Setup,
    seg_len_in: f64,
) -> Result<SegmentPath, DigitizeError> {
    let res = setup.res;
    if !(seg_len_in > 0.0 && setup.vt_in_per_s > 0.0 && setup.tick_hz > 0) {
        return Err(DigitizeError::Setup("segment length, Vt and tick rate must be > 0"));
    }
    // The event digitizer does the work-area, pole-inside and tool checks.
    super::digitize::digitize(contour, setup)?;
    let dense = dense_path(contour, setup, 100_000);
    let (Some(&x0), Some(&th0), Some(&len)) =
        (dense.xy.first(), dense.theta.first(), dense.s_in.last())
    else {
        return Err(DigitizeError::Setup("empty contour"));
    };
    let r_idx = |x: [f64; 2]| (x[0].hypot(x[1]) / res.dr_in).round() as i64;
    let t_idx = |th: f64| ((th - th0) / res.dtheta_rad).round() as i64;
    let mut out = SegmentPath {
        start_r_steps: r_idx(x0),
        theta0_rad: th0,
        length_in: len,
        ..Default::default()
    };
    let ticks_per_in = setup.tick_hz as f64 / setup.vt_in_per_s;
    let (mut at_r, mut at_t, mut at_tick) = (out.start_r_steps, 0i64, 0u64);
    let mut next_s = seg_len_in;
    let last = dense.xy.len() - 1;
    for i in 1..=last {
        if dense.s_in[i] < next_s && i < last {
            continue;
        }
        next_s = dense.s_in[i] + seg_len_in;
        let (r, t) = (r_idx(dense.xy[i]), t_idx(dense.theta[i]));
        if r == at_r && t == at_t {
            continue;
        }
        let tick = (dense.s_in[i] * ticks_per_in).round() as u64;
        let mut steps = [0i32; MAX_AXES];
        steps[0] = (t - at_t) as i32;
        steps[1] = (r - at_r) as i32;
        out.segments.push(Segment {
            steps,
            duration_ticks: tick.saturating_sub(at_tick).max(1) as u32,
            entry_rate: Rate::ONE,
            exit_rate: Rate::ONE,
            accel_per_tick: Rate::ONE,
            id: out.segments.len() as u32,
        });
        (at_r, at_t, at_tick) = (r, t, tick.max(at_tick + 1));
    }
    Ok(out)
}

/// A two-axis machine config for running polar segments through the host model of the DDA
/// (rates far above what the contour needs: the segments' own durations set the speed).
pub fn polar_machine(tick_hz: u32) -> MachineConfig {
    let axis =
        AxisLimits { max_rate_hz: 40_000, accel_steps_per_s2: 4_000_000, junction_jerk_hz: 40_000 };
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = axis;
    axes[1] = axis;
    MachineConfig {
        tick_hz,
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: 2,
        axes,
    }
}

/// Runs the segments through `motion::model::run`; returns the (theta, r) step position after
/// every tick.
pub fn run_segments(path: &SegmentPath, tick_hz: u32) -> Result<Vec<[i64; 2]>, String> {
    let cfg = polar_machine(tick_hz);
    let mut it = path.segments.iter().copied();
    let mut pos = vec![[0i64; 2]];
    let total: u64 = path.segments.iter().map(|s| s.duration_ticks as u64).sum();
    motion::model::run(
        &cfg,
        || it.next(),
        &[],
        total * 2 + 1000,
        |dda, _| {
            let p = dda.positions();
            pos.push([p[0], p[1]]);
        },
    )
    .map_err(|e| format!("{e:?}"))?;
    Ok(pos)
}

/// Plays events through the firmware's playback; returns the (theta, r) step position after every
/// tick.
pub fn play_events(events: &[StepEvent]) -> Vec<[i64; 2]> {
    let mut p = Playback::new(SizeScale::ONE);
    let mut it = events.iter();
    let mut pos = vec![[0, 0]];
    while !p.done() {
        while p.free() > 0 {
            match it.next() {
                // free() > 0 was just checked.
                Some(&e) => {
                    let _ = p.push(e);
                }
                None => {
                    p.finish();
                    break;
                }
            }
        }
        p.tick();
        pos.push(p.position());
    }
    pos
}

/// Largest distance (inches) of the machine's tool centre, at every distinct position it visits,
/// from the ideal tool path (the polyline `dense`, nearest point): one metric for both paths.
/// Positions are steps relative to (`start_r_steps`, `theta0_rad`).
pub fn max_deviation_in(
    dense: &DensePath,
    start_r_steps: i64,
    theta0_rad: f64,
    res: &super::Resolution,
    positions: &[[i64; 2]],
) -> f64 {
    let mut worst = 0.0f64;
    // The machine moves forward along the path: search a window about the last nearest index.
    let mut k = 0usize;
    let n = dense.xy.len();
    let window = 2000usize;
    let mut prev: Option<[i64; 2]> = None;
    for &p in positions {
        if prev == Some(p) {
            continue;
        }
        prev = Some(p);
        let r = (start_r_steps + p[1]) as f64 * res.dr_in;
        let th = theta0_rad + p[0] as f64 * res.dtheta_rad;
        let m = [r * th.cos(), r * th.sin()];
        let (lo, hi) = (k.saturating_sub(window), (k + window).min(n.saturating_sub(1)));
        let mut best = (f64::INFINITY, k);
        for j in lo..hi {
            let d = seg_dist(m, dense.xy[j], dense.xy[j + 1]);
            if d < best.0 {
                best = (d, j);
            }
        }
        k = best.1;
        worst = worst.max(best.0);
    }
    worst
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}
