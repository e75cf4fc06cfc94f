//! The wire job's figure (`wire plan|run --plot FILE`): the die's ruled surface in 3-D (top
//! and bottom faces and every few ruling lines), both faces seen from above, and the four axes
//! against time on the host model (X and Y in mm, beta and alpha in degrees).

use super::ik::Joints;
use super::Die;
use crate::plot::{Figure, Panel, Panel3d, Series, Series3d, Style};

/// Ruling lines drawn in the 3-D view, about.
const RULINGS_SHOWN: usize = 36;

/// The figure titled `title` for `die`, with `joints` (time s, joints) sampled along the job.
pub fn figure(title: &str, die: &Die, joints: &[(f64, Joints)]) -> Figure {
    let zt = die.zt_mm;
    let n = die.top.len();
    let step = n.div_ceil(RULINGS_SHOWN).max(1);
    let rulings: Vec<Vec<[f64; 3]>> = die
        .top
        .iter()
        .zip(&die.bottom)
        .step_by(step)
        .map(|(t, b)| vec![[b.x_mm, b.y_mm, 0.0], [t.x_mm, t.y_mm, zt]])
        .collect();
    let surface = Panel3d {
        title: format!("ruled surface ({n} ruling lines, every {step}. shown)"),
        labels: ["X, mm".into(), "Y, mm".into(), "Z, mm".into()],
        series: vec![
            Series3d {
                label: format!("top face, Z = {zt} mm"),
                points: die.top.iter().map(|p| [p.x_mm, p.y_mm, zt]).collect(),
                style: Style::Line,
            },
            Series3d {
                label: "bottom face, Z = 0".into(),
                points: die.bottom.iter().map(|p| [p.x_mm, p.y_mm, 0.0]).collect(),
                style: Style::Line,
            },
        ],
        meshes: vec![("ruling lines".into(), rulings)],
    };
    let faces = Panel::new("faces from above (workpiece frame)", "X, mm", "Y, mm")
        .with(Series::line("top face", die.top.iter().map(|p| (p.x_mm, p.y_mm)).collect()))
        .with(Series::line("bottom face", die.bottom.iter().map(|p| (p.x_mm, p.y_mm)).collect()))
        .with(Series::styled(
            "point 0 (start of the cut)",
            die.top
                .first()
                .into_iter()
                .chain(die.bottom.first())
                .map(|p| (p.x_mm, p.y_mm))
                .collect(),
            Style::Points,
        ))
        .equal_aspect();
    let series = |label: &str, f: fn(&Joints) -> f64| {
        Series::line(label, joints.iter().map(|(t, j)| (*t, f(j))).collect())
    };
    let linear = Panel::new("linear axes against time (host model)", "time, s", "position, mm")
        .with(series("X, mm", |j| j.x_mm))
        .with(series("Y, mm", |j| j.y_mm));
    let rotary = Panel::new("rotary axes against time (host model)", "time, s", "angle, deg")
        .with(series("beta (about Y), deg", |j| j.beta_rad.to_degrees()))
        .with(series("alpha (about X), deg", |j| j.alpha_rad.to_degrees()));
    Figure::new(title).columns(2).panel3d(surface).panel(faces).panel(linear).panel(rotary)
}
