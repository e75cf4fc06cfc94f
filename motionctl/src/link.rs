//! A protocol session over a [`Transport`]: drives [`HostLink`] (seqs, retransmission, credits)
//! with a wall clock, reassembles frames, notices a dead link (no frame for `link_timeout`, or a
//! transport error) and reopens the transport. The board keeps its session across a reopen, so
//! unanswered requests are simply retransmitted; a board that reset answers `NoSession`, which
//! shows up as [`HostEvent::SessionLost`].

use crate::transport::Transport;
use motion::protocol::{
    encode_frame, ErrorCode, FrameDecoder, HelloInfo, HostConfig, HostEvent, HostLink, NakDetail,
    Rejection, Reply, RequestBody, SendError, MAX_FRAME, MAX_FRAME_LINK, PROTOCOL_VERSION,
};
use std::collections::{HashMap, VecDeque};
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// No frame for this long (while one is expected) = the link is dead.
pub const LINK_TIMEOUT: Duration = Duration::from_secs(2);
/// How long reopening a dead link is tried.
pub const RECONNECT_WINDOW: Duration = Duration::from_secs(10);
/// How long a Hello may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a single request may take to be answered.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(5);

/// Names a factor every wall-clock wait of the link and of the job watchdogs is multiplied by,
/// for a board far slower than real time: QEMU tracing each instruction for the tick profile,
/// on a loaded machine, runs hundreds of times slower than the board it models.
pub const PATIENCE_ENV: &str = "MOTIONCTL_PATIENCE";
/// The largest factor [`PATIENCE_ENV`] may give (a wait of hours is a hang, not patience).
pub const MAX_PATIENCE: f64 = 1000.0;

/// `d` times the patience factor of [`PATIENCE_ENV`] (1 when unset).
pub fn patient(d: Duration) -> Duration {
    d.mul_f64(patience())
}

fn patience() -> f64 {
    static FACTOR: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *FACTOR.get_or_init(|| {
        parse_patience(std::env::var_os(PATIENCE_ENV).as_deref()).unwrap_or_else(|e| {
            eprintln!("warning: {e}; waiting as for a real board");
            1.0
        })
    })
}

/// The patience factor a value of [`PATIENCE_ENV`] gives: 1 when unset.
fn parse_patience(v: Option<&std::ffi::OsStr>) -> Result<f64, String> {
    let Some(v) = v else { return Ok(1.0) };
    match v.to_str().and_then(|s| s.trim().parse::<f64>().ok()) {
        Some(f) if (1.0..=MAX_PATIENCE).contains(&f) => Ok(f),
        _ => Err(format!(
            "{PATIENCE_ENV}={} is not a number from 1 to {MAX_PATIENCE}",
            v.to_string_lossy()
        )),
    }
}

/// Counters for the summary.
#[derive(Clone, Copy, Debug, Default)]
pub struct LinkStats {
    pub frames_in: u64,
    /// Frames from the board that failed COBS/CRC (noise).
    pub bad_frames_in: u64,
    /// NAKs for garbled or missing requests (the board saw noise).
    pub link_naks: u64,
    pub reconnects: u64,
}

/// "Code (description)" for a rejection, the way every NAK is shown.
pub fn describe_rejection(r: &Rejection) -> String {
    let detail = match &r.detail {
        NakDetail::None => String::new(),
        NakDetail::Expected { expected } => format!(" [board expects seq {expected}]"),
        NakDetail::Segment { index, reason, axis } => {
            let axis = axis.map(|a| format!(", axis {a}")).unwrap_or_default();
            format!(" [batch index {index}: {} ({}){axis}]", reason.name(), reason.description())
        }
        NakDetail::Config { field, axis } => {
            let axis = axis.map(|a| format!(", axis {a}")).unwrap_or_default();
            format!(" [field {field}{axis}]")
        }
        NakDetail::State(s) => format!(" [board state {s:?}]"),
        NakDetail::Block { reason, expected } => {
            format!(" [event block check {reason} failed; board expects block {expected:?}]")
        }
        // -- Z-slide job --
        NakDetail::Turning { reason, expected, fault } => {
            let fault =
                fault.map(|f| format!(", pre-start check: {}", f.name())).unwrap_or_default();
            format!(" [Z request check {reason}; board expects chunk {expected:?}{fault}]")
        }
    };
    format!("{} ({}){detail}", r.code.name(), r.code.description())
}

/// Why a session failed.
#[derive(Debug)]
pub enum LinkFailure {
    /// The link died and could not be reopened.
    Down(String),
    /// The board lost the session (reset: `NoSession`; or `Stale`).
    SessionLost(ErrorCode),
    Timeout(String),
    Refused(String),
}

