//! The run itself: connect and configure, then one loop that reads what the board said, sends
//! segments as credits allow, starts the board, keeps the link alive and schedules the feed
//! commands, until everything sent is done; then the checks.

use super::board::{axes_of, link_config, ready_board, seq_at_or_after, status_of, Home};
use super::options::RunOptions;
use super::outputs::{peek, Outputs, Tagged, Whereabouts};
use super::path_check::PathCheck;
use super::report::{err, link_err, RunError, RunReport};
use crate::convert::Program;
use crate::job::Job;
use crate::link::{describe_rejection, Session};
use crate::plan::Output;
use crate::progress::Progress;
use crate::transport::Transport;
use motion::dda::Command;
use motion::machine::{MachineState, ProbeKind};
use motion::protocol::{
    ProgramOutputs, Reply, RequestBody, SegmentBatch, Status, MAX_SEGMENTS_PER_FRAME,
};
use motion::segment::order_hash;
use motion::{Rate, MAX_AXES};
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// A request in flight, for its answer.
pub(super) enum Pending {
    Batch {
        n: u32,
    },
    Start,
    Feed(&'static str),
    /// GetStatus while starved of credits.
    Poll,
}

/// Shortest interval between credit polls.
const POLL_EVERY: Duration = Duration::from_millis(10);
/// Longest the host stays silent during a job: the board holds the job and latches LinkLost
/// after `LINK_TIMEOUT_MS` (1 s of machine time on the real board) without a valid frame.
pub const HEARTBEAT_EVERY: Duration = Duration::from_millis(100);

/// Connects, configures and streams `outputs`; `expected_steps` = the host model's final
/// positions (steps from the job's start).
pub fn run(
    transport: &mut dyn Transport,
    job: &Job,
    program: &Program,
    outputs: &[Output],
    expected_steps: &[i64; MAX_AXES],
    opts: RunOptions,
) -> Result<RunReport, RunError> {
    run_outputs(transport, job, program, Outputs::planned(outputs), expected_steps, opts)
}

/// [`run`] with the outputs pulled from `outputs` as the link takes them (a stream planned
/// while it runs). `program` gives the machine and the feed commands; its items are not read.
pub fn run_outputs(
    transport: &mut dyn Transport,
    job: &Job,
    program: &Program,
    outputs: Outputs<'_>,
    expected_steps: &[i64; MAX_AXES],
    opts: RunOptions,
) -> Result<RunReport, RunError> {
    let mut stream = Stream::connect(transport, job, program, outputs, opts)?;
    while !stream.step()? {}
    stream.verify(expected_steps)
}

/// A probe move under way.
pub(super) struct Probing {
    pub(super) kind: ProbeKind,
    pub(super) line: Option<usize>,
    /// Segments of the job done, and the order hash expected, when it was armed.
    pub(super) done_at_arm: u32,
    pub(super) hash_at_arm: u32,
    /// The probe move's segment ids, as sent.
    pub(super) ids: Vec<u32>,
    /// The seq of its `Start`, once sent.
    pub(super) start_seq: Option<u32>,
}

/// A run under way: the link, what is left to send, and what the loop has learnt so far.
pub(super) struct Stream<'t, 'o> {
    // In the order a run has always dropped them in: the link, the progress bar, the options
    // (the CSV log, the journal), the outputs.
    pub(super) s: Session<'t>,
    pub(super) progress: Progress,
    pub(super) opts: RunOptions,
    pub(super) outputs: Outputs<'o>,
    pub(super) report: RunReport,
    pub(super) t0: Instant,
    pub(super) n_axes: usize,
    /// Segments in the job.
    pub(super) total: u32,
    pub(super) tick_hz: f64,
    /// The board's status before the job, and the latest one.
    pub(super) base: Status,
    pub(super) latest: Status,
    pub(super) pending: HashMap<u32, Pending>,
    whereabouts: Whereabouts,
    pub(super) sent_segs: u32,
    last_batch_seq: Option<u32>,
    pub(super) start_seq: Option<u32>,
    pub(super) last_start_seq: Option<u32>,
    pub(super) ever_started: bool,
    pub(super) start_tick: Option<u64>,
    feed_cmds: Vec<(u64, Command)>,
    feed_next: usize,
    batch_limit: usize,
    pub(super) clean_acks: u32,
    seen_link_naks: u64,
    pub(super) stream_start: Option<Instant>,
    pub(super) last_ack_at: Instant,
    /// Status-rate window: (first wall, first tick), (last wall, last tick), count.
    pub(super) rate_first: Option<(Instant, u64)>,
    pub(super) rate_last: Option<(Instant, u64)>,
    pub(super) rate_count: u64,
    pub(super) pause_wait: Option<mpsc::Receiver<()>>,
    /// A dwell under way: when it ends.
    pub(super) dwell_until: Option<Instant>,
    pub(super) finished_at: Option<Instant>,
    pub(super) poll_in_flight: bool,
    last_tx: (u64, Instant),
    last_poll: Instant,
    /// The spindle and coolant as the board has them (switched in program order from here).
    pub(super) switched: ProgramOutputs,
    /// (name, steps per mm) of the job's axes.
    pub(super) axes: Vec<(String, f64)>,
    /// A probe move under way, and the segments probe moves dropped at their trips.
    pub(super) probing: Option<Probing>,
    pub(super) dropped: u32,
    /// Every status report against the planned path.
    pub(super) path: PathCheck,
}

impl<'t, 'o> Stream<'t, 'o> {
    /// Hello, state check, config, status stream.
    fn connect(
        transport: &'t mut dyn Transport,
        job: &Job,
        program: &Program,
        outputs: Outputs<'o>,
        opts: RunOptions,
    ) -> Result<Self, RunError> {
        let t0 = Instant::now();
        let axes = axes_of(job);
        let n_axes = axes.len();
        let total: u32 = outputs.segments;
        let progress = Progress::new(total as u64, axes.clone(), opts.progress);
        let mut s = Session::new(transport, opts.host);
        s.interrupt = opts.interrupt.clone();
        let say = |p: &Progress, m: &str| p.println(&format!("motionctl: {m}"));

        let info = s.connect().map_err(link_err)?;
        say(
            &progress,
            &format!(
                "connected to {}: firmware {:?}, protocol v{}, queue {} segments, window {}",
                s.describe(),
                info.firmware.as_str(),
                info.version,
                info.queue_capacity,
                info.max_window
            ),
        );
        let want = link_config(job, program);
        let homing = job.machine.homing();
        let zero_here = |why: &str| progress.suspend(|| opts.zero_here.confirm(why));
        let home = Home::Switches { homing: &homing, allowed: opts.home, zero_here: &zero_here };
        ready_board(&mut s, want, home, "job's machine", &|m| say(&progress, m)).map_err(|e| {
            let why = want.validate().err().map(|e| format!(" ({e:?})")).unwrap_or_default();
            err(format!("{e}{why}"))
        })?;
        query(
            &mut s,
            RequestBody::SetStatusPeriod { ms: opts.status_period_ms },
            "SetStatusPeriod",
        )?;
        s.streaming = opts.status_period_ms > 0;
        let base = status_of(query(&mut s, RequestBody::GetStatus, "GetStatus")?)
            .ok_or_else(|| err("the board answered GetStatus without a status"))?;
        if base.positions[..n_axes].iter().any(|&p| p != 0) {
            say(
                &progress,
                &format!(
                    "note: the board is not at 0 ({:?} steps); the job runs relative to there",
                    &base.positions[..n_axes]
                ),
            );
        }
        let tick_hz = program.config.tick_hz.max(1) as f64;
        let sim_probe = opts.sim_probe;

        let report = RunReport {
            segments: total,
            capacity: info.queue_capacity,
            min_credits: u16::MAX,
            expected_hash: base.done_hash,
            ..RunReport::default()
        };
        let whereabouts = Whereabouts::new(
            outputs.planned_ticks,
            outputs.model_ticks,
            program.config.tick_hz.max(1) as f64,
        );
        let mut feed_cmds: Vec<(u64, Command)> = program.commands.clone();
        feed_cmds.sort_by_key(|c| c.0);
        let batch_limit = opts.max_batch.clamp(1, MAX_SEGMENTS_PER_FRAME);
        let axis_names = axes.iter().map(|a| a.0.clone()).collect();
        let path = PathCheck::new(base.positions, axis_names, outputs.label.clone());
        let last_tx = (s.host.sent_frames, Instant::now());
        Ok(Stream {
            s,
            progress,
            opts,
            outputs,
            report,
            t0,
            n_axes,
            total,
            tick_hz,
            latest: base.clone(),
            switched: ProgramOutputs::from_bits(base.outputs),
            base,
            pending: HashMap::new(),
            whereabouts,
            sent_segs: 0,
            last_batch_seq: None,
            start_seq: None,
            last_start_seq: None,
            ever_started: false,
            start_tick: None,
            feed_cmds,
            feed_next: 0,
            batch_limit,
            clean_acks: 0,
            seen_link_naks: 0,
            stream_start: None,
            last_ack_at: Instant::now(),
            rate_first: None,
            rate_last: None,
            rate_count: 0,
            pause_wait: None,
            dwell_until: None,
            finished_at: None,
            poll_in_flight: false,
            last_tx,
            last_poll: Instant::now(),
            axes,
            probing: None,
            dropped: 0,
            path,
        })
        .and_then(|mut stream| {
            if let Some(sim) = sim_probe {
                stream.set_sim_probe(sim, &program.steps_per_mm)?;
            }
            Ok(stream)
        })
    }

