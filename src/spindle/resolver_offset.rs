//! Resolver ADC samples to observer input: the raw 12-bit sin/cos counts around their mid-scale
//! offset become the signed pair [`super::Resolver::update`] takes. A missing sample (the
//! conversion had not finished at the tick) becomes `(0, 0)`: the observer then only predicts,
//! and the zero amplitude counts towards its loss-of-signal timer like any out-of-band sample.
//!
//! Interrupt-rate code: two subtractions, no division.

/// Mid-scale of a 12-bit ADC: a resolver interface biased to VDDA/2 reads this at zero.
pub const ADC_MID_SCALE_12BIT: u16 = 2048;
/// Largest 12-bit count.
pub const ADC_MAX_12BIT: u16 = 4095;

/// The counts at which sin and cos read zero (mid-scale, or measured on the machine).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolverOffset {
    sin_zero_counts: u16,
    cos_zero_counts: u16,
}

impl ResolverOffset {
    /// Both channels at the ADC's mid-scale.
    pub const MID_SCALE: ResolverOffset = ResolverOffset {
        sin_zero_counts: ADC_MID_SCALE_12BIT,
        cos_zero_counts: ADC_MID_SCALE_12BIT,
    };

    /// `None` unless both offsets are 12-bit counts.
    pub const fn new(sin_zero_counts: u16, cos_zero_counts: u16) -> Option<Self> {
        if sin_zero_counts > ADC_MAX_12BIT || cos_zero_counts > ADC_MAX_12BIT {
            return None;
        }
        Some(ResolverOffset { sin_zero_counts, cos_zero_counts })
    }

    /// Offset removed: `(sin, cos)` in LSB around zero. Any `u16` input is accepted (a 12-bit
    /// ADC gives -4095..=4095 here; larger inputs saturate at the `i16` range).
    #[inline]
    pub const fn remove(&self, sin_counts: u16, cos_counts: u16) -> (i16, i16) {
        (centre(sin_counts, self.sin_zero_counts), centre(cos_counts, self.cos_zero_counts))
    }

    /// The observer's input for one tick: the centred sample, or `(0, 0)` if there was none.
    #[inline]
    pub const fn observer_input(&self, sample: Option<(u16, u16)>) -> (i16, i16) {
        match sample {
            Some((s, c)) => self.remove(s, c),
            None => (0, 0),
        }
    }
}

impl Default for ResolverOffset {
    fn default() -> Self {
        ResolverOffset::MID_SCALE
    }
}

#[inline]
const fn centre(counts: u16, zero: u16) -> i16 {
    let v = counts as i32 - zero as i32;
    if v > i16::MAX as i32 {
        i16::MAX
    } else if v < i16::MIN as i32 {
        i16::MIN
    } else {
        v as i16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spindle::{sim::SimSpindle, speed_turn_q32_per_tick, Resolver, SpindleSource};
    use proptest::prelude::*;

    #[test]
    fn mid_scale_and_measured_offsets() {
        let o = ResolverOffset::MID_SCALE;
        assert_eq!(o.remove(2048, 2048), (0, 0));
        assert_eq!(o.remove(0, 4095), (-2048, 2047));
        let m = ResolverOffset::new(2000, 2100).unwrap();
        assert_eq!(m.remove(2048, 2048), (48, -52));
        assert_eq!(m.observer_input(None), (0, 0));
        assert_eq!(ResolverOffset::new(4096, 0), None);
        assert_eq!(ResolverOffset::default(), o);
    }

    /// The simulated resolver as the ADC sees it (biased by measured offsets, rounded to 12-bit
    /// counts), centred by this module, tracks the true angle in the observer: the offsets are
    /// removed exactly, so no once-per-turn angle ripple from a residual bias.
    #[test]
    fn sim_resolver_through_the_adc_path() {
        const TICK_HZ: u32 = 50_000;
        let cfg = crate::turning::scenario::resolver_config();
        let amp = cfg.amplitude_lsb as i32;
        let off = ResolverOffset::new(1990, 2105).unwrap();
        let mut r = Resolver::new(cfg).unwrap();
        let mut sim = SimSpindle::new(0);
        let speed = speed_turn_q32_per_tick(600_000, TICK_HZ) as u32;
        let mut seed = 1;
        let mut worst: u32 = 0;
        for k in 0..TICK_HZ {
            sim.advance(speed);
            let (s, c) = sim.resolver(amp, 2, &mut seed);
            let raw = ((s as i32 + 1990) as u16, (c as i32 + 2105) as u16);
            let (si, co) = off.observer_input(Some(raw));
            r.update(si, co);
            if k > TICK_HZ / 2 {
                let e = r.angle_turn_q32().wrapping_sub(sim.angle_turn_q32()) as i32;
                worst = worst.max(e.unsigned_abs());
            }
        }
        assert_eq!(r.fault(), None);
        // Within 0.1 degree (2^32 / 3600 turn) once settled.
        assert!(worst < (1u32 << 31) / 1800, "worst {worst}");
    }

    #[test]
    fn missing_samples_count_as_signal_loss() {
        let cfg = crate::turning::scenario::resolver_config();
        let mut r = Resolver::new(cfg).unwrap();
        let o = ResolverOffset::MID_SCALE;
        for _ in 0..cfg.loss_ticks {
            let (s, c) = o.observer_input(None);
            r.update(s, c);
        }
        assert_eq!(r.fault(), Some(crate::protocol::errors::FaultCode::ResolverLoss));
    }

    proptest! {
        #[test]
        fn centring_is_exact_for_12_bit_counts(s in 0u16..=4095, c in 0u16..=4095, zs in 0u16..=4095, zc in 0u16..=4095) {
            let o = ResolverOffset::new(zs, zc).unwrap();
            let (a, b) = o.remove(s, c);
            prop_assert_eq!(a as i32 + zs as i32, s as i32);
            prop_assert_eq!(b as i32 + zc as i32, c as i32);
        }

        #[test]
        fn never_panics(s in any::<u16>(), c in any::<u16>()) {
            let _ = ResolverOffset::MID_SCALE.remove(s, c);
        }
    }
}
