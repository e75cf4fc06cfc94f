//! The milling plant the simulation cuts: force from the stepped X position (eq 4.17,
//! F = K a b [x(t) - x(t - tau)] = Kc b [x(t) - x(t - tau)], tau = 1/(z N)), the optional two-tooth periodic force
//! (eq 4.19: factor 1 + sin(z N 2 pi t)), spindle compliance across passes, and the ADC that turns
//! force into counts for the chain. Integer-only; setup divides.

/// Longest tooth delay, in plant samples (102 ms at 10 kHz).
pub const MAX_DELAY_SAMPLES: usize = 1024;

/// Plant setup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlantParams {
    /// Cutting constant Kc: force per mm^2 of chip section (axial depth b times the chip the
    /// tooth takes), mN/mm^2; eq 4.17's `K a` (205 N/mm^3 x 20 mm = 4100 N/mm^2).
    pub kc_mn_per_mm2: u32,
    /// Axial depth b before and after the step, um, and the penetration where it steps, um.
    pub b_before_um: u32,
    pub b_after_um: u32,
    pub step_at_um: u32,
    /// Axis position of the workpiece wall, steps; the tool cuts beyond it.
    pub wall_steps: i64,
    /// Axis travel per step, nm.
    pub nm_per_step: u32,
    pub sample_hz: u32,
    pub teeth: u32,
    pub spindle_mrev_s: u32,
    /// Eq 4.19's periodic tooth force instead of eq 4.17's steady one.
    pub periodic: bool,
}

/// Why a plant setup was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlantConfigError {
    /// The tooth delay does not fit 1..MAX_DELAY_SAMPLES samples.
    Delay,
    /// Zero resolution or sample rate.
    Units,
}

/// The plant's state: a delay line of penetration samples.
#[derive(Clone, Debug)]
pub struct MillingPlant {
    p: PlantParams,
    /// mN per step of chip, Q16, before and after the depth step.
    c_before_q16: u64,
    c_after_q16: u64,
    step_at_steps: i64,
    delay: usize,
    ring: [i32; MAX_DELAY_SAMPLES],
    at: usize,
    tooth_phase: u32,
    tooth_inc: u32,
}

impl MillingPlant {
    pub fn new(p: PlantParams) -> Result<Self, PlantConfigError> {
        if p.nm_per_step == 0 || p.sample_hz == 0 {
            return Err(PlantConfigError::Units);
        }
        let den = p.teeth as u64 * p.spindle_mrev_s as u64;
        if den == 0 {
            return Err(PlantConfigError::Delay);
        }
        // tau = 1/(z N) in samples, rounded.
        let delay = (p.sample_hz as u64 * 1000 + den / 2) / den;
        if delay == 0 || delay >= MAX_DELAY_SAMPLES as u64 {
            return Err(PlantConfigError::Delay);
        }
        // F[mN] = Kc b dx: mN/mm^2 * um * nm is 1e-9 mN.
        let c = |b_um: u32| {
            let k = p.kc_mn_per_mm2 as u128 * b_um as u128 * p.nm_per_step as u128;
            ((k << 16) / 1_000_000_000).min(u64::MAX as u128) as u64
        };
        Ok(MillingPlant {
            p,
            c_before_q16: c(p.b_before_um),
            c_after_q16: c(p.b_after_um),
            step_at_steps: (p.step_at_um as i64 * 1000) / p.nm_per_step as i64,
            delay: delay as usize,
            ring: [0; MAX_DELAY_SAMPLES],
            at: 0,
            tooth_phase: 0,
            tooth_inc: ((1u64 << 32) / delay) as u32,
        })
    }

    /// The tooth delay in samples.
    pub fn delay_samples(&self) -> usize {
        self.delay
    }

    /// Penetration where the depth steps, in axis steps beyond the wall.
    pub fn step_at_steps(&self) -> i64 {
        self.step_at_steps
    }

