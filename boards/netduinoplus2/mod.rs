//! QEMU's `netduinoplus2` machine: an STM32F405 whose timers, NVIC and SysTick are modelled but
//! whose GPIO, RCC, DWT and DMA are not. The step port therefore records its outputs instead of
//! driving pins, logs go out over semihosting, and `exit` ends the QEMU process.
//!
//! | resource | use |
//! | --- | --- |
//! | TIM2 | DDA tick (update interrupt at `tick_hz`), 1 GHz input clock under QEMU |
//! | TIM5 | free-running 32-bit cycle counter for benchmarks (1 count = 1 instruction with `-icount shift=0`) |
//! | IWDG | started by the link firmware; not modelled by QEMU (never bites) |
//! | (none) | copy-mode encoders: simulated counters driven by `SimEncoders` (`CopyEncoders`) |
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
    /// RCC_CSR as it was at reset: why the chip reset (`motion::machine::ResetCause`).
    #[cfg_attr(not(feature = "link"), allow(dead_code))]
    pub reset_csr: u32,
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
    /// Copy-mode encoders: simulated (QEMU's timers have no encoder mode), driven by the host.
    #[cfg(feature = "link")]
    pub copy_encoders: CopyEncoders,
    /// No force ADC under QEMU: force jobs sample the simulated plant in the tick.
    #[cfg(feature = "link")]
    pub force_adc: Option<ForceAdc>,
    /// The simulated spindle (`SimSpindle`), read through the encoder logic.
    #[cfg(feature = "link")]
    pub spindle: Spindle,
}

pub fn init(dp: pac::Peripherals, _core: &mut cortex_m::Peripherals, tick_hz: u32) -> Board {
    // QEMU does not model RCC: this reads 0, a reset of unknown cause (never a watchdog one).
    let reset_csr = dp.RCC.csr().read().bits();
    let clocks = clocks::init(&dp.RCC);
    Board {
        reset_csr,
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
        copy_encoders: CopyEncoders::new(),
        #[cfg(feature = "link")]
        force_adc: None,
        #[cfg(feature = "link")]
        spindle: Spindle::new(),
    }
}

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

/// The simulated encoders' target counts (`SimEncoders`): written by the USART task, read by
/// the tick.
#[cfg(feature = "link")]
static SIM_ENCODER_TARGET: [core::sync::atomic::AtomicI32; 2] =
    [core::sync::atomic::AtomicI32::new(0), core::sync::atomic::AtomicI32::new(0)];

/// Copy-mode encoders under QEMU: two counters that slew toward the host's `SimEncoders` target
/// at one count per `SIM_TICKS_PER_COUNT` ticks each, like a template moved at a bounded speed
/// (`motion::polar::copy_link::SimEncoderSlew`).
#[cfg(feature = "link")]
pub struct CopyEncoders {
    slew: motion::polar::copy_link::SimEncoderSlew,
}

#[cfg(feature = "link")]
impl CopyEncoders {
    /// Copy jobs are possible (announced as `CAP_COPY_JOB`).
    pub const ROUTED: bool = true;

    pub const fn new() -> Self {
        CopyEncoders { slew: motion::polar::copy_link::SimEncoderSlew::new() }
    }

    /// Sets the simulated encoders' target from the next tick on; true (honoured).
    pub fn set_sim_target(counts: [i32; 2]) -> bool {
        for (t, c) in SIM_ENCODER_TARGET.iter().zip(counts) {
            t.store(c, core::sync::atomic::Ordering::Relaxed);
        }
        true
    }

    /// One tick: (arm, carriage) counts. Two loads, a countdown, two clamped adds.
    #[inline]
    pub fn read(&mut self) -> [i32; 2] {
        use core::sync::atomic::Ordering::Relaxed;
        let target = [SIM_ENCODER_TARGET[0].load(Relaxed), SIM_ENCODER_TARGET[1].load(Relaxed)];
        self.slew.tick(target)
    }
}

/// QEMU's ADC values are fake: force jobs sample the simulated milling plant (`SimMilling`) in
/// the tick instead. This stub keeps the link app's force-DMA task board-independent; it is
/// never made, so the task never runs.
#[cfg(feature = "link")]
pub struct ForceAdc;

#[cfg(feature = "link")]
impl ForceAdc {
    pub fn start(&mut self, _sample_hz: u32) -> Result<u32, ()> {
        Err(())
    }

    pub fn on_dma_irq(&mut self) -> Option<&[[u16; 3]]> {
        None
    }

    pub fn overrun(&self) -> Option<()> {
        None
    }
}

/// QEMU has no e-stop input: the interrupt is never raised.
pub struct EStop;

impl EStop {
    pub fn clear(&mut self) -> bool {
        false
    }
}
