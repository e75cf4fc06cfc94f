//! Closed-loop scenarios: a capability (force override, Z slide, playback, ...) together with the
//! simulated machine it drives, stepped one tick at a time. The firmware's scenario build runs
//! them in its timer interrupt with the sim board standing in for the sensors; the host model runs
//! the same structs. Both print a [`ScenarioReport`], and xtask compares them line for line.

use core::fmt::Write;

pub use crate::trace::TraceHash;

/// Most named figures one report carries.
pub const MAX_FIGURES: usize = 32;
/// Longest report line (`scenario ...` or one `scenario_fig ...`).
pub const LINE_CAPACITY: usize = 160;
pub type Line = heapless::String<LINE_CAPACITY>;

/// A closed loop that runs to completion one tick at a time, with bounded work per tick.
pub trait Scenario {
    /// Short identifier, `[a-z0-9_]`, used in report lines and test names.
    fn name(&self) -> &'static str;
    /// Ticks per second of machine time.
    fn tick_hz(&self) -> u32;
    /// One tick: sim sensors -> control -> DDA -> pins -> sim plant. False once finished (the
    /// tick that returns false did no work).
    fn tick(&mut self) -> bool;
    /// The outcome so far (complete once [`Scenario::tick`] returned false).
    fn report(&self) -> ScenarioReport;

    /// True when planning-rate work (anything that divides or takes unbounded time: planning,
    /// preparing segments) must run before the next tick. The firmware then skips the tick and
    /// runs [`Scenario::background`] in a low-priority task; the host runs it at once. Either way
    /// no tick runs while it is wanted, so the outcome never depends on how long it took.
    fn wants_background(&self) -> bool {
        false
    }

    /// The planning-rate work [`Scenario::wants_background`] asked for.
    fn background(&mut self) {}
}

/// One named integer outcome (units in the name: `_um`, `_mn`, `_ticks`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Figure {
    pub name: &'static str,
    pub value: i64,
}

/// What a scenario produced: tick count, a hash over its whole trace, an optional fault code
/// (the shared fault table's number) and named figures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScenarioReport {
    pub name: &'static str,
    pub ticks: u64,
    pub hash: u64,
    pub fault: u8,
    pub figures: heapless::Vec<Figure, MAX_FIGURES>,
}

impl ScenarioReport {
    pub fn new(name: &'static str, ticks: u64, hash: u64, fault: u8) -> Self {
        ScenarioReport { name, ticks, hash, fault, figures: heapless::Vec::new() }
    }

    /// Adds a figure; past [`MAX_FIGURES`] the figure is dropped and `false` returned (a test
    /// of every scenario checks none is).
    pub fn push(&mut self, name: &'static str, value: i64) -> bool {
        self.figures.push(Figure { name, value }).is_ok()
    }

    pub fn figure(&self, name: &str) -> Option<i64> {
        self.figures.iter().find(|f| f.name == name).map(|f| f.value)
    }

    /// The report as text: `scenario name=.. ticks=.. hash=.. fault=.. figures=N`, then one
    /// `scenario_fig name=.. key=value` line per figure.
    pub fn write_lines(&self, mut emit: impl FnMut(&str)) {
        let mut l = Line::new();
        // A Line holds any of these lines for names of sane length; overflow only truncates.
        let _ = write!(
            l,
            "scenario name={} ticks={} hash={:016x} fault={} figures={}",
            self.name,
            self.ticks,
            self.hash,
            self.fault,
            self.figures.len()
        );
        emit(&l);
        for f in &self.figures {
            l.clear();
            let _ = write!(l, "scenario_fig name={} {}={}", self.name, f.name, f.value);
            emit(&l);
        }
    }
}

/// Runs a scenario to completion (or `max_ticks`) and returns its report.
/// Background work runs whenever the scenario wants it, as in the firmware.
pub fn run_to_end<S: Scenario>(s: &mut S, max_ticks: u64) -> ScenarioReport {
    let mut n = 0;
    while n < max_ticks {
        if s.wants_background() {
            s.background();
            continue;
        }
        if !s.tick() {
            break;
        }
        n += 1;
    }
    s.report()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_lines_carry_every_figure() {
        let mut r = ScenarioReport::new("demo", 12, 0xabc, 3);
        assert!(r.push("force_peak_mn", -5));
        assert!(r.push("settle_ticks", 40));
        let mut lines = heapless::Vec::<Line, 4>::new();
        r.write_lines(|l| {
            let _ = lines.push(Line::try_from(l).unwrap());
        });
        assert_eq!(lines[0], "scenario name=demo ticks=12 hash=0000000000000abc fault=3 figures=2");
        assert_eq!(lines[1], "scenario_fig name=demo force_peak_mn=-5");
        assert_eq!(lines[2], "scenario_fig name=demo settle_ticks=40");
        assert_eq!(r.figure("settle_ticks"), Some(40));
        assert_eq!(r.figure("missing"), None);
    }

    #[test]
    fn hash_depends_on_order() {
        let (mut a, mut b) = (TraceHash::new(), TraceHash::new());
        a.u32(1);
        a.u32(2);
        b.u32(2);
        b.u32(1);
        assert_ne!(a.value(), b.value());
    }
}
