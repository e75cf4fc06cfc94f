//! Firmware playback of recorded step events, one call per DDA tick.
//!
//! Time is a virtual clock like the DDA's: each tick adds the feed override (Q2.30 virtual ticks
//! per tick) to a phase, and an event fires once the phase reaches its `dt` (in Q30). So
//! `dt' = dt / override` with no division, and the event count never depends on the speed.
//! Radial size scaling m/k passes m radial steps per k recorded ones (a Bresenham remainder).
//! Fired steps go through [`StepPins`], which emits at most one rise per axis per tick, writes DIR
//! one tick before a reversed rise (setup) and never in the tick of a rise (hold).

use super::{StepEvent, AXIS_R};
use crate::dda::{Dda, StepOutput};
use crate::machine::StepSource;
use crate::segment::Rate;
use heapless::Deque;

/// Decoded events the playback holds ahead of the tick.
pub const QUEUE_DEPTH: usize = 64;
/// Most events fired in one tick; the rest wait for the next tick (their time is kept).
pub const MAX_FIRE_PER_TICK: u32 = 4;
/// Slowest and fastest speed scale.
pub const RATE_MIN: Rate = Rate::lit("0.25");
pub const RATE_MAX: Rate = Rate::lit("2");

/// Radial size scaling m/k, 1:4 ..= 4:1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SizeScale {
    pub m: u8,
    pub k: u8,
}

impl SizeScale {
    pub const ONE: SizeScale = SizeScale { m: 1, k: 1 };

    /// Checks 1 <= m, k <= 4 (ratios 1:4 to 4:1, the thesis's presettable counter).
    pub const fn new(m: u8, k: u8) -> Option<Self> {
        if m >= 1 && m <= 4 && k >= 1 && k <= 4 {
            Some(SizeScale { m, k })
        } else {
            None
        }
    }
}

/// Per-axis step output with pending counts: the shared pin stage of playback and copy mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepPins {
    /// Steps still to emit per axis (theta, r), signed.
    pending: [i32; 2],
    /// DIR levels (bit set = negative).
    dir: u8,
    rose_last: u8,
    /// Size-scale remainder, -k < acc < k.
    acc: i8,
    scale: SizeScale,
    /// Net steps emitted per axis.
    pub position: [i64; 2],
    /// Rising edges per axis.
    pub rises: [u64; 2],
}

impl StepPins {
    pub const fn new(scale: SizeScale) -> Self {
        StepPins {
            pending: [0; 2],
            dir: 0,
            rose_last: 0,
            acc: 0,
            scale,
            position: [0; 2],
            rises: [0; 2],
        }
    }

    /// Adds one recorded step; radial ones pass through the m/k scaler (at most 4 subtractions).
    #[inline]
    pub fn add(&mut self, ev: StepEvent) {
        let s = ev.signed();
        if ev.axis & 1 != AXIS_R {
            self.pending[0] += s;
            return;
        }
        let (m, k) = (self.scale.m as i8, self.scale.k as i8);
        self.acc += if ev.negative { -m } else { m };
        let mut n = 0;
        while self.acc >= k && n < 4 {
            self.acc -= k;
            self.pending[1] += 1;
            n += 1;
        }
        while self.acc <= -k && n < 4 {
            self.acc += k;
            self.pending[1] -= 1;
            n += 1;
        }
    }

    /// True when no step is waiting.
    pub fn idle(&self) -> bool {
        self.pending == [0, 0]
    }

    /// This tick's pins: fall of last tick's rises, DIR writes, rises.
    #[inline]
    pub fn output(&mut self) -> StepOutput {
        let mut rise = 0u8;
        let mut dir_write = 0u8;
        for a in 0..2 {
            let p = self.pending[a];
            if p == 0 {
                continue;
            }
            let bit = 1u8 << a;
            let neg = if p < 0 { bit } else { 0 };
            if neg != self.dir & bit {
                if self.rose_last & bit == 0 {
                    // DIR changes a tick after the last rise (hold) and a tick before the next (setup).
                    self.dir = (self.dir & !bit) | neg;
                    dir_write |= bit;
                }
            } else if self.rose_last & bit == 0 {
                rise |= bit;
                let s = if p < 0 { -1 } else { 1 };
                self.pending[a] -= s;
                self.position[a] += s as i64;
                self.rises[a] += 1;
            }
        }
        let fall = self.rose_last;
        self.rose_last = rise;
        StepOutput::new(fall, dir_write, self.dir, rise)
    }
}

