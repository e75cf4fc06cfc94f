//! The hooks every capability's link module fills ([`LinkJob`]); the list of modules is
//! `super::capabilities`.

use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::protocol::Status;

use super::Motion;

/// The link side of one capability's jobs.
pub trait LinkJob {
    /// Its job holds the board (armed, queued or running): no other job may be queued, armed
    /// or started.
    fn live(m: &Motion) -> bool;
    /// Abort, ClearFault, SetConfig or Home dropped the job (inside the `Motion` lock).
    fn drop_job(m: &mut Motion);
    /// Its fields of `Status`.
    fn status(m: &Motion, teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status);
}

/// Implements [`LinkJob`] for `$ty` in a module whose free functions `live(m)`,
/// `drop_job(m)` and `status(m, s)` are the hooks (the module needs no teach recorder).
macro_rules! link_job_from_module_fns {
    ($ty:ident) => {
        impl $crate::link::link_job::LinkJob for $ty {
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
        }
    };
}
pub(crate) use link_job_from_module_fns;
