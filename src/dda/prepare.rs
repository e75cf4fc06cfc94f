//! [`Preparer`]: planned segments into [`Prepared`] ones for the tick path (every division the
//! DDA needs happens here, at the feeding task's priority).

use super::*;

/// A segment converted for the tick path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prepared {
    pub(super) steps: [i32; MAX_AXES],
    /// Steps per axis (0: the axis does not move).
    pub(super) d: [u32; MAX_AXES],
    /// The six-lane kernel is needed (an axis above 3 moves).
    pub(super) wide: bool,
    /// floor(2^32 / (2 * dr)): lets the tick count cruise ticks without dividing.
    pub(super) inv_two_dr: u32,
    /// DIR levels of the moving axes.
    pub(super) dir: u8,
    pub(super) active: u8,
    pub(super) t: u32,
    pub(super) h: u32,
    pub(super) cap: u32,
    pub(super) floor: u32,
    pub(super) dr: u32,
    pub(super) exit_sq: u64,
    /// Scale from the previous segment's rate units to this one's at the junction.
    pub(super) carry: u32,
    pub(super) exit_rate: u32,
    pub(super) id: u32,
}

/// Turns planned segments into [`Prepared`] ones; owned by the task that feeds the DDA.
#[derive(Clone, Debug)]
pub struct Preparer {
    cfg: MachineConfig,
    timing: TickTiming,
    prev_exit: u32,
}

impl Preparer {
    pub fn new(cfg: &MachineConfig) -> Result<Self, ConfigError> {
        Ok(Self::with_timing(cfg, cfg.validate()?))
    }

    /// A preparer for `cfg` with its timing validated elsewhere (a streamed step output's,
    /// `edge_stream::timing`).
    pub fn with_timing(cfg: &MachineConfig, timing: TickTiming) -> Self {
        Preparer { cfg: *cfg, timing, prev_exit: 0 }
    }

    /// The next segment starts from rest (after an abort or an underrun).
    pub fn reset_junction(&mut self) {
        self.prev_exit = 0;
    }

    pub fn prepare(&mut self, seg: &Segment) -> Result<Prepared, SegmentError> {
        seg.check(&self.cfg)?;
        let t = seg.duration_ticks;
        let mut p = Prepared {
            steps: seg.steps,
            d: [0; MAX_AXES],
            wide: false,
            inv_two_dr: 0,
            dir: 0,
            active: 0,
            t,
            h: t / 2,
            cap: MAX_RATE,
            floor: 0,
            dr: 0,
            exit_sq: 0,
            carry: 0,
            exit_rate: seg.exit_rate.to_bits(),
            id: seg.id,
        };
        let mut d_max = 0u32;
        for (i, &s) in seg.steps.iter().enumerate() {
            let d = s.unsigned_abs();
            if d == 0 {
                continue;
            }
            p.d[i] = d;
            p.active |= 1 << i;
            if s < 0 {
                p.dir |= 1 << i;
            }
            d_max = d_max.max(d);
            // Axis rate at virtual rate r: r * d / t * tick_hz <= max_rate_hz.
            let cap = (self.cfg.axes[i].max_rate_hz as u128 * t as u128) << RATE_FRAC_BITS;
            let cap = cap / (d as u128 * self.cfg.tick_hz as u128);
            p.cap = p.cap.min(cap.min(MAX_RATE as u128) as u32);
        }
        // Steps of one axis are at least floor(t / d_max) virtual ticks apart; at rate r they are
        // then more than that / r - 1 ticks apart, which must cover high + low time.
        let spacing_vticks = (t / d_max) as u64;
        let cap = (spacing_vticks << RATE_FRAC_BITS) / self.timing.min_spacing_ticks as u64;
        p.cap = p.cap.min(cap.min(MAX_RATE as u64) as u32);
        p.dr = seg.accel_per_tick.to_bits().clamp(1, ONE);
        p.inv_two_dr = ((1u64 << 32) / (2 * p.dr as u64)).min(u32::MAX as u64) as u32;
        p.wide = lanes::needs_wide(p.active);
        // Rate reached after one virtual tick of acceleration from rest: moves start there
        // instead of creeping, and decelerations never stall short of the segment end.
        p.floor = isqrt_u64(2 * p.dr as u64 * ONE as u64).max(p.dr).min(p.cap);
        let exit = p.exit_rate.min(p.cap) as u64;
        p.exit_sq = (exit * exit) >> RATE_FRAC_BITS;
        p.carry = if self.prev_exit == 0 {
            0
        } else {
            let c = ((seg.entry_rate.to_bits() as u64) << RATE_FRAC_BITS) / self.prev_exit as u64;
            c.min(MAX_RATE as u64) as u32
        };
        self.prev_exit = p.exit_rate;
        Ok(p)
    }
}
