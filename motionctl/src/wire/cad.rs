//! User contours for the two faces of a ruled die from drawing files: SVG paths (through
//! `usvg`) and DXF entities (through `dxf`), flattened to closed polylines within a chord
//! tolerance, then resampled by arc length to the same point count for the top and the bottom
//! (Bhatti's pairing: point `i` of the top and point `i` of the bottom make ruling line `i`).
//!
//! Units and axes:
//! - SVG: 1 user unit = 1 mm unless the file says otherwise. `usvg` resolves every transform
//!   and the root `viewBox` against `width`/`height`; those are read with 25.4 "dpi", so
//!   `width="100mm" viewBox="0 0 1000 1000"` makes a user unit 0.1 mm, `in`, `cm`, `pt` and `pc`
//!   convert to mm, and a plain number or `px` counts as mm. The centre of the page (the
//!   `viewBox`, or `width` x `height`) is the workpiece centre (a `viewBox` centred on 0 keeps
//!   the user origin there); a file with no page keeps its user origin. SVG's y axis points
//!   down, the die's up, so y is negated (the die seen from above looks as the drawing does).
//!   `usvg` turns elliptical arcs (`A`, `<circle>`, `<ellipse>`, rounded `<rect>`) into cubic
//!   Béziers, four per full turn below about 300 user units of radius, which lie at most
//!   2.7e-4 R outside the true arc (0.005 mm at R 20 mm); Béziers are then flattened within
//!   the chord tolerance.
//! - DXF: `$INSUNITS` scales to mm (unitless counts as mm); the drawing's origin is the
//!   workpiece centre; entities lie in the XY plane (extrusion +Z, or -Z for a mirrored one).
//!
//! Which contour: an SVG file gives its first path (`<path>`, `<circle>`, `<rect>`,
//! `<polygon>`, ... in document order; unpainted ones included, `display: none` ones not) or
//! the one whose `id` is named (`FILE#ID` on the command line); it must have exactly one
//! subpath. A DXF file gives the one
//! closed loop its LWPOLYLINE, LINE, ARC, CIRCLE and SPLINE entities make (open pieces are
//! chained end to end within 0.001 mm, in any order and direction), or the loop on the named
//! layer (`FILE#LAYER`); other entity types are ignored.
//!
//! Pairing rule ([`resample`]): each contour is made counter-clockwise (seen from +Z), starts
//! where the ray from its centroid towards +X leaves it (the outermost crossing), and is
//! resampled to `n` points equally spaced along its length; the die's faces get those `n`
//! points and the first again at the end, so the cut goes once round and closes.

use super::area::polygon_area_signed_mm2;
use super::{Die, Point2};
use std::path::Path;

/// Largest gap between the ends of two DXF pieces that still joins them, mm.
pub const JOIN_TOL_MM: f64 = 1e-3;
/// Default chord tolerance: largest distance of a flattened chord from its curve, mm.
pub const DEFAULT_CHORD_TOL_MM: f64 = 0.01;
/// Default number of points per face.
pub const DEFAULT_POINTS: usize = 120;
/// Smallest chord tolerance accepted, mm (smaller ones only make points).
pub const MIN_CHORD_TOL_MM: f64 = 1e-4;
/// Most points a flattened contour may have.
pub const MAX_FLAT_POINTS: usize = 200_000;
/// Most points per face after resampling.
pub const MAX_POINTS: usize = 100_000;
/// Nesting limit of curve subdivision (at most 65536 chords per curve).
const MAX_DEPTH: u32 = 16;

/// Why a contour could not be read: the file (and the element, layer or entity) and what.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {what}")]
pub struct CadError {
    pub file: String,
    pub what: String,
}

fn cad_err(file: &str, what: impl Into<String>) -> CadError {
    CadError { file: file.to_string(), what: what.into() }
}

pub type Result<T> = std::result::Result<T, CadError>;

/// A closed contour read from a drawing: counter-clockwise, the closing point not repeated.
#[derive(Clone, Debug, PartialEq)]
pub struct Contour {
    /// The file (and `#ID` or `#LAYER`) it came from.
    pub source: String,
    /// The flattened contour, mm.
    pub points: Vec<Point2>,
}

impl Contour {
    /// Length of the closed polyline, mm.
    pub fn perimeter_mm(&self) -> f64 {
        perimeter_mm(&self.points)
    }

    /// Enclosed area, mm^2.
    pub fn area_mm2(&self) -> f64 {
        polygon_area_signed_mm2(&self.points).abs()
    }
}

