//! User shapes from MDI data files (seed L2743, Appendix C8): the first number is the
//! workpiece thickness ZT, the second the number of points N, then N groups of
//! XB, YB, XT, YT. Numbers are separated by commas and/or white space (GW-BASIC `INPUT #`);
//! lines starting with `#` are comments.

use super::{Die, Point2, Result, WireError};

const FIELDS: [&str; 4] = ["XB", "YB", "XT", "YT"];

/// Parses an MDI file into a [`Die`] (top and bottom as given, not closed).
pub fn parse_mdi(text: &str) -> Result<Die> {
    let mut tokens = text
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .flat_map(|l| l.split(|c: char| c == ',' || c.is_whitespace()))
        .filter(|t| !t.is_empty());
    let mut num = |what: String| -> Result<f64> {
        let t = tokens
            .next()
            .ok_or_else(|| WireError::Parse(format!("{what}: missing (file ends early)")))?;
        let v: f64 =
            t.parse().map_err(|_| WireError::Parse(format!("{what}: `{t}` is not a number")))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(WireError::Parse(format!("{what}: `{t}` is not finite")))
        }
    };
    let zt = num("ZT (first number)".into())?;
    let n = num("N (second number)".into())?;
    if !(n >= 1.0 && n.fract() == 0.0 && n <= 1e6) {
        return Err(WireError::Parse(format!(
            "N (second number): {n} is not a positive whole number"
        )));
    }
    let n = n as usize;
    let (mut top, mut bottom) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut v = [0.0; 4];
        for (k, f) in FIELDS.iter().enumerate() {
            v[k] = num(format!("point index {i} field {f}"))?;
        }
        bottom.push(Point2::new(v[0], v[1]));
        top.push(Point2::new(v[2], v[3]));
    }
    if let Some(t) = tokens.next() {
        return Err(WireError::Parse(format!(
            "after point index {}: unexpected extra value `{t}`",
            n - 1
        )));
    }
    Die::new(zt, top, bottom)
}

/// Writes `die` in the MDI format, one point per line.
pub fn write_mdi(die: &Die) -> String {
    let mut s = format!("{}\n{}\n", die.zt_mm, die.top.len());
    for (b, t) in die.bottom.iter().zip(&die.top) {
        s += &format!("{},{},{},{}\n", b.x_mm, b.y_mm, t.x_mm, t.y_mm);
    }
    s
}