/// Plays decoded events at their recorded times, scaled.
#[derive(Clone, Debug)]
pub struct Playback {
    queue: Deque<StepEvent, QUEUE_DEPTH>,
    /// Virtual ticks since the last fired event, Q30.
    phase_q30: u64,
    rate_bits: u32,
    pins: StepPins,
    fired: u32,
    source_done: bool,
}

impl Playback {
    /// A playback at speed 1.0 with radial size scale `scale`.
    pub const fn new(scale: SizeScale) -> Self {
        Playback {
            queue: Deque::new(),
            phase_q30: 0,
            rate_bits: 1 << 30,
            pins: StepPins::new(scale),
            fired: 0,
            source_done: false,
        }
    }

    /// Speed scale (the feed override), clamped to 0.25..=2: recorded dt becomes dt / rate.
    pub fn set_rate(&mut self, rate: Rate) {
        self.rate_bits = rate.clamp(RATE_MIN, RATE_MAX).to_bits();
    }

    /// Free queue slots for the feeder task.
    pub fn free(&self) -> usize {
        QUEUE_DEPTH - self.queue.len()
    }

    /// Queues a decoded event; gives it back when the queue is full.
    pub fn push(&mut self, ev: StepEvent) -> Result<(), StepEvent> {
        self.queue.push_back(ev)
    }

    /// The feeder has no more events: once the queue and pins drain, [`Playback::done`] is true.
    pub fn finish(&mut self) {
        self.source_done = true;
    }

    pub fn done(&self) -> bool {
        self.source_done && self.queue.is_empty() && self.pins.idle()
    }

    /// Decoded events waiting to fire.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// The feeder has not finished and no event is waiting: time cannot run on (an underrun).
    pub fn starved(&self) -> bool {
        self.queue.is_empty() && !self.source_done
    }

    /// The size scale this playback was made with.
    pub fn scale(&self) -> SizeScale {
        self.pins.scale
    }

    /// The speed scale in force, `Rate` bits.
    pub fn rate_bits(&self) -> u32 {
        self.rate_bits
    }

    /// Events fired so far.
    pub fn fired(&self) -> u32 {
        self.fired
    }

    /// Net steps per axis (theta, r) emitted so far.
    pub fn position(&self) -> [i64; 2] {
        self.pins.position
    }

    pub fn pins(&self) -> &StepPins {
        &self.pins
    }

    /// One DDA tick: advance the virtual clock, fire due events (at most [`MAX_FIRE_PER_TICK`]),
    /// return the pins. Integer adds, compares and shifts only; bounded loops.
    #[inline]
    pub fn tick(&mut self) -> StepOutput {
        self.tick_at(self.rate_bits)
    }

    /// [`Playback::tick`] at speed `rate_bits` (Q2.30) for this tick only; 0 stops the clock
    /// (a hold: due events wait, steps already fired still reach the pins).
    #[inline]
    pub fn tick_at(&mut self, rate_bits: u32) -> StepOutput {
        self.phase_q30 += rate_bits as u64;
        let mut n = 0;
        while n < MAX_FIRE_PER_TICK {
            let Some(ev) = self.queue.front().copied() else { break };
            let need = (ev.dt_ticks as u64) << 30;
            if self.phase_q30 < need {
                break;
            }
            self.phase_q30 -= need;
            self.queue.pop_front();
            self.pins.add(ev);
            self.fired += 1;
            n += 1;
        }
        if self.queue.is_empty() && !self.source_done {
            // Underrun: time does not run ahead of events not yet received.
            self.phase_q30 = self.phase_q30.min(1 << 31);
        }
        self.pins.output()
    }
}

/// An event job through the machine's tick: the idle DDA is ticked for its clock (status time,
/// link timeout, scheduled commands), the speed scale follows its feed override clamped to
/// 0.25..=2 (two compares), and a hold stops the playback's clock.
impl StepSource for Playback {
    #[inline]
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput {
        // Idle DDA: its idle fast path (a decrement) or one idle full tick.
        let _ = dda.tick();
        let rate = if hold { 0 } else { dda.feed_override().clamp(RATE_MIN, RATE_MAX).to_bits() };
        self.tick_at(rate)
    }

