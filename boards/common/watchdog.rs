//! The independent watchdog (IWDG, LSI ~32 kHz). Started once, it cannot be stopped: the app
//! feeds it only when `motion::machine::WatchdogGate` says the tick and the control task are
//! both alive. Under a debugger halt the watchdog is frozen (DBGMCU), so a breakpoint does not
//! reset the board. QEMU does not model the IWDG (writes ignored, reads 0), so there it never
//! bites and the feeding logic is tested on the host.

use stm32f4::stm32f405 as pac;

/// LSI nominal frequency; it may be off by up to -50 %/+60 % (RM0090 datasheet), so the
/// timeout is chosen with that margin.
const LSI_HZ: u32 = 32_000;
/// Prescaler /32 (PR = 3): one reload count = 1 ms at the nominal LSI.
const PRESCALER_CODE: u16 = 3;
const COUNTS_PER_MS: u32 = LSI_HZ / 32 / 1_000;
const KEY_UNLOCK: u16 = 0x5555;
const KEY_FEED: u16 = 0xAAAA;
const KEY_START: u16 = 0xCCCC;

pub struct Watchdog {
    iwdg: pac::IWDG,
}

impl Watchdog {
    /// Starts the watchdog with a nominal timeout of `timeout_ms` (at most 4095 ms).
    pub fn start(iwdg: pac::IWDG, timeout_ms: u32) -> Self {
        // SAFETY: DBGMCU only affects behaviour under a debugger halt; this bit is ours alone.
        unsafe { (*pac::DBGMCU::ptr()).apb1_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit()) };
        let reload = timeout_ms.saturating_mul(COUNTS_PER_MS).clamp(1, 0xfff) as u16;
        // SAFETY (all below): the key values and 3-/12-bit fields are the ones RM0090 21.4
        // defines; PR and RLR are written after the unlock key.
        unsafe {
            iwdg.kr().write(|w| w.bits(KEY_UNLOCK));
            iwdg.pr().write(|w| w.bits(PRESCALER_CODE));
            iwdg.rlr().write(|w| w.bits(reload));
            iwdg.kr().write(|w| w.bits(KEY_START));
            iwdg.kr().write(|w| w.bits(KEY_FEED));
        }
        Watchdog { iwdg }
    }

    pub fn feed(&mut self) {
        // SAFETY: the reload key.
        unsafe { self.iwdg.kr().write(|w| w.bits(KEY_FEED)) };
    }
}
