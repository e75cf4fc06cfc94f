//! Double-buffered ADC frames from a circular DMA stream, board-independent: which half of the
//! buffer is ready from the stream's half-transfer / transfer-complete flags, and every way a
//! half can be lost (both flags pending = the consumer missed a half; the DMA already back in the
//! half about to be read; DMA transfer or direct-mode error; ADC overrun). The DMA's FIFO error
//! flag is counted, not a fault: in direct mode it also rises under bus contention without any
//! data lost (zephyrproject-rtos/zephyr PR #112397, STM32CubeH7 HAL issue #76), and real loss
//! of an ADC conversion shows as the ADC's own overrun flag. The board driver
//! (`boards/f405_motion/force_adc.rs`) reads the registers and hands the bits to [`HalfTracker`].
//!
//! Interrupt-rate code: a few compares, no division.

use super::chain::MAX_CHANNELS;

/// One half of the double buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Half {
    /// Frames `0..frames_per_half`: ready at half transfer.
    First,
    /// Frames `frames_per_half..2 * frames_per_half`: ready at transfer complete.
    Second,
}

impl Half {
    /// 0 or 1: the half's index, for the frame offset `index * frames_per_half`.
    #[inline]
    pub const fn index(self) -> usize {
        match self {
            Half::First => 0,
            Half::Second => 1,
        }
    }

    const fn other(self) -> Half {
        match self {
            Half::First => Half::Second,
            Half::Second => Half::First,
        }
    }
}

/// A DMA stream's five status flags (RM0090 10.5.1: FEIF, DMEIF, TEIF, HTIF, TCIF).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DmaFlags {
    pub fifo_error: bool,
    pub direct_mode_error: bool,
    pub transfer_error: bool,
    pub half_transfer: bool,
    pub transfer_complete: bool,
}

/// Stream 0's flag bits in DMA_LISR / DMA_LIFCR (streams 1..3 sit at +6, +16, +22).
pub const STREAM0_FLAG_BITS: u32 = 0b11_1101;

impl DmaFlags {
    /// Stream 0's flags from a DMA_LISR value: FEIF0 bit 0, DMEIF0 bit 2, TEIF0 bit 3,
    /// HTIF0 bit 4, TCIF0 bit 5.
    #[inline]
    pub const fn from_lisr_stream0(lisr: u32) -> Self {
        DmaFlags {
            fifo_error: lisr & 1 != 0,
            direct_mode_error: lisr & (1 << 2) != 0,
            transfer_error: lisr & (1 << 3) != 0,
            half_transfer: lisr & (1 << 4) != 0,
            transfer_complete: lisr & (1 << 5) != 0,
        }
    }
}

/// Why the sample stream stopped being trustworthy. The firmware reports any of these as
/// `FaultCode::SensorFault`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameOverrun {
    /// DMA transfer error (bus error; the hardware disabled the stream).
    DmaTransfer,
    /// DMA direct-mode error (a request came before the previous data reached memory).
    DmaDirectMode,
    /// ADC overrun: a conversion finished before the DMA read the previous one.
    Adc,
    /// A half completed while the previous one was still unread (the interrupt came too late).
    MissedHalf,
    /// The DMA was already writing into the half about to be handed out.
    Overwritten,
}

/// The DMA stream's position: which half it is writing, from NDTR (items still to transfer in
/// this cycle, counting down from `2 * half_items` to 1 and reloading).
#[inline]
pub const fn half_being_written(remaining_items: u16, half_items: u16) -> Half {
    if remaining_items > half_items {
        Half::First
    } else {
        Half::Second
    }
}

/// Tracks the halves of a circular double buffer across DMA interrupts; latches the first
/// overrun (after which no half is handed out again until [`HalfTracker::restart`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HalfTracker {
    half_items: u16,
    expected: Half,
    overrun: Option<FrameOverrun>,
    halves: u32,
    fifo_errors: u32,
}

impl HalfTracker {
    /// A tracker for a buffer of `2 * half_items` DMA items, the stream just started.
    pub const fn new(half_items: u16) -> Self {
        HalfTracker { half_items, expected: Half::First, overrun: None, halves: 0, fifo_errors: 0 }
    }

    /// The stream restarted from the buffer's start: forget the overrun.
    pub fn restart(&mut self) {
        *self = HalfTracker::new(self.half_items);
    }

