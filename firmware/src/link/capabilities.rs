//! The link application's capability registry: the one list ([`Capabilities`]) of the
//! capabilities' link modules, each filling [`LinkJob`], that the link target walks for the
//! requests that concern every job (a job that holds the board refuses another; abort, clear,
//! config and homing drop every job; Status carries every capability's fields) and that the tick
//! walks ([`TickChain`]: every capability's readings, then the full tick of the one whose job
//! runs, and that one's step-only ticks after it). A fifth capability adds its module and one
//! element to [`Capabilities`] (the walks are implemented for tuples of four to six).

use motion::dda::StepOutput;
use motion::machine::TickOut;
use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::protocol::Status;

use super::link_job::{LinkJob, Readings, StepReadings};
use super::{milling, polar, turning, wire, Motion};

/// Every capability's link module, in the order Status fills them.
pub type Capabilities = (wire::Wire, turning::Turning, polar::Polar, milling::Milling);

/// The tick's walk over the capabilities. Each capability's job excludes the others'
/// ([`LinkJob::live`]), so at most one `tick` answers.
pub trait TickChain {
    /// Every capability's [`LinkJob::sense`].
    fn sense(m: &mut Motion, r: &mut Readings<'_>);
    /// The full tick of the capability whose job runs, and its place in the list (from 1);
    /// `None`: no capability job runs (the plain tick's turn).
    fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<(TickOut, u8)>;
    /// The step-only tick of the capability at place `which` (from [`TickChain::tick`]).
    fn step_only_tick(which: u8, m: &mut Motion, b: &mut StepReadings<'_>) -> Option<StepOutput>;
}

/// [`LinkJob`] (every element's, in order) and [`TickChain`] for a tuple of link modules, from
/// its elements' places (from 1) and types. Monomorphised and inlined: the tick's walk is the
/// chain of tests it would be if written out.
macro_rules! registry_tuple {
    ($($n:literal $t:ident),+) => {
        impl<$($t: LinkJob),+> LinkJob for ($($t,)+) {
            fn live(m: &Motion) -> bool {
                $(if $t::live(m) {
                    return true;
                })+
                false
            }

            fn drop_job(m: &mut Motion) {
                $($t::drop_job(m);)+
            }

            fn status(m: &Motion, teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status) {
                $($t::status(m, teach, s);)+
            }
        }

        impl<$($t: LinkJob),+> TickChain for ($($t,)+) {
            #[inline(always)]
            fn sense(m: &mut Motion, r: &mut Readings<'_>) {
                $($t::sense(m, r);)+
            }

            #[inline(always)]
            fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<(TickOut, u8)> {
                $(if let Some(out) = $t::tick(m, r) {
                    return Some((out, $n));
                })+
                None
            }

            #[inline(always)]
            fn step_only_tick(
                which: u8,
                m: &mut Motion,
                b: &mut StepReadings<'_>,
            ) -> Option<StepOutput> {
                match which {
                    $($n => $t::step_only_tick(m, b),)+
                    _ => None,
                }
            }
        }
    };
}

registry_tuple!(1 A, 2 B, 3 C, 4 D);
registry_tuple!(1 A, 2 B, 3 C, 4 D, 5 E);
registry_tuple!(1 A, 2 B, 3 C, 4 D, 5 E, 6 F);
