//! The link application's capability registry: the one list ([`Capabilities`]) of the
//! capabilities' link modules, each filling [`LinkJob`], that the link target walks for the
//! requests that concern every job (a job that holds the board refuses another; abort, clear,
//! config and homing drop every job; Status carries every capability's fields). A fifth
//! capability adds its module and one element to [`Capabilities`]. The tick's chain of
//! capability ticks stays spelt out in `bin/link.rs`: it is the interrupt's hot path, in
//! priority order.

use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::protocol::Status;

use super::link_job::LinkJob;
use super::{copy, milling, turning, wire, Motion};

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
