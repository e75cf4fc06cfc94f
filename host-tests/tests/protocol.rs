//! Wire protocol: framing round trips, corruption detection, the lossy-channel acceptance test
//! (2000 segments arrive exactly once, in order, without overrunning the queue), refusals that
//! change nothing, and a million-input robustness run of the board's receive path.

use std::collections::{HashSet, VecDeque};
use std::time::Instant;

use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::machine::MachineState;
use motion::protocol::*;
use motion::segment::{Rate, Segment};

/// xorshift64*: deterministic, no dependencies.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    /// True with probability `p`.
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 > 1.0 - p
    }
    fn byte(&mut self) -> u8 {
        self.next() as u8
    }
}

fn config() -> LinkConfig {
    LinkConfig {
        machine: MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 12_000 },
            axis_count: 3,
            axes: [AxisLimits {
                max_rate_hz: 40_000,
                accel_steps_per_s2: 200_000,
                junction_jerk_hz: 500,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: 80_000,
            soft_min: -10_000_000,
            soft_max: 10_000_000,
        }; MAX_AXES],
        inputs: motion::InputFilterConfig::DEFAULT,
    }
}

fn seg(id: u32, steps: [i32; 3]) -> Segment {
    let d = steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0);
    Segment {
        steps: [steps[0], steps[1], steps[2], 0, 0, 0],
        duration_ticks: d.saturating_mul(3).max(100),
        entry_rate: Rate::from_num(0.5),
        exit_rate: Rate::from_num(0.25),
        accel_per_tick: Rate::from_bits(1 << 18),
        id,
    }
}

/// Requests and responses (host-tests has no serde dependency of its own).
trait Message {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError>;
}
impl Message for Request {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError> {
        encode_frame(self, buf)
    }
}
impl Message for Response {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError> {
        encode_frame(self, buf)
    }
}

fn frame(msg: &impl Message) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LINK];
    msg.encode(&mut buf).expect("message fits a frame").to_vec()
}

fn varint(mut v: u32, out: &mut Vec<u8>) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Every complete frame's result in `bytes`.
fn deframe(d: &mut FrameDecoder<MAX_FRAME>, bytes: &[u8]) -> Vec<Result<Vec<u8>, FrameError>> {
    bytes.iter().filter_map(|&b| d.push(b).map(|r| r.map(|m| m.to_vec()))).collect()
}

fn all_requests() -> Vec<Request> {
    let segs = [seg(1, [100, -200, 3]), seg(u32::MAX, [i32::MIN, i32::MAX, 0])];
    let mut extreme = config();
    extreme.machine.tick_hz = u32::MAX;
    extreme.scale[5] =
        AxisScale { steps_per_unit_milli: u32::MAX, soft_min: i64::MIN, soft_max: i64::MAX };
    [
        RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 0xDEAD_BEEF },
        RequestBody::GetConfig,
        RequestBody::SetConfig(config()),
        RequestBody::SetConfig(extreme),
        RequestBody::QueueSegments(SegmentBatch::from_slice(&segs).unwrap()),
        RequestBody::QueueSegments(
            SegmentBatch::from_slice(&[segs[1]; MAX_SEGMENTS_PER_FRAME]).unwrap(),
        ),
        RequestBody::QueueSegments(SegmentBatch::default()),
        RequestBody::Start,
        RequestBody::Hold,
        RequestBody::Resume,
        RequestBody::Abort,
        RequestBody::SetOverride { rate_bits: MAX_OVERRIDE_BITS },
        RequestBody::GetStatus,
        RequestBody::SetStatusPeriod { ms: 250 },
        RequestBody::ClearFault,
        RequestBody::Home,
        RequestBody::SetHoming(HomingConfig::NONE),
        RequestBody::JogOffLimit,
        RequestBody::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(&[0xB5, 1, 2, 3]).unwrap(),
            last: false,
        }),
        RequestBody::StartPlayback { m: 3, k: 2 },
        RequestBody::ArmWire(WireJobParams {
            debounce_ticks: 50,
            retrace_limit_steps: 40_000,
            retrace_override_bits: 1 << 29,
            resume_override_bits: 1 << 29,
            resume_segments: 2,
            segments: 91,
        }),
        RequestBody::Sim(SimRequest::Inject { wire_stall: true }),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, body)| Request { seq: [0, 1, 127, 128, u32::MAX][i % 5], body })
    .collect()
}

