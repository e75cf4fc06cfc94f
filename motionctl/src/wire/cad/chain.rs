//! Open DXF pieces joined end to end into closed loops.

use super::{cad_err, Result};
use crate::wire::Point2;

/// A flattened DXF piece: its points and whether it closes on itself.
pub(super) struct Piece {
    pub(super) what: String,
    pub(super) points: Vec<Point2>,
    pub(super) closed: bool,
}

/// Joins open pieces end to end (either direction) into closed loops; closed pieces are loops
/// of their own. An open piece left over is an open contour.
pub(super) fn chain(file: &str, pieces: Vec<Piece>, join: f64) -> Result<Vec<Vec<Point2>>> {
    let mut loops = Vec::new();
    let mut open: Vec<Piece> = Vec::new();
    for p in pieces {
        if p.closed {
            loops.push(p.points);
        } else if p.points.len() >= 2 {
            open.push(p);
        }
    }
    while let Some(first) = open.pop() {
        let what = first.what.clone();
        let mut pts = first.points;
        loop {
            let (start, end) = (pts[0], pts[pts.len() - 1]);
            if pts.len() > 2 && start.dist_mm(end) <= join {
                pts.pop();
                loops.push(pts);
                break;
            }
            // The piece whose end is nearest ours.
            let best = open
                .iter()
                .enumerate()
                .flat_map(|(i, q)| {
                    [
                        (i, false, q.points[0].dist_mm(end)),
                        (i, true, q.points[q.points.len() - 1].dist_mm(end)),
                    ]
                })
                .filter(|c| c.2 <= join)
                .min_by(|a, b| a.2.total_cmp(&b.2));
            match best {
                Some((i, reversed, _)) => {
                    let mut q = open.swap_remove(i).points;
                    if reversed {
                        q.reverse();
                    }
                    pts.extend(q.into_iter().skip(1));
                }
                None => {
                    return Err(cad_err(
                        file,
                        format!(
                            "open contour: the chain from {what} ends at ({:.3}, {:.3}) and \
                             ({:.3}, {:.3}), {:.3} apart, and no other piece meets its end; a die \
                             face must be closed",
                            start.x_mm,
                            start.y_mm,
                            end.x_mm,
                            end.y_mm,
                            start.dist_mm(end)
                        ),
                    ));
                }
            }
        }
    }
    Ok(loops)
}
