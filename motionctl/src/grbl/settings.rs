//! grbl's `$` settings, mapped from the machine file: `$100`.. steps/mm, `$110`.. max rate
//! (mm/min), `$120`.. acceleration (mm/s^2), `$130`.. travel (mm), one per machine axis; `$0`
//! step pulse (us), `$12` arc tolerance (mm), `$26` switch debounce (ms); the rest at grbl's
//! defaults or what this machine does (soft limits on, homing on, no hard limits in the bridge).
//!
//! `$N=V` on one of the machine file's values makes a new machine: the machine file's text with
//! that field replaced ([`machine_with`]), read back through the machine file's own checks, so a
//! value the file would refuse is refused with the same words. The bridge sends the new machine
//! to the board and keeps every changed setting (and the `$Nx=` startup lines) in an overlay
//! file beside the machine file ([`overlay_path`], [`Overlay`]) that it reads at start; `$RST=$`
//! drops the settings from it. The machine file itself is never written.

use crate::job::Machine;
use anyhow::{bail, Context};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A setting's value: grbl prints integers without decimals, the rest with three.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Value {
    pub v: f64,
    pub integer: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    values: BTreeMap<u16, Value>,
    defaults: BTreeMap<u16, Value>,
}

/// Why `$N=V` was refused (grbl's error number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetError {
    /// Not a number: `error:2`.
    BadNumber,
    /// No such setting: `error:3`.
    Unknown,
    /// Negative: `error:4`.
    Negative,
}

impl std::fmt::Display for SetError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SetError::BadNumber => "not a number",
            SetError::Unknown => "no such setting",
            SetError::Negative => "negative",
        })
    }
}

/// Settings with no other error of their own that the machine file refuses (grblHAL's
/// `Status_SettingValueOutOfRange`).
pub const OUT_OF_RANGE: u8 = 52;

/// Settings that are fields of the machine file's `[machine]`.
pub fn is_machine_field(n: u16, axes: usize) -> bool {
    matches!(n, 0 | ARC_TOLERANCE | 26) || axis_of(n, axes).is_some()
}

/// Settings the board's config carries (changing one sends the board a new config); `$12` is a
/// machine field the bridge alone uses.
pub fn is_board_field(n: u16, axes: usize) -> bool {
    is_machine_field(n, axes) && n != ARC_TOLERANCE
}

/// (group 100/110/120/130, axis index) of an axis setting.
fn axis_of(n: u16, axes: usize) -> Option<(u16, usize)> {
    let (group, i) = (n / 10 * 10, (n % 10) as usize);
    (matches!(group, 100 | 110 | 120 | 130) && i < axes).then_some((group, i))
}

/// The machine file's text `src` with the machine fields of `s` that differ from the file's
/// values replaced, read back as the machine file is read (`job::parse_machine_toml`) and
/// converted to the board's units (`convert::machine_config`): the machine, or what is wrong
/// with it (the field and the reason, as for the machine file).
pub fn machine_with(src: &str, s: &Settings) -> Result<Machine, String> {
    let mut doc: toml::Table = src.parse().map_err(|e| format!("the machine file: {e}"))?;
    let m = doc
        .get_mut("machine")
        .and_then(|v| v.as_table_mut())
        .ok_or("the machine file has no [machine] table")?;
    let axes = m.get("axes").and_then(|a| a.as_array()).map_or(0, |a| a.len());
    let num = |v: Option<&toml::Value>| match v {
        Some(toml::Value::Float(f)) => Some(*f),
        Some(toml::Value::Integer(i)) => Some(*i as f64),
        _ => None,
    };
    for (&n, v) in &s.values {
        if s.defaults.get(&n) == Some(v) || !is_machine_field(n, axes) {
            continue;
        }
        let v = v.v;
        let set = |t: &mut toml::Table, key: &str, val: toml::Value| {
            t.insert(key.to_string(), val);
        };
        match (n, axis_of(n, axes)) {
            (0, _) => {
                let t = m
                    .get_mut("timing")
                    .and_then(|t| t.as_table_mut())
                    .ok_or("the machine file has no [machine.timing] table")?;
                let ns = (v * 1000.0).round().min(i64::MAX as f64) as i64;
                set(t, "pulse_ns", toml::Value::Integer(ns));
            }
            (ARC_TOLERANCE, _) => set(m, "arc_tolerance_mm", toml::Value::Float(v)),
            (26, _) => set(m, "switch_debounce_ms", toml::Value::Float(v)),
            (_, Some((group, i))) => {
                let a = m
                    .get_mut("axes")
                    .and_then(|a| a.as_array_mut())
                    .and_then(|a| a.get_mut(i))
                    .and_then(|a| a.as_table_mut())
                    .ok_or_else(|| format!("the machine file has no axis {i}"))?;
                let (key, val) = match group {
                    100 => ("steps_per_mm", v),
                    110 => ("max_rate_mm_s", v / 60.0),
                    120 => ("accel_mm_s2", v),
                    // Travel: the axis keeps its minimum, the maximum moves.
                    _ => {
                        let min = num(a.get("min_mm"))
                            .ok_or_else(|| format!("machine.axes[{i}].min_mm is not a number"))?;
                        ("max_mm", min + v)
                    }
                };
                set(a, key, toml::Value::Float(val));
            }
            _ => {}
        }
    }
    let text = toml::to_string(&doc).map_err(|e| format!("the machine with the settings: {e}"))?;
    let machine = crate::job::parse_machine_toml(&text).map_err(|e| {
        // Lines of the regenerated text mean nothing to the sender: field and reason only.
        if e.field.is_empty() {
            e.message
        } else {
            format!("{}: {}", e.field, e.message)
        }
    })?;
    crate::convert::machine_config(&machine).map_err(|e| e.to_string())?;
    Ok(machine)
}

