//! Soft limits per axis (inclusive, in machine steps: counted steps plus the homing offset),
//! checked when a segment is admitted and again every tick.

use crate::config::MAX_AXES;
use crate::protocol::AxisScale;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SoftLimits {
    pub min_steps: [i64; MAX_AXES],
    pub max_steps: [i64; MAX_AXES],
}

impl SoftLimits {
    /// No limits at all.
    pub const NONE: SoftLimits =
        SoftLimits { min_steps: [i64::MIN; MAX_AXES], max_steps: [i64::MAX; MAX_AXES] };

    /// The limits of the link's config; axes at or above `axis_count` get none (they never move).
    pub fn from_scale(scale: &[AxisScale; MAX_AXES], axis_count: u8) -> Self {
        let mut l = SoftLimits::NONE;
        for i in 0..(axis_count as usize).min(MAX_AXES) {
            l.min_steps[i] = scale[i].soft_min;
            l.max_steps[i] = scale[i].soft_max;
        }
        l
    }

    /// The first axis outside its limits at `pos`, if any. Twelve compares: tick-safe.
    #[inline]
    pub fn outside(&self, pos: &[i64; MAX_AXES]) -> Option<u8> {
        for i in 0..MAX_AXES {
            if pos[i] < self.min_steps[i] || pos[i] > self.max_steps[i] {
                return Some(i as u8);
            }
        }
        None
    }

    /// The same limits in the frame of raw step counts whose machine position is
    /// `raw + offset`: the tick then compares a stepped axis's counter with its bound, with no
    /// add. Saturating, as machine positions are.
    pub fn minus(&self, offset: &[i64; MAX_AXES]) -> SoftLimits {
        let mut l = *self;
        for i in 0..MAX_AXES {
            l.min_steps[i] = self.min_steps[i].saturating_sub(offset[i]);
            l.max_steps[i] = self.max_steps[i].saturating_sub(offset[i]);
        }
        l
    }

    /// The end of a straight move from `from` by `steps`, or the first axis it would leave its
    /// limits on. A straight segment between two points inside the box stays inside (the box is
    /// convex), so checking its end is enough.
    pub fn check_move(
        &self,
        from: &[i64; MAX_AXES],
        steps: &[i32; MAX_AXES],
    ) -> Result<[i64; MAX_AXES], u8> {
        let mut end = *from;
        for i in 0..MAX_AXES {
            end[i] = from[i].saturating_add(steps[i] as i64);
        }
        match self.outside(&end) {
            Some(axis) => Err(axis),
            None => Ok(end),
        }
    }
}
