//! Every closed-loop scenario the firmware's scenario build runs, in order, behind one enum so
//! the firmware and the host model walk the same list. Each capability keeps its scenario next
//! to its logic; this module only lists them.

pub mod faults;
pub mod override_sweep;

use crate::dda::lane_kernel_check::LaneKernelCheck;
use crate::milling::scenario::{MillingScenario, Variant as MillingVariant};
use crate::polar::playback::SizeScale;
use crate::polar::scenario::PolarPlayback;
use crate::segment::Rate;
use crate::turning::scenario::{TurningScenario, TurningVariant};
use crate::wire::scenario::{WireJobScenario, WireStallScenario};

use crate::scenario::{Scenario, ScenarioReport};

/// One of the built-in scenarios. Variants differ in size a lot; only one exists at a time (the
/// firmware's single slot) and there is no allocator to box them.
#[allow(clippy::large_enum_variant)]
pub enum AnyScenario {
    OverrideSweep(override_sweep::OverrideSweep),
    /// The built-in limacon contour (Fahim) at 2x speed and 3:2 radial size.
    PolarPlayback(PolarPlayback),
    /// Constant-force milling (Elbestawi): closed-loop Case A and its fault variants.
    Milling(MillingScenario),
    /// The machine's fault suite: each cause injected by the sim board.
    Fault(faults::FaultScenario),
    /// Non-axisymmetric turning (Douglass): the Fourier-series Z slide from encoder or resolver.
    Turning(TurningScenario),
    /// The 4-axis wire manipulator (Bhatti): the whole circle -> complex job, continuous.
    WireJob(WireJobScenario),
    /// A shortened wire job with a stall injected: retrace, return, finish.
    WireStall(WireStallScenario),
    /// The DDA's lane kernel on pseudo-random lanes (Thumb-2 in the firmware, Rust on the host).
    LaneKernel(LaneKernelCheck),
}

/// How many scenarios [`build`] knows.
pub const COUNT: usize =
    2 + MillingVariant::ALL.len() + faults::CASES.len() + TURNING_VARIANTS.len() + 3;

const TURNING_VARIANTS: [TurningVariant; 3] =
    [TurningVariant::Encoder, TurningVariant::Resolver, TurningVariant::IndexLoss];

/// Scenario `index` (0..[`COUNT`]), freshly built; `None` past the end.
pub fn build(index: usize) -> Option<AnyScenario> {
    match index {
        0 => override_sweep::OverrideSweep::new().map(AnyScenario::OverrideSweep),
        1 => SizeScale::new(3, 2)
            .map(|scale| AnyScenario::PolarPlayback(PolarPlayback::new(Rate::lit("2"), scale))),
        _ => build_group(index - 2),
    }
}

/// The scenarios after the first two, group by group.
fn build_group(mut i: usize) -> Option<AnyScenario> {
    if let Some(&v) = MillingVariant::ALL.get(i) {
        return MillingScenario::new(v).ok().map(AnyScenario::Milling);
    }
    i -= MillingVariant::ALL.len();
    if let Some(&c) = faults::CASES.get(i) {
        return faults::FaultScenario::new(c).map(AnyScenario::Fault);
    }
    i -= faults::CASES.len();
    if let Some(&v) = TURNING_VARIANTS.get(i) {
        return Some(AnyScenario::Turning(TurningScenario::new(v)));
    }
    i -= TURNING_VARIANTS.len();
    match i {
        0 => WireJobScenario::new().ok().map(AnyScenario::WireJob),
        1 => WireStallScenario::new().ok().map(AnyScenario::WireStall),
        2 => Some(AnyScenario::LaneKernel(LaneKernelCheck::new())),
        _ => None,
    }
}

macro_rules! dispatch {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            AnyScenario::OverrideSweep($s) => $e,
            AnyScenario::PolarPlayback($s) => $e,
            AnyScenario::Milling($s) => $e,
            AnyScenario::Fault($s) => $e,
            AnyScenario::Turning($s) => $e,
            AnyScenario::WireJob($s) => $e,
            AnyScenario::WireStall($s) => $e,
            AnyScenario::LaneKernel($s) => $e,
        }
    };
}

impl Scenario for AnyScenario {
    fn name(&self) -> &'static str {
        dispatch!(self, s => s.name())
    }

    fn tick_hz(&self) -> u32 {
        dispatch!(self, s => s.tick_hz())
    }

    #[inline]
    fn tick(&mut self) -> bool {
        dispatch!(self, s => s.tick())
    }

    fn report(&self) -> ScenarioReport {
        dispatch!(self, s => s.report())
    }

    #[inline]
    fn wants_background(&self) -> bool {
        dispatch!(self, s => s.wants_background())
    }

    fn background(&mut self) {
        dispatch!(self, s => s.background())
    }
}

/// Longest any scenario may run on the host before it is cut off (ticks).
pub const HOST_MAX_TICKS: u64 = 1 << 32;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{run_to_end, MAX_FIGURES};

    #[test]
    fn every_scenario_builds_finishes_and_fits_its_report() {
        for i in 0..COUNT {
            let mut s = build(i).expect("builds");
            let r = run_to_end(&mut s, HOST_MAX_TICKS);
            assert!(!s.tick(), "{} keeps running after its end", r.name);
            assert!(r.figures.len() < MAX_FIGURES, "{}: figures may have been dropped", r.name);
            assert!(r
                .name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_'));
        }
        assert!(build(COUNT).is_none());
    }

    #[test]
    fn override_sweep_keeps_every_step() {
        let mut s = override_sweep::OverrideSweep::new().unwrap();
        let r = run_to_end(&mut s, HOST_MAX_TICKS);
        assert_eq!(r.fault, 0);
        let total = |axis: usize| -> i64 {
            override_sweep_moves().iter().map(|m| m.steps[axis] as i64).sum()
        };
        for axis in 0..2 {
            assert_eq!(r.figure(["pos0_steps", "pos1_steps"][axis]), Some(total(axis)));
            assert_eq!(r.figure(["net0_steps", "net1_steps"][axis]), Some(total(axis)));
        }
        assert_eq!(r.figure("segments").map(|n| n > 0), Some(true));
    }

    fn override_sweep_moves() -> &'static [crate::planner::Move] {
        &override_sweep::MOVES
    }
}
