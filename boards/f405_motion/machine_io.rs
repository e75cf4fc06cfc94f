//! The safety inputs and process outputs the machine reads and drives every tick: e-stop and the
//! 12 limit switches in; spindle enable, wire power and the Z-slide DAC out. Inputs are
//! read from the three ports' IDR (read-only, so sharing the ports with the step port is safe);
//! outputs go through GPIOB's BSRR (atomic set/reset, no read-modify-write).

use super::pins::{Port, ESTOP, LIMIT_MAX, LIMIT_MIN, SPINDLE_EN, WIRE_POWER, WIRE_STALL};
use super::z_dac::ZDac;
use motion::machine::Outputs;
use stm32f4::stm32f405 as pac;

/// Levels read in one tick. (The wire-stall switch belongs to the wire manipulator's retrace
/// controller, not to the fault model: only a stall that outlasts the retrace is a fault.)
#[derive(Clone, Copy, Default)]
pub struct RawInputs {
    pub estop: bool,
    /// Bit i = axis i's switch open (tripped).
    pub limit_min: u8,
    pub limit_max: u8,
    /// The wire-lag micro-switch (`pins::WIRE_STALL`, PA8) is closed: the wire stalls.
    pub wire_stall: bool,
}

pub struct MachineIo {
    z_dac: ZDac,
}

/// Bit `n` of a port's input data register.
#[inline(always)]
fn idr(port: Port) -> u32 {
    // SAFETY: reading IDR has no side effects; the ports are configured by `pins::init`.
    unsafe {
        match port {
            Port::A => (*pac::GPIOA::ptr()).idr().read().bits(),
            Port::B => (*pac::GPIOB::ptr()).idr().read().bits(),
            Port::C => (*pac::GPIOC::ptr()).idr().read().bits(),
        }
    }
}

#[inline(always)]
fn gather(pins: &[(Port, u8); 6], a: u32, b: u32, c: u32) -> u8 {
    let mut bits = 0u8;
    for (i, &(port, pin)) in pins.iter().enumerate() {
        let level = match port {
            Port::A => a,
            Port::B => b,
            Port::C => c,
        };
        bits |= (((level >> pin) & 1) as u8) << i;
    }
    bits
}

impl MachineIo {
    /// The real board reads real inputs: no `SimInject`.
    pub const SIM_INPUTS: bool = false;

    /// `SimInject` is not honoured here (false: refused).
    pub fn inject_wire_stall(_stalled: bool) -> bool {
        false
    }

    /// Pins are configured by `pins::init`.
    pub fn new(z_dac: ZDac) -> Self {
        MachineIo { z_dac }
    }

    /// Every input, active levels resolved: the e-stop loop and the limit switches are normally
    /// closed to ground (open = high = stop).
    #[inline]
    pub fn read(&mut self) -> RawInputs {
        let (a, b, c) = (idr(Port::A), idr(Port::B), idr(Port::C));
        RawInputs {
            estop: (b >> ESTOP) & 1 != 0,
            limit_min: gather(&LIMIT_MIN, a, b, c),
            limit_max: gather(&LIMIT_MAX, a, b, c),
            // Closed to ground (pulled up): low = stalled.
            wire_stall: (a >> WIRE_STALL) & 1 == 0,
        }
    }

    /// Spindle enable, wire power and the Z DAC to `o`'s levels. A DAC code out of range
    /// writes mid-scale (the slide at rest); the machine only ever produces 12-bit codes.
    #[inline]
    pub fn write(&mut self, o: &Outputs) {
        let on = |level: bool, pin: u32| if level { 1 << pin } else { 1 << (pin + 16) };
        let bits = on(o.spindle_enable, SPINDLE_EN) | on(o.wire_power, WIRE_POWER);
        // SAFETY: BSRR accepts any bit pattern; only these two output bits are written.
        unsafe { (*pac::GPIOB::ptr()).bsrr().write(|w| w.bits(bits)) };
        let _ = self.z_dac.write(o.z_dac);
    }
}
