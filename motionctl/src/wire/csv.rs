//! User shapes from MDI data files (seed L2743, Appendix C8): the first number is the
//! workpiece thickness ZT, the second the number of points N, then N groups of
//! XB, YB, XT, YT. Numbers are separated by commas and/or white space (GW-BASIC `INPUT #`);
//! lines starting with `#` are comments.

use super::{Die, Point2, Result, WireError};

const FIELDS: [&str; 4] = ["XB", "YB", "XT", "YT"];

/// Parses an MDI file into a [`Die`] (top and bottom as given, not closed). Errors name the
/// file's line (1-based) and what is wrong there.
pub fn parse_mdi(text: &str) -> Result<Die> {
    let last_line = text.lines().count();
    let mut tokens =
        text.lines().enumerate().filter(|(_, l)| !l.trim_start().starts_with('#')).flat_map(
            |(n, l)| {
                l.split(|c: char| c == ',' || c.is_whitespace())
                    .filter(|t| !t.is_empty())
                    .map(move |t| (n + 1, t))
            },
        );
    let mut num = |what: String| -> Result<(usize, f64)> {
        let (line, t) = tokens.next().ok_or_else(|| {
            WireError::Parse(format!("{what}: missing (the file ends at line {last_line})"))
        })?;
        let v: f64 = t
            .parse()
            .map_err(|_| WireError::Parse(format!("line {line}: {what}: `{t}` is not a number")))?;
        if v.is_finite() {
            Ok((line, v))
        } else {
            Err(WireError::Parse(format!("line {line}: {what}: `{t}` is not finite")))
        }
    };
    let (zt_line, zt) = num("ZT (first number)".into())?;
    if zt <= 0.0 {
        return Err(WireError::Parse(format!(
            "line {zt_line}: ZT (first number): {zt} is not a thickness > 0 mm"
        )));
    }
    let (n_line, n) = num("N (second number)".into())?;
    if !(n >= 1.0 && n.fract() == 0.0 && n <= 1e6) {
        return Err(WireError::Parse(format!(
            "line {n_line}: N (second number): {n} is not a positive whole number"
        )));
    }
    let n = n as usize;
    let (mut top, mut bottom) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut v = [0.0; 4];
        for (k, f) in FIELDS.iter().enumerate() {
            v[k] = num(format!("point index {i} field {f}"))?.1;
        }
        bottom.push(Point2::new(v[0], v[1]));
        top.push(Point2::new(v[2], v[3]));
    }
    if let Some((line, t)) = tokens.next() {
        return Err(WireError::Parse(format!(
            "line {line}: after point index {}: unexpected extra value `{t}`",
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
