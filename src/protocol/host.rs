//! Host side of the link: seq assignment, the retransmission window and credit accounting, with
//! no I/O and no clock of its own, so it runs the same against a serial port, a simulated lossy
//! channel or a unit test.
//!
//! Driving it (e.g. from `motionctl`):
//! ```text
//! link.connect(nonce);
//! loop {
//!     while let Some(req) = link.poll_transmit(now_ms()) { port.write(encode_frame(&req, &mut buf)?) }
//!     for byte in port.read(timeout = link.next_deadline() - now) {
//!         if let Some(Ok(msg)) = decoder.push(byte) {
//!             if let Some(ev) = link.receive_message(msg) { /* Connected, Completed, Status, ... */ }
//!         }
//!     }
//!     // queue work with link.send(..) while link.segment_credits() / link.window_free() allow
//! }
//! ```
//!
//! Rules:
//! * Requests get consecutive seqs and stay in the window until their own Ack/Nak arrives.
//! * Go-back-N: when the oldest unanswered request has waited `rto_ms`, or a NAK says the board
//!   expects an earlier seq (a gap or a garbled frame), every unanswered request is sent again in
//!   order. The board executes each seq once and answers repeats from memory, so nothing is lost
//!   or repeated.
//! * Credits: `segment_credits()` = the board's latest credit report (after executing up to `T`)
//!   minus every segment in requests after `T` still in the window. `send` refuses segments beyond
//!   it, so the board's queue cannot overflow. With nothing in flight, credits only grow on the
//!   board but the host learns of it only from a response: keep a status stream on
//!   (`SetStatusPeriod`) or send `GetStatus` when starved.
//! * Event credits (`QueueEvents` blocks) are counted the same way in a second counter,
//!   `event_credits()`, from `Status::event_credits` (unsolicited: after `next_seq - 1`; a
//!   `GetStatus` answer: after its seq) and `Reply::EventCredits` (after the QueueEvents' seq).
//!   Before the first report it is 0: send a `GetStatus` first.

use heapless::Deque;

use super::errors::ErrorCode;
use super::messages::*;

/// Largest window a `HostLink` supports (the board's `RESULT_MEMORY` bounds it too).
pub const MAX_WINDOW: usize = 32;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HostConfig {
    /// Retransmission timeout.
    pub rto_ms: u64,
    /// Most unanswered requests; clamped to `MAX_WINDOW` and the board's `max_window`.
    pub window: usize,
}

impl Default for HostConfig {
    fn default() -> Self {
        HostConfig { rto_ms: 100, window: 8 }
    }
}

/// The board refused a request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rejection {
    pub code: ErrorCode,
    pub detail: NakDetail,
}

/// What a response meant to the host.
#[derive(Clone, Debug, PartialEq, Eq)]
#[allow(clippy::large_enum_variant)]
pub enum HostEvent {
    /// The Hello was accepted; requests may be sent.
    Connected(HelloInfo),
    /// The Hello was refused (e.g. `Version`).
    ConnectFailed(Rejection),
    /// The request `seq` was executed (`Ok`) or refused (`Err`), exactly once.
    Completed {
        seq: u32,
        kind: u8,
        result: Result<Reply, Rejection>,
    },
    Status(Status),
    Fault {
        code: super::errors::FaultCode,
        tick: u64,
    },
    /// The board reported a garbled frame or a gap; retransmission is under way. Informational.
    LinkError(ErrorCode),
    /// The board has no session (it reset) or lost a result (`Stale`), or answered
    /// inconsistently: unanswered requests may or may not have run. Reconnect.
    SessionLost(ErrorCode),
}

/// Why `send` refused a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendError {
    NotConnected,
    /// Wait for answers.
    WindowFull,
    /// The segments would not fit into the board's queue yet; `available` would.
    NoCredits {
        available: u16,
    },
    /// `Hello` goes through `connect`.
    UseConnect,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tx {
    /// To be (re)sent.
    Due,
    Sent {
        at_ms: u64,
    },
    Answered,
}

#[derive(Clone, Debug)]
struct Entry {
    seq: u32,
    body: RequestBody,
    tx: Tx,
}

#[derive(Clone, Debug)]
pub struct HostLink {
    cfg: HostConfig,
    window: usize,
    entries: Deque<Entry, MAX_WINDOW>,
    next_seq: u32,
    /// First seq of this session (the Hello's).
    session_start: u32,
    board: Option<HelloInfo>,
    /// Latest credit report and the seq it holds after.
    credits: u16,
    credits_after: u32,
    /// Latest event-credit report and the seq it holds after.
    event_credits: u16,
    event_credits_after: u32,
    /// Expected seq of the last rewind; repeats of it are ignored until progress past it.
    rewound_to: Option<u32>,
    /// Frames handed out by `poll_transmit`, and of those, retransmissions.
    pub sent_frames: u64,
    pub retransmissions: u64,
}

/// `a` after `b` in seq order (wrapping).
fn after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