/// The overlay beside `machine`: `NAME.grbl.toml` for `NAME.toml`.
pub fn overlay_path(machine: &Path) -> PathBuf {
    machine.with_extension("grbl.toml")
}

/// What the overlay keeps: the settings changed from the machine file's, the startup lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlay {
    pub settings: BTreeMap<u16, f64>,
    pub startup: [String; 2],
}

impl Overlay {
    /// The overlay at `path`, empty if there is none; errors name the file and the entry.
    pub fn read(path: &Path) -> anyhow::Result<Overlay> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Overlay::default()),
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
        };
        let doc: toml::Table =
            text.parse().with_context(|| format!("{}: not TOML", path.display()))?;
        let mut o = Overlay::default();
        for (key, v) in &doc {
            match (key.as_str(), v) {
                ("settings", toml::Value::Table(t)) => {
                    for (n, v) in t {
                        let Ok(num) = n.parse::<u16>() else {
                            bail!("{}: settings.{n}: not a setting number", path.display());
                        };
                        let val = match v {
                            toml::Value::Float(f) => *f,
                            toml::Value::Integer(i) => *i as f64,
                            _ => bail!("{}: settings.{n}: not a number", path.display()),
                        };
                        o.settings.insert(num, val);
                    }
                }
                ("startup", toml::Value::Table(t)) => {
                    for (k, v) in t {
                        let i = match k.as_str() {
                            "N0" => 0,
                            "N1" => 1,
                            _ => bail!("{}: startup.{k}: only N0 and N1", path.display()),
                        };
                        let Some(line) = v.as_str() else {
                            bail!("{}: startup.{k}: not a string", path.display());
                        };
                        o.startup[i] = line.to_string();
                    }
                }
                _ => bail!("{}: `{key}`: expected only [settings] and [startup]", path.display()),
            }
        }
        Ok(o)
    }

    /// Writes the overlay to `path` (through a temporary file, so a reader never sees half of
    /// it), or removes it when it keeps nothing.
    pub fn write(&self, path: &Path, machine: &Path) -> anyhow::Result<()> {
        if self.settings.is_empty() && self.startup.iter().all(String::is_empty) {
            return match std::fs::remove_file(path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    Err(e).with_context(|| format!("removing {}", path.display()))
                }
                _ => Ok(()),
            };
        }
        let mut settings = toml::Table::new();
        for (n, v) in &self.settings {
            settings.insert(n.to_string(), toml::Value::Float(*v));
        }
        let mut startup = toml::Table::new();
        for (i, l) in self.startup.iter().enumerate() {
            if !l.is_empty() {
                startup.insert(format!("N{i}"), toml::Value::String(l.clone()));
            }
        }
        let mut doc = toml::Table::new();
        doc.insert("settings".into(), toml::Value::Table(settings));
        doc.insert("startup".into(), toml::Value::Table(startup));
        let name = machine.file_name().map_or("the machine file".into(), |n| n.to_string_lossy());
        let text = format!(
            "# Written by `motionctl grbl`: the grbl settings a sender changed over {name} \
             (`$N=V`),\n# and its startup lines (`$Nx=`). `$RST=$` drops the settings, `$RST=*` \
             everything;\n# the bridge reads this file at start. Edit the machine file to make a \
             value its own.\n{}",
            toml::to_string(&doc).context("writing the overlay")?
        );
        let tmp = path.with_extension("toml.tmp");
        std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path)
            .with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
    }
}

