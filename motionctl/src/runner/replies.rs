//! What the board said during a run: the answers to the requests in flight, then its status
//! reports, faults and a lost session.

use super::board::{fault_names, seq_at_or_after, status_of};
use super::report::{err, RunError};
use super::stream::{Pending, Stream};
use crate::link::{describe_rejection, LinkFailure};
use motion::protocol::{ErrorCode, HostEvent, Status};
use std::time::Instant;

impl Stream<'_, '_> {
    /// Answers: batches acknowledged or refused, Start, feed commands, polled statuses.
    pub(super) fn take_answers(&mut self) -> Result<(), RunError> {
        for (seq, result) in self.s.take_answers() {
            let Some(p) = self.pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Batch { n }, Ok(_)) => {
                    self.report.acked += n;
                    self.last_ack_at = Instant::now();
                    self.clean_acks += 1;
                }
                (Pending::Batch { .. }, Err(r)) => {
                    if r.code == ErrorCode::QueueFull {
                        self.report.queue_full_naks += 1;
                    }
                    // In Fault, say which: the operator's next step depends on it.
                    let faults = match self.latest.faults {
                        0 => String::new(),
                        bits => format!("; latched faults: {}", fault_names(bits)),
                    };
                    return Err(err(format!(
                        "the board refused segments after {} acknowledged: {}{faults}",
                        self.report.acked,
                        describe_rejection(&r)
                    )));
                }
                (Pending::Start, Ok(_)) => {
                    self.start_seq = None;
                    self.last_start_seq = Some(seq);
                    self.ever_started = true;
                }
                (Pending::Start, Err(r)) if r.code == ErrorCode::OutOfState => {
                    // Already moving: nothing to do.
                    self.start_seq = None;
                    self.last_start_seq = Some(seq);
                }
                (Pending::Start, Err(r)) => {
                    return Err(err(format!("the board refused Start: {}", describe_rejection(&r))))
                }
                (Pending::Feed(what), Err(r)) => {
                    self.say(&format!("feed command {what} refused: {}", describe_rejection(&r)))
                }
                (Pending::Feed(_), Ok(_)) => {}
                (Pending::Poll, Ok(reply)) => {
                    self.poll_in_flight = false;
                    if let Some(st) = status_of(reply) {
                        if st.faults == 0 && seq_at_or_after(st.next_seq, self.latest.next_seq) {
                            self.report.max_queue_depth =
                                self.report.max_queue_depth.max(st.queue_depth);
                            let done = self.job_done(&st);
                            self.path.observe(&st, done, self.probing.is_some());
                            self.latest = st;
                        }
                    }
                }
                (Pending::Poll, Err(_)) => self.poll_in_flight = false,
            }
        }
        Ok(())
    }

    /// Everything else the board said.
    pub(super) fn take_board_events(&mut self) -> Result<(), RunError> {
        let total = self.total;
        while let Some(ev) = self.s.events.pop_front() {
            match ev {
                HostEvent::Status(st) => self.take_status(st)?,
                // A fault announced before this job's first status (e.g. the ConfigMissing a
                // fresh board latched at boot, cleared above) is history, not this job's.
                HostEvent::Fault { code, tick } if tick < self.base.tick => {
                    self.say(&format!("note: earlier board fault {} at tick {tick}", code.name()));
                }
                HostEvent::Fault { code, tick } => {
                    return Err(err(format!(
                        "{}board fault {} ({}) at tick {tick}, after {} of {total} segments",
                        self.probe_context(),
                        code.name(),
                        code.description(),
                        self.job_done(&self.latest)
                    )));
                }
                HostEvent::SessionLost(code) => {
                    let why = LinkFailure::SessionLost(code);
                    return Err(err(format!(
                        "{why}; the job cannot resume safely ({} of {total} segments were done \
                         at the last report): home the machine and run the job again",
                        self.job_done(&self.latest)
                    )));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// A periodic status: the queue and credit extremes, the CSV log, the status rate.
    fn take_status(&mut self, st: Status) -> Result<(), RunError> {
        let report = &mut self.report;
        report.max_queue_depth = report.max_queue_depth.max(st.queue_depth);
        report.min_credits = report.min_credits.min(st.credits);
        report.max_credits = report.max_credits.max(st.credits);
        let done = self.job_done(&st);
        if let Some(csv) = self.opts.csv.as_mut() {
            let wall_ms = self.t0.elapsed().as_millis() as u64;
            let host = (self.s.host.retransmissions, self.s.stats.bad_frames_in);
            csv.row(wall_ms, &st, done, host)
                .map_err(|e| err(format!("writing the CSV log: {e}")))?;
        }
        if self.ever_started && self.finished_at.is_none() {
            let now = Instant::now();
            self.rate_first.get_or_insert((now, st.tick));
            self.rate_last = Some((now, st.tick));
            self.rate_count += 1;
            self.start_tick.get_or_insert(st.tick);
        }
        if st.faults != 0 {
            return Err(err(format!(
                "{}the board faulted ({}) after {done} of {} segments",
                self.probe_context(),
                fault_names(st.faults),
                self.total
            )));
        }
        self.path.observe(&st, done, self.probing.is_some());
        self.latest = st;
        Ok(())
    }
}
