//! Copy mode on the link firmware, the hardware-free parts: the copy job as a
//! [`StepSource`] for `Machine::tick_with` ([`CopySource`]), the teach recorder that turns taught
//! events into v1 stream blocks for `ReadTeach` ([`TeachRecorder`]), the 16-bit encoder counter
//! extension ([`Extend16`]) and the simulated encoders' bounded slew ([`slew_toward`]).
//!
//! Nothing lost: the recorder only takes events from the copy while it has room for the blocks
//! they can finish, so a slow host fills the copy's own teach queue, whose overflow is counted
//! (`CopyMode::teach_overflow`) and reported with every `ReadTeach` answer and `Status`.

use super::copy::CopyMode;
use super::stream::{BlockEncoder, MAX_BLOCK, MAX_DT_TICKS};
use super::StepEvent;
use crate::dda::{Dda, StepOutput};
use crate::machine::StepSource;
use heapless::{Deque, Vec};

/// Stream blocks the board holds for `ReadTeach` (about 250 bytes each).
pub const TEACH_BLOCKS: usize = 16;
/// Taught events the link task moves per pass (one short critical section).
pub const TEACH_BATCH: usize = 32;
/// Counts per tick the simulated encoders move toward the host's target (on the ticks
/// [`SIM_TICKS_PER_COUNT`] allows).
pub const SIM_SLEW_COUNTS_PER_TICK: u32 = 1;
/// Ticks per simulated encoder count: a step pin rises at most every second tick, so a template
/// at one count per 4 ticks is copied without lag, and its recording replays at speed 2 within
/// the step rate.
pub const SIM_TICKS_PER_COUNT: u32 = 4;

/// The simulated encoders (QEMU, host sim): each moves one count toward its target every
/// [`SIM_TICKS_PER_COUNT`] ticks. Interrupt rate: a countdown and two clamped adds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimEncoderSlew {
    pub counts: [i32; 2],
    countdown: u32,
}

impl SimEncoderSlew {
    pub const fn new() -> Self {
        SimEncoderSlew { counts: [0; 2], countdown: SIM_TICKS_PER_COUNT }
    }

    /// One tick toward `target`; the counts now.
    #[inline]
    pub fn tick(&mut self, target: [i32; 2]) -> [i32; 2] {
        self.countdown = self.countdown.saturating_sub(1);
        if self.countdown == 0 {
            self.countdown = SIM_TICKS_PER_COUNT;
            for (c, t) in self.counts.iter_mut().zip(target) {
                *c = slew_toward(*c, t, SIM_SLEW_COUNTS_PER_TICK);
            }
        }
        self.counts
    }
}

/// A 16-bit hardware encoder counter extended to i32: exact as long as the counter moves less
/// than 32768 counts between two reads (at a 10 kHz tick: 327 M counts/s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Extend16 {
    raw: u16,
    count: i32,
}

impl Extend16 {
    /// Starts at count 0 with the counter's current raw value.
    pub const fn new(raw: u16) -> Self {
        Extend16 { raw, count: 0 }
    }

    /// Takes a new raw reading; returns the extended count. Interrupt rate: a subtract, a sign
    /// extension and an add (wrapping: the i32 count itself wraps after 2^31 counts, which
    /// `CopyMode` handles as a wrapping counter).
    #[inline]
    pub fn update(&mut self, raw: u16) -> i32 {
        let delta = raw.wrapping_sub(self.raw) as i16 as i32;
        self.raw = raw;
        self.count = self.count.wrapping_add(delta);
        self.count
    }

    pub const fn count(&self) -> i32 {
        self.count
    }
}

/// One simulated encoder tick: `current` moves toward `target` by at most `max_step` counts
/// (wrapping difference, so a target across the i32 wrap is reached the short way).
#[inline]
pub const fn slew_toward(current: i32, target: i32, max_step: u32) -> i32 {
    let d = target.wrapping_sub(current);
    let max = if max_step > i32::MAX as u32 { i32::MAX } else { max_step as i32 };
    let step = if d > max {
        max
    } else if d < -max {
        -max
    } else {
        d
    };
    current.wrapping_add(step)
}

/// The copy job as the machine's step source for one tick: the encoder counts read this tick.
pub struct CopySource<'a> {
    pub copy: &'a mut CopyMode,
    pub counts: [i32; 2],
}

impl StepSource for CopySource<'_> {
    /// Ticks the idle DDA (its clock and feed commands), then the copy: new counts while
    /// running, none while held. Interrupt rate: `CopyMode::tick` (at most 2 counts per axis,
    /// compares and adds, no division).
    #[inline]
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput {
        let _ = dda.tick();
        if hold {
            self.copy.tick_held()
        } else {
            self.copy.tick(self.counts)
        }
    }

    /// A copy runs until the host aborts it (or a fault stops it): never done by itself.
    fn idle(&self, _dda: &Dda) -> bool {
        false
    }
}

