//! [`HostPort`]: the serial driver and the transmit byte queue.

use heapless::Deque;
use motion::protocol::{encode_frame, Response, MAX_FRAME_LINK};

use crate::board;
use board_contract::HostSerial as _;

use super::*;

/// The serial port and its transmit queue.
pub struct HostPort {
    pub serial: board::HostSerial,
    tx: Deque<u8, TX_BUFFER>,
    /// Responses dropped because the queue could not hold them whole.
    pub dropped: u32,
}

impl HostPort {
    pub fn new(mut serial: board::HostSerial) -> Self {
        serial.listen_rx();
        HostPort { serial, tx: Deque::new(), dropped: 0 }
    }

    /// Encodes and queues one response; false if it was dropped.
    pub fn send(&mut self, resp: &Response) -> bool {
        let mut buf = [0u8; MAX_FRAME_LINK];
        match encode_frame(resp, &mut buf) {
            Ok(frame) => self.queue_frame(frame),
            Err(_) => {
                self.dropped = self.dropped.wrapping_add(1);
                false
            }
        }
    }

    /// Queues one encoded frame whole, or drops it; starts the transmitter.
    pub fn queue_frame(&mut self, frame: &[u8]) -> bool {
        if TX_BUFFER - self.tx.len() < frame.len() {
            self.dropped = self.dropped.wrapping_add(1);
            return false;
        }
        for &b in frame {
            // Cannot fail: checked for room above.
            let _ = self.tx.push_back(b);
        }
        self.pump();
        true
    }

    /// Moves queued bytes into the USART while it takes them; the TXE interrupt is on exactly
    /// while bytes wait.
    pub fn pump(&mut self) {
        while let Some(&b) = self.tx.front() {
            if !self.serial.write_byte(b) {
                self.serial.listen_tx(true);
                return;
            }
            self.tx.pop_front();
        }
        self.serial.listen_tx(false);
    }
}

/// Encodes `resp` into `buf` for [`HostPort::queue_frame`]; outside any lock.
pub fn encode<'b>(resp: &Response, buf: &'b mut [u8; MAX_FRAME_LINK]) -> Option<&'b [u8]> {
    encode_frame(resp, buf).ok()
}
