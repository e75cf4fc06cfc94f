//! Force sensor chain, per ADC sample: counts -> millinewtons per channel, tare while cutting air,
//! anti-alias biquad, decimation; per decimated sample: exact resultant magnitude and tooth peak
//! hold; saturation and stuck-channel detection.

use super::biquad::{Biquad, BiquadCoeffs};
use super::peak::{PeakHold, ToothClock};
use crate::fixed_math::isqrt_u64;
use crate::protocol::errors::FaultCode;

/// Force channels the chain can carry (Fx, Fy, Fz).
pub const MAX_CHANNELS: usize = 3;
/// ADC samples per control update: the biquads' fs/20 cutoff is matched to this.
pub const DECIMATION: u32 = 5;

/// One channel's calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelCal {
    /// ADC reading at zero force (a first guess; tare tracks it while cutting air).
    pub zero_counts: u16,
    /// Millinewtons per count, Q16 (signed: a reversed sensor has a negative gain).
    pub mn_per_count_q16: i32,
}

/// Setup of the chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainConfig {
    /// Channels in use, 2 or 3.
    pub channels: u8,
    pub cal: [ChannelCal; MAX_CHANNELS],
    /// Highest ADC count (4095 for 12 bits); 0 and this are the rails.
    pub adc_max_counts: u16,
    /// Samples within this many counts of a rail count as saturated.
    pub rail_margin_counts: u16,
    /// Consecutive samples on a rail before `ForceSaturated`.
    pub saturated_samples: u16,
    /// Consecutive identical samples while cutting before `ForceStuck`.
    pub stuck_samples: u16,
    /// Tare time constant as a shift: the zero moves 1/2^k of the way per air sample.
    pub tare_shift: u8,
    pub coeffs: BiquadCoeffs,
    /// Cutter flutes and control rate for the peak-hold window.
    pub teeth: u32,
    pub control_hz: u32,
    /// Spindle speed for the first peak-hold window, milli-revolutions per second.
    pub nominal_spindle_mrev_s: u32,
}

/// Why a chain configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainConfigError {
    Channels,
    Teeth,
    ControlRate,
    TareShift,
}

/// One decimated force reading.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ForceReading {
    /// Filtered per-channel force, mN.
    pub channel_mn: [i32; MAX_CHANNELS],
    /// Resultant magnitude, mN (exact integer square root).
    pub magnitude_mn: u32,
    /// Peak of the magnitude over the last tooth period, mN.
    pub peak_mn: u32,
    /// The last whole tooth period, in control updates.
    pub tooth_updates: u32,
}

/// What one ADC sample produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainOutput {
    /// Sample absorbed; no control update due.
    Pending,
    /// A decimated reading: run the control law now.
    Reading(ForceReading),
    /// A channel failed; the reading cannot be trusted.
    Fault(FaultCode),
}

/// The chain's state.
#[derive(Clone, Debug)]
pub struct ForceChain {
    cfg: ChainConfig,
    /// Tracked zero per channel, counts Q8.
    zero_q8: [i32; MAX_CHANNELS],
    filt: [Biquad; MAX_CHANNELS],
    last_counts: [u16; MAX_CHANNELS],
    same_run: [u16; MAX_CHANNELS],
    rail_run: [u16; MAX_CHANNELS],
    phase: u32,
    clock: ToothClock,
    peak: PeakHold,
}

impl ForceChain {
    /// Checks the setup (setup-time divisions happen here).
    pub fn new(cfg: ChainConfig) -> Result<Self, ChainConfigError> {
        if !(2..=MAX_CHANNELS as u8).contains(&cfg.channels) {
            return Err(ChainConfigError::Channels);
        }
        if cfg.teeth == 0 || cfg.teeth > 64 {
            return Err(ChainConfigError::Teeth);
        }
        if cfg.control_hz == 0 || cfg.control_hz > 100_000 {
            return Err(ChainConfigError::ControlRate);
        }
        if cfg.tare_shift == 0 || cfg.tare_shift > 16 {
            return Err(ChainConfigError::TareShift);
        }
        let zero_q8 = [0, 1, 2].map(|i| (cfg.cal[i].zero_counts as i32) << 8);
        Ok(ForceChain {
            cfg,
            zero_q8,
            filt: [Biquad::settled(0); MAX_CHANNELS],
            last_counts: [0; MAX_CHANNELS],
            same_run: [0; MAX_CHANNELS],
            rail_run: [0; MAX_CHANNELS],
            phase: 0,
            clock: ToothClock::new(cfg.teeth, cfg.control_hz, cfg.nominal_spindle_mrev_s),
            peak: PeakHold::default(),
        })
    }

