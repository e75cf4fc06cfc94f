//! The link application's capability registry: the hooks every capability's link module fills
//! ([`LinkJob`]) and the one list of them ([`Capabilities`]) that the link target walks for the
//! requests that concern every job (a job that holds the board refuses another; abort, clear,
//! config and homing drop every job; Status carries every capability's fields). A fifth
//! capability adds its module and one element to [`Capabilities`]. The tick's chain of
//! capability ticks stays spelt out in `bin/link.rs`: it is the interrupt's hot path, in
//! priority order.

use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::protocol::Status;

use super::{copy, milling, turning, wire, Motion};

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
        impl $crate::link::capabilities::LinkJob for $ty {
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

/// Every capability's link module, in the order Status fills them.
pub type Capabilities = (wire::Wire, turning::Turning, copy::PolarCopy, milling::Milling);

impl<A: LinkJob, B: LinkJob, C: LinkJob, D: LinkJob> LinkJob for (A, B, C, D) {
    fn live(m: &Motion) -> bool {
        A::live(m) || B::live(m) || C::live(m) || D::live(m)
    }

    fn drop_job(m: &mut Motion) {
        A::drop_job(m);
        B::drop_job(m);
        C::drop_job(m);
        D::drop_job(m);
    }

    fn status(m: &Motion, teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status) {
        A::status(m, teach, s);
        B::status(m, teach, s);
        C::status(m, teach, s);
        D::status(m, teach, s);
    }
}
