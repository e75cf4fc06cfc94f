//! Quadrature encoder in a timer's encoder mode: the timer's free-running `u16` count (read every
//! tick; wrap-safe as long as it moves less than 32768 counts per tick) and the count latched by
//! the index pulse. Counts per revolution are checked at every index (a mismatch or a missing
//! index latches `FaultCode::EncoderIndex`); the speed is the count difference over a fixed
//! window of `2^window_log2` ticks, scaled by a precomputed multiplier (no division per tick).

use super::SpindleSource;
use crate::protocol::errors::FaultCode;

/// Longest speed window, in ticks (a ring of this many positions).
pub const MAX_WINDOW_TICKS: usize = 256;

/// Encoder setup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderConfig {
    /// Quadrature counts per revolution (4 x lines), 4..=2^24.
    pub counts_per_rev: u32,
    /// Allowed difference between counts seen between two index pulses and `counts_per_rev`.
    pub index_tolerance_counts: u32,
    /// Speed window `2^window_log2` ticks, 0..=8.
    pub window_log2: u8,
    /// Below this many counts per window the spindle counts as stopped.
    pub stop_counts_per_window: u32,
}

/// Why an encoder config was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderConfigError {
    CountsPerRev,
    Window,
    Tolerance,
}

/// Encoder state: extended position, index reference, speed window.
#[derive(Clone, Debug)]
pub struct QuadratureEncoder {
    cfg: EncoderConfig,
    /// `2^48 / counts_per_rev`: counts -> turn Q32 with 16 extra fraction bits.
    turn_q48_per_count: u64,
    last_count: u16,
    position_counts: i64,
    /// Position at the last index pulse, or at start before the first one.
    reference_counts: i64,
    referenced: bool,
    window: [i32; MAX_WINDOW_TICKS],
    head: usize,
    window_counts: i32,
    /// Updates in a row without a count or an index (saturating): from the window's length on,
    /// every slot holds the position and an update changes nothing.
    still: u16,
    fault: Option<FaultCode>,
}

impl QuadratureEncoder {
    /// A new encoder whose timer currently reads `count`.
    pub fn new(cfg: EncoderConfig, count: u16) -> Result<Self, EncoderConfigError> {
        if !(4..=1 << 24).contains(&cfg.counts_per_rev) {
            return Err(EncoderConfigError::CountsPerRev);
        }
        if cfg.window_log2 > 8 {
            return Err(EncoderConfigError::Window);
        }
        if cfg.index_tolerance_counts >= cfg.counts_per_rev / 2 {
            return Err(EncoderConfigError::Tolerance);
        }
        Ok(Self {
            cfg,
            turn_q48_per_count: (1u64 << 48) / cfg.counts_per_rev as u64,
            last_count: count,
            position_counts: 0,
            reference_counts: 0,
            referenced: false,
            window: [0; MAX_WINDOW_TICKS],
            head: 0,
            window_counts: 0,
            // Every slot of the window already holds the position (0) and the timer has not
            // moved: an update with the same count changes nothing but the window's rotation,
            // which nothing reads while the slots are equal. So the encoder starts still, and
            // a board skips its updates until the spindle turns.
            still: 1 << cfg.window_log2,
            fault: None,
        })
    }

    /// A whole speed window of still updates has passed: an update with the same count and
    /// no index changes nothing (the caller may skip it).
    #[inline]
    pub fn is_still(&self) -> bool {
        self.still >= 1 << self.cfg.window_log2
    }

    /// One tick: the timer's count now and, if an index pulse came since the last tick, the
    /// count the timer latched on it. Bounded, division-free, never panics.
    #[inline]
    pub fn update(&mut self, count: u16, index_count: Option<u16>) {
        // Wrap-safe: the signed 16-bit difference is right for moves under 32768 counts/tick.
        let delta = count.wrapping_sub(self.last_count) as i16 as i64;
        // A stopped spindle: after a window of still updates nothing can change (the position,
        // the reference, every slot of the window), so the rest is skipped.
        if delta == 0 && index_count.is_none() {
            if self.still >= 1 << self.cfg.window_log2 {
                return;
            }
            self.still += 1;
        } else {
            self.still = 0;
        }
        self.last_count = count;
        self.position_counts = self.position_counts.wrapping_add(delta);
        let cpr = self.cfg.counts_per_rev as i64;
        let tol = self.cfg.index_tolerance_counts as i64;
        if let Some(latched) = index_count {
            let at_index =
                self.position_counts.wrapping_sub(count.wrapping_sub(latched) as i16 as i64);
            if self.referenced {
                let between = at_index.wrapping_sub(self.reference_counts).unsigned_abs();
                if between.abs_diff(cpr as u64) > tol as u64 {
                    self.fault = Some(FaultCode::EncoderIndex);
                }
            }
            self.reference_counts = at_index;
            self.referenced = true;
        }
        let rel = self.position_counts.wrapping_sub(self.reference_counts);
        // A revolution and the tolerance without an index: the index is lost (or, before the
        // first one, never came).
        if rel > cpr + tol || rel < -(cpr + tol) {
            self.fault = Some(FaultCode::EncoderIndex);
        }
        // Speed window: position now minus position 2^window_log2 ticks ago.
        let mask = (1usize << self.cfg.window_log2) - 1;
        let slot = self.head & mask;
        let pos = self.position_counts as i32;
        let old = self.window.get(slot).copied().unwrap_or(pos);
        self.window_counts = pos.wrapping_sub(old);
        if let Some(s) = self.window.get_mut(slot) {
            *s = pos;
        }
        self.head = (slot + 1) & mask;
    }

