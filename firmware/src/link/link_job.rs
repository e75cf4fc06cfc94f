//! The hooks every capability's link module fills ([`LinkJob`]); the list of modules is
//! `super::capabilities`.

use motion::dda::StepOutput;
use motion::machine::{Inputs, TickOut};
use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::protocol::Status;

use super::Motion;
use crate::board;

/// What a full tick read from the board, for the capabilities' [`LinkJob::sense`] and
/// [`LinkJob::tick`].
pub struct Readings<'a> {
    pub inputs: &'a Inputs,
    /// The copy encoders' counts (arm, carriage).
    pub copy_counts: [i32; 2],
    /// The wire-stall switch.
    pub wire_stall: bool,
    pub spindle: &'a mut board::Spindle,
}

/// What a step-only tick may read from the board: only the capability whose job runs reads it,
/// and only what its tick uses.
pub struct StepReadings<'a> {
    pub spindle: &'a mut board::Spindle,
    /// The spindle stood still at the last full tick: its update would change nothing.
    pub spindle_at_rest: bool,
    pub io: &'a mut board::MachineIo,
}

/// The link side of one capability's jobs.
pub trait LinkJob {
    /// Its job holds the board (armed, queued or running): no other job may be queued, armed
    /// or started.
    fn live(m: &Motion) -> bool;
    /// Abort, ClearFault, SetConfig or Home dropped the job (inside the `Motion` lock).
    fn drop_job(m: &mut Motion);
    /// Its fields of `Status`.
    fn status(m: &Motion, teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status);
    /// Every full tick, before any job's tick: the readings it keeps whatever job runs (the
    /// spindle's decoder, the copy encoders' counts for Status). Interrupt rate.
    #[inline(always)]
    fn sense(_m: &mut Motion, _r: &mut Readings<'_>) {}
    /// Its job's full tick, if its job runs (`None`: not its job). Interrupt rate.
    #[inline(always)]
    fn tick(_m: &mut Motion, _r: &Readings<'_>) -> Option<TickOut> {
        None
    }
    /// A step-only tick of its job, tried on the ticks after its [`LinkJob::tick`] ran, if the
    /// machine grants one (`None`: run a full tick, which reads what this did not). Interrupt
    /// rate.
    #[inline(always)]
    fn step_only_tick(_m: &mut Motion, _b: &mut StepReadings<'_>) -> Option<StepOutput> {
        None
    }
}

/// Inside an `impl LinkJob` in a module whose free functions `live(m)`, `drop_job(m)` and
/// `status(m, s)` are the hooks of those names (a module that needs no teach recorder).
macro_rules! job_hooks_from_module_fns {
    () => {
        fn live(m: &Motion) -> bool {
            live(m)
        }

        fn drop_job(m: &mut Motion) {
            drop_job(m)
        }

        fn status(
            m: &Motion,
            _teach: &motion::polar::copy_link::TeachRecorder<
                { motion::polar::copy_link::TEACH_BLOCKS },
            >,
            s: &mut Status,
        ) {
            status(m, s)
        }
    };
}
pub(crate) use job_hooks_from_module_fns;
