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

use crate::dda::{Command, Dda, StepOutput};
use crate::machine::{Inputs, Machine, MachineState, TickOut};
use crate::protocol::{
    FaultCode, ForceJobParams, ForcePhase, ForceStrategy, SimForceFault, SimMillingParams, Status,
    MAX_OVERRIDE_BITS,
};
use crate::segment::Rate;

use super::biquad::BiquadCoeffs;
use super::chain::{ChainConfig, ChainOutput, ChannelCal, ForceChain, DECIMATION, MAX_CHANNELS};
use super::control::{ContactStrategy, ControlInput, ControlParams, ForceController, Mode};
use super::plant::{AdcFault, MillingPlant, PlantParams, SimAdc};

/// The simulated ADC's true zeros and force direction (those of the Case A scenario: zeros off
/// the calibration's mid-scale guess, force along (0.48, 0.64, 0.60)), so the board's chain has
/// a real tare to do.
pub const SIM_ZERO_COUNTS: [u16; 3] = [2085, 2036, 2053];

/// Milli-revolutions per second (the force job's spindle unit) from a spindle speed in turns
/// (Q32) per tick at `tick_hz` (the spindle sources' unit), rounded; the direction is dropped.
/// Multiply and shift only (u64, saturating): it runs at sample rate.
#[inline]
pub fn mrev_s_from_turn_q32_per_tick(speed_turn_q32_per_tick: i32, tick_hz: u32) -> u32 {
    let per_s_q32 = (speed_turn_q32_per_tick.unsigned_abs() as u64)
        .saturating_mul(tick_hz as u64 * MILLI_PER_UNIT);
    (per_s_q32.saturating_add(HALF_Q32) >> 32).min(u32::MAX as u64) as u32
}

const MILLI_PER_UNIT: u64 = 1000;
const HALF_Q32: u64 = 1 << 31;
pub const SIM_DIRECTION_Q16: [i32; 3] = [31_457, 41_943, 39_322];

/// The control law's setup from a job's parameters; `Err` names the offending field.
pub fn control_params(p: &ForceJobParams) -> Result<ControlParams, &'static str> {
    let rate = |bits: u32, field| {
        if bits <= MAX_OVERRIDE_BITS {
            Ok(Rate::from_bits(bits))
        } else {
            Err(field)
        }
    };
    let contact = match p.strategy {
        ForceStrategy::Direct => ContactStrategy::Direct,
        ForceStrategy::SlowHold { slow_bits, hold_ms } => ContactStrategy::SlowHold {
            slow: rate(slow_bits, "strategy.slow_bits")?,
            hold_ms: hold_ms as u32,
        },
        ForceStrategy::StopReduced { stop_ms, reduced_ms, reduced_gain_q16 } => {
            if reduced_gain_q16 == 0 || reduced_gain_q16 > 1 << 16 {
                return Err("strategy.reduced_gain_q16");
            }
            ContactStrategy::StopReduced {
                stop_ms: stop_ms as u32,
                reduced_ms: reduced_ms as u32,
                reduced_gain_q16,
            }
        }
    };
    // Gains beyond 100 (P) and 10 000/s (I) are typing errors, and keep the PI's products
    // inside i64.
    if p.kp_dec_q16 > 100 << 16 {
        return Err("kp_dec_q16");
    }
    if p.kp_inc_q16 > 100 << 16 {
        return Err("kp_inc_q16");
    }
    if p.ki_dec_per_s_q16 > 10_000 << 16 {
        return Err("ki_dec_per_s_q16");
    }
    if p.ki_inc_per_s_q16 > 10_000 << 16 {
        return Err("ki_inc_per_s_q16");
    }
    if p.fixed_scale_q16 > 64 << 16 {
        return Err("fixed_scale_q16");
    }
    Ok(ControlParams {
        fnom_mn: p.fnom_mn,
        contact_mn: p.contact_mn,
        trip_mn: p.trip_mn,
        air_after_ms: p.air_after_ms as u32,
        tare_ms: p.tare_ms as u32,
        control_hz: p.sample_hz / DECIMATION,
        steps_per_s_at_one: p.steps_per_s_at_one,
        kp_dec_q16: p.kp_dec_q16,
        kp_inc_q16: p.kp_inc_q16,
        ki_dec_per_s_q16: p.ki_dec_per_s_q16,
        ki_inc_per_s_q16: p.ki_inc_per_s_q16,
        normalise: p.normalise,
        fixed_scale_q16: p.fixed_scale_q16,
        feed_min: rate(p.feed_min_bits, "feed_min_bits")?,
        feed_max: rate(p.feed_max_bits, "feed_max_bits")?,
        feed_air: rate(p.feed_air_bits, "feed_air_bits")?,
        contact,
        min_spindle_mrev_s: p.min_spindle_mrev_s,
    })
}

