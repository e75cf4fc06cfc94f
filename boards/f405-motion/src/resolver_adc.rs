//! Spindle resolver sin/cos (PA5/PA6 = ADC12_IN5/IN6) on ADC2's injected group, one software-
//! started pair per tick: each [`ResolverAdc::sample`] takes the pair converted since the last
//! call and starts the next, so the samples are a fixed one tick old and the tick never waits
//! for the ADC. Offset removal is `motion::spindle::resolver_offset`; registers only here.

use crate::pac;
use motion::spindle::resolver_offset::ResolverOffset;

/// ADC channel of RESOLVER_SIN (PA5).
const SIN_CHANNEL: u8 = 5;
/// ADC channel of RESOLVER_COS (PA6).
const COS_CHANNEL: u8 = 6;

/// ADC2 as the resolver's sampler.
pub struct ResolverAdc {
    adc: pac::ADC2,
    offset: ResolverOffset,
    /// A conversion was started and not yet collected.
    started: bool,
    missed: u32,
}

impl ResolverAdc {
    /// ADC2 on, injected sequence sin then cos, 28-cycle sampling: a pair takes
    /// 2 * (28 + 12) = 80 ADC cycles = 3.8 us at 21 MHz, inside a 10 us (100 kHz) tick.
    /// The ADC clock prescaler is ADC_COMMON's, shared with ADC1 (`force_adc::init_common`).
    pub fn new(adc: pac::ADC2) -> Self {
        adc.smpr2().modify(|_, w| w.smp(SIN_CHANNEL).cycles28().smp(COS_CHANNEL).cycles28());
        // JL = 1 (two conversions): with JL = 1 the ADC converts JSQ3 then JSQ4, and stores
        // them in JDR1 then JDR2 (RM0090 13.13.12).
        // SAFETY: channel numbers 5 and 6 are valid JSQ values.
        adc.jsqr()
            .write(|w| unsafe { w.jl().set(1).jsq3().bits(SIN_CHANNEL).jsq4().bits(COS_CHANNEL) });
        // SCAN: the injected group converts all its channels per start; 12 bits; no interrupts.
        adc.cr1().write(|w| w.scan().enabled().res().twelve_bit());
        // Injected trigger: software (JEXTEN = 0); regular group unused.
        adc.cr2().write(|w| w.adon().enabled());
        ResolverAdc { adc, offset: ResolverOffset::MID_SCALE, started: false, missed: 0 }
    }

    /// The counts at which sin and cos read zero (default: mid-scale).
    pub fn set_offset(&mut self, offset: ResolverOffset) {
        self.offset = offset;
    }

    /// The raw pair converted since the last call, if it is complete, and starts the next one.
    /// `None` on the first call and when the conversion has not finished (counted in
    /// [`ResolverAdc::missed`]). Once per tick; bounded, no division.
    #[inline]
    pub fn read_raw(&mut self) -> Option<(u16, u16)> {
        let sr = self.adc.sr().read();
        let pair = if sr.jeoc().bit_is_set() {
            let s = self.adc.jdr1().read().jdata().bits();
            let c = self.adc.jdr2().read().jdata().bits();
            Some((s, c))
        } else {
            None
        };
        if pair.is_none() && self.started {
            self.missed = self.missed.saturating_add(1);
        }
        if pair.is_some() || !self.started {
            // JEOC and JSTRT are rc_w0: write 0 to clear them, 1 leaves the others.
            // SAFETY: SR holds status flags only.
            self.adc.sr().write(|w| unsafe { w.bits(!(0b1100)) });
            self.adc.cr2().modify(|_, w| w.jswstart().start());
            self.started = true;
        }
        pair
    }

    /// The pair for `Resolver::update`: offset removed, `(0, 0)` if no sample (the observer
    /// predicts only and counts it towards signal loss). Once per tick at the Z-slide rate.
    #[inline]
    pub fn sample(&mut self) -> (i16, i16) {
        let raw = self.read_raw();
        self.offset.observer_input(raw)
    }

    /// Ticks whose conversion had not finished.
    pub fn missed(&self) -> u32 {
        self.missed
    }
}
