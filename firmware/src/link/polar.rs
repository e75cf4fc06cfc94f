//! Polar contouring on the link firmware: its `LinkJob` ([`Polar`]: the playback's and the copy
//! job's ticks) and the board's side of its link requests (`PolarTarget` for [`Target`]: event
//! blocks, playback, copy, teach).
//!
//! Copy-mode jobs (`motion::polar::copy_link`): `StartCopy` makes a
//! [`CopyMode`] in [`Motion`] from the encoders' counts now and starts the machine's
//! `StartCopy` in the same critical section; the tick feeds it the board's encoder counts every
//! tick through `Machine::tick_with` ([`tick`]); the status task moves taught events into
//! stream blocks ([`drain_teach`]) that `ReadTeach` hands out.
//!
//! The tick's copy work is `CopyMode::tick` (at most 2 counts per axis, compares and adds, no
//! division); the block encoding (varints, CRC) runs in the status task, never in the tick.

mod requests;

use crate::board;
use motion::machine::{Inputs, MachineCommand, TickOut};
use motion::polar::copy::CopyMode;
use motion::polar::copy_link::{
    take_batch, CopySource, TeachRead, TeachRecorder, TEACH_BATCH, TEACH_BLOCKS,
};
use motion::polar::playback::SizeScale;
use motion::polar::StepEvent;
use motion::polar::COPY_JOB;
use motion::protocol::{BlockBytes, ErrorCode, Status, TeachChunk};
use rtic::Mutex;

use super::link_job::{LinkJob, Readings, StepReadings};
use super::Motion;
use board_contract::SpindleEncoder as _;
use motion::dda::StepOutput;
use motion::polar::PLAYBACK_JOB;

/// The copy job's state in [`Motion`] (the tick owns it).
pub struct CopyState {
    /// The current (or last) copy job.
    pub mode: Option<CopyMode>,
    /// `StartCopy` started it and no abort, clear or config change dropped it since.
    pub running: bool,
    /// The encoders' counts the tick read last (arm, carriage).
    pub counts: [i32; 2],
}

impl CopyState {
    pub const fn new() -> Self {
        CopyState { mode: None, running: false, counts: [0; 2] }
    }
}

impl Default for CopyState {
    fn default() -> Self {
        Self::new()
    }
}

/// The copy job runs (the machine's source job is ours).
pub fn live(m: &Motion) -> bool {
    m.copy.running && m.machine.runs(COPY_JOB)
}

/// One tick with the encoder counts read this tick (`None`: no copy job, the caller ticks as
/// usual). A copy the machine ended (abort, fault cleared) is marked stopped here.
#[inline]
pub fn tick(m: &mut Motion, inputs: &Inputs, counts: [i32; 2]) -> Option<TickOut> {
    if !m.copy.running {
        return None;
    }
    if !m.machine.runs(COPY_JOB) {
        m.copy.running = false;
        return None;
    }
    let Motion { dda, machine, copy, .. } = m;
    let mode = copy.mode.as_mut()?;
    Some(machine.tick_with(dda, inputs, &mut CopySource { copy: mode, counts }))
}

/// `StartCopy`: the machine's command first (it refuses out of state or with anything queued),
/// then a fresh copy from the counts now, in one critical section: the next tick copies.
pub fn start(m: &mut Motion, scale: SizeScale, teach: bool) -> Result<(), ErrorCode> {
    if super::wire::live(m) || m.machine.source_queued() {
        return Err(ErrorCode::OutOfState);
    }
    m.machine
        .command(MachineCommand::StartSource(COPY_JOB), &mut m.dda)
        .map_err(|e| e.error_code())?;
    m.copy.mode = Some(CopyMode::new(m.copy.counts, scale, teach));
    m.copy.running = true;
    Ok(())
}

/// The link dropped the job (Abort, ClearFault, SetConfig, Home): the recording keeps what it
/// has and ends once the status task drained it.
pub fn drop_job(m: &mut Motion) {
    m.copy.running = false;
}

/// Taught and lost events of the current (or last) copy job.
fn counts(m: &Motion, rec: &TeachRecorder<TEACH_BLOCKS>) -> (u32, u32) {
    m.copy
        .mode
        .as_ref()
        .map_or((0, 0), |c| (c.taught_total, c.teach_overflow.saturating_add(rec.lost)))
}

