//! Shared helpers of the `wire_*` tests: the transcribed thesis tables under
//! `tests/data/wire/` and the "within the printed digits" comparison.
#![allow(dead_code)]

use std::cell::RefCell;

thread_local! {
    /// When set, [`check`] records failures here instead of panicking.
    pub static SOFT: RefCell<Option<Vec<String>>> = const { RefCell::new(None) };
}

use std::path::PathBuf;

pub fn data_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/wire").join(name)
}

/// One transcribed row: seed line, printed row number, printed cells.
pub struct Row {
    pub line: usize,
    pub row: usize,
    pub cells: Vec<String>,
}

impl Row {
    pub fn f(&self, k: usize) -> f64 {
        self.cells[k]
            .parse()
            .unwrap_or_else(|_| panic!("seed line {}: cell {k} `{}`", self.line, self.cells[k]))
    }
}

pub fn table(name: &str) -> Vec<Row> {
    let text = std::fs::read_to_string(data_path(name)).expect("table file");
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split('\t');
            let line = it.next().and_then(|s| s.parse().ok()).expect("seed line");
            let row = it.next().and_then(|s| s.parse().ok()).expect("row");
            Row { line, row, cells: it.map(str::to_string).collect() }
        })
        .collect()
}

/// (seed line, printed text) of a key in `scalars.tsv`.
pub fn scalar(key: &str) -> (usize, String) {
    let text = std::fs::read_to_string(data_path("scalars.tsv")).expect("scalars");
    for l in text.lines().filter(|l| !l.starts_with('#')) {
        let c: Vec<&str> = l.split('\t').collect();
        if c.len() == 3 && c[1] == key {
            return (c[0].parse().expect("line"), c[2].to_string());
        }
    }
    panic!("no scalar {key}")
}

/// Tolerance for a printed thesis number: one unit of its last printed digit (the thesis
/// truncates to 5 significant digits), a 5-significant-digit unit for GW-BASIC
/// single-precision print artefacts such as 9.567001, and never less than 1e-5 relative (the
/// thesis computed in single precision, 24-bit mantissa; digits past that are its noise), added.
pub fn tolerance(printed: &str) -> f64 {
    let v: f64 = printed.parse().expect("number");
    let decimals = printed.split_once('.').map_or(0, |(_, d)| d.len());
    let mut unit = 10f64.powi(-(decimals as i32));
    if v != 0.0 {
        let mag = v.abs().log10().floor() as i32;
        let five = 10f64.powi(mag - 4);
        let sig = printed.chars().filter(|c| c.is_ascii_digit()).collect::<String>();
        let sig = sig.trim_start_matches('0').len();
        if sig >= 7 && (v - (v / five).round() * five).abs() < 5e-7 * v.abs() {
            // A 7-digit artefact like 8.602899 (= 8.6029 in single precision): trust 4 digits.
            unit = 10f64.powi(mag - 3);
        }
    }
    unit * 1.000_001 + 1e-5 * v.abs() + 1e-12
}

/// Panics unless `ours` equals the printed `printed` within [`tolerance`].
pub fn check(ours: f64, printed: &str, what: &str, line: usize) {
    check_rel(ours, printed, what, line, 0.0);
}

/// [`check`] with `rel` extra relative tolerance (documented thesis drift).
pub fn check_rel(ours: f64, printed: &str, what: &str, line: usize, rel: f64) {
    let v: f64 = printed.parse().expect("number");
    let tol = tolerance(printed) + rel * v.abs();
    if (ours - v).abs() > tol {
        let msg = format!(
            "{what} (seed line {line}): ours {ours:.7} vs printed {printed} (tolerance {tol:.2e})"
        );
        let soft = SOFT.with(|s| s.borrow_mut().as_mut().map(|v| v.push(msg.clone())).is_some());
        assert!(soft, "{msg}");
    }
}

pub fn within(ours: f64, printed: &str) -> bool {
    let v: f64 = printed.parse().expect("number");
    (ours - v).abs() <= tolerance(printed)
}

/// [`within`] plus `abs` extra absolute tolerance (documented single-precision noise).
pub fn within_abs(ours: f64, printed: &str, abs: f64) -> bool {
    let v: f64 = printed.parse().expect("number");
    (ours - v).abs() <= tolerance(printed) + abs
}