    /// Counts moved over the last window.
    pub fn window_counts(&self) -> i32 {
        self.window_counts
    }
    /// Extended position in counts since start.
    pub fn position_counts(&self) -> i64 {
        self.position_counts
    }
    pub fn config(&self) -> &EncoderConfig {
        &self.cfg
    }
}

impl SpindleSource for QuadratureEncoder {
    /// From the position and the index reference when asked (not every update: most ticks
    /// nobody reads the angle).
    fn angle_turn_q32(&self) -> u32 {
        let cpr = self.cfg.counts_per_rev as i64;
        let mut rel = self.position_counts.wrapping_sub(self.reference_counts);
        if rel >= cpr {
            rel -= cpr;
        } else if rel < 0 {
            rel += cpr;
        }
        let rel = rel.clamp(0, cpr - 1) as u64;
        ((rel * self.turn_q48_per_count) >> 16) as u32
    }
    fn speed_turn_q32_per_tick(&self) -> i32 {
        // counts/window * turn per count / window; |window_counts| < 2^24 so this fits.
        let v = (self.window_counts as i64).saturating_mul(self.turn_q48_per_count as i64)
            >> (16 + self.cfg.window_log2 as u32);
        v.clamp(i32::MIN as i64, i32::MAX as i64) as i32
    }
    fn fault(&self) -> Option<FaultCode> {
        self.fault
    }
    fn is_referenced(&self) -> bool {
        self.referenced
    }
    fn is_stopped(&self) -> bool {
        self.window_counts.unsigned_abs() < self.cfg.stop_counts_per_window
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a plain model that keeps the whole history: the speed window is the position now
    /// minus the position a window ago, the angle the position since the last index modulo a
    /// revolution; through stops longer than the window (the still fast path), starts, reversals
    /// and index pulses.
    #[test]
    fn matches_a_model_with_the_whole_history_through_stops_and_starts() {
        let cfg = EncoderConfig {
            counts_per_rev: 4000,
            index_tolerance_counts: 2,
            window_log2: 4,
            stop_counts_per_window: 1,
        };
        let mut e = QuadratureEncoder::new(cfg, 100).unwrap();
        let mut history = vec![0i64];
        let (mut pos, mut count, mut index_at) = (0i64, 100u16, None::<i64>);
        // Speed per update in counts: a start from still (the encoder starts still), runs,
        // stops of 3 windows, a reversal, a stop of 1 tick.
        let plan: Vec<(i64, usize)> = vec![
            (0, 5),
            (3, 500),
            (0, 48),
            (7, 900),
            (0, 1),
            (-5, 300),
            (0, 100),
            (2, 2000),
            (0, 17),
        ];
        assert!(e.is_still());
        for (speed, n) in plan {
            for _ in 0..n {
                let before = pos;
                pos += speed;
                count = count.wrapping_add(speed as u16);
                // An index every revolution, at position multiples of 4000.
                let idx = (before.div_euclid(4000) != pos.div_euclid(4000)).then(|| {
                    let at = pos.div_euclid(4000).max(before.div_euclid(4000)) * 4000;
                    index_at = Some(at);
                    count.wrapping_sub((pos - at) as u16)
                });
                e.update(count, idx);
                history.push(pos);
                let window = 1usize << cfg.window_log2;
                let past = history[history.len().saturating_sub(window + 1)];
                assert_eq!(e.window_counts() as i64, pos - past, "at {pos}");
                assert_eq!(e.position_counts(), pos);
                let rel = (pos - index_at.unwrap_or(0)).rem_euclid(4000) as u64;
                assert_eq!(e.angle_turn_q32(), ((rel * ((1u64 << 48) / 4000)) >> 16) as u32);
                assert_eq!(e.fault(), None);
            }
        }
    }
}