    /// One ADC sample of every channel (unused channels ignored). `cutting_air`: the control law
    /// says the tool is in air, so the reading is zero force and the zero may be tracked; while
    /// cutting, an unchanging channel is stuck. `spindle_mrev_s` drives the peak-hold window.
    /// Call at `DECIMATION * control_hz`.
    pub fn sample(
        &mut self,
        counts: &[u16; MAX_CHANNELS],
        spindle_mrev_s: u32,
        cutting_air: bool,
    ) -> ChainOutput {
        let n = self.cfg.channels as usize;
        let hi = self.cfg.adc_max_counts.saturating_sub(self.cfg.rail_margin_counts);
        let lo = self.cfg.rail_margin_counts;
        let mut mn = [0i32; MAX_CHANNELS];
        let mut fault = None;
        for i in 0..MAX_CHANNELS {
            if i >= n {
                break;
            }
            let c = counts[i];
            // Saturation: the reading is only a lower bound of the force.
            let railed = c >= hi || c <= lo;
            self.rail_run[i] = if railed { self.rail_run[i].saturating_add(1) } else { 0 };
            if self.rail_run[i] >= self.cfg.saturated_samples {
                fault = Some(FaultCode::ForceSaturated);
            }
            // Stuck: real sensors always show some noise while the tool cuts.
            let same = c == self.last_counts[i] && !cutting_air;
            self.same_run[i] = if same { self.same_run[i].saturating_add(1) } else { 0 };
            if self.same_run[i] >= self.cfg.stuck_samples && fault.is_none() {
                fault = Some(FaultCode::ForceStuck);
            }
            self.last_counts[i] = c;
            let c_q8 = (c as i32) << 8;
            if cutting_air {
                // Rounded, so the tracked zero has no downward bias from flooring.
                let half = 1 << (self.cfg.tare_shift - 1);
                self.zero_q8[i] += (c_q8 - self.zero_q8[i] + half) >> self.cfg.tare_shift;
            }
            // counts Q8 * mN/count Q16 -> mN: >> 24, rounded.
            let net_q8 = (c_q8 - self.zero_q8[i]) as i64;
            let f = (net_q8 * self.cfg.cal[i].mn_per_count_q16 as i64 + (1 << 23)) >> 24;
            let f = f.clamp(-(1 << 28), 1 << 28) as i32;
            mn[i] = self.filt[i].step(&self.cfg.coeffs, f);
        }
        if let Some(code) = fault {
            return ChainOutput::Fault(code);
        }
        self.phase += 1;
        if self.phase < DECIMATION {
            return ChainOutput::Pending;
        }
        self.phase = 0;
        let mut sq: u64 = 0;
        for &v in mn.iter().take(n) {
            sq += (v as i64 * v as i64) as u64;
        }
        let magnitude_mn = isqrt_u64(sq);
        let phases = self.clock.advance(spindle_mrev_s);
        let peak_mn = self.peak.update(phases, magnitude_mn);
        ChainOutput::Reading(ForceReading {
            channel_mn: mn,
            magnitude_mn,
            peak_mn,
            tooth_updates: self.clock.tooth_updates(),
        })
    }

    /// The tracked zero of channel `i`, counts Q8.
    pub fn zero_q8(&self, i: usize) -> Option<i32> {
        self.zero_q8.get(i).copied()
    }

    pub fn config(&self) -> &ChainConfig {
        &self.cfg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Case A chain with a round 10 N per count.
    pub(crate) fn cfg() -> ChainConfig {
        let cal = ChannelCal { zero_counts: 2048, mn_per_count_q16: 10_000 << 16 };
        ChainConfig { cal: [cal; MAX_CHANNELS], ..crate::milling::scenario::chain_config() }
    }

    fn run(
        ch: &mut ForceChain,
        counts: [u16; 3],
        samples: usize,
        air: bool,
    ) -> Option<ForceReading> {
        let mut last = None;
        for k in 0..samples {
            // +/-1 count of noise so the channels are alive.
            let d = (k & 1) as u16;
            match ch.sample(&counts.map(|c| c + d), 8333, air) {
                ChainOutput::Reading(r) => last = Some(r),
                ChainOutput::Pending => {}
                ChainOutput::Fault(f) => panic!("{f:?}"),
            }
        }
        last
    }

    #[test]
    fn tare_learns_the_offset_in_air_and_magnitude_is_exact() {
        let mut ch = ForceChain::new(cfg()).unwrap();
        // True zeros differ from the calibration's guess by 37, -12 and 5 counts.
        let zero = [2085u16, 2036, 2053];
        run(&mut ch, zero, 2000, true);
        for (i, z) in zero.iter().enumerate() {
            // Noise alternates 0/1: the mean is half a count up.
            let err = ch.zero_q8(i).unwrap() - ((*z as i32) << 8) - 128;
            assert!(err.abs() <= 40, "channel {i}: {err}");
        }
        // 3-4-12 triangle scaled: 300, 400, 1200 counts -> 13 * 100 counts = 13 000 N.
        let r = run(&mut ch, [zero[0] + 300, zero[1] + 400, zero[2] + 1200], 500, false).unwrap();
        assert!((r.magnitude_mn as i64 - 13_000_000).abs() < 10_000, "{r:?}");
        assert!(r.peak_mn >= r.magnitude_mn);
        assert_eq!(r.tooth_updates, 60);
    }

    #[test]
    fn saturation_and_stuck_channels_fault() {
        let mut ch = ForceChain::new(cfg()).unwrap();
        let mut got = None;
        for _ in 0..10 {
            if let ChainOutput::Fault(f) = ch.sample(&[2048, 4095, 2048], 8333, false) {
                got = Some(f);
                break;
            }
        }
        assert_eq!(got, Some(FaultCode::ForceSaturated));
        let mut ch = ForceChain::new(cfg()).unwrap();
        let mut at = None;
        for k in 0..1000u16 {
            if let ChainOutput::Fault(f) =
                ch.sample(&[2100, 2100 + (k & 1), 2048 + (k & 3)], 8333, false)
            {
                at = Some((k, f));
                break;
            }
        }
        assert_eq!(at, Some((200, FaultCode::ForceStuck)));
        // In air a constant channel is fine (no force, maybe no noise).
        let mut ch = ForceChain::new(cfg()).unwrap();
        for _ in 0..1000 {
            assert!(!matches!(ch.sample(&[2100; 3], 8333, true), ChainOutput::Fault(_)));
        }
    }

    #[test]
    fn bad_configs_are_refused() {
        let mut c = cfg();
        c.channels = 1;
        assert_eq!(ForceChain::new(c).unwrap_err(), ChainConfigError::Channels);
        let mut c = cfg();
        c.teeth = 0;
        assert_eq!(ForceChain::new(c).unwrap_err(), ChainConfigError::Teeth);
    }
}
