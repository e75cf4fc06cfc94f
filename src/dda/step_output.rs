//! [`StepOutput`]: one tick's pin changes, packed in a word.

/// What the pins do this tick, in the order the board applies it: falling edges, direction
/// writes, rising edges. Bit `i` of each mask is axis `i`. Packed in one word so the tick
/// returns it in a register.
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub struct StepOutput(u32);

impl StepOutput {
    #[inline(always)]
    pub const fn new(fall: u8, dir_write: u8, dir: u8, rise: u8) -> Self {
        StepOutput(fall as u32 | (dir_write as u32) << 8 | (dir as u32) << 16 | (rise as u32) << 24)
    }

    /// Only falling edges (`fall`: a mask in the low byte, nothing above) at DIR levels `dir`
    /// (from [`StepOutput::dir_bits`]).
    #[inline(always)]
    pub(super) const fn falling(fall: u32, dir: u32) -> Self {
        StepOutput(fall | dir)
    }

    /// DIR levels in their place in the word.
    #[inline(always)]
    pub(super) const fn dir_bits(dir: u8) -> u32 {
        (dir as u32) << 16
    }

    /// Adds rising edges (`rise`: a mask in the low byte, nothing above) to an output that has
    /// none.
    #[inline(always)]
    pub(super) const fn with_rise(self, rise: u32) -> Self {
        StepOutput(self.0 | rise << 24)
    }

    /// STEP pins to bring low.
    #[inline(always)]
    pub const fn fall(self) -> u8 {
        self.0 as u8
    }

    /// DIR pins to write this tick (their new levels are in [`StepOutput::dir`]).
    #[inline(always)]
    pub const fn dir_write(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// DIR levels after this tick; a set bit means the negative direction.
    #[inline(always)]
    pub const fn dir(self) -> u8 {
        (self.0 >> 16) as u8
    }

    /// STEP pins to bring high (one step each).
    #[inline(always)]
    pub const fn rise(self) -> u8 {
        (self.0 >> 24) as u8
    }
}

impl core::fmt::Debug for StepOutput {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("StepOutput")
            .field("fall", &self.fall())
            .field("dir_write", &self.dir_write())
            .field("dir", &self.dir())
            .field("rise", &self.rise())
            .finish()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for StepOutput {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "fall={=u8:b} dir_write={=u8:b} dir={=u8:b} rise={=u8:b}",
            self.fall(),
            self.dir_write(),
            self.dir(),
            self.rise()
        )
    }
}
