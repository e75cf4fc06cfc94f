//! SVG drawings (through `usvg`): the selected path, in mm about the page's centre, flattened.

use super::flatten::flatten_cubic;
use super::{cad_err, Result, JOIN_TOL_MM, MAX_FLAT_POINTS};
use crate::wire::Point2;

pub(super) fn svg_polyline(
    file: &str,
    bytes: &[u8],
    select: Option<&str>,
    tol: f64,
) -> Result<Vec<Point2>> {
    let opt = usvg::Options { dpi: 25.4, ..usvg::Options::default() };
    let tree = usvg::Tree::from_data(bytes, &opt)
        .map_err(|e| cad_err(file, format!("not a readable SVG: {e}")))?;
    let mut paths = Vec::new();
    collect_paths(tree.root(), &mut paths);
    let path = select_path(file, &paths, select)?;
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
    let (out, closed) = flatten_path(file, &what, path, map, tol)?;
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

/// The path whose `id` is `select`, or the first.
fn select_path<'a>(
    file: &str,
    paths: &[&'a usvg::Path],
    select: Option<&str>,
) -> Result<&'a usvg::Path> {
    match select {
        Some(id) => paths.iter().copied().find(|p| p.id() == id).ok_or_else(|| {
            let ids: Vec<&str> = paths.iter().map(|p| p.id()).filter(|i| !i.is_empty()).collect();
            cad_err(
                file,
                format!(
                    "no path with id `{id}` (ids of its paths: {})",
                    if ids.is_empty() { "none".to_string() } else { ids.join(", ") }
                ),
            )
        }),
        None => paths.first().copied().ok_or_else(|| cad_err(file, "no path found")),
    }
}

/// The path's one subpath flattened within `tol` through `map` (user units to mm), and whether
/// it was closed with Z.
fn flatten_path(
    file: &str,
    what: &str,
    path: &usvg::Path,
    map: impl Fn(usvg::tiny_skia_path::Point) -> Point2,
    tol: f64,
) -> Result<(Vec<Point2>, bool)> {
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
    Ok((out, closed))
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
