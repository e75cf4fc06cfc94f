//! Homing switches in the machine file: an axis's `home = { ... }` entry and the machine's
//! `home_order`, checked and turned into the board's [`HomingConfig`] (steps, steps/s).
//!
//! A machine without any `home` entry has no switches: homing it takes the axes where they stand
//! as machine zero, which only the operator can vouch for (`runner::ZeroHere`).

use motion::machine::config::MAX_HOME_TRAVEL_STEPS;
use motion::machine::HomeAxis;
use motion::protocol::HomingConfig;
use motion::MAX_AXES;
use serde::Deserialize;

/// Search distance when the file gives none, as a multiple of the axis's travel (grbl's 1.5).
pub const DEFAULT_SEARCH_TRAVELS: f64 = 1.5;
/// Back-off from the switch when the file gives none, mm.
pub const DEFAULT_BACKOFF_MM: f64 = 2.0;

/// Which limit switch an axis homes on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SwitchEnd {
    Min,
    Max,
}

/// An axis's `home` entry as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawHome {
    /// The switch it homes on: `"min"` or `"max"`.
    pub switch: SwitchEnd,
    /// Machine position of the switch's latch point, mm.
    pub at_mm: f64,
    /// Speed toward the switch, mm/s.
    pub search_mm_s: f64,
    /// Slower second approach that sets the origin, mm/s.
    pub latch_mm_s: f64,
    /// Distance backed off the switch between the approaches and after homing, mm.
    #[serde(default)]
    pub backoff_mm: Option<f64>,
    /// Longest search before "switch not found", mm (default 1.5 x the axis's travel).
    #[serde(default)]
    pub max_search_mm: Option<f64>,
}

/// An axis's homing, checked, in mm and mm/s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisHome {
    pub switch: SwitchEnd,
    pub at_mm: f64,
    pub search_mm_s: f64,
    pub latch_mm_s: f64,
    pub backoff_mm: f64,
    pub max_search_mm: f64,
}

/// What [`check_axis`] needs to know of the axis.
pub struct AxisLimits {
    pub steps_per_mm: f64,
    pub max_rate_mm_s: f64,
    pub min_mm: f64,
    pub max_mm: f64,
}