/// Length of the closed polyline through `points`, mm.
pub fn perimeter_mm(points: &[Point2]) -> f64 {
    let n = points.len();
    (0..n).map(|i| points[i].dist_mm(points[(i + 1) % n])).sum()
}

/// Splits `FILE#ID` into the file and the selector. A name that exists as a file is taken
/// whole (a `#` in a file name still works).
pub fn split_selector(arg: &str) -> (&str, Option<&str>) {
    if Path::new(arg).exists() {
        return (arg, None);
    }
    match arg.rsplit_once('#') {
        Some((f, id)) if !f.is_empty() && !id.is_empty() => (f, Some(id)),
        _ => (arg, None),
    }
}

/// Checks a chord tolerance.
pub fn check_chord_tol(tol_mm: f64) -> std::result::Result<f64, String> {
    if tol_mm.is_finite() && tol_mm >= MIN_CHORD_TOL_MM {
        Ok(tol_mm)
    } else {
        Err(format!("chord tolerance {tol_mm} mm: must be a finite number >= {MIN_CHORD_TOL_MM}"))
    }
}

/// Reads the contour of `arg` (`FILE` or `FILE#ID`): SVG by the extension `.svg`, DXF by
/// `.dxf` (any case).
pub fn read_contour(arg: &str, chord_tol_mm: f64) -> Result<Contour> {
    let (file, select) = split_selector(arg);
    check_chord_tol(chord_tol_mm).map_err(|e| cad_err(file, e))?;
    let ext = Path::new(file).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let bytes = std::fs::read(file).map_err(|e| cad_err(file, format!("cannot read: {e}")))?;
    let raw = match ext.as_deref() {
        Some("svg") => svg_polyline(file, &bytes, select, chord_tol_mm)?,
        Some("dxf") => dxf_polyline(file, &bytes, select, chord_tol_mm)?,
        _ => return Err(cad_err(file, "unknown drawing type: the name must end in .svg or .dxf")),
    };
    let source = match select {
        Some(s) => format!("{file}#{s}"),
        None => file.to_string(),
    };
    let points = finish_contour(&source, raw)?;
    Ok(Contour { source, points })
}

/// Checks a flattened closed polyline (finite, not degenerate, not self-intersecting) and makes
/// it counter-clockwise without a repeated closing point.
pub fn finish_contour(source: &str, mut pts: Vec<Point2>) -> Result<Vec<Point2>> {
    if let Some((i, p)) =
        pts.iter().enumerate().find(|(_, p)| !(p.x_mm.is_finite() && p.y_mm.is_finite()))
    {
        return Err(cad_err(
            source,
            format!("point {i} of the contour is not finite ({}, {})", p.x_mm, p.y_mm),
        ));
    }
    pts.dedup_by(|a, b| a.dist_mm(*b) <= 1e-9);
    while pts.len() > 1 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-9 {
        pts.pop();
    }
    if pts.len() < 3 {
        return Err(cad_err(
            source,
            format!("the contour has {} distinct point(s): nothing to cut", pts.len()),
        ));
    }
    if pts.len() > MAX_FLAT_POINTS {
        return Err(cad_err(
            source,
            format!(
                "the contour flattens to {} points (most {MAX_FLAT_POINTS}): use a larger chord \
                 tolerance",
                pts.len()
            ),
        ));
    }
    if let Some((a, b, p)) = self_intersection(&pts) {
        return Err(cad_err(
            source,
            format!(
                "the contour crosses itself near ({:.3}, {:.3}) mm (edges {a} and {b})",
                p.x_mm, p.y_mm
            ),
        ));
    }
    let area = polygon_area_signed_mm2(&pts);
    let scale = pts.iter().map(|p| p.norm_mm()).fold(0.0, f64::max).max(1.0);
    if area.abs() <= 1e-9 * scale * scale {
        return Err(cad_err(source, "the contour encloses no area (degenerate)"));
    }
    if area < 0.0 {
        pts.reverse();
    }
    Ok(pts)
}

