//! The machine's states and commands, and the one table that says which command each state
//! accepts and where it leads. [`crate::machine::Machine::command`] consults [`cell`] before it
//! changes anything, and [`markdown_table`] / [`mermaid_diagram`] render the same table for the
//! documentation, so behaviour and docs cannot drift apart.

use core::fmt::Write;

/// Where the machine is in its life cycle.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum MachineState {
    /// Power-up: loading the persisted configuration. Leaves by itself.
    #[default]
    Boot = 0,
    /// Configured, not homed: positions mean nothing yet, so no job may run.
    Idle = 1,
    /// The homing sequencer is moving the axes onto their switches.
    Homing = 2,
    /// Homed and still: jobs may be queued and started.
    Ready = 3,
    /// A job is running (the feeder may push segments to the DDA).
    Running = 4,
    /// A job is stopped on its path by a feed hold; `Resume` continues it.
    Holding = 5,
    /// A fault is latched: motion stopped (or stopping) until `ClearFault` after the cause is gone.
    Fault = 6,
}

impl MachineState {
    pub const COUNT: usize = 7;
    /// Every state, in table order.
    pub const ALL: [MachineState; Self::COUNT] = [
        MachineState::Boot,
        MachineState::Idle,
        MachineState::Homing,
        MachineState::Ready,
        MachineState::Running,
        MachineState::Holding,
        MachineState::Fault,
    ];

    pub const fn name(self) -> &'static str {
        match self {
            MachineState::Boot => "Boot",
            MachineState::Idle => "Idle",
            MachineState::Homing => "Homing",
            MachineState::Ready => "Ready",
            MachineState::Running => "Running",
            MachineState::Holding => "Holding",
            MachineState::Fault => "Fault",
        }
    }

    pub const fn description(self) -> &'static str {
        match self {
            MachineState::Boot => "Loading the persisted config; leaves by itself.",
            MachineState::Idle => "Configured, not homed: no job may run.",
            MachineState::Homing => "The homing sequencer moves each axis onto its switch.",
            MachineState::Ready => "Homed and still: jobs may be queued and started.",
            MachineState::Running => "A job runs; the feeder may push segments.",
            MachineState::Holding => "Stopped on the path by a feed hold.",
            MachineState::Fault => {
                "A fault is latched; ClearFault once its cause is gone (after a safe stop)."
            }
        }
    }

    /// Row of this state in [`TABLE`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// A command without its payload: the column of [`TABLE`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum CommandKind {
    SetConfig = 0,
    Home = 1,
    Start = 2,
    Queue = 3,
    Hold = 4,
    Resume = 5,
    Abort = 6,
    ClearFault = 7,
    JogOff = 8,
}

impl CommandKind {
    pub const COUNT: usize = 9;
    /// Every command, in table order.
    pub const ALL: [CommandKind; Self::COUNT] = [
        CommandKind::SetConfig,
        CommandKind::Home,
        CommandKind::Start,
        CommandKind::Queue,
        CommandKind::Hold,
        CommandKind::Resume,
        CommandKind::Abort,
        CommandKind::ClearFault,
        CommandKind::JogOff,
    ];

    pub const fn name(self) -> &'static str {
        match self {
            CommandKind::SetConfig => "SetConfig",
            CommandKind::Home => "Home",
            CommandKind::Start => "Start",
            CommandKind::Queue => "Queue",
            CommandKind::Hold => "Hold",
            CommandKind::Resume => "Resume",
            CommandKind::Abort => "Abort",
            CommandKind::ClearFault => "ClearFault",
            CommandKind::JogOff => "JogOff",
        }
    }

    pub const fn description(self) -> &'static str {
        match self {
            CommandKind::SetConfig => {
                "Replace the board config (validated; the caller rebuilds Dda and Preparer). Loses homing."
            }
            CommandKind::Home => "Run the homing sequence (each axis: seek, back off, latch).",
            CommandKind::Start => "Run the queued job.",
            CommandKind::Queue => {
                "Admit one segment: soft limits checked against the end of everything queued before it."
            }
            CommandKind::Hold => "Feed hold: decelerate and stop on the path.",
            CommandKind::Resume => "Leave a feed hold.",
            CommandKind::Abort => "Stop at once (no deceleration) and drop every queued segment.",
            CommandKind::ClearFault => {
                "Unlatch the faults once no cause is active; the rest of the job is dropped."
            }
            CommandKind::JogOff => {
                "After a limit fault, move the tripped axes slowly off their switches (stops when they open, or at once if another closes); then ClearFault."
            }
        }
    }

    /// Column of this command in [`TABLE`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// What a state does with a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cell {
    /// Refused (`OutOfState`); nothing changes.
    Refused,
    /// Accepted; the state stays.
    Stay,
    /// Accepted; the machine goes to this state.
    To(MachineState),
    /// Accepted only when no fault cause is still active (else refused, nothing changes); goes to
    /// `Ready` if the homing is still trusted, else `Idle`.
    Recover,
}

use CommandKind as C;
use MachineState as S;
const R: Cell = Cell::Refused;
const K: Cell = Cell::Stay;
const fn to(s: MachineState) -> Cell {
    Cell::To(s)
}