fn all_responses() -> Vec<Response> {
    let status = Status {
        tick: u64::MAX,
        positions: [i64::MIN, -1, 0, 1, i64::MAX, 42],
        state: LinkState::Stopping,
        override_bits: MAX_OVERRIDE_BITS,
        queue_depth: 3,
        credits: 13,
        segments_done: 99,
        last_done_id: Some(7),
        done_hash: 0xdead_beef,
        faults: FaultCode::EStop.bit() | FaultCode::SensorFault.bit(),
        sensors: [i32::MIN, 0, 5, i32::MAX],
        next_seq: 1234,
        machine: MachineState::Holding,
        causes: FaultCode::EStop.bit(),
        homed: true,
        event_credits: 7,
        events_fired: 19_036,
        event_blocks: 1,
        wire_stalls: 2,
        wire_retraces: 3,
        wire_returns: 4,
        wire_max_retrace_steps: 8_738,
        wire_power: true,
        // -- Z-slide job --
        ..Status::default()
    };
    let hello = HelloInfo {
        version: PROTOCOL_VERSION,
        firmware: FixedStr::truncated("motion-board 0.1.0 (f405)"),
        capabilities: CAP_DDA | CAP_STATUS_STREAM | CAP_SOFT_LIMITS,
        axes: 3,
        queue_capacity: 16,
        tick_hz: 100_000,
        max_window: RESULT_MEMORY as u16,
        max_segments_per_frame: MAX_SEGMENTS_PER_FRAME as u8,
        last_panic: Some(PanicSite {
            file: FixedStr::tail("firmware/src/bin/link.rs"),
            line: 281,
            column: 25,
        }),
    };
    let mut v = vec![
        Response::Ack { seq: 0, credits: 0, reply: Reply::None },
        Response::Ack { seq: 5, credits: 16, reply: Reply::Hello(hello) },
        Response::Ack { seq: u32::MAX, credits: u16::MAX, reply: Reply::Config(config()) },
        Response::Ack { seq: 9, credits: 2, reply: Reply::Status(status.clone()) },
        Response::Status(Status::default()),
        Response::Status(status),
    ];
    for &code in FaultCode::ALL {
        v.push(Response::Fault { code, tick: 77 });
    }
    let details = [
        NakDetail::None,
        NakDetail::Expected { expected: 3 },
        NakDetail::Segment { index: 2, reason: SegmentReason::AxisRate, axis: Some(1) },
        NakDetail::Segment { index: 0, reason: SegmentReason::Duration, axis: None },
        NakDetail::Config { field: FixedStr::truncated("accel_steps_per_s2"), axis: Some(4) },
        NakDetail::State(MachineState::Holding),
    ];
    for (i, &code) in ErrorCode::ALL.iter().enumerate() {
        v.push(Response::Nak {
            seq: i as u32,
            credits: 1,
            code,
            detail: details[i % details.len()].clone(),
        });
    }
    v
}

#[test]
fn every_message_round_trips_through_frames() {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let reqs = all_requests();
    let resps = all_responses();
    let mut stream = Vec::new();
    for r in &reqs {
        stream.extend(frame(r));
        stream.push(0); // empty frames are ignored
    }
    let got = deframe(&mut d, &stream);
    assert_eq!(got.len(), reqs.len());
    for (g, r) in got.iter().zip(&reqs) {
        assert_eq!(&decode_request(g.as_ref().unwrap()).unwrap(), r);
    }
    let stream: Vec<u8> = resps.iter().flat_map(frame).collect();
    let got = deframe(&mut d, &stream);
    assert_eq!(got.len(), resps.len());
    for (g, r) in got.iter().zip(&resps) {
        assert_eq!(&decode_response(g.as_ref().unwrap()).unwrap(), r);
    }
    // The kinds are all covered.
    let kinds: HashSet<u8> = reqs.iter().map(|r| r.body.kind()).collect();
    assert_eq!(kinds.len(), 19);
}