/// First crossing of two non-adjacent edges of the closed polyline `pts`: the edge indices and
/// the point. A sweep over the edges sorted by their lowest x.
pub fn self_intersection(pts: &[Point2]) -> Option<(usize, usize, Point2)> {
    let n = pts.len();
    let edge = |i: usize| (pts[i], pts[(i + 1) % n]);
    let mut order: Vec<usize> = (0..n).collect();
    let lo = |i: usize| edge(i).0.x_mm.min(edge(i).1.x_mm);
    order.sort_by(|&a, &b| lo(a).total_cmp(&lo(b)));
    for (k, &i) in order.iter().enumerate() {
        let (a0, a1) = edge(i);
        let hi = a0.x_mm.max(a1.x_mm);
        for &j in &order[k + 1..] {
            if lo(j) > hi {
                break;
            }
            let adjacent = (i + 1) % n == j || (j + 1) % n == i;
            if adjacent {
                continue;
            }
            let (b0, b1) = edge(j);
            if let Some(p) = segments_cross(a0, a1, b0, b1) {
                return Some((i.min(j), i.max(j), p));
            }
        }
    }
    None
}

fn cross(o: Point2, a: Point2, b: Point2) -> f64 {
    (a.x_mm - o.x_mm) * (b.y_mm - o.y_mm) - (a.y_mm - o.y_mm) * (b.x_mm - o.x_mm)
}

/// Where segments a0-a1 and b0-b1 meet (touching counts), if they do.
fn segments_cross(a0: Point2, a1: Point2, b0: Point2, b1: Point2) -> Option<Point2> {
    if a0.y_mm.max(a1.y_mm) < b0.y_mm.min(b1.y_mm) || b0.y_mm.max(b1.y_mm) < a0.y_mm.min(a1.y_mm) {
        return None;
    }
    let (d1, d2) = (cross(b0, b1, a0), cross(b0, b1, a1));
    let (d3, d4) = (cross(a0, a1, b0), cross(a0, a1, b1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        let t = d1 / (d1 - d2);
        return Some(Point2::new(
            a0.x_mm + (a1.x_mm - a0.x_mm) * t,
            a0.y_mm + (a1.y_mm - a0.y_mm) * t,
        ));
    }
    // Collinear overlaps and touching ends of non-adjacent edges.
    let on = |p: Point2, q0: Point2, q1: Point2, d: f64| {
        d == 0.0
            && p.x_mm >= q0.x_mm.min(q1.x_mm)
            && p.x_mm <= q0.x_mm.max(q1.x_mm)
            && p.y_mm >= q0.y_mm.min(q1.y_mm)
            && p.y_mm <= q0.y_mm.max(q1.y_mm)
    };
    [(a0, b0, b1, d1), (a1, b0, b1, d2), (b0, a0, a1, d3), (b1, a0, a1, d4)]
        .into_iter()
        .find(|&(p, q0, q1, d)| on(p, q0, q1, d))
        .map(|(p, ..)| p)
}

// ---------------------------------------------------------------------------------------------
// Flattening.

/// Appends the cubic Bézier p0..p3 (p0 already in `out`) within `tol`: split in halves until
/// both inner control points are within `tol` of the chord (the curve lies in their hull).
fn flatten_cubic(out: &mut Vec<Point2>, p: [Point2; 4], tol: f64, depth: u32) {
    let d = dist_to_segment(p[1], p[0], p[3]).max(dist_to_segment(p[2], p[0], p[3]));
    if d <= tol || depth >= MAX_DEPTH {
        out.push(p[3]);
        return;
    }
    let mid = |a: Point2, b: Point2| Point2::new((a.x_mm + b.x_mm) / 2.0, (a.y_mm + b.y_mm) / 2.0);
    let (p01, p12, p23) = (mid(p[0], p[1]), mid(p[1], p[2]), mid(p[2], p[3]));
    let (p012, p123) = (mid(p01, p12), mid(p12, p23));
    let m = mid(p012, p123);
    flatten_cubic(out, [p[0], p01, p012, m], tol, depth + 1);
    flatten_cubic(out, [m, p123, p23, p[3]], tol, depth + 1);
}

/// Distance from `p` to the segment a-b, mm.
pub fn dist_to_segment(p: Point2, a: Point2, b: Point2) -> f64 {
    let (dx, dy) = (b.x_mm - a.x_mm, b.y_mm - a.y_mm);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.x_mm - a.x_mm) * dx + (p.y_mm - a.y_mm) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.dist_mm(Point2::new(a.x_mm + dx * t, a.y_mm + dy * t))
}

