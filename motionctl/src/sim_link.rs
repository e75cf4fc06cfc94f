//! The byte side every in-process simulated board shares: frames decoded from what the host
//! sent, run through the board's `BoardLink` on its target, and the answers encoded into the
//! bytes the host reads next (the firmware's USART task, without the USART).

use motion::protocol::{
    encode_frame, BoardLink, FrameDecoder, LinkTarget, Response, MAX_FRAME, MAX_FRAME_LINK,
};
use std::time::Duration;

/// How long a simulated board's `recv` waits when it has nothing to say yet, at most (as a real
/// port would, so a polling host does not spin).
pub const IDLE_WAIT: Duration = Duration::from_millis(1);

/// Decoder in, encoded answers out.
pub struct SimLink {
    decoder: FrameDecoder<MAX_FRAME>,
    out: Vec<u8>,
}

impl Default for SimLink {
    fn default() -> Self {
        Self::new()
    }
}

impl SimLink {
    pub fn new() -> Self {
        SimLink { decoder: FrameDecoder::new(), out: Vec::new() }
    }

    /// Every frame in `bytes` through `board` on `target`, its answer queued; the frames
    /// decoded (good or bad).
    pub fn receive(
        &mut self,
        bytes: &[u8],
        board: &mut BoardLink,
        target: &mut impl LinkTarget,
    ) -> u64 {
        let mut frames = 0;
        for &b in bytes {
            if let Some(frame) = self.decoder.push(b) {
                frames += 1;
                let resp = board.on_frame(frame, target);
                Self::encode(&mut self.out, &resp);
            }
        }
        frames
    }

    /// Queues `resp` (a status the board sends by itself).
    pub fn emit(&mut self, resp: &Response) {
        Self::encode(&mut self.out, resp);
    }

    fn encode(out: &mut Vec<u8>, resp: &Response) {
        let mut buf = [0u8; MAX_FRAME_LINK];
        if let Ok(f) = encode_frame(resp, &mut buf) {
            out.extend_from_slice(f);
        }
    }

    /// Nothing queued for the host.
    pub fn is_empty(&self) -> bool {
        self.out.is_empty()
    }

    /// The queued bytes, taken.
    pub fn take(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Drops what is queued (a board that went silent).
    pub fn clear(&mut self) {
        self.out.clear();
    }

    /// A reconnect: a half-received frame is dropped.
    pub fn reset(&mut self) {
        self.decoder.reset();
    }

    /// The wait before a second look when there is nothing to send: at most [`IDLE_WAIT`].
    pub fn idle_wait(timeout: Duration) {
        std::thread::sleep(timeout.min(IDLE_WAIT));
    }
}
