//! The status report and the board's counters of recovered trouble.

use serde::{Deserialize, Serialize};

use super::SENSOR_CHANNELS;
use crate::config::MAX_AXES;
use crate::dda::MotionState;
use crate::machine::MachineState;

/// Counts of recovered trouble since boot. Each is modular (u32, wraps after 2^32): compare two
/// readings with `wrapping_sub`, as [`BoardCounters::since`] does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BoardCounters {
    /// Received bytes lost because the USART's data register was not read in time.
    pub usart_overruns: u32,
    /// Frames that failed COBS, length or CRC checks, or did not decode as a request.
    pub frames_bad: u32,
    /// Answers that did not fit the transmit queue whole and were dropped (the host resends).
    pub responses_dropped: u32,
    /// Ticks that started after their period had passed.
    pub tick_overruns: u32,
    /// Steps the DDA held back a tick (direction setup or a step pulse still high).
    pub steps_deferred: u32,
    /// Times a segment job held on the path because the host had not sent the next segment
    /// in time (it resumed when the segment came).
    pub starve_holds: u32,
}

impl BoardCounters {
    /// Counts from `earlier` to `self`, correct across one wrap of each counter.
    pub fn since(&self, earlier: &BoardCounters) -> BoardCounters {
        BoardCounters {
            usart_overruns: self.usart_overruns.wrapping_sub(earlier.usart_overruns),
            frames_bad: self.frames_bad.wrapping_sub(earlier.frames_bad),
            responses_dropped: self.responses_dropped.wrapping_sub(earlier.responses_dropped),
            tick_overruns: self.tick_overruns.wrapping_sub(earlier.tick_overruns),
            steps_deferred: self.steps_deferred.wrapping_sub(earlier.steps_deferred),
            starve_holds: self.starve_holds.wrapping_sub(earlier.starve_holds),
        }
    }
}

/// Motion state on the link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkState {
    #[default]
    Idle,
    Moving,
    /// Hold requested, decelerating.
    Stopping,
    Held,
    /// A fault is latched: motion stopped; `ClearFault` (or `Abort`) needed.
    Faulted,
}

impl From<MotionState> for LinkState {
    fn from(s: MotionState) -> Self {
        match s {
            MotionState::Idle => LinkState::Idle,
            MotionState::Moving => LinkState::Moving,
            MotionState::Stopping => LinkState::Stopping,
            MotionState::Held => LinkState::Held,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// DDA tick count.
    pub tick: u64,
    /// Steps, per axis.
    pub positions: [i64; MAX_AXES],
    pub state: LinkState,
    /// Feed override, `Rate` bits.
    pub override_bits: u32,
    /// Segments queued, not yet finished.
    pub queue_depth: u16,
    /// Free queue slots (filled in by `BoardLink`).
    pub credits: u16,
    pub segments_done: u32,
    pub last_done_id: Option<u32>,
    /// `segment::order_hash` over every completed segment id, in completion order.
    pub done_hash: u32,
    /// Latched faults: bit n set = `FaultCode` n.
    pub faults: u32,
    pub sensors: [i32; SENSOR_CHANNELS],
    /// Board's next expected seq (filled in by `BoardLink`); `credits` hold after `next_seq - 1`.
    pub next_seq: u32,
    /// The machine's state (`src/machine/MACHINE.md`): `state` says how the axes move, this
    /// says what the board accepts.
    pub machine: MachineState,
    /// Fault causes present now (`FaultCode` bits): `ClearFault` is refused while one is.
    pub causes: u32,
    /// The homing is trusted (positions are machine coordinates).
    pub homed: bool,
    /// Free event-block slots (`QueueEvents` credits, counted like `credits`).
    pub event_credits: u16,
    /// Events the current (or last) event job has fired.
    pub events_fired: u32,
    /// Event blocks queued and not yet decoded into the playback.
    pub event_blocks: u16,
    /// The current (or last) wire job: stalls detected, retrace and return segments run, the
    /// largest retraced distance of one stall (L1 steps), and the wire power output now.
    pub wire_stalls: u32,
    pub wire_retraces: u32,
    pub wire_returns: u32,
    pub wire_max_retrace_steps: u64,
    pub wire_power: bool,
    // -- Z-slide job --
    /// The current (or last) Z job: `ZJob::state_code` (`ZState`) (0 none, 1 idle/engaging,
    /// 2 running, 3 finished, 4 faulted), commanded X (inches Q24), Z command (inches Q32),
    /// the largest following error (nanoinches), Z steps emitted, the DAC code, and the spindle
    /// speed the board senses (thousandths of rpm).
    pub z_state: u8,
    pub z_x_in_q24: i32,
    pub z_cmd_in_q32: i32,
    pub z_max_following_nin: i64,
    pub z_steps: i64,
    pub z_dac_code: u16,
    pub z_spindle_rpm_milli: i64,
    // -- force job --
    /// The current (or last) force job: the chain's latest force (resultant) and its tooth
    /// peak, mN; the controller's override (`Rate` bits); its phase (`ForcePhase` as u8: 0 no
    /// job); control updates run.
    pub force_mn: u32,
    pub force_peak_mn: u32,
    pub force_override_bits: u32,
    pub force_phase: u8,
    pub force_updates: u32,
    // -- copy mode --
    /// A copy job runs (or holds).
    pub copy_running: bool,
    /// The copy encoders' counts now (arm, carriage), read every tick.
    pub encoder_counts: [i32; 2],
    /// The current (or last) copy job: events recorded and events lost (teach).
    pub taught_events: u32,
    pub lost_events: u32,
    /// What the board recovered from without a fault, counted since boot.
    pub counters: BoardCounters,
    /// The program outputs the board drives now (`SetProgramOutputs`), `OUT_*` bits: bit 0
    /// spindle on, bit 1 spindle counterclockwise (with bit 0), bit 2 mist, bit 3 flood.
    pub outputs: u8,
    /// The current (or last) probe move: `machine::ProbePhase` as u8 (0 none, 1 armed,
    /// 2 moving, 3 tripped, 4 missed, 5 refused, 6 dropped), the machine position of every axis
    /// latched at the trip (steps; meaningful when tripped), and the debounced probe input now.
    pub probe_phase: u8,
    pub probe_steps: [i64; MAX_AXES],
    pub probe_input: bool,
}
