//! A quadrature encoder read through a 16-bit timer (encoder mode, index on an input-capture
//! channel), board-independent: the lossless unwrapping of the wrapping `u16` counter to an
//! `i64` position ([`CountUnwrapper`]), the index capture handed from the capture interrupt to
//! the tick ([`IndexLatch`]), and both feeding [`QuadratureEncoder`] ([`TimerEncoder`], which
//! is the [`SpindleSource`] the board driver exposes). The board shell
//! (`boards/f405_motion/spindle_timer.rs`) only reads CNT, CCR3 and the status flags.
//!
//! Interrupt-rate code: wrapping adds and compares, no division.

use super::encoder::{EncoderConfig, EncoderConfigError, QuadratureEncoder};
use super::SpindleSource;
use crate::protocol::errors::FaultCode;

/// The wrapping `u16` timer count extended to an `i64` position. Lossless as long as the count
/// moves less than 32768 counts between two updates (the same bound as
/// [`QuadratureEncoder::update`]: at a 10 kHz tick that is 327 M counts/s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CountUnwrapper {
    last_raw: u16,
    position_counts: i64,
}

impl CountUnwrapper {
    /// Position 0 at the timer's current `raw` count.
    pub const fn new(raw: u16) -> Self {
        CountUnwrapper { last_raw: raw, position_counts: 0 }
    }

    /// The timer now reads `raw`: the extended position.
    #[inline]
    pub fn update(&mut self, raw: u16) -> i64 {
        self.position_counts = self.extend(raw);
        self.last_raw = raw;
        self.position_counts
    }

    /// The extended position of a count `raw` taken near the last update (an input capture,
    /// before or after it), without moving the unwrapper.
    #[inline]
    pub const fn extend(&self, raw: u16) -> i64 {
        // The signed 16-bit difference: wrap in either direction is the short way round.
        self.position_counts.wrapping_add(raw.wrapping_sub(self.last_raw) as i16 as i64)
    }

    pub const fn position_counts(&self) -> i64 {
        self.position_counts
    }
}

/// The index capture from the capture interrupt to the next tick. Keeps the latest capture;
/// counts captures that were overwritten (the timer's overcapture flag, or a second capture
/// before the tick took the first). A lost index also shows in the encoder logic, which faults
/// when a revolution passes without one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IndexLatch {
    pending: Option<u16>,
    lost: u32,
}

impl IndexLatch {
    pub const fn new() -> Self {
        IndexLatch { pending: None, lost: 0 }
    }

    /// A capture: the count latched at the index edge, and whether the timer flagged an
    /// overcapture (an earlier capture overwritten before it was read).
    #[inline]
    pub fn capture(&mut self, captured: u16, overcapture: bool) {
        if overcapture {
            self.lost = self.lost.saturating_add(1);
        }
        if self.pending.is_some() {
            self.lost = self.lost.saturating_add(1);
        }
        self.pending = Some(captured);
    }

    /// The capture since the last take, if any.
    #[inline]
    pub fn take(&mut self) -> Option<u16> {
        self.pending.take()
    }

    /// Captures overwritten before they were used.
    pub const fn lost(&self) -> u32 {
        self.lost
    }
}

/// The timer's view of a spindle encoder: unwrapped count, index latch and the encoder logic
/// (created by [`TimerEncoder::configure`] once counts per revolution are known). Until then it
/// reports `SensorFault`: a spindle source without a configuration is a missing sensor.
#[derive(Clone, Debug)]
pub struct TimerEncoder {
    unwrap: CountUnwrapper,
    index: IndexLatch,
    encoder: Option<QuadratureEncoder>,
}

impl TimerEncoder {
    /// An unconfigured encoder whose timer reads `raw` now.
    pub const fn new(raw: u16) -> Self {
        TimerEncoder { unwrap: CountUnwrapper::new(raw), index: IndexLatch::new(), encoder: None }
    }

    /// (Re)starts the encoder logic with `cfg` at the last count read (setup: divides).
    pub fn configure(&mut self, cfg: EncoderConfig) -> Result<(), EncoderConfigError> {
        self.encoder = Some(QuadratureEncoder::new(cfg, self.unwrap.last_raw)?);
        self.index = IndexLatch::new();
        Ok(())
    }

    /// The capture interrupt: CCR value and the overcapture flag.
    #[inline]
    pub fn capture(&mut self, captured: u16, overcapture: bool) {
        self.index.capture(captured, overcapture);
    }

