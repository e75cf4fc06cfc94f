//! The independent watchdog (IWDG, LSI ~32 kHz). Started once, it cannot be stopped: the app
//! feeds it only when `motion::machine::WatchdogGate` says the tick and the control task are
//! both alive. Under a debugger halt the watchdog is frozen (DBGMCU), so a breakpoint does not
//! reset the board. QEMU does not model the IWDG (writes ignored, reads 0), so there it never
//! bites and the feeding logic is tested on the host.

use crate::pac;

/// LSI nominal frequency; it may be off by up to -50 %/+60 % (RM0090 datasheet), so the
/// timeout is chosen with that margin.
const LSI_HZ: u32 = 32_000;
/// Prescaler /32 (PR = 3): one reload count = 1 ms at the nominal LSI.
const PRESCALER_CODE: u16 = 3;
const COUNTS_PER_MS: u32 = LSI_HZ / 32 / 1_000;
const KEY_UNLOCK: u16 = 0x5555;
const KEY_FEED: u16 = 0xAAAA;
const KEY_START: u16 = 0xCCCC;
/// While stretched: prescaler /64 (PR = 4) and the largest reload, 4095 * 64 / 32 kHz = 8.2 s
/// nominal (4.1 s at the fastest LSI), well beyond a 16 KiB sector erase (0.5 s at most).
const STRETCH_PRESCALER_CODE: u16 = 4;
const MAX_RELOAD: u16 = 0xfff;

pub struct Watchdog {
    iwdg: pac::IWDG,
    reload: u16,
}

impl Watchdog {
    /// The IWDG, not started.
    pub fn new(iwdg: pac::IWDG) -> Self {
        Watchdog { iwdg, reload: MAX_RELOAD }
    }

    /// Writes PR and RLR once the previous update reached the LSI domain (PVU/RVU clear).
    fn set(&mut self, prescaler_code: u16, reload: u16) {
        while self.iwdg.sr().read().pvu().bit_is_set() || self.iwdg.sr().read().rvu().bit_is_set() {
        }
        // SAFETY: the unlock key, then 3- and 12-bit fields as RM0090 21.4 defines them.
        unsafe {
            self.iwdg.kr().write(|w| w.bits(KEY_UNLOCK));
            self.iwdg.pr().write(|w| w.bits(prescaler_code));
            self.iwdg.rlr().write(|w| w.bits(reload));
        }
    }
}

impl board_contract::Watchdog for Watchdog {
    /// Starts the watchdog with a nominal timeout of `timeout_ms` (at most 4095 ms).
    fn start(&mut self, timeout_ms: u32) {
        // SAFETY: DBGMCU only affects behaviour under a debugger halt; this bit is ours alone.
        unsafe { (*pac::DBGMCU::ptr()).apb1_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit()) };
        self.reload = timeout_ms.saturating_mul(COUNTS_PER_MS).clamp(1, MAX_RELOAD as u32) as u16;
        self.set(PRESCALER_CODE, self.reload);
        // SAFETY: the start and reload keys.
        unsafe {
            self.iwdg.kr().write(|w| w.bits(KEY_START));
            self.iwdg.kr().write(|w| w.bits(KEY_FEED));
        }
    }

    /// Runs `f` (a flash erase: every fetch stalls, the control task cannot feed) with the
    /// timeout stretched to seconds, then restores it. Fed on both sides.
    fn stretch<R>(&mut self, f: impl FnOnce() -> R) -> R {
        self.feed();
        self.set(STRETCH_PRESCALER_CODE, MAX_RELOAD);
        self.feed();
        let r = f();
        self.feed();
        self.set(PRESCALER_CODE, self.reload);
        self.feed();
        r
    }

    fn feed(&mut self) {
        // SAFETY: the reload key.
        unsafe { self.iwdg.kr().write(|w| w.bits(KEY_FEED)) };
    }
}
