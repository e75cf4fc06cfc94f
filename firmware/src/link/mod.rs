//! The host link's machine side (link firmware): the protocol state machine ([`BoardLink`]) over
//! [`Machine`], the one state machine and fault model of `motion::machine`.
//!
//! * [`Motion`] (shared by the tick, the USART task, the feeder and the status task; ceiling =
//!   the tick's priority): the DDA and the [`Machine`] wrapped around it. The tick calls
//!   [`Machine::tick`], never `Dda::tick` directly, so every e-stop, limit, sensor, link and
//!   overrun input reaches the fault latch the same tick.
//! * [`Link`] (USART task, feeder, status task): the protocol session, the segment queue between
//!   the host and the feeder, the preparer and the link watchdog.
//! * [`Target`] implements [`LinkTarget`] for one request: every machine command goes through
//!   [`Machine::command`], which consults the one command table; the link only adds its queue.
//! * [`HostPort`]: the serial driver and the transmit byte queue.
//!
//! Event jobs (recorded step events, `motion::polar`): `QueueEvents` blocks are verified by
//! `BoardLink` and wait whole in the link's [`EventFeed`]; `StartPlayback` makes a fresh
//! [`Playback`] (inside [`Motion`], so the tick owns it) pre-filled from the blocks, and starts
//! the job in the same critical section; the feeder decodes the rest a few events at a time
//! ([`Link::feed_events`]) and finishes the playback after the host's last block. The tick runs
//! it through [`Machine::tick_with`]: the same fault inputs, freeze, counters, soft limits and
//! job end as segments. Event credits are blocks.
//!
//! Job life cycle, as the machine's table has it: SetConfig (Idle), Home (-> Homing -> Ready),
//! QueueSegments (Ready/Running/Holding), Start (Ready -> Running); the job ends (Running ->
//! Ready) when every admitted segment has finished and the DDA is at rest. `Abort` stops at
//! once and drops the queue; a fault latches, reacts (kill/stop/hold) and waits for ClearFault.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use motion::dda::{MotionState, Preparer};
use motion::machine::persist::SaveError;
use motion::machine::{BoardConfig, BootConfig, Machine, MachineState, ResetCause, WatchdogGate};
use motion::polar::playback::QUEUE_DEPTH;
use motion::polar::playback::{Playback, SizeScale};
use motion::protocol::LinkState;
use motion::protocol::{
    CAP_COPY_JOB, CAP_DDA, CAP_HOLD_RESUME, CAP_MILLING_JOB, CAP_OVERRIDE, CAP_PROBE,
    CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM,
};
use motion::turning::link_job::ZJob;
use motion::Dda;

use crate::board;
use board_contract::{CopyEncoders as _, MachineIo as _};

/// The list of the capabilities' link modules, walked by the target.
pub mod capabilities;
mod feed;
mod host_port;
mod last_job;
/// The hooks each capability's link module fills.
pub mod link_job;
/// Constant-force milling jobs (`ArmForce`).
pub mod milling;
/// Copy-mode jobs (`StartCopy`, `ReadTeach`).
pub mod polar;
mod session;
/// The simulator board's test hooks (`Sim` requests).
#[cfg(feature = "sim-inputs")]
pub mod sim;
mod target;
/// Z-slide jobs (`ZTableBegin`..`StartZ`).
pub mod turning;
/// Wire-manipulator jobs (`ArmWire`).
pub mod wire;

pub use host_port::{encode, HostPort};
pub use last_job::LastJob;
pub use session::Link;
pub use target::Target;

/// Segments the host may have queued beyond the DDA's own ready queue (`credits` when empty).
pub const SEGMENT_QUEUE: usize = 64;
/// Transmit queue; a response that does not fit whole is dropped (the host retransmits).
pub const TX_BUFFER: usize = 1024;
/// How often the status task runs, as a fraction of a second: 1 ms, so a status period of P ms
/// is met to the millisecond.
const POLLS_PER_SECOND: u32 = 1_000;
/// Watchdog timeout (nominal LSI) and how often the status task offers to feed it.
pub const WATCHDOG_TIMEOUT_MS: u32 = 100;
pub const WATCHDOG_POLL_MS: u64 = 10;

/// DDA ticks between two runs of the status task; the tick counts down from it (no division in
/// the tick). Rewritten when SetConfig changes the tick rate.
pub static WAKE_TICKS: AtomicU32 = AtomicU32::new(1);
/// The host link is alive, as the status task judged it; read by the tick.
pub static LINK_OK: AtomicBool = AtomicBool::new(true);
/// The e-stop interrupt saw the loop open: the tick latches EStop even if the level is gone.
pub static ESTOP_EDGE: AtomicBool = AtomicBool::new(false);
/// A config save is erasing flash: every fetch stalls, so the tick that follows finds its timer
/// update pending. That late tick is the save's, not an overrun.
pub static SAVING_CONFIG: AtomicBool = AtomicBool::new(false);
/// Fed only when the tick and the status task both ran since the last feed.
pub static WATCHDOG: WatchdogGate = WatchdogGate::new();
/// The event feed holds events not yet in the playback: the tick wakes the feeder when the
/// playback has room for [`EVENT_REFILL`] of them.
pub static EVENTS_WAITING: AtomicBool = AtomicBool::new(false);
/// The feeder refills the playback once this many slots are free: the other half of the
/// queue covers the feeder's latency (at least 32 ticks: at most 4 events fire per tick).
pub const EVENT_REFILL: usize = QUEUE_DEPTH / 2;
/// Events decoded per critical section: the decoding runs outside the `Motion` lock, the copy
/// into the playback inside it (a few hundred cycles, well inside a tick).
const EVENT_BATCH: usize = 16;