impl HostLink {
    pub fn new(cfg: HostConfig) -> Self {
        HostLink {
            cfg,
            window: cfg.window.clamp(1, MAX_WINDOW),
            entries: Deque::new(),
            next_seq: 0,
            session_start: 0,
            board: None,
            credits: 0,
            credits_after: 0,
            event_credits: 0,
            event_credits_after: 0,
            rewound_to: None,
            sent_frames: 0,
            retransmissions: 0,
        }
    }

    /// Starts a new session: forgets every unanswered request and queues a Hello whose seq is
    /// `nonce` (so answers from an old session do not match). Pick a fresh random `nonce` per
    /// connection.
    pub fn connect(&mut self, nonce: u32) {
        self.entries.clear();
        self.board = None;
        self.session_start = nonce;
        self.next_seq = nonce;
        self.credits = 0;
        self.credits_after = nonce;
        self.event_credits = 0;
        self.event_credits_after = nonce;
        self.rewound_to = None;
        let body = RequestBody::Hello { version: PROTOCOL_VERSION, nonce };
        // Cannot fail: the window was just emptied.
        let _ = self.entries.push_back(Entry { seq: self.next_seq, body, tx: Tx::Due });
        self.next_seq = self.next_seq.wrapping_add(1);
    }

    pub fn is_connected(&self) -> bool {
        self.board.is_some()
    }

    /// The board's Hello answer, once connected.
    pub fn board(&self) -> Option<&HelloInfo> {
        self.board.as_ref()
    }

    /// Requests sent or queued but not yet answered.
    pub fn in_flight(&self) -> usize {
        self.entries.iter().filter(|e| e.tx != Tx::Answered).count()
    }

    /// Requests `send` would accept now.
    pub fn window_free(&self) -> usize {
        self.window.saturating_sub(self.entries.len())
    }

    /// Segments `send` would accept now.
    pub fn segment_credits(&self) -> u16 {
        let committed: u32 = self
            .entries
            .iter()
            .filter(|e| after(e.seq, self.credits_after))
            .map(|e| e.body.segment_count() as u32)
            .sum();
        (self.credits as u32).saturating_sub(committed) as u16
    }

    /// Event blocks `send` would accept now.
    pub fn event_credits(&self) -> u16 {
        let committed: u32 = self
            .entries
            .iter()
            .filter(|e| after(e.seq, self.event_credits_after))
            .map(|e| e.body.block_count() as u32)
            .sum();
        (self.event_credits as u32).saturating_sub(committed) as u16
    }

    /// Queues a request; returns its seq. It goes out through `poll_transmit`.
    pub fn send(&mut self, body: RequestBody) -> Result<u32, SendError> {
        if matches!(body, RequestBody::Hello { .. }) {
            return Err(SendError::UseConnect);
        }
        if !self.is_connected() {
            return Err(SendError::NotConnected);
        }
        if self.window_free() == 0 {
            return Err(SendError::WindowFull);
        }
        let available = self.segment_credits();
        if body.segment_count() > available {
            return Err(SendError::NoCredits { available });
        }
        let available = self.event_credits();
        if body.block_count() > available {
            return Err(SendError::NoCredits { available });
        }
        let seq = self.next_seq;
        self.entries
            .push_back(Entry { seq, body, tx: Tx::Due })
            .map_err(|_| SendError::WindowFull)?;
        self.next_seq = seq.wrapping_add(1);
        Ok(seq)
    }

    /// The next request to put on the link, if any: queued ones first, then (after `rto_ms`
    /// without an answer) the whole unanswered window again. Call until it returns `None`.
    pub fn poll_transmit(&mut self, now_ms: u64) -> Option<Request> {
        let rto = self.cfg.rto_ms;
        let timed_out = self.entries.iter().find(|e| e.tx != Tx::Answered).is_some_and(
            |e| matches!(e.tx, Tx::Sent { at_ms } if now_ms.saturating_sub(at_ms) >= rto),
        );
        if timed_out {
            self.rewind();
            self.rewound_to = None;
        }
        let e = self.entries.iter_mut().find(|e| e.tx == Tx::Due)?;
        e.tx = Tx::Sent { at_ms: now_ms };
        self.sent_frames += 1;
        Some(Request { seq: e.seq, body: e.body.clone() })
    }

    /// When `poll_transmit` will next have something to send without new input, if ever.
    pub fn next_deadline(&self) -> Option<u64> {
        if self.entries.iter().any(|e| e.tx == Tx::Due) {
            return Some(0);
        }
        self.entries.iter().find(|e| e.tx != Tx::Answered).and_then(|e| match e.tx {
            Tx::Sent { at_ms } => Some(at_ms.saturating_add(self.cfg.rto_ms)),
            _ => None,
        })
    }

    /// Go-back-N: every unanswered request is due again.
    fn rewind(&mut self) {
        for e in self.entries.iter_mut() {
            if let Tx::Sent { .. } = e.tx {
                e.tx = Tx::Due;
                self.retransmissions += 1;
            }
        }
    }

