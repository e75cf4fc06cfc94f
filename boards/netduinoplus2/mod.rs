//! QEMU's `netduinoplus2` machine: an STM32F405 whose timers, NVIC and SysTick are modelled but
//! whose GPIO, RCC, DWT and DMA are not. The step port therefore records its outputs instead of
//! driving pins, logs go out over semihosting, and `exit` ends the QEMU process.
//!
//! | resource | use |
//! | --- | --- |
//! | TIM2 | DDA tick (update interrupt at `tick_hz`), 1 GHz input clock under QEMU |
//! | TIM5 | free-running 32-bit cycle counter for benchmarks (1 count = 1 instruction with `-icount shift=0`) |
//! | IWDG | started by the link firmware; not modelled by QEMU (never bites) |
//! | USART1 | host link (`link` feature), 115200 8N1 from the 16 MHz HSI; QEMU's `-serial` |
//! | (sim) | spindle for Z-slide jobs: `SimSpindle` sets its speed, the encoder logic reads it |
//! | semihosting | defmt log frames on QEMU's stdout, exit status |

mod clocks;
mod cycles;
#[path = "../common/host_serial.rs"]
mod host_serial;
mod log;
#[cfg(feature = "link")]
mod spindle;
mod step_port;
#[path = "../common/tick_timer.rs"]
mod tick_timer;
#[cfg(feature = "link")]
#[path = "../common/watchdog.rs"]
mod watchdog;

pub use cycles::CycleCounter;
pub use host_serial::HostSerial;
#[cfg(feature = "link")]
pub use spindle::Spindle;
pub use step_port::StepPort;
// The demo firmware never changes its tick rate.
#[allow(unused_imports)]
pub use tick_timer::TickRate;
pub use tick_timer::TickTimer;
#[cfg(feature = "link")]
pub use watchdog::Watchdog;

use stm32f4::stm32f405 as pac;

pub const NAME: &str = "netduinoplus2";
/// Host link baud rate (QEMU moves bytes at its own pace whatever BRR says).
pub const HOST_BAUD: u32 = 115_200;

/// Everything the app needs from the board, configured and idle.
pub struct Board {
    pub tick_timer: TickTimer,
    pub step_port: StepPort,
    #[cfg_attr(feature = "link", allow(dead_code))]
    pub cycles: CycleCounter,
    pub estop: EStop,
    /// USART1, configured, interrupts off (only `link` builds use it).
    #[cfg_attr(not(feature = "link"), allow(dead_code))]
    pub host: HostSerial,
    /// No switches under QEMU: every input reads "all clear".
    #[cfg(feature = "link")]
    pub io: MachineIo,
    /// QEMU ignores the IWDG; started anyway so the link firmware is the same code.
    #[cfg(feature = "link")]
    pub iwdg: pac::IWDG,
    /// No persisted config under QEMU (its flash is read-only ROM).
    #[cfg(feature = "link")]
    pub config: ConfigStorage,
    /// The simulated spindle (`SimSpindle`), read through the encoder logic.
    #[cfg(feature = "link")]
    pub spindle: Spindle,
}

pub fn init(dp: pac::Peripherals, _core: &mut cortex_m::Peripherals, tick_hz: u32) -> Board {
    let clocks = clocks::init(&dp.RCC);
    Board {
        tick_timer: TickTimer::new(dp.TIM2, clocks.tim2_hz, tick_hz),
        step_port: StepPort::new(),
        cycles: CycleCounter::new(dp.TIM5),
        estop: EStop,
        host: HostSerial::new(dp.USART1, clocks.pclk2_hz, HOST_BAUD),
        #[cfg(feature = "link")]
        io: MachineIo,
        #[cfg(feature = "link")]
        iwdg: dp.IWDG,
        #[cfg(feature = "link")]
        config: ConfigStorage,
        #[cfg(feature = "link")]
        spindle: Spindle::new(),
    }
}

