//! The Z table file: what `motionctl turning table --out` writes and `turning run --table` (and
//! through it the board) takes. Text, one row per line:
//!
//! ```text
//! # lines starting with '#' are comments
//! x_mm c00_mm c01_mm c02_mm c03_mm        <- header: the columns, each name ending in its unit
//! 0.00000 0.00000000000 0.00000000000 0.00000000000 0.00000000000
//! 2.54000 -0.00000021336 ...
//! ```
//!
//! * Columns are separated by blanks, commas or `|`, so the `--csv` export and the thesis's
//!   FOR30 print (`F4.1|F10.7|...`) read the same way.
//! * Header: the power form (eq 2-19) is `x c00 c01 c02 c03`; the harmonic form of order `K`
//!   (`Z = a0 + sum ak cos(k phi) + bk sin(k phi)`, `1 <= K <= 8`) is `x a0 a1 b1 ... aK bK`.
//!   Every name ends in `_in` or `_mm` (all the same unit). A file without a header row is the
//!   older form: inches, power form.
//! * X is the feed coordinate (the radius for face turning, the axial position for a profile),
//!   on a uniform grid; at most [`MAX_ROWS`] rows (the board's table).
//!
//! Every line is read: a line that is not a comment, the header or a complete row of numbers is
//! an error naming `file:line:column`; no row is ever dropped.

use super::fit::Harmonics;
use super::table::CoefficientTable;
use super::units::Units;
use std::fmt;

/// Most rows a table may have: the board's table (`LINK_TABLE_ROWS`).
pub const MAX_ROWS: usize = motion::turning::link_job::LINK_TABLE_ROWS;
/// Highest harmonic order of the harmonic form (the board's `MAX_ORDER`).
pub const MAX_ORDER: u8 = motion::turning::table::MAX_ORDER as u8;
/// Largest departure of a row's X from the uniform grid, as a fraction of the step.
const GRID_TOLERANCE: f64 = 1e-4;

/// Which series a table's rows hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// `[C00, C01, C02, C03]`: `Z = C00 + C01 s + C02 s^2 + C03 s^3`, `s = sin(phi)`.
    Power,
    /// `[a0, a1, b1, ..., aK, bK]` of order `K` in `1..=8`.
    Harmonic(u8),
}

impl Form {
    /// Coefficients per row.
    pub fn width(self) -> usize {
        match self {
            Form::Power => 4,
            Form::Harmonic(k) => 2 * k as usize + 1,
        }
    }

    /// The coefficient columns' names, without the unit.
    pub fn column_names(self) -> Vec<String> {
        match self {
            Form::Power => ["c00", "c01", "c02", "c03"].map(String::from).to_vec(),
            Form::Harmonic(k) => std::iter::once("a0".to_string())
                .chain((1..=k).flat_map(|i| [format!("a{i}"), format!("b{i}")]))
                .collect(),
        }
    }

    pub fn describe(self) -> String {
        match self {
            Form::Power => "power form C00..C03 (eq 2-19)".into(),
            Form::Harmonic(k) => format!("harmonic form, order {k}"),
        }
    }
}

/// A coefficient table on the uniform grid `X = x0 + i dx`, in inches.
#[derive(Clone, Debug, PartialEq)]
pub struct ZTable {
    pub form: Form,
    pub x0_in: f64,
    pub dx_in: f64,
    /// One row of `form.width()` coefficients per X, inches.
    pub rows: Vec<Vec<f64>>,
}

impl ZTable {
    /// The power form of an f64 table.
    pub fn from_power(t: &CoefficientTable) -> Self {
        ZTable {
            form: Form::Power,
            x0_in: t.x0_in(),
            dx_in: t.dx_in(),
            rows: t.rows().iter().map(|r| r.as_array().to_vec()).collect(),
        }
    }

    /// The harmonic form of order `order` from each row's harmonics, the row's `gross_in` taken
    /// off `a0` (the part the gross path carries).
    pub fn from_harmonics(
        x0_in: f64,
        dx_in: f64,
        harmonics: &[Harmonics],
        gross_in: &[f64],
        order: u8,
    ) -> Self {
        let rows = harmonics
            .iter()
            .enumerate()
            .map(|(r, h)| {
                let c = |i: usize| h.cos_in.get(i).copied().unwrap_or(0.0);
                let s = |i: usize| h.sin_in.get(i).copied().unwrap_or(0.0);
                let mut row = vec![c(0) - gross_in.get(r).copied().unwrap_or(0.0)];
                for k in 1..=order as usize {
                    row.extend([c(k), s(k)]);
                }
                row
            })
            .collect();
        ZTable { form: Form::Harmonic(order), x0_in, dx_in, rows }
    }