    /// Feeds CRC-checked message bytes from the board.
    pub fn receive_message(&mut self, msg: &[u8]) -> Option<HostEvent> {
        // An undecodable response (CRC-valid): nothing to learn; timeouts recover.
        self.receive(decode_response(msg)?)
    }

    /// `seq` belongs to this session and has been assigned.
    fn in_session(&self, seq: u32) -> bool {
        seq.wrapping_sub(self.session_start) < self.next_seq.wrapping_sub(self.session_start)
    }

    fn note_credits(&mut self, credits: u16, after_seq: u32) {
        if self.in_session(after_seq) && !after(self.credits_after, after_seq) {
            self.credits = credits;
            self.credits_after = after_seq;
        }
    }

    fn note_event_credits(&mut self, credits: u16, after_seq: u32) {
        if self.in_session(after_seq) && !after(self.event_credits_after, after_seq) {
            self.event_credits = credits;
            self.event_credits_after = after_seq;
        }
    }

    /// Feeds a decoded response; returns what it meant, if anything.
    pub fn receive(&mut self, resp: Response) -> Option<HostEvent> {
        let ev = match resp {
            Response::Status(s) => {
                if self.is_connected() {
                    self.note_credits(s.credits, s.next_seq.wrapping_sub(1));
                    self.note_event_credits(s.event_credits, s.next_seq.wrapping_sub(1));
                }
                Some(HostEvent::Status(s))
            }
            Response::Fault { code, tick } => Some(HostEvent::Fault { code, tick }),
            Response::Ack { seq, credits, reply } => self.answered(seq, credits, Ok(reply)),
            Response::Nak { credits, code, detail: NakDetail::Expected { expected }, .. } => {
                self.expected(code, credits, expected)
            }
            // Link-level NAKs from a board without a session: nothing to learn.
            Response::Nak {
                code: ErrorCode::Crc | ErrorCode::Framing | ErrorCode::Overflow,
                ..
            } => None,
            Response::Nak {
                seq, code: code @ (ErrorCode::NoSession | ErrorCode::Stale), ..
            } => {
                if !self.in_session(seq) || (!self.is_connected() && code == ErrorCode::NoSession) {
                    // Not about this session (or an old frame during connect).
                    None
                } else {
                    self.lose_session(code)
                }
            }
            Response::Nak { seq, credits, code, detail } => {
                self.answered(seq, credits, Err(Rejection { code, detail }))
            }
        };
        while self.entries.front().is_some_and(|e| e.tx == Tx::Answered) {
            self.entries.pop_front();
        }
        ev
    }

    fn lose_session(&mut self, code: ErrorCode) -> Option<HostEvent> {
        self.entries.clear();
        self.board = None;
        self.credits = 0;
        self.event_credits = 0;
        Some(HostEvent::SessionLost(code))
    }

    fn expected(&mut self, code: ErrorCode, credits: u16, expected: u32) -> Option<HostEvent> {
        if !self.in_session(expected) && expected != self.next_seq {
            // The board expects a seq this session never reached (or one from another
            // session): it is not in the state we think.
            return if self.is_connected() { self.lose_session(ErrorCode::Sequence) } else { None };
        }
        if let Some(oldest) = self.entries.iter().find(|e| e.tx != Tx::Answered) {
            if after(oldest.seq, expected) {
                // The board has not executed a request we saw answered: impossible unless it
                // lost state.
                return self.lose_session(ErrorCode::Sequence);
            }
        }
        self.note_credits(credits, expected.wrapping_sub(1));
        if self.rewound_to != Some(expected) {
            self.rewind();
            self.rewound_to = Some(expected);
        }
        Some(HostEvent::LinkError(code))
    }

    fn answered(
        &mut self,
        seq: u32,
        credits: u16,
        result: Result<Reply, Rejection>,
    ) -> Option<HostEvent> {
        if !self.in_session(seq) {
            return None;
        }
        self.note_credits(credits, seq);
        match &result {
            Ok(Reply::EventCredits(c)) => self.note_event_credits(*c, seq),
            Ok(Reply::Status(s)) => self.note_event_credits(s.event_credits, seq),
            _ => {}
        }
        if self.rewound_to.is_some_and(|r| !after(r, seq)) {
            self.rewound_to = None;
        }
        let e = self.entries.iter_mut().find(|e| e.seq == seq && e.tx != Tx::Answered)?;
        e.tx = Tx::Answered;
        let kind = e.body.kind();
        if let RequestBody::Hello { .. } = e.body {
            return Some(match result {
                Ok(Reply::Hello(info)) => {
                    self.window =
                        self.cfg.window.clamp(1, MAX_WINDOW).min(info.max_window.max(1) as usize);
                    self.board = Some(info.clone());
                    HostEvent::Connected(info)
                }
                Ok(_) => HostEvent::ConnectFailed(Rejection {
                    code: ErrorCode::Malformed,
                    detail: NakDetail::None,
                }),
                Err(r) => HostEvent::ConnectFailed(r),
            });
        }
        Some(HostEvent::Completed { seq, kind, result })
    }
}