/// The chain's setup from a job's parameters; `Err` names the offending field.
pub fn chain_config(p: &ForceJobParams) -> Result<ChainConfig, &'static str> {
    let mut cal = [ChannelCal { zero_counts: 0, mn_per_count_q16: 0 }; MAX_CHANNELS];
    for (c, w) in cal.iter_mut().zip(p.cal.iter()).take(p.channels as usize) {
        if w.mn_per_count_q16 == 0 {
            return Err("cal.mn_per_count_q16");
        }
        if w.zero_counts > p.adc_max_counts {
            return Err("cal.zero_counts");
        }
        *c = ChannelCal { zero_counts: w.zero_counts, mn_per_count_q16: w.mn_per_count_q16 };
    }
    // 2^16 counts at the largest gain must stay inside the chain's i64 products: any i32 gain
    // does; the ADC itself is at most 16 bits.
    if p.adc_max_counts < 255 {
        return Err("adc_max_counts");
    }
    if p.rail_margin_counts >= p.adc_max_counts / 2 {
        return Err("rail_margin_counts");
    }
    if p.saturated_samples == 0 {
        return Err("saturated_samples");
    }
    if p.stuck_samples == 0 {
        return Err("stuck_samples");
    }
    Ok(ChainConfig {
        channels: p.channels,
        cal,
        adc_max_counts: p.adc_max_counts,
        rail_margin_counts: p.rail_margin_counts,
        saturated_samples: p.saturated_samples,
        stuck_samples: p.stuck_samples,
        tare_shift: p.tare_shift,
        coeffs: BiquadCoeffs::BUTTERWORTH_FS_OVER_20,
        teeth: p.flutes as u32,
        control_hz: p.sample_hz / DECIMATION,
        nominal_spindle_mrev_s: p.spindle_mrev_s,
    })
}

/// Every check `ArmForce` makes before the board sees the job; `Err` names the field.
pub fn check_job(p: &ForceJobParams) -> Result<(), &'static str> {
    use super::chain::ChainConfigError as C;
    use super::control::ControlConfigError as K;
    if p.axis as usize >= crate::config::MAX_AXES {
        return Err("axis");
    }
    if p.sample_hz == 0 || !p.sample_hz.is_multiple_of(DECIMATION) {
        return Err("sample_hz");
    }
    if p.spindle_mrev_s == 0 {
        return Err("spindle_mrev_s");
    }
    let ctl = control_params(p)?;
    let chain = chain_config(p)?;
    ForceChain::new(chain).map_err(|e| match e {
        C::Channels => "channels",
        C::Teeth => "flutes",
        C::ControlRate => "sample_hz",
        C::TareShift => "tare_shift",
    })?;
    // The controller is large (its position ring): checked without keeping it.
    ForceController::check(&ctl).map_err(|e| match e {
        K::Thresholds => "contact_mn",
        K::Rate => "sample_hz",
        K::Feeds => "feed_min_bits",
        K::Speed => "steps_per_s_at_one",
    })?;
    // The peak-hold window (one tooth period) must fit the chain's tooth clock.
    let tooth_updates =
        (ctl.control_hz as u64 * 1000) / (p.flutes as u64 * p.spindle_mrev_s as u64).max(1);
    if tooth_updates == 0 || tooth_updates > super::peak::MAX_TOOTH_UPDATES as u64 {
        return Err("spindle_mrev_s");
    }
    Ok(())
}

/// The checks `Sim(Milling)` makes on its own; `Err` names the field. (The tooth delay, which
/// also depends on the job's sample rate and flutes, is checked when both are known.)
pub fn check_sim(s: &SimMillingParams) -> Result<(), &'static str> {
    if s.nm_per_step == 0 {
        return Err("nm_per_step");
    }
    if s.spindle_mrev_s == 0 {
        return Err("spindle_mrev_s");
    }
    // Kc b per step of chip must fit the plant's u64 Q16 product: any u32 Kc, depths up to 1 m.
    for (v, f) in [(s.b_before_um, "b_before_um"), (s.b_after_um, "b_after_um")] {
        if v > 1_000_000 {
            return Err(f);
        }
    }
    if s.nm_per_step > 1_000_000 {
        return Err("nm_per_step");
    }
    if s.wall_steps.unsigned_abs() > 1 << 40 {
        return Err("wall_steps");
    }
    match s.fault {
        SimForceFault::Saturated { channel } | SimForceFault::Stuck { channel }
            if channel as usize >= MAX_CHANNELS =>
        {
            Err("fault.channel")
        }
        _ => Ok(()),
    }
}

