//! The end of a run: a fresh status from the board, the report filled in from it and from the
//! link's counts, and the checks (segments, order hash, positions, queue).

use super::board::status_of;
use super::report::{err, RunError, RunReport};
use super::stream::{query, Stream};
use motion::protocol::RequestBody;
use motion::MAX_AXES;
use std::time::Instant;

impl Stream<'_, '_> {
    /// Verify with a fresh status: the report, its problems named.
    pub(super) fn verify(
        mut self,
        expected_steps: &[i64; MAX_AXES],
    ) -> Result<RunReport, RunError> {
        let s = &mut self.s;
        let fin = status_of(query(s, RequestBody::GetStatus, "GetStatus")?)
            .ok_or_else(|| err("the board answered GetStatus without a status"))?;
        let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
        self.progress.finish();
        let done = fin.segments_done.wrapping_sub(self.base.segments_done);
        // After a probe move the rest of the job was planned from where the axes stopped: it
        // ends where the source says, and has the segments sent less those dropped at trips.
        let probed = !self.report.probes.is_empty();
        let source_end = self.outputs.final_steps().filter(|_| probed);
        let expected_steps = source_end.as_ref().unwrap_or(expected_steps);
        let total = if probed { self.sent_segs - self.dropped } else { self.total };
        if let Some(csv) = self.opts.csv.as_mut() {
            // The log ends with the board's final state even when noise took the last periodic
            // status: this one was asked for, and answered reliably.
            let wall_ms = self.t0.elapsed().as_millis() as u64;
            let host = (s.host.retransmissions, s.stats.bad_frames_in);
            csv.row(wall_ms, &fin, done, host)
                .map_err(|e| err(format!("writing the CSV log: {e}")))?;
            csv.flush().map_err(|e| err(format!("writing the CSV log: {e}")))?;
        }
        let n_axes = self.n_axes;
        let report = &mut self.report;
        report.done = done;
        report.done_hash = fin.done_hash;
        report.positions = fin.positions[..n_axes].to_vec();
        report.expected_positions =
            (0..n_axes).map(|i| self.base.positions[i] + expected_steps[i]).collect();
        report.seconds = self.t0.elapsed().as_secs_f64();
        if let Some(st) = self.stream_start {
            report.stream_seconds =
                self.finished_at.unwrap_or_else(Instant::now).duration_since(st).as_secs_f64();
            let ack_span = self.last_ack_at.duration_since(st).as_secs_f64();
            report.acked_per_s = if ack_span > 0.0 { report.acked as f64 / ack_span } else { 0.0 };
        }
        report.frames_out = s.host.sent_frames;
        report.retransmissions = s.host.retransmissions;
        report.link_naks = s.stats.link_naks;
        report.bad_frames_in = s.stats.bad_frames_in;
        report.reconnects = s.stats.reconnects;
        report.noise = s.transport().noise_stats();
        report.board = fin.counters.since(&self.base.counters);
        report.final_outputs = fin.outputs;
        report.statuses = self.rate_count;
        if let (Some((w0, k0)), Some((w1, k1))) = (self.rate_first, self.rate_last) {
            let n = self.rate_count.saturating_sub(1) as f64;
            let wall = w1.duration_since(w0).as_secs_f64();
            let board = k1.saturating_sub(k0) as f64 / self.tick_hz;
            report.status_hz_wall = if wall > 0.0 { n / wall } else { 0.0 };
            report.status_hz_board = if board > 0.0 { n / board } else { 0.0 };
        }
        if probed {
            report.segments = total;
        }
        report.path = self.path.summary();
        report.check(total);
        self.opts.csv = None;
        if self.report.ok() {
            if let Some(j) = &self.opts.journal {
                j.finished();
            }
        }
        Ok(self.report)
    }
}
