//! [`Target`]: [`LinkTarget`] for one request, every machine command through
//! `Machine::command`.

use core::cell::RefCell;
use core::sync::atomic::Ordering::Relaxed;

use motion::config::MAX_AXES;
use motion::dda::{Command, Preparer};
use motion::machine::{BoardConfig, MachineCommand, MachineState, ProbeKind, Refusal};
use motion::protocol::{
    BoardCounters, ErrorCode, HomingConfig, LinkConfig, LinkState, LinkTarget, ProgramOutputs,
    Status, SENSOR_CHANNELS,
};
use motion::segment::{Rate, Segment};
use motion::Dda;
use rtic::Mutex;

use crate::board;
use board_contract::{ConfigStorage as _, TickRate as _};

use super::capabilities::Capabilities;
use super::feed::Feed;
use super::link_job::LinkJob as _;
use super::*;

/// [`LinkTarget`] for one request: the link plus the `Motion` resource. `LinkTarget` reads
/// through `&self`, and an RTIC lock needs `&mut`, hence the `RefCell` (never borrowed twice: no
/// method calls another while it holds the lock).
pub struct Target<'a, M: Mutex<T = Motion>> {
    pub(super) link: &'a mut Feed,
    pub(super) motion: RefCell<&'a mut M>,
    /// The feeder has work.
    pub wake_feeder: bool,
}

impl<'a, M: Mutex<T = Motion>> Target<'a, M> {
    pub(super) fn new(link: &'a mut Feed, motion: &'a mut M) -> Self {
        Target { link, motion: RefCell::new(motion), wake_feeder: false }
    }

    pub(super) fn with<R>(&self, f: impl FnOnce(&mut Motion) -> R) -> R {
        self.motion.borrow_mut().lock(f)
    }

    /// One machine command; a refusal changes nothing and becomes the NAK code.
    pub(super) fn command(&mut self, cmd: MachineCommand<'_>) -> Result<MachineState, ErrorCode> {
        let r = self.motion.get_mut().lock(|m| m.machine.command(cmd, &mut m.dda));
        r.map_err(|e: Refusal| e.error_code())
    }

    /// After a command that stops and drops the job: the queue goes too, and the feeder runs the
    /// machine's background (the abort of the frozen DDA).
    pub(super) fn drop_job(&mut self) {
        self.motion.get_mut().lock(|m| {
            Capabilities::drop_job(m);
        });
        self.link.queue.clear();
        self.link.events.clear();
        EVENTS_WAITING.store(false, Relaxed);
        self.wake_feeder = true;
    }

    /// Installs `cfg` (a validated board config): the machine first (it refuses out of state),
    /// then a DDA and preparer for a changed machine config, retimed in one critical section.
    pub(super) fn install(&mut self, cfg: &BoardConfig) -> Result<(), ErrorCode> {
        let preparer = Preparer::new(&cfg.link.machine).map_err(|_| ErrorCode::InvalidConfig)?;
        let old = self.with(|m| m.machine.config().link.machine);
        let tick_hz = cfg.link.machine.tick_hz;
        let fresh = if cfg.link.machine == old {
            None
        } else {
            if !self.link.tick_rate.supports(tick_hz) {
                return Err(ErrorCode::InvalidConfig);
            }
            // A streamed output writes DIR and STEP in one word: DIR needs a tick of its own.
            #[cfg(feature = "step-stream")]
            motion::dda::edge_stream::timing(&cfg.link.machine)
                .map_err(|_| ErrorCode::InvalidConfig)?;
            Some(Dda::new(&cfg.link.machine).map_err(|_| ErrorCode::InvalidConfig)?)
        };
        let r = self.motion.get_mut().lock(|m| m.machine.set_config(cfg));
        r.map_err(|e: Refusal| e.error_code())?;
        self.drop_job();
        if board::ConfigStorage::PERSISTS {
            self.link.save_pending = Some(*cfg);
        }
        let Some(mut fresh) = fresh else { return Ok(()) };
        let tick_rate = &mut self.link.tick_rate;
        // The swap and the retiming in one critical section: no tick sees a half-done change.
        // The machine froze the DDA (SetConfig stops at once); the background aborts the new one.
        self.motion.get_mut().lock(|m| {
            core::mem::swap(&mut m.dda, &mut fresh);
            tick_rate.set(tick_hz)
        });
        // `fresh` now holds the old DDA.
        self.link.clock_base_ms += fresh.now() * 1_000 / old.tick_hz.max(1) as u64;
        self.link.preparer = preparer;
        WAKE_TICKS.store(wake_ticks(tick_hz), Relaxed);
        Ok(())
    }
}

