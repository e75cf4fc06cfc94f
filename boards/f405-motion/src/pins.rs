//! Pin map of the board (mirrored in README.md). STEP and DIR sit on consecutive bits of GPIOC so
//! one BSRR write moves all six axes at once.

use crate::pac;
use core::convert::Infallible;

#[derive(Clone, Copy)]
pub enum Port {
    A,
    B,
    C,
    D,
}

#[derive(Clone, Copy)]
pub enum Mode {
    /// Push-pull output at the given initial level.
    Output {
        high: bool,
    },
    /// Input with pull-up.
    InputPullUp,
    /// Alternate function `af`, pulled up when `pull_up`.
    Alternate {
        af: u8,
        pull_up: bool,
    },
    Analog,
}

pub struct Pin {
    pub name: &'static str,
    pub port: Port,
    pub pin: u8,
    pub mode: Mode,
}

/// STEP0..5 = PC0..PC5 (active high: rising edge = one step).
pub const STEP_SHIFT: u32 = 0;
/// DIR0..5 = PC6..PC11 (high = negative direction).
pub const DIR_SHIFT: u32 = 6;
/// Shared driver enable, active low (high = drivers disabled), on GPIOB.
pub const DRV_EN_N: u32 = 2;
/// E-stop loop on GPIOB (EXTI line 12): closed to ground = run, open (high) = stop.
pub const ESTOP: u32 = 12;

/// Limit switches per axis (min, max), normally closed to ground: open (high) = tripped.
pub const LIMIT_MIN: [(Port, u8); 6] =
    [(Port::B, 3), (Port::C, 13), (Port::B, 9), (Port::B, 10), (Port::B, 11), (Port::B, 13)];
pub const LIMIT_MAX: [(Port, u8); 6] =
    [(Port::B, 14), (Port::B, 15), (Port::A, 11), (Port::A, 12), (Port::A, 15), (Port::C, 12)];
/// Spindle enable and wire power on GPIOB, active high.
pub const SPINDLE_EN: u32 = 0;
pub const WIRE_POWER: u32 = 1;
/// Wire-lag micro-switch on GPIOA, closed to ground = stalled.
pub const WIRE_STALL: u32 = 8;
/// Program outputs (G-code M3/M4, M8), active high, off (and clockwise) from reset: spindle
/// direction on PC14 (high = counterclockwise, M4), flood coolant on PC15. PC14/PC15 were the
/// LQFP64's last free pins; PD2, its only port-D pin, is the touch probe's ([`PROBE`]), so the
/// board has no mist output and refuses M7 (as grbl does by default, without `ENABLE_M7`).
/// PC13..PC15 are slow, low-current pins: they drive relay or SSR driver inputs, not loads.
pub const SPINDLE_DIR: (Port, u8) = (Port::C, 14);
pub const FLOOD: (Port, u8) = (Port::C, 15);
/// Touch probe on GPIOD, pulled up, closed to ground = in contact (grbl's default polarity: a
/// probe plate or a normally-open touch probe switching to ground).
pub const PROBE: u32 = 2;

const fn pin(name: &'static str, port: Port, pin: u8, mode: Mode) -> Pin {
    Pin { name, port, pin, mode }
}

const LOW: Mode = Mode::Output { high: false };

const IN: Mode = Mode::InputPullUp;

