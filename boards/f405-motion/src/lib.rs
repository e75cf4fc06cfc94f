//! A generic STM32F405RG motion board: six step/dir pairs, a shared driver enable, an e-stop
//! input, a quadrature spindle encoder, four analog force sensors and a USART host link.
//! Pin map: see `README.md` beside this file (and `pins.rs`, which is the source of truth).
//!
//! | resource | use |
//! | --- | --- |
//! | HSE 8 MHz -> PLL | SYSCLK 168 MHz, AHB 168, APB1 42 (timers 84), APB2 84 (timers 168) MHz |
//! | TIM2 | DDA tick (update interrupt at `tick_hz`) |
//! | TIM5, TIM3 | copy-mode encoders (arm, carriage; encoder mode 3; TIM3 through `board_drivers::quadrature::TimerEncoder`) |
//! | TIM4 | spindle encoder (encoder mode 3 on CH1/CH2), index capture on CH3 (`TIM4` interrupt) |
//! | ADC1 + TIM8 + DMA2 stream 0 | force sensors: TIM8 TRGO scans, DMA double buffer (`DMA2_STREAM0`) |
//! | ADC2 | resolver sin/cos, injected group, one pair per tick (not with `resolver-spi`/`force-spi`) |
//! | SPI1 | `resolver-spi`: AD2S1210 resolver-to-digital converter; `force-spi`: ADS131M04 force ADC (`spi.rs`, README) |
//! | DAC channel 1 | Z-slide command (PA4), mid-scale when safe |
//! | USART1 | host link (`link` firmware), 460800 8N1 from the 84 MHz APB2 clock, interrupt driven |
//! | EXTI12 | e-stop (EXTI15_10 interrupt); the tick also reads its level |
//! | GPIO | limit switches (raw; the machine debounces them), wire stall (read every tick), spindle enable and direction, mist, flood, wire power |
//! | IWDG | watchdog (link firmware), ~100 ms, fed only while tick and control run |
//! | FLASH sectors 2-3 | the persisted board config (two 16 KiB slots; code starts at sector 4) |
//! | DWT.CYCCNT | cycle counter for benchmarks |
//! | RTT | defmt log frames (probe-rs) |

#![no_std]

#[cfg(all(feature = "resolver-spi", feature = "force-spi"))]
compile_error!("resolver-spi and force-spi share SPI1's free pins: pick one (README.md)");

mod clocks;
mod copy_encoders;
mod cycles;
mod flash;
mod force_adc;
mod io;
mod log;
mod machine_io;
mod pins;
mod resolver_adc;
#[cfg(any(feature = "resolver-spi", feature = "force-spi"))]
mod spi;
mod spindle_timer;
mod step_port;
mod z_dac;

pub use board_stm32f405::{pac, HostSerial, TickRate, TickTimer, Watchdog};
pub use copy_encoders::CopyEncoders;
pub use cycles::CycleCounter;
pub use flash::ConfigFlash;
pub use force_adc::{ForceAdc, FRAMES_PER_HALF};
pub use io::EStop;
pub use machine_io::MachineIo;
pub use pins::{GpioIn, GpioOut};
pub use resolver_adc::ResolverAdc;
#[cfg(any(feature = "resolver-spi", feature = "force-spi"))]
pub use spi::Spi1Device;
pub use spindle_timer::SpindleTimer;
pub use step_port::StepPort;

use board_contract::{FlashConfig, Parts, FORCE_CHANNEL_COUNT};
use motion::machine::ResetCause;

/// The persisted config: flash sectors 2-3, one slot per sector.
pub type ConfigStorage = FlashConfig<ConfigFlash>;

/// The capability drivers no firmware task uses yet (the spindle encoder is
/// [`Parts::spindle`], the force ADC [`Parts::force_adc`]; the Z DAC is in [`MachineIo`]).
pub struct Capabilities {
    /// ADC2 resolver sin/cos (idle until the first `sample`); `None` when SPI1 takes its pins.
    pub resolver: Option<ResolverAdc>,
    /// The external resolver-to-digital converter on SPI1 (`resolver-spi`).
    #[cfg(feature = "resolver-spi")]
    pub resolver_spi: spi::Resolver,
    /// The external force ADC on SPI1 (`force-spi`).
    #[cfg(feature = "force-spi")]
    pub force_spi: spi::ForceSpi,
}

/// SPI1 takes PA5..PA7: the on-chip resolver (PA5/PA6) and force (PA7) front ends are off.
const SPI1_IN_USE: bool = cfg!(any(feature = "resolver-spi", feature = "force-spi"));

