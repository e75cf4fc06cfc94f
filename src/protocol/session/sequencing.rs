//! The sequence rules: sessions (Hello), each seq executed once, the result memory that answers
//! retransmissions, frames that do not decode, and the periodic status.

use super::target::LinkTarget;
use super::{BoardLink, Memo, Outcome, Session, RESULT_MEMORY};
use crate::capabilities::requests::{self as capability_requests, is_capability_kind};
use crate::protocol::bounded::FixedStr;
use crate::protocol::errors::ErrorCode;
use crate::protocol::frame::FrameError;
use crate::protocol::messages::*;

/// The message is a `RequestBody::Sim` (its body's variant index, a one-byte varint, follows
/// the seq).
#[cfg(not(feature = "sim-inputs"))]
fn is_sim_request(msg: &[u8]) -> bool {
    match postcard::take_from_bytes::<u32>(msg) {
        Ok((_, rest)) => rest.first() == Some(&KIND_SIM),
        Err(_) => false,
    }
}

/// `kind` recorded for a request that passed its CRC but did not decode.
const MALFORMED_KIND: u8 = 0xFF;
const KIND_HELLO: u8 = RequestBody::Hello { version: 0, nonce: 0 }.kind();
const KIND_GET_CONFIG: u8 = RequestBody::GetConfig.kind();
const KIND_GET_STATUS: u8 = RequestBody::GetStatus.kind();

