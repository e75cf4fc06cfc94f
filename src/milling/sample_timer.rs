//! The force ADC's trigger timer, board-independent: prescaler and auto-reload of a 16-bit timer
//! whose update event starts one ADC scan, for a requested sample rate, and the fastest rate the
//! ADC's scan time allows. Setup-time code: divides.

/// Lowest force sample rate: the chain's anti-alias filter and the control rate assume at least
/// 5 kHz (1 kHz control at `chain::DECIMATION` = 5).
pub const MIN_SAMPLE_HZ: u32 = 5_000;

/// ADC cycles of one conversion beyond the sampling time (12-bit successive approximation).
pub const ADC_CONVERSION_CYCLES: u32 = 12;

/// Timer settings for one sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleTiming {
    /// Timer prescaler register (counter clock = timer clock / (psc + 1)).
    pub psc: u16,
    /// Auto-reload register (update every arr + 1 counter ticks).
    pub arr: u16,
    /// The rate these give, Hz (rounded down): the nearest the timer clock allows.
    pub actual_hz: u32,
}

/// Why a sample rate was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleRateError {
    /// Below [`MIN_SAMPLE_HZ`].
    TooSlow,
    /// Above what one scan of the channels takes ([`max_scan_hz`]).
    TooFast,
}

/// Highest scan rate of `channels` conversions of `sampling_cycles` each at `adc_hz`, with a
/// 10 % margin so a scan always ends before the next trigger (a trigger during a scan is lost).
pub const fn max_scan_hz(adc_hz: u32, channels: u32, sampling_cycles: u32) -> u32 {
    let scan_cycles = channels * (sampling_cycles + ADC_CONVERSION_CYCLES);
    if scan_cycles == 0 {
        return 0;
    }
    (adc_hz as u64 * 9 / (10 * scan_cycles as u64)) as u32
}

/// Prescaler and reload for `sample_hz` from a `timer_hz` clock: the smallest prescaler that
/// fits the reload into 16 bits (finest rate steps), the reload rounded to the nearest.
pub const fn sample_timing(
    timer_hz: u32,
    sample_hz: u32,
    max_hz: u32,
) -> Result<SampleTiming, SampleRateError> {
    if sample_hz < MIN_SAMPLE_HZ {
        return Err(SampleRateError::TooSlow);
    }
    if sample_hz > max_hz {
        return Err(SampleRateError::TooFast);
    }
    // Counter ticks per sample, rounded; at least 2 so arr >= 1.
    let ticks = (timer_hz as u64 + sample_hz as u64 / 2) / sample_hz as u64;
    let psc = ticks / 65_536;
    let counter_hz = timer_hz as u64 / (psc + 1);
    let reload = (counter_hz + sample_hz as u64 / 2) / sample_hz as u64;
    if reload < 2 || reload > 65_536 || psc > 65_535 {
        return Err(SampleRateError::TooFast);
    }
    Ok(SampleTiming {
        psc: psc as u16,
        arr: (reload - 1) as u16,
        actual_hz: (counter_hz / reload) as u32,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TIMER_HZ: u32 = 84_000_000;
    /// F405 board: ADC clock 21 MHz, 4 channels of 84 sampling cycles.
    fn max() -> u32 {
        max_scan_hz(21_000_000, 4, 84)
    }

    #[test]
    fn board_rates() {
        // 4 * 96 cycles = 384 cycles = 18.3 us per scan at 21 MHz; 90 % of 54.7 kHz.
        assert_eq!(max(), 21_000_000 * 9 / 10 / 384);
        let t = sample_timing(TIMER_HZ, 10_000, max()).unwrap();
        assert_eq!((t.psc, t.arr, t.actual_hz), (0, 8_399, 10_000));
        let t = sample_timing(TIMER_HZ, 5_000, max()).unwrap();
        assert_eq!((t.psc, t.arr, t.actual_hz), (0, 16_799, 5_000));
        // Not a divisor: 84 MHz / 7 kHz = 12 000 exactly; 84 MHz / 9 kHz = 9333.3 -> 9333.
        let t = sample_timing(TIMER_HZ, 9_000, max()).unwrap();
        assert_eq!(t.arr, 9_332);
        assert!((t.actual_hz as i64 - 9_000).abs() <= 1);
        assert_eq!(sample_timing(TIMER_HZ, 4_999, max()), Err(SampleRateError::TooSlow));
        assert_eq!(sample_timing(TIMER_HZ, max() + 1, max()), Err(SampleRateError::TooFast));
    }

    #[test]
    fn prescaler_when_the_reload_would_not_fit() {
        // 5 kHz from a 400 MHz clock needs 80 000 ticks, more than 16 bits: psc 1 (200 MHz
        // counter), reload 40 000. (The board's 84 MHz never needs it above MIN_SAMPLE_HZ.)
        let t = sample_timing(400_000_000, 5_000, 50_000).unwrap();
        assert_eq!(t.psc, 1);
        assert_eq!(t.actual_hz, 5_000);
        let rate = 400_000_000 / (t.psc as u64 + 1) / (t.arr as u64 + 1);
        assert_eq!(rate, 5_000);
    }

    #[test]
    fn every_accepted_rate_is_within_one_counter_tick() {
        for hz in (MIN_SAMPLE_HZ..=max()).step_by(97) {
            let t = sample_timing(TIMER_HZ, hz, max()).unwrap();
            let period_ns = 1e9 * (t.psc as f64 + 1.0) * (t.arr as f64 + 1.0) / TIMER_HZ as f64;
            let want_ns = 1e9 / hz as f64;
            let tick_ns = 1e9 * (t.psc as f64 + 1.0) / TIMER_HZ as f64;
            assert!((period_ns - want_ns).abs() <= tick_ns / 2.0 + 1e-6, "{hz}: {t:?}");
        }
    }
}
