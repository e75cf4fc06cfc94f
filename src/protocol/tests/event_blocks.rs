//! Event blocks (the polar stream): checked whole before anything is queued, credits counted in
//! blocks, the machine's table deciding the state.

use super::*;
use crate::polar::link_messages::PolarRequest;

/// The blocks of the built-in limacon stream.
fn stream_blocks() -> Vec<&'static [u8]> {
    crate::polar::stream::data_blocks(crate::polar::limacon_stream::BYTES)
}

fn events(seq: u32, block: &[u8], last: bool) -> Request {
    req(
        seq,
        RequestBody::from(PolarRequest::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(block).unwrap(),
            last,
        })),
    )
}

fn event_credits(r: &Response) -> Option<u16> {
    match r {
        Response::Ack { reply: Reply::EventCredits(c), .. } => Some(*c),
        _ => None,
    }
}

#[test]
fn event_blocks_are_checked_whole_before_anything_is_queued() {
    let bl = stream_blocks();
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_EVENTS);
    b.handle(&hello(0, 1), &mut t);
    let before = t.clone();
    // One flipped payload bit: the CRC refuses it, nothing is queued, the NAK says why.
    let mut bad = bl[0].to_vec();
    bad[crate::polar::stream::HEADER_LEN + 2] ^= 0x04;
    let r = b.handle(&events(1, &bad, false), &mut t);
    assert_eq!(
        r,
        Response::Nak {
            seq: 1,
            credits: 4,
            code: ErrorCode::InvalidSegment,
            detail: NakDetail::Block {
                reason: crate::polar::stream::StreamError::Crc.code(),
                expected: Some(0)
            },
        }
    );
    // Out of sequence (block 1 first) and bytes after the block: refused too.
    let r = b.handle(&events(2, bl[1], false), &mut t);
    assert!(
        matches!(r, Response::Nak { detail: NakDetail::Block { reason: 10, .. }, .. }),
        "{r:?}"
    );
    let mut two = bl[0].to_vec();
    two.push(0xB5);
    let r = b.handle(&events(3, &two, false), &mut t);
    assert!(matches!(r, Response::Nak { detail: NakDetail::Block { reason: 9, .. }, .. }), "{r:?}");
    // Size scale outside 1..=4, and a start with nothing queued.
    let r =
        b.handle(&req(4, RequestBody::from(PolarRequest::StartPlayback { m: 5, k: 1 })), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfRange));
    let r =
        b.handle(&req(5, RequestBody::from(PolarRequest::StartPlayback { m: 1, k: 0 })), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfRange));
    let r =
        b.handle(&req(6, RequestBody::from(PolarRequest::StartPlayback { m: 1, k: 1 })), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    assert_eq!(t, before, "refusals change nothing");
    assert_eq!(t.events.events_admitted, 0);
}

#[test]
fn event_credits_count_blocks_and_the_machine_table_decides_the_state() {
    let bl = stream_blocks();
    let cap = crate::protocol::sim::SIM_EVENT_BLOCKS as u16;
    assert!(bl.len() > cap as usize + 2, "{} blocks", bl.len());
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_EVENTS);
    b.handle(&hello(0, 1), &mut t);
    let mut s = 1;
    // Segments and events never share a job.
    assert!(matches!(b.handle(&queue(s, &[seg(1, 10)]), &mut t), Response::Ack { .. }));
    s += 1;
    let r = b.handle(&events(s, bl[0], false), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    b.handle(&req(s, RequestBody::Abort), &mut t);
    s += 1;
    // Credits are blocks: each Ack carries what is left, until none; then QueueFull.
    for (i, block) in bl.iter().take(cap as usize).enumerate() {
        let r = b.handle(&events(s, block, false), &mut t);
        s += 1;
        assert_eq!(event_credits(&r), Some(cap - 1 - i as u16), "{r:?}");
    }
    let r = b.handle(&events(s, bl[cap as usize], false), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::QueueFull));
    // A retransmitted QueueEvents is answered from memory (credits of the time), not queued.
    let again = b.handle(&events(s - 2, bl[cap as usize - 1], false), &mut t);
    assert_eq!(event_credits(&again), Some(0));
    assert_eq!(t.events.blocks(), cap as usize);
    // Status reports the event credits; segments are refused while events are queued.
    let Response::Ack { reply: Reply::Status(st), .. } =
        b.handle(&req(s, RequestBody::GetStatus), &mut t)
    else {
        panic!()
    };
    s += 1;
    assert_eq!((st.event_credits, st.event_blocks, st.events_fired), (0, cap, 0));
    let r = b.handle(&queue(s, &[seg(2, 10)]), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    // Start (Ready -> Running, the table's Start column); a second start is refused by it.
    let r =
        b.handle(&req(s, RequestBody::from(PolarRequest::StartPlayback { m: 3, k: 2 })), &mut t);
    s += 1;
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    assert_eq!(t.machine_state(), crate::machine::MachineState::Running);
    let r =
        b.handle(&req(s, RequestBody::from(PolarRequest::StartPlayback { m: 3, k: 2 })), &mut t);
    s += 1;
    assert!(matches!(
        r,
        Response::Nak {
            code: ErrorCode::OutOfState,
            detail: NakDetail::State(crate::machine::MachineState::Running),
            ..
        }
    ));
    // Playing frees slots; with no block marked last, running dry is an underrun after every
    // admitted event fired.
    let admitted = t.events.events_admitted;
    let in_blocks: u32 = bl[..cap as usize]
        .iter()
        .map(|b| crate::polar::stream::parse_block(b).unwrap().0.events as u32)
        .sum();
    assert_eq!(admitted, in_blocks);
    t.run_events(50_000_000);
    assert_ne!(t.faults & FaultCode::QueueUnderrun.bit(), 0);
    assert_eq!(t.machine_state(), crate::machine::MachineState::Fault);
    assert_eq!(t.playback.fired(), admitted);
    let Response::Ack { reply: Reply::Status(st), .. } =
        b.handle(&req(s, RequestBody::GetStatus), &mut t)
    else {
        panic!()
    };
    assert_eq!((st.events_fired, st.event_credits), (admitted, cap));
}
