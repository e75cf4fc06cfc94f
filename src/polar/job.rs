//! The polar machine as the link sees it: a 2-axis (theta, r) config at the stream's tick rate,
//! for `motionctl polar run` (and tests of event jobs through [`crate::machine::Machine`]).

use super::scenario::TICK_HZ;
use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::machine::{BoardConfig, HomeAxis};
use crate::protocol::{AxisScale, HomingConfig, LinkConfig};

/// Steps per revolution of the arm (dTheta = 2 pi / 16000, the thesis's resolution).
pub const THETA_STEPS_PER_REV: u32 = 16_000;
/// Carriage steps per inch (dR = 0.001 in).
pub const R_STEPS_PER_IN: u32 = 1_000;
/// Soft limits, steps either side of the homed position: the work area's full span (theta
/// 0..2.8 rad = 7130 steps, r 3..13 in = 10000 steps), so a contour that starts inside the work
/// area can never trip them while one that runs away does.
pub const THETA_SPAN_STEPS: i64 = 7_130;
pub const R_SPAN_STEPS: i64 = 10_000;

/// The polar machine's link config: `TICK_HZ` (the stream's time quantum), one-tick DIR setup
/// and hold (what `StepPins` guarantees: DIR a tick before a reversed rise, never in the tick of
/// a rise), at most one rise per axis every other tick (50 kHz).
pub fn link_config() -> LinkConfig {
    let axis =
        AxisLimits { max_rate_hz: TICK_HZ / 2, accel_steps_per_s2: 1_000_000, junction_jerk_hz: 0 };
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = axis;
    axes[1] = axis;
    let mut scale = [AxisScale::UNUSED; MAX_AXES];
    // Steps per degree and per mm, times 1000.
    scale[0] = AxisScale {
        steps_per_unit_milli: THETA_STEPS_PER_REV * 1000 / 360,
        soft_min: -THETA_SPAN_STEPS,
        soft_max: THETA_SPAN_STEPS,
    };
    scale[1] = AxisScale {
        steps_per_unit_milli: R_STEPS_PER_IN * 10_000 / 254,
        soft_min: -R_SPAN_STEPS,
        soft_max: R_SPAN_STEPS,
    };
    LinkConfig {
        machine: MachineConfig {
            tick_hz: TICK_HZ,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
            axis_count: 2,
            axes,
        },
        scale,
        inputs: crate::config::InputFilterConfig::DEFAULT,
    }
}

/// Homing: seek speed, latch speed and back-off of both axes (steps/s, steps). The seek is a
/// fifth of the axis's top rate, the latch a tenth of the seek; the back-off (0.1 in radial,
/// 2.25 degrees angular) clears a switch's hysteresis.
pub const HOME_SEARCH_HZ: u32 = 10_000;
pub const HOME_LATCH_HZ: u32 = 1_000;
pub const HOME_BACKOFF_STEPS: u32 = 100;

/// How the polar machine homes (Fahim: "right end-stop = angular home; carriage at minimum
/// radius = radial home"): first the arm clockwise (theta decreasing) against its right
/// end-stop, then the carriage toward the pole onto its minimum-radius switch. Each: seek,
/// back off, latch slowly, pull off. The origins are the switch points: theta 0 at the
/// end-stop, r 0 at minimum radius (3 in from the pole), so the work area is theta
/// 0..=`THETA_SPAN_STEPS`, r 0..=`R_SPAN_STEPS`, inside the soft limits. The seek may cross the
/// whole work area (plus the back-off twice) before "switch not found".
pub fn homing_config() -> HomingConfig {
    let axis = |span: i64| HomeAxis {
        toward_max: false,
        search_hz: HOME_SEARCH_HZ,
        latch_hz: HOME_LATCH_HZ,
        backoff_steps: HOME_BACKOFF_STEPS,
        max_travel_steps: span as u32 + 2 * HOME_BACKOFF_STEPS,
        home_pos_steps: 0,
    };
    let mut axes = [HomeAxis::UNUSED; MAX_AXES];
    axes[0] = axis(THETA_SPAN_STEPS);
    axes[1] = axis(R_SPAN_STEPS);
    HomingConfig { order: [0, 1, 0, 0, 0, 0], count: 2, axes }
}

/// The polar machine's board config: [`link_config`] with [`homing_config`].
pub fn board_config() -> BoardConfig {
    BoardConfig::with_homing(link_config(), &homing_config())
}

#[cfg(test)]
mod tests {
    use super::super::feed::EventFeed;
    use super::super::limacon_stream::BYTES;
    use super::super::playback::{Playback, SizeScale};
    use super::super::stream::decode_all;
    use super::*;
    use crate::dda::Dda;
    use crate::machine::{Inputs, Machine, MachineCommand, MachineState, Refusal, StepSource};
    use crate::protocol::FaultCode;
    use crate::segment::Rate;