/// Points of the circular arc about `c` with radius `r` from angle `a0` through `sweep` (rad,
/// positive = counter-clockwise), the start excluded, chords within `tol` of the arc.
fn arc_points(c: Point2, r: f64, a0: f64, sweep: f64, tol: f64) -> Vec<Point2> {
    // Sagitta r (1 - cos(step / 2)) <= tol.
    let step = if tol >= r { std::f64::consts::FRAC_PI_2 } else { 2.0 * (1.0 - tol / r).acos() };
    let n = ((sweep.abs() / step.max(1e-6)).ceil() as usize).clamp(1, MAX_FLAT_POINTS);
    (1..=n)
        .map(|k| {
            let a = a0 + sweep * k as f64 / n as f64;
            Point2::new(c.x_mm + r * a.cos(), c.y_mm + r * a.sin())
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// SVG.

fn svg_polyline(file: &str, bytes: &[u8], select: Option<&str>, tol: f64) -> Result<Vec<Point2>> {
    let opt = usvg::Options { dpi: 25.4, ..usvg::Options::default() };
    let tree = usvg::Tree::from_data(bytes, &opt)
        .map_err(|e| cad_err(file, format!("not a readable SVG: {e}")))?;
    let mut paths = Vec::new();
    collect_paths(tree.root(), &mut paths);
    let path = match select {
        Some(id) => paths.iter().find(|p| p.id() == id).ok_or_else(|| {
            let ids: Vec<&str> = paths.iter().map(|p| p.id()).filter(|i| !i.is_empty()).collect();
            cad_err(
                file,
                format!(
                    "no path with id `{id}` (ids of its paths: {})",
                    if ids.is_empty() { "none".to_string() } else { ids.join(", ") }
                ),
            )
        })?,
        None => paths.first().ok_or_else(|| cad_err(file, "no path found"))?,
    };
    let what = if path.id().is_empty() {
        "its first path".to_string()
    } else {
        format!("path `{}`", path.id())
    };
    // The page's centre is the workpiece centre; without a page, the user origin.
    let (cx, cy) = if has_page(bytes) {
        (tree.size().width() as f64 / 2.0, tree.size().height() as f64 / 2.0)
    } else {
        (0.0, 0.0)
    };
    let ts = path.abs_transform();
    let map = |p: usvg::tiny_skia_path::Point| {
        let (x, y) = (p.x as f64, p.y as f64);
        let tx = ts.sx as f64 * x + ts.kx as f64 * y + ts.tx as f64;
        let ty = ts.ky as f64 * x + ts.sy as f64 * y + ts.ty as f64;
        // SVG's y points down, the die's up.
        Point2::new(tx - cx, cy - ty)
    };
    use usvg::tiny_skia_path::PathSegment as S;
    let mut out: Vec<Point2> = Vec::new();
    let mut closed = false;
    for seg in path.data().segments() {
        match seg {
            S::MoveTo(p) => {
                if out.len() >= 2 {
                    return Err(cad_err(
                        file,
                        format!("{what} has more than one subpath: a face needs one contour"),
                    ));
                }
                out.clear();
                closed = false;
                out.push(map(p));
            }
            S::LineTo(p) => out.push(map(p)),
            S::QuadTo(c, p) => {
                let p0 = *out.last().unwrap_or(&map(c));
                let (c, p) = (map(c), map(p));
                // The same curve as a cubic.
                let c1 = Point2::new(
                    p0.x_mm + 2.0 / 3.0 * (c.x_mm - p0.x_mm),
                    p0.y_mm + 2.0 / 3.0 * (c.y_mm - p0.y_mm),
                );
                let c2 = Point2::new(
                    p.x_mm + 2.0 / 3.0 * (c.x_mm - p.x_mm),
                    p.y_mm + 2.0 / 3.0 * (c.y_mm - p.y_mm),
                );
                flatten_cubic(&mut out, [p0, c1, c2, p], tol, 0);
            }
            S::CubicTo(c1, c2, p) => {
                let p0 = *out.last().unwrap_or(&map(c1));
                flatten_cubic(&mut out, [p0, map(c1), map(c2), map(p)], tol, 0);
            }
            S::Close => closed = true,
        }
        if out.len() > MAX_FLAT_POINTS {
            return Err(cad_err(
                file,
                format!("{what} flattens to more than {MAX_FLAT_POINTS} points: use a larger chord tolerance"),
            ));
        }
    }
    let gap = match (out.first(), out.last()) {
        (Some(a), Some(b)) => a.dist_mm(*b),
        _ => 0.0,
    };
    if !closed && gap > JOIN_TOL_MM {
        return Err(cad_err(
            file,
            format!(
                "{what} is an open contour (its ends are {gap:.3} mm apart); a die face must be \
                 closed (end the path data with Z)"
            ),
        ));
    }
    Ok(out)
}

/// Whether the root `<svg>` gives a page: a `viewBox`, or a width and a height that are not
/// percentages.
fn has_page(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else { return false };
    let Ok(doc) = usvg::roxmltree::Document::parse(text) else { return false };
    let root = doc.root_element();
    let sized = |a: &str| root.attribute(a).is_some_and(|v| !v.trim_end().ends_with('%'));
    root.attribute("viewBox").is_some() || (sized("width") && sized("height"))
}

fn collect_paths<'a>(g: &'a usvg::Group, out: &mut Vec<&'a usvg::Path>) {
    for node in g.children() {
        match node {
            usvg::Node::Group(g) => collect_paths(g, out),
            usvg::Node::Path(p) => out.push(p),
            _ => {}
        }
    }
}

// ---------------------------------------------------------------------------------------------
// DXF.

/// A flattened DXF piece: its points and whether it closes on itself.
struct Piece {
    what: String,
    points: Vec<Point2>,
    closed: bool,
}

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

fn dxf_polyline(file: &str, bytes: &[u8], select: Option<&str>, tol: f64) -> Result<Vec<Point2>> {
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
    let name = |t: &str| format!("entity {k} ({t}, layer `{}`)", e.common.layer);
    // Extrusion +Z, or -Z for a mirrored entity (object x = -world x).
    let plane = |t: &str, n: &dxf::Vector| -> Result<f64> {
        if n.x.abs() < 1e-9 && n.y.abs() < 1e-9 && n.z > 0.0 {
            Ok(1.0)
        } else if n.x.abs() < 1e-9 && n.y.abs() < 1e-9 && n.z < 0.0 {
            Ok(-1.0)
        } else {
            Err(cad_err(file, format!("{}: not in the XY plane (extrusion {:?})", name(t), n)))
        }
    };
    let finite = |t: &str, vals: &[f64]| -> Result<()> {
        if vals.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(cad_err(file, format!("{}: a coordinate is not finite", name(t))))
        }
    };
    let piece = match &e.specific {
        T::Line(l) => {
            finite("LINE", &[l.p1.x, l.p1.y, l.p2.x, l.p2.y])?;
            Piece {
                what: name("LINE"),
                points: vec![Point2::new(l.p1.x, l.p1.y), Point2::new(l.p2.x, l.p2.y)],
                closed: false,
            }
        }
        T::Circle(c) => {
            let m = plane("CIRCLE", &c.normal)?;
            finite("CIRCLE", &[c.center.x, c.center.y, c.radius])?;
            if c.radius <= 0.0 {
                return Err(cad_err(
                    file,
                    format!("{}: radius {} is not > 0", name("CIRCLE"), c.radius),
                ));
            }
            let centre = Point2::new(m * c.center.x, c.center.y);
            let mut pts = vec![Point2::new(centre.x_mm + c.radius, centre.y_mm)];
            pts.extend(arc_points(centre, c.radius, 0.0, std::f64::consts::TAU, tol));
            pts.pop();
            Piece { what: name("CIRCLE"), points: pts, closed: true }
        }
        T::Arc(a) => {
            let m = plane("ARC", &a.normal)?;
            finite("ARC", &[a.center.x, a.center.y, a.radius, a.start_angle, a.end_angle])?;
            if a.radius <= 0.0 {
                return Err(cad_err(
                    file,
                    format!("{}: radius {} is not > 0", name("ARC"), a.radius),
                ));
            }
            // Counter-clockwise from the start to the end angle; equal angles: a full turn.
            let sweep_deg = match (a.end_angle - a.start_angle).rem_euclid(360.0) {
                d if d > 0.0 && d.is_finite() => d,
                _ => 360.0,
            };
            let (a0, sweep) = (a.start_angle.to_radians(), sweep_deg.to_radians());
            let c = Point2::new(a.center.x, a.center.y);
            let mut pts =
                vec![Point2::new(c.x_mm + a.radius * a0.cos(), c.y_mm + a.radius * a0.sin())];
            pts.extend(arc_points(c, a.radius, a0, sweep, tol));
            for p in &mut pts {
                p.x_mm *= m;
            }
            Piece { what: name("ARC"), points: pts, closed: false }
        }
        T::LwPolyline(p) => {
            let m = plane("LWPOLYLINE", &p.extrusion_direction)?;
            let v = &p.vertices;
            for q in v {
                finite("LWPOLYLINE", &[q.x, q.y, q.bulge])?;
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
            Piece { what: name("LWPOLYLINE"), points: pts, closed }
        }
        T::Spline(s) => {
            let pts = spline_points(s, tol)
                .map_err(|why| cad_err(file, format!("{}: {why}", name("SPLINE"))))?;
            let closed =
                s.is_closed() || (pts.len() > 2 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-12);
            let mut pts = pts;
            if closed && pts.len() > 1 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-9 {
                pts.pop();
            }
            Piece { what: name("SPLINE"), points: pts, closed }
        }
        _ => return Ok(None),
    };
    Ok(Some(piece))
}

/// Points of an LWPOLYLINE span from `a` to `b` with `bulge` = tan(included angle / 4)
/// (positive = counter-clockwise), `a` excluded.
fn bulge_points(a: Point2, b: Point2, bulge: f64, tol: f64) -> Vec<Point2> {
    let chord = a.dist_mm(b);
    if bulge.abs() < 1e-12 || chord == 0.0 {
        return vec![b];
    }
    let theta = 4.0 * bulge.atan();
    let r = chord / (2.0 * (theta / 2.0).sin()).abs();
    // Centre: from the chord's midpoint along its left normal (for a CCW bulge below 180 deg).
    let (mx, my) = ((a.x_mm + b.x_mm) / 2.0, (a.y_mm + b.y_mm) / 2.0);
    let (ux, uy) = ((b.x_mm - a.x_mm) / chord, (b.y_mm - a.y_mm) / chord);
    // Signed distance from the midpoint to the centre along the left normal.
    let h = (chord / 2.0) / (theta / 2.0).tan();
    let c = Point2::new(mx - uy * h, my + ux * h);
    let a0 = (a.y_mm - c.y_mm).atan2(a.x_mm - c.x_mm);
    let mut pts = arc_points(c, r, a0, theta, tol);
    // The last point is b itself (no drift from the trigonometry).
    if let Some(last) = pts.last_mut() {
        *last = b;
    }
    pts
}

/// A DXF SPLINE as points within `tol`: the (rational) B-spline of its control points, knots
/// and weights; a spline with fit points only is taken as the polyline through them.
fn spline_points(s: &dxf::entities::Spline, tol: f64) -> std::result::Result<Vec<Point2>, String> {
    let ctrl: Vec<[f64; 3]> = s.control_points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let all_finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if ctrl.is_empty() {
        let fit: Vec<Point2> = s.fit_points.iter().map(|p| Point2::new(p.x, p.y)).collect();
        if fit.len() < 2 {
            return Err("no control points and fewer than 2 fit points".into());
        }
        if !fit.iter().all(|p| p.x_mm.is_finite() && p.y_mm.is_finite()) {
            return Err("a fit point is not finite".into());
        }
        return Ok(fit);
    }
    if ctrl.iter().any(|p| p[2].abs() > 1e-9) {
        return Err("a control point is off the XY plane".into());
    }
    let p = usize::try_from(s.degree_of_curve).ok().filter(|&d| (1..=11).contains(&d));
    let p = p.ok_or_else(|| format!("degree {} is not 1..11", s.degree_of_curve))?;
    let n = ctrl.len();
    let knots = &s.knot_values;
    if knots.len() != n + p + 1 {
        return Err(format!(
            "{} knots for {n} control points of degree {p} (want {})",
            knots.len(),
            n + p + 1
        ));
    }
    if !all_finite(knots) || !ctrl.iter().all(|c| all_finite(c)) {
        return Err("a knot or control point is not finite".into());
    }
    if knots.windows(2).any(|w| w[1] < w[0]) {
        return Err("the knots decrease".into());
    }
    let weights: Vec<f64> = if s.weight_values.is_empty() {
        vec![1.0; n]
    } else if s.weight_values.len() == n
        && s.weight_values.iter().all(|w| w.is_finite() && *w > 0.0)
    {
        s.weight_values.clone()
    } else {
        return Err(format!(
            "{} weights for {n} control points (each finite > 0)",
            s.weight_values.len()
        ));
    };
    let (u0, u1) = (knots[p], knots[n]);
    if u1.partial_cmp(&u0) != Some(std::cmp::Ordering::Greater) {
        return Err("the knots span no parameter range".into());
    }
    let eval = |u: f64| nurbs_point(p, knots, &ctrl, &weights, u);
    let mut out = vec![eval(u0)];
    // Each non-empty knot span, split in 4, then halved until the chord is within tol of the
    // curve at the quarter points.
    for k in p..n {
        let (a, b) = (knots[k], knots[k + 1]);
        if b <= a {
            continue;
        }
        for q in 0..4 {
            let (s0, s1) = (a + (b - a) * q as f64 / 4.0, a + (b - a) * (q + 1) as f64 / 4.0);
            refine(&eval, s0, s1, eval(s0), eval(s1), tol, 0, &mut out);
            if out.len() > MAX_FLAT_POINTS {
                return Err(format!(
                    "more than {MAX_FLAT_POINTS} points: use a larger chord tolerance"
                ));
            }
        }
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn refine(
    eval: &dyn Fn(f64) -> Point2,
    a: f64,
    b: f64,
    pa: Point2,
    pb: Point2,
    tol: f64,
    depth: u32,
    out: &mut Vec<Point2>,
) {
    let m = (a + b) / 2.0;
    let pm = eval(m);
    let dev = [0.25, 0.75]
        .iter()
        .map(|f| dist_to_segment(eval(a + (b - a) * f), pa, pb))
        .fold(dist_to_segment(pm, pa, pb), f64::max);
    if dev <= tol || depth >= MAX_DEPTH {
        out.push(pb);
        return;
    }
    refine(eval, a, m, pa, pm, tol, depth + 1, out);
    refine(eval, m, b, pm, pb, tol, depth + 1, out);
}

/// Point of the rational B-spline at `u` (de Boor on homogeneous coordinates).
fn nurbs_point(p: usize, knots: &[f64], ctrl: &[[f64; 3]], w: &[f64], u: f64) -> Point2 {
    let n = ctrl.len();
    // Span k with knots[k] <= u < knots[k + 1], k in p..n (u at the end uses the last span).
    let mut k = p;
    while k + 1 < n && u >= knots[k + 1] {
        k += 1;
    }
    let mut d: Vec<[f64; 3]> = (0..=p)
        .map(|j| {
            let c = ctrl[j + k - p];
            let wj = w[j + k - p];
            [c[0] * wj, c[1] * wj, wj]
        })
        .collect();
    for r in 1..=p {
        for j in (r..=p).rev() {
            let i = j + k - p;
            let den = knots[i + p + 1 - r] - knots[i];
            let alpha = if den > 0.0 { (u - knots[i]) / den } else { 0.0 };
            let prev = d[j - 1];
            for (v, q) in d[j].iter_mut().zip(prev) {
                *v = (1.0 - alpha) * q + alpha * *v;
            }
        }
    }
    let h = d[p];
    Point2::new(h[0] / h[2], h[1] / h[2])
}

/// Joins open pieces end to end (either direction) into closed loops; closed pieces are loops
/// of their own. An open piece left over is an open contour.
fn chain(file: &str, pieces: Vec<Piece>, join: f64) -> Result<Vec<Vec<Point2>>> {
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

// ---------------------------------------------------------------------------------------------
// Pairing.

/// Area centroid of the closed polygon `pts` (non-zero area).
pub fn centroid(pts: &[Point2]) -> Point2 {
    let n = pts.len();
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let c = p.x_mm * q.y_mm - q.x_mm * p.y_mm;
        a += c;
        cx += (p.x_mm + q.x_mm) * c;
        cy += (p.y_mm + q.y_mm) * c;
    }
    Point2::new(cx / (3.0 * a), cy / (3.0 * a))
}

/// Where the contour starts: the outermost crossing of the ray from its centroid towards +X
/// (edge index and point); without a crossing (a centroid right of the whole contour cannot
/// happen for a closed one, but a grazing ray can miss), the point of largest x.
pub fn start_point(pts: &[Point2]) -> (usize, Point2) {
    let c = centroid(pts);
    let n = pts.len();
    let mut best: Option<(usize, Point2)> = None;
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        // Half-open in y so a vertex on the ray counts once.
        if (a.y_mm <= c.y_mm) != (b.y_mm <= c.y_mm) {
            let t = (c.y_mm - a.y_mm) / (b.y_mm - a.y_mm);
            let x = a.x_mm + (b.x_mm - a.x_mm) * t;
            if x >= c.x_mm && best.is_none_or(|(_, p)| x > p.x_mm) {
                best = Some((i, Point2::new(x, c.y_mm)));
            }
        }
    }
    best.unwrap_or_else(|| {
        let i = (0..n).max_by(|&a, &b| pts[a].x_mm.total_cmp(&pts[b].x_mm)).unwrap_or(0);
        (i, pts[i])
    })
}

/// A contour resampled for pairing.
#[derive(Clone, Debug, PartialEq)]
pub struct Resampled {
    /// `n` points, counter-clockwise, equally spaced along the contour from [`start_point`].
    pub points: Vec<Point2>,
    /// Largest distance of the flattened contour from the resampled polygon, mm (corners the
    /// samples cut).
    pub deviation_mm: f64,
}

/// Resamples the closed counter-clockwise contour `pts` to `n` points equally spaced by arc
/// length, starting at [`start_point`].
pub fn resample(pts: &[Point2], n: usize) -> Resampled {
    let (i0, s) = start_point(pts);
    let m = pts.len();
    // The loop from the start point round to it again.
    let mut ring = Vec::with_capacity(m + 2);
    ring.push(s);
    for k in 1..=m {
        ring.push(pts[(i0 + k) % m]);
    }
    ring.push(s);
    ring.dedup_by(|a, b| a.dist_mm(*b) <= 1e-12);
    let mut cum = vec![0.0];
    for w in ring.windows(2) {
        cum.push(cum[cum.len() - 1] + w[0].dist_mm(w[1]));
    }
    let total = cum[cum.len() - 1];
    let at = |d: f64, j: &mut usize| {
        while *j + 2 < cum.len() && cum[*j + 1] < d {
            *j += 1;
        }
        let seg = cum[*j + 1] - cum[*j];
        let t = if seg > 0.0 { ((d - cum[*j]) / seg).clamp(0.0, 1.0) } else { 0.0 };
        let (a, b) = (ring[*j], ring[*j + 1]);
        Point2::new(a.x_mm + (b.x_mm - a.x_mm) * t, a.y_mm + (b.y_mm - a.y_mm) * t)
    };
    let mut j = 0;
    let points: Vec<Point2> = (0..n).map(|k| at(total * k as f64 / n as f64, &mut j)).collect();
    // Each vertex of the flattened contour against the resampled chord that spans it.
    let spacing = total / n as f64;
    let mut deviation_mm = 0.0f64;
    for (v, &d) in ring.iter().zip(&cum) {
        let k = ((d / spacing).floor() as usize).min(n - 1);
        let (a, b) = (points[k], points[(k + 1) % n]);
        deviation_mm = deviation_mm.max(dist_to_segment(*v, a, b));
    }
    Resampled { points, deviation_mm }
}

/// Why two contours could not be paired: a face (named by its file) or a parameter.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PairError {
    #[error(transparent)]
    Cad(#[from] CadError),
    #[error(transparent)]
    Wire(#[from] super::WireError),
}

/// The two faces of a contour die.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourPair {
    pub top: Contour,
    pub bottom: Contour,
    pub top_resampled: Resampled,
    pub bottom_resampled: Resampled,
    pub die: Die,
}

/// Pairs `top` (at Z = `zt_mm`) and `bottom` (Z = 0) with `n` points each: the die's faces are
/// the resampled points and the first again (the cut closes).
pub fn pair(
    top: Contour,
    bottom: Contour,
    zt_mm: f64,
    n: usize,
) -> std::result::Result<ContourPair, PairError> {
    if !(3..=MAX_POINTS).contains(&n) {
        return Err(PairError::Wire(super::WireError::BadParameter {
            name: "points",
            value: n as f64,
            reason: "must be 3 .. 100000",
        }));
    }
    let (tr, br) = (resample(&top.points, n), resample(&bottom.points, n));
    // Too few points can cut across a thin part of a face.
    for (c, r) in [(&top, &tr), (&bottom, &br)] {
        if let Some((_, _, p)) = self_intersection(&r.points) {
            return Err(PairError::Cad(cad_err(
                &c.source,
                format!(
                    "resampled to {n} points the face crosses itself near ({:.3}, {:.3}) mm: use \
                     more points",
                    p.x_mm, p.y_mm
                ),
            )));
        }
    }
    let close = |v: &[Point2]| v.iter().copied().chain(v.first().copied()).collect::<Vec<_>>();
    let die = Die::new(zt_mm, close(&tr.points), close(&br.points))?;
    Ok(ContourPair { top, bottom, top_resampled: tr, bottom_resampled: br, die })
}
