//! Tooth clock and peak hold: the window of the force peak hold is one tooth period, derived
//! from the spindle speed and the flute count by a phase accumulator (no division).

/// Bins a tooth period is split into: the held peak covers the last 7/8..8/8 of a tooth period.
pub const PEAK_BINS: usize = 8;
/// Longest tooth period measured, in control updates (128 ms at 2 kHz).
pub const MAX_TOOTH_UPDATES: u32 = 255;

/// Tooth phase from spindle speed: one full turn of the u32 phase per tooth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ToothClock {
    /// Phase per update per (mrev/s), Q16: 2^48 z / (1000 control_hz).
    inc_per_mrev_s_q16: u64,
    phase: u32,
    since_wrap: u32,
    /// Length of the last whole tooth period, in updates.
    tooth_updates: u32,
}

impl ToothClock {
    /// `teeth` flutes, updated at `control_hz`, first tooth period guessed from
    /// `nominal_mrev_s` (setup-time division).
    pub fn new(teeth: u32, control_hz: u32, nominal_mrev_s: u32) -> Self {
        let inc = ((teeth as u64) << 48) / (1000 * control_hz.max(1) as u64);
        let guess = (control_hz as u64 * 1000) / (teeth as u64 * nominal_mrev_s as u64).max(1);
        ToothClock {
            inc_per_mrev_s_q16: inc,
            phase: 0,
            since_wrap: 0,
            tooth_updates: (guess as u32).clamp(1, MAX_TOOTH_UPDATES),
        }
    }

    /// Advances one control update at spindle speed `mrev_s` (milli-revolutions per second);
    /// returns the phase before and after.
    #[inline]
    pub fn advance(&mut self, mrev_s: u32) -> (u32, u32) {
        let inc = ((self.inc_per_mrev_s_q16 * mrev_s as u64) >> 16).min(u32::MAX as u64) as u32;
        let before = self.phase;
        let (after, wrapped) = before.overflowing_add(inc);
        self.phase = after;
        self.since_wrap = (self.since_wrap + 1).min(MAX_TOOTH_UPDATES);
        if wrapped {
            self.tooth_updates = self.since_wrap;
            self.since_wrap = 0;
        }
        (before, after)
    }

    /// The last whole tooth period in updates (the setup guess until a tooth has passed).
    pub fn tooth_updates(&self) -> u32 {
        self.tooth_updates
    }
}

/// Peak of the force over the last tooth period, kept as [`PEAK_BINS`] bin maxima.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PeakHold {
    bins: [u32; PEAK_BINS],
}

impl PeakHold {
    /// Adds a sample taken while the tooth phase moved `before` -> `after`; returns the peak
    /// over the last 7/8 to 8/8 of a tooth period.
    #[inline]
    pub fn update(&mut self, (before, after): (u32, u32), force_mn: u32) -> u32 {
        const SHIFT: u32 = 32 - PEAK_BINS.trailing_zeros();
        let (b0, b1) = ((before >> SHIFT) as usize, (after >> SHIFT) as usize);
        if b0 != b1 {
            // Entering a new bin forgets what it held a tooth period ago. A spindle fast enough
            // to skip bins in one update only leaves them stale for one more tooth.
            self.bins[b1 & (PEAK_BINS - 1)] = 0;
        }
        let bin = &mut self.bins[b1 & (PEAK_BINS - 1)];
        *bin = (*bin).max(force_mn);
        let mut peak = 0;
        for &b in &self.bins {
            peak = peak.max(b);
        }
        peak
    }

    /// Forgets every bin (after a tare or a fault).
    pub fn clear(&mut self) {
        self.bins = [0; PEAK_BINS];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tooth_period_from_speed() {
        // 4 teeth at 500 rpm (8333 mrev/s), 2 kHz: 30 ms = 60 updates.
        let mut c = ToothClock::new(4, 2000, 8333);
        assert_eq!(c.tooth_updates(), 60);
        let mut c2 = ToothClock::new(4, 2000, 1);
        for _ in 0..200 {
            c.advance(8333);
            c2.advance(4167);
        }
        // 8333 mrev/s is a hair under 500 rpm (60.002 updates per tooth): whole periods of 60 or
        // 61 updates.
        assert!((60..=61).contains(&c.tooth_updates()), "{}", c.tooth_updates());
        assert!((120..=121).contains(&c2.tooth_updates()), "{}", c2.tooth_updates());
    }

    #[test]
    fn peak_holds_one_tooth_then_drops() {
        let mut c = ToothClock::new(4, 2000, 8333);
        let mut p = PeakHold::default();
        let mut out = [0u32; 200];
        for (k, o) in out.iter_mut().enumerate() {
            let f = if k == 10 { 9_000_000 } else { 1_000_000 };
            *o = p.update(c.advance(8333), f);
        }
        assert_eq!(out[10], 9_000_000);
        // Held for at least 7/8 of the 60-update tooth, gone after a whole one.
        assert!(out[10..10 + 52].iter().all(|&f| f == 9_000_000));
        assert!(out[10 + 61..].iter().all(|&f| f == 1_000_000));
    }
}