    fn idle(&self, _dda: &Dda) -> bool {
        self.done()
    }

    fn starved(&self) -> bool {
        Playback::starved(self)
    }

    /// Pins only. A late host's underrun, and the job's end, are seen on the next full tick;
    /// the playback stops its own clock when it runs dry either way.
    fn step_only_ticks(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(dt: u32, axis: u8, negative: bool) -> StepEvent {
        StepEvent { dt_ticks: dt, axis, negative }
    }

    /// Plays `evs` and returns (tick, rise mask, dir mask) of every tick with a rise.
    fn play(
        evs: &[StepEvent],
        rate: Rate,
        scale: SizeScale,
    ) -> (std::vec::Vec<(u64, u8, u8)>, Playback) {
        let mut p = Playback::new(scale);
        p.set_rate(rate);
        let mut it = evs.iter();
        let mut out = std::vec::Vec::new();
        let mut t = 0u64;
        while !p.done() && t < 10_000_000 {
            while p.free() > 0 {
                match it.next() {
                    Some(&e) => p.push(e).unwrap(),
                    None => {
                        p.finish();
                        break;
                    }
                }
            }
            t += 1;
            let o = p.tick();
            if o.rise() != 0 {
                out.push((t, o.rise(), o.dir()));
            }
        }
        (out, p)
    }

    #[test]
    fn events_fire_at_their_times_and_ties_share_a_tick() {
        let evs = [ev(100, 0, false), ev(0, 1, false), ev(50, 1, false), ev(200, 0, false)];
        let (rises, p) = play(&evs, Rate::ONE, SizeScale::ONE);
        assert_eq!(rises, vec![(100, 0b11, 0), (150, 0b10, 0), (350, 0b01, 0)]);
        assert_eq!(p.fired(), 4);
        assert_eq!(p.position(), [2, 2]);
    }

    #[test]
    fn speed_scale_divides_every_interval() {
        let evs: std::vec::Vec<_> =
            (0..400).map(|i| ev(100 + (i % 7), (i % 2) as u8, false)).collect();
        let total: u64 = evs.iter().map(|e| e.dt_ticks as u64).sum();
        for (rate, num, den) in [("0.25", 4, 1), ("0.5", 2, 1), ("1", 1, 1), ("2", 1, 2)] {
            let (rises, p) = play(&evs, Rate::lit(rate), SizeScale::ONE);
            let last = rises.last().unwrap().0;
            // Event i fires on the first tick t with t * rate >= its recorded time.
            assert_eq!(last, (total * num).div_ceil(den), "rate {rate}");
            assert_eq!(p.fired(), 400);
        }
    }

    #[test]
    fn size_scale_passes_m_per_k_radial_steps() {
        let evs: std::vec::Vec<_> = (0..240).map(|i| ev(40, 1, i >= 200)).collect();
        for (m, k) in [(1, 4), (1, 2), (3, 4), (1, 1), (2, 1), (4, 1), (4, 3)] {
            let (_, p) = play(&evs, Rate::ONE, SizeScale::new(m, k).unwrap());
            // 200 out then 40 back: net 160 recorded -> 160 m / k.
            // Net 160 recorded -> 160 m / k, within the remainder (less than one step).
            assert!((p.position()[1] * k as i64 - 160 * m as i64).abs() < k as i64, "{m}:{k}");
            let r = p.pins().rises[1];
            assert!(
                r >= 160 * m as u64 / k as u64 && r <= (240 * m as u64).div_ceil(k as u64),
                "{m}:{k}"
            );
        }
        assert!(SizeScale::new(5, 1).is_none() && SizeScale::new(1, 0).is_none());
    }

    #[test]
    fn reversal_writes_dir_a_tick_before_the_rise() {
        let mut p = Playback::new(SizeScale::ONE);
        p.push(ev(10, 0, false)).unwrap();
        p.push(ev(10, 0, true)).unwrap();
        p.finish();
        let mut log = std::vec::Vec::new();
        for t in 1..=30u64 {
            let o = p.tick();
            if o.rise() != 0 || o.dir_write() != 0 {
                log.push((t, o.rise(), o.dir_write(), o.dir()));
            }
        }
        assert_eq!(log, vec![(10, 1, 0, 0), (20, 0, 1, 1), (21, 1, 0, 1)]);
        assert!(p.done());
    }
}