/// A bad field of a `home` entry: the field's name (within the entry) and why.
pub type FieldError = (&'static str, String);

/// Checks an axis's `home` entry against the axis: speeds within its top speed (the latch no
/// faster than the search), the switch inside the soft limits, distances that the board can
/// count and that are at least a step.
pub fn check_axis(raw: &RawHome, axis: &AxisLimits) -> Result<AxisHome, FieldError> {
    let travel_mm = axis.max_mm - axis.min_mm;
    let backoff_mm = raw.backoff_mm.unwrap_or(DEFAULT_BACKOFF_MM);
    let max_search_mm = raw.max_search_mm.unwrap_or(travel_mm * DEFAULT_SEARCH_TRAVELS);
    let finite = |field, v: f64| {
        if v.is_finite() {
            Ok(v)
        } else {
            Err((field, format!("must be a finite number, got {v}")))
        }
    };
    let at_mm = finite("at_mm", raw.at_mm)?;
    if at_mm < axis.min_mm || at_mm > axis.max_mm {
        return Err((
            "at_mm",
            format!(
                "the switch must be within the axis's travel ({} ..= {} mm), got {at_mm} mm",
                axis.min_mm, axis.max_mm
            ),
        ));
    }
    let search_mm_s = finite("search_mm_s", raw.search_mm_s)?;
    if search_mm_s <= 0.0 || search_mm_s > axis.max_rate_mm_s {
        return Err((
            "search_mm_s",
            format!(
                "must be > 0 and at most the axis's max_rate_mm_s ({}), got {search_mm_s}",
                axis.max_rate_mm_s
            ),
        ));
    }
    let latch_mm_s = finite("latch_mm_s", raw.latch_mm_s)?;
    if latch_mm_s <= 0.0 || latch_mm_s > search_mm_s {
        return Err((
            "latch_mm_s",
            format!("must be > 0 and at most search_mm_s ({search_mm_s}), got {latch_mm_s}"),
        ));
    }
    let step_mm = 1.0 / axis.steps_per_mm;
    let max_steps = |mm: f64| mm * axis.steps_per_mm <= MAX_HOME_TRAVEL_STEPS as f64;
    let backoff_mm = finite("backoff_mm", backoff_mm)?;
    if backoff_mm < step_mm || !max_steps(backoff_mm * 2.0) {
        return Err((
            "backoff_mm",
            format!("must be at least one step ({step_mm} mm) and countable, got {backoff_mm}"),
        ));
    }
    let max_search_mm = finite("max_search_mm", max_search_mm)?;
    if max_search_mm <= backoff_mm || !max_steps(max_search_mm) {
        return Err((
            "max_search_mm",
            format!(
                "must be more than backoff_mm ({backoff_mm}) and at most {} mm on this axis, got \
                 {max_search_mm}",
                MAX_HOME_TRAVEL_STEPS as f64 / axis.steps_per_mm
            ),
        ));
    }
    Ok(AxisHome { switch: raw.switch, at_mm, search_mm_s, latch_mm_s, backoff_mm, max_search_mm })
}

/// The homing order: `order` (axis names, as `home_order` gives them) when given, else the axes
/// with a `home` entry in file order. Every axis with a `home` entry is homed exactly once.
/// `names[i]` is axis i's name, `homed[i]` whether it has a `home` entry.
pub fn order(
    order: Option<&[String]>,
    names: &[&str],
    homed: &[bool],
) -> Result<Vec<usize>, String> {
    let Some(order) = order else {
        return Ok((0..names.len()).filter(|&i| homed[i]).collect());
    };
    let mut out: Vec<usize> = Vec::with_capacity(order.len());
    for name in order {
        let Some(i) = names.iter().position(|n| n.eq_ignore_ascii_case(name.trim())) else {
            return Err(format!("no axis {name:?} (axes: {})", names.join(", ")));
        };
        if !homed[i] {
            return Err(format!("axis {} has no `home` entry (its switch)", names[i]));
        }
        if out.contains(&i) {
            return Err(format!("axis {} is listed twice", names[i]));
        }
        out.push(i);
    }
    if let Some(missing) = (0..names.len()).find(|&i| homed[i] && !out.contains(&i)) {
        return Err(format!(
            "axis {} has a `home` entry but is not in the order: list it or remove its entry",
            names[missing]
        ));
    }
    Ok(out)
}

/// The board's homing config: the axes of `order` with their `homes` in steps
/// (`steps_per_mm[i]` of axis i). No axis in `order`: no switches, home where it stands.
pub fn config(order: &[usize], homes: &[Option<AxisHome>], steps_per_mm: &[f64]) -> HomingConfig {
    let mut cfg = HomingConfig::NONE;
    for (k, &i) in order.iter().enumerate().take(MAX_AXES) {
        let (Some(h), Some(&spm)) = (homes.get(i).copied().flatten(), steps_per_mm.get(i)) else {
            continue;
        };
        let steps = |mm: f64| (mm * spm).round();
        cfg.order[k] = i as u8;
        cfg.count = k as u8 + 1;
        cfg.axes[i] = HomeAxis {
            toward_max: h.switch == SwitchEnd::Max,
            search_hz: steps(h.search_mm_s).max(1.0) as u32,
            latch_hz: steps(h.latch_mm_s).max(1.0) as u32,
            backoff_steps: steps(h.backoff_mm).max(1.0) as u32,
            max_travel_steps: steps(h.max_search_mm) as u32,
            home_pos_steps: steps(h.at_mm) as i64,
        };
    }
    cfg
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(switch: SwitchEnd, at_mm: f64) -> RawHome {
        RawHome {
            switch,
            at_mm,
            search_mm_s: 20.0,
            latch_mm_s: 2.0,
            backoff_mm: None,
            max_search_mm: None,
        }
    }

    const X: AxisLimits =
        AxisLimits { steps_per_mm: 80.0, max_rate_mm_s: 250.0, min_mm: 0.0, max_mm: 300.0 };

    #[test]
    fn an_axis_home_takes_the_defaults_and_becomes_steps() {
        let h = check_axis(&raw(SwitchEnd::Max, 300.0), &X).unwrap();
        assert_eq!(h.backoff_mm, DEFAULT_BACKOFF_MM);
        assert_eq!(h.max_search_mm, 450.0);
        let cfg = config(&[0], &[Some(h)], &[80.0]);
        assert_eq!((cfg.count, cfg.order[0]), (1, 0));
        let a = cfg.axes[0];
        assert!(a.toward_max);
        assert_eq!(
            (a.search_hz, a.latch_hz, a.backoff_steps, a.max_travel_steps, a.home_pos_steps),
            (1600, 160, 160, 36_000, 24_000)
        );
    }

    #[test]
    fn bad_home_entries_name_their_field() {
        let field = |r: RawHome| check_axis(&r, &X).unwrap_err().0;
        assert_eq!(field(raw(SwitchEnd::Min, -1.0)), "at_mm");
        assert_eq!(field(raw(SwitchEnd::Min, f64::NAN)), "at_mm");
        assert_eq!(
            field(RawHome { search_mm_s: 251.0, ..raw(SwitchEnd::Min, 0.0) }),
            "search_mm_s"
        );
        assert_eq!(field(RawHome { latch_mm_s: 21.0, ..raw(SwitchEnd::Min, 0.0) }), "latch_mm_s");
        assert_eq!(field(RawHome { latch_mm_s: 0.0, ..raw(SwitchEnd::Min, 0.0) }), "latch_mm_s");
        let tiny = RawHome { backoff_mm: Some(0.001), ..raw(SwitchEnd::Min, 0.0) };
        assert_eq!(field(tiny), "backoff_mm");
        let short = RawHome { max_search_mm: Some(1.0), ..raw(SwitchEnd::Min, 0.0) };
        assert_eq!(field(short), "max_search_mm");
        let far = RawHome { max_search_mm: Some(1e9), ..raw(SwitchEnd::Min, 0.0) };
        assert_eq!(field(far), "max_search_mm");
    }

    #[test]
    fn the_order_is_the_files_or_the_homed_axes_in_turn() {
        let names = ["X", "Y", "Z"];
        let homed = [true, false, true];
        assert_eq!(order(None, &names, &homed), Ok(vec![0, 2]));
        let given = ["z".to_string(), "X".to_string()];
        assert_eq!(order(Some(&given), &names, &homed), Ok(vec![2, 0]));
        let e = |o: &[&str]| {
            let o: Vec<String> = o.iter().map(|s| s.to_string()).collect();
            order(Some(&o), &names, &homed).unwrap_err()
        };
        assert!(e(&["X", "Y", "Z"]).contains("Y has no `home` entry"));
        assert!(e(&["X", "X", "Z"]).contains("listed twice"));
        assert!(e(&["X"]).contains("Z has a `home` entry but is not in the order"));
        assert!(e(&["W"]).contains("no axis \"W\""));
    }

    #[test]
    fn no_switches_is_the_boards_home_where_it_stands() {
        assert_eq!(config(&[], &[None, None], &[80.0, 80.0]), HomingConfig::NONE);
    }

    #[test]
    fn the_config_passes_the_boards_own_check() {
        use motion::machine::BoardConfig;
        let h = check_axis(&raw(SwitchEnd::Min, 0.0), &X).unwrap();
        let homing = config(&[0], &[Some(h)], &[80.0]);
        let mut link = BoardConfig::safe_default().link;
        link.machine.axes[0].max_rate_hz = 20_000;
        assert_eq!(BoardConfig::with_homing(link, &homing).validate(), Ok(()));
    }
}
