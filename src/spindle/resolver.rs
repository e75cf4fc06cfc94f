//! Resolver: sin/cos samples from two ADC channels (offset removed), an angle-tracking observer
//! (type II loop in fixed point) that gives angle and speed, and loss of signal from the
//! amplitude (`sin^2 + cos^2` outside a band for `loss_ticks` ticks latches
//! `FaultCode::ResolverLoss`).
//!
//! Observer: `e = sin(theta) cos(phi) - cos(theta) sin(phi) = A sin(theta - phi)`;
//! `phi += omega` (prediction to this sample), then `omega += Ki e`, `phi += Kp e`. With `wn T` the loop's natural frequency times the tick
//! period and damping 1, `Kp = 2 wn T`, `Ki = (wn T)^2` (both scaled by the nominal amplitude,
//! once, at setup). Zero steady-state error at constant speed; a constant acceleration `alpha`
//! (turns per tick^2) leaves an angle lag of `alpha / Ki`.

use super::SpindleSource;
use crate::protocol::errors::FaultCode;
use crate::trig::{cos_q30, sin_q30};

/// Resolver setup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolverConfig {
    /// Tick rate the observer runs at, Hz.
    pub tick_hz: u32,
    /// Nominal sin/cos amplitude in ADC LSB (after offset removal), 16..=16384.
    pub amplitude_lsb: u16,
    /// Amplitude band (LSB) outside which the signal counts as lost.
    pub amplitude_min_lsb: u16,
    pub amplitude_max_lsb: u16,
    /// Consecutive out-of-band ticks before the fault latches.
    pub loss_ticks: u16,
    /// Observer natural frequency, Hz (damping 1); well below `tick_hz / 10`.
    pub bandwidth_hz: u32,
    /// Below this speed (turn Q32 per tick) the spindle counts as stopped.
    pub stop_speed_turn_q32_per_tick: u32,
}

/// Why a resolver config was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResolverConfigError {
    Amplitude,
    Bandwidth,
}

/// Observer state.
#[derive(Clone, Debug)]
pub struct Resolver {
    cfg: ResolverConfig,
    /// Gains in 2^-48 turn per (LSB * Q30) of detector output, Q16.
    kp_q16: i64,
    ki_q16: i64,
    amp2_min: i32,
    amp2_max: i32,
    /// Angle, 2^-48 turn units (wraps every 65536 turns, a whole number of turns).
    phi_turn_q48: u64,
    /// Speed, 2^-48 turn per tick.
    omega_turn_q48_per_tick: i64,
    out_of_band_ticks: u16,
    fault: Option<FaultCode>,
}

impl Resolver {
    /// A new observer at angle zero, speed zero.
    pub fn new(cfg: ResolverConfig) -> Result<Self, ResolverConfigError> {
        if !(16..=16384).contains(&cfg.amplitude_lsb)
            || cfg.amplitude_min_lsb >= cfg.amplitude_max_lsb
            || cfg.amplitude_max_lsb > 23_000
        {
            return Err(ResolverConfigError::Amplitude);
        }
        if cfg.tick_hz == 0 || cfg.bandwidth_hz == 0 || cfg.bandwidth_hz > cfg.tick_hz / 10 {
            return Err(ResolverConfigError::Bandwidth);
        }
        // Setup-time f64: wn T, and the detector's scale A * 2^30 * 2 pi per turn of error.
        let wn_t = 2.0 * core::f64::consts::PI * cfg.bandwidth_hz as f64 / cfg.tick_hz as f64;
        let detector_per_turn =
            cfg.amplitude_lsb as f64 * (1u64 << 30) as f64 * 2.0 * core::f64::consts::PI;
        let to_q48_q16 = (1u64 << 48) as f64 * 65536.0 / detector_per_turn;
        Ok(Self {
            cfg,
            kp_q16: (2.0 * wn_t * to_q48_q16) as i64,
            ki_q16: (wn_t * wn_t * to_q48_q16) as i64,
            amp2_min: cfg.amplitude_min_lsb as i32 * cfg.amplitude_min_lsb as i32,
            amp2_max: cfg.amplitude_max_lsb as i32 * cfg.amplitude_max_lsb as i32,
            phi_turn_q48: 0,
            omega_turn_q48_per_tick: 0,
            out_of_band_ticks: 0,
            fault: None,
        })
    }

    /// One tick with this tick's ADC samples. Bounded, division-free, never panics.
    #[inline]
    pub fn update(&mut self, sin_lsb: i16, cos_lsb: i16) {
        let (s, c) = (sin_lsb as i32, cos_lsb as i32);
        let amp2 = s * s + c * c;
        if amp2 < self.amp2_min || amp2 > self.amp2_max {
            self.out_of_band_ticks = self.out_of_band_ticks.saturating_add(1);
            if self.out_of_band_ticks >= self.cfg.loss_ticks {
                self.fault = Some(FaultCode::ResolverLoss);
            }
        } else {
            self.out_of_band_ticks = 0;
        }
        // Predict to this sample, then correct: the angle reported belongs to this sample.
        self.phi_turn_q48 = self.phi_turn_q48.wrapping_add(self.omega_turn_q48_per_tick as u64);
        let phi = (self.phi_turn_q48 >> 16) as u32;
        // |e| <= 2 * 32768 * 2^30 = 2^46; gains < 2^17 for sane configs, saturating anyway.
        let e = s as i64 * cos_q30(phi) as i64 - c as i64 * sin_q30(phi) as i64;
        let ki = (e.saturating_mul(self.ki_q16)) >> 16;
        let kp = (e.saturating_mul(self.kp_q16)) >> 16;
        // Speed held to half a turn per tick, far beyond any spindle: keeps every sum in range.
        const OMEGA_MAX: i64 = 1 << 47;
        self.omega_turn_q48_per_tick =
            self.omega_turn_q48_per_tick.saturating_add(ki).clamp(-OMEGA_MAX, OMEGA_MAX);
        self.phi_turn_q48 = self.phi_turn_q48.wrapping_add(kp as u64);
    }

    pub fn config(&self) -> &ResolverConfig {
        &self.cfg
    }
}

impl SpindleSource for Resolver {
    fn angle_turn_q32(&self) -> u32 {
        (self.phi_turn_q48 >> 16) as u32
    }
    fn speed_turn_q32_per_tick(&self) -> i32 {
        (self.omega_turn_q48_per_tick >> 16) as i32
    }
    fn fault(&self) -> Option<FaultCode> {
        self.fault
    }
    /// A resolver is absolute: referenced from the first sample.
    fn is_referenced(&self) -> bool {
        true
    }
    fn is_stopped(&self) -> bool {
        self.speed_turn_q32_per_tick().unsigned_abs() < self.cfg.stop_speed_turn_q32_per_tick
    }
}