/// The plant of a simulator board for `job` (its sample rate and flutes).
pub fn plant_params(s: &SimMillingParams, job: &ForceJobParams) -> PlantParams {
    PlantParams {
        kc_mn_per_mm2: s.kc_mn_per_mm2,
        b_before_um: s.b_before_um,
        b_after_um: s.b_after_um,
        step_at_um: s.step_at_um,
        wall_steps: s.wall_steps,
        nm_per_step: s.nm_per_step,
        sample_hz: job.sample_hz,
        teeth: job.flutes as u32,
        spindle_mrev_s: s.spindle_mrev_s,
        periodic: s.periodic,
    }
}

/// The wire parameters of a control setup and chain (the inverse of [`control_params`] and
/// [`chain_config`]; saturating where a wire field is narrower). `sample_hz` = the chain's
/// control rate times `DECIMATION`.
pub fn job_params(ctl: &ControlParams, chain: &ChainConfig, axis: u8) -> ForceJobParams {
    let ms = |v: u32| v.min(u16::MAX as u32) as u16;
    let strategy = match ctl.contact {
        ContactStrategy::Direct => ForceStrategy::Direct,
        ContactStrategy::SlowHold { slow, hold_ms } => {
            ForceStrategy::SlowHold { slow_bits: slow.to_bits(), hold_ms: ms(hold_ms) }
        }
        ContactStrategy::StopReduced { stop_ms, reduced_ms, reduced_gain_q16 } => {
            ForceStrategy::StopReduced {
                stop_ms: ms(stop_ms),
                reduced_ms: ms(reduced_ms),
                reduced_gain_q16,
            }
        }
    };
    let cal = chain.cal.map(|c| crate::protocol::ForceCal {
        zero_counts: c.zero_counts,
        mn_per_count_q16: c.mn_per_count_q16,
    });
    ForceJobParams {
        fnom_mn: ctl.fnom_mn,
        contact_mn: ctl.contact_mn,
        trip_mn: ctl.trip_mn,
        kp_dec_q16: ctl.kp_dec_q16,
        kp_inc_q16: ctl.kp_inc_q16,
        ki_dec_per_s_q16: ctl.ki_dec_per_s_q16,
        ki_inc_per_s_q16: ctl.ki_inc_per_s_q16,
        normalise: ctl.normalise,
        fixed_scale_q16: ctl.fixed_scale_q16,
        feed_min_bits: ctl.feed_min.to_bits(),
        feed_max_bits: ctl.feed_max.to_bits(),
        feed_air_bits: ctl.feed_air.to_bits(),
        strategy,
        air_after_ms: ms(ctl.air_after_ms),
        tare_ms: ms(ctl.tare_ms),
        flutes: chain.teeth.min(u8::MAX as u32) as u8,
        spindle_mrev_s: chain.nominal_spindle_mrev_s,
        min_spindle_mrev_s: ctl.min_spindle_mrev_s,
        axis,
        steps_per_s_at_one: ctl.steps_per_s_at_one,
        sample_hz: ctl.control_hz.saturating_mul(DECIMATION),
        channels: chain.channels,
        cal,
        adc_max_counts: chain.adc_max_counts,
        rail_margin_counts: chain.rail_margin_counts,
        saturated_samples: chain.saturated_samples,
        stuck_samples: chain.stuck_samples,
        tare_shift: chain.tare_shift,
    }
}

/// The wire parameters of a simulated plant (the inverse of [`plant_params`]).
pub fn sim_params(plant: &PlantParams, fault: SimForceFault, fault_at_um: u32) -> SimMillingParams {
    SimMillingParams {
        kc_mn_per_mm2: plant.kc_mn_per_mm2,
        b_before_um: plant.b_before_um,
        b_after_um: plant.b_after_um,
        step_at_um: plant.step_at_um,
        wall_steps: plant.wall_steps,
        nm_per_step: plant.nm_per_step,
        spindle_mrev_s: plant.spindle_mrev_s,
        periodic: plant.periodic,
        fault,
        fault_at_um,
    }
}

/// The Case A job of `super::scenario` (trip 18 kN) as `ArmForce` parameters.
pub fn case_a_job() -> ForceJobParams {
    let s = super::scenario::control_params(18_000_000);
    job_params(&s, &super::scenario::chain_config(), 0)
}

