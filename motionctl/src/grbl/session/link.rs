//! The board's link: requests, statuses and answers, the loop's link step (news, flushing the
//! planner, heartbeat).

use super::{link_err, Bridge, Pending};
use crate::grbl::protocol::alarm;
use crate::link::describe_rejection;
use crate::runner::{self, seq_at_or_after};
use anyhow::{bail, Result};
use motion::protocol::{Reply, RequestBody, Status};
use std::time::{Duration, Instant};

/// The sender went quiet this long: the planned moves end at rest and go to the board.
const QUIET_FLUSH: Duration = Duration::from_millis(20);
/// Less than this much motion left on the board: flush now rather than risk running dry.
const LOW_WATER_S: f64 = 0.06;
/// The host speaks at least this often (the board holds a job after 1 s of silence).
const HEARTBEAT: Duration = Duration::from_millis(100);

impl Bridge<'_> {
    pub(super) fn request(&mut self, body: RequestBody, what: &str) -> Result<Reply> {
        match self.s.request(body).map_err(link_err)? {
            Ok(r) => Ok(r),
            Err(r) => bail!("{what} refused: {}", describe_rejection(&r)),
        }
    }

    /// Sends `link_cfg` as the board's config (`runner::ready_board`, homing if `home` allows), the
    /// bridge's status period, and reads the board's state back. The inner error: why the board
    /// is not ready (e.g. it must be homed and may not be).
    pub(super) fn configure(
        &mut self,
        link_cfg: motion::protocol::LinkConfig,
        home: bool,
        what: &str,
    ) -> Result<Result<(), String>> {
        let say = |m: &str| eprintln!("motionctl: {m}");
        let r = runner::ready_board(&mut self.s, link_cfg, runner::Home::allowed(home), what, &say)
            .map(drop);
        runner::ask(
            &mut self.s,
            RequestBody::SetStatusPeriod { ms: crate::grbl::STATUS_MS },
            "SetStatusPeriod",
        )?;
        self.refresh()?;
        self.faults_seen = self.latest.faults;
        Ok(r)
    }

    pub(super) fn refresh(&mut self) -> Result<()> {
        let st = runner::ask_status(&mut self.s)?;
        self.latest = st;
        self.latest_at = Instant::now();
        Ok(())
    }

    pub(super) fn on_status(&mut self, st: Status) {
        if seq_at_or_after(st.next_seq, self.latest.next_seq) {
            self.latest = st;
            self.latest_at = Instant::now();
        }
    }

    pub(super) fn answers(&mut self) {
        for (seq, result) in self.s.take_answers() {
            let Some(p) = self.pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Batch { n }, Ok(_)) => self.acked += n,
                (Pending::Batch { .. }, Err(r)) => {
                    eprintln!("motionctl: the board refused segments: {}", describe_rejection(&r));
                    self.stop_wanted = true;
                    if self.alarm.is_none() {
                        self.alarm = Some(alarm::ABORT_CYCLE);
                        self.say(&format!("ALARM:{}", alarm::ABORT_CYCLE));
                        self.say("[MSG:the board refused queued motion]");
                    }
                }
                (Pending::Poll, Ok(Reply::Status(st))) => self.on_status(st),
                _ => {}
            }
        }
    }

    pub(super) fn link(&mut self) -> Result<()> {
        self.s.pump(Duration::from_millis(1)).map_err(link_err)?;
        for n in self.s.notices.drain(..) {
            eprintln!("motionctl: {n}");
        }
        while let Some(ev) = self.s.events.pop_front() {
            match ev {
                motion::protocol::HostEvent::Status(st) => self.on_status(st),
                motion::protocol::HostEvent::SessionLost(code) => {
                    bail!("{}", crate::link::LinkFailure::SessionLost(code))
                }
                _ => {}
            }
        }
        self.answers();
        let done = self.done();
        while self.popped < done && self.inflight.pop_front().is_some() {
            self.popped += 1;
        }
        if self.latest.faults != self.faults_seen {
            let bits = self.latest.faults;
            self.on_faults(bits);
        }
        if self.stop_wanted {
            // What is left of a refused job stops and is dropped.
            self.stop_wanted = false;
            self.stop_motion()?;
        }
        if self.alarm.is_some() {
            self.spindle_stop_clear();
            return Ok(());
        }

        // Flush the planner when the sender has gone quiet or the board runs low.
        if self.motion.dirty && !self.rx.has_line() {
            let quiet = self.motion.last_push.elapsed();
            let left = self.remaining_s();
            if quiet >= QUIET_FLUSH || (left < LOW_WATER_S && quiet >= Duration::from_millis(2)) {
                self.motion.flush();
            }
        }

        self.front_events()?;
        self.spindle_stop_step()?;
        self.send_segments()?;
        self.probe_check_room()?;
        self.reconcile()?;

        // Heartbeat.
        if self.s.host.sent_frames != self.last_tx.0 {
            self.last_tx = (self.s.host.sent_frames, Instant::now());
        } else if self.last_tx.1.elapsed() >= HEARTBEAT && self.s.host.window_free() > 0 {
            let seq = self.s.send(RequestBody::GetStatus).map_err(link_err)?;
            self.pending.insert(seq, Pending::Poll);
        }
        Ok(())
    }

    /// Seconds of motion left on the board and on the way (an estimate from the last status).
    pub(super) fn remaining_s(&self) -> f64 {
        let ticks: u64 =
            self.inflight.iter().map(|&t| t as u64).sum::<u64>() + self.motion.queued_ticks();
        ticks as f64 / self.tick_hz - self.latest_at.elapsed().as_secs_f64()
    }
}