impl fmt::Display for LinkFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkFailure::Down(s) | LinkFailure::Timeout(s) | LinkFailure::Refused(s) => {
                f.write_str(s)
            }
            LinkFailure::SessionLost(ErrorCode::NoSession) => f.write_str(
                "the board reset (it answered NoSession): its queue and session are gone",
            ),
            LinkFailure::SessionLost(c) => {
                write!(f, "the board lost the session ({}: {})", c.name(), c.description())
            }
        }
    }
}

impl std::error::Error for LinkFailure {}

/// Shortest adaptive retransmission timeout.
pub const MIN_RTO_MS: f64 = 3.0;

/// Adaptive retransmission timeout (RFC 6298 style, Karn's rule) on top of `HostLink`, whose
/// `rto_ms` is fixed: the clock `HostLink` sees runs `cap / rto` times faster than real time, so
/// its fixed timeout lasts `rto` real milliseconds.
struct RtoClock {
    cap_ms: f64,
    rto_ms: f64,
    srtt_ms: Option<f64>,
    rttvar_ms: f64,
    virtual_ms: f64,
    last: Instant,
    /// First transmission time and transmission count per unanswered seq.
    sent: HashMap<u32, (Instant, u32)>,
}

impl RtoClock {
    fn new(cap_ms: u64) -> Self {
        let cap_ms = cap_ms.max(1) as f64;
        RtoClock {
            cap_ms,
            rto_ms: cap_ms,
            srtt_ms: None,
            rttvar_ms: 0.0,
            virtual_ms: 0.0,
            last: Instant::now(),
            sent: HashMap::new(),
        }
    }

    /// `HostLink`'s milliseconds.
    fn now_ms(&mut self) -> u64 {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64() * 1000.0;
        self.last = now;
        self.virtual_ms += dt * self.cap_ms / self.rto_ms;
        self.virtual_ms as u64
    }

    /// Real time until `HostLink`'s deadline `at` (its milliseconds).
    fn real_until(&self, at: u64) -> Duration {
        let v = (at as f64 - self.virtual_ms).max(0.0) * self.rto_ms / self.cap_ms;
        Duration::from_secs_f64(v / 1000.0)
    }

    fn transmitted(&mut self, seq: u32) {
        self.sent.entry(seq).or_insert((Instant::now(), 0)).1 += 1;
    }

    fn answered(&mut self, seq: u32) {
        let Some((at, count)) = self.sent.remove(&seq) else { return };
        if count != 1 {
            return; // Karn: a retransmitted request's answer says nothing about the RTT.
        }
        let r = at.elapsed().as_secs_f64() * 1000.0;
        let srtt = match self.srtt_ms {
            None => {
                self.rttvar_ms = r / 2.0;
                r
            }
            Some(s) => {
                self.rttvar_ms = 0.75 * self.rttvar_ms + 0.25 * (s - r).abs();
                0.875 * s + 0.125 * r
            }
        };
        self.srtt_ms = Some(srtt);
        self.rto_ms = (srtt + 4.0 * self.rttvar_ms).clamp(MIN_RTO_MS.min(self.cap_ms), self.cap_ms);
    }
}

pub struct Session<'a> {
    t: &'a mut dyn Transport,
    pub host: HostLink,
    decoder: FrameDecoder<MAX_FRAME>,
    rto: RtoClock,
    last_frame: Instant,
    /// When the link went quiet, across reconnects; cleared by any good frame.
    down_since: Option<Instant>,
    pub link_timeout: Duration,
    /// Answers by seq, until taken.
    completed: HashMap<u32, Result<Reply, Rejection>>,
    /// Everything else the board said, in order.
    pub events: VecDeque<HostEvent>,
    /// Messages for the operator (reconnects), to print where convenient.
    pub notices: Vec<String>,
    /// A status stream is on, so silence means a dead link.
    pub streaming: bool,
    pub stats: LinkStats,
    /// Set by Ctrl-C: stop reconnecting.
    pub interrupt: Option<Arc<AtomicBool>>,
}

fn nonce() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(std::time::SystemTime::now().elapsed().map(|d| d.as_nanos()).unwrap_or(0));
    h.write_u32(std::process::id());
    h.finish() as u32
}

impl<'a> Session<'a> {
    pub fn new(t: &'a mut dyn Transport, cfg: HostConfig) -> Self {
        let now = Instant::now();
        Session {
            t,
            host: HostLink::new(cfg),
            decoder: FrameDecoder::new(),
            rto: RtoClock::new(cfg.rto_ms),
            last_frame: now,
            down_since: None,
            link_timeout: patient(LINK_TIMEOUT),
            completed: HashMap::new(),
            events: VecDeque::new(),
            notices: Vec::new(),
            streaming: false,
            stats: LinkStats::default(),
            interrupt: None,
        }
    }