#[test]
fn corruption_is_detected() {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let mut frames: Vec<Vec<u8>> = all_requests().iter().map(frame).collect();
    frames.extend(all_responses().iter().map(frame));
    let mut undetected = 0;
    let mut trials = 0;
    // Every single-bit error in every frame.
    for f in &frames {
        for bit in 0..(f.len() - 1) * 8 {
            let mut g = f.clone();
            g[bit / 8] ^= 1 << (bit % 8);
            g.push(0); // in case the flip removed the delimiter's neighbour
            trials += 1;
            for r in deframe(&mut d, &g) {
                undetected += r.is_ok() as u32;
            }
        }
    }
    // Random multi-byte corruption, truncation and splices.
    let mut rng = Rng::new(7);
    for _ in 0..200_000 {
        let f = &frames[rng.below(frames.len() as u64) as usize];
        let mut g = f[..f.len() - 1].to_vec();
        match rng.below(3) {
            0 => {
                for _ in 0..1 + rng.below(4) {
                    let i = rng.below(g.len() as u64) as usize;
                    g[i] ^= 1 + rng.below(255) as u8;
                }
            }
            1 => g.truncate(rng.below(g.len() as u64) as usize),
            _ => {
                let h = &frames[rng.below(frames.len() as u64) as usize];
                let cut = rng.below(g.len() as u64) as usize;
                g.truncate(cut);
                g.extend_from_slice(&h[rng.below(h.len() as u64) as usize..h.len() - 1]);
                if g == f[..f.len() - 1] {
                    continue;
                }
            }
        }
        g.push(0);
        trials += 1;
        // A splice can legitimately contain a whole valid frame; only the original garbled one
        // must not get through.
        for m in deframe(&mut d, &g).into_iter().flatten() {
            let is_whole_frame = frames.iter().any(|x| {
                deframe(&mut FrameDecoder::<MAX_FRAME>::new(), x)[0].as_ref().ok() == Some(&m)
            });
            undetected += !is_whole_frame as u32;
        }
    }
    println!("corruption: {trials} corrupted frames, {undetected} undetected");
    assert_eq!(undetected, 0);
}

#[test]
fn error_table_renders() {
    let mut s = String::new();
    markdown_table(&mut s).unwrap();
    for (code, name, desc) in ErrorCode::TABLE {
        assert!(s.contains(&format!("| {code} | {name} | {desc} |")));
    }
    assert_eq!(ErrorCode::Sequence.code(), 6);
    assert_eq!(ErrorCode::from_code(7), Some(ErrorCode::QueueFull));
    assert_eq!(ErrorCode::QueueFull.name(), "QueueFull");
}

/// A byte pipe with latency that drops or duplicates whole frames and corrupts or drops bytes.
struct Channel {
    rng: Rng,
    in_flight: VecDeque<(u64, Vec<u8>)>,
    frame_drop: f64,
    frame_dup: f64,
    byte_corrupt: f64,
    byte_drop: f64,
    latency_ms: u64,
}

impl Channel {
    fn new(seed: u64, frame_loss: f64, byte_noise: f64) -> Self {
        Channel {
            rng: Rng::new(seed),
            in_flight: VecDeque::new(),
            frame_drop: frame_loss,
            frame_dup: frame_loss,
            byte_corrupt: byte_noise / 2.0,
            byte_drop: byte_noise / 2.0,
            latency_ms: 3,
        }
    }

    fn send(&mut self, now: u64, frame: &[u8]) {
        if self.rng.chance(self.frame_drop) {
            return;
        }
        let mut bytes = Vec::with_capacity(frame.len());
        for &b in frame {
            if self.rng.chance(self.byte_drop) {
                continue;
            }
            if self.rng.chance(self.byte_corrupt) {
                bytes.push(b ^ (1 << self.rng.below(8)));
            } else {
                bytes.push(b);
            }
        }
        let dup = self.rng.chance(self.frame_dup);
        self.in_flight.push_back((now + self.latency_ms, bytes.clone()));
        if dup {
            self.in_flight.push_back((now + self.latency_ms, bytes));
        }
    }

    fn deliver(&mut self, now: u64) -> Vec<u8> {
        let mut out = Vec::new();
        while self.in_flight.front().is_some_and(|(t, _)| *t <= now) {
            out.extend(self.in_flight.pop_front().unwrap().1);
        }
        out
    }
}

