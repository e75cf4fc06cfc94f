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

mod chain;
mod contour_check;
mod dxf;
mod flatten;
mod pairing;
mod spline;
mod svg;

pub use contour_check::{finish_contour, self_intersection};
pub use flatten::dist_to_segment;
pub use pairing::{centroid, pair, resample, start_point, ContourPair, PairError, Resampled};

use super::area::polygon_area_signed_mm2;
use super::Point2;
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
        Some("svg") => svg::svg_polyline(file, &bytes, select, chord_tol_mm)?,
        Some("dxf") => dxf::dxf_polyline(file, &bytes, select, chord_tol_mm)?,
        _ => return Err(cad_err(file, "unknown drawing type: the name must end in .svg or .dxf")),
    };
    let source = match select {
        Some(s) => format!("{file}#{s}"),
        None => file.to_string(),
    };
    let points = finish_contour(&source, raw)?;
    Ok(Contour { source, points })
}
