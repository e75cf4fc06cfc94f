//! The polar machine's work area: the radii and the angle span the arm reaches about the machine
//! pole. Fahim's machine (3 in < r < 13 in, 0 < theta < 2.8 rad) is the preset `fahim-1983`
//! and the default; a user's machine comes from the `[polar]` table of a machine file:
//!
//! ```toml
//! [polar]
//! preset = "fahim-1983"   # optional: start from a named machine
//! r_min_mm = 50           # or r_min_in; overrides the preset
//! r_max_mm = 400          # or r_max_in
//! theta_span_deg = 150    # theta from 0 to this
//! ```

use anyhow::{anyhow, bail, Context, Result};
use serde::Deserialize;
use std::fmt;
use std::path::Path;

const MM_PER_IN: f64 = 25.4;

/// Where the tool centre may go, about the machine pole: `r_min < r < r_max`,
/// `theta_min < theta < theta_max` (theta_min is 0 for a machine; an [`WorkArea::inset`] area
/// has it above).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkArea {
    pub r_min_in: f64,
    pub r_max_in: f64,
    pub theta_min_rad: f64,
    pub theta_max_rad: f64,
}

/// Named machines.
pub const PRESETS: [(&str, WorkArea); 1] = [("fahim-1983", WorkArea::FAHIM_1983)];

impl WorkArea {
    /// Fahim's machine: 3 in (7.62 cm) < r < 13 in (33.02 cm), 0 < theta < 2.8 rad.
    pub const FAHIM_1983: WorkArea = WorkArea {
        r_min_in: super::R_MIN_IN,
        r_max_in: super::R_MAX_IN,
        theta_min_rad: 0.0,
        theta_max_rad: super::THETA_MAX_RAD,
    };

    /// A work area after checking it: finite, `0 <= r_min < r_max`, `0 < theta_max <= 2 pi`.
    pub fn new(r_min_in: f64, r_max_in: f64, theta_max_rad: f64) -> Result<WorkArea> {
        if !(r_min_in.is_finite() && r_min_in >= 0.0) {
            bail!("r_min must be a finite number >= 0 (got {r_min_in} in)");
        }
        if !(r_max_in.is_finite() && r_max_in > r_min_in) {
            bail!("r_max must be a finite number above r_min {r_min_in} in (got {r_max_in} in)");
        }
        if !(theta_max_rad.is_finite()
            && theta_max_rad > 0.0
            && theta_max_rad <= 2.0 * std::f64::consts::PI)
        {
            bail!(
                "theta_span_deg must be within (0, 360] (got {:.4} deg)",
                theta_max_rad.to_degrees()
            );
        }
        Ok(WorkArea { r_min_in, r_max_in, theta_min_rad: 0.0, theta_max_rad })
    }

    /// The area whose points are at least `margin_in` inside this one (radially, and by arc at
    /// the inner radius on the angle), or `None` if nothing is left: where a contour may lie
    /// for a tool of that radius to stay inside.
    pub fn inset(&self, margin_in: f64) -> Option<WorkArea> {
        let r_min_in = self.r_min_in + margin_in;
        let r_max_in = self.r_max_in - margin_in;
        let dth = if r_min_in > 0.0 { margin_in / r_min_in } else { f64::INFINITY };
        let a = WorkArea {
            r_min_in,
            r_max_in,
            theta_min_rad: self.theta_min_rad + dth,
            theta_max_rad: self.theta_max_rad - dth,
        };
        (a.r_max_in > a.r_min_in && a.theta_max_rad > a.theta_min_rad).then_some(a)
    }

    /// Whether `(r, theta)` (unwrapped theta) is strictly inside.
    pub fn contains(&self, r_in: f64, theta_rad: f64) -> bool {
        r_in > self.r_min_in
            && r_in < self.r_max_in
            && theta_rad > self.theta_min_rad
            && theta_rad < self.theta_max_rad
    }

    /// How far `(r, theta)` lies outside, inches (0 inside): the radial overshoot, or the arc
    /// at radius r past the nearer edge of the angle span, whichever is larger.
    pub fn miss_in(&self, r_in: f64, theta_rad: f64) -> f64 {
        let radial = (self.r_min_in - r_in).max(r_in - self.r_max_in).max(0.0);
        let angular = (self.theta_min_rad - theta_rad).max(theta_rad - self.theta_max_rad).max(0.0)
            * r_in.abs();
        radial.max(angular)
    }