/// The Case A plant of `super::scenario` as `Sim(Milling)` parameters, with `fault` injected
/// 5 mm into the cut (the scenario's fault variants' point).
pub fn case_a_sim(fault: SimForceFault) -> SimMillingParams {
    sim_params(&super::scenario::plant_params(), fault, 5_000)
}

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

/// One link-firmware tick with a force job on a tick-sampled (simulator) board: the machine's
/// tick with the job's latched force faults among the sensor inputs, then the job's sample at
/// the feed axis's new position, whose override goes to the DDA the way `SetOverride` does
/// (the machine's holds and fault freeze stay in charge: a held or frozen DDA does not move
/// whatever the override). A force fault reaches the machine on the next tick (one tick of
/// latency). The job runs while the machine runs or holds the job, and ends with it.
/// Division-free, bounded: the machine's tick plus [`ForceJob::sample_sim`].
#[inline]
pub fn link_tick(
    machine: &mut Machine,
    dda: &mut Dda,
    inputs: &Inputs,
    job: &mut ForceJob,
) -> TickOut {
    let (out, due) = link_tick_deferred(machine, dda, inputs, job);
    if due {
        link_sample(machine, dda, job);
    }
    out
}

/// [`link_tick`] without the plant sample: the machine's tick and the sample countdown; true
/// when a sample is due, for [`link_sample`] to take right after this tick and before the next
/// (the simulator board's stand-in for the real board's ADC interrupt, so the tick interrupt
/// stays short and the sample sees the same positions as in [`link_tick`]).
#[inline]
pub fn link_tick_deferred(
    machine: &mut Machine,
    dda: &mut Dda,
    inputs: &Inputs,
    job: &mut ForceJob,
) -> (TickOut, bool) {
    let mut inp = *inputs;
    if job.is_running() {
        inp.sensor_faults |= job.fault_bits;
    }
    let out = machine.tick(dda, &inp);
    let mut due = false;
    if job.is_running() {
        if matches!(machine.state(), MachineState::Running | MachineState::Holding) {
            due = job.sample_due();
        } else {
            job.end();
        }
    }
    (out, due)
}

/// A step-only tick of a force job ([`Machine::fast_tick`]), if the machine grants one: the
/// DDA, the counters, the soft limits and the sample countdown (true: a sample is due, as from
/// [`link_tick_deferred`]). `None`: run [`link_tick_deferred`]. The machine grants none while
/// the job has a force fault latched (its bits are sensor inputs of the full tick), so a fault
/// found by a sample reaches the machine on the next full tick, at most
/// `SUPERVISE_TICKS - 1` ticks later; the job's end is seen there too.
#[inline(always)]
pub fn link_step_only_deferred(
    machine: &mut Machine,
    dda: &mut Dda,
    job: &mut ForceJob,
) -> Option<(StepOutput, bool)> {
    if !job.is_running() {
        return None;
    }
    let step = machine.fast_tick(dda)?;
    // A soft limit crossed on this tick faulted the machine: the next full tick ends the job.
    let due = matches!(machine.state(), MachineState::Running | MachineState::Holding)
        && job.sample_due();
    Some((step, due))
}

/// The plant sample [`link_tick_deferred`] said is due: the chain, the control law at its rate,
/// the override into the DDA.
pub fn link_sample(machine: &Machine, dda: &mut Dda, job: &mut ForceJob) {
    let pos = machine.positions().get(job.axis).copied().unwrap_or(0);
    let t = job.sample_sim(pos);
    if let Some(rate) = t.set_override {
        dda.apply(Command::CapabilityOverride(rate));
    }
}

/// The status phase of a controller mode.
pub fn phase_of(m: Mode) -> ForcePhase {
    match m {
        Mode::Tare(_) => ForcePhase::Tare,
        Mode::Air => ForcePhase::Air,
        Mode::ContactSlow(_) => ForcePhase::ContactSlow,
        Mode::ContactStop(_) => ForcePhase::ContactStop,
        Mode::Reduced(_) => ForcePhase::Reduced,
        Mode::Cutting => ForcePhase::Cutting,
        Mode::Faulted(_) => ForcePhase::Faulted,
    }
}

impl SimMillingParams {
    /// No cut: the plant never meets the work (zero force).
    pub const AIR: SimMillingParams = SimMillingParams {
        kc_mn_per_mm2: 0,
        b_before_um: 0,
        b_after_um: 0,
        step_at_um: 0,
        wall_steps: 1 << 40,
        nm_per_step: 1000,
        spindle_mrev_s: 8_333,
        periodic: false,
        fault: SimForceFault::None,
        fault_at_um: 0,
    };
}

#[cfg(test)]
#[path = "link_job_tests.rs"]
mod tests;