/// What a `ReadTeach` gets: the block asked for (empty when it is not there yet, or when the
/// recording ended before it) and whether the recording is over after it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TeachRead<'a> {
    pub bytes: &'a [u8],
    /// The recording ended and nothing follows `bytes`.
    pub ended: bool,
}

/// Taught events encoded into stream blocks (block seq from 0), held until the host has
/// read them: block `n` is dropped when the host asks for block `n + 1`, so a lost answer is
/// simply asked for again.
#[derive(Clone, Debug)]
pub struct TeachRecorder<const N: usize> {
    encoder: BlockEncoder,
    blocks: Deque<Vec<u8, MAX_BLOCK>, N>,
    /// Block seq of `blocks.front()`.
    front_seq: u16,
    /// Events encoded so far.
    pub encoded: u32,
    /// Events lost here (a block with no room: cannot happen while [`Self::has_room`] is
    /// respected; counted rather than assumed).
    pub lost: u32,
    /// Idle gaps longer than the stream's dt range, shortened to `MAX_DT_TICKS`.
    pub clamped: u32,
    ended: bool,
}

impl<const N: usize> Default for TeachRecorder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TeachRecorder<N> {
    /// An ended, empty recording (what `ReadTeach` sees before any copy job).
    pub const fn new() -> Self {
        TeachRecorder {
            encoder: BlockEncoder::new(),
            blocks: Deque::new(),
            front_seq: 0,
            encoded: 0,
            lost: 0,
            clamped: 0,
            ended: true,
        }
    }

    /// A new recording (`teach`), or an ended empty one (a copy without teach).
    pub fn reset(&mut self, teach: bool) {
        *self = Self::new();
        self.ended = !teach;
    }

    /// Room for the blocks the next [`TEACH_BATCH`] events (or the final flush) can finish:
    /// three (a batch finishes at most one block; the flush at most two and the end block).
    pub fn has_room(&self) -> bool {
        N - self.blocks.len() >= 3
    }

    pub fn is_ended(&self) -> bool {
        self.ended
    }

    /// Blocks waiting for the host.
    pub fn blocks_waiting(&self) -> usize {
        self.blocks.len()
    }

    fn emit_into(blocks: &mut Deque<Vec<u8, MAX_BLOCK>, N>, lost: &mut u32, b: &[u8]) {
        let stored = Vec::from_slice(b).ok().and_then(|v| blocks.push_back(v).ok());
        if stored.is_none() {
            let events = match b.get(4..6) {
                Some(&[lo, hi]) => u16::from_le_bytes([lo, hi]) as u32,
                _ => 0,
            };
            *lost = lost.saturating_add(events);
        }
    }

    /// Encodes taught events (call only when [`Self::has_room`], at most [`TEACH_BATCH`]).
    pub fn push_events(&mut self, events: &[StepEvent]) {
        if self.ended {
            return;
        }
        let TeachRecorder { encoder, blocks, lost, clamped, encoded, .. } = self;
        for &ev in events {
            let ev = if ev.dt_ticks > MAX_DT_TICKS {
                *clamped = clamped.saturating_add(1);
                StepEvent { dt_ticks: MAX_DT_TICKS, ..ev }
            } else {
                ev
            };
            // Cannot fail: dt is in range.
            let _ = encoder.push(ev, &mut |b: &[u8]| Self::emit_into(blocks, lost, b));
            *encoded = encoded.wrapping_add(1);
        }
    }

    /// The copy ended and every taught event was pushed: flushes the last block. False (try
    /// again later) while there is no room for it.
    pub fn end(&mut self) -> bool {
        if self.ended {
            return true;
        }
        if !self.has_room() {
            return false;
        }
        let TeachRecorder { encoder, blocks, lost, .. } = self;
        encoder.finish(&mut |b: &[u8]| Self::emit_into(blocks, lost, b));
        self.ended = true;
        true
    }

    /// `ReadTeach { block }`: drops the blocks before `block` (the host has them), returns
    /// `block` if it is here. A `block` outside the held range gets an empty answer.
    pub fn read(&mut self, block: u16) -> TeachRead<'_> {
        let ahead = block.wrapping_sub(self.front_seq) as usize;
        if ahead <= self.blocks.len() {
            for _ in 0..ahead {
                self.blocks.pop_front();
            }
            self.front_seq = block;
        }
        self.peek(block)
    }

    /// `block` if held, without dropping anything (a retransmitted `ReadTeach`).
    pub fn peek(&self, block: u16) -> TeachRead<'_> {
        let at = block.wrapping_sub(self.front_seq) as usize;
        let bytes = self.blocks.iter().nth(at).map(|v| v.as_slice()).unwrap_or(&[]);
        let ended = self.ended && at + 1 >= self.blocks.len();
        TeachRead { bytes, ended }
    }

    /// The seq of the oldest block still held (the host's next read, after a retransmission).
    pub fn front_seq(&self) -> u16 {
        self.front_seq
    }
}

