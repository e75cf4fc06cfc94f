//! The safety inputs and process outputs the machine reads and drives every tick: e-stop, the
//! 12 limit switches and the wire-stall switch in; spindle enable and direction, mist and flood
//! coolant, wire power and the Z-slide DAC out; the touch probe in.
//!
//! The limit switches are read as three port words (12 `InputPin` reads a tick would cost four
//! times as much) and the e-stop as an `InputPin` (an unreadable pin reads tripped), both raw:
//! the machine debounces them with the configured `switch_debounce_us`
//! (`motion::machine::debounce`), the same on every board, and so the touch probe on PD2
//! (closed to ground = contact; the machine debounces it with the same time and watches it
//! during probe moves). The board has no mist output (PD2 is the probe's): M7 is refused. The
//! wire-stall switch is passed raw: the wire controller debounces it with the
//! job's own `debounce_ticks`. Outputs go through their ports' BSRR (atomic set/reset, no
//! read-modify-write against the step port's writes to GPIOC).

use super::pins::{
    self, GpioIn, Port, ESTOP, FLOOD, LIMIT_MAX, LIMIT_MIN, PROBE, PROGRAM_OUTPUTS_ROUTED,
    SPINDLE_DIR, SPINDLE_EN, WIRE_POWER, WIRE_STALL,
};
use super::z_dac::ZDac;
use crate::pac;
use board_contract::{Debounced, Debouncer, RawInputs};
use motion::machine::Outputs;

pub struct MachineIo {
    z_dac: ZDac,
    /// Raw (a 0-tick debouncer: the active level resolved, a read error tripped).
    estop: Debounced<GpioIn>,
}

#[inline(always)]
fn gather(pins: &[(Port, u8); 6], a: u32, b: u32, c: u32) -> u8 {
    let mut bits = 0u8;
    for (i, &(port, pin)) in pins.iter().enumerate() {
        let level = match port {
            Port::A => a,
            Port::B => b,
            Port::C | Port::D => c,
        };
        bits |= (((level >> pin) & 1) as u8) << i;
    }
    bits
}

impl MachineIo {
    /// Pins are configured by `pins::init` and `pins::init_program_outputs`.
    pub fn new(z_dac: ZDac) -> Self {
        // Normally closed to ground: open (high) = stop / tripped.
        let estop =
            Debounced::new(GpioIn::new(Port::B, ESTOP as u8), true, Debouncer::new(0, false));
        MachineIo { z_dac, estop }
    }
}

impl board_contract::MachineIo for MachineIo {
    /// The real board reads real inputs: no `Sim(Inject)`.
    const SIM_INPUTS: bool = false;
    /// Spindle direction and flood on PC14 and PC15, unless an SPI option took them.
    const PROGRAM_OUTPUTS: bool = PROGRAM_OUTPUTS_ROUTED;
    /// No mist output: PD2 is the touch probe's.
    const MIST: bool = false;

    /// `Sim(Inject)` is not honoured here (false: refused).
    fn inject_wire_stall(_stalled: bool) -> bool {
        false
    }

    /// Every input, active levels resolved (see the module docs).
    #[inline]
    fn read(&mut self) -> RawInputs {
        let (a, b, c) = (pins::idr(Port::A), pins::idr(Port::B), pins::idr(Port::C));
        RawInputs {
            estop: self.estop.update(),
            limit_min: gather(&LIMIT_MIN, a, b, c),
            limit_max: gather(&LIMIT_MAX, a, b, c),
            // Closed to ground (pulled up): low = stalled.
            wire_stall: (a >> WIRE_STALL) & 1 == 0,
            // Closed to ground (pulled up): low = contact.
            probe: (pins::idr(Port::D) >> PROBE) & 1 == 0,
        }
    }

    /// Spindle enable and direction, coolant, wire power and the Z DAC to `o`'s levels. A DAC
    /// code out of range writes mid-scale (the slide at rest); the machine only ever produces
    /// 12-bit codes.
    #[inline]
    fn write(&mut self, o: &Outputs) {
        let on = |level: bool, pin: u32| if level { 1 << pin } else { 1 << (pin + 16) };
        let bits = on(o.spindle_enable, SPINDLE_EN) | on(o.wire_power, WIRE_POWER);
        // SAFETY: BSRR accepts any bit pattern; only these two output bits are written.
        unsafe { (*pac::GPIOB::ptr()).bsrr().write(|w| w.bits(bits)) };
        if PROGRAM_OUTPUTS_ROUTED {
            let c = on(o.spindle_ccw, SPINDLE_DIR.1 as u32) | on(o.flood, FLOOD.1 as u32);
            // SAFETY: as above; only the direction and flood bits of GPIOC (the step port's
            // bits are untouched: BSRR sets and resets only the bits written as 1).
            unsafe { (*pac::GPIOC::ptr()).bsrr().write(|w| w.bits(c)) };
        }
        let _ = self.z_dac.write(o.z_dac);
    }
}
