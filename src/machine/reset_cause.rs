//! Why the MCU last reset, decoded from the STM32F4's RCC_CSR reset flags, so that a board that
//! restarted after its independent watchdog expired boots into a fault that says so (the
//! operator sees `WatchdogReset`, not a quiet fresh start in the middle of a job).
//!
//! The board reads RCC_CSR once at start-up (before anything clears it), passes the word to
//! [`ResetCause::from_rcc_csr`] and the result to `Machine::boot_after_reset`, then clears the
//! flags (RMVF) so the next reset reports only itself.

/// RCC_CSR reset flags (RM0090, section 7.3.21 "RCC clock control & status register").
pub mod rcc_csr {
    pub const BORRSTF: u32 = 1 << 25;
    pub const PINRSTF: u32 = 1 << 26;
    pub const PORRSTF: u32 = 1 << 27;
    pub const SFTRSTF: u32 = 1 << 28;
    pub const IWDGRSTF: u32 = 1 << 29;
    pub const WWDGRSTF: u32 = 1 << 30;
    pub const LPWRRSTF: u32 = 1 << 31;
    /// Write 1 to clear every reset flag.
    pub const RMVF: u32 = 1 << 24;
}

/// The reset the board came out of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    PowerOn,
    BrownOut,
    /// The NRST pin (a reset button, the debugger).
    Pin,
    /// `SCB::sys_reset` (firmware update, a deliberate restart).
    Software,
    /// The independent watchdog expired: the tick or the control task stopped checking in.
    IndependentWatchdog,
    /// The window watchdog (not used by this firmware; reported the same way).
    WindowWatchdog,
    /// Entering standby or stop when the option bytes forbid it.
    LowPower,
    /// No flag set (a board that cannot tell, or flags already cleared).
    Unknown,
}

impl ResetCause {
    /// Decodes RCC_CSR. Several flags are set at once: every internal reset also drives NRST
    /// (PINRSTF), a power-on also sets BORRSTF. So the specific causes are tested first, the
    /// pin last.
    pub const fn from_rcc_csr(csr: u32) -> ResetCause {
        use rcc_csr::*;
        if csr & IWDGRSTF != 0 {
            ResetCause::IndependentWatchdog
        } else if csr & WWDGRSTF != 0 {
            ResetCause::WindowWatchdog
        } else if csr & LPWRRSTF != 0 {
            ResetCause::LowPower
        } else if csr & SFTRSTF != 0 {
            ResetCause::Software
        } else if csr & PORRSTF != 0 {
            ResetCause::PowerOn
        } else if csr & BORRSTF != 0 {
            ResetCause::BrownOut
        } else if csr & PINRSTF != 0 {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }

    /// A watchdog reset: the firmware stopped running as it should, so the machine boots into
    /// `WatchdogReset`.
    pub const fn is_watchdog(self) -> bool {
        matches!(self, ResetCause::IndependentWatchdog | ResetCause::WindowWatchdog)
    }
}

#[cfg(test)]
mod tests {
    use super::rcc_csr::*;
    use super::*;

    #[test]
    fn decodes_the_flag_combinations_the_f405_sets() {
        // Reset values per RM0090: after power-on PORRSTF, PINRSTF and BORRSTF are set.
        assert_eq!(ResetCause::from_rcc_csr(PORRSTF | PINRSTF | BORRSTF), ResetCause::PowerOn);
        assert_eq!(ResetCause::from_rcc_csr(IWDGRSTF | PINRSTF), ResetCause::IndependentWatchdog);
        assert_eq!(ResetCause::from_rcc_csr(SFTRSTF | PINRSTF), ResetCause::Software);
        assert_eq!(ResetCause::from_rcc_csr(PINRSTF), ResetCause::Pin);
        assert_eq!(ResetCause::from_rcc_csr(BORRSTF | PINRSTF), ResetCause::BrownOut);
        assert_eq!(ResetCause::from_rcc_csr(0), ResetCause::Unknown);
        // The low byte (LSION, LSIRDY) and RMVF do not matter.
        assert_eq!(ResetCause::from_rcc_csr(0x3 | RMVF), ResetCause::Unknown);
        let watchdog: std::vec::Vec<bool> = (24..32)
            .map(|b| ResetCause::from_rcc_csr((1u32 << b) | PINRSTF).is_watchdog())
            .collect();
        assert_eq!(watchdog, [false, false, false, false, false, true, true, false]);
    }
}