/// Status report mask: bit 0 machine position, bit 1 buffer state.
pub const STATUS_MASK: u16 = 10;
pub const JUNCTION_DEVIATION: u16 = 11;
pub const ARC_TOLERANCE: u16 = 12;
pub const REPORT_INCHES: u16 = 13;
pub const SOFT_LIMITS: u16 = 20;
pub const HARD_LIMITS: u16 = 21;
pub const HOMING: u16 = 22;

impl Settings {
    pub fn from_machine(m: &Machine) -> Self {
        let int = |v: f64| Value { v, integer: true };
        let real = |v: f64| Value { v, integer: false };
        let mut s = BTreeMap::new();
        let pulse_us = (m.timing.pulse_ns as f64 / 1000.0).round().max(1.0);
        s.insert(0, int(pulse_us));
        s.insert(1, int(25.0));
        for n in 2..=6 {
            s.insert(n, int(0.0));
        }
        s.insert(STATUS_MASK, int(3.0));
        s.insert(JUNCTION_DEVIATION, real(0.010));
        s.insert(ARC_TOLERANCE, real(m.arc_tolerance_mm));
        s.insert(REPORT_INCHES, int(0.0));
        s.insert(SOFT_LIMITS, int(1.0));
        s.insert(HARD_LIMITS, int(0.0));
        s.insert(HOMING, int(1.0));
        s.insert(23, int(0.0));
        s.insert(24, real(25.0));
        s.insert(25, real(500.0));
        // Homing switch debounce, ms: the board's switch debounce.
        s.insert(26, int(m.switch_debounce_ms.round()));
        s.insert(27, real(1.0));
        s.insert(30, int(1000.0));
        s.insert(31, int(0.0));
        s.insert(32, int(0.0));
        for (i, a) in m.axes.iter().enumerate() {
            let i = i as u16;
            s.insert(100 + i, real(a.steps_per_mm));
            s.insert(110 + i, real(a.max_rate_mm_s * 60.0));
            s.insert(120 + i, real(a.accel_mm_s2));
            s.insert(130 + i, real(a.max_mm - a.min_mm));
        }
        Settings { defaults: s.clone(), values: s }
    }

    pub fn get(&self, n: u16) -> f64 {
        self.values.get(&n).map_or(0.0, |v| v.v)
    }

    pub fn flag(&self, n: u16) -> bool {
        self.get(n) != 0.0
    }

    /// `$N=V`.
    pub fn set(&mut self, n: &str, v: &str) -> Result<(), SetError> {
        let n: u16 = n.trim().parse().map_err(|_| SetError::Unknown)?;
        let v: f64 = v.trim().parse().map_err(|_| SetError::BadNumber)?;
        if !v.is_finite() {
            return Err(SetError::BadNumber);
        }
        if v < 0.0 {
            return Err(SetError::Negative);
        }
        let slot = self.values.get_mut(&n).ok_or(SetError::Unknown)?;
        slot.v = if slot.integer { v.trunc() } else { v };
        Ok(())
    }

    /// `$RST=$`.
    pub fn restore(&mut self) {
        self.values = self.defaults.clone();
    }

    /// The settings that differ from the machine file's (what the overlay keeps).
    pub fn changed(&self) -> BTreeMap<u16, f64> {
        self.values
            .iter()
            .filter(|(n, v)| self.defaults.get(n) != Some(v))
            .map(|(n, v)| (*n, v.v))
            .collect()
    }