impl<M: Mutex<T = Motion>> LinkTarget for Target<'_, M> {
    fn state(&self) -> LinkState {
        self.with(|m| m.link_state())
    }

    fn machine_state(&self) -> MachineState {
        self.with(|m| m.machine.state())
    }

    fn credits(&self) -> u16 {
        self.with(|m| wire::credits(m)).unwrap_or((SEGMENT_QUEUE - self.link.queue.len()) as u16)
    }

    fn queue_capacity(&self) -> u16 {
        SEGMENT_QUEUE as u16
    }

    fn config(&self) -> LinkConfig {
        self.with(|m| m.machine.config().link)
    }

    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.with(|m| m.machine.planned_end())
    }

    fn status(&self) -> Status {
        // One lock: positions, tick, state and counters are one consistent snapshot.
        self.with(|m| {
            let (d, mc) = (&m.dda, &m.machine);
            let mut s = Status {
                tick: d.now(),
                positions: mc.positions(),
                state: m.link_state(),
                override_bits: d.feed_override().to_bits(),
                queue_depth: mc.in_flight(d).min(u16::MAX as u32) as u16,
                segments_done: d.segments_done(),
                last_done_id: d.last_done_id(),
                done_hash: d.done_hash(),
                faults: mc.faults().mask(),
                sensors: [0; SENSOR_CHANNELS],
                machine: mc.state(),
                causes: mc.active_causes(),
                homed: mc.is_homed(),
                events_fired: m.playback.fired(),
                event_blocks: self.link.events.blocks() as u16,
                counters: BoardCounters {
                    tick_overruns: mc.tick_overruns(),
                    steps_deferred: d.deferred_steps(),
                    starve_holds: mc.starve_holds(),
                    ..BoardCounters::default()
                },
                outputs: ProgramOutputs::of(&mc.outputs()).bits(),
                probe_phase: mc.probe().phase() as u8,
                probe_steps: mc.probe().latched_steps(),
                probe_input: mc.probe_input(),
                ..Status::default()
            };
            Capabilities::status(m, &self.link.teach, &mut s);
            s
        })
    }

    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
        let homing = self.with(|m| m.machine.config().homing());
        self.install(&BoardConfig::with_homing(*cfg, &homing))
    }

    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        // The same switches again change nothing: no flash write, and the machine stays homed
        // (a new config would lose the homing), so a host may send them before every job.
        if *homing == self.with(|m| m.machine.config().homing()) {
            return Ok(());
        }
        let link = self.with(|m| m.machine.config().link);
        self.install(&BoardConfig::with_homing(link, homing))
    }

    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        if self.with(|m| wire::live(m)) {
            let state = self.motion.get_mut().lock(|m| wire::queue(m, seg))?;
            self.wake_feeder |= state != MachineState::Ready;
            return Ok(());
        }
        if self.link.queue.is_full() {
            return Err(ErrorCode::QueueFull);
        }
        let state = self.command(MachineCommand::Queue(seg))?;
        // Cannot fail: checked for room above.
        let _ = self.link.queue.push_back(*seg);
        self.wake_feeder |= state != MachineState::Ready;
        Ok(())
    }

    fn start(&mut self) -> Result<(), ErrorCode> {
        if self.with(|m| wire::live(m)) {
            self.motion.get_mut().lock(wire::start)?;
            self.wake_feeder = true;
            return Ok(());
        }
        if self.with(|m| milling::armed(m)) {
            // The machine's start and the force loop's in one critical section.
            let r = self.motion.get_mut().lock(|m| {
                m.machine.command(MachineCommand::Start, &mut m.dda)?;
                milling::start(m);
                Ok(())
            });
            r.map_err(|e: Refusal| e.error_code())?;
            self.wake_feeder = true;
            return Ok(());
        }
        self.command(MachineCommand::Start)?;
        self.wake_feeder = true;
        Ok(())
    }

    fn hold(&mut self) -> Result<(), ErrorCode> {
        // A hold must not outlive the job it was meant for: nothing moving and nothing to feed
        // means there is nothing to hold.
        let idle = self.with(|m| m.dda.is_idle() && m.machine.source_job().is_none());
        if idle && self.link.queue.is_empty() {
            return Err(ErrorCode::OutOfState);
        }
        self.command(MachineCommand::Hold).map(|_| ())
    }

    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Resume)?;
        self.wake_feeder = true;
        Ok(())
    }

    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Abort)?;
        self.drop_job();
        Ok(())
    }

    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.with(|m| m.dda.apply(Command::SetOverride(rate)));
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::ClearFault)?;
        self.link.announced = 0;
        self.drop_job();
        Ok(())
    }

    fn home(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Home)?;
        self.drop_job();
        Ok(())
    }

    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::JogOff)?;
        // The feeder plans the jog move (the machine's background).
        self.wake_feeder = true;
        Ok(())
    }

    fn event_credits(&self) -> u16 {
        if self.with(|m| m.machine.source_queued()) {
            self.link.events.credits()
        } else {
            // A new stream starts with an empty feed (see `queue_events`).
            self.link.events.capacity()
        }
    }

    fn events_pending(&self) -> bool {
        // A wire job is a source job too, but its segments come through QueueSegments.
        self.with(|m| {
            (m.machine.source_queued() || m.machine.source_job().is_some()) && !wire::live(m)
        })
    }

    /// The next `Start` runs a probe move: nothing queued or armed besides it.
    fn arm_probe(&mut self, kind: ProbeKind) -> Result<(), ErrorCode> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        let r = self.motion.get_mut().lock(|m| {
            if !empty || Capabilities::live(m) {
                return Err(ErrorCode::OutOfState);
            }
            m.machine.arm_probe(kind, &m.dda).map_err(|e| e.error_code())
        });
        r
    }

    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, req: &motion::protocol::SimRequest) -> Result<(), ErrorCode> {
        let motion: &mut M = self.motion.get_mut();
        super::sim::apply(motion, req)
    }

    /// The spindle and coolant levels into the machine's outputs, which the tick writes to the
    /// board's pins; the wire power and the Z DAC stay the wire and Z jobs'. The machine refuses
    /// while an e-stop is latched or pressed; a board without the pins refuses as unsupported.
    fn set_program_outputs(&mut self, o: ProgramOutputs) -> Result<(), ErrorCode> {
        if !board::MachineIo::PROGRAM_OUTPUTS || (o.mist && !board::MachineIo::MIST) {
            return Err(ErrorCode::Unsupported);
        }
        let set = self.motion.get_mut().lock(|m| {
            let now = m.machine.outputs();
            m.machine.set_outputs(o.applied_to(now))
        });
        if set {
            Ok(())
        } else {
            Err(ErrorCode::OutOfState)
        }
    }
}
