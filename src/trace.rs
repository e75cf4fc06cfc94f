//! What the pins did: per-axis step counts, peak step rates and a hash of every rising edge
//! (tick, axis, direction). The QEMU board records its outputs with this, and the host model
//! records the same DDA's outputs with it, so one hash compares whole runs.

use crate::config::MAX_AXES;
use crate::dda::StepOutput;

/// FNV-1a, 64 bit: the hash of the step trace and of every scenario's per-tick
/// outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceHash(u64);

impl Default for TraceHash {
    fn default() -> Self {
        Self::new()
    }
}

impl TraceHash {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    pub const fn new() -> Self {
        TraceHash(Self::OFFSET)
    }

    #[inline]
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(Self::PRIME);
        }
    }

    #[inline]
    pub fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }

    #[inline]
    pub fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }

    #[inline]
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }

    #[inline]
    pub fn i64(&mut self, v: i64) {
        self.bytes(&v.to_le_bytes());
    }

    pub const fn value(&self) -> u64 {
        self.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepRecorder {
    hash: TraceHash,
    /// Rising edges per axis.
    pub steps: [u64; MAX_AXES],
    /// Net steps per axis (+1 positive, -1 negative), as the DIR pins said at each edge.
    pub net: [i64; MAX_AXES],
    /// Shortest interval between two rising edges per axis, ticks (u64::MAX: fewer than two).
    pub min_interval_ticks: [u64; MAX_AXES],
    last_rise: [Option<u64>; MAX_AXES],
    pub first_step_tick: Option<u64>,
    pub last_step_tick: u64,
    /// DIR writes per axis.
    pub dir_writes: [u32; MAX_AXES],
    /// Peak rates are counted over aligned windows of this many ticks.
    window_ticks: u64,
    window_start: u64,
    window_steps: [u32; MAX_AXES],
    /// Most rising edges seen in one window, per axis.
    pub peak_window_steps: [u32; MAX_AXES],
}

/// Default peak-rate window: 1 ms at the demo's 100 kHz tick.
pub const DEFAULT_WINDOW_TICKS: u64 = 100;

impl Default for StepRecorder {
    fn default() -> Self {
        Self::new()
    }
}

impl StepRecorder {
    pub const fn new() -> Self {
        Self::with_window(DEFAULT_WINDOW_TICKS)
    }

    pub const fn with_window(window_ticks: u64) -> Self {
        StepRecorder {
            window_ticks: if window_ticks == 0 { 1 } else { window_ticks },
            window_start: 0,
            window_steps: [0; MAX_AXES],
            peak_window_steps: [0; MAX_AXES],
            hash: TraceHash::new(),
            steps: [0; MAX_AXES],
            net: [0; MAX_AXES],
            min_interval_ticks: [u64::MAX; MAX_AXES],
            last_rise: [None; MAX_AXES],
            first_step_tick: None,
            last_step_tick: 0,
            dir_writes: [0; MAX_AXES],
        }
    }

    #[inline]
    pub fn record(&mut self, tick: u64, out: &StepOutput) {
        if out.dir_write() != 0 {
            for (i, w) in self.dir_writes.iter_mut().enumerate() {
                *w += (out.dir_write() >> i) as u32 & 1;
            }
        }
        if out.rise() != 0 {
            self.record_rises(tick, out);
        }
    }

    #[cold]
    fn record_rises(&mut self, tick: u64, out: &StepOutput) {
        self.first_step_tick.get_or_insert(tick);
        self.last_step_tick = tick;
        if tick >= self.window_start + self.window_ticks {
            // Next window, or realign after a gap; no division on the interrupt path.
            self.window_start = if tick >= self.window_start + 2 * self.window_ticks {
                tick
            } else {
                self.window_start + self.window_ticks
            };
            self.window_steps = [0; MAX_AXES];
        }
        for i in 0..MAX_AXES {
            if out.rise() & (1 << i) == 0 {
                continue;
            }
            let negative = out.dir() & (1 << i) != 0;
            self.steps[i] += 1;
            self.window_steps[i] += 1;
            self.peak_window_steps[i] = self.peak_window_steps[i].max(self.window_steps[i]);
            self.net[i] += if negative { -1 } else { 1 };
            if let Some(prev) = self.last_rise[i] {
                self.min_interval_ticks[i] = self.min_interval_ticks[i].min(tick - prev);
            }
            self.last_rise[i] = Some(tick);
            self.hash.u64(tick);
            self.hash.bytes(&[i as u8, negative as u8]);
        }
    }

    /// FNV-1a over (tick as 8 LE bytes, axis, dir) of every rising edge in order.
    pub fn hash(&self) -> u64 {
        self.hash.value()
    }

    /// Peak step rate per axis: the busiest window's steps over the window's duration, Hz.
    pub fn peak_rate_hz(&self, tick_hz: u32) -> [u32; MAX_AXES] {
        let mut r = [0; MAX_AXES];
        for (r, &n) in r.iter_mut().zip(&self.peak_window_steps) {
            *r = (n as u64 * tick_hz as u64 / self.window_ticks) as u32;
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_depends_on_tick_axis_and_dir() {
        let out = |rise, dir| StepOutput::new(0, 0, dir, rise);
        let run = |events: &[(u64, u8, u8)]| {
            let mut r = StepRecorder::new();
            for &(t, rise, dir) in events {
                r.record(t, &out(rise, dir));
            }
            r.hash()
        };
        let base = run(&[(5, 1, 0), (9, 2, 0)]);
        assert_eq!(base, run(&[(5, 1, 0), (9, 2, 0)]));
        assert_ne!(base, run(&[(5, 1, 0), (10, 2, 0)]));
        assert_ne!(base, run(&[(5, 1, 0), (9, 4, 0)]));
        assert_ne!(base, run(&[(5, 1, 0), (9, 2, 2)]));
        let mut r = StepRecorder::new();
        r.record(3, &out(0b11, 0b10));
        r.record(7, &out(0b01, 0b10));
        assert_eq!(r.steps[..2], [2, 1]);
        assert_eq!(r.net[..2], [2, -1]);
        assert_eq!(r.min_interval_ticks[0], 4);
        // Both axis-0 edges fall in the first 100-tick window: 2 steps per ms.
        assert_eq!(r.peak_rate_hz(100_000)[..2], [2_000, 1_000]);
        r.record(250, &out(0b01, 0));
        r.record(260, &out(0b01, 0));
        r.record(270, &out(0b01, 0));
        assert_eq!(r.peak_rate_hz(100_000)[0], 3_000);
    }
}
