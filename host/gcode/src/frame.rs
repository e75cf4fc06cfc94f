//! From canonical calls to machine moves: millimetres (degrees for A, B, C) in machine
//! coordinates, with the G5x and G92 offsets, the XY rotation and the tool length offset
//! applied as LinuxCNC's canon layer does (`rotate_and_offset_pos` in emccanon.cc), and feeds
//! in mm/min as they were set.

use crate::canon::{Canon, ControlPoint, Plane, Pos, ProbeKind, Units};
use crate::state::rotate;

/// One move in machine coordinates (mm, degrees).
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    Rapid {
        from: Pos,
        to: Pos,
    },
    Feed {
        from: Pos,
        to: Pos,
        feed_mm_min: f64,
    },
    /// A circular or helical arc. `axes` are the plane's first, second and normal axes (indices
    /// into X Y Z); `turn` is rs274's: +n counterclockwise, -n clockwise, |n| - 1 full circles
    /// more than the partial one.
    Arc {
        from: Pos,
        to: Pos,
        center: [f64; 3],
        axes: [usize; 3],
        turn: i32,
        feed_mm_min: f64,
    },
    Probe {
        from: Pos,
        to: Pos,
        kind: ProbeKind,
        feed_mm_min: f64,
    },
    /// Spindle-synchronised tapping down to `to` and back.
    RigidTap {
        from: Pos,
        to: Pos,
    },
    /// A NURBS in the XY plane (control points in machine X, Y; Z, A, B, C stay).
    Nurbs {
        from: Pos,
        points: Vec<ControlPoint>,
        order: u32,
        feed_mm_min: f64,
    },
}

impl Motion {
    pub fn end(&self) -> Pos {
        match self {
            Motion::Rapid { to, .. }
            | Motion::Feed { to, .. }
            | Motion::Arc { to, .. }
            | Motion::Probe { to, .. } => *to,
            Motion::RigidTap { from, .. } => *from,
            Motion::Nurbs { from, points, .. } => {
                let mut p = *from;
                if let Some(last) = points.last() {
                    p[0] = last.x;
                    p[1] = last.y;
                }
                p
            }
        }
    }
}

/// The canon layer's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    units: Units,
    plane: Plane,
    /// Offsets in mm (X Y Z) and degrees (A B C).
    g5x: Pos,
    g92: Pos,
    tool: Pos,
    rotation_deg: f64,
    feed_mm_min: f64,
    /// Machine position, mm.
    pub position: Pos,
}

impl Default for Frame {
    fn default() -> Self {
        Frame::new([0.0; 6])
    }
}

impl Frame {
    /// A frame with the machine at `position` (mm).
    pub fn new(position: Pos) -> Self {
        Frame {
            units: Units::Mm,
            plane: Plane::XY,
            g5x: [0.0; 6],
            g92: [0.0; 6],
            tool: [0.0; 6],
            rotation_deg: 0.0,
            feed_mm_min: 0.0,
            position,
        }
    }

    fn mm(&self, v: f64) -> f64 {
        v * self.units.mm()
    }

    fn pos_mm(&self, p: &Pos) -> Pos {
        let mut q = *p;
        for v in q.iter_mut().take(3) {
            *v = self.mm(*v);
        }
        q
    }

    /// A program-coordinate point in machine coordinates.
    pub fn to_machine(&self, p: &Pos) -> Pos {
        let mut q = self.pos_mm(p);
        for i in 0..6 {
            q[i] += self.g92[i];
        }
        let (mut x, mut y) = (q[0], q[1]);
        rotate(&mut x, &mut y, self.rotation_deg);
        (q[0], q[1]) = (x, y);
        for i in 0..6 {
            q[i] += self.g5x[i] + self.tool[i];
        }
        q
    }

    /// A machine-coordinate point (mm, degrees) in program coordinates: [`Frame::to_machine`]
    /// undone (where a probe tripped, for #5061..#5066, as LinuxCNC reports it).
    pub fn to_program(&self, m: &Pos) -> Pos {
        let mut q = *m;
        for i in 0..6 {
            q[i] -= self.g5x[i] + self.tool[i];
        }
        let (mut x, mut y) = (q[0], q[1]);
        rotate(&mut x, &mut y, -self.rotation_deg);
        (q[0], q[1]) = (x, y);
        for i in 0..6 {
            q[i] -= self.g92[i];
        }
        let per_mm = 1.0 / self.units.mm();
        for v in q.iter_mut().take(3) {
            *v *= per_mm;
        }
        q
    }

    /// The feed rate set last, mm/min.
    pub fn feed_mm_min(&self) -> f64 {
        self.feed_mm_min
    }