    /// One plant sample at axis position `x_steps`: the cutting force, mN.
    #[inline]
    pub fn sample(&mut self, x_steps: i64) -> u32 {
        let pen = (x_steps - self.p.wall_steps).clamp(0, i32::MAX as i64) as i32;
        self.at = (self.at + 1) & (MAX_DELAY_SAMPLES - 1);
        self.ring[self.at] = pen;
        let then = self.ring[(self.at + MAX_DELAY_SAMPLES - self.delay) & (MAX_DELAY_SAMPLES - 1)];
        // A tooth removes what the table advanced since the last tooth; never negative.
        let chip = pen.saturating_sub(then).max(0) as u64;
        let c = if pen as i64 >= self.step_at_steps { self.c_after_q16 } else { self.c_before_q16 };
        let mut f = (c * chip) >> 16;
        if self.p.periodic {
            self.tooth_phase = self.tooth_phase.wrapping_add(self.tooth_inc);
            // 1 + sin, Q15: 0..2.
            let m = (32_768 + (crate::trig::sin_q30(self.tooth_phase) >> 15)) as u64;
            f = (f * m) >> 15;
        }
        f.min(u32::MAX as u64) as u32
    }
}

/// Spindle compliance across passes: pass n cuts the nominal chip plus what the previous pass's
/// deflection left, F_n (1 + mu) = F + mu F_{n-1}, so F_n = F [1 - (mu/(1+mu))^n].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpindleCompliance {
    /// mu = Kc/Ks and 1/(1 + mu), Q16.
    mu_q16: u64,
    inv_one_plus_mu_q16: u64,
    last_mn: u64,
}

impl SpindleCompliance {
    /// `cutting_n_mm` = Kc, `spindle_n_mm` = Ks (setup-time division).
    pub fn new(cutting_n_mm: u32, spindle_n_mm: u32) -> Self {
        let ks = spindle_n_mm.max(1) as u64;
        SpindleCompliance {
            mu_q16: ((cutting_n_mm as u64) << 16) / ks,
            inv_one_plus_mu_q16: (ks << 16) / (ks + cutting_n_mm as u64),
            last_mn: 0,
        }
    }

    /// The force of the next pass whose rigid-machine force would be `rigid_mn`.
    pub fn next_pass(&mut self, rigid_mn: u32) -> u32 {
        let sum = ((rigid_mn as u64) << 16) + self.mu_q16 * self.last_mn;
        self.last_mn = ((sum >> 16) * self.inv_one_plus_mu_q16) >> 16;
        self.last_mn.min(u32::MAX as u64) as u32
    }
}

/// A 12-bit ADC behind the dynamometer's amplifiers, with a fault to inject.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdcFault {
    None,
    /// The channel reads full scale.
    Saturated(u8),
    /// The channel repeats its last reading.
    Stuck(u8),
}

/// The simulated ADC: force along a fixed direction, per-channel zero errors, +/-1 count dither.
#[derive(Clone, Debug)]
pub struct SimAdc {
    /// True zero of each channel, counts.
    pub zero_counts: [u16; 3],
    /// Share of the resultant on each channel, Q16 (a unit vector).
    pub direction_q16: [i32; 3],
    /// Counts per mN, Q32 (setup: 2^32 / mN per count).
    counts_per_mn_q32: u64,
    pub fault: AdcFault,
    lcg: u32,
    last: [u16; 3],
}

impl SimAdc {
    pub fn new(zero_counts: [u16; 3], direction_q16: [i32; 3], mn_per_count: u32) -> Self {
        SimAdc {
            zero_counts,
            direction_q16,
            counts_per_mn_q32: (1u64 << 32) / mn_per_count.max(1) as u64,
            fault: AdcFault::None,
            lcg: 0x1234_5678,
            last: zero_counts,
        }
    }

