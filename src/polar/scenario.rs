//! Scenario: plays the built-in limacon stream ([`super::limacon_stream::BYTES`]) at a speed and
//! size scale, decoding block by block in the background (as the firmware's feeder would) and
//! recording the pins.

use super::limacon_stream;
use super::playback::{Playback, SizeScale};
use super::stream::{blocks, BlockEvents, Blocks};
use crate::protocol::errors::FaultCode;
use crate::scenario::{Scenario, ScenarioReport};
use crate::segment::Rate;
use crate::trace::StepRecorder;

/// Tick rate the stream was generated for.
pub const TICK_HZ: u32 = 100_000;
/// The tick asks for more events once this many queue slots are free: the rest of the queue
/// covers the ticks until the background decoder has run (at most 4 events fire per tick).
const REFILL_WHEN_FREE: usize = super::playback::QUEUE_DEPTH / 2;

/// Playback of the built-in stream.
#[derive(Clone, Debug)]
pub struct PolarPlayback {
    play: Playback,
    /// The stream's blocks not yet decoded (sequence and end block checked as they come).
    rest: Blocks<'static>,
    block: Option<BlockEvents<'static>>,
    rec: StepRecorder,
    ticks: u64,
    fault: u8,
    events_decoded: u32,
    /// Every event of the stream is in the playback queue.
    fed: bool,
}

impl PolarPlayback {
    /// Speed scale (0.25..=2) and radial size scale m/k.
    pub fn new(rate: Rate, scale: SizeScale) -> Self {
        let mut play = Playback::new(scale);
        play.set_rate(rate);
        PolarPlayback {
            play,
            rest: blocks(limacon_stream::BYTES),
            block: None,
            rec: StepRecorder::new(),
            ticks: 0,
            fault: 0,
            events_decoded: 0,
            fed: false,
        }
    }

    /// Decodes events into the playback queue until it is full or the stream ends: block
    /// parsing checks a CRC and decodes varints, planning-rate work kept out of the tick.
    fn refill(&mut self) {
        while self.play.free() > 0 {
            if let Some(it) = self.block.as_mut() {
                match it.next() {
                    Some(Ok(ev)) => {
                        // free() > 0 was checked.
                        let _ = self.play.push(ev);
                        self.events_decoded += 1;
                        continue;
                    }
                    Some(Err(_)) => return self.fail(),
                    None => self.block = None,
                }
            }
            match self.rest.next() {
                Some(Ok((b, _))) => self.block = Some(b.iter()),
                Some(Err(_)) => return self.fail(),
                None => {
                    self.play.finish();
                    self.fed = true;
                    return;
                }
            }
        }
    }

    fn fail(&mut self) {
        // A corrupt built-in stream: stop feeding and report a sensor-class data fault.
        self.fault = FaultCode::SensorFault.code();
        self.rest = blocks(&[]);
        self.block = None;
        self.play.finish();
        self.fed = true;
    }
}

impl Scenario for PolarPlayback {
    fn name(&self) -> &'static str {
        "polar_playback"
    }

    fn tick_hz(&self) -> u32 {
        TICK_HZ
    }

    fn wants_background(&self) -> bool {
        !self.fed && self.play.free() >= REFILL_WHEN_FREE
    }

    fn background(&mut self) {
        self.refill();
    }

    fn tick(&mut self) -> bool {
        if self.play.done() {
            return false;
        }
        let out = self.play.tick();
        self.ticks += 1;
        self.rec.record(self.ticks, &out);
        true
    }

    fn report(&self) -> ScenarioReport {
        let mut r = ScenarioReport::new(self.name(), self.ticks, self.rec.hash(), self.fault);
        let p = self.play.position();
        r.push("theta_steps", p[0]);
        r.push("r_steps", p[1]);
        r.push("events", self.play.fired() as i64);
        r.push("events_decoded", self.events_decoded as i64);
        r.push("theta_rises", self.rec.steps[0] as i64);
        r.push("r_rises", self.rec.steps[1] as i64);
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::run_to_end;

    #[test]
    fn built_in_stream_plays_to_a_closed_contour() {
        let mut s = PolarPlayback::new(Rate::ONE, SizeScale::ONE);
        let r = run_to_end(&mut s, 100_000_000);
        assert_eq!(r.fault, 0);
        assert!(r.figure("events").unwrap() > 1000);
        assert_eq!(r.figure("events"), r.figure("events_decoded"));
        // A closed contour returns to its start on both axes.
        assert_eq!((r.figure("theta_steps"), r.figure("r_steps")), (Some(0), Some(0)));
        // Double speed: same events, about half the ticks.
        let mut f = PolarPlayback::new(Rate::lit("2"), SizeScale::ONE);
        let rf = run_to_end(&mut f, 100_000_000);
        assert_eq!(rf.figure("events"), r.figure("events"));
        assert!(rf.ticks.abs_diff(r.ticks / 2) < 5, "{} vs {}", rf.ticks, r.ticks);
        assert_ne!(rf.hash, r.hash);
    }
}