    /// Follows one call; the move it makes, if it moves.
    pub fn apply(&mut self, c: &Canon) -> Option<Motion> {
        let from = self.position;
        let m = match c {
            Canon::UseLengthUnits(u) => {
                self.units = *u;
                return None;
            }
            Canon::SelectPlane(p) => {
                self.plane = *p;
                return None;
            }
            Canon::SetG5xOffset { offset, .. } => {
                self.g5x = self.pos_mm(offset);
                return None;
            }
            Canon::SetG92Offset(p) => {
                self.g92 = self.pos_mm(p);
                return None;
            }
            Canon::SetXyRotation(t) => {
                self.rotation_deg = *t;
                return None;
            }
            Canon::UseToolLengthOffset(o) => {
                let p = [o[0], o[1], o[2], o[3], o[4], o[5]];
                self.tool = self.pos_mm(&p);
                return None;
            }
            Canon::SetFeedRate(f) => {
                self.feed_mm_min = self.mm(*f);
                return None;
            }
            Canon::StraightTraverse(p) => Motion::Rapid { from, to: self.to_machine(p) },
            Canon::StraightFeed(p) => {
                Motion::Feed { from, to: self.to_machine(p), feed_mm_min: self.feed_mm_min }
            }
            Canon::StraightProbe { end, kind } => Motion::Probe {
                from,
                to: self.to_machine(end),
                kind: *kind,
                feed_mm_min: self.feed_mm_min,
            },
            Canon::RigidTap { x, y, z, .. } => {
                let mut p = from;
                let target = self.to_machine(&[*x, *y, *z, 0.0, 0.0, 0.0]);
                p[..3].copy_from_slice(&target[..3]);
                Motion::RigidTap { from, to: p }
            }
            Canon::ArcFeed {
                first_end,
                second_end,
                first_axis,
                second_axis,
                rotation,
                axis_end_point,
                a,
                b,
                c,
            } => {
                let (axes, _) = crate::arc::plane_axes(self.plane);
                let mut end = [0.0, 0.0, 0.0, *a, *b, *c];
                end[axes[0]] = *first_end;
                end[axes[1]] = *second_end;
                end[axes[2]] = *axis_end_point;
                let to = self.to_machine(&end);
                // The centre, at the end's level along the normal (the offsets move it alike).
                let mut cp = end;
                cp[axes[0]] = *first_axis;
                cp[axes[1]] = *second_axis;
                let cm = self.to_machine(&cp);
                let center = [cm[0], cm[1], cm[2]];
                Motion::Arc {
                    from,
                    to,
                    center,
                    axes,
                    turn: *rotation,
                    feed_mm_min: self.feed_mm_min,
                }
            }
            Canon::NurbsFeed { order, points } => {
                let pts = points
                    .iter()
                    .map(|p| {
                        let m = self.to_machine(&[p.x, p.y, 0.0, 0.0, 0.0, 0.0]);
                        ControlPoint { x: m[0], y: m[1], w: p.w }
                    })
                    .collect();
                Motion::Nurbs { from, points: pts, order: *order, feed_mm_min: self.feed_mm_min }
            }
            _ => return None,
        };
        self.position = m.end();
        Some(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_units_and_rotation_apply_like_linuxcnc() {
        let mut f = Frame::default();
        f.apply(&Canon::UseLengthUnits(Units::Inches));
        f.apply(&Canon::SetG5xOffset { index: 1, offset: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0] });
        f.apply(&Canon::SetFeedRate(10.0));
        f.apply(&Canon::SetXyRotation(90.0));
        let m = f.apply(&Canon::StraightFeed([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])).unwrap();
        let Motion::Feed { to, feed_mm_min, .. } = m else { panic!("{m:?}") };
        assert!((to[0] - 25.4).abs() < 1e-9 && (to[1] - 25.4).abs() < 1e-9, "{to:?}");
        assert_eq!(feed_mm_min, 254.0);
        // Units change later does not change offsets already set, as in LinuxCNC's canon.
        f.apply(&Canon::UseLengthUnits(Units::Mm));
        let m = f.apply(&Canon::StraightTraverse([0.0; 6])).unwrap();
        assert!((m.end()[0] - 25.4).abs() < 1e-9);
    }

    #[test]
    fn to_program_undoes_to_machine() {
        let mut f = Frame::default();
        f.apply(&Canon::UseLengthUnits(Units::Inches));
        f.apply(&Canon::SetG5xOffset { index: 1, offset: [1.0, -2.0, 0.5, 0.0, 0.0, 0.0] });
        f.apply(&Canon::SetG92Offset([0.25, 0.0, -1.0, 0.0, 0.0, 0.0]));
        f.apply(&Canon::UseToolLengthOffset([0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        f.apply(&Canon::SetXyRotation(30.0));
        let p = [0.3, -0.7, 1.9, 10.0, 0.0, 0.0];
        let back = f.to_program(&f.to_machine(&p));
        for i in 0..6 {
            assert!((back[i] - p[i]).abs() < 1e-9, "{back:?} != {p:?}");
        }
        // Machine 0 is -(offsets) in program units.
        let origin = Frame::default().to_program(&[5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(origin[0], 5.0);
    }
}