/// Pops up to [`TEACH_BATCH`] taught events from `copy` into `buf`; returns how many. The link
/// task calls it inside its `Motion` lock (only when [`TeachRecorder::has_room`]) and pushes the
/// events into the recorder outside it.
pub fn take_batch(copy: &mut CopyMode, buf: &mut [StepEvent; TEACH_BATCH]) -> usize {
    let mut n = 0;
    while n < TEACH_BATCH {
        let Some(ev) = copy.take_taught() else { break };
        if let Some(slot) = buf.get_mut(n) {
            *slot = ev;
        }
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::super::playback::SizeScale;
    use super::super::stream::{decode_all, net_steps};
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Any sequence of counter moves below half the 16-bit range extends exactly.
        #[test]
        fn extend16_tracks_a_wide_count(start in any::<u16>(),
                                        moves in proptest::collection::vec(-32767i32..=32767, 1..200)) {
            let mut e = Extend16::new(start);
            let mut truth: i64 = 0;
            for d in moves {
                truth += d as i64;
                let raw = (start as i64 + truth).rem_euclid(65536) as u16;
                prop_assert_eq!(e.update(raw) as i64, truth);
            }
        }

        #[test]
        fn slew_moves_at_most_max_and_reaches_target(cur in any::<i32>(), tgt in any::<i32>(), max in 1u32..5) {
            let next = slew_toward(cur, tgt, max);
            let moved = next.wrapping_sub(cur).unsigned_abs();
            prop_assert!(moved <= max);
            let left = tgt.wrapping_sub(cur).unsigned_abs();
            prop_assert!(next == tgt || moved == max, "left {left}");
        }
    }

    /// Copies a trace through the recorder as the firmware does (a slow reader pulling one
    /// block per `read_every` ticks) and returns the bytes read, the copy and the recorder.
    fn record(
        ticks: u32,
        read_every: u32,
        counts_at: impl Fn(u32) -> [i32; 2],
    ) -> (std::vec::Vec<u8>, CopyMode, TeachRecorder<4>) {
        let mut c = CopyMode::new(counts_at(0), SizeScale::new(3, 2).unwrap(), true);
        let mut rec = TeachRecorder::<4>::new();
        rec.reset(true);
        let mut out = std::vec::Vec::new();
        let mut next_block = 0u16;
        let mut buf = [StepEvent::default(); TEACH_BATCH];
        let mut t = 0;
        while t < ticks || !rec.is_ended() {
            t += 1;
            c.tick(counts_at(t.min(ticks)));
            if t > ticks && c.taught_waiting() == 0 {
                rec.end();
            }
            if rec.has_room() {
                let n = take_batch(&mut c, &mut buf);
                rec.push_events(&buf[..n]);
            }
            if t % read_every == 0 || t > ticks {
                let r = rec.read(next_block);
                if !r.bytes.is_empty() {
                    out.extend_from_slice(r.bytes);
                    next_block += 1;
                }
            }
            assert!(t < ticks + 100_000, "recording never ended");
        }
        // Let the step pins finish, then drain what is left after the end.
        for _ in 0..100 {
            c.tick(counts_at(ticks));
        }
        loop {
            let r = rec.read(next_block);
            if r.bytes.is_empty() {
                break;
            }
            out.extend_from_slice(r.bytes);
            next_block += 1;
        }
        (out, c, rec)
    }

    #[test]
    fn recorder_keeps_every_event_when_the_host_keeps_up() {
        let counts_at = |t: u32| [(t / 5) as i32, -((t / 3) as i32)];
        let (bytes, c, rec) = record(30_000, 10, counts_at);
        let (sum, n) = net_steps(&bytes);
        assert_eq!(c.teach_overflow, 0);
        assert_eq!(rec.lost, 0);
        assert_eq!(n, c.taught_total);
        assert_eq!(n, rec.encoded);
        assert_eq!(sum, [6_000, -10_000]);
        // The copy's r output is scaled 3:2 from the same counts.
        assert_eq!(c.position(), [6_000, -15_000]);
    }

    #[test]
    fn a_host_that_never_reads_loses_events_and_the_count_says_how_many() {
        // Irregular intervals (no long runs to fold): theta moves on ticks a hash picks.
        let mut theta = std::vec![0i32; 40_001];
        for t in 1..=40_000usize {
            let h = (t as u32).wrapping_mul(2_654_435_761) >> 29;
            theta[t] = theta[t - 1] + (h < 3) as i32;
        }
        let total = theta[40_000] as u64;
        let (bytes, c, rec) = record(40_000, u32::MAX, |t| [theta[t as usize], 0]);
        let (_, n) = net_steps(&bytes);
        assert!(c.teach_overflow > 0);
        // Every event is either in the stream or counted as lost: nothing vanishes silently.
        assert_eq!(n as u64 + c.teach_overflow as u64 + rec.lost as u64, total);
    }

    #[test]
    fn read_answers_the_same_block_again_until_the_next_is_asked() {
        let mut rec = TeachRecorder::<4>::new();
        rec.reset(true);
        let evs: std::vec::Vec<StepEvent> = (0..400u32)
            .map(|i| StepEvent { dt_ticks: i * 7 % 13, axis: (i % 2) as u8, negative: i % 3 == 0 })
            .collect();
        for chunk in evs.chunks(TEACH_BATCH) {
            assert!(rec.has_room());
            rec.push_events(chunk);
        }
        assert!(rec.end());
        let first = rec.read(0).bytes.to_vec();
        assert!(!first.is_empty());
        assert_eq!(rec.read(0).bytes, &first[..]);
        assert_eq!(rec.peek(0).bytes, &first[..]);
        let mut all = first.clone();
        let mut b = 1;
        loop {
            let r = rec.read(b);
            all.extend_from_slice(r.bytes);
            if r.ended {
                break;
            }
            b += 1;
        }
        // Asking for an old block after it was dropped gets nothing (the host had it).
        assert!(rec.read(0).bytes.is_empty());
        let mut back = std::vec::Vec::new();
        decode_all(&all, |e| back.push(e)).unwrap();
        assert_eq!(back, evs);
    }

    #[test]
    fn copy_source_holds_without_taking_counts() {
        let mut c = CopyMode::new([0, 0], SizeScale::ONE, false);
        let mut dda = Dda::new(&crate::polar::job::link_config().machine).unwrap();
        let mut src = CopySource { copy: &mut c, counts: [5, -3] };
        for _ in 0..20 {
            src.tick(&mut dda, true);
        }
        assert_eq!(src.copy.taken(), [0, 0]);
        for _ in 0..20 {
            src.tick(&mut dda, false);
        }
        assert_eq!(src.copy.taken(), [5, -3]);
        assert_eq!(src.copy.position(), [5, -3]);
        assert!(!src.idle(&dda));
    }

    /// The copy job through the machine: StartCopy from Ready, steps counted by the machine,
    /// Hold stops taking counts, Resume catches up, Abort ends the job; segments are refused
    /// while it runs.
    #[test]
    fn copy_job_runs_through_the_machine_until_abort() {
        use crate::machine::{BoardConfig, Inputs, Machine, MachineCommand, MachineState};
        use crate::protocol::HomingConfig;
        // The rig has no switches: home where it stands (the real machine:
        // `polar::job::homing_config`).
        let cfg = BoardConfig::with_homing(crate::polar::job::link_config(), &HomingConfig::NONE);
        let (mut m, mut dda, mut prep) = crate::machine::homed(cfg);
        m.command(MachineCommand::StartSource(crate::polar::COPY_JOB), &mut dda).unwrap();
        assert_eq!(m.state(), MachineState::Running);
        assert!(m.command(MachineCommand::StartSource(crate::polar::COPY_JOB), &mut dda).is_err());
        assert!(m.command(MachineCommand::Start, &mut dda).is_err());
        let mut copy = CopyMode::new([0, 0], SizeScale::new(3, 2).unwrap(), false);
        let tick = |m: &mut Machine, dda: &mut Dda, copy: &mut CopyMode, counts| {
            m.tick_with(dda, &Inputs::QUIET, &mut CopySource { copy, counts });
        };
        for _ in 0..200 {
            tick(&mut m, &mut dda, &mut copy, [40, 20]);
        }
        assert_eq!(m.state(), MachineState::Running);
        assert_eq!(&m.positions()[..2], &[40, 30]);
        m.command(MachineCommand::Hold, &mut dda).unwrap();
        for _ in 0..200 {
            tick(&mut m, &mut dda, &mut copy, [60, 20]);
        }
        assert_eq!(&m.positions()[..2], &[40, 30], "held: no new counts taken");
        m.command(MachineCommand::Resume, &mut dda).unwrap();
        for _ in 0..200 {
            tick(&mut m, &mut dda, &mut copy, [60, 20]);
        }
        assert_eq!(&m.positions()[..2], &[60, 30]);
        assert_eq!(m.state(), MachineState::Running, "a copy never ends by itself");
        m.command(MachineCommand::Abort, &mut dda).unwrap();
        m.background(&mut dda, &mut prep);
        assert!(m.source_job().is_none());
        assert_eq!(m.state(), MachineState::Ready);
    }
}
