//! A force job on the link firmware (`ArmForce`): the force chain and the control law
//! around one segment job, fed per ADC sample, with the simulated milling plant of a simulator
//! board (`Sim(Milling)`) as the sample source where the board has no real ADC.
//!
//! On a simulator board the DDA tick counts down to each plant sample ([`ForceJob::sample_due`],
//! every `ticks_per_sample` ticks) and the sample itself ([`ForceJob::sample_sim`], from the feed
//! axis's position) runs in the interrupt the tick pends, right after it, as the real board's
//! force ADC DMA interrupt calls [`ForceJob::sample`]. Either returns a
//! [`ForceTick`]: the override for the DDA (the path `SetOverride` takes) and the force fault
//! bits for `Inputs::sensor_faults`, so the machine's one fault model holds the feed.
//!
//! Setup ([`check_job`], [`check_sim`], [`ForceJob::new`]) divides; the per-sample and per-tick
//! paths are integer-only, division-free and bounded (one plant sample, one ADC conversion, one
//! chain sample of three channels, and every `DECIMATION`th sample one control update).
//!
//! Parts: `params` (the link parameters and the setups they stand for, with their checks) and
//! `ticks` (the firmware's tick and sample entry points); the job itself is here.

mod params;
mod ticks;

pub use params::{
    case_a_job, case_a_sim, chain_config, check_job, check_sim, control_params, job_params,
    plant_params, sim_params,
};
pub use ticks::{
    link_sample, link_step_only_deferred, link_tick, link_tick_deferred,
    mrev_s_from_turn_q32_per_tick, phase_of,
};

use crate::milling::link_params::ForceJobParams;
use crate::milling::link_params::ForcePhase;
use crate::protocol::{FaultCode, SimForceFault, SimMillingParams, Status};
use crate::segment::Rate;

use super::chain::{ChainOutput, ForceChain, MAX_CHANNELS};
use super::control::{ControlInput, ForceController};
use super::plant::{AdcFault, MillingPlant, SimAdc};

/// The simulated ADC's true zeros and force direction (those of the Case A scenario: zeros off
/// the calibration's mid-scale guess, force along (0.48, 0.64, 0.60)), so the board's chain has
/// a real tare to do.
pub const SIM_ZERO_COUNTS: [u16; 3] = [2085, 2036, 2053];
pub const SIM_DIRECTION_Q16: [i32; 3] = [31_457, 41_943, 39_322];

/// Why a force job could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JobError {
    /// The offending parameter.
    pub field: &'static str,
}

/// A simulator board's sample source: the plant, its ADC and the fault to inject.
#[derive(Clone, Debug)]
struct SimSource {
    plant: MillingPlant,
    adc: SimAdc,
    fault: SimForceFault,
    /// Feed-axis position (relative to the job's start) where `fault` starts.
    fault_at_steps: i64,
    spindle_mrev_s: u32,
    /// `fault` is in (injected once, at `fault_at_steps`).
    injected: bool,
}

/// What one tick or sample asks of the DDA and the machine.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ForceTick {
    /// A changed feed override for the DDA (`Command::SetOverride`).
    pub set_override: Option<Rate>,
    /// Force fault bits for `Inputs::sensor_faults` (the machine latches and holds).
    pub fault_bits: u32,
}

/// What the status reports of a force job.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ForceTelemetry {
    pub force_mn: u32,
    pub peak_mn: u32,
    pub override_bits: u32,
    pub phase: ForcePhase,
    pub updates: u32,
}

