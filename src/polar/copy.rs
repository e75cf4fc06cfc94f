//! Copy mode (the template digitizer driving the machine live): two encoder counts, arm angle and
//! carriage radius, become steps on theta and r with m/k radial scaling, and "teach" records the
//! encoder events with their tick intervals for the host to save as a stream.

use super::playback::{SizeScale, StepPins};
use super::StepEvent;
use crate::dda::StepOutput;
use heapless::Deque;

/// Encoder counts taken per axis per tick; a larger jump is spread over the next ticks.
pub const MAX_COUNTS_PER_TICK: u32 = 2;
/// Taught events waiting for the link task to encode them.
pub const TEACH_DEPTH: usize = 128;

/// Live copy from encoder counts, optionally recording.
#[derive(Clone, Debug)]
pub struct CopyMode {
    /// Encoder counts already turned into steps (theta, r).
    taken: [i32; 2],
    pins: StepPins,
    teach: bool,
    /// Ticks since the last taught event.
    since_ticks: u32,
    taught: Deque<StepEvent, TEACH_DEPTH>,
    /// Events lost because the teach queue was full (the recording is then incomplete).
    pub teach_overflow: u32,
    /// Events recorded (queued for the link task), since the start.
    pub taught_total: u32,
}

impl CopyMode {
    /// Starts from the encoders' current counts (they define the home).
    pub const fn new(counts: [i32; 2], scale: SizeScale, teach: bool) -> Self {
        CopyMode {
            taken: counts,
            pins: StepPins::new(scale),
            teach,
            since_ticks: 0,
            taught: Deque::new(),
            teach_overflow: 0,
            taught_total: 0,
        }
    }

    /// One tick: read both encoder counters (wrapping hardware counters are fine), turn up to
    /// [`MAX_COUNTS_PER_TICK`] counts per axis into steps, record them when teaching.
    #[inline]
    pub fn tick(&mut self, counts: [i32; 2]) -> StepOutput {
        self.since_ticks = self.since_ticks.saturating_add(1);
        for a in 0..2 {
            let mut n = 0;
            while n < MAX_COUNTS_PER_TICK {
                let d = counts[a].wrapping_sub(self.taken[a]);
                if d == 0 {
                    break;
                }
                let negative = d < 0;
                self.taken[a] = self.taken[a].wrapping_add(if negative { -1 } else { 1 });
                let ev = StepEvent { dt_ticks: self.since_ticks, axis: a as u8, negative };
                self.pins.add(ev);
                if self.teach {
                    if self.taught.push_back(ev).is_err() {
                        self.teach_overflow = self.teach_overflow.saturating_add(1);
                    } else {
                        self.taught_total = self.taught_total.wrapping_add(1);
                    }
                    self.since_ticks = 0;
                }
                n += 1;
            }
        }
        self.pins.output()
    }

    /// One tick while the machine holds: no new encoder counts are taken (the template may move
    /// on; [`CopyMode::tick`] catches up at its bounded rate after the resume), steps already
    /// taken finish, and the teach clock keeps running (the recording keeps real time).
    #[inline]
    pub fn tick_held(&mut self) -> StepOutput {
        self.since_ticks = self.since_ticks.saturating_add(1);
        self.pins.output()
    }

    /// Encoder counts turned into steps so far (theta, r): where the template was, as far as
    /// the copy has followed it.
    pub fn taken(&self) -> [i32; 2] {
        self.taken
    }

    /// Events recorded so far would be in [`CopyMode::take_taught`]; this is how many wait.
    pub fn taught_waiting(&self) -> usize {
        self.taught.len()
    }

    /// The next taught event, for the link task's [`super::stream::BlockEncoder`].
    pub fn take_taught(&mut self) -> Option<StepEvent> {
        self.taught.pop_front()
    }

    /// Every count seen so far (`counts`) is taken and stepped: the tool is where the template is.
    pub fn caught_up(&self, counts: [i32; 2]) -> bool {
        self.taken == counts && self.pins.idle()
    }

    /// Net steps emitted per axis (theta, r), after the size scale.
    pub fn position(&self) -> [i64; 2] {
        self.pins.position
    }
}

#[cfg(test)]
mod tests {
    use super::super::playback::Playback;
    use super::super::stream::{decode_all, BlockEncoder};
    use super::*;
    use crate::segment::Rate;

    #[test]
    fn copy_follows_encoders_scales_r_and_teach_replays_at_half_speed() {
        // A synthetic template trace: theta counts up 1 per 37 ticks, r oscillates.
        let counts_at = |t: u32| -> [i32; 2] {
            let th = (t / 37) as i32;
            let r = ((t as f64 / 900.0).sin() * 300.0) as i32;
            [th, r]
        };
        let mut c = CopyMode::new(counts_at(0), SizeScale::new(2, 1).unwrap(), true);
        let mut bytes = std::vec::Vec::new();
        let mut enc = BlockEncoder::new();
        let mut rises_live = std::vec::Vec::new();
        for t in 1..=20_000u32 {
            let o = c.tick(counts_at(t));
            if o.rise() != 0 {
                rises_live.push(t);
            }
            while let Some(e) = c.take_taught() {
                enc.push(e, &mut |b: &[u8]| bytes.extend_from_slice(b)).unwrap();
            }
        }
        enc.finish(&mut |b: &[u8]| bytes.extend_from_slice(b));
        let end = counts_at(20_000);
        // Let the pins drain.
        for _ in 0..2_000 {
            c.tick(end);
        }
        assert_eq!(c.position(), [end[0] as i64, 2 * end[1] as i64]);
        assert_eq!(c.teach_overflow, 0);
        // Replay the taught stream at half speed, scale 1: same net counts, twice the time.
        let mut evs = std::vec::Vec::new();
        decode_all(&bytes, |e| evs.push(e)).unwrap();
        let mut p = Playback::new(SizeScale::ONE);
        p.set_rate(Rate::lit("0.5"));
        let mut it = evs.iter();
        let mut t = 0u64;
        let mut last_rise = 0;
        while !p.done() && t < 1_000_000 {
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
            if p.tick().rise() != 0 {
                last_rise = t;
            }
        }
        assert_eq!(p.position(), [end[0] as i64, end[1] as i64]);
        let taught_end: u64 = evs.iter().map(|e| e.dt_ticks as u64).sum();
        assert!(
            last_rise >= 2 * taught_end && last_rise <= 2 * taught_end + 3,
            "{last_rise} vs {taught_end}"
        );
    }
}