struct SimResult {
    ms: u64,
    sent_frames: u64,
    retransmissions: u64,
    max_depth: u16,
}

/// Host -> lossy channel -> board -> lossy channel -> host, 1 ms steps. The board finishes one
/// segment every `drain_every` ms once started.
fn run_lossy(seed: u64, n_segments: u32, frame_loss: f64, byte_noise: f64) -> SimResult {
    const CAPACITY: u16 = 12;
    let mut rng = Rng::new(seed ^ 0x5EED);
    let mut target = SimTarget::new(config(), CAPACITY);
    let mut board = BoardLink::new("sim", CAP_DDA | CAP_STATUS_STREAM);
    let mut board_rx = FrameDecoder::<MAX_FRAME>::new();
    let mut host = HostLink::new(HostConfig { rto_ms: 25, window: 8 });
    let mut host_rx = FrameDecoder::<MAX_FRAME>::new();
    let mut h2b = Channel::new(seed, frame_loss, byte_noise);
    let mut b2h = Channel::new(seed.wrapping_add(1), frame_loss, byte_noise);

    let mut next_id = 0u32;
    let mut done_ids = Vec::new();
    let mut completed = HashSet::new();
    let mut setup_sent = false;
    let mut last_status_req = 0;
    // Frames the board must count as bad: failed COBS/CRC, or not a request.
    let mut bad_frames = 0u32;
    host.connect(rng.next() as u32);
    let mut now = 0u64;
    while done_ids.len() < n_segments as usize || host.in_flight() > 0 {
        now += 1;
        assert!(now < 2_000_000, "seed {seed}: stuck at {} segments", done_ids.len());
        // Host: new work, then whatever is due on the link.
        if host.is_connected() {
            if !setup_sent {
                host.send(RequestBody::SetStatusPeriod { ms: 20 }).unwrap();
                host.send(RequestBody::Start).unwrap();
                setup_sent = true;
            }
            while next_id < n_segments && host.window_free() > 0 {
                let n = (host.segment_credits() as u32)
                    .min(MAX_SEGMENTS_PER_FRAME as u32)
                    .min(n_segments - next_id)
                    .min(1 + rng.below(4) as u32);
                if n == 0 {
                    break;
                }
                let mut batch = SegmentBatch::default();
                for k in 0..n {
                    let id = next_id + k;
                    let x = (id % 50) as i32 - 25;
                    batch.push(seg(id, [x + 1, -(id as i32 % 7), 3])).unwrap();
                }
                host.send(RequestBody::QueueSegments(batch)).unwrap();
                next_id += n;
            }
            // Starved of credits with nothing in flight: ask (the stream would tell us too).
            if host.in_flight() == 0 && next_id < n_segments && now - last_status_req > 40 {
                host.send(RequestBody::GetStatus).unwrap();
                last_status_req = now;
            }
        }
        while let Some(req) = host.poll_transmit(now) {
            h2b.send(now, &frame(&req));
        }
        // Board: receive, answer, stream status, run the machine.
        for b in h2b.deliver(now) {
            if let Some(r) = board_rx.push(b) {
                bad_frames += r.is_err_and(|_| true) as u32
                    + r.is_ok_and(|m| decode_request(m).is_err()) as u32;
                let resp = board.on_frame(r, &mut target);
                assert!(
                    !matches!(
                        resp,
                        Response::Nak { code: ErrorCode::QueueFull | ErrorCode::Internal, .. }
                    ),
                    "seed {seed}: host overran the queue: {resp:?}"
                );
                b2h.send(now, &frame(&resp));
            }
        }
        if let Some(s) = board.poll(now, &target) {
            b2h.send(now, &frame(&s));
        }
        if now.is_multiple_of(2) {
            if let Some(s) = target.complete_one() {
                done_ids.push(s.id);
            }
        }
        // Host: answers.
        for b in b2h.deliver(now) {
            let Some(Ok(msg)) = host_rx.push(b) else {
                continue;
            };
            match host.receive_message(msg) {
                Some(HostEvent::Completed { seq, result, .. }) => {
                    assert!(completed.insert(seq), "seed {seed}: seq {seq} completed twice");
                    assert!(result.is_ok(), "seed {seed}: seq {seq} refused: {result:?}");
                }
                Some(HostEvent::SessionLost(c)) => panic!("seed {seed}: session lost ({c:?})"),
                Some(HostEvent::ConnectFailed(r)) => panic!("seed {seed}: connect failed {r:?}"),
                _ => {}
            }
        }
        assert!(target.queue_len() <= CAPACITY as usize);
    }
    let expected: Vec<u32> = (0..n_segments).collect();
    assert_eq!(done_ids, expected, "seed {seed}: segments lost, repeated or reordered");
    assert_eq!(target.queued_total, n_segments as u64, "seed {seed}: a segment was queued twice");
    assert!(target.max_depth <= CAPACITY);
    let counted = board.status(&target).counters.frames_bad;
    assert_eq!(counted, bad_frames, "seed {seed}: the board's bad-frame count");
    if byte_noise > 0.0 {
        assert!(counted > 0, "seed {seed}: byte noise and no bad frame counted");
    }
    SimResult {
        ms: now,
        sent_frames: host.sent_frames,
        retransmissions: host.retransmissions,
        max_depth: target.max_depth,
    }
}