    /// Counts of the three channels for resultant force `force_mn`.
    #[inline]
    pub fn convert(&mut self, force_mn: u32) -> [u16; 3] {
        let mut out = [0u16; 3];
        for i in 0..3 {
            self.lcg = self.lcg.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let dither = (self.lcg >> 30) as i64 - 1; // -1, 0, 1, 2
            let ch_mn = (force_mn as i64 * self.direction_q16[i] as i64) >> 16;
            let counts = (ch_mn * self.counts_per_mn_q32 as i64 + (1 << 31)) >> 32;
            out[i] = (self.zero_counts[i] as i64 + counts + dither).clamp(0, 4095) as u16;
        }
        match self.fault {
            AdcFault::Saturated(k) if (k as usize) < 3 => out[k as usize] = 4095,
            AdcFault::Stuck(k) if (k as usize) < 3 => out[k as usize] = self.last[k as usize],
            _ => {}
        }
        self.last = out;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn case_a() -> PlantParams {
        PlantParams {
            kc_mn_per_mm2: 4_100_000,
            b_before_um: 2_500,
            b_after_um: 10_000,
            step_at_um: 10_000,
            wall_steps: 0,
            nm_per_step: 1000,
            sample_hz: 10_000,
            teeth: 4,
            spindle_mrev_s: 8_333,
            periodic: false,
        }
    }

    /// Eq 4.17 statics at a constant feed: 12.7 mm/s gives 3905 N before the step (thesis
    /// "3900 N") and 15 621 N after it ("15 600 N").
    #[test]
    fn steady_force_matches_eq_4_17() {
        let mut pl = MillingPlant::new(case_a()).unwrap();
        assert_eq!(pl.delay_samples(), 300);
        // 12.7 um per sample at 10 kHz is 127 mm/s: use 1.27 um per sample over 10 samples.
        let mut f = 0;
        let mut x = 0i64;
        let mut frac = 0;
        let mut before = 0;
        for k in 0..200_000 {
            frac += 127;
            x += frac / 100;
            frac %= 100;
            f = pl.sample(x);
            if x < 9_800 && k > 400 {
                before = f;
            }
            if x > 10_800 {
                break;
            }
        }
        assert!((before as i64 - 3_904_950).abs() < 10_000, "{before}");
        assert!((f as i64 - 15_619_800).abs() < 40_000, "{f}");
    }

    #[test]
    fn periodic_force_doubles_at_peak_and_averages_the_steady_one() {
        let mut p = case_a();
        p.periodic = true;
        let mut pl = MillingPlant::new(p).unwrap();
        let (mut peak, mut sum, mut n) = (0u32, 0u64, 0u64);
        for k in 0..3000i64 {
            let f = pl.sample(k);
            if k >= 600 {
                peak = peak.max(f);
                sum += f as u64;
                n += 1;
            }
        }
        // Steady: K a b * 300 steps of 1 um at b = 2.5 mm = 3075 N; peak twice that.
        assert!((peak as i64 - 6_150_000).abs() < 10_000, "{peak}");
        assert!(((sum / n) as i64 - 3_075_000).abs() < 5_000, "{}", sum / n);
    }

    /// Pass growth (digest oracle 8): mu = 1 gives 0.5, 0.75, 0.875; mu = 0.5 gives 0.667, 0.889.
    #[test]
    fn spindle_compliance_pass_growth() {
        for (kc, ks, printed) in
            [(5800, 5800, &[0.5, 0.75, 0.875][..]), (2900, 5800, &[0.667, 0.889][..])]
        {
            let mut sc = SpindleCompliance::new(kc, ks);
            let mu = kc as f64 / ks as f64;
            for (n, &p) in printed.iter().enumerate() {
                let f = sc.next_pass(1_000_000) as f64 / 1e6;
                let closed = 1.0 - (mu / (1.0 + mu)).powi(n as i32 + 1);
                assert!((f - closed).abs() < 1e-4, "{f} vs {closed}");
                assert!((f - p).abs() < 6e-4, "{f} vs printed {p}");
            }
        }
    }

    #[test]
    fn adc_injects_faults() {
        let mut adc = SimAdc::new([2085, 2036, 2053], [31_457, 41_943, 39_322], 9_770);
        let c = adc.convert(10_000_000);
        // 10 kN * 0.48 / 9.77 N = 491 counts above zero, +/- dither.
        assert!((c[0] as i32 - 2085 - 491).abs() <= 2, "{c:?}");
        adc.fault = AdcFault::Saturated(1);
        assert_eq!(adc.convert(0)[1], 4095);
        adc.fault = AdcFault::Stuck(2);
        let a = adc.convert(5_000_000)[2];
        assert_eq!(adc.convert(9_000_000)[2], a);
    }
}