    pub(super) fn say(&self, m: &str) {
        self.progress.println(&format!("motionctl: {m}"));
    }

    /// Segments of this job that `st` shows done, counting those probe moves dropped as done
    /// (they never will be).
    pub(super) fn job_done(&self, st: &Status) -> u32 {
        st.segments_done.wrapping_sub(self.base.segments_done).wrapping_add(self.dropped)
    }

    /// Segments the job has: the checked count, or, once a probe move has replanned the rest,
    /// those sent.
    pub(super) fn segments_expected(&self) -> u32 {
        if self.report.probes.is_empty() {
            self.total
        } else {
            self.sent_segs
        }
    }

    /// The next output, not taken.
    pub(super) fn peek(&mut self) -> Result<Option<Tagged>, RunError> {
        peek(&mut self.outputs, &mut self.s, &self.latest, &self.base)
    }

    fn segment_next(&mut self) -> Result<bool, RunError> {
        Ok(matches!(self.peek()?, Some((Output::Segment(_), _))))
    }

    /// One pass of the loop; true once the job is done.
    fn step(&mut self) -> Result<bool, RunError> {
        self.s.pump(Duration::from_millis(5)).map_err(link_err)?;
        let notices: Vec<String> = self.s.notices.drain(..).collect();
        for n in notices {
            self.say(&n);
        }
        self.check_interrupt()?;
        self.take_answers()?;
        self.take_board_events()?;
        self.adapt_batch_limit();
        self.handle_events()?;
        self.send_batches()?;
        self.poll_status()?;
        self.start_if_ready()?;
        self.send_feed_commands()?;
        self.show_progress();
        self.all_done()
    }