    pub fn len(&self) -> usize {
        self.rows.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// X of row `i`, inches.
    pub fn x_at(&self, i: usize) -> f64 {
        self.x0_in + i as f64 * self.dx_in
    }

    pub fn last_x_in(&self) -> f64 {
        self.x_at(self.rows.len().saturating_sub(1))
    }

    /// Largest coefficient magnitude, inches (the board takes at most 1/16 in).
    pub fn largest_coefficient_in(&self) -> f64 {
        self.rows.iter().flatten().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// The coefficients at `x_in` as the board finds them: Lagrange cubic through the four
    /// nearest rows (shifted inwards at the ends; linear below four rows). `None` outside the
    /// table.
    pub fn coefficients_at(&self, x_in: f64) -> Option<Vec<f64>> {
        let n = self.rows.len();
        let last = self.last_x_in();
        let tol = 1e-9 * self.dx_in;
        if n == 0 || !x_in.is_finite() || x_in < self.x0_in - tol || x_in > last + tol {
            return None;
        }
        if n == 1 {
            return Some(self.rows[0].clone());
        }
        let u = ((x_in - self.x0_in) / self.dx_in).clamp(0.0, (n - 1) as f64);
        let cell = (u.floor() as usize).min(n - 2);
        let width = self.form.width();
        if n < 4 {
            let t = u - cell as f64;
            let (a, b) = (&self.rows[cell], &self.rows[cell + 1]);
            return Some((0..width).map(|k| a[k] + (b[k] - a[k]) * t).collect());
        }
        let start = cell.saturating_sub(1).min(n - 4);
        let t = u - start as f64;
        let w = [
            -(t - 1.0) * (t - 2.0) * (t - 3.0) / 6.0,
            t * (t - 2.0) * (t - 3.0) / 2.0,
            -t * (t - 1.0) * (t - 3.0) / 2.0,
            t * (t - 1.0) * (t - 2.0) / 6.0,
        ];
        Some((0..width).map(|k| (0..4).map(|j| w[j] * self.rows[start + j][k]).sum()).collect())
    }

    /// The series of one row at spindle angle `phi_rad`, inches.
    pub fn eval_row(form: Form, c: &[f64], phi_rad: f64) -> f64 {
        let get = |k: usize| c.get(k).copied().unwrap_or(0.0);
        match form {
            Form::Power => {
                let s = phi_rad.sin();
                get(0) + s * (get(1) + s * (get(2) + s * get(3)))
            }
            Form::Harmonic(order) => {
                let mut z = get(0);
                for k in 1..=order as usize {
                    let (s, co) = (k as f64 * phi_rad).sin_cos();
                    z += get(2 * k - 1) * co + get(2 * k) * s;
                }
                z
            }
        }
    }

    /// `Z(X, phi)` the table commands, inches (`None` outside the table).
    pub fn z_in(&self, x_in: f64, phi_rad: f64) -> Option<f64> {
        Some(Self::eval_row(self.form, &self.coefficients_at(x_in)?, phi_rad))
    }

    /// The header row in `units`.
    fn header(&self, units: Units, sep: &str) -> String {
        let u = units.name();
        std::iter::once(format!("x_{u}"))
            .chain(self.form.column_names().into_iter().map(|c| format!("{c}_{u}")))
            .collect::<Vec<_>>()
            .join(sep)
    }

    /// The table file: `comments` (each line prefixed `# `), the header, the rows in `units`,
    /// every coefficient through `coefficient` (a value in `units` -> its text).
    pub fn render(
        &self,
        units: Units,
        comments: &[String],
        coefficient: &dyn Fn(f64) -> String,
    ) -> String {
        let mut out = String::new();
        for c in comments {
            out.push_str("# ");
            out.push_str(c);
            out.push('\n');
        }
        out.push_str(&self.header(units, " "));
        out.push('\n');
        let xd = units.x_decimals();
        for (i, r) in self.rows.iter().enumerate() {
            out.push_str(&format!("{:.xd$}", units.from_in(self.x_at(i))));
            for v in r {
                out.push(' ');
                out.push_str(&coefficient(units.from_in(*v)));
            }
            out.push('\n');
        }
        out
    }

    /// The table as CSV (header row, then rows; no comments), in `units`.
    pub fn render_csv(&self, units: Units) -> String {
        let mut out = self.header(units, ",");
        out.push('\n');
        let (xd, cd) = (units.x_decimals(), units.coefficient_decimals());
        for (i, r) in self.rows.iter().enumerate() {
            out.push_str(&format!("{:.xd$}", units.from_in(self.x_at(i))));
            for v in r {
                out.push_str(&format!(",{:.cd$}", units.from_in(*v)));
            }
            out.push('\n');
        }
        out
    }

    /// Reads a table file; `name` (the path) goes into the errors.
    pub fn parse(name: &str, src: &str) -> Result<ZTable, TableFileError> {
        Parser::new(name).run(src)
    }
}

/// Where and why a table file was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TableFileError {
    pub file: String,
    /// 1-based line (0: the file as a whole).
    pub line: usize,
    /// 1-based column of the offending field.
    pub column: Option<usize>,
    pub what: String,
}

impl fmt::Display for TableFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (0, _) => write!(f, "{}: {}", self.file, self.what),
            (l, None) => write!(f, "{}:{l}: {}", self.file, self.what),
            (l, Some(c)) => write!(f, "{}:{l}:{c}: {}", self.file, self.what),
        }
    }
}

