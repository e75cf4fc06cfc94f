//! Figures for every capability, in one place: a [`Figure`] is a title and a grid of panels, each
//! panel a 2-D chart ([`Panel`]) or a 3-D projection ([`Panel3d`]) with axis labels that carry
//! units, a legend, and optional horizontal bands (a nominal value and its tolerance).
//! [`Figure::write`] renders SVG or PNG by the file's extension.
//!
//! Text needs font metrics even in SVG (the layout measures labels), so a system TrueType font
//! is looked up once; without one the figure is drawn without text and `write` says so.

use anyhow::{bail, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// Line colours, in series order: distinguishable, and readable on white.
const PALETTE: [RGBColor; 8] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x7f, 0x7f, 0x7f),
];
/// Pixels per panel; a figure of R x C panels is C * width by R * height plus the title.
const PANEL_PX: (u32, u32) = (900, 320);
const TITLE_PX: u32 = 40;
const FONT_PX: u32 = 16;
const TITLE_FONT_PX: u32 = 22;
/// Fraction of a range added on each side so lines never sit on the frame.
const MARGIN_FRACTION: f64 = 0.05;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Style {
    #[default]
    Line,
    /// Thin dashed line: rapids, references, the ideal next to the measured.
    Dashed,
    /// Points only: samples, events.
    Points,
}

/// One labelled curve of a 2-D panel.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
}

impl Series {
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series { label: label.into(), points, style: Style::Line }
    }

    pub fn styled(label: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series { label: label.into(), points, style }
    }
}

/// A horizontal band: `lo..=hi` shaded, with a legend entry (e.g. the nominal force +-10 %). A
/// band with `lo == hi` is a reference line.
#[derive(Clone, Debug)]
pub struct Band {
    pub label: String,
    pub lo: f64,
    pub hi: f64,
}

/// A 2-D chart: x and y labels name the quantity and its unit ("time, s").
#[derive(Clone, Debug, Default)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub bands: Vec<Band>,
    /// Same scale on both axes (toolpaths, contours).
    pub equal_aspect: bool,
}

impl Panel {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Panel::default()
        }
    }

    pub fn with(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    pub fn band(mut self, label: impl Into<String>, lo: f64, hi: f64) -> Self {
        self.bands.push(Band { label: label.into(), lo, hi });
        self
    }

    pub fn equal_aspect(mut self) -> Self {
        self.equal_aspect = true;
        self
    }
}

/// One labelled curve of a 3-D panel.
#[derive(Clone, Debug)]
pub struct Series3d {
    pub label: String,
    pub points: Vec<[f64; 3]>,
    pub style: Style,
}

/// A 3-D chart drawn in a fixed oblique projection, axes labelled with units.
#[derive(Clone, Debug, Default)]
pub struct Panel3d {
    pub title: String,
    pub labels: [String; 3],
    pub series: Vec<Series3d>,
    /// Separate polylines drawn in one colour under one legend entry (e.g. the rulings of a
    /// ruled surface); `(label, lines)`.
    pub meshes: Vec<(String, Vec<Vec<[f64; 3]>>)>,
}

#[derive(Clone, Debug)]
pub enum Chart {
    Flat(Panel),
    Solid(Panel3d),
}

/// A titled grid of panels, filled row by row.
#[derive(Clone, Debug)]
pub struct Figure {
    pub title: String,
    pub columns: usize,
    pub charts: Vec<Chart>,
}

/// What [`Figure::write`] produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Written {
    Labelled,
    /// No system font was found: lines only (the caller should say so).
    Unlabelled,
}

impl Figure {
    pub fn new(title: impl Into<String>) -> Self {
        Figure { title: title.into(), columns: 1, charts: Vec::new() }
    }

    pub fn columns(mut self, columns: usize) -> Self {
        self.columns = columns.max(1);
        self
    }

    pub fn panel(mut self, panel: Panel) -> Self {
        self.charts.push(Chart::Flat(panel));
        self
    }

    pub fn panel3d(mut self, panel: Panel3d) -> Self {
        self.charts.push(Chart::Solid(panel));
        self
    }

