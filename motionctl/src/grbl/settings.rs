//! grbl's `$` settings, mapped from the machine file: `$100`.. steps/mm, `$110`.. max rate
//! (mm/min), `$120`.. acceleration (mm/s^2), `$130`.. travel (mm), one per machine axis; the rest
//! at grbl's defaults or what this machine does (soft limits on, homing on, no hard limits in
//! the bridge). `$N=V` is kept for the session; `$10`, `$13` and `$20` change what the bridge
//! does, the axis values are reported back but do not reconfigure the board (edit the machine
//! file for that).

use crate::job::Machine;
use std::collections::BTreeMap;

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
        let src = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/corpus-machine.toml"
        ))
        .unwrap();
        crate::job::parse_machine_toml(&src).unwrap()
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
