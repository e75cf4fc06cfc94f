//! The software digitizer: the tool-centre path, parametrised by arc length, crossing the
//! machine's grid of radii and angles, as timed single-axis step events.
//!
//! Modern form of the thesis's listing (App. C): instead of Newton on theta1 for each grid line
//! (which fails at tangency and picks the direction by retrying), the tool-centre path is sampled
//! with steps small enough that each axis's nearest grid index changes by at most one between
//! samples; an index change is a step, its direction is the sign of the change (robust at
//! tangency: a path that touches a grid line without crossing it gives no event), and its time
//! is the arc length to the crossing over Vt. The arc length uses the correct integrand |Q'(u)|
//! (for a polar contour with no tool, sqrt(r1^2 + r1'^2)); the listing integrated r1 alone.
//! The machine sits at the grid point nearest the tool centre, so each axis is within half a
//! resolution of the ideal path between events (the crossings are of the midlines).

use super::contour::{Contour, Jet};
use super::drive;
use super::work_area::WorkArea;
use super::Resolution;
use motion::polar::StepEvent;
use std::f64::consts::PI;

/// What the digitizer needs besides the contour.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    /// Contour pole O1 relative to the machine pole O: distance (RI) and angle (EPS).
    pub pole_r_in: f64,
    pub pole_angle_rad: f64,
    /// Tool radius; the tool centre runs on the right of the direction of travel (outside a
    /// counter-clockwise closed contour).
    pub tool_radius_in: f64,
    /// Tangential speed Vt, held at the point [`Setup::feed_at`] names.
    pub vt_in_per_s: f64,
    /// Where Vt is held: the contact point (the thesis's definition) or the tool centre.
    pub feed_at: FeedAt,
    pub res: Resolution,
    /// Event time quantum (the playback's DDA tick).
    pub tick_hz: u32,
    /// Cap Vt at the curvature-based speed limit (with a warning) instead of only warning.
    pub cap_speed: bool,
    /// Where the tool centre may go.
    pub area: WorkArea,
}

/// Where the tangential speed is held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FeedAt {
    /// At the contact point on the contour (Fahim's Vt: the cut's surface speed). The tool
    /// centre then runs at Vt (1 + R kappa): faster round convex parts, slower in concave ones.
    #[default]
    Contact,
    /// At the tool centre (a machine's programmed feed).
    Centre,
}

/// Why a contour cannot be digitized.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DigitizeError {
    #[error("the machine pole lies inside the closed contour (winding number {0}): the arm cannot follow it")]
    PoleInside(i32),
    #[error("the tool path leaves the work area ({area}): at r = {r_in:.4} in, theta = {:.3} deg (contour parameter u = {u:.4}) it is {miss_in:.4} in ({:.3} mm) outside", theta_rad.to_degrees(), miss_in * 25.4)]
    OutsideWorkArea { u: f64, r_in: f64, theta_rad: f64, miss_in: f64, area: WorkArea },
    #[error("tool radius {0} in is larger than the concave radius of curvature {1:.4} in: the offset path folds")]
    ToolTooLarge(f64, f64),
    #[error("bad setup: {0}")]
    Setup(&'static str),
    #[error("the contour is degenerate: its tool path is {0} in long (a zero radius, or a curve from X0 to the same X1?)")]
    Degenerate(f64),
    #[error("the contour needs about {estimated:.0} events at dR {dr_in} in and dTheta {dtheta_rad} rad; at most {max} (a coarser --dr or --dtheta)")]
    TooManyEvents { estimated: f64, dr_in: f64, dtheta_rad: f64, max: usize },
}

/// Most events one stream may hold: 1 600 s of machine time at 100 kHz, about 240 MB in memory
/// while digitizing; any resolution a user asks for is checked against it before allocating.
pub const MAX_EVENTS: usize = 20_000_000;
/// Samples of the path for the winding number and the event estimate.
const PATH_SAMPLES: usize = 4096;
/// Shortest tool path that is a contour, inches.
const MIN_PATH_IN: f64 = 1e-9;