    /// The `$$` listing, one `$N=V` per line, in number order as grbl prints it.
    pub fn listing(&self) -> Vec<String> {
        self.values
            .iter()
            .map(|(n, v)| {
                if v.integer {
                    format!("${n}={}", v.v as i64)
                } else {
                    format!("${n}={:.3}", v.v)
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine() -> Machine {
        crate::grbl::test_machine()
    }

    #[test]
    fn axis_settings_come_from_the_machine_file() {
        let s = Settings::from_machine(&machine());
        let l = s.listing();
        assert_eq!(l.first().map(String::as_str), Some("$0=3"));
        assert!(l.contains(&"$100=80.000".to_string()), "{l:?}");
        assert!(l.contains(&"$102=400.000".to_string()), "{l:?}");
        assert!(l.contains(&"$110=15000.000".to_string()), "{l:?}");
        assert!(l.contains(&"$122=500.000".to_string()), "{l:?}");
        assert_eq!(l.last().map(String::as_str), Some("$132=200.000"));
    }

    fn machine_src() -> String {
        std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/corpus-machine.toml"
        ))
        .unwrap()
    }

    #[test]
    fn machine_fields_change_the_machine_and_out_of_range_names_the_field() {
        let src = machine_src();
        let mut s = Settings::from_machine(&machine());
        assert_eq!(machine_with(&src, &s).unwrap(), machine(), "no change: the file's machine");
        s.set("100", "160").unwrap();
        s.set("111", "600").unwrap();
        s.set("122", "250").unwrap();
        s.set("130", "520").unwrap();
        s.set("12", "0.01").unwrap();
        s.set("0", "5").unwrap();
        let m = machine_with(&src, &s).unwrap();
        assert_eq!(m.axes[0].steps_per_mm, 160.0);
        assert_eq!(m.axes[1].max_rate_mm_s, 10.0);
        assert_eq!(m.axes[2].accel_mm_s2, 250.0);
        assert_eq!((m.axes[0].min_mm, m.axes[0].max_mm), (-500.0, 20.0));
        assert_eq!(m.arc_tolerance_mm, 0.01);
        assert_eq!(m.timing.pulse_ns, 5000);
        assert_eq!(Settings::from_machine(&m).listing(), s.listing());
        s.set("100", "0").unwrap();
        let e = machine_with(&src, &s).unwrap_err();
        assert!(e.starts_with("machine.axes[0].steps_per_mm: must be > 0"), "{e}");
        assert!(!is_machine_field(103, 3) && !is_machine_field(10, 3));
        assert!(is_machine_field(12, 3) && !is_board_field(12, 3) && is_board_field(132, 3));
    }

    #[test]
    fn the_overlay_round_trips_and_names_bad_entries() {
        let dir = std::env::temp_dir().join(format!("grbl-overlay-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let machine = dir.join("m.toml");
        let path = overlay_path(&machine);
        assert_eq!(path, dir.join("m.grbl.toml"));
        assert_eq!(Overlay::read(&path).unwrap(), Overlay::default(), "none yet");
        let o = Overlay {
            settings: [(100, 7.77), (20, 0.0)].into_iter().collect(),
            startup: ["G21 G90".into(), String::new()],
        };
        o.write(&path, &machine).unwrap();
        assert_eq!(Overlay::read(&path).unwrap(), o);
        Overlay::default().write(&path, &machine).unwrap();
        assert!(!path.exists(), "an empty overlay is removed");
        std::fs::write(&path, "[settings]\nx = 1\n").unwrap();
        let e = Overlay::read(&path).unwrap_err().to_string();
        assert!(e.ends_with("m.grbl.toml: settings.x: not a setting number"), "{e}");
        std::fs::write(&path, "[startup]\nN2 = \"G0\"\n").unwrap();
        let e = Overlay::read(&path).unwrap_err().to_string();
        assert!(e.ends_with("startup.N2: only N0 and N1"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn set_checks_number_and_sign() {
        let mut s = Settings::from_machine(&machine());
        assert_eq!(s.set("10", "1"), Ok(()));
        assert_eq!(s.get(STATUS_MASK), 1.0);
        assert_eq!(s.set("10", "x"), Err(SetError::BadNumber));
        assert_eq!(s.set("999", "1"), Err(SetError::Unknown));
        assert_eq!(s.set("110", "-5"), Err(SetError::Negative));
        s.restore();
        assert_eq!(s.get(STATUS_MASK), 3.0);
    }
}
