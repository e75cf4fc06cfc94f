//! [`Link`]: the protocol session, the segment and event queues and what the feeder and the
//! status task do with them.

use core::sync::atomic::Ordering::Relaxed;

use heapless::Deque;
use motion::dda::{Prepared, Preparer};
use motion::machine::{BoardConfig, MachineState};
use motion::polar::copy_link::TeachRecorder;
use motion::polar::feed::EventFeed;
use motion::polar::StepEvent;
use motion::polar::PLAYBACK_JOB;
use motion::protocol::{BoardLink, FaultCode, FrameError, Response};
use motion::segment::SegmentError;
use motion::turning::link_requests::ZRequests;
use rtic::Mutex;

use crate::board;

use super::feed::Feed;
use super::*;

/// The protocol session and everything the link owns besides [`Motion`].
pub struct Link {
    pub board: BoardLink,
    feed: Feed,
    /// Status clock of the last valid frame from the host.
    last_frame_ms: u64,
    next_watchdog_ms: u64,
}

impl Link {
    /// `firmware` is reported in `HelloInfo`.
    pub fn new(firmware: &str, preparer: Preparer, tick_rate: board::TickRate) -> Self {
        Link {
            board: BoardLink::new(firmware, CAPABILITIES),
            feed: Feed {
                queue: Deque::new(),
                events: EventFeed::new(),
                preparer,
                tick_rate,
                clock_base_ms: 0,
                announced: 0,
                save_pending: None,
                z: ZRequests::new(),
                teach: TeachRecorder::new(),
            },
            last_frame_ms: 0,
            next_watchdog_ms: 0,
        }
    }

    /// Handles one frame from the decoder; the response must be sent. The flag is true when the
    /// feeder has work (a Start, segments for a running job, or machine background work).
    pub fn on_frame(
        &mut self,
        frame: Result<&[u8], FrameError>,
        motion: &mut impl Mutex<T = Motion>,
    ) -> (Response, bool) {
        if frame.is_ok() {
            self.last_frame_ms = self.now_ms(motion);
        }
        let mut t = Target::new(&mut self.feed, motion);
        let resp = self.board.on_frame(frame, &mut t);
        (resp, t.wake_feeder)
    }

    /// The status task's periodic work: judge the link, announce a newly latched fault, send
    /// the periodic Status when one is due. Returns the frames to send (a `Fault` first) and
    /// whether the watchdog may be fed now.
    pub fn poll(&mut self, motion: &mut impl Mutex<T = Motion>) -> ([Option<Response>; 2], bool) {
        let now_ms = self.now_ms(motion);
        let (state, latched, first, tick) = motion.lock(|m| {
            let f = m.machine.faults();
            (m.machine.state(), f.mask(), f.first(), m.dda.now())
        });
        let job = matches!(state, MachineState::Running | MachineState::Holding);
        // A job with no valid frame for the board's link timeout is a lost link (motionctl
        // sends at least every 100 ms during a job).
        let fresh = now_ms.saturating_sub(self.last_frame_ms) < board::LINK_TIMEOUT_MS;
        LINK_OK.store(!job || fresh, Relaxed);
        // Without a session nobody hears a Fault frame; the host reads the latch from its first
        // Status. Announcing it later would report a fault the host may since have cleared.
        if self.board.next_seq().is_none() {
            self.feed.announced = latched;
        }
        let fresh = latched & !self.feed.announced;
        self.feed.announced = latched;
        let fault = match first {
            Some(code) if fresh != 0 => {
                let code = if fresh & code.bit() != 0 { code } else { lowest(fresh) };
                Some(Response::Fault { code, tick })
            }
            _ => None,
        };
        let feed = now_ms >= self.next_watchdog_ms;
        if feed {
            self.next_watchdog_ms = now_ms + WATCHDOG_POLL_MS;
        }
        let t = Target::new(&mut self.feed, motion);
        let status = self.board.poll(now_ms, &t);
        ([fault, status], feed)
    }