impl ForceTelemetry {
    /// The force fields of `Status` (the board's and the host simulator's alike).
    pub fn write_status(&self, s: &mut Status) {
        s.force_mn = self.force_mn;
        s.force_peak_mn = self.peak_mn;
        s.force_override_bits = self.override_bits;
        s.force_phase = self.phase as u8;
        s.force_updates = self.updates;
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Armed,
    Running,
    Ended,
}

/// See the module docs.
#[derive(Clone, Debug)]
pub struct ForceJob {
    chain: ForceChain,
    ctl: ForceController,
    axis: usize,
    /// Ticks per ADC sample on a tick-sampled board (0: samples come from an ADC interrupt).
    ticks_per_sample: u32,
    countdown: u32,
    sim: Option<SimSource>,
    spindle_mrev_s: u32,
    air: bool,
    stage: Stage,
    origin_steps: i64,
    /// The last override handed to the DDA (`u32::MAX`: none yet).
    ovr_bits: u32,
    fault_bits: u32,
    t: ForceTelemetry,
}

impl ForceJob {
    /// A job from checked parameters. `ticks_per_sample`: DDA ticks per ADC sample when the tick
    /// samples (`tick_hz / sample_hz`, which must divide exactly), 0 when an ADC interrupt
    /// does. `sim`: the simulated plant (a simulator board; `None` there reads zero force).
    pub fn new(
        p: &ForceJobParams,
        tick_hz: u32,
        tick_sampled: bool,
        sim: Option<&SimMillingParams>,
    ) -> Result<Self, JobError> {
        let field = |field| JobError { field };
        check_job(p).map_err(field)?;
        let ticks_per_sample = if tick_sampled {
            if p.sample_hz > tick_hz || !tick_hz.is_multiple_of(p.sample_hz) {
                return Err(field("sample_hz"));
            }
            tick_hz / p.sample_hz
        } else {
            0
        };
        let chain =
            ForceChain::new(chain_config(p).map_err(field)?).map_err(|_| field("channels"))?;
        let ctl = ForceController::new(control_params(p).map_err(field)?)
            .map_err(|_| field("contact_mn"))?;
        let sim = match (tick_sampled, sim) {
            (false, _) => None,
            (true, s) => {
                let s = s.copied().unwrap_or(SimMillingParams::AIR);
                check_sim(&s).map_err(field)?;
                let plant =
                    MillingPlant::new(plant_params(&s, p)).map_err(|_| field("spindle_mrev_s"))?;
                // The ADC converts with the first channel's calibration gain (mN per count).
                let mn_per_count = (p.cal[0].mn_per_count_q16.unsigned_abs() >> 16).max(1);
                let fault_at_steps =
                    s.wall_steps + ((s.fault_at_um as i64 * 1000) / s.nm_per_step.max(1) as i64);
                Some(SimSource {
                    plant,
                    adc: SimAdc::new(SIM_ZERO_COUNTS, SIM_DIRECTION_Q16, mn_per_count),
                    fault: s.fault,
                    fault_at_steps,
                    spindle_mrev_s: s.spindle_mrev_s,
                    injected: false,
                })
            }
        };
        Ok(ForceJob {
            chain,
            ctl,
            axis: p.axis as usize,
            ticks_per_sample,
            countdown: ticks_per_sample,
            sim,
            spindle_mrev_s: p.spindle_mrev_s,
            air: true,
            stage: Stage::Armed,
            origin_steps: 0,
            ovr_bits: u32::MAX,
            fault_bits: 0,
            t: ForceTelemetry { phase: ForcePhase::Armed, ..ForceTelemetry::default() },
        })
    }

    /// Armed and not yet started.
    pub fn is_armed(&self) -> bool {
        self.stage == Stage::Armed
    }

    /// Started and not yet ended: the loop runs.
    pub fn is_running(&self) -> bool {
        self.stage == Stage::Running
    }

    /// Armed or running: the next (or current) segment job is this force job's.
    pub fn is_live(&self) -> bool {
        self.stage != Stage::Ended
    }

    /// The feed axis.
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// `Start`: the loop runs from the next tick; positions count from `position_steps` (the
    /// feed axis's position now: the sim plant's wall is relative to it).
    pub fn start(&mut self, position_steps: i64) {
        if self.stage == Stage::Armed {
            self.stage = Stage::Running;
            self.origin_steps = position_steps;
            self.t.phase = phase_of(self.ctl.mode());
        }
    }

    /// The job is over (its segments ran out, a fault stopped it, or the host dropped it).
    pub fn end(&mut self) {
        self.stage = Stage::Ended;
        if self.t.phase != ForcePhase::Faulted {
            self.t.phase = ForcePhase::Ended;
        }
    }

    /// A sample-source fault (the real board's DMA or ADC overrun): latched like a chain fault,
    /// the machine holds on the next tick.
    pub fn source_fault(&mut self, code: FaultCode) {
        if self.stage == Stage::Running {
            self.fault_bits |= code.bit();
            self.t.phase = ForcePhase::Faulted;
        }
    }