/// The digitizer's output.
#[derive(Clone, Debug, Default)]
pub struct Digitized {
    pub events: Vec<StepEvent>,
    /// Arc length at each event along the path Vt is held on ([`Setup::feed_at`]), inches: the
    /// event's time is this over Vt.
    pub s_in: Vec<f64>,
    /// Start of the machine: radial grid index, angle theta0 (the angular grid's origin).
    pub start_r_steps: i64,
    pub theta0_rad: f64,
    /// Tool-centre path length.
    pub length_in: f64,
    /// Contact-point path length (the contour's own length; the tool-centre's with no tool).
    pub contact_length_in: f64,
    /// The length Vt is held along ([`Setup::feed_at`]): the cut lasts `feed_length_in / Vt`.
    pub feed_length_in: f64,
    /// Speed the events are timed for (Vt, or the capped speed).
    pub vt_in_per_s: f64,
    /// Smallest radius of curvature of the tool-centre path.
    pub min_rho_in: f64,
    pub warnings: Vec<String>,
}

/// 4-point Gauss-Legendre nodes and weights (the listing's; its text calls them Laguerre).
pub const GL4_NODES: [f64; 4] =
    [-0.861136311594053, -0.339981043584856, 0.339981043584856, 0.861136311594053];
pub const GL4_WEIGHTS: [f64; 4] =
    [0.347854845137454, 0.652145154862546, 0.652145154862546, 0.347854845137454];

/// Integral of `f` over [a, b] by 4-point Gauss-Legendre.
pub fn gauss4(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (m, h) = ((a + b) / 2.0, (b - a) / 2.0);
    h * GL4_NODES.iter().zip(GL4_WEIGHTS).map(|(&x, w)| w * f(m + h * x)).sum::<f64>()
}

/// The tool-centre path in the machine frame.
pub struct ToolPath<'a, C: Contour + ?Sized> {
    pub contour: &'a C,
    pub pole: [f64; 2],
    pub tool_radius_in: f64,
}

impl<'a, C: Contour + ?Sized> ToolPath<'a, C> {
    pub fn new(contour: &'a C, s: &Setup) -> Self {
        let (sn, cs) = s.pole_angle_rad.sin_cos();
        ToolPath {
            contour,
            pole: [s.pole_r_in * cs, s.pole_r_in * sn],
            tool_radius_in: s.tool_radius_in,
        }
    }

    /// Tool centre X and its derivative X' in the machine frame, plus the contour's signed
    /// curvature (positive turning left).
    pub fn eval(&self, u: f64) -> ([f64; 2], [f64; 2], f64) {
        let [p, d1, d2]: Jet = self.contour.jet(u);
        let speed = d1[0].hypot(d1[1]);
        let t = [d1[0] / speed, d1[1] / speed];
        let kappa = (d1[0] * d2[1] - d1[1] * d2[0]) / (speed * speed * speed);
        // Normal to the right of travel: n = (t_y, -t_x); dn/du = -(-kappa |P'|) ... = kappa|P'| t.
        let n = [t[1], -t[0]];
        let rr = self.tool_radius_in;
        let x = [self.pole[0] + p[0] + rr * n[0], self.pole[1] + p[1] + rr * n[1]];
        let g = 1.0 + rr * kappa;
        let dx = [d1[0] * g, d1[1] * g];
        (x, dx, kappa)
    }
}

struct Sample {
    u: f64,
    s: f64,
    /// Contact-point arc length.
    c: f64,
    r: f64,
    /// Unwrapped machine angle.
    th: f64,
}

/// The contact point's speed from the tool centre's `centre_speed` (|X'| = |P'| (1 + R kappa)).
pub fn contact_speed(centre_speed: f64, tool_radius_in: f64, kappa: f64) -> f64 {
    let g = 1.0 + tool_radius_in * kappa;
    if g > 0.0 {
        centre_speed / g
    } else {
        centre_speed
    }
}

