//! Copy-mode encoders (template digitizer): the arm angle on TIM5 (32-bit) and the
//! carriage radius on TIM3 (16-bit, extended to i32 by `board_drivers::quadrature::TimerEncoder`),
//! both in encoder mode 3 (every edge of both quadrature channels counts). Pins: `pins.rs`
//! (`COPY_ENCODER_PINS`).
//! Registers only here; the carriage's 16 -> 32 bit extension is
//! `board_drivers::quadrature::TimerEncoder`, host-tested there.

use board_drivers::quadrature::{Counter16, Quadrature, TimerEncoder};

use super::pins;
use crate::pac;

/// TIM3's counter, for the quadrature driver.
pub struct Tim3Count(pac::TIM3);

impl Counter16 for Tim3Count {
    #[inline]
    fn count(&mut self) -> u16 {
        self.0.cnt().read().bits() as u16
    }
}

/// TIM5 and TIM3 in encoder mode; the carriage counter extended by the quadrature driver.
pub struct CopyEncoders {
    arm: pac::TIM5,
    carriage: TimerEncoder<Tim3Count>,
    /// The arm count when the driver started (TIM5 counts from there, as an i32).
    arm_base: u32,
}

/// Encoder mode 3 on CH1/CH2 with an 8-sample input filter (RM0090 17.3.12 / 18.3.16): the
/// same register values for both general-purpose timers.
macro_rules! encoder_mode {
    ($tim:expr, $arr:expr) => {{
        let tim = $tim;
        // CC1S/CC2S = 01 (IC1 on TI1, IC2 on TI2), IC1F/IC2F = 0011 (8 samples at f_CK_INT).
        // SAFETY: 2-bit CCxS and 4-bit ICxF fields written with values from RM0090.
        tim.ccmr1_input()
            .write(|w| unsafe { w.bits(0b01 | 0b0011 << 4 | 0b01 << 8 | 0b0011 << 12) });
        // CC1P/CC2P = 0: non-inverted quadrature.
        // SAFETY: CCER = 0 is its reset value.
        tim.ccer().write(|w| unsafe { w.bits(0) });
        // SMS = 011: encoder mode 3.
        // SAFETY: SMS is a 3-bit field; 0b011 is encoder mode 3.
        tim.smcr().write(|w| unsafe { w.bits(0b011) });
        // SAFETY: ARR takes any value; the full range makes the counter wrap naturally.
        tim.arr().write(|w| unsafe { w.bits($arr) });
        // SAFETY: CEN = bit 0.
        tim.cr1().write(|w| unsafe { w.bits(1) });
    }};
}

impl CopyEncoders {
    /// Clocks both timers, configures their pins (if routed) and starts counting.
    pub fn new(
        arm: pac::TIM5,
        carriage: pac::TIM3,
        rcc: &pac::RCC,
        a: &pac::GPIOA,
        b: &pac::GPIOB,
    ) -> Self {
        rcc.apb1enr().modify(|_, w| w.tim5en().set_bit().tim3en().set_bit());
        // Read back so the enables have taken effect before the first register access.
        let _ = rcc.apb1enr().read();
        pins::init_copy_encoders(a, b);
        encoder_mode!(&arm, 0xffff_ffff);
        encoder_mode!(&carriage, 0xffff);
        let arm_base = arm.cnt().read().bits();
        CopyEncoders { arm, carriage: TimerEncoder::new(Tim3Count(carriage)), arm_base }
    }
}

impl board_contract::CopyEncoders for CopyEncoders {
    /// The encoders feed copy jobs (`CAP_COPY_JOB`) only when their pins are routed.
    const ROUTED: bool = pins::COPY_ENCODERS_ROUTED;

    /// No simulated encoders on real hardware.
    fn set_sim_target(_counts: [i32; 2]) -> bool {
        false
    }

    /// One tick: (arm, carriage) counts. Two register reads, a subtract and a sign extension.
    #[inline]
    fn read(&mut self) -> [i32; 2] {
        // TIM5 is 32-bit: the wrapping difference is the signed count (a copy job reads it
        // as a wrapping counter).
        let arm = self.arm.cnt().read().bits().wrapping_sub(self.arm_base) as i32;
        [arm, self.carriage.update()]
    }
}