/// Waits for the next interrupt, from `idle`. Under QEMU (`-icount shift=0,sleep=off`) a `wfi`
/// costs a round trip between QEMU's vCPU and main-loop threads to advance the virtual clock to
/// the next timer deadline; at a 100 kHz tick those round trips, not the guest's code, set the
/// wall time (measured: the polar end-to-end arc took 129 s with `wfi`, 22 s spinning). A spin
/// keeps the vCPU running, so idle virtual time costs only emulated no-ops. The guest sees the
/// same clock and the same interrupts either way (`-icount` counts instructions, not host time).
#[inline(always)]
pub fn idle_wait() {
    // A straight run of no-ops translates into one cheap block per pass.
    for _ in 0..IDLE_SPIN_NOPS {
        cortex_m::asm::nop();
    }
}

/// No-ops per [`idle_wait`] pass: interrupts are taken between passes, so this bounds the
/// extra entry latency idling adds under QEMU (ns at `shift=0`).
const IDLE_SPIN_NOPS: u32 = 16;

/// Ends the run: QEMU exits with status 0 (`ok`) or 1.
pub fn exit(ok: bool) -> ! {
    use cortex_m_semihosting::debug;
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    // Only reached without a semihosting host (e.g. QEMU started without semihosting).
    loop {
        cortex_m::asm::wfi();
    }
}

/// Levels read in one tick (see the real board's `machine_io.rs`).
#[cfg(feature = "link")]
#[derive(Clone, Copy, Default)]
pub struct RawInputs {
    pub estop: bool,
    pub limit_min: u8,
    pub limit_max: u8,
    /// The wire-stall switch: here the level the host set with `SimInject`.
    pub wire_stall: bool,
}

/// The simulated wire-stall switch (`SimInject`): written by the USART task, read by the tick.
#[cfg(feature = "link")]
static SIM_WIRE_STALL: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// QEMU models no GPIO: no switch is ever open, and the outputs go nowhere. The fault paths
/// these inputs drive are exercised by the scenario firmware's `fault_*` scenarios instead.
/// The one simulated input is the wire-stall switch, which the host drives with `SimInject`
/// (announced by `CAP_SIM_INPUTS`) to test the wire-stall retrace end to end.
#[cfg(feature = "link")]
pub struct MachineIo;

#[cfg(feature = "link")]
impl MachineIo {
    /// The host drives the simulated inputs (`SimInject`).
    pub const SIM_INPUTS: bool = true;

    /// Sets the simulated wire-stall switch from the next tick on; true (honoured).
    pub fn inject_wire_stall(stalled: bool) -> bool {
        SIM_WIRE_STALL.store(stalled, core::sync::atomic::Ordering::Relaxed);
        true
    }

    #[inline]
    pub fn read(&mut self) -> RawInputs {
        RawInputs {
            wire_stall: SIM_WIRE_STALL.load(core::sync::atomic::Ordering::Relaxed),
            ..RawInputs::default()
        }
    }

    #[inline]
    pub fn write(&mut self, _o: &motion::machine::Outputs) {}
}

/// QEMU models no flash interface (its flash is ROM): the config is always "missing" at boot
/// and never saved; the store itself is tested on the host over a NOR-flash mock.
#[cfg(feature = "link")]
pub struct ConfigStorage;

#[cfg(feature = "link")]
impl ConfigStorage {
    pub const PERSISTS: bool = false;

    pub fn load(&mut self) -> Result<motion::machine::BoardConfig, motion::machine::BootConfig> {
        Err(motion::machine::BootConfig::Missing)
    }

    pub fn save(
        &mut self,
        _cfg: &motion::machine::BoardConfig,
    ) -> Result<(), motion::machine::persist::SaveError> {
        Ok(())
    }
}

/// QEMU has no e-stop input: the interrupt is never raised.
pub struct EStop;

impl EStop {
    pub fn clear(&mut self) -> bool {
        false
    }
}
