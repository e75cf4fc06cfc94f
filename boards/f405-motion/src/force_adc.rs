//! Force sensors: ADC1 scans the force channels (pins.rs `FORCE_CHANNELS`) once per TIM8 update
//! (TRGO), DMA2 stream 0 channel 0 moves each conversion into a circular double buffer, and the
//! `DMA2_STREAM0` interrupt (half transfer, transfer complete) hands out the half just filled.
//! The flag logic (which half, what was lost) is `motion::milling::dma_frames`; the timer math is
//! `motion::milling::sample_timer`. Registers only here.

use super::pins::FORCE_CHANNELS;
use crate::pac;
use core::sync::atomic::{compiler_fence, Ordering};
use motion::milling::chain::DECIMATION;
use motion::milling::dma_frames::{DmaFlags, FrameOverrun, HalfTracker, STREAM0_FLAG_BITS};
use motion::milling::sample_timer::{max_scan_hz, sample_timing, SampleRateError, SampleTiming};

use board_contract::{ForceFrame, FORCE_CHANNEL_COUNT};

const _: () =
    assert!(FORCE_CHANNELS.len() == FORCE_CHANNEL_COUNT, "one ADC channel per force axis");
/// Frames per half buffer: one control update's worth (the chain decimates by this), so each
/// DMA interrupt yields exactly one decimated reading once the chain's phase is aligned.
pub const FRAMES_PER_HALF: usize = DECIMATION as usize;
/// The DMA's circular buffer: two halves of [`FRAMES_PER_HALF`] frames.
pub type ForceDmaBuffer = [ForceFrame; 2 * FRAMES_PER_HALF];

/// DMA items (half-words) per half buffer.
const HALF_ITEMS: u16 = (FRAMES_PER_HALF * FORCE_CHANNEL_COUNT) as u16;
/// ADC clock: PCLK2 84 MHz / 4 (ADC_COMMON.CCR ADCPRE, set in `init_common`).
const ADC_HZ: u32 = 21_000_000;
/// Sampling time of every force channel, ADC cycles (SMPR value below must match).
const SAMPLING_CYCLES: u32 = 84;

/// ADC1 + DMA2 stream 0 + TIM8, and the buffer the DMA fills.
pub struct ForceAdc {
    adc: pac::ADC1,
    dma: pac::DMA2,
    tim: pac::TIM8,
    /// The `'static` buffer as a raw pointer: the DMA writes one half while the CPU reads the
    /// other, so no `&mut` to the whole buffer may exist once the stream runs.
    buf: *mut ForceFrame,
    tracker: HalfTracker,
    timer_hz: u32,
    timing: Option<SampleTiming>,
}

// SAFETY: the raw pointer is the only access path to a `'static` buffer owned by this driver;
// moving the driver to the task that runs the DMA interrupt moves that ownership with it.
unsafe impl Send for ForceAdc {}

/// ADC clock prescaler shared by ADC1 and ADC2: PCLK2 / 4 = 21 MHz (datasheet max 36 MHz).
pub fn init_common(common: &pac::ADC_COMMON) {
    // Independent mode (MULTI = 0): ADC1 and ADC2 trigger and convert on their own.
    common.ccr().modify(|_, w| w.adcpre().div4().multi().independent());
}

impl ForceAdc {
    /// Configures ADC1's scan sequence, the DMA stream and TIM8 as a trigger; nothing runs until
    /// [`ForceAdc::start`]. `timer_hz` is TIM8's clock (APB2 timers, 168 MHz). TIM8 rather than
    /// TIM3: TIM3's pins carry the copy-mode carriage encoder (`pins.rs`), and a trigger needs
    /// no pins.
    pub fn new(
        adc: pac::ADC1,
        dma: pac::DMA2,
        tim: pac::TIM8,
        buf: &'static mut ForceDmaBuffer,
        timer_hz: u32,
    ) -> Self {
        for (rank, &ch) in FORCE_CHANNELS.iter().enumerate() {
            // 84 cycles: the force amplifiers' source impedance needs a long sample (RM0090 13.3.11).
            adc.smpr2().modify(|_, w| w.smp(ch).cycles84());
            // SAFETY: ranks 1..=4 in SQR3, channel numbers 0..=18 are valid SQ values.
            adc.sqr3().modify(|_, w| unsafe { w.sq(rank as u8).bits(ch) });
        }
        // L = conversions - 1.
        adc.sqr1().modify(|_, w| w.l().set(FORCE_CHANNEL_COUNT as u8 - 1));
        // Scan mode: one trigger converts the whole sequence; 12 bits; no ADC interrupts (the
        // DMA interrupt polls OVR).
        adc.cr1().write(|w| w.scan().enabled().res().twelve_bit());
        adc.cr2().write(|w| w.adon().enabled());
        // TIM8 only counts and emits TRGO on update; no interrupt, no outputs (MOE stays 0).
        tim.cr1().write(|w| w.arpe().enabled());
        tim.cr2().write(|w| w.mms().update());
        ForceAdc {
            adc,
            dma,
            tim,
            buf: buf.as_mut_ptr(),
            tracker: HalfTracker::new(HALF_ITEMS),
            timer_hz,
            timing: None,
        }
    }

    /// Highest accepted sample rate (one scan must end before the next trigger).
    pub const fn max_sample_hz() -> u32 {
        max_scan_hz(ADC_HZ, FORCE_CHANNEL_COUNT as u32, SAMPLING_CYCLES)
    }