#[test]
fn lossy_link_delivers_every_segment_exactly_once_in_order() {
    let t0 = Instant::now();
    // Clean link, then frame loss/duplication, then byte noise on top (1 % of bytes hit).
    for (seed, frame_loss, byte_noise) in
        [(1, 0.0, 0.0), (2, 0.01, 0.0), (3, 0.01, 0.01), (4, 0.05, 0.01), (5, 0.01, 0.01)]
    {
        let r = run_lossy(seed, 2000, frame_loss, byte_noise);
        println!(
            "seed {seed} frame loss/dup {frame_loss} byte noise {byte_noise}: 2000 segments in {} ms simulated, \
             {} frames sent ({} retransmissions), queue peak {}",
            r.ms, r.sent_frames, r.retransmissions, r.max_depth
        );
        if frame_loss == 0.0 && byte_noise == 0.0 {
            assert_eq!(r.retransmissions, 0);
        }
    }
    println!("lossy-link runs took {:?}", t0.elapsed());
}

/// More seeds and harsher links: `cargo test -p host-tests --profile test-fast --test protocol -- --ignored`.
#[test]
#[ignore]
fn lossy_link_many_seeds() {
    for seed in 100..300 {
        let frame_loss = [0.0, 0.01, 0.05, 0.2][seed as usize % 4];
        let byte_noise = [0.0, 0.001, 0.01, 0.03][seed as usize / 4 % 4];
        run_lossy(seed, 500, frame_loss, byte_noise);
    }
}

fn hello(seq: u32) -> Request {
    Request { seq, body: RequestBody::Hello { version: PROTOCOL_VERSION, nonce: seq } }
}

/// Sends `body` as the next request through the framing and returns the answer.
fn exchange(board: &mut BoardLink, t: &mut SimTarget, seq: u32, body: RequestBody) -> Response {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let f = frame(&Request { seq, body });
    let mut out = None;
    for b in f {
        if let Some(r) = d.push(b) {
            out = Some(board.on_frame(r, t));
        }
    }
    let resp = out.unwrap();
    decode_response(&deframe(&mut d, &frame(&resp))[0].clone().unwrap()).unwrap()
}