impl std::error::Error for TableFileError {}

/// The fields of a line between separators (`is_sep`), with their 1-based columns (characters).
pub(crate) fn fields_by(line: &str, is_sep: impl Fn(char) -> bool) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start: Option<(usize, usize)> = None;
    for (col, (i, ch)) in line.char_indices().enumerate() {
        match (is_sep(ch), start) {
            (true, Some((s, c))) => {
                out.push((c, &line[s..i]));
                start = None;
            }
            (false, None) => start = Some((i, col + 1)),
            _ => {}
        }
    }
    if let Some((s, c)) = start {
        out.push((c, &line[s..]));
    }
    out
}

/// A table line's fields: blanks, commas and `|` separate.
fn fields(line: &str) -> Vec<(usize, &str)> {
    fields_by(line, |c| c.is_whitespace() || c == ',' || c == '|')
}

struct Parser<'a> {
    name: &'a str,
    layout: Option<(Units, Form)>,
    xs: Vec<(usize, f64)>,
    rows: Vec<Vec<f64>>,
}

impl<'a> Parser<'a> {
    fn new(name: &'a str) -> Self {
        Parser { name, layout: None, xs: Vec::new(), rows: Vec::new() }
    }

    fn err(&self, line: usize, column: Option<usize>, what: String) -> TableFileError {
        TableFileError { file: self.name.to_string(), line, column, what }
    }

    fn run(mut self, src: &str) -> Result<ZTable, TableFileError> {
        for (i, raw) in src.lines().enumerate() {
            let line = i + 1;
            let text = raw.trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let f = fields(raw);
            if f.is_empty() {
                return Err(self.err(line, None, format!("`{text}` holds no values")));
            }
            if self.layout.is_none() {
                if f[0].1.parse::<f64>().is_err() {
                    self.layout = Some(self.header(line, &f)?);
                    continue;
                }
                // No header: the older form.
                self.layout = Some((Units::In, Form::Power));
            }
            self.row(line, &f)?;
        }
        self.finish()
    }