    fn check_interrupt(&mut self) -> Result<(), RunError> {
        if !self.opts.interrupt.as_ref().is_some_and(|f| f.load(Ordering::SeqCst)) {
            return Ok(());
        }
        let aborted = matches!(self.s.request(RequestBody::Abort), Ok(Ok(_)));
        // An operator's stop stops the spindle and coolant too (the board's Abort stops
        // motion only).
        if self.switched != ProgramOutputs::OFF {
            let _ = self.s.request(RequestBody::SetProgramOutputs(ProgramOutputs::OFF));
        }
        Err(err(format!(
            "interrupted: {} sent to the board; {} of {} segments were done",
            if aborted { "Abort" } else { "Abort could not be" },
            self.job_done(&self.latest),
            self.total
        )))
    }

    /// Shrink batches while the link is noisy (a garbled batch costs a retransmission of the
    /// whole window), grow them back when it is clean.
    fn adapt_batch_limit(&mut self) {
        if self.s.stats.link_naks > self.seen_link_naks {
            self.seen_link_naks = self.s.stats.link_naks;
            self.batch_limit = (self.batch_limit / 2).max(1);
            self.clean_acks = 0;
        } else if self.clean_acks >= 16 {
            self.batch_limit =
                (self.batch_limit + 1).min(self.opts.max_batch.clamp(1, MAX_SEGMENTS_PER_FRAME));
            self.clean_acks = 0;
        }
    }

    /// Segments, as credits and the window allow.
    fn send_batches(&mut self) -> Result<(), RunError> {
        while self.s.host.window_free() > 0 {
            let mut batch = SegmentBatch::default();
            let credits = self.s.host.segment_credits() as usize;
            let room = self.batch_limit.min(credits);
            while batch.len() < room {
                let Some((Output::Segment(seg), line)) = self.peek()? else {
                    break;
                };
                if batch.push(seg).is_err() {
                    break;
                }
                self.whereabouts.sent(line, &seg);
                self.path.sent(&seg, line);
                self.outputs.advance();
            }
            if batch.is_empty() {
                break;
            }
            let n = batch.len() as u32;
            let ids: Vec<u32> = batch.iter().map(|g| g.id).collect();
            if let Some(p) = self.probing.as_mut() {
                p.ids.extend_from_slice(&ids);
            }
            let seq = self.s.send(RequestBody::QueueSegments(batch)).map_err(link_err)?;
            for id in ids {
                self.report.expected_hash = order_hash(self.report.expected_hash, id);
            }
            self.pending.insert(seq, Pending::Batch { n });
            self.sent_segs += n;
            self.last_batch_seq = Some(seq);
            self.stream_start.get_or_insert_with(Instant::now);
        }
        Ok(())
    }