    /// [`Figure::write`], then says on stderr where it went (and if it lacks labels): what the
    /// subcommands' `--plot` does.
    pub fn save(&self, path: &Path) -> Result<()> {
        let w = self.write(path)?;
        let note = if w == Written::Unlabelled { " (no system font: unlabelled)" } else { "" };
        eprintln!("motionctl: wrote {}{note}", path.display());
        Ok(())
    }

    /// Renders to `path`: `.svg` or `.png` (any other extension is refused).
    pub fn write(&self, path: &Path) -> Result<Written> {
        if self.charts.is_empty() {
            bail!("plot {}: the figure has no panels", path.display());
        }
        let labelled = font_registered();
        let rows = self.charts.len().div_ceil(self.columns);
        let size = (PANEL_PX.0 * self.columns as u32, PANEL_PX.1 * rows as u32 + TITLE_PX);
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let drawn = match ext.as_deref() {
            Some("svg") => self.draw(&SVGBackend::new(path, size).into_drawing_area(), labelled),
            Some("png") => self.draw(&BitMapBackend::new(path, size).into_drawing_area(), labelled),
            _ => bail!("plot {}: the file name must end in .svg or .png", path.display()),
        };
        drawn.with_context(|| format!("drawing {}", path.display()))?;
        Ok(if labelled { Written::Labelled } else { Written::Unlabelled })
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, labelled: bool) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(err)?;
        let body = if labelled {
            root.titled(&self.title, ("sans-serif", TITLE_FONT_PX)).map_err(err)?
        } else {
            root.margin(TITLE_PX, 0, 0, 0)
        };
        let rows = self.charts.len().div_ceil(self.columns);
        let cells = body.split_evenly((rows, self.columns));
        for (area, chart) in cells.iter().zip(&self.charts) {
            match chart {
                Chart::Flat(p) => draw_panel(area, p, labelled)?,
                Chart::Solid(p) => draw_panel3d(area, p, labelled)?,
            }
        }
        root.present().map_err(err)?;
        Ok(())
    }
}

fn err<E: std::error::Error + Send + Sync + 'static>(e: E) -> anyhow::Error {
    anyhow::Error::new(e)
}

/// Registers a system sans-serif font with plotters once; false when the machine has none.
fn font_registered() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| {
        const CANDIDATES: [&str; 4] = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        ];
        let Some(bytes) = CANDIDATES.iter().find_map(|p| std::fs::read(p).ok()) else {
            return false;
        };
        let font: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, font).is_ok()
    })
}

/// `lo..hi` widened by the margin; a degenerate range becomes one unit wide.
fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if !lo.is_finite() || !hi.is_finite() || lo > hi {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    if span <= f64::EPSILON * hi.abs().max(1.0) {
        return (lo - 0.5, hi + 0.5);
    }
    (lo - span * MARGIN_FRACTION, hi + span * MARGIN_FRACTION)
}

fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

/// Ranges for a panel; equal aspect grows the shorter range about its centre to the panel's
/// pixel proportions.
fn panel_ranges(p: &Panel, px: (u32, u32)) -> ((f64, f64), (f64, f64)) {
    let pts = || p.series.iter().flat_map(|s| s.points.iter().copied());
    let (x0, x1) = padded_extent(extent(pts().map(|q| q.0)));
    let bands = p.bands.iter().flat_map(|b| [b.lo, b.hi]);
    let (y0, y1) = padded_extent(extent(pts().map(|q| q.1).chain(bands)));
    if !p.equal_aspect {
        return ((x0, x1), (y0, y1));
    }
    let (w, h) = (px.0.max(1) as f64, px.1.max(1) as f64);
    let per_px = ((x1 - x0) / w).max((y1 - y0) / h);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hw, hh) = (per_px * w / 2.0, per_px * h / 2.0);
    ((cx - hw, cx + hw), (cy - hh, cy + hh))
}