    pub fn describe(&self) -> String {
        self.t.describe()
    }

    pub fn transport(&self) -> &dyn Transport {
        &*self.t
    }

    /// The transport, for a runner that opens its own session on it (this one must `connect`
    /// again after).
    pub fn transport_mut(&mut self) -> &mut dyn Transport {
        &mut *self.t
    }

    /// The current adaptive retransmission timeout, ms.
    pub fn rto_ms(&self) -> f64 {
        self.rto.rto_ms
    }

    /// Opens a session with Hello and checks the protocol version.
    pub fn connect(&mut self) -> Result<HelloInfo, LinkFailure> {
        self.rto.sent.clear();
        self.host.connect(nonce());
        self.last_frame = Instant::now();
        let start = Instant::now();
        loop {
            self.pump(Duration::from_millis(10))?;
            while let Some(ev) = self.events.pop_front() {
                match ev {
                    HostEvent::Connected(info) if info.version != PROTOCOL_VERSION => {
                        return Err(LinkFailure::Refused(format!(
                            "board speaks protocol v{}, motionctl v{PROTOCOL_VERSION}",
                            info.version
                        )));
                    }
                    HostEvent::Connected(info) => {
                        if let Some(p) = &info.last_panic {
                            eprintln!(
                                "motionctl: the board restarted after a firmware panic at \
                                 {}:{}:{} (fault Panicked; `motionctl clear-fault` once noted)",
                                p.file.as_str(),
                                p.line,
                                p.column
                            );
                        }
                        return Ok(info);
                    }
                    HostEvent::ConnectFailed(r) if r.code == ErrorCode::Version => {
                        return Err(LinkFailure::Refused(format!(
                            "board does not speak protocol v{PROTOCOL_VERSION} (motionctl's): \
                             update the firmware or motionctl so they match"
                        )));
                    }
                    HostEvent::ConnectFailed(r) => {
                        return Err(LinkFailure::Refused(format!(
                            "the board refused Hello: {}",
                            describe_rejection(&r)
                        )));
                    }
                    _ => {}
                }
            }
            if start.elapsed() > patient(CONNECT_TIMEOUT) {
                return Err(LinkFailure::Timeout(format!(
                    "no answer to Hello from {} within {} s (is the board running the link \
                     firmware, at this speed?)",
                    self.t.describe(),
                    patient(CONNECT_TIMEOUT).as_secs()
                )));
            }
        }
    }

    /// Queues a request (waiting for room in the window); returns its seq.
    pub fn send(&mut self, body: RequestBody) -> Result<u32, LinkFailure> {
        let start = Instant::now();
        loop {
            match self.host.send(body.clone()) {
                Ok(seq) => return Ok(seq),
                Err(SendError::WindowFull) => {
                    self.pump(Duration::from_millis(5))?;
                    if start.elapsed() > patient(REQUEST_TIMEOUT) {
                        return Err(LinkFailure::Timeout(
                            "the request window never drained".into(),
                        ));
                    }
                }
                Err(SendError::NotConnected) => {
                    return Err(LinkFailure::SessionLost(ErrorCode::NoSession))
                }
                Err(e) => return Err(LinkFailure::Refused(format!("cannot send: {e:?}"))),
            }
        }
    }

    /// The answer to `seq`, if it has arrived.
    pub fn take_answer(&mut self, seq: u32) -> Option<Result<Reply, Rejection>> {
        self.completed.remove(&seq)
    }

    /// Every answer that arrived (any order).
    pub fn take_answers(&mut self) -> Vec<(u32, Result<Reply, Rejection>)> {
        self.completed.drain().collect()
    }

    /// Sends `body` and waits for its answer (other events are kept in `events`).
    pub fn request(&mut self, body: RequestBody) -> Result<Result<Reply, Rejection>, LinkFailure> {
        let seq = self.send(body)?;
        let start = Instant::now();
        loop {
            if let Some(r) = self.take_answer(seq) {
                return Ok(r);
            }
            if let Some(code) = self.events.iter().find_map(|e| match e {
                HostEvent::SessionLost(c) => Some(*c),
                _ => None,
            }) {
                return Err(LinkFailure::SessionLost(code));
            }
            if start.elapsed() > patient(REQUEST_TIMEOUT) {
                return Err(LinkFailure::Timeout(format!(
                    "no answer from {} within {} s",
                    self.t.describe(),
                    patient(REQUEST_TIMEOUT).as_secs()
                )));
            }
            self.pump(Duration::from_millis(10))?;
        }
    }

