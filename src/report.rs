//! The end-of-job report both the firmware and the host model produce, and its text form.
//! The firmware prints these lines over defmt; xtask parses them back with [`Report::parse_line`].

use crate::config::MAX_AXES;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Report {
    pub axes: u8,
    pub ticks: u64,
    pub tick_hz: u32,
    pub segments: u32,
    pub underruns: u32,
    pub deferred_steps: u32,
    pub trace_hash: u64,
    pub positions: [i64; MAX_AXES],
    pub steps: [u64; MAX_AXES],
    pub peak_rate_hz: [u32; MAX_AXES],
    pub first_step_tick: u64,
    pub last_step_tick: u64,
}

/// A position snapshot taken mid-run (tick and positions read in one critical section).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Snapshot {
    pub tick: u64,
    pub positions: [i64; MAX_AXES],
}

use crate::dda::Dda;
use crate::trace::StepRecorder;
use core::fmt::Write;

/// Longest line the report writes.
pub const LINE_CAPACITY: usize = 160;
pub type Line = heapless::String<LINE_CAPACITY>;

impl Report {
    /// The report for a finished run: DDA counters plus what the pins did.
    pub fn from_run(dda: &Dda, rec: &StepRecorder, axes: u8, tick_hz: u32) -> Report {
        Report {
            axes,
            ticks: dda.now(),
            tick_hz,
            segments: dda.segments_done(),
            underruns: dda.underruns(),
            deferred_steps: dda.deferred_steps(),
            trace_hash: rec.hash(),
            positions: dda.positions(),
            steps: rec.steps,
            peak_rate_hz: rec.peak_rate_hz(tick_hz),
            first_step_tick: rec.first_step_tick.unwrap_or(0),
            last_step_tick: rec.last_step_tick,
        }
    }

    /// The report as text lines: one `report ...` line, then one `report_axis ...` per axis.
    pub fn write_lines(&self, mut emit: impl FnMut(&str)) {
        let mut l = Line::new();
        // A Line holds any of these lines; a write error would only truncate.
        let _ = write!(
            l,
            "report axes={} ticks={} tick_hz={} segments={} underruns={} deferred={} hash={:016x} first={} last={}",
            self.axes, self.ticks, self.tick_hz, self.segments, self.underruns,
            self.deferred_steps, self.trace_hash, self.first_step_tick, self.last_step_tick
        );
        emit(&l);
        for i in 0..(self.axes as usize).min(MAX_AXES) {
            l.clear();
            let _ = write!(
                l,
                "report_axis axis={} pos={} steps={} peak_hz={}",
                i, self.positions[i], self.steps[i], self.peak_rate_hz[i]
            );
            emit(&l);
        }
    }

    /// Folds one line of [`Report::write_lines`] output into `self`; false if it is not one.
    pub fn parse_line(&mut self, line: &str) -> bool {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("report ") {
            for (k, v) in fields(rest) {
                let ok = match k {
                    "axes" => v.parse().map(|x| self.axes = x).is_ok(),
                    "ticks" => v.parse().map(|x| self.ticks = x).is_ok(),
                    "tick_hz" => v.parse().map(|x| self.tick_hz = x).is_ok(),
                    "segments" => v.parse().map(|x| self.segments = x).is_ok(),
                    "underruns" => v.parse().map(|x| self.underruns = x).is_ok(),
                    "deferred" => v.parse().map(|x| self.deferred_steps = x).is_ok(),
                    "hash" => u64::from_str_radix(v, 16).map(|x| self.trace_hash = x).is_ok(),
                    "first" => v.parse().map(|x| self.first_step_tick = x).is_ok(),
                    "last" => v.parse().map(|x| self.last_step_tick = x).is_ok(),
                    _ => false,
                };
                if !ok {
                    return false;
                }
            }
            return true;
        }
        if let Some(rest) = line.strip_prefix("report_axis ") {
            let (mut axis, mut pos, mut steps, mut peak) = (None, None, None, None);
            for (k, v) in fields(rest) {
                match k {
                    "axis" => axis = v.parse::<usize>().ok().filter(|&a| a < MAX_AXES),
                    "pos" => pos = v.parse().ok(),
                    "steps" => steps = v.parse().ok(),
                    "peak_hz" => peak = v.parse().ok(),
                    _ => return false,
                }
            }
            if let (Some(a), Some(p), Some(s), Some(r)) = (axis, pos, steps, peak) {
                self.positions[a] = p;
                self.steps[a] = s;
                self.peak_rate_hz[a] = r;
                return true;
            }
        }
        false
    }
}

impl Snapshot {
    pub fn write_line(&self, axes: u8) -> Line {
        let mut l = Line::new();
        let _ = write!(l, "snapshot tick={} pos=", self.tick);
        for i in 0..(axes as usize).min(MAX_AXES) {
            let _ = write!(l, "{}{}", if i == 0 { "" } else { "," }, self.positions[i]);
        }
        l
    }

    pub fn parse_line(line: &str) -> Option<Snapshot> {
        let rest = line.trim().strip_prefix("snapshot ")?;
        let mut s = Snapshot::default();
        for (k, v) in fields(rest) {
            match k {
                "tick" => s.tick = v.parse().ok()?,
                "pos" => {
                    for (slot, p) in s.positions.iter_mut().zip(v.split(',')) {
                        *slot = p.parse().ok()?;
                    }
                }
                _ => return None,
            }
        }
        Some(s)
    }
}

fn fields(s: &str) -> impl Iterator<Item = (&str, &str)> {
    s.split_ascii_whitespace().filter_map(|f| f.split_once('='))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_lines_round_trip() {
        let r = Report {
            axes: 3,
            ticks: 123_456,
            tick_hz: 100_000,
            segments: 9,
            underruns: 1,
            deferred_steps: 2,
            trace_hash: 0xdead_beef_0123_4567,
            positions: [-5, 7, 1 << 40, 0, 0, 0],
            steps: [5, 7, 1 << 40, 0, 0, 0],
            peak_rate_hz: [1, 2, 3, 0, 0, 0],
            first_step_tick: 4,
            last_step_tick: 100_000,
        };
        let mut back = Report::default();
        let mut n = 0;
        r.write_lines(|l| {
            assert!(back.parse_line(l), "{l}");
            n += 1;
        });
        assert_eq!(n, 4);
        assert_eq!(back, r);
        let s = Snapshot { tick: 77, positions: [1, -2, 3, 0, 0, 0] };
        assert_eq!(Snapshot::parse_line(&s.write_line(3)), Some(s));
        assert!(!back.parse_line("report ticks=x"));
        assert_eq!(Snapshot::parse_line("snapshot tick=1 pos=a"), None);
    }
}