pub const PINS: [Pin; 41] = [
    pin("STEP0", Port::C, 0, LOW),
    pin("STEP1", Port::C, 1, LOW),
    pin("STEP2", Port::C, 2, LOW),
    pin("STEP3", Port::C, 3, LOW),
    pin("STEP4", Port::C, 4, LOW),
    pin("STEP5", Port::C, 5, LOW),
    pin("DIR0", Port::C, 6, LOW),
    pin("DIR1", Port::C, 7, LOW),
    pin("DIR2", Port::C, 8, LOW),
    pin("DIR3", Port::C, 9, LOW),
    pin("DIR4", Port::C, 10, LOW),
    pin("DIR5", Port::C, 11, LOW),
    pin("DRV_EN_N", Port::B, DRV_EN_N as u8, Mode::Output { high: true }),
    pin("ESTOP", Port::B, ESTOP as u8, Mode::InputPullUp),
    pin("SPINDLE_A", Port::B, 6, Mode::Alternate { af: 2, pull_up: true }), // TIM4_CH1
    pin("SPINDLE_B", Port::B, 7, Mode::Alternate { af: 2, pull_up: true }), // TIM4_CH2
    pin("FORCE0", Port::A, 2, Mode::Analog),                                // ADC1_IN2
    pin("FORCE1", Port::A, 3, Mode::Analog),                                // ADC1_IN3
    pin("FORCE2", Port::A, 7, Mode::Analog),                                // ADC1_IN7
    pin("HOST_TX", Port::A, 9, Mode::Alternate { af: 7, pull_up: false }),  // USART1_TX
    pin("HOST_RX", Port::A, 10, Mode::Alternate { af: 7, pull_up: true }),  // USART1_RX
    // Spindle encoder index: TIM4_CH3 input capture latches the count at the index edge.
    pin("SPINDLE_INDEX", Port::B, 8, Mode::Alternate { af: 2, pull_up: true }),
    pin("RESOLVER_SIN", Port::A, 5, Mode::Analog), // ADC2_IN5 (ADC12_IN5)
    pin("RESOLVER_COS", Port::A, 6, Mode::Analog), // ADC2_IN6 (ADC12_IN6)
    pin("Z_DAC", Port::A, 4, Mode::Analog),        // DAC1_OUT1: voice-coil Z slide command
    // Outputs that power the process start off: nothing cuts before the firmware says so.
    pin("SPINDLE_EN", Port::B, SPINDLE_EN as u8, LOW),
    pin("WIRE_POWER", Port::B, WIRE_POWER as u8, LOW),
    pin("WIRE_STALL", Port::A, WIRE_STALL as u8, IN),
    pin("PROBE", Port::D, PROBE as u8, IN),
    // Limit switches, normally closed to ground: open (high) = tripped or a broken wire.
    pin("LIMIT_MIN0", LIMIT_MIN[0].0, LIMIT_MIN[0].1, IN),
    pin("LIMIT_MIN1", LIMIT_MIN[1].0, LIMIT_MIN[1].1, IN),
    pin("LIMIT_MIN2", LIMIT_MIN[2].0, LIMIT_MIN[2].1, IN),
    pin("LIMIT_MIN3", LIMIT_MIN[3].0, LIMIT_MIN[3].1, IN),
    pin("LIMIT_MIN4", LIMIT_MIN[4].0, LIMIT_MIN[4].1, IN),
    pin("LIMIT_MIN5", LIMIT_MIN[5].0, LIMIT_MIN[5].1, IN),
    pin("LIMIT_MAX0", LIMIT_MAX[0].0, LIMIT_MAX[0].1, IN),
    pin("LIMIT_MAX1", LIMIT_MAX[1].0, LIMIT_MAX[1].1, IN),
    pin("LIMIT_MAX2", LIMIT_MAX[2].0, LIMIT_MAX[2].1, IN),
    pin("LIMIT_MAX3", LIMIT_MAX[3].0, LIMIT_MAX[3].1, IN),
    pin("LIMIT_MAX4", LIMIT_MAX[4].0, LIMIT_MAX[4].1, IN),
    pin("LIMIT_MAX5", LIMIT_MAX[5].0, LIMIT_MAX[5].1, IN),
];

/// No pin is assigned twice (checked at compile time).
const _: () = {
    let mut i = 0;
    while i < PINS.len() {
        let mut j = i + 1;
        while j < PINS.len() {
            let same_port = PINS[i].port as u8 == PINS[j].port as u8;
            assert!(!(same_port && PINS[i].pin == PINS[j].pin), "a pin is assigned twice");
            j += 1;
        }
        i += 1;
    }
};

/// Copy-mode encoder inputs (template digitizer): arm angle on TIM5 CH1/CH2 (PA0/PA1,
/// AF2; TIM5 is 32-bit), carriage radius on TIM3 CH1/CH2 (PB4/PB5, AF2; 16-bit, extended in
/// software). The 64-pin F405RG has no spare pair of encoder pins, so the pin plan makes room:
/// the force sensors sit on PA2/PA3/PA7 (ADC1 IN2/IN3/IN7; the chain takes three channels),
/// LIMIT_MIN1 on PC13 and DRV_EN_N on PB2, and the force ADC is triggered by TIM8 (no pins)
/// instead of TIM3. [`COPY_ENCODERS_ROUTED`] still checks, at compile time, that no pin of
/// [`PINS`] uses them.
pub const COPY_ENCODER_PINS: [Pin; 4] = [
    pin("COPY_ARM_A", Port::A, 0, Mode::Alternate { af: 2, pull_up: true }), // TIM5_CH1
    pin("COPY_ARM_B", Port::A, 1, Mode::Alternate { af: 2, pull_up: true }), // TIM5_CH2
    pin("COPY_CARRIAGE_A", Port::B, 4, Mode::Alternate { af: 2, pull_up: true }), // TIM3_CH1
    pin("COPY_CARRIAGE_B", Port::B, 5, Mode::Alternate { af: 2, pull_up: true }), // TIM3_CH2
];

