//! DXF drawings (through `dxf`): LWPOLYLINE, LINE, ARC, CIRCLE and SPLINE entities (of a layer)
//! as flattened pieces, in mm, chained into the one closed loop.

use super::chain::{chain, Piece};
use super::flatten::{arc_points, bulge_points};
use super::spline::spline_points;
use super::{cad_err, Result, JOIN_TOL_MM, MAX_FLAT_POINTS};
use crate::wire::Point2;

fn units_to_mm(u: dxf::enums::Units) -> Option<f64> {
    use dxf::enums::Units as U;
    Some(match u {
        U::Unitless | U::Millimeters => 1.0,
        U::Inches | U::USSurveyInch => 25.4,
        U::Feet => 304.8,
        U::USSurveyFeet => 1200.0 / 3937.0 * 1000.0,
        U::Centimeters => 10.0,
        U::Decimeters => 100.0,
        U::Meters => 1000.0,
        U::Microns => 1e-3,
        U::Mils => 0.0254,
        U::Microinches => 25.4e-6,
        U::Nanometers => 1e-6,
        U::Yards => 914.4,
        _ => return None,
    })
}

pub(super) fn dxf_polyline(
    file: &str,
    bytes: &[u8],
    select: Option<&str>,
    tol: f64,
) -> Result<Vec<Point2>> {
    let mut reader = std::io::Cursor::new(bytes);
    let drawing = dxf::Drawing::load(&mut reader)
        .map_err(|e| cad_err(file, format!("not a readable DXF: {e}")))?;
    let units = drawing.header.default_drawing_units;
    let scale = units_to_mm(units).ok_or_else(|| {
        cad_err(file, format!("$INSUNITS {units:?}: not a length unit this reader converts"))
    })?;
    // Flatten in drawing units with the tolerance converted to them.
    let tol_u = tol / scale;
    let mut pieces = Vec::new();
    let mut total = 0usize;
    let mut layers: Vec<String> = Vec::new();
    for (k, e) in drawing.entities().enumerate() {
        let layer = &e.common.layer;
        if !layers.contains(layer) {
            layers.push(layer.clone());
        }
        if select.is_some_and(|s| s != layer) {
            continue;
        }
        if let Some(p) = dxf_piece(file, k, e, tol_u)? {
            total += p.points.len();
            if total > MAX_FLAT_POINTS {
                return Err(cad_err(
                    file,
                    format!(
                        "the entities flatten to more than {MAX_FLAT_POINTS} points: use a larger \
                         chord tolerance"
                    ),
                ));
            }
            pieces.push(p);
        }
    }
    if pieces.is_empty() {
        return Err(cad_err(
            file,
            match select {
                Some(l) => format!(
                    "no LWPOLYLINE, LINE, ARC, CIRCLE or SPLINE on layer `{l}` (layers: {})",
                    layers.join(", ")
                ),
                None => "no path found: no LWPOLYLINE, LINE, ARC, CIRCLE or SPLINE entity".into(),
            },
        ));
    }
    let mut loops = chain(file, pieces, JOIN_TOL_MM / scale)?;
    if loops.len() > 1 {
        return Err(cad_err(
            file,
            format!(
                "{} closed contours{}; a face needs one (put each on its own layer and name it: \
                 FILE#LAYER)",
                loops.len(),
                select.map(|l| format!(" on layer `{l}`")).unwrap_or_default()
            ),
        ));
    }
    let pts = loops.pop().unwrap_or_default();
    Ok(pts.into_iter().map(|p| Point2::new(p.x_mm * scale, p.y_mm * scale)).collect())
}

/// Entity number `k` as a piece, `None` for entity types that carry no contour.
fn dxf_piece(file: &str, k: usize, e: &dxf::entities::Entity, tol: f64) -> Result<Option<Piece>> {
    use dxf::entities::EntityType as T;
    let at = Entity { file, k, layer: &e.common.layer };
    let piece = match &e.specific {
        T::Line(l) => line_piece(&at, l)?,
        T::Circle(c) => circle_piece(&at, c, tol)?,
        T::Arc(a) => arc_piece(&at, a, tol)?,
        T::LwPolyline(p) => return lwpolyline_piece(&at, p, tol),
        T::Spline(s) => spline_piece(&at, s, tol)?,
        _ => return Ok(None),
    };
    Ok(Some(piece))
}

/// The entity a piece is read from, for its checks and messages.
struct Entity<'a> {
    file: &'a str,
    k: usize,
    layer: &'a str,
}