/// Row = state ([`MachineState::index`]), column = command ([`CommandKind::index`]):
/// SetConfig, Home, Start, Queue, Hold, Resume, Abort, ClearFault, JogOff.
pub const TABLE: [[Cell; CommandKind::COUNT]; MachineState::COUNT] = [
    /* Boot    */ [R, R, R, R, R, R, R, R, R],
    /* Idle    */ [K, to(S::Homing), R, R, R, R, K, R, R],
    /* Homing  */ [R, R, R, R, R, R, to(S::Idle), R, R],
    /* Ready   */ [to(S::Idle), to(S::Homing), to(S::Running), K, R, R, K, R, R],
    /* Running */ [R, R, R, K, to(S::Holding), R, to(S::Ready), R, R],
    /* Holding */ [R, R, R, K, R, to(S::Running), to(S::Ready), R, R],
    /* Fault   */ [K, R, R, R, R, R, K, Cell::Recover, K],
];

/// The table's answer for `state` and `cmd`.
pub const fn cell(state: MachineState, cmd: CommandKind) -> Cell {
    TABLE[state.index()][cmd.index()]
}

/// Transitions the machine takes by itself (not on a command): from, to, why.
pub const EVENTS: [(MachineState, MachineState, &str); 11] = [
    (S::Boot, S::Idle, "config loaded"),
    (S::Boot, S::Fault, "config missing or corrupt"),
    (S::Homing, S::Ready, "every axis homed"),
    (S::Running, S::Ready, "job done"),
    (S::Boot, S::Fault, "fault"),
    (S::Idle, S::Fault, "fault"),
    (S::Homing, S::Fault, "fault"),
    (S::Ready, S::Fault, "fault"),
    (S::Running, S::Fault, "fault"),
    (S::Holding, S::Fault, "fault"),
    (S::Fault, S::Fault, "another fault (first one kept)"),
];

/// True when the machine may go from `from` to `to` by itself; [`crate::machine::Machine`]
/// takes no event transition the table does not list.
pub fn event_allowed(from: MachineState, to: MachineState) -> bool {
    EVENTS.iter().any(|&(f, t, _)| f == from && t == to)
}

fn cell_text(c: Cell) -> &'static str {
    match c {
        Cell::Refused => "refused",
        Cell::Stay => "stay",
        Cell::To(S::Boot) => "-> Boot",
        Cell::To(S::Idle) => "-> Idle",
        Cell::To(S::Homing) => "-> Homing",
        Cell::To(S::Ready) => "-> Ready",
        Cell::To(S::Running) => "-> Running",
        Cell::To(S::Holding) => "-> Holding",
        Cell::To(S::Fault) => "-> Fault",
        Cell::Recover => "-> Ready / Idle (1)",
    }
}

/// The command table as Markdown: one row per state, one column per command, then the state and
/// command legends and the self-transitions.
pub fn markdown_table(out: &mut impl Write) -> core::fmt::Result {
    out.write_str("| State |")?;
    for c in C::ALL {
        write!(out, " {} |", c.name())?;
    }
    out.write_str("\n|---|")?;
    for _ in C::ALL {
        out.write_str("---|")?;
    }
    out.write_str("\n")?;
    for s in S::ALL {
        write!(out, "| {} |", s.name())?;
        for c in C::ALL {
            write!(out, " {} |", cell_text(cell(s, c)))?;
        }
        out.write_str("\n")?;
    }
    out.write_str(
        "\n\"refused\": NAK `OutOfState`, nothing changes. (1) refused while a fault cause is \
         still active (NAK names it); else Ready if the homing is still trusted (no e-stop, no \
         config change since), Idle otherwise.\n\n| State | Meaning |\n|---|---|\n",
    )?;
    for s in S::ALL {
        writeln!(out, "| {} | {} |", s.name(), s.description())?;
    }
    out.write_str("\n| Command | Meaning |\n|---|---|\n")?;
    for c in C::ALL {
        writeln!(out, "| {} | {} |", c.name(), c.description())?;
    }
    out.write_str("\n| Event | From | To |\n|---|---|---|\n")?;
    for (from, to, why) in EVENTS {
        writeln!(out, "| {why} | {} | {} |", from.name(), to.name())?;
    }
    Ok(())
}

/// The state diagram as Mermaid text: every state-changing cell of [`TABLE`] and every
/// [`EVENTS`] edge (the many "fault" edges drawn once each).
pub fn mermaid_diagram(out: &mut impl Write) -> core::fmt::Result {
    out.write_str("stateDiagram-v2\n    [*] --> Boot\n")?;
    for s in S::ALL {
        for c in C::ALL {
            match cell(s, c) {
                Cell::To(t) => writeln!(out, "    {} --> {}: {}", s.name(), t.name(), c.name())?,
                Cell::Recover => {
                    writeln!(out, "    {} --> Ready: {} (homed)", s.name(), c.name())?;
                    writeln!(out, "    {} --> Idle: {} (not homed)", s.name(), c.name())?;
                }
                Cell::Refused | Cell::Stay => {}
            }
        }
    }
    for (from, to, why) in EVENTS {
        if from != to {
            writeln!(out, "    {} --> {}: {}", from.name(), to.name(), why)?;
        }
    }
    Ok(())
}
