//! Commands to the machine: [`MachineCommand`], why one is refused ([`Refusal`]) and
//! [`Machine::command`], which runs one if the state table allows it.

use super::*;

/// A command with its payload.
#[derive(Clone, Copy, Debug)]
pub enum MachineCommand<'a> {
    SetConfig(&'a BoardConfig),
    Home,
    Start,
    Queue(&'a Segment),
    Hold,
    Resume,
    Abort,
    ClearFault,
    JogOff,
    /// Admit step events for an event job (the table's Queue column). The caller checked the
    /// events (stream CRC and decoding) and holds them; segments and events never share a job.
    QueueEvents,
    /// Start the event job (the table's Start column): the caller's step source plays the
    /// admitted events through [`Machine::tick_with`].
    StartEvents,
    /// Start a Z-slide job (the table's Start column): the caller's step source
    /// (`motion::turning::link_job::ZJob`) steps X and Z through [`Machine::tick_with`]; the job
    /// ends when the source is idle. Refused while segments or events are queued.
    StartZ,
    /// Admit one segment for a wire job (the table's Queue column): checked like `Queue`
    /// (segment and soft limits) but held by the caller's wire job (`motion::wire::link_job`),
    /// not fed by the link's feeder. A wire job is a source job like an event job: it runs
    /// through [`Machine::tick_with`] and never shares a job with plain segments or events.
    QueueWire(&'a Segment),
    /// Start the wire job (the table's Start column): like `StartEvents`.
    StartWire,
    /// Start a copy job (the table's Start column): the caller's step source
    /// (`motion::polar::copy_link::CopySource`) turns encoder counts into steps through
    /// [`Machine::tick_with`] as an event job whose source is never idle: it runs until `Abort`
    /// or a fault, and `Hold`/`Resume` act on it like on an event job. Refused while segments
    /// or events are queued or another source job runs.
    StartCopy,
}

impl MachineCommand<'_> {
    pub const fn kind(&self) -> CommandKind {
        match self {
            MachineCommand::SetConfig(_) => CommandKind::SetConfig,
            MachineCommand::Home => CommandKind::Home,
            MachineCommand::Start => CommandKind::Start,
            MachineCommand::Queue(_) => CommandKind::Queue,
            MachineCommand::Hold => CommandKind::Hold,
            MachineCommand::Resume => CommandKind::Resume,
            MachineCommand::Abort => CommandKind::Abort,
            MachineCommand::ClearFault => CommandKind::ClearFault,
            MachineCommand::JogOff => CommandKind::JogOff,
            MachineCommand::QueueEvents => CommandKind::Queue,
            MachineCommand::StartEvents => CommandKind::Start,
            MachineCommand::StartZ => CommandKind::Start,
            MachineCommand::QueueWire(_) => CommandKind::Queue,
            MachineCommand::StartWire => CommandKind::Start,
            MachineCommand::StartCopy => CommandKind::Start,
        }
    }
}

/// Why a command was refused; nothing changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// The table does not allow this command in this state.
    OutOfState(MachineState),
    /// `ClearFault` while this fault's cause is still active.
    CauseActive(FaultCode),
    InvalidConfig(ConfigError),
    Segment(SegmentError),
    /// The segment would end outside the soft limits of `axis`.
    SoftLimit {
        axis: u8,
    },
    /// `JogOff` without a limit fault to jog off: no LimitSwitch latched, another cause present,
    /// no switch (or both switches of an axis) closed, or motion not yet at rest.
    NotOnLimit,
}

impl Refusal {
    /// The NAK code the link sends for this refusal.
    pub const fn error_code(&self) -> ErrorCode {
        match self {
            Refusal::OutOfState(_) | Refusal::CauseActive(_) | Refusal::NotOnLimit => {
                ErrorCode::OutOfState
            }
            Refusal::InvalidConfig(_) => ErrorCode::InvalidConfig,
            Refusal::Segment(_) | Refusal::SoftLimit { .. } => ErrorCode::InvalidSegment,
        }
    }
}

