//! Cycles spent in an interrupt handler, as a histogram a board can keep for hours: the handler
//! records each run with a shift and an atomic add ([`CycleBins::record`]); a lower-priority task
//! drains the bins into a [`CycleHistogram`] and logs its count, mean, percentiles and maximum.
//! On the F405 the cycles come from DWT CYCCNT; under QEMU (`-icount shift=0`) the board's
//! counter ticks once per instruction, so the same build measures instructions there.

use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// Width of a bin, as a shift: 2^5 = 32 cycles.
pub const BIN_SHIFT: u32 = 5;
/// Number of bins; the last also counts every run longer than the others cover.
pub const BINS: usize = 128;
/// Runs at or above this many cycles land in the last bin (4096 at 32-cycle bins).
pub const BINS_CYCLES: u32 = (BINS as u32) << BIN_SHIFT;

/// The interrupt's side: atomic bins, the longest run, and the total for the mean.
pub struct CycleBins {
    bins: [AtomicU32; BINS],
    max: AtomicU32,
    sum_lo: AtomicU32,
}

impl Default for CycleBins {
    fn default() -> Self {
        Self::new()
    }
}

impl CycleBins {
    pub const fn new() -> Self {
        CycleBins {
            bins: [const { AtomicU32::new(0) }; BINS],
            max: AtomicU32::new(0),
            sum_lo: AtomicU32::new(0),
        }
    }

    /// One run of `cycles` (interrupt rate: a shift, a compare and three atomic adds; the bins
    /// saturate instead of wrapping only if nobody drains them for 2^32 runs).
    #[inline(always)]
    pub fn record(&self, cycles: u32) {
        let bin = ((cycles >> BIN_SHIFT) as usize).min(BINS - 1);
        self.bins[bin].fetch_add(1, Relaxed);
        self.max.fetch_max(cycles, Relaxed);
        self.sum_lo.fetch_add(cycles, Relaxed);
    }

    /// Moves everything recorded since the last drain into `h` (the logging task; drain at
    /// least once per 2^32 cycles of handler time so the sum cannot wrap: 25 s at 168 MHz).
    pub fn drain_into(&self, h: &mut CycleHistogram) {
        for (acc, bin) in h.bins.iter_mut().zip(&self.bins) {
            let n = bin.swap(0, Relaxed) as u64;
            *acc += n;
            h.count += n;
        }
        h.sum += self.sum_lo.swap(0, Relaxed) as u64;
        h.max = h.max.max(self.max.swap(0, Relaxed));
    }
}

/// Runs accumulated over a period or a whole job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CycleHistogram {
    pub bins: [u64; BINS],
    pub count: u64,
    pub sum: u64,
    pub max: u32,
}

impl Default for CycleHistogram {
    fn default() -> Self {
        CycleHistogram { bins: [0; BINS], count: 0, sum: 0, max: 0 }
    }
}

impl CycleHistogram {
    /// Mean cycles per run (0 with no runs).
    pub fn mean(&self) -> u64 {
        self.sum.checked_div(self.count).unwrap_or(0)
    }

    /// The upper edge of the bin holding the `per_mille`-th per-mille run (at most the maximum;
    /// the maximum for the overflow bin), so the figure errs high by less than one bin; 0 with
    /// no runs.
    pub fn percentile(&self, per_mille: u32) -> u32 {
        if self.count == 0 {
            return 0;
        }
        let rank = (self.count * per_mille.min(1000) as u64).div_ceil(1000).max(1);
        let mut seen = 0;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= rank && i == BINS - 1 {
                // The overflow bin has no upper edge: the longest run is the honest figure.
                return self.max;
            }
            if seen >= rank {
                return (((i as u32) + 1) << BIN_SHIFT).min(self.max);
            }
        }
        self.max
    }

    /// Mean CPU share at `tick_hz` on a `core_hz` core, per mille.
    pub fn cpu_per_mille(&self, tick_hz: u32, core_hz: u32) -> u64 {
        (self.mean() * tick_hz as u64 * 1000).checked_div(core_hz as u64).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_land_in_their_bins_and_the_figures_follow() {
        let bins = CycleBins::new();
        // 90 runs of 500 cycles, 9 of 1000, one of 9000 (beyond the bins).
        for _ in 0..90 {
            bins.record(500);
        }
        for _ in 0..9 {
            bins.record(1_000);
        }
        bins.record(9_000);
        let mut h = CycleHistogram::default();
        bins.drain_into(&mut h);
        assert_eq!(h.count, 100);
        assert_eq!(h.bins[500 >> BIN_SHIFT], 90);
        assert_eq!(h.bins[1_000 >> BIN_SHIFT], 9);
        assert_eq!(h.bins[BINS - 1], 1);
        assert_eq!(h.max, 9_000);
        assert_eq!(h.mean(), (90 * 500 + 9 * 1_000 + 9_000) / 100);
        // Percentiles are the bin's upper edge: within one bin above the true value.
        assert_eq!(h.percentile(500), 512);
        assert_eq!(h.percentile(990), 1_024);
        assert_eq!(h.percentile(1000), 9_000);
        // 630 cycles at 100 kHz on 168 MHz: 37.5 %.
        assert_eq!(h.cpu_per_mille(100_000, 168_000_000), 630 * 100_000 * 1000 / 168_000_000);
    }

    #[test]
    fn a_drain_empties_the_bins_and_adds_up() {
        let bins = CycleBins::new();
        let mut h = CycleHistogram::default();
        bins.record(100);
        bins.drain_into(&mut h);
        bins.drain_into(&mut h);
        bins.record(300);
        bins.drain_into(&mut h);
        assert_eq!((h.count, h.sum, h.max), (2, 400, 300));
        assert_eq!(CycleHistogram::default().percentile(500), 0);
        assert_eq!(CycleHistogram::default().mean(), 0);
    }
}