#[test]
fn refusals_in_every_state_change_nothing() {
    let mut t = SimTarget::new(config(), 8);
    let mut board = BoardLink::new("sim", CAP_DDA);
    let mut seq = 100;
    exchange(&mut board, &mut t, seq, hello(seq).body);
    let mut next = || {
        seq += 1;
        seq
    };
    let q = |segs: &[Segment]| RequestBody::QueueSegments(SegmentBatch::from_slice(segs).unwrap());
    let assert_refused =
        |board: &mut BoardLink, t: &mut SimTarget, seq: u32, body: RequestBody, code: ErrorCode| {
            let before = t.clone();
            let r = exchange(board, t, seq, body.clone());
            match &r {
                Response::Nak { code: c, .. } => assert_eq!(*c, code, "{body:?}"),
                _ => panic!("{body:?} accepted in {:?}: {r:?}", before.state()),
            }
            assert!(*t == before, "{body:?} changed the target");
            // The retransmission gets the same answer and changes nothing either.
            assert_eq!(exchange(board, t, seq, body), r);
            assert!(*t == before);
        };
    let mut big = config();
    big.machine.axes[0].max_rate_hz = 1;
    use ErrorCode::*;
    // Idle.
    assert_refused(&mut board, &mut t, next(), RequestBody::Hold, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::ClearFault, OutOfState);
    assert_refused(
        &mut board,
        &mut t,
        next(),
        RequestBody::SetOverride { rate_bits: u32::MAX },
        OutOfRange,
    );
    assert_refused(&mut board, &mut t, next(), RequestBody::SetStatusPeriod { ms: 9 }, OutOfRange);
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [0, 0, 0])]), InvalidSegment);
    assert_refused(
        &mut board,
        &mut t,
        next(),
        q(&[seg(1, [1, 0, 0]), seg(2, [0, 0, 1_000_000_000])]),
        InvalidSegment,
    );
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [11_000_000, 0, 0])]), InvalidSegment);
    // A refused Hello does not consume a seq (nor end the session).
    assert_refused(
        &mut board,
        &mut t,
        0,
        RequestBody::Hello { version: PROTOCOL_VERSION + 1, nonce: 1 },
        Version,
    );
    // Moving.
    for _ in 0..2 {
        assert!(matches!(
            exchange(&mut board, &mut t, next(), q(&[seg(1, [10, 0, 0]); 4])),
            Response::Ack { .. }
        ));
    }
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::Start),
        Response::Ack { .. }
    ));
    assert_eq!(t.state(), LinkState::Moving);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::SetConfig(config()), OutOfState);
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [10, 0, 0])]), QueueFull);
    // Held.
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::Hold),
        Response::Ack { .. }
    ));
    assert_refused(&mut board, &mut t, next(), RequestBody::Hold, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::SetConfig(big), OutOfState);
    // Faulted.
    t.raise_fault(FaultCode::EStop);
    assert_refused(&mut board, &mut t, next(), q(&[seg(5, [1, 0, 0])]), OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::ClearFault),
        Response::Ack { .. }
    ));
    assert_eq!(t.state(), LinkState::Idle);
    // Idle again: an invalid config names its field.
    let r = exchange(&mut board, &mut t, next(), RequestBody::SetConfig(big));
    let before = t.clone();
    assert!(matches!(r, Response::Ack { .. }), "max_rate_hz 1 is valid: {r:?}");
    let mut bad = config();
    bad.scale[1].steps_per_unit_milli = 0;
    let r = exchange(&mut board, &mut t, next(), RequestBody::SetConfig(bad));
    let Response::Nak { code: InvalidConfig, detail: NakDetail::Config { field, axis }, .. } = r
    else {
        panic!("{r:?}")
    };
    assert_eq!((field.as_str(), axis), ("steps_per_unit_milli", Some(1)));
    assert_eq!(bad.validate().unwrap_err().reason, "must be > 0");
    assert!(t == before);
}

#[test]
fn host_respects_credits_and_detects_board_reset() {
    let mut t = SimTarget::new(config(), 5);
    let mut board = BoardLink::new("sim", CAP_DDA);
    let mut host = HostLink::new(HostConfig::default());
    assert_eq!(host.send(RequestBody::Start), Err(SendError::NotConnected));
    host.connect(40);
    let pump = |host: &mut HostLink, board: &mut BoardLink, t: &mut SimTarget| {
        let mut evs = Vec::new();
        while let Some(req) = host.poll_transmit(0) {
            let resp = board.handle(&req, t);
            evs.extend(host.receive(resp));
        }
        evs
    };
    let evs = pump(&mut host, &mut board, &mut t);
    assert!(matches!(evs[..], [HostEvent::Connected(ref i)] if i.queue_capacity == 5));
    assert_eq!(host.segment_credits(), 5);
    let four = SegmentBatch::from_slice(&[seg(1, [1, 0, 0]); 4]).unwrap();
    host.send(RequestBody::QueueSegments(four.clone())).unwrap();
    assert_eq!(host.segment_credits(), 1, "in-flight segments count against credits");
    assert_eq!(
        host.send(RequestBody::QueueSegments(four.clone())),
        Err(SendError::NoCredits { available: 1 })
    );
    pump(&mut host, &mut board, &mut t);
    assert_eq!(host.segment_credits(), 1);
    t.start().unwrap();
    t.complete_one();
    t.complete_one();
    host.send(RequestBody::GetStatus).unwrap();
    pump(&mut host, &mut board, &mut t);
    assert_eq!(host.segment_credits(), 3);
    // The board resets: its next answer is NoSession and the host must reconnect.
    let mut board = BoardLink::new("sim", CAP_DDA);
    host.send(RequestBody::Abort).unwrap();
    let evs = pump(&mut host, &mut board, &mut t);
    assert_eq!(evs, vec![HostEvent::SessionLost(ErrorCode::NoSession)]);
    assert!(!host.is_connected());
    // A board speaking another version refuses the Hello.
    host.connect(1);
    let req = host.poll_transmit(0).unwrap();
    let ev = host.receive(Response::Nak {
        seq: req.seq,
        credits: 0,
        code: ErrorCode::Version,
        detail: NakDetail::None,
    });
    assert!(matches!(
        ev,
        Some(HostEvent::ConnectFailed(Rejection { code: ErrorCode::Version, .. }))
    ));
}