impl Machine {
    /// Runs `cmd` if the table allows it in the current state; else refuses and changes
    /// nothing. Control-task priority (with the DDA locked: Hold and Resume act on it).
    /// After an accepted `Abort`, `ClearFault` or `SetConfig` the caller drops the segments it
    /// holds for the DDA (its link queue); after `SetConfig` it rebuilds the DDA and preparer
    /// from [`Machine::config`] before the next [`Machine::background`].
    pub fn command(
        &mut self,
        cmd: MachineCommand<'_>,
        dda: &mut Dda,
    ) -> Result<MachineState, Refusal> {
        let to = match cell(self.state, cmd.kind()) {
            Cell::Refused => return Err(Refusal::OutOfState(self.state)),
            Cell::Stay => self.state,
            Cell::To(s) => s,
            Cell::Recover => {
                if let Some(&f) = FaultCode::ALL.iter().find(|f| self.active & f.bit() != 0) {
                    return Err(Refusal::CauseActive(f));
                }
                // After a following error the counters no longer say where the axis is.
                if self.homed && !self.latch.has(FaultCode::FollowingError) {
                    MachineState::Ready
                } else {
                    MachineState::Idle
                }
            }
        };
        // Segments and events never share a job: the machine has one job end to watch.
        let events = self.events_queued || self.event_job || self.z_job;
        let mixed = match cmd {
            MachineCommand::Queue(_) | MachineCommand::Start => events,
            MachineCommand::QueueEvents => self.in_flight(dda) != 0,
            MachineCommand::StartEvents => !self.events_queued || self.event_job,
            MachineCommand::StartZ => events || self.in_flight(dda) != 0,
            // During a source job the DDA also runs the source's own segments: only a plain
            // job's segments count against it.
            MachineCommand::QueueWire(_) => !events && self.in_flight(dda) != 0,
            MachineCommand::StartWire => !self.events_queued || self.event_job,
            MachineCommand::StartCopy => events || self.in_flight(dda) != 0,
            _ => false,
        };
        if mixed {
            return Err(Refusal::OutOfState(self.state));
        }
        // Checks first (a refusal changes nothing), then effects.
        match cmd {
            MachineCommand::SetConfig(new) => {
                new.validate().map_err(Refusal::InvalidConfig)?;
                self.install(*new);
                self.following.resync();
                self.homed = false;
                self.homing.cancel();
                self.probe.drop_move();
                self.jog = None;
                self.freeze();
            }
            MachineCommand::Queue(seg) => {
                self.admit(seg)?;
                self.admitted = self.admitted.wrapping_add(1);
                self.last_exit_nonzero = seg.exit_rate.to_bits() != 0;
            }
            MachineCommand::QueueEvents => self.events_queued = true,
            MachineCommand::QueueWire(seg) => {
                self.admit(seg)?;
                self.events_queued = true;
            }
            MachineCommand::StartWire | MachineCommand::StartEvents | MachineCommand::StartCopy => {
                self.probe.drop_move();
                self.event_job = true;
                self.paused = false;
            }
            MachineCommand::StartZ => {
                self.probe.drop_move();
                self.z_job = true;
                self.paused = false;
            }
            MachineCommand::Home => {
                self.probe.drop_move();
                self.events_queued = false;
                self.homed = false;
                self.homing = Homing::start(&self.cfg);
            }
            MachineCommand::Start => {
                if let Err(fault) = self.probe.start(self.switch_filter.probe_level()) {
                    // Nothing moves: the fault is the answer (grbl's ALARM:4).
                    self.raise(fault);
                    return Ok(self.state);
                }
            }
            MachineCommand::Hold => {
                self.paused = true;
                dda.apply(Command::Hold);
            }
            MachineCommand::Resume => {
                // Still starved, the next tick holds again.
                self.starved = false;
                self.resume_pending = false;
                self.paused = false;
                dda.apply(Command::Resume);
            }
            MachineCommand::Abort => {
                self.probe.drop_move();
                self.homing.cancel();
                self.jog = None;
                self.freeze();
            }
            MachineCommand::ClearFault => {
                if self.latch.has(FaultCode::FollowingError) {
                    self.homed = false;
                    // The operator accepts where the axes stand: errors count from here.
                    self.following.resync();
                }
                self.latch.clear();
                self.probe.drop_move();
                self.homing.cancel();
                self.jog = None;
                self.hold_pending = false;
                self.freeze();
            }
            MachineCommand::JogOff => {
                let only_limit = self.active & !FaultCode::LimitSwitch.bit() == 0;
                let at_rest = !self.frozen && !self.abort_pending && dda.is_idle();
                let jog = JogOff::start(self.switches.0, self.switches.1, &self.cfg)
                    .filter(|_| self.latch.has(FaultCode::LimitSwitch) && only_limit && at_rest)
                    .filter(|_| self.jog.is_none());
                self.jog = Some(jog.ok_or(Refusal::NotOnLimit)?);
            }
        }
        self.state = to;
        // Whatever the command changed, the next tick is a full one.
        self.fast_left = 0;
        Ok(to)
    }
}
