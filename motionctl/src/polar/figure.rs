//! The digitized contour's figure: in the plane (x-y about the machine pole, equal scale) the
//! contour, the tool-centre path, the machine's stepped path and the work area's edges; in
//! (theta, r) the tool path and the steps; and r and theta against time.

use super::contour::Contour;
use super::digitize::{Digitized, Setup, ToolPath};
use super::work_area::WorkArea;
use crate::plot::{Figure, Panel, Series, Style};
use motion::polar::StepEvent;

/// Samples along the contour for its curves.
const CURVE_POINTS: usize = 2000;
/// At most this many points of the stepped path per curve (every k-th event): dots over the
/// tool path, a line against time.
const STEP_DOTS: usize = 150;
const STEP_POINTS: usize = 4000;
/// Points per work-area arc.
const ARC_POINTS: usize = 181;

/// The machine's (r in, theta rad, t s) after each event, from the start grid point.
fn stepped(d: &Digitized, setup: &Setup, points: usize) -> Vec<(f64, f64, f64)> {
    let (mut r, mut th, mut ticks) = (d.start_r_steps, 0i64, 0u64);
    let every = (d.events.len() / points).max(1);
    let at = |r: i64, th: i64, ticks: u64| {
        (
            r as f64 * setup.res.dr_in,
            d.theta0_rad + th as f64 * setup.res.dtheta_rad,
            ticks as f64 / setup.tick_hz as f64,
        )
    };
    let mut out = vec![at(r, th, 0)];
    for (i, e) in d.events.iter().enumerate() {
        let StepEvent { dt_ticks, axis, negative } = *e;
        ticks += dt_ticks as u64;
        let s = if negative { -1 } else { 1 };
        if axis == 1 {
            r += s;
        } else {
            th += s;
        }
        if i % every == 0 || i + 1 == d.events.len() {
            out.push(at(r, th, ticks));
        }
    }
    out
}

/// The figure of `contour` digitized as `d` with `setup`, titled `title`.
pub fn digitized_figure(
    contour: &dyn Contour,
    setup: &Setup,
    d: &Digitized,
    title: &str,
) -> Figure {
    let path = ToolPath::new(contour, setup);
    let (u0, u1) = contour.range();
    let us = (0..=CURVE_POINTS).map(|i| u0 + (u1 - u0) * i as f64 / CURVE_POINTS as f64);
    let part: Vec<(f64, f64)> = us
        .clone()
        .map(|u| {
            let p = contour.jet(u)[0];
            (path.pole[0] + p[0], path.pole[1] + p[1])
        })
        .collect();
    let centre: Vec<[f64; 2]> = us.map(|u| path.eval(u).0).collect();
    let steps = stepped(d, setup, STEP_DOTS);
    let timeline = stepped(d, setup, STEP_POINTS);
    let xy = |r: f64, th: f64| (r * th.cos(), r * th.sin());
    let mut plane = Panel::new("the part in the plane, about the machine pole", "x, in", "y, in")
        .equal_aspect()
        .with(Series::line("contour (contact point)", part))
        .with(Series::styled(
            "tool centre",
            centre.iter().map(|p| (p[0], p[1])).collect(),
            Style::Dashed,
        ))
        .with(Series::styled(
            "machine (grid point after an event)",
            steps.iter().map(|&(r, th, _)| xy(r, th)).collect(),
            Style::Points,
        ));
    for (label, edge) in work_area_edges(&setup.area) {
        plane = plane.with(Series::styled(label, edge, Style::Dashed));
    }
    plane = plane.with(Series::styled("machine pole", vec![(0.0, 0.0)], Style::Points));
    // theta unwrapped from the start so the curve does not jump at +-180 deg.
    let mut last = d.theta0_rad;
    let polar_centre: Vec<(f64, f64)> = centre
        .iter()
        .map(|p| {
            let th = p[1].atan2(p[0]);
            let d = (th - last + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            last += d;
            (last.to_degrees(), p[0].hypot(p[1]))
        })
        .collect();
    let rt = Panel::new("the tool path in machine coordinates", "theta, deg", "r, in")
        .with(Series::line("tool centre", polar_centre))
        .with(Series::styled(
            "machine",
            steps.iter().map(|&(r, th, _)| (th.to_degrees(), r)).collect(),
            Style::Points,
        ))
        .band("work area r_min", setup.area.r_min_in, setup.area.r_min_in)
        .band("work area r_max", setup.area.r_max_in, setup.area.r_max_in);
    let feed = match setup.feed_at {
        super::digitize::FeedAt::Contact => "contact point",
        super::digitize::FeedAt::Centre => "tool centre",
    };
    let time = Panel::new(
        format!("the axes against time (Vt {:.4} in/s at the {feed})", d.vt_in_per_s),
        "time, s",
        "r, in / theta, rad",
    )
    .with(Series::line("r, in", timeline.iter().map(|&(r, _, t)| (t, r)).collect()))
    .with(Series::line("theta, rad", timeline.iter().map(|&(_, th, t)| (t, th)).collect()));
    Figure::new(title).columns(2).panel(plane).panel(rt).panel(time)
}

/// The work area's edges in the plane: the inner and outer arcs and the two limiting rays.
fn work_area_edges(a: &WorkArea) -> Vec<(&'static str, Vec<(f64, f64)>)> {
    let arc = |r: f64| {
        (0..ARC_POINTS)
            .map(|i| {
                let th = a.theta_min_rad
                    + (a.theta_max_rad - a.theta_min_rad) * i as f64 / (ARC_POINTS - 1) as f64;
                (r * th.cos(), r * th.sin())
            })
            .collect()
    };
    let ray = |th: f64| {
        vec![
            (a.r_min_in * th.cos(), a.r_min_in * th.sin()),
            (a.r_max_in * th.cos(), a.r_max_in * th.sin()),
        ]
    };
    let mut edge: Vec<(f64, f64)> = arc(a.r_min_in);
    edge.extend(ray(a.theta_max_rad));
    let mut outer: Vec<(f64, f64)> = arc(a.r_max_in);
    outer.reverse();
    edge.extend(outer);
    edge.extend(ray(a.theta_min_rad).into_iter().rev());
    vec![("work area", edge)]
}