/// What the board announces in `HelloInfo::capabilities`: the machine's own features, and every
/// registered capability's jobs less those whose hardware this board lacks.
pub const CAPABILITIES: u32 = CAP_DDA
    | CAP_STATUS_STREAM
    | CAP_OVERRIDE
    | CAP_HOLD_RESUME
    | CAP_SOFT_LIMITS
    | CAP_PROBE
    | (motion::capabilities::hello_bits() & !MISSING_HARDWARE)
    // The hooks need their code (the `sim-inputs` feature) and a board that simulates inputs.
    | if cfg!(feature = "sim-inputs") && board::MachineIo::SIM_INPUTS { CAP_SIM_INPUTS } else { 0 };

/// Capability jobs this board cannot run: no force source, no copy encoders.
const MISSING_HARDWARE: u32 = if milling::HAS_FORCE_SOURCE { 0 } else { CAP_MILLING_JOB }
    | if board::CopyEncoders::ROUTED { 0 } else { CAP_COPY_JOB };

/// The DDA, the event playback and the machine around them: one resource, so the tick takes
/// one lock.
pub struct Motion {
    pub dda: Dda,
    pub machine: Machine,
    /// The event job's playback (the last job's, for its counts, until the next start).
    pub playback: Playback,
    /// The last wire or force job (for its counts, until the next `ArmWire` or `ArmForce`).
    pub job: LastJob,
    /// The Z-slide job: the active table and the current (or last) run.
    pub z: ZJob,
    /// The copy job (the last one, for its counts, until the next `StartCopy`).
    pub copy: polar::CopyState,
    /// The simulated plant the next force job samples.
    pub milling: milling::ForceSlot,
    /// The simulated probe surface (`Sim(Probe)`), evaluated from the step counters every tick.
    #[cfg(feature = "sim-inputs")]
    pub sim_probe: Option<motion::protocol::SimProbeSurface>,
}

impl Motion {
    /// Boots the machine with `loaded` (the flash record; QEMU has none) after a reset of cause
    /// `reset`, and builds the DDA from the config it ends up with (safe defaults when missing
    /// or corrupt).
    pub fn boot(
        loaded: Result<BoardConfig, BootConfig>,
        reset: ResetCause,
    ) -> Option<(Self, Preparer)> {
        let mut machine = Machine::new();
        machine.boot_after_reset(loaded, reset);
        let mut cfg = machine.config().link.machine;
        if cfg.validate().is_err() {
            // A validated config the DDA or preparer still refuses: the safe defaults instead.
            machine = Machine::new();
            machine.boot_after_reset(Err(BootConfig::Corrupt), reset);
            cfg = machine.config().link.machine;
        }
        let dda = Dda::new(&cfg).ok()?;
        let preparer = Preparer::new(&cfg).ok()?;
        WAKE_TICKS.store(wake_ticks(cfg.tick_hz), Relaxed);
        Some((
            Motion {
                dda,
                machine,
                playback: Playback::new(SizeScale::ONE),
                job: LastJob::None,
                z: ZJob::new(),
                copy: polar::CopyState::new(),
                milling: milling::ForceSlot::default(),
                #[cfg(feature = "sim-inputs")]
                sim_probe: None,
            },
            preparer,
        ))
    }

    /// The state as the link reports it: started with segments still to feed counts as
    /// moving (the feeder is about to run).
    pub(super) fn link_state(&self) -> LinkState {
        match (self.machine.state(), self.dda.state()) {
            (MachineState::Running, MotionState::Idle) => LinkState::Moving,
            (MachineState::Holding, MotionState::Idle) if self.machine.source_job().is_some() => {
                LinkState::Held
            }
            _ => self.machine.link_state(&self.dda),
        }
    }
}

/// Ticks between status-task runs at `tick_hz` (>= MIN_TICK_HZ after validation, so >= 10).
pub(super) fn wake_ticks(tick_hz: u32) -> u32 {
    (tick_hz / POLLS_PER_SECOND).max(1)
}

/// The log's name for a refused config save: a constant string, where `Debug` formatting would
/// link core::fmt into the image for this one line.
pub fn save_error_name(e: SaveError) -> &'static str {
    match e {
        SaveError::TooLarge => "TooLarge (the config does not fit a record)",
        SaveError::Flash => "Flash (an erase or write failed)",
        SaveError::Geometry => "Geometry (the flash slots do not fit a record)",
    }
}
