//! Wire-manipulator scenarios: (a) the whole circle -> complex job run continuously, (b) a
//! shortened job with a wire stall injected by the sim board (the micro-switch closes for a
//! while), retraced and recovered. Both run [`WireController`] one tick at a time, record the
//! pins with a [`StepRecorder`] and report integer figures.

use super::circle_complex_job as table;
use super::controller::{Phase, StallParams, WireController};
use super::job::{total_steps, JobSegment};
use super::machine;
use crate::config::ConfigError;
use crate::scenario::{Scenario, ScenarioReport};
use crate::segment::Rate;
use crate::trace::StepRecorder;

/// Stall handling used by both scenarios: 2 ms debounce, up to 40 000 steps (about 12 mm of
/// X/Y travel) of retrace at the cutting feed, half feed for two segments after the return.
pub const STALL_PARAMS: StallParams = StallParams {
    debounce_ticks: 20,
    retrace_limit_steps: 40_000,
    retrace_override: Rate::ONE,
    resume_override: Rate::lit("0.5"),
    resume_segments: 2,
};

/// The stall scenario's job: table segments 1..13 (point 1 to point 13 of the die, ~73 s).
pub const STALL_JOB: core::ops::Range<usize> = 1..13;
/// The sim board closes the stall switch at this tick (mid segment 2 of the shortened job) ...
pub const STALL_AT_TICK: u64 = 150_000;
/// ... for this long (4 s).
pub const STALL_TICKS: u64 = 40_000;

/// Shared body of both scenarios.
pub struct WireRun {
    name: &'static str,
    ctl: WireController<'static>,
    rec: StepRecorder,
    /// Sim board: the stall switch is closed on ticks `[stall_from, stall_to)`.
    stall_from: u64,
    stall_to: u64,
    wire_off_ticks: u64,
    /// 60 A / FR of the full job, us (0: not the full job).
    reference_us: u64,
    refused: bool,
}

impl WireRun {
    fn new(
        name: &'static str,
        job: &'static [JobSegment],
        stall: (u64, u64),
        reference_us: u64,
    ) -> Result<Self, ConfigError> {
        Ok(WireRun {
            name,
            ctl: WireController::new(&machine::config(), job, STALL_PARAMS)?,
            rec: StepRecorder::new(),
            stall_from: stall.0,
            stall_to: stall.1,
            wire_off_ticks: 0,
            reference_us,
            refused: false,
        })
    }

    fn wants_background(&self) -> bool {
        !self.refused && !self.ctl.is_finished() && self.ctl.wants_feed()
    }

    /// Planning-rate work (preparing segments, stopping, retrace planning: all divide).
    fn background(&mut self) {
        if self.ctl.feed().is_err() {
            // A refused table segment: a generator bug the host tests catch.
            self.refused = true;
        }
    }

    fn step(&mut self) -> bool {
        if self.ctl.is_finished() || self.refused {
            return false;
        }
        let now = self.ctl.dda().now();
        let stall = now >= self.stall_from && now < self.stall_to;
        let out = self.ctl.tick(stall, false);
        self.rec.record(self.ctl.dda().now(), &out);
        if !self.ctl.wire_power() && !self.ctl.is_finished() {
            self.wire_off_ticks += 1;
        }
        true
    }

    fn report(&self) -> ScenarioReport {
        let dda = self.ctl.dda();
        let fault = self.ctl.fault_code().map_or(0, |c| c.code());
        let mut r = ScenarioReport::new(self.name, dda.now(), self.rec.hash(), fault);
        let pos = dda.positions();
        let end = self.ctl.job_end();
        let names = ["pos_x_steps", "pos_y_steps", "pos_beta_steps", "pos_alpha_steps"];
        for (a, n) in names.iter().enumerate() {
            r.push(n, pos[a]);
        }
        let exact = (0..4).all(|a| pos[a] == end[a]);
        let net_ok = (0..4).all(|a| self.rec.net[a] == pos[a]);
        r.push("final_exact", exact as i64);
        r.push("net_equals_positions", net_ok as i64);
        r.push("done", (self.ctl.phase() == Phase::Done) as i64);
        r.push("segments_done", dda.segments_done() as i64);
        r.push("underruns", dda.underruns() as i64);
        r.push("deferred_steps", dda.deferred_steps() as i64);
        r.push("refused", self.refused as i64);
        if self.reference_us != 0 {
            // Machine time against 60 A / FR, ppm (report time, not tick rate).
            let t_us = dda.now() as i64 * 1_000_000 / machine::TICK_HZ as i64;
            let ref_us = self.reference_us as i64;
            r.push("time_us", t_us);
            r.push("ref_60a_fr_us", ref_us);
            r.push("time_vs_ref_ppm", (t_us - ref_us) * 1_000_000 / ref_us);
        }
        let s = self.ctl.stats();
        r.push("stalls", s.stalls as i64);
        r.push("retrace_segments", s.retrace_segments as i64);
        r.push("return_segments", s.return_segments as i64);
        r.push("retrace_steps", s.max_retrace_steps as i64);
        r.push("retrace_interrupts", s.retrace_interrupts as i64);
        r.push("stall_tick", s.first_stall_tick as i64);
        r.push("resume_tick", s.first_resume_tick as i64);
        r.push("wire_off_ticks", self.wire_off_ticks as i64);
        r
    }
}