    /// The `[polar]` table of the machine file at `path`.
    pub fn from_file(path: &Path) -> Result<WorkArea> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Self::parse(&text).with_context(|| format!("{}: [polar]", path.display()))
    }

    /// [`WorkArea::from_file`] on text.
    pub fn parse(text: &str) -> Result<WorkArea> {
        #[derive(Deserialize)]
        struct File {
            polar: Option<toml::Value>,
        }
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Polar {
            preset: Option<String>,
            r_min_in: Option<f64>,
            r_min_mm: Option<f64>,
            r_max_in: Option<f64>,
            r_max_mm: Option<f64>,
            theta_span_deg: Option<f64>,
        }
        let file: File = toml::from_str(text).map_err(|e| anyhow!("{e}"))?;
        let table = file.polar.ok_or_else(|| anyhow!("the file has no [polar] table"))?;
        let p: Polar = table.try_into().map_err(|e| anyhow!("{e}"))?;
        let base = match &p.preset {
            None => None,
            Some(name) => {
                Some(PRESETS.iter().find(|(n, _)| n == name).map(|(_, a)| *a).ok_or_else(|| {
                    let names: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
                    anyhow!("preset `{name}` is not known (known: {})", names.join(", "))
                })?)
            }
        };
        let length =
            |key: &str, inch: Option<f64>, mm: Option<f64>, preset: Option<f64>| match (inch, mm) {
                (Some(_), Some(_)) => bail!("{key}_in and {key}_mm both given: give one"),
                (Some(v), None) => Ok(v),
                (None, Some(v)) => Ok(v / MM_PER_IN),
                (None, None) => preset
                    .ok_or_else(|| anyhow!("{key}_in or {key}_mm is missing (or give a preset)")),
            };
        let r_min = length("r_min", p.r_min_in, p.r_min_mm, base.map(|a| a.r_min_in))?;
        let r_max = length("r_max", p.r_max_in, p.r_max_mm, base.map(|a| a.r_max_in))?;
        let theta = match (p.theta_span_deg, base) {
            (Some(d), _) => d.to_radians(),
            (None, Some(a)) => a.theta_max_rad,
            (None, None) => bail!("theta_span_deg is missing (or give a preset)"),
        };
        WorkArea::new(r_min, r_max, theta)
    }
}

impl Default for WorkArea {
    fn default() -> Self {
        WorkArea::FAHIM_1983
    }
}

impl fmt::Display for WorkArea {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:.4} < r < {:.4} in ({:.2} < r < {:.2} mm), {:.2} < theta < {:.2} deg",
            self.r_min_in,
            self.r_max_in,
            self.r_min_in * MM_PER_IN,
            self.r_max_in * MM_PER_IN,
            self.theta_min_rad.to_degrees(),
            self.theta_max_rad.to_degrees()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_machine_file_gives_the_area_in_either_unit_and_refuses_what_is_not_one() {
        let a = WorkArea::parse("[polar]\nr_min_mm = 50.8\nr_max_in = 10\ntheta_span_deg = 90\n")
            .unwrap();
        assert!((a.r_min_in - 2.0).abs() < 1e-12 && a.r_max_in == 10.0);
        assert!((a.theta_max_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let p = WorkArea::parse("[polar]\npreset = \"fahim-1983\"\nr_max_in = 12\n").unwrap();
        assert_eq!((p.r_min_in, p.r_max_in, p.theta_max_rad), (3.0, 12.0, 2.8));
        for (bad, says) in [
            ("[polar]\nr_min_in = 5\nr_max_in = 4\ntheta_span_deg = 90\n", "r_max"),
            ("[polar]\nr_min_in = -1\nr_max_in = 4\ntheta_span_deg = 90\n", "r_min"),
            ("[polar]\nr_min_in = 1\nr_max_in = 4\ntheta_span_deg = 400\n", "theta_span_deg"),
            ("[polar]\nr_min_in = 1\nr_max_in = nan\ntheta_span_deg = 90\n", "r_max"),
            ("[polar]\npreset = \"lathe\"\n", "preset `lathe`"),
            ("[polar]\nr_min_in = 1\nr_min_mm = 1\n", "both given"),
            ("[polar]\nr_min_in = 1\nr_max_in = 4\n", "theta_span_deg is missing"),
            ("[polar]\nr_min = 1\n", "unknown field"),
            ("[machine]\n", "no [polar]"),
        ] {
            let e = format!("{:#}", WorkArea::parse(bad).unwrap_err());
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn miss_is_the_distance_past_the_nearer_edge() {
        let a = WorkArea::FAHIM_1983;
        assert_eq!(a.miss_in(5.0, 1.0), 0.0);
        assert!((a.miss_in(2.5, 1.0) - 0.5).abs() < 1e-12);
        assert!((a.miss_in(14.0, 1.0) - 1.0).abs() < 1e-12);
        assert!((a.miss_in(10.0, -0.01) - 0.1).abs() < 1e-12);
        assert!((a.miss_in(10.0, 2.9) - 1.0).abs() < 1e-9);
    }
}