    /// A status asked for: when starved of credits, and as a heartbeat.
    fn poll_status(&mut self) -> Result<(), RunError> {
        // Starved of credits with segments to send: ask instead of waiting for the stream.
        let more = self.segment_next()?;
        if more
            && !self.poll_in_flight
            && self.s.host.segment_credits() == 0
            && self.s.host.window_free() > 0
            && self.last_poll.elapsed() >= POLL_EVERY
        {
            self.send_poll()?;
        }

        // Heartbeat: a job the host has gone quiet on (everything sent, long segments running)
        // still hears from it, so the board does not take the silence for a lost link.
        if self.s.host.sent_frames != self.last_tx.0 {
            self.last_tx = (self.s.host.sent_frames, Instant::now());
        } else if self.last_tx.1.elapsed() >= HEARTBEAT_EVERY
            && !self.poll_in_flight
            && self.s.host.window_free() > 0
        {
            self.send_poll()?;
        }
        Ok(())
    }

    fn send_poll(&mut self) -> Result<(), RunError> {
        let seq = self.s.send(RequestBody::GetStatus).map_err(link_err)?;
        self.pending.insert(seq, Pending::Poll);
        self.poll_in_flight = true;
        self.last_poll = Instant::now();
        Ok(())
    }

    /// Start: first once the queue is full or everything before the next event is queued;
    /// again whenever a fresh status shows the board idle with segments waiting.
    fn start_if_ready(&mut self) -> Result<(), RunError> {
        let waiting = self.report.acked > self.job_done(&self.latest);
        let fresh =
            self.last_start_seq.is_none_or(|ls| seq_at_or_after(self.latest.next_seq, ls + 1));
        let nothing_more = !self.segment_next()?;
        let ready = self.ever_started
            || (self.report.acked == self.sent_segs
                && (self.s.host.segment_credits() == 0 || nothing_more));
        if self.start_seq.is_none()
            && waiting
            && fresh
            && self.latest.machine == MachineState::Ready
            && ready
            && self.probe_allows_start()?
        {
            let seq = self.s.send(RequestBody::Start).map_err(link_err)?;
            self.pending.insert(seq, Pending::Start);
            self.start_seq = Some(seq);
            self.probe_started(seq);
        }
        Ok(())
    }

    /// The job's feed commands, at their machine time (as seen in the status stream).
    fn send_feed_commands(&mut self) -> Result<(), RunError> {
        let Some(t_start) = self.start_tick else { return Ok(()) };
        while let Some(&(at, cmd)) = self.feed_cmds.get(self.feed_next) {
            if self.latest.tick.saturating_sub(t_start) < at {
                break;
            }
            let (body, what) = match cmd {
                Command::SetOverride(r) => {
                    (RequestBody::SetOverride { rate_bits: r.to_bits() }, "override")
                }
                Command::Hold => (RequestBody::Hold, "hold"),
                Command::Resume => (RequestBody::Resume, "resume"),
                // Only the board's own controllers set the capability factor; a job file
                // cannot schedule one (convert.rs makes operator overrides only).
                Command::CapabilityOverride(_) => {
                    self.feed_next += 1;
                    continue;
                }
            };
            let seq = self.s.send(body).map_err(link_err)?;
            self.pending.insert(seq, Pending::Feed(what));
            self.feed_next += 1;
        }
        Ok(())
    }

    fn show_progress(&mut self) {
        let done = self.job_done(&self.latest);
        self.whereabouts.update(done);
        let override_factor = Rate::from_bits(self.latest.override_bits).to_num::<f64>();
        let (line, eta) = self.whereabouts.at(override_factor);
        if let Some(warning) = self.opts.journal.as_mut().and_then(|j| j.update(line, done)) {
            self.say(&warning);
        }
        self.progress.update(self.report.acked as u64, done as u64, Some(&self.latest), line, eta);
    }

    /// Done: everything sent and answered, every segment done, the board idle.
    fn all_done(&mut self) -> Result<bool, RunError> {
        let all_sent = self.peek()?.is_none()
            && self.pending.values().all(|p| matches!(p, Pending::Poll | Pending::Feed(_)));
        let after_batches =
            self.last_batch_seq.is_none_or(|b| seq_at_or_after(self.latest.next_seq, b + 1));
        if all_sent
            && after_batches
            && self.job_done(&self.latest) == self.segments_expected()
            && self.latest.machine == MachineState::Ready
            && self.latest.queue_depth == 0
        {
            self.finished_at.get_or_insert_with(Instant::now);
            return Ok(true);
        }
        Ok(false)
    }
}

/// One request answered, or the run's error naming `what` with the refusal.
pub(super) fn query(s: &mut Session, body: RequestBody, what: &str) -> Result<Reply, RunError> {
    match s.request(body).map_err(link_err)? {
        Ok(r) => Ok(r),
        Err(r) => Err(err(format!("{what} refused: {}", describe_rejection(&r)))),
    }
}