    /// (Re)starts sampling at `sample_hz` (>= 5 kHz) from the buffer's first frame; returns the
    /// rate the timer gives (the chain's control rate is this / `DECIMATION`).
    pub fn start_sampling(&mut self, sample_hz: u32) -> Result<u32, SampleRateError> {
        let timing = sample_timing(self.timer_hz, sample_hz, Self::max_sample_hz())?;
        self.stop();
        let st = self.dma.st(0);
        // Stream configuration is only writable with EN = 0 (it may take a transfer to drop).
        while st.cr().read().en().bit_is_set() {}
        // SAFETY: stream 0's flag bits in LIFCR are write-1-to-clear.
        self.dma.lifcr().write(|w| unsafe { w.bits(STREAM0_FLAG_BITS) });
        st.par().write(|w| unsafe { w.pa().bits(self.adc.dr().as_ptr() as u32) });
        st.m0ar().write(|w| unsafe { w.m0a().bits(self.buf as u32) });
        st.ndtr().write(|w| w.ndt().set(2 * HALF_ITEMS));
        // Direct mode (no FIFO: one half-word per request). No FIFO error interrupt: in direct
        // mode FEIF also rises under bus contention with nothing lost (see `dma_frames`); a lost
        // conversion shows as ADC OVR instead.
        st.fcr().write(|w| w.dmdis().enabled().feie().disabled());
        st.cr().write(|w| {
            // Channel 0 routes ADC1 to stream 0 (RM0090 table 43).
            w.chsel().set(0);
            w.pl().high().msize().bits16().psize().bits16().minc().incremented();
            w.pinc().fixed().circ().enabled().dir().peripheral_to_memory();
            w.tcie().enabled().htie().enabled().teie().enabled().dmeie().enabled()
        });
        st.cr().modify(|_, w| w.en().enabled());

        // Trigger timer loaded with UG while the ADC ignores TRGO, so that update starts nothing.
        self.tim.psc().write(|w| w.psc().set(timing.psc));
        self.tim.arr().write(|w| w.arr().set(timing.arr));
        self.tim.egr().write(|w| w.ug().set_bit());
        self.tim.sr().write(|w| unsafe { w.bits(0) });

        // OVR from an earlier run would stop the DMA requests; clear it, then DMA with DDS
        // (requests continue after the last item: circular), triggered by TIM8_TRGO rising.
        self.adc.sr().modify(|_, w| w.ovr().clear_bit());
        self.adc.cr2().write(|w| {
            w.adon().enabled().dma().enabled().dds().continuous();
            w.extsel().tim8trgo().exten().rising_edge()
        });
        self.tracker.restart();
        self.timing = Some(timing);
        self.tim.cr1().modify(|_, w| w.cen().enabled());
        Ok(timing.actual_hz)
    }

    /// Stops the trigger, the ADC's DMA requests and the stream (idempotent).
    pub fn stop(&mut self) {
        self.tim.cr1().modify(|_, w| w.cen().disabled());
        self.adc.cr2().write(|w| w.adon().enabled());
        self.dma.st(0).cr().modify(|_, w| w.en().disabled());
    }

    /// The `DMA2_STREAM0` interrupt: acknowledges the stream's flags and returns the half just
    /// completed (`FRAMES_PER_HALF` frames, valid until the DMA comes back to it: one half
    /// period, `FRAMES_PER_HALF / sample_hz`). `None` on a spurious interrupt or once an overrun
    /// is latched ([`ForceAdc::overrun_cause`]); sampling then stops. No division, bounded time.
    #[inline]
    pub fn take_half(&mut self) -> Option<&[ForceFrame]> {
        let lisr = self.dma.lisr().read().bits();
        // SAFETY: clears exactly the stream-0 flags just read (write-1-to-clear).
        self.dma.lifcr().write(|w| unsafe { w.bits(lisr & STREAM0_FLAG_BITS) });
        // NDTR after the flags: where the DMA is now, for the overwrite check.
        let remaining = self.dma.st(0).ndtr().read().ndt().bits();
        let adc_overrun = self.adc.sr().read().ovr().bit_is_set();
        let ready = self.tracker.on_irq(DmaFlags::from_lisr_stream0(lisr), remaining, adc_overrun);
        let Some(half) = ready else {
            if self.tracker.overrun().is_some() {
                self.stop();
            }
            return None;
        };
        // The DMA's writes to this half happened before the flag it set: read them after.
        compiler_fence(Ordering::Acquire);
        // SAFETY: `buf` points to 2 * FRAMES_PER_HALF frames; the half at `half.index()` is
        // complete and the DMA is in the other one (checked by the tracker from NDTR).
        Some(unsafe {
            core::slice::from_raw_parts(
                self.buf.add(half.index() * FRAMES_PER_HALF),
                FRAMES_PER_HALF,
            )
        })
    }

    /// The latched overrun (DMA TEIF/DMEIF, ADC OVR, a missed or overwritten half): the
    /// firmware reports it as `FaultCode::SensorFault`.
    pub fn overrun_cause(&self) -> Option<FrameOverrun> {
        self.tracker.overrun()
    }

    /// DMA FIFO error flags seen (bus-contention warnings, not faults).
    pub fn fifo_errors(&self) -> u32 {
        self.tracker.fifo_errors()
    }

    /// The running timing, if started.
    pub fn timing(&self) -> Option<SampleTiming> {
        self.timing
    }
}

impl board_contract::ForceAdc for ForceAdc {
    fn start(&mut self, sample_hz: u32) -> Result<u32, SampleRateError> {
        self.start_sampling(sample_hz)
    }

    #[inline]
    fn on_dma_irq(&mut self) -> Option<&[ForceFrame]> {
        self.take_half()
    }

    fn overrun(&self) -> bool {
        self.tracker.overrun().is_some()
    }
}
