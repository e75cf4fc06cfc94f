//! The streamed step output under QEMU, which models neither DMA nor GPIO: the words go to a
//! two-half buffer in RAM, and TIM2's update interrupt, at the slot rate / [`STREAM_SLOTS`],
//! stands in for the DMA's half interrupt (`tick_timer.rs`). The fill interrupt is the same
//! code as on a board whose DMA plays the buffer, and it costs the same; what the words do to
//! the pins is proven on the host (`motion::dda::edge_stream`).

use board_contract::STREAM_SLOTS;
use motion::dda::edge_stream::PortWords;

/// STEP on pins 0..6 and DIR on pins 6..12 of one port, as the F405 motion board's GPIOC.
const LAYOUT: PortWords = match PortWords::new(0, 6, 6) {
    Ok(l) => l,
    Err(_) => panic!("the QEMU board's step pins do not fit one port"),
};

pub struct StepStream {
    halves: [[u32; STREAM_SLOTS]; 2],
    next: usize,
}

impl StepStream {
    pub const fn new() -> Self {
        StepStream { halves: [[0; STREAM_SLOTS]; 2], next: 0 }
    }
}

impl Default for StepStream {
    fn default() -> Self {
        Self::new()
    }
}

impl board_contract::StepStream for StepStream {
    #[inline(always)]
    fn layout(&self) -> PortWords {
        LAYOUT
    }

    #[inline(always)]
    fn half(&mut self) -> &mut [u32; STREAM_SLOTS] {
        let i = self.next;
        self.next ^= 1;
        &mut self.halves[i & 1]
    }
}