/// A request that is often valid, aimed near the board's next seq.
fn random_request(rng: &mut Rng, next_seq: u32) -> Request {
    let seq = match rng.below(8) {
        0 => rng.next() as u32,
        1..=2 => next_seq.wrapping_sub(rng.below(40) as u32),
        _ => next_seq.wrapping_add(rng.below(2) as u32),
    };
    let small = |rng: &mut Rng| (rng.below(400) as i32 - 200) * (rng.below(4) != 0) as i32;
    let body = match rng.below(15) {
        0 if rng.chance(0.9) => RequestBody::GetConfig,
        0 => RequestBody::Hello {
            version: if rng.chance(0.9) { PROTOCOL_VERSION } else { rng.next() as u16 },
            nonce: rng.below(4) as u32,
        },
        1 => RequestBody::GetConfig,
        2 => {
            let mut c = config();
            match rng.below(6) {
                0 => c.machine.tick_hz = rng.next() as u32,
                1 => c.machine.axis_count = rng.below(8) as u8,
                2 => c.machine.timing.pulse_ns = rng.below(100_000) as u32,
                3 => c.scale[rng.below(6) as usize].soft_min = rng.next() as i64,
                4 => c.machine.axes[rng.below(6) as usize].max_rate_hz = rng.next() as u32,
                _ => {}
            }
            RequestBody::SetConfig(c)
        }
        3..=5 => {
            let mut b = SegmentBatch::default();
            for _ in 0..rng.below(5) {
                let mut s = seg(rng.next() as u32, [small(rng), small(rng), small(rng)]);
                if rng.chance(0.2) {
                    s.duration_ticks = rng.next() as u32;
                    s.steps[rng.below(6) as usize] = rng.next() as i32;
                    s.exit_rate = Rate::from_bits(rng.next() as u32);
                    s.accel_per_tick = Rate::from_bits(rng.below(3) as u32);
                }
                let _ = b.push(s);
            }
            RequestBody::QueueSegments(b)
        }
        6 => RequestBody::Start,
        7 => RequestBody::Hold,
        8 => RequestBody::Resume,
        9 => {
            if rng.chance(0.3) {
                RequestBody::Abort
            } else {
                RequestBody::GetStatus
            }
        }
        10 => RequestBody::SetOverride { rate_bits: rng.next() as u32 >> rng.below(4) },
        11 => RequestBody::SetStatusPeriod { ms: rng.next() as u16 >> rng.below(16) },
        12 if rng.chance(0.5) => RequestBody::Home,
        12 => RequestBody::JogOffLimit,
        13 => {
            let mut h = HomingConfig::NONE;
            h.count = rng.below(3) as u8;
            h.order[0] = rng.below(4) as u8;
            h.axes[h.order[0] as usize].search_hz = rng.below(100_000) as u32;
            RequestBody::SetHoming(h)
        }
        _ => RequestBody::ClearFault,
    };
    Request { seq, body }
}