    /// One DMA interrupt: the flags read (and cleared) on entry, NDTR read after them, and the
    /// ADC's overrun bit. Returns the half now safe to read, `None` if nothing is ready (spurious
    /// interrupt) or the stream is overrun ([`HalfTracker::overrun`] says why).
    #[inline]
    pub fn on_irq(
        &mut self,
        flags: DmaFlags,
        remaining_items: u16,
        adc_overrun: bool,
    ) -> Option<Half> {
        if flags.fifo_error {
            self.fifo_errors = self.fifo_errors.saturating_add(1);
        }
        if self.overrun.is_some() {
            return None;
        }
        let cause = if flags.transfer_error {
            Some(FrameOverrun::DmaTransfer)
        } else if flags.direct_mode_error {
            Some(FrameOverrun::DmaDirectMode)
        } else if adc_overrun {
            Some(FrameOverrun::Adc)
        } else if flags.half_transfer && flags.transfer_complete {
            Some(FrameOverrun::MissedHalf)
        } else {
            None
        };
        if cause.is_some() {
            self.overrun = cause;
            return None;
        }
        let ready = match (flags.half_transfer, flags.transfer_complete) {
            (true, _) => Half::First,
            (false, true) => Half::Second,
            (false, false) => return None,
        };
        if ready != self.expected {
            // HT twice (or TC twice) in a row: the interrupt of the half between was lost.
            self.overrun = Some(FrameOverrun::MissedHalf);
            return None;
        }
        if half_being_written(remaining_items, self.half_items) == ready {
            self.overrun = Some(FrameOverrun::Overwritten);
            return None;
        }
        self.expected = ready.other();
        self.halves = self.halves.wrapping_add(1);
        Some(ready)
    }

    /// The latched overrun, if any.
    pub const fn overrun(&self) -> Option<FrameOverrun> {
        self.overrun
    }

    /// DMA FIFO error flags seen (a bus-contention warning, not a loss: see the module doc).
    pub const fn fifo_errors(&self) -> u32 {
        self.fifo_errors
    }

    /// Halves handed out since the start (wraps).
    pub const fn halves(&self) -> u32 {
        self.halves
    }
}