/// No pin of [`COPY_ENCODER_PINS`] is in [`PINS`]: the copy encoders can be wired.
pub const COPY_ENCODERS_ROUTED: bool = {
    let mut free = true;
    let mut i = 0;
    while i < COPY_ENCODER_PINS.len() {
        let mut j = 0;
        while j < PINS.len() {
            let same_port = COPY_ENCODER_PINS[i].port as u8 == PINS[j].port as u8;
            if same_port && COPY_ENCODER_PINS[i].pin == PINS[j].pin {
                free = false;
            }
            j += 1;
        }
        i += 1;
    }
    free
};

// This board routes them: a pin change that takes one fails the build instead of quietly
// turning copy mode off.
const _: () = assert!(COPY_ENCODERS_ROUTED, "a copy encoder pin is assigned to something else");

/// The program outputs' pins ([`SPINDLE_DIR`], [`FLOOD`]), configured by
/// [`init_program_outputs`] when [`PROGRAM_OUTPUTS_ROUTED`].
pub const PROGRAM_OUTPUT_PINS: [Pin; 2] =
    [pin("SPINDLE_DIR", SPINDLE_DIR.0, SPINDLE_DIR.1, LOW), pin("FLOOD", FLOOD.0, FLOOD.1, LOW)];

/// The program outputs are wired: no SPI option takes PC14/PC15 (its chip select and
/// sample/reset lines sit there).
pub const PROGRAM_OUTPUTS_ROUTED: bool =
    !cfg!(any(feature = "resolver-spi", feature = "force-spi"));

/// No program output pin is in [`PINS`] (checked at compile time).
const _: () = {
    let mut i = 0;
    while i < PROGRAM_OUTPUT_PINS.len() {
        let mut j = 0;
        while j < PINS.len() {
            let same_port = PROGRAM_OUTPUT_PINS[i].port as u8 == PINS[j].port as u8;
            assert!(
                !(same_port && PROGRAM_OUTPUT_PINS[i].pin == PINS[j].pin),
                "a program output pin is assigned to something else"
            );
            j += 1;
        }
        i += 1;
    }
};

/// Force-sensor ADC channels, in FORCE0.. order.
pub const FORCE_CHANNELS: [u8; 3] = [2, 3, 7];

/// Writes one pin's configuration. All GPIO ports share one register layout but are distinct
/// PAC types, hence a macro.
macro_rules! configure {
    ($gpio:expr, $p:expr) => {{
        let gpio = $gpio;
        let n = $p.pin as u32;
        let (moder, pull, af, out_high) = match $p.mode {
            Mode::Output { high } => (0b01, 0b00, 0, Some(high)),
            Mode::InputPullUp => (0b00, 0b01, 0, None),
            Mode::Alternate { af, pull_up } => (0b10, pull_up as u32, af as u32, None),
            Mode::Analog => (0b11, 0b00, 0, None),
        };
        // Level first, so an output never glitches to the wrong state.
        if let Some(high) = out_high {
            let bit = if high { 1 << n } else { 1 << (n + 16) };
            // SAFETY: BSRR accepts any bit pattern.
            gpio.bsrr().write(|w| unsafe { w.bits(bit) });
        }
        let two = |v: u32, r: u32| (r & !(0b11 << (2 * n))) | (v << (2 * n));
        // SAFETY (all below): 2- and 4-bit fields written with values defined in RM0090 8.4.
        gpio.otyper().modify(|r, w| unsafe { w.bits(r.bits() & !(1 << n)) });
        gpio.ospeedr().modify(|r, w| unsafe { w.bits(two(0b11, r.bits())) });
        gpio.pupdr().modify(|r, w| unsafe { w.bits(two(pull, r.bits())) });
        if n < 8 {
            let s = 4 * n;
            gpio.afrl().modify(|r, w| unsafe { w.bits((r.bits() & !(0xf << s)) | (af << s)) });
        } else {
            let s = 4 * (n - 8);
            gpio.afrh().modify(|r, w| unsafe { w.bits((r.bits() & !(0xf << s)) | (af << s)) });
        }
        gpio.moder().modify(|r, w| unsafe { w.bits(two(moder, r.bits())) });
    }};
}