impl Entity<'_> {
    /// The entity named in messages: number, type `t` and layer.
    fn name(&self, t: &str) -> String {
        format!("entity {} ({t}, layer `{}`)", self.k, self.layer)
    }

    /// Extrusion +Z, or -Z for a mirrored entity (object x = -world x): the x factor.
    fn plane(&self, t: &str, n: &dxf::Vector) -> Result<f64> {
        if n.x.abs() < 1e-9 && n.y.abs() < 1e-9 && n.z > 0.0 {
            Ok(1.0)
        } else if n.x.abs() < 1e-9 && n.y.abs() < 1e-9 && n.z < 0.0 {
            Ok(-1.0)
        } else {
            Err(cad_err(
                self.file,
                format!("{}: not in the XY plane (extrusion {:?})", self.name(t), n),
            ))
        }
    }

    fn finite(&self, t: &str, vals: &[f64]) -> Result<()> {
        if vals.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(cad_err(self.file, format!("{}: a coordinate is not finite", self.name(t))))
        }
    }

    /// A radius that is not > 0 refused.
    fn radius(&self, t: &str, r: f64) -> Result<()> {
        if r <= 0.0 {
            return Err(cad_err(self.file, format!("{}: radius {} is not > 0", self.name(t), r)));
        }
        Ok(())
    }
}

fn line_piece(at: &Entity, l: &dxf::entities::Line) -> Result<Piece> {
    at.finite("LINE", &[l.p1.x, l.p1.y, l.p2.x, l.p2.y])?;
    Ok(Piece {
        what: at.name("LINE"),
        points: vec![Point2::new(l.p1.x, l.p1.y), Point2::new(l.p2.x, l.p2.y)],
        closed: false,
    })
}

fn circle_piece(at: &Entity, c: &dxf::entities::Circle, tol: f64) -> Result<Piece> {
    let m = at.plane("CIRCLE", &c.normal)?;
    at.finite("CIRCLE", &[c.center.x, c.center.y, c.radius])?;
    at.radius("CIRCLE", c.radius)?;
    let centre = Point2::new(m * c.center.x, c.center.y);
    let mut pts = vec![Point2::new(centre.x_mm + c.radius, centre.y_mm)];
    pts.extend(arc_points(centre, c.radius, 0.0, std::f64::consts::TAU, tol));
    pts.pop();
    Ok(Piece { what: at.name("CIRCLE"), points: pts, closed: true })
}

fn arc_piece(at: &Entity, a: &dxf::entities::Arc, tol: f64) -> Result<Piece> {
    let m = at.plane("ARC", &a.normal)?;
    at.finite("ARC", &[a.center.x, a.center.y, a.radius, a.start_angle, a.end_angle])?;
    at.radius("ARC", a.radius)?;
    // Counter-clockwise from the start to the end angle; equal angles: a full turn.
    let sweep_deg = match (a.end_angle - a.start_angle).rem_euclid(360.0) {
        d if d > 0.0 && d.is_finite() => d,
        _ => 360.0,
    };
    let (a0, sweep) = (a.start_angle.to_radians(), sweep_deg.to_radians());
    let c = Point2::new(a.center.x, a.center.y);
    let mut pts = vec![Point2::new(c.x_mm + a.radius * a0.cos(), c.y_mm + a.radius * a0.sin())];
    pts.extend(arc_points(c, a.radius, a0, sweep, tol));
    for p in &mut pts {
        p.x_mm *= m;
    }
    Ok(Piece { what: at.name("ARC"), points: pts, closed: false })
}

/// `None` for a polyline without vertices.
fn lwpolyline_piece(at: &Entity, p: &dxf::entities::LwPolyline, tol: f64) -> Result<Option<Piece>> {
    let m = at.plane("LWPOLYLINE", &p.extrusion_direction)?;
    let v = &p.vertices;
    for q in v {
        at.finite("LWPOLYLINE", &[q.x, q.y, q.bulge])?;
    }
    if v.is_empty() {
        return Ok(None);
    }
    let closed = p.is_closed();
    let mut pts = vec![Point2::new(v[0].x, v[0].y)];
    let spans = if closed { v.len() } else { v.len() - 1 };
    for i in 0..spans {
        let (a, b) = (&v[i], &v[(i + 1) % v.len()]);
        let (pa, pb) = (Point2::new(a.x, a.y), Point2::new(b.x, b.y));
        pts.extend(bulge_points(pa, pb, a.bulge, tol));
    }
    if closed {
        pts.pop();
    }
    for q in &mut pts {
        q.x_mm *= m;
    }
    Ok(Some(Piece { what: at.name("LWPOLYLINE"), points: pts, closed }))
}

fn spline_piece(at: &Entity, s: &dxf::entities::Spline, tol: f64) -> Result<Piece> {
    let pts = spline_points(s, tol)
        .map_err(|why| cad_err(at.file, format!("{}: {why}", at.name("SPLINE"))))?;
    let closed = s.is_closed() || (pts.len() > 2 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-12);
    let mut pts = pts;
    if closed && pts.len() > 1 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-9 {
        pts.pop();
    }
    Ok(Piece { what: at.name("SPLINE"), points: pts, closed })
}