    pub fn telemetry(&self) -> ForceTelemetry {
        self.t
    }

    /// A tick-sampled (simulator) board's sample countdown, every DDA tick: true on the ticks
    /// whose plant sample ([`Self::sample_sim`]) is due. A few instructions.
    #[inline]
    pub fn sample_due(&mut self) -> bool {
        if self.stage != Stage::Running || self.ticks_per_sample == 0 {
            return false;
        }
        self.countdown -= 1;
        if self.countdown != 0 {
            return false;
        }
        self.countdown = self.ticks_per_sample;
        true
    }

    /// A tick-sampled board's sample: the plant at the feed axis's position (after the
    /// machine's tick moved the axes) through the simulated ADC into [`Self::sample`].
    /// Division-free, bounded.
    pub fn sample_sim(&mut self, position_steps: i64) -> ForceTick {
        if self.stage != Stage::Running {
            return ForceTick { set_override: None, fault_bits: self.fault_bits };
        }
        let x = position_steps - self.origin_steps;
        let counts = match self.sim.as_mut() {
            Some(s) => {
                if !s.injected && x >= s.fault_at_steps {
                    s.injected = true;
                    match s.fault {
                        SimForceFault::None => {}
                        SimForceFault::Saturated { channel } => {
                            s.adc.fault = AdcFault::Saturated(channel)
                        }
                        SimForceFault::Stuck { channel } => s.adc.fault = AdcFault::Stuck(channel),
                        SimForceFault::SpindleStop => s.spindle_mrev_s = 0,
                    }
                }
                self.spindle_mrev_s = s.spindle_mrev_s;
                let force_mn = s.plant.sample(x);
                s.adc.convert(force_mn)
            }
            None => [0; 3],
        };
        self.sample(&counts, position_steps)
    }

    /// The spindle speed the board measures (the real board's spindle encoder), for the chain's
    /// tooth period and the controller's spindle-stopped hold; a simulated plant sets its own in
    /// [`Self::sample_sim`].
    #[inline]
    pub fn set_spindle_mrev_s(&mut self, mrev_s: u32) {
        self.spindle_mrev_s = mrev_s;
    }

    /// One ADC sample of every channel (the real board's DMA interrupt, or [`Self::sample_sim`]):
    /// the chain, and at the decimated rate the control law. Division-free, bounded.
    #[inline]
    pub fn sample(&mut self, counts: &[u16; MAX_CHANNELS], position_steps: i64) -> ForceTick {
        if self.stage != Stage::Running {
            return ForceTick { set_override: None, fault_bits: self.fault_bits };
        }
        let (force_mn, peak_mn, tooth_updates, chain_fault) =
            match self.chain.sample(counts, self.spindle_mrev_s, self.air) {
                ChainOutput::Pending => {
                    return ForceTick { set_override: None, fault_bits: self.fault_bits }
                }
                ChainOutput::Reading(r) => (r.magnitude_mn, r.peak_mn, r.tooth_updates, None),
                ChainOutput::Fault(code) => (0, 0, 0, Some(code)),
            };
        let o = self.ctl.update(&ControlInput {
            force_mn,
            tooth_updates,
            position_steps: position_steps - self.origin_steps,
            spindle_mrev_s: self.spindle_mrev_s,
            chain_fault,
        });
        self.air = o.air;
        self.t.force_mn = force_mn;
        self.t.peak_mn = peak_mn;
        self.t.updates = self.t.updates.wrapping_add(1);
        self.t.phase = phase_of(self.ctl.mode());
        let mut set_override = None;
        if o.hold {
            // Latched: the machine raises the fault and holds the feed (Reaction::Hold).
            self.fault_bits |= o.fault.map_or(FaultCode::SensorFault.bit(), FaultCode::bit);
        } else if o.feed.to_bits() != self.ovr_bits {
            set_override = Some(o.feed);
        }
        self.ovr_bits = o.feed.to_bits();
        self.t.override_bits = self.ovr_bits;
        ForceTick { set_override, fault_bits: self.fault_bits }
    }
}

#[cfg(test)]
#[path = "link_job_tests.rs"]
mod tests;