    fn header(&self, line: usize, f: &[(usize, &str)]) -> Result<(Units, Form), TableFileError> {
        let mut units: Option<Option<Units>> = None;
        let mut names = Vec::with_capacity(f.len());
        for &(col, name) in f {
            let lower = name.to_ascii_lowercase();
            let (base, unit) = match lower.rsplit_once('_') {
                Some((b, "in")) => (b.to_string(), Some(Units::In)),
                Some((b, "mm")) => (b.to_string(), Some(Units::Mm)),
                _ => (lower.clone(), None),
            };
            match units {
                None => units = Some(unit),
                Some(u) if u != unit => {
                    return Err(self.err(
                        line,
                        Some(col),
                        format!("`{name}`: every column name needs the same unit (_in or _mm)"),
                    ))
                }
                _ => {}
            }
            names.push((col, base));
        }
        let units = units.flatten().unwrap_or(Units::In);
        let expect = |form: Form| -> Vec<String> {
            std::iter::once("x".to_string()).chain(form.column_names()).collect()
        };
        let k = names.len().saturating_sub(2) / 2;
        let candidates = [Form::Power, Form::Harmonic(k.clamp(1, MAX_ORDER as usize) as u8)];
        for form in candidates {
            let want = expect(form);
            if want.len() == names.len() && want.iter().zip(&names).all(|(w, (_, n))| w == n) {
                return Ok((units, form));
            }
        }
        // Name the first column that fits neither form.
        let want = if names.get(1).is_some_and(|(_, n)| n.starts_with('c')) {
            expect(Form::Power)
        } else {
            expect(candidates[1])
        };
        let (col, got) = names
            .iter()
            .zip(want.iter().map(Some).chain(std::iter::repeat(None)))
            .find(|((_, n), w)| w.is_none_or(|w| w != n))
            .map(|((c, n), _)| (Some(*c), n.clone()))
            .unwrap_or((None, format!("{} columns", names.len())));
        Err(self.err(
            line,
            col,
            format!(
                "header: unexpected `{got}`; a power table's columns are x c00 c01 c02 c03, a \
                 harmonic one's x a0 a1 b1 ... aK bK (K <= {MAX_ORDER}), each name ending in \
                 _in or _mm"
            ),
        ))
    }

    fn row(&mut self, line: usize, f: &[(usize, &str)]) -> Result<(), TableFileError> {
        let Some((_, form)) = self.layout else { return Ok(()) };
        let width = 1 + form.width();
        if f.len() != width {
            let col = f.get(width).map(|c| c.0);
            return Err(self.err(
                line,
                col,
                format!("{} values, a row of this table has {width} (X and {})", f.len(), {
                    let names = form.column_names();
                    format!("{}..{}", names[0], names[names.len() - 1])
                }),
            ));
        }
        if self.rows.len() == MAX_ROWS {
            return Err(self.err(
                line,
                None,
                format!("more than {MAX_ROWS} rows: the board's table holds at most {MAX_ROWS}"),
            ));
        }
        let mut values = Vec::with_capacity(width);
        for &(col, text) in f {
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => values.push(v),
                _ => {
                    return Err(self.err(
                        line,
                        Some(col),
                        format!("`{text}` is not a finite number"),
                    ))
                }
            }
        }
        self.xs.push((line, values[0]));
        self.rows.push(values.split_off(1));
        Ok(())
    }

    fn finish(self) -> Result<ZTable, TableFileError> {
        let Some((units, form)) = self.layout else {
            return Err(self.err(0, None, "no table rows".into()));
        };
        if self.rows.len() < 2 {
            return Err(self.err(0, None, "a table needs at least two rows".into()));
        }
        let (x0, dx) = (self.xs[0].1, self.xs[1].1 - self.xs[0].1);
        if dx <= 0.0 {
            return Err(self.err(self.xs[1].0, Some(1), "X must increase from row to row".into()));
        }
        for (i, &(line, x)) in self.xs.iter().enumerate() {
            let want = x0 + dx * i as f64;
            if (x - want).abs() > dx * GRID_TOLERANCE {
                return Err(self.err(
                    line,
                    Some(1),
                    format!("X = {x} is off the uniform grid {x0} + {dx} i (expected {want})"),
                ));
            }
        }
        Ok(ZTable {
            form,
            x0_in: units.to_in(x0),
            dx_in: units.to_in(dx),
            rows: self
                .rows
                .into_iter()
                .map(|r| r.into_iter().map(|v| units.to_in(v)).collect())
                .collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_and_columns() {
        assert_eq!(fields(" 8.0|-0.1, 2  x"), vec![(2, "8.0"), (6, "-0.1"), (12, "2"), (15, "x")]);
        assert!(fields(" , | ").is_empty());
    }

    #[test]
    fn cubic_interpolation_is_exact_for_cubics() {
        let f = |x: f64| 1e-3 * x * x * x - 2e-3 * x + 5e-4;
        let t = ZTable {
            form: Form::Harmonic(1),
            x0_in: 0.0,
            dx_in: 0.5,
            rows: (0..9).map(|i| vec![f(i as f64 * 0.5), 0.0, 0.0]).collect(),
        };
        for x in [0.0, 0.26, 1.9, 4.0] {
            assert!((t.coefficients_at(x).unwrap()[0] - f(x)).abs() < 1e-15);
        }
        assert!(t.coefficients_at(4.1).is_none());
    }
}