pub fn init(a: &pac::GPIOA, b: &pac::GPIOB, c: &pac::GPIOC, d: &pac::GPIOD) {
    for p in &PINS {
        let port = match p.port {
            Port::A => 'A',
            Port::B => 'B',
            Port::C => 'C',
            Port::D => 'D',
        };
        defmt::debug!("pin {=str} = P{=char}{=u8}", p.name, port, p.pin);
        match p.port {
            Port::A => configure!(a, p),
            Port::B => configure!(b, p),
            Port::C => configure!(c, p),
            Port::D => configure!(d, p),
        }
    }
}

/// Configures the copy encoder pins if they are free (see [`COPY_ENCODERS_ROUTED`]).
pub fn init_copy_encoders(a: &pac::GPIOA, b: &pac::GPIOB) {
    if !COPY_ENCODERS_ROUTED {
        defmt::warn!("copy encoders not routed: their pins are in use (see pins.rs)");
        return;
    }
    for p in &COPY_ENCODER_PINS {
        match p.port {
            Port::A => configure!(a, p),
            Port::B => configure!(b, p),
            Port::C | Port::D => {}
        }
    }
}

/// Configures the program output pins (low: spindle clockwise, coolant off) if they are routed
/// (see [`PROGRAM_OUTPUTS_ROUTED`]).
pub fn init_program_outputs(c: &pac::GPIOC) {
    if !PROGRAM_OUTPUTS_ROUTED {
        defmt::warn!("spindle direction and coolant not routed: an SPI option uses PC14/PC15");
        return;
    }
    for p in &PROGRAM_OUTPUT_PINS {
        match p.port {
            Port::C => configure!(c, p),
            Port::A | Port::B | Port::D => {}
        }
    }
}

/// Configures one pin (the SPI options' pins, which are not in [`PINS`]).
#[cfg(any(feature = "resolver-spi", feature = "force-spi"))]
pub fn configure_one(a: &pac::GPIOA, c: &pac::GPIOC, p: &Pin) {
    match p.port {
        Port::A => configure!(a, p),
        Port::C => configure!(c, p),
        Port::B | Port::D => {}
    }
}

/// A port's register block (all GPIO ports share one layout).
#[inline(always)]
fn regs(port: Port) -> &'static pac::gpioa::RegisterBlock {
    // SAFETY: the GPIO register blocks are memory-mapped for the program's lifetime; GPIOB..D
    // have GPIOA's layout (the PAC derives them from it).
    unsafe {
        match port {
            Port::A => &*pac::GPIOA::ptr(),
            Port::B => &*(pac::GPIOB::ptr() as *const pac::gpioa::RegisterBlock),
            Port::C => &*(pac::GPIOC::ptr() as *const pac::gpioa::RegisterBlock),
            Port::D => &*(pac::GPIOD::ptr() as *const pac::gpioa::RegisterBlock),
        }
    }
}

/// A port's input data register (read-only, so reading it next to other owners is safe).
#[inline(always)]
pub fn idr(port: Port) -> u32 {
    regs(port).idr().read().bits()
}

/// One output pin, written through its port's BSRR (atomic: no read-modify-write), as an
/// `embedded_hal::digital::OutputPin`. Configured by [`init`].
pub struct GpioOut {
    port: Port,
    pin: u8,
}

impl GpioOut {
    pub const fn new(port: Port, pin: u8) -> Self {
        GpioOut { port, pin }
    }
}

impl embedded_hal::digital::ErrorType for GpioOut {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for GpioOut {
    #[inline]
    fn set_low(&mut self) -> Result<(), Infallible> {
        // SAFETY: BSRR accepts any bit pattern; this writes only this pin's reset bit.
        regs(self.port).bsrr().write(|w| unsafe { w.bits(1 << (self.pin + 16)) });
        Ok(())
    }

    #[inline]
    fn set_high(&mut self) -> Result<(), Infallible> {
        // SAFETY: as above, this pin's set bit.
        regs(self.port).bsrr().write(|w| unsafe { w.bits(1 << self.pin) });
        Ok(())
    }
}

/// One input pin read from its port's IDR, as an `embedded_hal::digital::InputPin`.
pub struct GpioIn {
    port: Port,
    pin: u8,
}

impl GpioIn {
    pub const fn new(port: Port, pin: u8) -> Self {
        GpioIn { port, pin }
    }
}

impl embedded_hal::digital::ErrorType for GpioIn {
    type Error = Infallible;
}

impl embedded_hal::digital::InputPin for GpioIn {
    #[inline]
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok((idr(self.port) >> self.pin) & 1 != 0)
    }

    #[inline]
    fn is_low(&mut self) -> Result<bool, Infallible> {
        self.is_high().map(|h| !h)
    }
}