    /// One tick with the timer's count now.
    #[inline]
    pub fn update(&mut self, raw: u16) {
        self.unwrap.update(raw);
        let index = self.index.take();
        if let Some(enc) = self.encoder.as_mut() {
            enc.update(raw, index);
        }
    }

    /// Extended position since start, counts.
    pub const fn position_counts(&self) -> i64 {
        self.unwrap.position_counts()
    }

    /// Index captures lost (see [`IndexLatch::lost`]).
    pub const fn lost_index_captures(&self) -> u32 {
        self.index.lost()
    }

    /// The encoder logic, once configured.
    pub const fn encoder(&self) -> Option<&QuadratureEncoder> {
        self.encoder.as_ref()
    }
}

impl SpindleSource for TimerEncoder {
    fn angle_turn_q32(&self) -> u32 {
        self.encoder.as_ref().map_or(0, |e| e.angle_turn_q32())
    }
    fn speed_turn_q32_per_tick(&self) -> i32 {
        self.encoder.as_ref().map_or(0, |e| e.speed_turn_q32_per_tick())
    }
    fn fault(&self) -> Option<FaultCode> {
        match &self.encoder {
            Some(e) => e.fault(),
            None => Some(FaultCode::SensorFault),
        }
    }
    fn is_referenced(&self) -> bool {
        self.encoder.as_ref().is_some_and(|e| e.is_referenced())
    }
    fn is_stopped(&self) -> bool {
        self.encoder.as_ref().is_none_or(|e| e.is_stopped())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spindle::sim::SimSpindle;
    use crate::spindle::speed_turn_q32_per_tick;
    use proptest::prelude::*;

    const CPR: u32 = 4000;
    const TICK_HZ: u32 = 10_000;

    fn cfg() -> EncoderConfig {
        EncoderConfig {
            counts_per_rev: CPR,
            index_tolerance_counts: 2,
            window_log2: 6,
            stop_counts_per_window: 2,
        }
    }

    #[test]
    fn unwraps_across_both_wrap_directions() {
        // Forward through 65535 -> 0, then back through 0 -> 65535, in 1000-count steps.
        let mut u = CountUnwrapper::new(64_000);
        let mut truth: i64 = 0;
        for _ in 0..5 {
            truth += 1000;
            assert_eq!(u.update((64_000 + truth).rem_euclid(65_536) as u16), truth);
        }
        assert_eq!(truth, 5000, "crossed 65535 -> 0 going up");
        for _ in 0..200 {
            truth -= 1000;
            assert_eq!(u.update((64_000 + truth).rem_euclid(65_536) as u16), truth);
        }
        assert_eq!(truth, -195_000, "crossed 0 -> 65535 going down, three times");
        // The largest step each way: +32767 and -32768.
        assert_eq!(u.update((64_000 + truth + 32_767).rem_euclid(65_536) as u16), truth + 32_767);
        truth += 32_767;
        assert_eq!(u.update((64_000 + truth - 32_768).rem_euclid(65_536) as u16), truth - 32_768);
        // A capture two counts behind and three ahead of the last read, across a wrap.
        let mut u = CountUnwrapper::new(1);
        assert_eq!(u.extend(65_535), -2);
        assert_eq!(u.extend(4), 3);
        assert_eq!(u.update(65_534), -3);
        assert_eq!(u.extend(2), 1);
    }

    #[test]
    fn index_latch_keeps_the_latest_and_counts_losses() {
        let mut l = IndexLatch::new();
        assert_eq!(l.take(), None);
        l.capture(10, false);
        assert_eq!(l.take(), Some(10));
        assert_eq!(l.take(), None);
        l.capture(20, false);
        l.capture(30, false);
        assert_eq!((l.take(), l.lost()), (Some(30), 1));
        l.capture(40, true);
        assert_eq!((l.take(), l.lost()), (Some(40), 2));
    }

    /// The simulated spindle at 3000 rpm (20 counts per tick), read the way the board reads
    /// TIM4: CCR3 (if the index passed) then CNT, every tick. `late_every`: every n-th index
    /// capture is handed over only at the next tick instead (as if the tick had not polled the
    /// capture flag and a lower-priority capture interrupt delivered it afterwards).
    fn run_sim(late_every: Option<u32>, seconds: u32) -> (TimerEncoder, SimSpindle, i32) {
        let speed = speed_turn_q32_per_tick(3_000_000, TICK_HZ);
        let mut sim = SimSpindle::new(0x1234_5678);
        let mut t = TimerEncoder::new(sim.encoder(CPR).0);
        assert_eq!(t.fault(), Some(FaultCode::SensorFault), "unconfigured");
        t.configure(cfg()).unwrap();
        let mut late: Option<u16> = None;
        let mut seen = 0;
        for _ in 0..(seconds * TICK_HZ) {
            sim.advance(speed as u32);
            let (raw, idx) = sim.encoder(CPR);
            if let Some(c) = late.take() {
                t.capture(c, false);
            }
            if let Some(c) = idx {
                seen += 1;
                match late_every {
                    Some(n) if seen % n == 0 => late = Some(c),
                    _ => t.capture(c, false),
                }
            }
            t.update(raw);
        }
        (t, sim, speed)
    }

    /// Captures taken in the same tick as CNT: the encoder logic's own answers come through
    /// the timer path: angle within one count of the truth, speed, referenced, no fault, and
    /// the unwrapped position equals the counts the sim made.
    #[test]
    fn sim_spindle_through_the_timer_path() {
        let (t, sim, speed) = run_sim(None, 3);
        assert_eq!(t.fault(), None);
        assert!(t.is_referenced());
        let truth = sim.angle_turn_q32();
        let count_q32 = (1u64 << 32) / CPR as u64;
        let err = t.angle_turn_q32().wrapping_sub(truth) as i32;
        assert!((err.unsigned_abs() as u64) <= count_q32, "angle error {err}");
        // Window speed: counts per 64 ticks, quantised to one count.
        let v = t.speed_turn_q32_per_tick();
        let count_per_window = (count_q32 >> 6) as i64;
        assert!((v as i64 - speed as i64).abs() <= count_per_window, "{v} vs {speed}");
        let turns_counts = sim.turns() as i64 * CPR as i64
            + ((sim.angle_turn_q32() as u64 * CPR as u64) >> 32) as i64;
        let start = ((0x1234_5678u64 * CPR as u64) >> 32) as i64;
        assert_eq!(t.position_counts(), turns_counts - start);
        assert_eq!(t.encoder().unwrap().position_counts(), t.position_counts());
    }

    /// Why the board's tick polls the capture flag itself before reading CNT: the encoder logic
    /// declares the index lost as soon as a revolution plus `index_tolerance_counts` (2) passes
    /// without one, and a capture one tick late arrives 20 counts past the revolution.
    #[test]
    fn a_capture_one_tick_late_trips_the_index_check() {
        let (t, _, _) = run_sim(Some(3), 1);
        assert_eq!(t.fault(), Some(FaultCode::EncoderIndex));
    }

    #[test]
    fn a_lost_index_faults_through_the_encoder_logic() {
        let speed = speed_turn_q32_per_tick(3_000_000, TICK_HZ);
        let mut sim = SimSpindle::new(0);
        let mut t = TimerEncoder::new(0);
        t.configure(cfg()).unwrap();
        let mut seen = 0;
        for _ in 0..(2 * TICK_HZ) {
            sim.advance(speed as u32);
            let (raw, idx) = sim.encoder(CPR);
            if let Some(c) = idx {
                seen += 1;
                // The third index pulse never reaches the timer.
                if seen != 3 {
                    t.capture(c, false);
                }
            }
            t.update(raw);
        }
        assert_eq!(t.fault(), Some(FaultCode::EncoderIndex));
    }

    proptest! {
        /// Any walk of steps within +/-32767 counts: the unwrapped position is the walk's sum and
        /// agrees with the encoder logic's own extended position.
        #[test]
        fn unwrap_is_lossless(start in any::<u16>(), steps in proptest::collection::vec(-32_767i64..=32_767, 1..200)) {
            let mut u = CountUnwrapper::new(start);
            let mut e = QuadratureEncoder::new(cfg(), start).unwrap();
            let mut truth = 0i64;
            for s in steps {
                truth += s;
                let raw = (start as i64 + truth).rem_euclid(65_536) as u16;
                prop_assert_eq!(u.update(raw), truth);
                e.update(raw, None);
                prop_assert_eq!(e.position_counts(), truth);
            }
        }
    }
}
