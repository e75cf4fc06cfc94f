//! The board's side of polar's link requests: its target trait filled for the link
//! firmware's [`Target`].

use super::*;
use crate::link::capabilities::Capabilities;
use crate::link::target::Target;
use crate::link::{wire, EVENTS_WAITING};
use board_contract::CopyEncoders as _;
use core::sync::atomic::Ordering::Relaxed;
use motion::machine::{MachineState, Refusal};
use motion::polar::link_messages::PolarTarget;
use motion::polar::playback::{Playback, QUEUE_DEPTH};
use rtic::Mutex;

impl<M: Mutex<T = Motion>> PolarTarget for Target<'_, M> {
    fn next_event_block(&self) -> Option<u16> {
        if self.with(|m| m.machine.source_queued()) {
            self.link.events.expected()
        } else {
            Some(0)
        }
    }
    fn queue_events(&mut self, block: &[u8], last: bool) -> Result<(), ErrorCode> {
        if self.with(|m| Capabilities::live(m)) {
            return Err(ErrorCode::OutOfState);
        }
        let fresh = !self.with(|m| m.machine.source_queued());
        let state = self.command(MachineCommand::QueueSource)?;
        if fresh {
            // The machine had no events: whatever the feed holds is a finished job's.
            self.link.events.clear();
        }
        // Checked by BoardLink against `next_event_block` and `event_credits`: a refusal here
        // is a link bug. (The machine's flag stays set: the job has nothing new to play.)
        self.link.events.push(block, last).map_err(|_| ErrorCode::Internal)?;
        EVENTS_WAITING.store(true, Relaxed);
        self.wake_feeder |= state != MachineState::Ready;
        Ok(())
    }
    fn start_playback(&mut self, scale: SizeScale) -> Result<(), ErrorCode> {
        if self.with(|m| wire::live(m)) {
            return Err(ErrorCode::OutOfState);
        }
        // Decode the first events outside the lock, from a copy (a refused start changes
        // nothing), then start the job and fill its playback in one critical section: the
        // first tick of the job already has events.
        let mut feed = self.link.events.clone();
        let mut first = [StepEvent::default(); QUEUE_DEPTH];
        let (n, finished) = feed.take(&mut first);
        let (head, _) = first.split_at(n);
        let r = self.motion.get_mut().lock(|m| {
            m.machine.command(MachineCommand::StartQueued(PLAYBACK_JOB), &mut m.dda)?;
            m.playback = Playback::new(scale);
            for &ev in head {
                // Cannot fail: a fresh playback holds QUEUE_DEPTH events.
                let _ = m.playback.push(ev);
            }
            if finished {
                m.playback.finish();
            }
            Ok(())
        });
        r.map_err(|e: Refusal| e.error_code())?;
        self.link.events = feed;
        self.wake_feeder = true;
        Ok(())
    }
    fn start_copy(&mut self, scale: SizeScale, teach: bool) -> Result<(), ErrorCode> {
        if !board::CopyEncoders::ROUTED {
            return Err(ErrorCode::Unsupported);
        }
        if !self.link.queue.is_empty() || self.link.events.blocks() != 0 {
            return Err(ErrorCode::OutOfState);
        }
        self.motion.get_mut().lock(|m| start(m, scale, teach))?;
        // A new recording (the last one's unread blocks go).
        self.link.teach.reset(teach);
        Ok(())
    }
    fn read_teach(&mut self, block: u16) -> Result<TeachChunk, ErrorCode> {
        let rec = &mut self.link.teach;
        Ok(self.motion.get_mut().lock(|m| read(rec, m, block)))
    }
    fn teach_resend(&self) -> Option<TeachChunk> {
        Some(self.with(|m| resend(&self.link.teach, m)))
    }
}