/// The copy fields of `s`.
pub fn status(m: &Motion, rec: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status) {
    s.copy_running = live(m);
    s.encoder_counts = m.copy.counts;
    (s.taught_events, s.lost_events) = counts(m, rec);
}

/// The status task's teach pass: up to [`TEACH_BATCH`] taught events out of the copy (a short
/// critical section), encoded into blocks outside it; the recording ends once the copy stopped
/// and its queue is empty. Called with the link locked, so a `StartCopy` (USART task) cannot
/// reset the recorder between the pop and the push.
pub fn drain_teach(rec: &mut TeachRecorder<TEACH_BLOCKS>, motion: &mut impl Mutex<T = Motion>) {
    // Up to TEACH_PASSES batches per run (every millisecond): 256 events/ms, above the
    // simulated encoders' top rate (2 x 25 counts/ms at 100 kHz) with room to spare.
    for _ in 0..TEACH_PASSES {
        if rec.is_ended() {
            return;
        }
        let mut buf = [StepEvent::default(); TEACH_BATCH];
        let room = rec.has_room();
        let (n, stopped_and_empty) = motion.lock(|m| {
            let running = live(m);
            let Some(c) = m.copy.mode.as_mut() else { return (0, true) };
            let n = if room { take_batch(c, &mut buf) } else { 0 };
            (n, !running && c.taught_waiting() == 0)
        });
        rec.push_events(buf.get(..n).unwrap_or(&[]));
        if stopped_and_empty {
            rec.end();
        }
        if n < TEACH_BATCH {
            return;
        }
    }
}

/// Teach batches per status-task run.
const TEACH_PASSES: usize = 8;

/// `ReadTeach { block }`.
pub fn read(rec: &mut TeachRecorder<TEACH_BLOCKS>, m: &Motion, block: u16) -> TeachChunk {
    let counts = counts(m, rec);
    chunk(block, rec.read(block), counts)
}

/// A retransmitted `ReadTeach`: the block the last one asked for, nothing dropped.
pub fn resend(rec: &TeachRecorder<TEACH_BLOCKS>, m: &Motion) -> TeachChunk {
    let counts = counts(m, rec);
    let block = rec.front_seq();
    chunk(block, rec.peek(block), counts)
}

/// The reply carrying block `block` as `r` holds it, with the taught and lost counts.
fn chunk(block: u16, r: TeachRead<'_>, (taught_events, lost_events): (u32, u32)) -> TeachChunk {
    TeachChunk {
        block,
        bytes: BlockBytes::from_slice(r.bytes).unwrap_or_default(),
        ended: r.ended,
        taught_events,
        lost_events,
    }
}

/// The polar capability's link hooks: its copy jobs (this module) and its playback (the
/// machine's source job the link feeds, `Link::feed_events`).
pub struct Polar;

impl LinkJob for Polar {
    fn live(m: &Motion) -> bool {
        live(m)
    }

    fn drop_job(m: &mut Motion) {
        drop_job(m)
    }

    fn status(m: &Motion, teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status) {
        status(m, teach, s)
    }

    /// The copy encoders' counts, for Status whatever job runs.
    #[inline(always)]
    fn sense(m: &mut Motion, r: &mut Readings<'_>) {
        m.copy.counts = r.copy_counts;
    }

    /// A copy job's tick, else a playback's.
    #[inline(always)]
    fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<TickOut> {
        if let Some(out) = tick(m, r.inputs, r.copy_counts) {
            return Some(out);
        }
        if !m.machine.runs(PLAYBACK_JOB) {
            return None;
        }
        Some(m.machine.tick_with(&mut m.dda, r.inputs, &mut m.playback))
    }

    /// A playback's step-only tick, reading the spindle only if the machine grants it. A copy
    /// job takes none: it reads its encoders every tick.
    #[inline(always)]
    fn step_only_tick(m: &mut Motion, b: &mut StepReadings<'_>) -> Option<StepOutput> {
        if m.copy.running {
            return None;
        }
        let (spindle, at_rest) = (&mut *b.spindle, b.spindle_at_rest);
        let sense = || {
            if !at_rest {
                spindle.update();
            }
        };
        m.machine.fast_tick_sensing(&mut m.dda, &mut m.playback, sense)
    }
}