fn is_before(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

impl BoardLink {
    /// `firmware` (cut to 24 bytes) and `capabilities` (`CAP_*`) are reported in `HelloInfo`.
    pub fn new(firmware: &str, capabilities: u32) -> Self {
        BoardLink {
            firmware: FixedStr::truncated(firmware),
            capabilities,
            last_panic: None,
            frames_bad: 0,
            port: (0, 0),
            session: None,
            memo: [const { None }; RESULT_MEMORY],
            status_period_ms: 0,
            status_due_ms: None,
        }
    }

    /// The serial port's receive overruns and dropped answers so far, for `Status::counters`.
    pub fn note_port(&mut self, usart_overruns: u32, responses_dropped: u32) {
        self.port = (usart_overruns, responses_dropped);
    }

    /// The panic the board found recorded at boot, reported in every `HelloInfo`.
    pub fn set_last_panic(&mut self, site: PanicSite) {
        self.last_panic = Some(site);
    }

    /// The next seq the board will execute, if a session is open.
    pub fn next_seq(&self) -> Option<u32> {
        self.session.map(|s| s.next_seq)
    }

    /// Handles one frame from [`FrameDecoder::push`](crate::protocol::FrameDecoder::push); always
    /// answers.
    pub fn on_frame(
        &mut self,
        frame: Result<&[u8], FrameError>,
        t: &mut impl LinkTarget,
    ) -> Response {
        match frame {
            Ok(msg) => self.handle_message(msg, t),
            Err(e) => {
                self.frames_bad = self.frames_bad.wrapping_add(1);
                self.link_nak(e.error_code(), t)
            }
        }
    }

    /// Handles CRC-checked message bytes.
    pub fn handle_message(&mut self, msg: &[u8], t: &mut impl LinkTarget) -> Response {
        let malformed = match decode_request(msg) {
            Ok(req) => return self.handle(&req, t),
            Err(m) => m,
        };
        #[cfg(not(feature = "sim-inputs"))]
        if let Some(seq) = malformed.seq.filter(|_| is_sim_request(msg)) {
            // A test hook this build has no code for: refused as a board without the
            // simulator capability refuses it, not counted as a bad frame.
            return self.sequenced(seq, KIND_SIM, t, |_, _| {
                Err((ErrorCode::Unsupported, NakDetail::None))
            });
        }
        self.frames_bad = self.frames_bad.wrapping_add(1);
        match malformed {
            Malformed { seq: None } => self.link_nak(ErrorCode::Malformed, t),
            Malformed { seq: Some(seq) } => self.sequenced(seq, MALFORMED_KIND, t, |_, _| {
                Err((ErrorCode::Malformed, NakDetail::None))
            }),
        }
    }

    /// Handles a decoded request.
    pub fn handle(&mut self, req: &Request, t: &mut impl LinkTarget) -> Response {
        if let RequestBody::Hello { version, nonce } = req.body {
            return self.hello(req, version, nonce, t);
        }
        let kind = req.body.kind();
        self.sequenced(req.seq, kind, t, |link, t| link.execute(req, t))
    }

    /// NAK for a frame that carried no readable request.
    pub fn link_nak(&self, code: ErrorCode, t: &impl LinkTarget) -> Response {
        let (seq, detail) = match self.session {
            Some(s) => (s.next_seq, NakDetail::Expected { expected: s.next_seq }),
            None => (0, NakDetail::None),
        };
        Response::Nak { seq, credits: t.credits(), code, detail }
    }

    /// A periodic `Status` when one is due (after `SetStatusPeriod`); call often.
    pub fn poll(&mut self, now_ms: u64, t: &impl LinkTarget) -> Option<Response> {
        if self.status_period_ms == 0 || self.session.is_none() {
            return None;
        }
        let due = *self.status_due_ms.get_or_insert(now_ms);
        if now_ms < due {
            return None;
        }
        self.status_due_ms = Some(now_ms.saturating_add(self.status_period_ms as u64));
        Some(Response::Status(self.status(t)))
    }

    /// The target's status with the link fields filled in.
    pub fn status(&self, t: &impl LinkTarget) -> Status {
        let mut s = t.status();
        s.credits = t.credits();
        s.event_credits = t.event_credits();
        s.next_seq = self.next_seq().unwrap_or(0);
        s.counters.frames_bad = self.frames_bad;
        (s.counters.usart_overruns, s.counters.responses_dropped) = self.port;
        s
    }

    /// `HelloInfo` for the current target.
    pub fn hello_info(&self, t: &impl LinkTarget) -> HelloInfo {
        let cfg = t.config();
        HelloInfo {
            version: PROTOCOL_VERSION,
            firmware: self.firmware.clone(),
            capabilities: self.capabilities,
            axes: cfg.machine.axis_count,
            queue_capacity: t.queue_capacity(),
            tick_hz: cfg.machine.tick_hz,
            max_window: RESULT_MEMORY as u16,
            max_segments_per_frame: crate::protocol::MAX_SEGMENTS_PER_FRAME as u8,
            last_panic: self.last_panic.clone(),
        }
    }

    fn hello(
        &mut self,
        req: &Request,
        version: u16,
        nonce: u32,
        t: &mut impl LinkTarget,
    ) -> Response {
        if version != PROTOCOL_VERSION {
            return Response::Nak {
                seq: req.seq,
                credits: t.credits(),
                code: ErrorCode::Version,
                detail: NakDetail::None,
            };
        }
        if let Some(s) = self.session {
            if s.hello_seq == req.seq && s.nonce == nonce && is_before(req.seq, s.next_seq) {
                return self.replay(req.seq, req.body.kind(), t);
            }
        }
        self.session =
            Some(Session { next_seq: req.seq.wrapping_add(1), hello_seq: req.seq, nonce });
        self.memo = [const { None }; RESULT_MEMORY];
        self.status_period_ms = 0;
        self.status_due_ms = None;
        let credits = t.credits();
        self.remember(req.seq, req.body.kind(), (credits, t.event_credits()), Ok(()));
        Response::Ack { seq: req.seq, credits, reply: Reply::Hello(self.hello_info(t)) }
    }

    fn sequenced<T: LinkTarget>(
        &mut self,
        seq: u32,
        kind: u8,
        t: &mut T,
        exec: impl FnOnce(&mut Self, &mut T) -> Result<Reply, (ErrorCode, NakDetail)>,
    ) -> Response {
        let Some(s) = self.session else {
            return Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::NoSession,
                detail: NakDetail::None,
            };
        };
        if seq != s.next_seq {
            if is_before(seq, s.next_seq) {
                return self.replay(seq, kind, t);
            }
            let expected = s.next_seq;
            return Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::Sequence,
                detail: NakDetail::Expected { expected },
            };
        }
        let result = exec(self, t);
        let credits = (t.credits(), t.event_credits());
        if let Some(s) = self.session.as_mut() {
            s.next_seq = seq.wrapping_add(1);
        }
        match result {
            Ok(reply) => {
                self.remember(seq, kind, credits, Ok(()));
                Response::Ack { seq, credits: credits.0, reply }
            }
            Err((code, detail)) => {
                self.remember(seq, kind, credits, Err((code, detail.clone())));
                Response::Nak { seq, credits: credits.0, code, detail }
            }
        }
    }

    fn remember(&mut self, seq: u32, kind: u8, credits: (u16, u16), outcome: Outcome) {
        let (credits, event_credits) = credits;
        self.memo[seq as usize % RESULT_MEMORY] =
            Some(Memo { seq, kind, credits, event_credits, outcome });
    }

    /// Answers a retransmission from memory, executing nothing.
    fn replay(&self, seq: u32, kind: u8, t: &impl LinkTarget) -> Response {
        match &self.memo[seq as usize % RESULT_MEMORY] {
            Some(m) if m.seq == seq && m.kind == kind => match &m.outcome {
                Ok(()) => {
                    // Queries answer with fresh data; nothing is executed again.
                    let reply = match kind {
                        KIND_HELLO => Reply::Hello(self.hello_info(t)),
                        KIND_GET_CONFIG => Reply::Config(t.config()),
                        KIND_GET_STATUS => Reply::Status(self.status(t)),
                        // A capability's request: its owner says (queue credits, a block
                        // held for a resend).
                        k if is_capability_kind(k) => {
                            capability_requests::replay(k, t, m.event_credits)
                        }
                        _ => Reply::None,
                    };
                    Response::Ack { seq, credits: m.credits, reply }
                }
                Err((code, detail)) => {
                    Response::Nak { seq, credits: m.credits, code: *code, detail: detail.clone() }
                }
            },
            _ => Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::Stale,
                detail: NakDetail::None,
            },
        }
    }
}