    fn blocks() -> std::vec::Vec<&'static [u8]> {
        super::super::stream::data_blocks(BYTES)
    }

    /// A homed polar machine in `Ready` and its DDA. The rig has no switches, so it homes where
    /// it stands (`HomingConfig::NONE`); [`homing_config`] is the real machine's, run against
    /// switches in the fault suite's `fault_homing_polar`.
    fn ready() -> (Machine, Dda) {
        let (m, dda, _) =
            crate::machine::homed(BoardConfig::with_homing(link_config(), &HomingConfig::NONE));
        (m, dda)
    }

    /// The host model: the same playback, fed everything, ticked to the end.
    fn model(scale: SizeScale, rate: Rate) -> (u32, [i64; 2], u64) {
        let mut p = Playback::new(scale);
        p.set_rate(rate);
        let mut evs = std::vec::Vec::new();
        decode_all(BYTES, |e| evs.push(e)).unwrap();
        let mut it = evs.into_iter();
        let mut ticks = 0;
        while !p.done() {
            while p.free() > 0 {
                match it.next() {
                    Some(e) => p.push(e).unwrap(),
                    None => {
                        p.finish();
                        break;
                    }
                }
            }
            p.tick();
            ticks += 1;
        }
        (p.fired(), p.position(), ticks)
    }

    struct Run {
        m: Machine,
        dda: Dda,
        play: Playback,
        feed: EventFeed<8>,
        next: usize,
        blocks: std::vec::Vec<&'static [u8]>,
        ticks: u64,
    }

    impl Run {
        fn new(scale: SizeScale, rate: Rate) -> Self {
            let (m, mut dda) = ready();
            dda.apply(crate::dda::Command::SetOverride(rate));
            Run {
                m,
                dda,
                play: Playback::new(scale),
                feed: EventFeed::new(),
                next: 0,
                blocks: blocks(),
                ticks: 0,
            }
        }

        /// Queues blocks while credits last (all of them when `upto` allows).
        fn queue(&mut self, upto: usize) {
            while self.next < upto.min(self.blocks.len()) && self.feed.credits() > 0 {
                let last = self.next + 1 == self.blocks.len();
                self.m.command(MachineCommand::QueueSource, &mut self.dda).unwrap();
                self.feed.push(self.blocks[self.next], last).unwrap();
                self.next += 1;
            }
        }

        /// One tick with full ticks only: feeder refill, then the machine's tick.
        fn tick(&mut self, inp: &Inputs) -> crate::machine::TickOut {
            self.feed.fill(&mut self.play);
            self.ticks += 1;
            self.m.tick_with(&mut self.dda, inp, &mut self.play)
        }

        /// One tick as the link firmware runs it: a step-only tick when the machine grants one
        /// (and true), else a full one.
        fn tick_step_only(&mut self) -> (crate::dda::StepOutput, bool) {
            self.feed.fill(&mut self.play);
            self.ticks += 1;
            match self.m.fast_tick_with(&mut self.dda, &mut self.play) {
                Some(step) => (step, true),
                None => {
                    (self.m.tick_with(&mut self.dda, &Inputs::QUIET, &mut self.play).step, false)
                }
            }
        }
    }

    #[test]
    fn step_only_ticks_play_an_event_job_as_full_ticks_do() {
        let (scale, rate) = (SizeScale::new(3, 2).unwrap(), Rate::lit("2"));
        let (mut full, mut fast) = (Run::new(scale, rate), Run::new(scale, rate));
        for r in [&mut full, &mut fast] {
            r.queue(usize::MAX);
            r.feed.fill(&mut r.play);
            r.m.command(MachineCommand::StartQueued(crate::polar::PLAYBACK_JOB), &mut r.dda)
                .unwrap();
        }
        let (mut job_ticks, mut step_only) = (0u64, 0u64);
        while fast.m.state() == MachineState::Running && fast.ticks < 100_000_000 {
            let running = full.m.state() == MachineState::Running;
            full.queue(usize::MAX);
            fast.queue(usize::MAX);
            let a = full.tick(&Inputs::QUIET).step;
            let (b, was_step_only) = fast.tick_step_only();
            if running {
                assert_eq!(a, b, "tick {}", full.ticks);
                job_ticks += 1;
                step_only += u64::from(was_step_only);
            }
        }
        eprintln!("{step_only} of the job's {job_ticks} ticks were step-only");
        // Every full tick grants the next 7, but for the ones a queued block makes full.
        let commands = fast.blocks.len() as u64;
        assert!(step_only * 8 >= job_ticks * 7 - 8 * (commands + 1), "{step_only}/{job_ticks}");
        for r in [&full, &fast] {
            assert_eq!(r.m.state(), MachineState::Ready, "faults {:#x}", r.m.faults().mask());
        }
        assert_eq!(full.m.positions(), fast.m.positions());
        assert_eq!(full.play.fired(), fast.play.fired());
        // The end is seen on the next full tick.
        let late = fast.ticks - full.ticks;
        assert!(late < u64::from(crate::machine::machine::SUPERVISE_TICKS), "{late}");
    }

    #[test]
    fn event_job_runs_through_the_machine_and_matches_the_host_model() {
        let (scale, rate) = (SizeScale::new(3, 2).unwrap(), Rate::lit("2"));
        let (events, pos, model_ticks) = model(scale, rate);
        let mut r = Run::new(scale, rate);
        r.queue(usize::MAX);
        // Segments and events never share a job.
        let seg = crate::segment::Segment {
            steps: [10, 0, 0, 0, 0, 0],
            duration_ticks: 1_000,
            entry_rate: Rate::ZERO,
            exit_rate: Rate::ZERO,
            accel_per_tick: Rate::from_bits(1 << 20),
            id: 1,
        };
        assert!(matches!(
            r.m.command(MachineCommand::Queue(&seg), &mut r.dda),
            Err(Refusal::OutOfState(MachineState::Ready))
        ));
        r.feed.fill(&mut r.play);
        r.m.command(MachineCommand::StartQueued(crate::polar::PLAYBACK_JOB), &mut r.dda).unwrap();
        assert!(r.m.runs(crate::polar::PLAYBACK_JOB));
        let mut rises = [0u64; 2];
        while r.m.state() == MachineState::Running && r.ticks < 100_000_000 {
            r.queue(usize::MAX);
            let out = r.tick(&Inputs::QUIET);
            for (a, n) in rises.iter_mut().enumerate() {
                *n += (out.step.rise() >> a & 1) as u64;
            }
        }
        assert_eq!(r.m.state(), MachineState::Ready, "faults {:#x}", r.m.faults().mask());
        assert!(!r.m.runs(crate::polar::PLAYBACK_JOB) && !r.m.source_queued());
        // Same events, same steps, same ticks as the model; positions from the machine's own
        // counters (rising edges and DIR), not from the playback.
        assert_eq!(r.play.fired(), events);
        assert_eq!([r.m.positions()[0], r.m.positions()[1]], pos);
        assert_eq!(rises, [r.play.pins().rises[0], r.play.pins().rises[1]]);
        assert_eq!(r.ticks, model_ticks);
        // 3:2 on r only: the closed limacon still closes on both axes.
        assert_eq!(pos, [0, 0]);
        assert!(events > 19_000, "{events}");
    }

    #[test]
    fn estop_freezes_an_event_job_the_same_tick() {
        let mut r = Run::new(SizeScale::ONE, Rate::ONE);
        r.queue(usize::MAX);
        r.feed.fill(&mut r.play);
        r.m.command(MachineCommand::StartQueued(crate::polar::PLAYBACK_JOB), &mut r.dda).unwrap();
        while r.play.fired() < 500 {
            r.queue(usize::MAX);
            r.tick(&Inputs::QUIET);
        }
        let estop = Inputs { estop: true, ..Inputs::QUIET };
        let out = r.tick(&estop);
        assert_eq!(out.step.rise(), 0);
        let (fired, pos) = (r.play.fired(), r.m.positions());
        for _ in 0..100_000 {
            let out = r.tick(&Inputs::QUIET);
            assert_eq!(out.step.rise(), 0, "frozen: nothing reaches the pins");
        }
        assert_eq!((r.play.fired(), r.m.positions()), (fired, pos));
        assert_eq!(r.m.state(), MachineState::Fault);
        assert!(r.m.faults().has(FaultCode::EStop));
    }

    #[test]
    fn a_late_host_is_an_underrun_and_the_playback_holds() {
        let mut r = Run::new(SizeScale::ONE, Rate::ONE);
        // Two blocks, none marked last: the host is late with the third.
        r.queue(2);
        r.feed.fill(&mut r.play);
        r.m.command(MachineCommand::StartQueued(crate::polar::PLAYBACK_JOB), &mut r.dda).unwrap();
        let admitted = r.feed.events_admitted;
        while r.m.state() == MachineState::Running && r.ticks < 10_000_000 {
            r.tick(&Inputs::QUIET);
        }
        assert_eq!(r.m.state(), MachineState::Fault);
        assert!(r.m.faults().has(FaultCode::QueueUnderrun));
        assert_eq!(r.play.fired(), admitted, "every admitted event fired before the underrun");
        // The machine table refuses more blocks in Fault.
        assert!(matches!(
            r.m.command(MachineCommand::QueueSource, &mut r.dda),
            Err(Refusal::OutOfState(MachineState::Fault))
        ));
        // The hold reaction stops the playback's clock: events that reach it now do not fire.
        r.feed.push(r.blocks[2], false).unwrap();
        r.feed.fill(&mut r.play);
        assert!(r.play.queued() > 0);
        let fired = r.play.fired();
        for _ in 0..100_000 {
            r.tick(&Inputs::QUIET);
        }
        assert_eq!(r.play.fired(), fired);
        assert!(!StepSource::idle(&r.play, &r.dda));
    }
}
