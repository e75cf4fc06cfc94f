//! A generic STM32F405RG motion board: six step/dir pairs, a shared driver enable, an e-stop
//! input, a quadrature spindle encoder, four analog force sensors and a USART host link.
//! Pin map: see `README.md` beside this file (and `pins.rs`, which is the source of truth).
//!
//! | resource | use |
//! | --- | --- |
//! | HSE 8 MHz -> PLL | SYSCLK 168 MHz, AHB 168, APB1 42 (timers 84), APB2 84 (timers 168) MHz |
//! | TIM2 | DDA tick (update interrupt at `tick_hz`) |
//! | TIM5, TIM3 | copy-mode encoders (arm, carriage; encoder mode 3), `link` builds (`pins.rs`) |
//! | TIM4 | spindle encoder (encoder mode 3 on CH1/CH2), index capture on CH3 (`TIM4` interrupt) |
//! | ADC1 + TIM8 + DMA2 stream 0 | force sensors: TIM8 TRGO scans, DMA double buffer (`DMA2_STREAM0`) |
//! | ADC2 | resolver sin/cos, injected group, one pair per tick |
//! | DAC channel 1 | Z-slide command (PA4), mid-scale when safe |
//! | USART1 | host link (`link` feature), 460800 8N1 from the 84 MHz APB2 clock, interrupt driven |
//! | EXTI12 | e-stop (EXTI15_10 interrupt); the tick also reads its level |
//! | GPIO | limit switches, wire stall (read every tick), spindle enable, wire power |
//! | IWDG | watchdog (link firmware), ~100 ms, fed only while tick and control run |
//! | FLASH sectors 2-3 | the persisted board config (two 16 KiB slots; code starts at sector 4) |
//! | DWT.CYCCNT | cycle counter for benchmarks |
//! | RTT | defmt log frames (probe-rs) |

mod clocks;
#[cfg(feature = "link")]
mod config_storage;
#[cfg(feature = "link")]
mod copy_encoders;
mod cycles;
#[cfg(feature = "link")]
mod flash;
mod force_adc;
#[path = "../common/host_serial.rs"]
mod host_serial;
mod io;
mod log;
#[cfg(feature = "link")]
mod machine_io;
mod pins;
mod resolver_adc;
mod spindle_timer;
mod step_port;
#[path = "../common/tick_timer.rs"]
mod tick_timer;
#[cfg(feature = "link")]
#[path = "../common/watchdog.rs"]
mod watchdog;
mod z_dac;

pub use cycles::CycleCounter;
// Wired by the link firmware's capability tasks (no app names these types yet).
#[cfg(feature = "link")]
pub use config_storage::ConfigStorage;
#[cfg(feature = "link")]
pub use copy_encoders::CopyEncoders;
#[allow(unused_imports)]
pub use force_adc::{ForceAdc, ForceFrame, FORCE_CHANNEL_COUNT, FRAMES_PER_HALF};
pub use host_serial::HostSerial;
pub use io::EStop;
#[cfg(feature = "link")]
pub use machine_io::MachineIo;
// Wired by the link firmware's capability tasks (no app names these types yet).
#[allow(unused_imports)]
pub use resolver_adc::ResolverAdc;
pub use spindle_timer::SpindleTimer;
/// The spindle angle source of Z-slide jobs: TIM4's encoder through the encoder logic.
#[cfg(feature = "link")]
pub type Spindle = SpindleTimer;
pub use step_port::StepPort;
#[cfg(feature = "link")]
pub use watchdog::Watchdog;
// The demo firmware never changes its tick rate.
#[allow(unused_imports)]
pub use tick_timer::TickRate;
pub use tick_timer::TickTimer;

use stm32f4::stm32f405 as pac;

pub const NAME: &str = "f405-motion";
/// Host link baud rate: 84 MHz / 460800 -> BRR 182 (USARTDIV 11.375), 461538 baud, +0.16 %.
pub const HOST_BAUD: u32 = 460_800;