/// The board, for the Board contract.
pub struct Board;

impl board_contract::Board for Board {
    const NAME: &'static str = "f405-motion";
    /// 84 MHz / 460800 -> BRR 182 (USARTDIV 11.375), 461538 baud, +0.16 %.
    const HOST_BAUD: u32 = 460_800;
    const LINK_TIMEOUT_MS: u64 = 1_000;
    type Device = pac::Peripherals;
    type Core = cortex_m::Peripherals;
    type TickTimer = TickTimer;
    type TickRate = TickRate;
    type StepPort = StepPort;
    type EStop = EStop;
    type MachineIo = MachineIo;
    type HostSerial = HostSerial;
    type Watchdog = Watchdog;
    type ConfigStorage = ConfigStorage;
    type CopyEncoders = CopyEncoders;
    type ForceAdc = ForceAdc;
    type Spindle = SpindleTimer;
    type CycleCounter = CycleCounter;
    type Extras = Capabilities;

    fn init(dp: pac::Peripherals, core: &mut cortex_m::Peripherals, tick_hz: u32) -> Parts<Self> {
        // Why the chip reset (watchdog, pin, power-on...), read before anything else and then
        // cleared, so the next reset reports only itself.
        let reset = ResetCause::from_rcc_csr(dp.RCC.csr().read().bits());
        dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
        let clocks = clocks::init(&dp.RCC, &dp.PWR, &dp.FLASH);
        clocks::enable_peripherals(&dp.RCC);
        pins::init(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC, &dp.GPIOD);
        pins::init_program_outputs(&dp.GPIOC);
        let copy_encoders = CopyEncoders::new(dp.TIM5, dp.TIM3, &dp.RCC, &dp.GPIOA, &dp.GPIOB);
        force_adc::init_common(&dp.ADC_COMMON);
        // In SRAM (memory.x: the CCM is not DMA-capable and unused); init runs once, so `Some`.
        let force_buf = cortex_m::singleton!(: force_adc::ForceDmaBuffer =
            [[0; FORCE_CHANNEL_COUNT]; 2 * FRAMES_PER_HALF]);
        let force_adc = force_buf
            .filter(|_| !SPI1_IN_USE)
            .map(|buf| ForceAdc::new(dp.ADC1, dp.DMA2, dp.TIM8, buf, clocks.apb2_timer_hz));
        #[cfg(any(feature = "resolver-spi", feature = "force-spi"))]
        let bus = spi::init(dp.SPI1, &dp.RCC, &dp.GPIOA, &dp.GPIOC);
        let extras = Capabilities {
            resolver: (!SPI1_IN_USE).then(|| ResolverAdc::new(dp.ADC2)),
            #[cfg(feature = "resolver-spi")]
            resolver_spi: spi::resolver(bus),
            #[cfg(feature = "force-spi")]
            force_spi: spi::force(bus),
        };
        // Mid-scale (the Z slide at rest) from here on, whichever firmware runs.
        let z_dac = z_dac::ZDac::new(dp.DAC);
        Parts {
            reset,
            tick_timer: TickTimer::new(dp.TIM2, clocks.apb1_timer_hz, tick_hz),
            step_port: StepPort::new(dp.GPIOC, GpioOut::new(pins::Port::B, pins::DRV_EN_N as u8)),
            estop: EStop::new(dp.EXTI, &dp.SYSCFG),
            io: MachineIo::new(z_dac),
            host: HostSerial::new(dp.USART1, clocks.pclk2_hz, Self::HOST_BAUD),
            watchdog: Watchdog::new(dp.IWDG),
            config: FlashConfig::new(ConfigFlash::new(dp.FLASH), flash::SECTOR_BYTES),
            copy_encoders,
            force_adc,
            spindle: SpindleTimer::new(dp.TIM4),
            cycles: CycleCounter::new(core),
            extras,
        }
    }

    /// Ends the run. Outputs go to their safe state (drivers disabled, STEP low). Under a
    /// debugger the core halts on a breakpoint so `probe-rs run` returns; standalone it parks
    /// in `wfi` (a motion controller must not restart a job by itself after a fault).
    fn exit(_ok: bool) -> ! {
        step_port::force_safe();
        z_dac::force_safe();
        // SAFETY: reading DHCSR has no side effects.
        let debugger = unsafe { (*cortex_m::peripheral::DCB::PTR).dhcsr.read() } & 1 != 0;
        if debugger {
            cortex_m::asm::bkpt();
        }
        loop {
            cortex_m::asm::wfi();
        }
    }
}
