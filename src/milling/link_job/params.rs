//! A force job's link parameters and the setups they stand for: the control law's, the chain's
//! and the simulated plant's, both ways, with every check `ArmForce` and `Sim(Milling)` make.

use crate::milling::link_params::ForceJobParams;
use crate::milling::link_params::ForceStrategy;
use crate::protocol::{SimForceFault, SimMillingParams, MAX_OVERRIDE_BITS};
use crate::segment::Rate;

use crate::milling::biquad::BiquadCoeffs;
use crate::milling::chain::{ChainConfig, ChannelCal, ForceChain, DECIMATION, MAX_CHANNELS};
use crate::milling::control::{ContactStrategy, ControlParams, ForceController};
use crate::milling::plant::PlantParams;

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
    use crate::milling::chain::ChainConfigError as C;
    use crate::milling::control::ControlConfigError as K;
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
    if tooth_updates == 0 || tooth_updates > crate::milling::peak::MAX_TOOTH_UPDATES as u64 {
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

/// The link parameters of a control setup and chain (the inverse of [`control_params`] and
/// [`chain_config`]; saturating where a link field is narrower). `sample_hz` = the chain's
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
    let cal = chain.cal.map(|c| crate::milling::link_params::ForceCal {
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

/// The link parameters of a simulated plant (the inverse of [`plant_params`]).
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

/// The Case A job of `crate::milling::scenario` (trip 18 kN) as `ArmForce` parameters.
pub fn case_a_job() -> ForceJobParams {
    let s = crate::milling::scenario::control_params(18_000_000);
    job_params(&s, &crate::milling::scenario::chain_config(), 0)
}

/// The Case A plant of `crate::milling::scenario` as `Sim(Milling)` parameters, with `fault` injected
/// 5 mm into the cut (the scenario's fault variants' point).
pub fn case_a_sim(fault: SimForceFault) -> SimMillingParams {
    sim_params(&crate::milling::scenario::plant_params(), fault, 5_000)
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
