//! The one place the feed override is decided. Two sources ask for a factor: the operator
//! (`SetOverride` from the host, a sender's override keys, the demo job) and the running
//! capability's controller (the constant-force loop, the wire manipulator's retrace). The DDA
//! runs at their product, clamped to 0..=2.0; a hold is not a factor: it stops the path
//! whatever the factors are, and a resume comes back to the same product. Neither source can
//! undo the other: a force loop's update does not erase the operator's 50 %, and the end of a
//! wire retrace returns the capability factor to 1.0, not the operator's.

use crate::segment::Rate;

const ONE: u32 = 1 << Rate::FRAC_NBITS;
/// Largest combined override, 2.0 (the DDA's fastest virtual clock).
pub const MAX_OVERRIDE_BITS: u32 = 2 * ONE;

/// Who asks for a feed factor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OverrideSource {
    Operator,
    Capability,
}

/// The two factors and their product (`Rate` bits, 2^30 = 1.0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FeedArbiter {
    operator: u32,
    capability: u32,
    combined: u32,
}

impl Default for FeedArbiter {
    fn default() -> Self {
        Self::new()
    }
}

impl FeedArbiter {
    /// Both factors 1.0.
    pub const fn new() -> Self {
        FeedArbiter { operator: ONE, capability: ONE, combined: ONE }
    }

    /// Sets `source`'s factor (each clamped to 2.0) and returns the new product, clamped to
    /// 2.0. A multiply and a shift: no division.
    pub fn set(&mut self, source: OverrideSource, rate: Rate) -> u32 {
        let bits = rate.to_bits().min(MAX_OVERRIDE_BITS);
        match source {
            OverrideSource::Operator => self.operator = bits,
            OverrideSource::Capability => self.capability = bits,
        }
        let product = (self.operator as u64 * self.capability as u64) >> Rate::FRAC_NBITS;
        self.combined = product.min(MAX_OVERRIDE_BITS as u64) as u32;
        self.combined
    }

    /// The product the DDA runs at.
    pub const fn combined(&self) -> u32 {
        self.combined
    }

    /// `source`'s own factor.
    pub fn factor(&self, source: OverrideSource) -> Rate {
        Rate::from_bits(match source {
            OverrideSource::Operator => self.operator,
            OverrideSource::Capability => self.capability,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x: f64) -> Rate {
        Rate::from_num(x)
    }

    #[test]
    fn the_product_of_both_clamped_and_neither_erases_the_other() {
        let mut a = FeedArbiter::new();
        assert_eq!(a.combined(), ONE);
        a.set(OverrideSource::Operator, r(0.5));
        // The force loop asks for 1.5: the DDA runs at 0.75, the operator's 0.5 still holds.
        assert_eq!(a.set(OverrideSource::Capability, r(1.5)), r(0.75).to_bits());
        assert_eq!(a.factor(OverrideSource::Operator), r(0.5));
        // The capability returns to 1.0 (end of a retrace): back to the operator's 0.5.
        assert_eq!(a.set(OverrideSource::Capability, Rate::ONE), r(0.5).to_bits());
        // 2.0 x 2.0 is clamped to 2.0; a factor above 2.0 is clamped first.
        a.set(OverrideSource::Operator, r(2.0));
        assert_eq!(a.set(OverrideSource::Capability, r(3.0)), MAX_OVERRIDE_BITS);
        assert_eq!(a.factor(OverrideSource::Capability), r(2.0));
        // Zero from either stops the feed.
        assert_eq!(a.set(OverrideSource::Capability, r(0.0)), 0);
    }

    #[test]
    fn a_factor_of_one_changes_nothing_bit_for_bit() {
        let mut a = FeedArbiter::new();
        for bits in [0, 1, 12_345_678, ONE - 1, ONE, ONE + 7, MAX_OVERRIDE_BITS] {
            assert_eq!(a.set(OverrideSource::Capability, Rate::from_bits(bits)), bits);
            a.set(OverrideSource::Capability, Rate::ONE);
            assert_eq!(a.set(OverrideSource::Operator, Rate::from_bits(bits)), bits);
            a.set(OverrideSource::Operator, Rate::ONE);
        }
    }
}
