//! `motionctl run`: streams a planned job to the board and checks what it did.
//!
//! Hello (protocol version) -> the board must be idle with an empty queue -> `SetConfig` from the
//! job's `[machine]` (skipped when the board already has it) -> `SetStatusPeriod` -> the
//! segments of [`crate::plan::Stream`] in `QueueSegments` batches as credits allow, `Start` once
//! the queue is full (or everything before the next event is queued), the spindle and coolant
//! switched (`SetProgramOutputs`, read back from the board's status) once the motion before them
//! is done,
//! program pauses (M0) held until the operator presses Enter -> wait until every segment is done
//! and the board is idle -> verify: segments done == sent, the board's order hash == the hash of
//! the ids sent (every segment exactly once, in order), final positions == the host model's.
//!
//! One concern a file, each importing only those named before it here: `path_check` (every
//! status report against the planned path), `options` and `report` (what a run is given and
//! what it gives back), `watch` (limits on a running job), `board`
//! (asking the board, bringing it to `Ready`), `outputs` (what is sent, and where the run is in
//! it), then the run itself: `stream` (connecting, the loop and most of its steps), `replies`
//! (what the board said), `events` (spindle, coolant, pauses and dwells between segments),
//! `probe` (G38.x probe moves, each run alone and the rest replanned from where it stopped) and
//! `verify` (the checks at the end). `hook` lets a capability's runner be driven (held,
//! resumed, aborted) while it owns the link.

mod board;
mod events;
mod hook;
mod options;
mod outputs;
mod path_check;
mod probe;
mod replies;
mod report;
mod stream;
mod verify;
mod watch;

pub use board::{
    ask, ask_status, axes_of, fault_names, home, link_config, ready_board, seq_at_or_after, Home,
    HOMING_BOARD_SECONDS, HOMING_STUCK,
};
pub use hook::{JobControl, JobHook, Steer, Unattended};
pub use options::{RunOptions, SimProbe, ZeroHere, DEFAULT_STATUS_PERIOD_MS};
pub use outputs::{OutputSource, Outputs, Tagged};
pub use path_check::{PathSummary, PATH_LIMIT_STEPS};
pub use probe::{probe_ended_as, probe_outcome, set_sim_probe};
pub use report::{counters_text, ProbeOutcome, Probed, RunError, RunReport};
pub use stream::{run, run_outputs, HEARTBEAT_EVERY};
pub use watch::{JobWatch, Overdue};