/// The board's whole receive path on a million inputs (`FUZZ_INPUTS` for longer runs, as
/// `cargo xtask bench` does): random bytes, valid frames of random (often valid) requests, and
/// those frames bit-flipped, truncated and spliced. A panic fails the test; every answer must
/// frame, and the queue must never be overrun.
#[test]
fn board_survives_a_million_hostile_inputs() {
    let inputs: u64 =
        std::env::var("FUZZ_INPUTS").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000);
    let t0 = Instant::now();
    let mut rng = Rng::new(0xF022);
    let mut target = SimTarget::new(config(), 16);
    let mut board = BoardLink::new("fuzz", CAP_DDA);
    let mut rx = FrameDecoder::<MAX_FRAME>::new();
    let mut host = HostLink::new(HostConfig::default());
    host.connect(3);
    let mut host_rx = FrameDecoder::<MAX_FRAME>::new();
    let mut out = [0u8; MAX_FRAME_LINK];
    let mut recent: Vec<Vec<u8>> = vec![frame(&hello(0))];
    let (mut frames_ok, mut frame_errors, mut acks, mut naks) = (0u64, 0u64, 0u64, 0u64);
    let mut input = Vec::with_capacity(1024);
    for i in 0..inputs {
        input.clear();
        let next = board.next_seq().unwrap_or(0);
        match rng.below(10) {
            0..=1 => {
                for _ in 0..rng.below(400) {
                    input.push(if rng.chance(0.05) { 0 } else { rng.byte() });
                }
            }
            2..=4 => {
                let f = frame(&random_request(&mut rng, next));
                input.extend_from_slice(&f);
                if recent.len() < 64 {
                    recent.push(f);
                } else {
                    let k = rng.below(64) as usize;
                    recent[k] = f;
                }
            }
            5..=6 => {
                let f = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(f);
                for _ in 0..1 + rng.below(3) {
                    let k = rng.below(input.len() as u64) as usize;
                    input[k] ^= 1 << rng.below(8);
                }
            }
            7 => {
                let f = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(&f[..rng.below(f.len() as u64) as usize]);
            }
            8 => {
                let a = &recent[rng.below(recent.len() as u64) as usize];
                let b = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(&a[..rng.below(a.len() as u64) as usize]);
                input.extend_from_slice(&b[rng.below(b.len() as u64) as usize..]);
            }
            _ => {
                // Valid COBS + CRC around random message bytes: exercises postcard decoding.
                let mut m = Vec::new();
                if rng.chance(0.5) {
                    varint(next, &mut m);
                }
                m.extend((0..1 + rng.below(60)).map(|_| rng.byte()));
                input.extend_from_slice(encode_payload_frame(&m, &mut out).unwrap());
            }
        }
        for &b in &input {
            let Some(r) = rx.push(b) else { continue };
            if r.is_ok() {
                frames_ok += 1
            } else {
                frame_errors += 1
            }
            let resp = board.on_frame(r, &mut target);
            match &resp {
                Response::Ack { .. } => acks += 1,
                Response::Nak { code, .. } => {
                    assert_ne!(*code, ErrorCode::Internal, "{resp:?}");
                    naks += 1
                }
                _ => {}
            }
            // Every answer frames, and the host side survives it too.
            let f = encode_frame(&resp, &mut out).expect("answers always fit");
            for &b in f {
                if let Some(Ok(m)) = host_rx.push(b) {
                    let _ = host.receive_message(m);
                }
            }
        }
        assert!(target.queue_len() <= 16);
        if rng.chance(0.2) {
            target.complete_one();
        }
        if rng.chance(0.001) {
            target.raise_fault(FaultCode::ALL[rng.below(8) as usize]);
        }
        if let Some(s) = board.poll(i, &target) {
            encode_frame(&s, &mut out).unwrap();
        }
        // Random bytes at the host's receive path too.
        if rng.chance(0.05) {
            for _ in 0..rng.below(200) {
                if let Some(Ok(m)) = host_rx.push(rng.byte()) {
                    let _ = host.receive_message(m);
                }
            }
        }
        let _ = host.poll_transmit(i);
    }
    println!(
        "fuzz: {inputs} inputs in {:?}: {frames_ok} CRC-valid frames, {frame_errors} bad frames, \
         {acks} acks, {naks} naks, {} segments queued",
        t0.elapsed(),
        target.queued_total
    );
    assert!(
        acks > 10_000 && target.queued_total > 1_000,
        "the fuzzer reaches the interesting paths"
    );
}