/// The counts the force chain takes from one ADC frame: its first [`MAX_CHANNELS`] channels
/// (the chain carries Fx, Fy, Fz; further sensors in the frame are not part of it), zero where
/// the frame is shorter.
#[inline]
pub fn chain_counts<const N: usize>(frame: &[u16; N]) -> [u16; MAX_CHANNELS] {
    let mut out = [0u16; MAX_CHANNELS];
    for (o, c) in out.iter_mut().zip(frame.iter()) {
        *o = *c;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const HALF: u16 = 20; // 5 frames of 4 channels

    fn ht() -> DmaFlags {
        DmaFlags { half_transfer: true, ..DmaFlags::default() }
    }
    fn tc() -> DmaFlags {
        DmaFlags { transfer_complete: true, ..DmaFlags::default() }
    }

    #[test]
    fn lisr_bits_map_to_stream0_flags() {
        // Every stream-0 bit alone, and a stream-1 bit (6) that must be ignored.
        assert_eq!(
            DmaFlags::from_lisr_stream0(1),
            DmaFlags { fifo_error: true, ..Default::default() }
        );
        assert!(DmaFlags::from_lisr_stream0(1 << 2).direct_mode_error);
        assert!(DmaFlags::from_lisr_stream0(1 << 3).transfer_error);
        assert_eq!(DmaFlags::from_lisr_stream0(1 << 4), ht());
        assert_eq!(DmaFlags::from_lisr_stream0(1 << 5), tc());
        assert_eq!(DmaFlags::from_lisr_stream0(0x3f << 6), DmaFlags::default());
        assert_eq!(STREAM0_FLAG_BITS, 0x3f & !(1 << 1), "bit 1 is reserved");
    }

    #[test]
    fn halves_alternate_and_each_is_read_while_the_dma_fills_the_other() {
        let mut t = HalfTracker::new(HALF);
        for k in 0..10 {
            // HT: the DMA has just moved into the second half (remaining <= HALF).
            assert_eq!(t.on_irq(ht(), HALF - (k % 3), false), Some(Half::First));
            // TC: reloaded to 2 * HALF, writing the first half.
            assert_eq!(t.on_irq(tc(), 2 * HALF - (k % 3), false), Some(Half::Second));
        }
        assert_eq!(t.halves(), 20);
        assert_eq!(t.overrun(), None);
        assert_eq!(t.on_irq(DmaFlags::default(), HALF, false), None, "spurious");
        assert_eq!(t.overrun(), None);
    }

    #[test]
    fn every_loss_latches_its_cause() {
        let cases: [(DmaFlags, u16, bool, FrameOverrun); 5] = [
            (DmaFlags { transfer_error: true, ..ht() }, HALF, false, FrameOverrun::DmaTransfer),
            (
                DmaFlags { direct_mode_error: true, ..ht() },
                HALF,
                false,
                FrameOverrun::DmaDirectMode,
            ),
            (ht(), HALF, true, FrameOverrun::Adc),
            (DmaFlags { transfer_complete: true, ..ht() }, HALF, false, FrameOverrun::MissedHalf),
            // First half ready, but NDTR says the DMA wrapped back into it.
            (ht(), HALF + 1, false, FrameOverrun::Overwritten),
        ];
        for (flags, remaining, adc, cause) in cases {
            let mut t = HalfTracker::new(HALF);
            assert_eq!(t.on_irq(flags, remaining, adc), None, "{cause:?}");
            assert_eq!(t.overrun(), Some(cause));
            // Latched: even a clean interrupt hands nothing out.
            assert_eq!(t.on_irq(ht(), HALF, false), None);
            assert_eq!(t.overrun(), Some(cause));
            t.restart();
            assert_eq!(t.on_irq(ht(), HALF, false), Some(Half::First));
        }
        // A FIFO error alone is counted and the half still handed out.
        let mut t = HalfTracker::new(HALF);
        assert_eq!(t.on_irq(DmaFlags { fifo_error: true, ..ht() }, HALF, false), Some(Half::First));
        assert_eq!((t.overrun(), t.fifo_errors()), (None, 1));
        // HT, then HT again: the TC between was lost.
        let mut t = HalfTracker::new(HALF);
        assert_eq!(t.on_irq(ht(), HALF, false), Some(Half::First));
        assert_eq!(t.on_irq(ht(), HALF, false), None);
        assert_eq!(t.overrun(), Some(FrameOverrun::MissedHalf));
        // TC while the DMA is already in the second half again.
        let mut t = HalfTracker::new(HALF);
        assert_eq!(t.on_irq(ht(), 1, false), Some(Half::First));
        assert_eq!(t.on_irq(tc(), HALF, false), None);
        assert_eq!(t.overrun(), Some(FrameOverrun::Overwritten));
    }

    #[test]
    fn chain_takes_the_first_three_channels() {
        assert_eq!(chain_counts(&[10, 20, 30, 40]), [10, 20, 30]);
        assert_eq!(chain_counts(&[7, 8]), [7, 8, 0]);
    }

    proptest! {
        /// A simulated circular DMA and a consumer that is sometimes late: the tracker hands out
        /// exactly the halves that were complete and untouched, in order, and latches an overrun
        /// the first time the consumer was too late.
        #[test]
        fn simulated_stream(delays in proptest::collection::vec(0u16..60, 1..40)) {
            let total = 2 * HALF;
            let mut t = HalfTracker::new(HALF);
            // Items written so far; flags pending since the last interrupt.
            let mut written: u32 = 0;
            let mut pending = DmaFlags::default();
            let mut expected = Half::First;
            for d in delays {
                // The DMA moves to the next event, then on by `d` more items before the CPU reads.
                let to_event = HALF as u32 - (written % HALF as u32);
                for _ in 0..to_event + d as u32 {
                    written += 1;
                    let pos = (written % total as u32) as u16;
                    if pos == HALF { pending.half_transfer = true; }
                    if pos == 0 { pending.transfer_complete = true; }
                }
                let remaining = total - (written % total as u32) as u16;
                let got = t.on_irq(pending, remaining, false);
                // Oracle from the simulation alone: once the DMA is a whole half past the event,
                // it has finished the other half and reached (or entered) the ready one.
                let late = d >= HALF;
                if late {
                    prop_assert_eq!(got, None);
                    prop_assert!(t.overrun().is_some());
                    break;
                }
                prop_assert_eq!(got, Some(expected));
                expected = expected.other();
                pending = DmaFlags::default();
            }
        }
    }
}
