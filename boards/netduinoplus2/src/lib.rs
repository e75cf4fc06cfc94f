//! QEMU's `netduinoplus2` machine: an STM32F405 whose timers, NVIC and SysTick are modelled but
//! whose GPIO, RCC, DWT and DMA are not. The step port therefore records its outputs instead of
//! driving pins, logs go out over semihosting, and `exit` ends the QEMU process.
//!
//! | resource | use |
//! | --- | --- |
//! | TIM2 | DDA tick (update interrupt at `tick_hz`), 1 GHz input clock under QEMU; its ticks counted as the sim spindle's clock. With `step-stream`: the stand-in for the DMA's half interrupt, at `tick_hz / STREAM_SLOTS` |
//! | TIM5 | free-running 32-bit cycle counter for benchmarks (1 count = 1 instruction with `-icount shift=0`) |
//! | IWDG | started by the link firmware; not modelled by QEMU (never bites) |
//! | (none) | copy-mode encoders: simulated A/B levels (`Sim(Encoders)`) decoded by `board_drivers::quadrature::SoftDecoder` (`sim_io.rs`) |
//! | USART1 | host link (`link` firmware), 115200 8N1 from the 16 MHz HSI; QEMU's `-serial` |
//! | (sim) | spindle for Z-slide jobs: `Sim(Spindle)` sets its speed, the encoder logic reads it |
//! | semihosting | defmt log frames on QEMU's stdout, exit status |
//! | SRAM (`.uninit`) | the stored config, a NOR-flash model that survives a reset (`config_ram.rs`) |

#![no_std]

mod clocks;
mod config_ram;
mod cycles;
mod log;
mod sim_io;
mod spindle;
mod step_port;
#[cfg(feature = "step-stream")]
mod step_stream;
mod tick_timer;

pub use board_stm32f405::{pac, HostSerial, Watchdog};
pub use config_ram::RamConfig;
pub use cycles::CycleCounter;
pub use sim_io::{CopyEncoders, MachineIo};
pub use spindle::Spindle;
pub use step_port::StepPort;
#[cfg(feature = "step-stream")]
pub use step_stream::StepStream;
pub use tick_timer::{TickRate, TickTimer};

use board_contract::{NoForceAdc, Parts};
use motion::machine::ResetCause;

/// QEMU has no e-stop input: the interrupt is never raised.
pub struct EStop;

impl board_contract::EStopLine for EStop {
    fn clear(&mut self) -> bool {
        false
    }
}

/// The board, for the Board contract.
pub struct Board;

impl board_contract::Board for Board {
    const NAME: &'static str = "netduinoplus2";
    /// QEMU moves bytes at its own pace whatever BRR says.
    const HOST_BAUD: u32 = 115_200;
    /// Ten times the real board's: under `-icount sleep=off` the board's clock is its
    /// instruction count, and while the guest idles (a job held, a queue waiting for the host)
    /// it runs about 3.5x ahead of the wall clock. With 1 s, a host that a loaded machine left
    /// without the CPU for 0.3 s lost its QEMU job to `LinkLost` (seen in corpus and bench runs
    /// beside compilers); 10 s asks for about 3 s of host silence.
    const LINK_TIMEOUT_MS: u64 = 10_000;
    type Device = pac::Peripherals;
    type Core = cortex_m::Peripherals;
    type TickTimer = TickTimer;
    type TickRate = TickRate;
    type StepPort = StepPort;
    type EStop = EStop;
    type MachineIo = MachineIo;
    type HostSerial = HostSerial;
    /// QEMU ignores the IWDG; started anyway so the link firmware is the same code.
    type Watchdog = Watchdog;
    /// QEMU's flash is read-only ROM: the record is kept in RAM that survives a reset
    /// (`config_ram`), in the same store format the real board's flash holds.
    type ConfigStorage = RamConfig;
    type CopyEncoders = CopyEncoders;
    /// QEMU's ADC values are fake: force jobs sample the simulated milling plant in the tick.
    type ForceAdc = NoForceAdc;
    type Spindle = Spindle;
    type CycleCounter = CycleCounter;
    type Extras = ();

    fn init(dp: pac::Peripherals, _core: &mut cortex_m::Peripherals, tick_hz: u32) -> Parts<Self> {
        // QEMU does not model RCC: this reads 0, a reset of unknown cause (never a watchdog one).
        let reset = ResetCause::from_rcc_csr(dp.RCC.csr().read().bits());
        let clocks = clocks::init(&dp.RCC);
        Parts {
            reset,
            tick_timer: TickTimer::new(dp.TIM2, clocks.tim2_hz, tick_hz),
            step_port: StepPort,
            estop: EStop,
            io: MachineIo,
            host: HostSerial::new(dp.USART1, clocks.pclk2_hz, Self::HOST_BAUD),
            watchdog: Watchdog::new(dp.IWDG),
            config: RamConfig::take(),
            copy_encoders: CopyEncoders::new(),
            force_adc: None,
            spindle: Spindle::new(),
            cycles: CycleCounter::new(dp.TIM5),
            extras: (),
        }
    }

    /// Ends the run: QEMU exits with status 0 (`ok`) or 1.
    fn exit(ok: bool) -> ! {
        use cortex_m_semihosting::debug;
        debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
        // Only reached without a semihosting host (e.g. QEMU started without semihosting).
        loop {
            cortex_m::asm::wfi();
        }
    }
}