    /// The feeder's work: the machine's background (abort after an immediate stop, homing
    /// moves), then the next segment for the DDA, prepared; `None` when there is nothing to feed.
    /// The divisions of preparing happen here, outside the `Motion` lock.
    pub fn next_prepared(
        &mut self,
        motion: &mut impl Mutex<T = Motion>,
    ) -> Option<Result<Prepared, (u32, SegmentError)>> {
        let prep = &mut self.feed.preparer;
        let queue = &mut self.feed.queue;
        let may_feed = motion.lock(|m| {
            if m.machine.wants_background() {
                m.machine.background(&mut m.dda, prep);
            }
            // A tripped probe move stopped: the rest of it goes before anything is fed (in the
            // same critical section as the abort, so no segment of it reaches the DDA).
            if m.machine.take_probe_discard() {
                queue.clear();
            }
            m.machine.may_feed() && m.dda.ready_free() > 0
        });
        if !may_feed {
            return None;
        }
        let seg = self.feed.queue.pop_front()?;
        Some(self.feed.preparer.prepare(&seg).map_err(|e| (seg.id, e)))
    }

    /// The config to persist, once the machine is at rest (no job, no homing, DDA idle): a save
    /// stalls the flash, and with it the tick, for up to half a second.
    pub fn take_save(&mut self, motion: &mut impl Mutex<T = Motion>) -> Option<BoardConfig> {
        self.feed.save_pending?;
        let at_rest = motion.lock(|m| {
            matches!(
                m.machine.state(),
                MachineState::Idle | MachineState::Ready | MachineState::Fault
            ) && m.dda.is_idle()
                && !m.machine.is_jogging()
        });
        if at_rest {
            self.feed.save_pending.take()
        } else {
            None
        }
    }

    /// The feeder's event work: moves decoded events into the running event job's playback in
    /// small batches (decoded outside the `Motion` lock) until it is full or the blocks run out;
    /// finishes it after the last block. Clears [`EVENTS_WAITING`] once nothing is left to move.
    pub fn feed_events(&mut self, motion: &mut impl Mutex<T = Motion>) {
        let events = &mut self.feed.events;
        loop {
            let room = motion.lock(|m| {
                if m.machine.runs(PLAYBACK_JOB) && !events.is_finished() {
                    m.playback.free()
                } else {
                    0
                }
            });
            if room == 0 {
                return;
            }
            let mut buf = [StepEvent::default(); EVENT_BATCH];
            let want = room.min(EVENT_BATCH);
            let (n, finished) = events.take(&mut buf[..want]);
            let (head, _) = buf.split_at(n);
            motion.lock(|m| {
                for &ev in head {
                    // Cannot fail: only this task pushes, and `room` slots were free.
                    let _ = m.playback.push(ev);
                }
                if finished {
                    m.playback.finish();
                }
            });
            if finished || n < want {
                // The stream ended, or every queued block went in: QueueEvents wakes us again.
                EVENTS_WAITING.store(false, Relaxed);
                return;
            }
        }
    }

    /// The feeder's wire-job work (segments into the DDA, stops, retrace and return moves),
    /// when the tick asked for it. Inside the `Motion` lock: the controller pushes straight
    /// into the DDA.
    pub fn feed_wire(&mut self, motion: &mut impl Mutex<T = Motion>) {
        motion.lock(|m| {
            if wire::wants_feed(m) {
                wire::feed(m);
            }
        });
    }

    /// The status task's teach work: taught events into stream blocks for `ReadTeach`.
    pub fn drain_teach(&mut self, motion: &mut impl Mutex<T = Motion>) {
        polar::drain_teach(&mut self.feed.teach, motion);
    }

    /// Milliseconds of DDA time since boot (division: never call from the tick).
    fn now_ms(&self, motion: &mut impl Mutex<T = Motion>) -> u64 {
        let (now, tick_hz) =
            motion.lock(|m| (m.dda.now(), m.machine.config().link.machine.tick_hz));
        self.feed.clock_base_ms + now * 1_000 / tick_hz.max(1) as u64
    }
}

fn lowest(bits: u32) -> FaultCode {
    FaultCode::ALL.iter().copied().find(|f| bits & f.bit() != 0).unwrap_or(FaultCode::SensorFault)
}
