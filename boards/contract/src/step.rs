//! The step/dir/enable outputs.
//!
//! The DDA hands the port one [`StepOutput`] per tick: falling STEP edges, DIR writes (with
//! their levels) and rising STEP edges, to be applied in that order. A board with all STEP and
//! DIR pins on one GPIO port implements [`StepPort::write`] as single word stores (set/reset
//! register writes): the tick is the hottest code there is, and a pin-by-pin loop costs tens
//! of cycles per axis. [`PinStepPort`] is that loop over `embedded_hal::digital::OutputPin`s,
//! for boards whose pins are scattered (and as the reference the word ports are held to).

use embedded_hal::digital::{OutputPin, PinState};
use motion::dda::edge_stream::PortWords;
use motion::StepOutput;

/// Slots per half buffer of a [`StepStream`]: ticks per fill interrupt. 40 divides the tick
/// rates configs use (the 50 kHz safe default, 100, 250, 500 kHz): 80 us of slots at 500 kHz.
pub const STREAM_SLOTS: usize = 40;

/// A step output played by hardware (`motion::dda::edge_stream`): a timer at the slot rate
/// requests a DMA transfer of the next word of a circular buffer into the step port's
/// set/reset register, and the DMA's half interrupt fills the half it has just played, one
/// machine tick per slot. The board's tick timer is then that interrupt's source, and its
/// rate control takes the slot rate. The [`StepPort`] keeps the enable and the safe state.
pub trait StepStream {
    /// Where the STEP and DIR pins sit on the port.
    fn layout(&self) -> PortWords;
    /// The half the hardware has just played and plays again after the other: the fill
    /// interrupt writes all of it, one word per slot, in slot order.
    fn half(&mut self) -> &mut [u32; STREAM_SLOTS];
}

pub trait StepPort {
    /// One tick's output: falling edges, DIR writes, rising edges. Bounded, no division.
    fn write(&mut self, out: &StepOutput);
    /// Drivers on.
    fn enable(&mut self);
    /// Drivers off and every STEP low (also the safe state after an e-stop).
    fn disable(&mut self);
}

/// A step port over individual pins: STEP and DIR per axis, one shared enable (active level
/// given). DIR high = negative direction, as on every board here.
pub struct PinStepPort<P, const N: usize> {
    step: [P; N],
    dir: [P; N],
    enable: P,
    enable_active_high: bool,
}

impl<P: OutputPin, const N: usize> PinStepPort<P, N> {
    pub fn new(step: [P; N], dir: [P; N], enable: P, enable_active_high: bool) -> Self {
        PinStepPort { step, dir, enable, enable_active_high }
    }

    pub fn release(self) -> ([P; N], [P; N], P) {
        (self.step, self.dir, self.enable)
    }

    fn set_enable(&mut self, on: bool) {
        let level = if on == self.enable_active_high { PinState::High } else { PinState::Low };
        // A GPIO write cannot fail on these boards; nothing better to do if one did.
        let _ = self.enable.set_state(level);
    }
}

impl<P: OutputPin, const N: usize> StepPort for PinStepPort<P, N> {
    fn write(&mut self, out: &StepOutput) {
        let (fall, write, dir, rise) = (out.fall(), out.dir_write(), out.dir(), out.rise());
        for (i, p) in self.step.iter_mut().enumerate() {
            if fall & (1 << i) != 0 {
                let _ = p.set_low();
            }
        }
        for (i, p) in self.dir.iter_mut().enumerate() {
            if write & (1 << i) != 0 {
                let _ = p.set_state(PinState::from(dir & (1 << i) != 0));
            }
        }
        for (i, p) in self.step.iter_mut().enumerate() {
            if rise & (1 << i) != 0 {
                let _ = p.set_high();
            }
        }
    }

    fn enable(&mut self) {
        self.set_enable(true);
    }

    fn disable(&mut self) {
        self.set_enable(false);
        for p in self.step.iter_mut() {
            let _ = p.set_low();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};

    #[test]
    fn falls_then_dir_then_rises_and_disable_drops_every_step() {
        // Axis 0 falls; axis 1's DIR goes high (negative); axes 1 and 2 rise.
        let out = StepOutput::new(0b001, 0b010, 0b010, 0b110);
        let step = [
            Mock::new(&[T::set(State::Low), T::set(State::Low)]),
            Mock::new(&[T::set(State::High), T::set(State::Low)]),
            Mock::new(&[T::set(State::High), T::set(State::Low)]),
        ];
        let dir = [Mock::new(&[]), Mock::new(&[T::set(State::High)]), Mock::new(&[])];
        // Active low enable: on = low, off = high.
        let en = Mock::new(&[T::set(State::Low), T::set(State::High)]);
        let mut port = PinStepPort::new(step, dir, en, false);
        port.enable();
        port.write(&out);
        port.disable();
        let (step, dir, mut en) = port.release();
        for mut p in step.into_iter().chain(dir) {
            p.done();
        }
        en.done();
    }
}