/// Digitizes `contour` with `setup`.
pub fn digitize<C: Contour + ?Sized>(
    contour: &C,
    setup: &Setup,
) -> Result<Digitized, DigitizeError> {
    let res = setup.res;
    if !(setup.vt_in_per_s > 0.0 && res.dr_in > 0.0 && res.dtheta_rad > 0.0 && setup.tick_hz > 0) {
        return Err(DigitizeError::Setup("Vt, resolutions and tick rate must be > 0"));
    }
    if !(setup.tool_radius_in >= 0.0 && setup.tool_radius_in.is_finite()) {
        return Err(DigitizeError::Setup("tool radius must be finite and >= 0"));
    }
    if !(setup.pole_r_in.is_finite()
        && setup.pole_angle_rad.is_finite()
        && setup.vt_in_per_s.is_finite()
        && res.dr_in.is_finite()
        && res.dtheta_rad.is_finite())
    {
        return Err(DigitizeError::Setup("the pole, Vt and resolutions must be finite numbers"));
    }
    let path = ToolPath::new(contour, setup);
    let (u0, u1) = contour.range();
    let polar = |u: f64| {
        let (x, dx, k) = path.eval(u);
        let r = x[0].hypot(x[1]);
        (r, x[1].atan2(x[0]), x, dx, k)
    };
    let mut out = Digitized { min_rho_in: f64::INFINITY, ..Default::default() };
    let (r_start, th_start, ..) = polar(u0);
    out.theta0_rad = th_start;
    let ir = |r: f64| (r / res.dr_in).round() as i64;
    let jt = |th: f64| ((th - th_start) / res.dtheta_rad).round() as i64;
    out.start_r_steps = ir(r_start);
    let area = setup.area;
    let outside = |u: f64, r: f64, th: f64| DigitizeError::OutsideWorkArea {
        u,
        r_in: r,
        theta_rad: th,
        miss_in: area.miss_in(r, th),
        area,
    };
    let check = |u: f64, r: f64, th: f64| {
        if area.contains(r, th) {
            Ok(())
        } else {
            Err(outside(u, r, th))
        }
    };
    // The sample of the first pass furthest outside the work area, if any: (miss, u, r, theta).
    let mut worst_out: Option<(f64, f64, f64, f64)> = None;
    // One pass over the path: its length and the radial and angular travel (for the event
    // estimate, so no resolution can make the digitizer allocate without bound), and the winding
    // number about the machine pole.
    let (mut turn, mut length, mut r_travel, mut th_travel) = (0.0, 0.0, 0.0, 0.0);
    let (mut prev_r, mut prev_th, mut prev_x) = (r_start, th_start, polar(u0).2);
    for i in 1..=PATH_SAMPLES {
        let u = u0 + (u1 - u0) * i as f64 / PATH_SAMPLES as f64;
        let (r, th, x, ..) = polar(u);
        let dth = (th - prev_th + PI).rem_euclid(2.0 * PI) - PI;
        turn += dth;
        let th_unwrapped = th_start + turn;
        let miss = area.miss_in(r, th_unwrapped);
        if miss > 0.0 && worst_out.is_none_or(|w| miss > w.0) {
            worst_out = Some((miss, u, r, th_unwrapped));
        }
        th_travel += dth.abs();
        r_travel += (r - prev_r).abs();
        length += (x[0] - prev_x[0]).hypot(x[1] - prev_x[1]);
        (prev_r, prev_th, prev_x) = (r, th, x);
    }
    if !(length.is_finite() && length > MIN_PATH_IN) {
        return Err(DigitizeError::Degenerate(length));
    }
    let estimated = r_travel / res.dr_in + th_travel / res.dtheta_rad;
    if estimated.is_nan() || estimated > MAX_EVENTS as f64 {
        return Err(DigitizeError::TooManyEvents {
            estimated,
            dr_in: res.dr_in,
            dtheta_rad: res.dtheta_rad,
            max: MAX_EVENTS,
        });
    }
    if contour.closed() {
        // The winding number before the work-area check (a path round the pole always leaves
        // the 2.8 rad sector, and this is the clearer error).
        let winding = (turn / (2.0 * PI)).round() as i32;
        if winding != 0 {
            return Err(DigitizeError::PoleInside(winding));
        }
    }
    check(u0, r_start, th_start)?;
    // Where the path is furthest outside (the dense pass below finds a point between samples).
    if let Some((_, u, r, th)) = worst_out {
        return Err(outside(u, r, th));
    }
    let mut cur = Sample { u: u0, s: 0.0, c: 0.0, r: r_start, th: th_start };
    let (mut ri, mut tj) = (ir(r_start), 0i64);
    // Tool-centre and contact-point speeds along u (|X'| and |P'|: |X'| = |P'| (1 + R kappa)).
    let speeds = |u: f64| {
        let (_, dx, kappa) = path.eval(u);
        let sp = dx[0].hypot(dx[1]);
        (sp, contact_speed(sp, setup.tool_radius_in, kappa))
    };
    // The sample where the tool centre's speed squared over its radius of curvature (the radial
    // drive's load) is largest per Vt^2: (rho, centre speed / Vt) there.
    let mut worst: (f64, f64) = (f64::INFINITY, 1.0);
    let span = u1 - u0;
    let mut h = span * 1e-4;
    // (tool-centre arc length, contact arc length, axis, negative) per crossing.
    let mut events: Vec<(f64, f64, u8, bool)> = Vec::with_capacity(1024);
    // The path at the current sample, carried over from the step that accepted it (one curve
    // evaluation per accepted sample instead of two).
    let mut at = polar(u0);
    while cur.u < u1 {
        let (r, _, x, dx, kappa) = at;
        // Concave curvature tighter than the tool radius folds the offset path.
        let g = 1.0 + setup.tool_radius_in * kappa;
        if g <= 0.0 {
            return Err(DigitizeError::ToolTooLarge(setup.tool_radius_in, 1.0 / kappa.abs()));
        }
        let sp = dx[0].hypot(dx[1]);
        let csp = contact_speed(sp, setup.tool_radius_in, kappa);
        if kappa.abs() > 0.0 {
            let rho = (1.0 / kappa + setup.tool_radius_in).abs();
            out.min_rho_in = out.min_rho_in.min(rho);
            let ratio = match setup.feed_at {
                FeedAt::Contact => g,
                FeedAt::Centre => 1.0,
            };
            if ratio * ratio / rho > worst.1 * worst.1 / worst.0 {
                worst = (rho, ratio);
            }
        }
        let dr = (x[0] * dx[0] + x[1] * dx[1]) / r;
        let dth = (x[0] * dx[1] - x[1] * dx[0]) / (r * r);
        // Under half a resolution per sample on each axis (at most one index change), and at most a
        // small fraction of the contour so the curvature is resolved.
        let lim =
            |rate: f64, q: f64| if rate.abs() > 1e-300 { q / rate.abs() } else { f64::INFINITY };
        h = lim(dr, 0.45 * res.dr_in)
            .min(lim(dth, 0.45 * res.dtheta_rad))
            .min(lim(sp, 0.02))
            .min(h * 4.0);
        let mut un = (cur.u + h).min(u1);
        let next = loop {
            let ev = polar(un);
            let (rn, thn_w, _, dxn, _) = ev;
            let mut dthw = thn_w - cur.th.rem_euclid(2.0 * PI);
            dthw = (dthw + PI).rem_euclid(2.0 * PI) - PI;
            let thn = cur.th + dthw;
            let ok = (ir(rn) - ri).abs() <= 1 && (jt(thn) - tj).abs() <= 1;
            if ok || un - cur.u < span * 1e-14 {
                // Simpson on the sample step, reusing both end speeds: one evaluation instead of
                // Gauss-Legendre's four. The step is under half a resolution on each axis, so
                // the h^5 error term is ~1e-15 in per step (the accuracy tests compare against
                // 4-point Gauss-Legendre on a 200000-point grid).
                let (mid, cmid) = speeds((cur.u + un) / 2.0);
                let (spn, kn) = (dxn[0].hypot(dxn[1]), ev.4);
                let w = (un - cur.u) / 6.0;
                let s = cur.s + w * (sp + 4.0 * mid + spn);
                let c =
                    cur.c + w * (csp + 4.0 * cmid + contact_speed(spn, setup.tool_radius_in, kn));
                at = ev;
                break Sample { u: un, s, c, r: rn, th: thn };
            }
            un = cur.u + (un - cur.u) / 2.0;
        };
        check(next.u, next.r, next.th)?;
        // Crossings inside this interval, by linear interpolation of the index functions.
        let mut pair: [(f64, u8, bool); 2] = [(0.0, 9, false); 2];
        let mut k = 0;
        let ri_n = ir(next.r);
        if ri_n != ri {
            let line = (ri.max(ri_n) as f64 - 0.5) * res.dr_in;
            let f = ((line - cur.r) / (next.r - cur.r)).clamp(0.0, 1.0);
            pair[k] = (f, 1, ri_n < ri);
            k += 1;
            ri = ri_n;
        }
        let tj_n = jt(next.th);
        if tj_n != tj {
            let line = th_start + (tj.max(tj_n) as f64 - 0.5) * res.dtheta_rad;
            let f = ((line - cur.th) / (next.th - cur.th)).clamp(0.0, 1.0);
            pair[k] = (f, 0, tj_n < tj);
            k += 1;
            tj = tj_n;
        }
        if k == 2 && pair[1].0 < pair[0].0 {
            pair.swap(0, 1);
        }
        // Both arc lengths at each crossing (the fraction of this sample step).
        for &(f, axis, negative) in &pair[..k] {
            events.push((
                cur.s + f * (next.s - cur.s),
                cur.c + f * (next.c - cur.c),
                axis,
                negative,
            ));
        }
        cur = next;
    }
    out.length_in = cur.s;
    out.contact_length_in = cur.c;
    out.feed_length_in = match setup.feed_at {
        FeedAt::Contact => cur.c,
        FeedAt::Centre => cur.s,
    };
    if contour.closed() {
        let winding = ((cur.th - th_start) / (2.0 * PI)).round() as i32;
        if winding != 0 {
            return Err(DigitizeError::PoleInside(winding));
        }
    }
    // Speed limit from the curvature and the radial drive's torque (warn, and cap if asked).
    // The limit is the tool centre's; with Vt held at the contact point the centre runs at
    // Vt times the ratio there.
    let limit = drive::curvature_speed_limit_in_per_s(worst.0) / worst.1;
    let mut vt = setup.vt_in_per_s;
    if vt > limit {
        let msg = format!(
            "Vt {:.4} in/s exceeds the curvature speed limit {:.4} in/s at radius of curvature {:.4} in: steps would be lost",
            vt, limit, worst.0
        );
        if setup.cap_speed {
            out.warnings.push(format!("{msg}; slowed to the limit"));
            vt = limit;
        } else {
            out.warnings.push(msg);
        }
    }
    out.vt_in_per_s = vt;
    // Times in whole ticks from the start (no drift), dt = difference.
    let ticks_per_in = setup.tick_hz as f64 / vt;
    let mut prev = 0u64;
    for (s, c, axis, negative) in events {
        let fed = match setup.feed_at {
            FeedAt::Contact => c,
            FeedAt::Centre => s,
        };
        let t = (fed * ticks_per_in).round() as u64;
        let dt = t.saturating_sub(prev);
        prev = prev.max(t);
        out.events.push(StepEvent { dt_ticks: dt as u32, axis, negative });
        out.s_in.push(fed);
    }
    Ok(out)
}
