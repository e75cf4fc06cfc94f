//! The last check between a Z-slide DAC code and the DAC's data register: a 12-bit
//! right-aligned register takes 0..=4095; anything else is a `ZSlideLimit` fault and the
//! output goes to the safe mid-scale instead (never a masked or clipped code, which would move
//! the slide somewhere nobody commanded).

use crate::machine::Z_DAC_MID_SCALE;
use crate::protocol::errors::FaultCode;

/// Largest code of the 12-bit DAC.
pub const DAC_MAX_CODE: u16 = 4095;

/// What to write into the 12-bit right-aligned data register for `code`, and the fault if
/// `code` was out of range (then the value is [`Z_DAC_MID_SCALE`]).
#[inline]
pub const fn dac_register_value(code: u16) -> (u16, Option<FaultCode>) {
    if code <= DAC_MAX_CODE {
        (code, None)
    } else {
        (Z_DAC_MID_SCALE, Some(FaultCode::ZSlideLimit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::turning::DacScale;
    use proptest::prelude::*;

    #[test]
    fn codes_from_the_scale_pass_unchanged() {
        // The scale's own extremes (0.010 in full scale around mid) are in range.
        let d = DacScale::new(204_800, Z_DAC_MID_SCALE).unwrap();
        for z_in in [-0.009_99, -0.005, 0.0, 0.005, 0.009_99] {
            let code = d.code((z_in * 4_294_967_296.0) as i32).unwrap();
            assert_eq!(dac_register_value(code), (code, None));
        }
        assert_eq!(dac_register_value(4095), (4095, None));
        assert_eq!(dac_register_value(4096), (Z_DAC_MID_SCALE, Some(FaultCode::ZSlideLimit)));
    }

    proptest! {
        #[test]
        fn register_value_is_always_12_bit(code in any::<u16>()) {
            let (v, fault) = dac_register_value(code);
            prop_assert!(v <= DAC_MAX_CODE);
            prop_assert_eq!(fault.is_none(), code <= DAC_MAX_CODE);
            prop_assert_eq!(v == code, code <= DAC_MAX_CODE);
        }
    }
}