/// Everything the app needs from the board, configured and idle (drivers disabled).
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
    /// E-stop, limit and wire-stall inputs; spindle and wire-power outputs (`link` builds).
    #[cfg(feature = "link")]
    pub io: MachineIo,
    /// The independent watchdog, not started (the link firmware starts it).
    #[cfg(feature = "link")]
    pub iwdg: pac::IWDG,
    /// The persisted config (flash sectors 2-3).
    #[cfg(feature = "link")]
    pub config: ConfigStorage,
    /// Copy-mode encoders on TIM5 (arm) and TIM3 (carriage); see `pins.rs` for their pins.
    #[cfg(feature = "link")]
    pub copy_encoders: CopyEncoders,
    /// ADC1 scans of the force channels, TIM8-triggered, DMA2 stream 0 (not started; `None`
    /// only if init ran twice): the link firmware's force jobs.
    #[cfg_attr(not(feature = "link"), allow(dead_code))]
    pub force_adc: Option<ForceAdc>,
    /// The capability drivers (`None` only if init ran twice).
    // Wired by the link firmware's capability tasks; no app uses them yet.
    #[allow(dead_code)]
    pub capabilities: Option<Capabilities>,
    /// TIM4 encoder count and index capture (counting; the link firmware configures the
    /// encoder logic and reads it every tick for Z-slide jobs).
    #[cfg_attr(not(feature = "link"), allow(dead_code))]
    pub spindle: SpindleTimer,
}

/// The capability drivers not yet wired into an app (resolver ADC; the spindle encoder is
/// [`Board::spindle`], the force ADC [`Board::force_adc`]). The Z DAC is in [`MachineIo`]: the
/// machine's outputs drive it every tick.
#[allow(dead_code)]
pub struct Capabilities {
    /// ADC2 resolver sin/cos (idle until the first `sample`).
    pub resolver: ResolverAdc,
}

pub fn init(dp: pac::Peripherals, core: &mut cortex_m::Peripherals, tick_hz: u32) -> Board {
    // Why the chip reset (watchdog, pin, power-on...), read before anything else and then
    // cleared, so the next reset reports only itself.
    let reset_csr = dp.RCC.csr().read().bits();
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    let clocks = clocks::init(&dp.RCC, &dp.PWR, &dp.FLASH);
    clocks::enable_peripherals(&dp.RCC);
    pins::init(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
    #[cfg(feature = "link")]
    let copy_encoders = CopyEncoders::new(dp.TIM5, dp.TIM3, &dp.RCC, &dp.GPIOA, &dp.GPIOB);
    force_adc::init_common(&dp.ADC_COMMON);
    // In SRAM (memory.x: the CCM is not DMA-capable and unused); init runs once, so `Some`.
    let force_buf = cortex_m::singleton!(: force_adc::ForceDmaBuffer =
        [[0; FORCE_CHANNEL_COUNT]; 2 * FRAMES_PER_HALF]);
    let force_adc =
        force_buf.map(|buf| ForceAdc::new(dp.ADC1, dp.DMA2, dp.TIM8, buf, clocks.apb2_timer_hz));
    let capabilities = Some(Capabilities { resolver: ResolverAdc::new(dp.ADC2) });
    // Mid-scale (the Z slide at rest) from here on, whichever firmware runs.
    #[cfg_attr(not(feature = "link"), allow(unused_variables))]
    let z_dac = z_dac::ZDac::new(dp.DAC);
    Board {
        reset_csr,
        tick_timer: TickTimer::new(dp.TIM2, clocks.apb1_timer_hz, tick_hz),
        step_port: StepPort::new(dp.GPIOC, dp.GPIOB),
        cycles: CycleCounter::new(core),
        estop: EStop::new(dp.EXTI, &dp.SYSCFG),
        host: HostSerial::new(dp.USART1, clocks.pclk2_hz, HOST_BAUD),
        #[cfg(feature = "link")]
        io: MachineIo::new(z_dac),
        #[cfg(feature = "link")]
        iwdg: dp.IWDG,
        #[cfg(feature = "link")]
        config: ConfigStorage::new(dp.FLASH),
        #[cfg(feature = "link")]
        copy_encoders,
        force_adc,
        capabilities,
        spindle: SpindleTimer::new(dp.TIM4),
    }
}

/// Ends the run. Outputs go to their safe state (drivers disabled, STEP low). Under a debugger the
/// core halts on a breakpoint so `probe-rs run` returns; standalone it parks in `wfi` (a motion
/// controller must not restart a job by itself after a fault).
pub fn exit(_ok: bool) -> ! {
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

/// The real spindle is read, never simulated: `SimSpindle` is refused.
#[cfg(feature = "link")]
impl SpindleTimer {
    pub const SIM: bool = false;

    /// Not honoured on real hardware; false.
    pub fn set_sim(_speed_turn_q32_per_tick: u32, _index: bool) -> bool {
        false
    }
}