    /// Transmits what is due, receives for at most `max_wait`, and files what arrived.
    pub fn pump(&mut self, max_wait: Duration) -> Result<(), LinkFailure> {
        let now = self.rto.now_ms();
        let mut buf = [0u8; MAX_FRAME_LINK];
        while let Some(req) = self.host.poll_transmit(now) {
            self.rto.transmitted(req.seq);
            let Ok(frame) = encode_frame(&req, &mut buf) else { continue };
            if let Err(e) = self.t.send(frame) {
                return self.link_down(format!("write failed: {e}"));
            }
        }
        let wait = match self.host.next_deadline() {
            Some(d) => self.rto.real_until(d).min(max_wait),
            None => max_wait,
        };
        let bytes = match self.t.recv(wait) {
            Ok(b) => b,
            Err(e) => return self.link_down(format!("read failed: {e}")),
        };
        for b in bytes {
            let Some(frame) = self.decoder.push(b) else { continue };
            let msg = match frame {
                Ok(m) => m.to_vec(),
                Err(_) => {
                    self.stats.bad_frames_in += 1;
                    continue;
                }
            };
            self.stats.frames_in += 1;
            self.last_frame = Instant::now();
            self.down_since = None;
            match self.host.receive_message(&msg) {
                Some(HostEvent::Completed { seq, result, .. }) => {
                    self.rto.answered(seq);
                    self.completed.insert(seq, result);
                }
                Some(HostEvent::Connected(info)) => {
                    self.rto.sent.clear();
                    self.events.push_back(HostEvent::Connected(info));
                }
                Some(HostEvent::LinkError(_)) => self.stats.link_naks += 1,
                Some(ev) => self.events.push_back(ev),
                None => {}
            }
        }
        let expecting = self.streaming || self.host.in_flight() > 0;
        if expecting && self.last_frame.elapsed() > self.link_timeout {
            let secs = self.last_frame.elapsed().as_secs_f64();
            return self.link_down(format!("no frame from the board for {secs:.1} s"));
        }
        Ok(())
    }

    /// Reopens the transport; the board's session (and HostLink's window) carry on. A probe
    /// (`GetStatus`) follows, so a board that reset answers `NoSession` even when nothing else
    /// is in flight.
    fn link_down(&mut self, why: String) -> Result<(), LinkFailure> {
        let what = self.t.describe();
        let since = *self.down_since.get_or_insert(self.last_frame);
        self.notices.push(format!("link to {what} lost ({why}); reconnecting"));
        loop {
            let quiet = since.elapsed();
            if self.interrupt.as_ref().is_some_and(|f| f.load(Ordering::SeqCst)) {
                return Err(LinkFailure::Down(format!("link to {what} lost ({why}); interrupted")));
            }
            match self.t.reconnect() {
                Ok(()) if quiet <= patient(RECONNECT_WINDOW) => {
                    self.stats.reconnects += 1;
                    self.decoder.reset();
                    self.last_frame = Instant::now();
                    if self.host.is_connected() {
                        let _ = self.host.send(RequestBody::GetStatus);
                    }
                    self.notices.push(format!(
                        "reconnected to {what}; resuming (unanswered requests are retransmitted)"
                    ));
                    return Ok(());
                }
                Err(e) if e.kind() == std::io::ErrorKind::Unsupported => {
                    return Err(LinkFailure::Down(format!("link to {what} lost ({why})")));
                }
                Ok(()) => {
                    return Err(LinkFailure::Down(format!(
                        "link to {what} lost ({why}): no frame for {:.0} s despite reconnecting",
                        quiet.as_secs_f64()
                    )));
                }
                Err(e) if quiet > patient(RECONNECT_WINDOW) => {
                    return Err(LinkFailure::Down(format!(
                        "link to {what} lost ({why}) and not back within {} s: {e}",
                        patient(RECONNECT_WINDOW).as_secs()
                    )));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(300)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsStr;

    #[test]
    fn patience_is_one_unless_set_and_refuses_what_is_not_a_factor() {
        assert_eq!(parse_patience(None), Ok(1.0));
        assert_eq!(parse_patience(Some(OsStr::new(" 100 "))), Ok(100.0));
        for bad in ["0.5", "0", "-3", "abc", "", "1e9", "NaN"] {
            let e = parse_patience(Some(OsStr::new(bad))).unwrap_err();
            assert!(e.contains(PATIENCE_ENV) && e.contains(bad), "{bad}: {e}");
        }
    }
}
