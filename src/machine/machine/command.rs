//! Commands to the machine: [`MachineCommand`], why one is refused ([`Refusal`]) and
//! [`Machine::command`], which runs one if the state table allows it.

use super::*;

/// A command with its payload.
#[derive(Clone, Copy, Debug)]
pub enum MachineCommand<'a> {
    Home,
    Start,
    Queue(&'a Segment),
    Hold,
    Resume,
    Abort,
    ClearFault,
    JogOff,
    /// Admit items (step events, checked and held by the caller) for a source job (the table's
    /// Queue column). Segments and a source job's items never share a job.
    QueueSource,
    /// Admit one segment for a source job (the table's Queue column): checked like `Queue`
    /// (segment and soft limits) but held by the caller's source (a wire job's), not fed by the
    /// link's feeder.
    QueueSourceSegment(&'a Segment),
    /// Start the source job `job` over the items admitted for it (the table's Start column): the
    /// caller's step source plays them through [`Machine::tick_with`]; the job ends when the
    /// source is idle, and a source that runs dry first raises `QueueUnderrun`.
    StartQueued(SourceJob),
    /// Start the source job `job` with nothing admitted (the table's Start column): the caller's
    /// source makes its own motion (a Z slide from the spindle angle, steps from encoder counts)
    /// until it is idle, or for ever (until `Abort` or a fault). Refused while segments or items
    /// are queued or another source job runs.
    StartSource(SourceJob),
}

impl MachineCommand<'_> {
    pub const fn kind(&self) -> CommandKind {
        match self {
            MachineCommand::Home => CommandKind::Home,
            MachineCommand::Start => CommandKind::Start,
            MachineCommand::Queue(_) => CommandKind::Queue,
            MachineCommand::Hold => CommandKind::Hold,
            MachineCommand::Resume => CommandKind::Resume,
            MachineCommand::Abort => CommandKind::Abort,
            MachineCommand::ClearFault => CommandKind::ClearFault,
            MachineCommand::JogOff => CommandKind::JogOff,
            MachineCommand::QueueSource | MachineCommand::QueueSourceSegment(_) => {
                CommandKind::Queue
            }
            MachineCommand::StartQueued(_) | MachineCommand::StartSource(_) => CommandKind::Start,
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
    /// After an accepted `Abort` or `ClearFault` the caller drops the segments it holds for the
    /// DDA (its link queue). `SetConfig` is [`Machine::set_config`].
    pub fn command(
        &mut self,
        cmd: MachineCommand<'_>,
        dda: &mut Dda,
    ) -> Result<MachineState, Refusal> {
        let to = self.table_target(cmd.kind())?;
        // Segments and a source job never share a job: the machine has one job end to watch.
        let source = self.source_queued || self.source.is_some();
        let mixed = match cmd {
            MachineCommand::Queue(_) | MachineCommand::Start => source,
            MachineCommand::QueueSource => self.in_flight(dda) != 0,
            // During a source job the DDA also runs the source's own segments: only a plain
            // job's segments count against it.
            MachineCommand::QueueSourceSegment(_) => !source && self.in_flight(dda) != 0,
            MachineCommand::StartQueued(_) => !self.source_queued || self.source.is_some(),
            MachineCommand::StartSource(_) => source || self.in_flight(dda) != 0,
            _ => false,
        };
        if mixed {
            return Err(Refusal::OutOfState(self.state));
        }
        // Checks first (a refusal changes nothing), then effects.
        match cmd {
            MachineCommand::Queue(seg) => {
                self.admit(seg)?;
                self.admitted = self.admitted.wrapping_add(1);
                self.last_exit_nonzero = seg.exit_rate.to_bits() != 0;
            }
            MachineCommand::QueueSource => self.source_queued = true,
            MachineCommand::QueueSourceSegment(seg) => {
                self.admit(seg)?;
                self.source_queued = true;
            }
            MachineCommand::StartQueued(job) | MachineCommand::StartSource(job) => {
                self.probe.drop_move();
                self.source = Some(job);
                self.paused = false;
            }
            MachineCommand::Home => {
                self.probe.drop_move();
                self.source_queued = false;
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

    /// `SetConfig` (the table's SetConfig column): validates `new` and installs it, if the
    /// table allows it in the current state; else refuses and changes nothing. Homing is lost
    /// and the DDA stops; the caller drops the segments it holds, and rebuilds the DDA and
    /// preparer from [`Machine::config`] before the next [`Machine::background`]. Not a
    /// [`MachineCommand`]: installing a config divides (the debounce in ticks), and the
    /// commands that may run at tick rate (a scenario's) must not reach that code.
    pub fn set_config(&mut self, new: &BoardConfig) -> Result<MachineState, Refusal> {
        let to = self.table_target(CommandKind::SetConfig)?;
        new.validate().map_err(Refusal::InvalidConfig)?;
        self.install(*new);
        self.following.resync();
        self.homed = false;
        self.homing.cancel();
        self.probe.drop_move();
        self.jog = None;
        self.freeze();
        self.state = to;
        self.fast_left = 0;
        Ok(to)
    }

    /// The state a command of `kind` leads to from the current one, by the table; a refusal
    /// (nothing changed) when the table refuses it or a fault's cause is still present.
    fn table_target(&self, kind: CommandKind) -> Result<MachineState, Refusal> {
        match cell(self.state, kind) {
            Cell::Refused => Err(Refusal::OutOfState(self.state)),
            Cell::Stay => Ok(self.state),
            Cell::To(s) => Ok(s),
            Cell::Recover => {
                if let Some(&f) = FaultCode::ALL.iter().find(|f| self.active & f.bit() != 0) {
                    return Err(Refusal::CauseActive(f));
                }
                // After a following error the counters no longer say where the axis is.
                if self.homed && !self.latch.has(FaultCode::FollowingError) {
                    Ok(MachineState::Ready)
                } else {
                    Ok(MachineState::Idle)
                }
            }
        }
    }
}
