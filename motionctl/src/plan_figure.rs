//! `plan --plot`: the programmed toolpath of a job in mm, rapids told apart from feed moves, in
//! a 3-D projection and from above. Arcs and splines are drawn as the chords the board runs.

use crate::job::{Feed, Item, Machine, Target};
use crate::plot::{Figure, Panel, Panel3d, Series};

type Polyline = Vec<[f64; 3]>;

/// Most points drawn; a longer path is thinned evenly (every k-th point of each polyline).
const MAX_POINTS: usize = 200_000;

/// The figure of `items` on `machine`, titled `title`.
pub fn toolpath_figure(machine: &Machine, items: &[Item], title: &str) -> Figure {
    let axis = |name: &str| machine.axis_index(name);
    let (ix, iy, iz) = (axis("X"), axis("Y"), axis("Z"));
    let mut pos = vec![0.0f64; machine.axes.len()];
    let at = |p: &[f64]| {
        let get = |i: Option<usize>| i.and_then(|i| p.get(i).copied()).unwrap_or(0.0);
        [get(ix), get(iy), get(iz)]
    };
    // Polylines of consecutive moves of one kind.
    let mut feeds: Vec<Polyline> = Vec::new();
    let mut rapids: Vec<Polyline> = Vec::new();
    let mut last_rapid: Option<bool> = None;
    let mut path: Vec<[f64; 3]> = vec![at(&pos)];
    for item in items {
        // A probe move is drawn to its programmed end (where `plan` assumes it ends).
        let (Item::Move(m) | Item::Probe { mv: m, .. }) = item else { continue };
        let from = at(&pos);
        match &m.target {
            Target::Absolute(t) => {
                for (p, v) in pos.iter_mut().zip(t) {
                    if let Some(v) = v {
                        *p = *v;
                    }
                }
            }
            Target::Relative(d) => {
                for (p, v) in pos.iter_mut().zip(d) {
                    *p += v;
                }
            }
        }
        let to = at(&pos);
        let rapid = m.feed == Feed::Rapid;
        let lines = if rapid { &mut rapids } else { &mut feeds };
        if last_rapid != Some(rapid) || lines.is_empty() {
            lines.push(vec![from]);
        }
        if let Some(l) = lines.last_mut() {
            l.push(to);
        }
        last_rapid = Some(rapid);
        path.push(to);
    }
    let total: usize = path.len();
    let every = total.div_ceil(MAX_POINTS).max(1);
    let thin = |l: &Vec<[f64; 3]>| -> Vec<[f64; 3]> {
        let mut v: Vec<[f64; 3]> = l.iter().step_by(every).copied().collect();
        if let (Some(&end), true) = (l.last(), every > 1) {
            v.push(end);
        }
        v
    };
    let solid = Panel3d {
        title: "toolpath".into(),
        labels: ["X, mm".into(), "Y, mm".into(), "Z, mm".into()],
        series: Vec::new(),
        meshes: vec![
            ("feed moves".into(), feeds.iter().map(thin).collect()),
            ("rapids".into(), rapids.iter().map(thin).collect()),
        ],
    };
    let top = Panel::new("from above", "X, mm", "Y, mm").equal_aspect().with(Series::line(
        "toolpath (feeds and rapids)",
        thin(&path).iter().map(|p| (p[0], p[1])).collect(),
    ));
    Figure::new(title).columns(2).panel3d(solid).panel(top)
}