fn padded_extent((lo, hi): (f64, f64)) -> (f64, f64) {
    padded(lo, hi)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    labelled: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mut b = ChartBuilder::on(area);
    b.margin(12);
    if labelled {
        b.caption(&p.title, ("sans-serif", FONT_PX + 2))
            .x_label_area_size(40)
            .y_label_area_size(70);
    }
    let (w, h) = area.dim_in_pixel();
    let plot_px = if labelled { (w.saturating_sub(94), h.saturating_sub(80)) } else { (w, h) };
    let ((x0, x1), (y0, y1)) = panel_ranges(p, plot_px);
    let mut chart = b.build_cartesian_2d(x0..x1, y0..y1).map_err(err)?;
    let mut mesh = chart.configure_mesh();
    if labelled {
        mesh.x_desc(&p.x_label).y_desc(&p.y_label).label_style(("sans-serif", FONT_PX - 2));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.light_line_style(RGBColor(0xee, 0xee, 0xee)).draw().map_err(err)?;

    for (i, band) in p.bands.iter().enumerate() {
        let color = RGBColor(0x60, 0x60, 0x60);
        let drawn = if band.hi > band.lo {
            chart.draw_series([Rectangle::new(
                [(x0, band.lo), (x1, band.hi)],
                color.mix(0.15 + 0.05 * i as f64).filled(),
            )])
        } else {
            chart.draw_series([PathElement::new(vec![(x0, band.lo), (x1, band.lo)], color)])
        };
        let anno = drawn.map_err(err)?;
        if labelled {
            anno.label(&band.label).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 16, y + 5)], color.mix(0.3).filled())
            });
        }
    }
    for (i, s) in p.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let anno = match s.style {
            Style::Line => {
                chart.draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(2)))
            }
            Style::Dashed => chart.draw_series(DashedLineSeries::new(
                s.points.iter().copied(),
                6,
                4,
                color.stroke_width(1),
            )),
            Style::Points => {
                chart.draw_series(s.points.iter().map(|&q| Circle::new(q, 2, color.filled())))
            }
        }
        .map_err(err)?;
        if labelled {
            anno.label(&s.label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
        }
    }
    if labelled && (p.series.len() + p.bands.len()) > 0 {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", FONT_PX - 2))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

fn draw_panel3d<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel3d,
    labelled: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let all = || {
        p.series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .chain(p.meshes.iter().flat_map(|(_, ls)| ls.iter().flatten().copied()))
    };
    let r = |k: usize| padded_extent(extent(all().map(|q| q[k])));
    let ((x0, x1), (y0, y1), (z0, z1)) = (r(0), r(1), r(2));
    // Equal scale on the three axes: a toolpath keeps its shape.
    let half = [(x1 - x0), (y1 - y0), (z1 - z0)].into_iter().fold(0.0f64, f64::max) / 2.0;
    let c = [(x0 + x1) / 2.0, (y0 + y1) / 2.0, (z0 + z1) / 2.0];
    let mut b = ChartBuilder::on(area);
    b.margin(12);
    if labelled {
        b.caption(&p.title, ("sans-serif", FONT_PX + 2));
    }
    // Plotters' 3-D frame: x across, y up, z into the page; the part's Z is drawn up.
    let mut chart = b
        .build_cartesian_3d(
            c[0] - half..c[0] + half,
            c[2] - half..c[2] + half,
            c[1] - half..c[1] + half,
        )
        .map_err(err)?;
    chart.with_projection(|mut pb| {
        pb.yaw = 0.6;
        pb.pitch = 0.35;
        pb.scale = 0.8;
        pb.into_matrix()
    });
    let mut axes = chart.configure_axes();
    if labelled {
        axes.label_style(("sans-serif", FONT_PX - 4));
    } else {
        axes.x_labels(0).y_labels(0).z_labels(0);
    }
    axes.light_grid_style(RGBColor(0xee, 0xee, 0xee)).max_light_lines(4).draw().map_err(err)?;
    let to3 = |q: [f64; 3]| (q[0], q[2], q[1]);
    let mut n = 0;
    for (label, lines) in &p.meshes {
        let color = PALETTE[n % PALETTE.len()].mix(0.5);
        n += 1;
        for (k, line) in lines.iter().enumerate() {
            let anno = chart
                .draw_series(LineSeries::new(line.iter().copied().map(to3), color))
                .map_err(err)?;
            if k == 0 && labelled {
                anno.label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            }
        }
    }
    for s in &p.series {
        let color = PALETTE[n % PALETTE.len()];
        n += 1;
        let pts = s.points.iter().copied().map(to3);
        let anno = match s.style {
            Style::Line => chart.draw_series(LineSeries::new(pts, color.stroke_width(2))),
            Style::Dashed => {
                chart.draw_series(DashedLineSeries::new(pts, 6, 4, color.stroke_width(1)))
            }
            Style::Points => {
                chart.draw_series(s.points.iter().map(|&q| Circle::new(to3(q), 2, color.filled())))
            }
        }
        .map_err(err)?;
        if labelled {
            anno.label(&s.label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
        }
    }
    if labelled {
        // Axis names at the positive ends (plotters' 3-D axes carry numbers, not names).
        let style = ("sans-serif", FONT_PX - 2).into_font().color(&BLACK);
        let ends = [
            ([c[0] + half, c[1] - half, c[2] - half], &p.labels[0]),
            ([c[0] - half, c[1] + half, c[2] - half], &p.labels[1]),
            ([c[0] - half, c[1] - half, c[2] + half], &p.labels[2]),
        ];
        chart
            .draw_series(ends.iter().map(|(q, t)| Text::new(t.to_string(), to3(*q), style.clone())))
            .map_err(err)?;
        if n > 0 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", FONT_PX - 2))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(err)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure() -> Figure {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
        Figure::new("test job: force loop")
            .panel(
                Panel::new("force", "time, s", "force, N")
                    .with(Series::line(
                        "force",
                        t.iter().map(|&x| (x, 1000.0 + 50.0 * x.sin())).collect(),
                    ))
                    .band("nominal +-10 %", 900.0, 1100.0),
            )
            .panel3d(Panel3d {
                title: "toolpath".into(),
                labels: ["X, mm".into(), "Y, mm".into(), "Z, mm".into()],
                series: vec![Series3d {
                    label: "feed".into(),
                    points: t.iter().map(|&x| [x.cos(), x.sin(), x]).collect(),
                    style: Style::Line,
                }],
                meshes: vec![],
            })
    }

    #[test]
    fn svg_has_the_titles_labels_and_legend() {
        let dir = std::env::temp_dir().join(format!("plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("f.svg");
        let written = figure().write(&path).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        if written == Written::Labelled {
            for text in ["test job: force loop", "time, s", "force, N", "nominal +-10 %", "X, mm"] {
                assert!(svg.contains(text), "{text} missing from the SVG");
            }
        }
        assert!(svg.contains("<polyline") || svg.contains("<path"), "no lines drawn");
        let png = dir.join("f.png");
        figure().write(&png).unwrap();
        assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
        assert!(figure().write(&dir.join("f.jpg")).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn ranges_survive_empty_and_flat_data() {
        let p = Panel::new("t", "x", "y").with(Series::line("flat", vec![(1.0, 2.0), (1.0, 2.0)]));
        let ((x0, x1), (y0, y1)) = panel_ranges(&p, (100, 100));
        assert!(x0 < 1.0 && x1 > 1.0 && y0 < 2.0 && y1 > 2.0);
        let empty = Panel::new("t", "x", "y");
        let ((x0, x1), _) = panel_ranges(&empty, (100, 100));
        assert!(x0 < x1);
    }

    #[test]
    fn equal_aspect_keeps_one_scale() {
        let p = Panel::new("t", "x, mm", "y, mm")
            .with(Series::line("c", vec![(0.0, 0.0), (10.0, 1.0)]))
            .equal_aspect();
        let ((x0, x1), (y0, y1)) = panel_ranges(&p, (200, 100));
        assert!(((x1 - x0) / 200.0 - (y1 - y0) / 100.0).abs() < 1e-9);
    }
}