/// Both scenarios are a [`WireRun`] under a name of their own.
macro_rules! wire_scenario {
    ($t:ident) => {
        impl Scenario for $t {
            fn name(&self) -> &'static str {
                self.0.name
            }
            fn tick_hz(&self) -> u32 {
                machine::TICK_HZ
            }
            fn tick(&mut self) -> bool {
                self.0.step()
            }
            fn wants_background(&self) -> bool {
                self.0.wants_background()
            }
            fn background(&mut self) {
                self.0.background()
            }
            fn report(&self) -> ScenarioReport {
                self.0.report()
            }
        }
    };
}

wire_scenario!(WireJobScenario);
wire_scenario!(WireStallScenario);

/// (a) The whole circle -> complex job, continuous, no stall.
pub struct WireJobScenario(WireRun);

impl WireJobScenario {
    pub fn new() -> Result<Self, ConfigError> {
        let stall = (u64::MAX, u64::MAX);
        WireRun::new("wire_job", &table::SEGMENTS, stall, table::TIME_RULED_US).map(Self)
    }
}

/// (b) The shortened job with a stall injected by the sim board.
pub struct WireStallScenario(WireRun);

impl WireStallScenario {
    pub fn new() -> Result<Self, ConfigError> {
        let job: &'static [JobSegment] = table::SEGMENTS.get(STALL_JOB).unwrap_or(&[]);
        WireRun::new("wire_stall", job, (STALL_AT_TICK, STALL_AT_TICK + STALL_TICKS), 0).map(Self)
    }

    /// Where the shortened job ends, relative to its start.
    pub fn job_end() -> [i64; 4] {
        total_steps(table::SEGMENTS.get(STALL_JOB).unwrap_or(&[]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{run_to_end, MAX_FIGURES};

    #[test]
    fn stall_scenario_retraces_and_finishes_exactly() {
        let mut s = WireStallScenario::new().unwrap();
        let r = run_to_end(&mut s, 10_000_000);
        assert!(r.figures.len() < MAX_FIGURES);
        let f = |n| r.figure(n).unwrap();
        assert_eq!(r.fault, 0);
        assert_eq!(f("done"), 1);
        assert_eq!(f("final_exact"), 1);
        assert_eq!((f("underruns"), f("refused")), (0, 0));
        assert_eq!(f("net_equals_positions"), 1);
        let end = WireStallScenario::job_end();
        assert_eq!(
            [f("pos_x_steps"), f("pos_y_steps"), f("pos_beta_steps"), f("pos_alpha_steps")],
            end
        );
        assert_eq!(f("stalls"), 1);
        assert!(f("retrace_segments") >= 1 && f("return_segments") >= 2);
        assert!(f("retrace_steps") > 0);
        // Detected on the debounce-th sample of the closed switch (samples at ticks
        // STALL_AT_TICK, STALL_AT_TICK + 1, ...).
        let detect = STALL_AT_TICK + STALL_PARAMS.debounce_ticks as u64 - 1;
        assert_eq!(f("stall_tick"), detect as i64);
        assert!(f("resume_tick") > (STALL_AT_TICK + STALL_TICKS) as i64);
        // The wire was off at least while the switch was closed (less the debounce).
        assert!(f("wire_off_ticks") >= (STALL_TICKS - STALL_PARAMS.debounce_ticks as u64) as i64);
        let mut lines = 0;
        r.write_lines(|_| lines += 1);
        assert_eq!(lines, 1 + r.figures.len());
    }
}
