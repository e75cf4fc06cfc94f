//! The constant-force control law: force -> DDA feed override, at a fixed rate (2 kHz in the
//! scenario).
//!
//! ef = (Fnom - F)/Fnom with 1/Fnom precomputed. The PI acts on e = s ef in override units:
//! with gain normalisation s = u_cut Fnom / F, where u_cut is the feed that actually cut the
//! measured chip (the axis's own steps over the last tooth period, as an override); s ef is then
//! u_cut (Fnom/F - 1), the change of feed that would bring F to Fnom if the force is proportional
//! to the feed per tooth (the thesis's own v_new = v Fnom / F, L2124). Without normalisation s is
//! a fixed scale. Gains are asymmetric (faster when F > Fnom), the integrator is clamped so the
//! output stays inside the feed clamps (anti-windup), and every change of mode re-bases the
//! integrator on the last output (bumpless).
//!
//! Contact (air -> cut) strategies: Algorithm A (immediate slow feed, hold, then PI) and
//! Algorithm B (stop, reduced gain, then full). The thesis's B cut the NC position-loop gain; here
//! the A/C gain is reduced, the part this board controls. Faults (chain fault, spindle stopped,
//! force above trip) latch a feed hold; the DDA decelerates at the segment's acceleration
//! (12.7 mm/s at 500 mm/s^2: 161 um in 25.4 ms) and the position stays exact.

use crate::protocol::errors::FaultCode;
use crate::segment::Rate;

use crate::fixed_math::ratio_u64;

/// Positions kept for the feed-per-tooth measure: tooth periods up to 255 updates.
const POS_RING: usize = 256;
const ONE_Q30: i64 = 1 << 30;
const ONE_Q16: i64 = 1 << 16;

/// What to do when the tool meets the work (force crosses the contact threshold from air).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactStrategy {
    /// Straight to the PI (bumpless from the air feed).
    Direct,
    /// Algorithm A: feed `slow` for `hold_ms`, then the PI.
    SlowHold { slow: Rate, hold_ms: u32 },
    /// Algorithm B: feed 0 for `stop_ms`, then the PI at `reduced_gain_q16` of its gains for
    /// `reduced_ms`, then full gains.
    StopReduced { stop_ms: u32, reduced_ms: u32, reduced_gain_q16: u32 },
}

/// Control-law setup, in user units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlParams {
    /// Nominal force, contact threshold and trip level, mN (contact < nominal < trip).
    pub fnom_mn: u32,
    pub contact_mn: u32,
    pub trip_mn: u32,
    /// Consecutive updates below the contact threshold that mean the tool left the cut.
    pub air_after_ms: u32,
    /// Standstill at start while the chain learns the zero (the tool must be in air); the
    /// contact threshold means nothing before that.
    pub tare_ms: u32,
    pub control_hz: u32,
    /// Axis steps per second at override 1.0 (the segment's planned feed).
    pub steps_per_s_at_one: u32,
    /// Proportional gains (override per unit of e, Q16) when F > Fnom (dec) and F < Fnom (inc).
    pub kp_dec_q16: u32,
    pub kp_inc_q16: u32,
    /// Integral gains, 1/s, Q16.
    pub ki_dec_per_s_q16: u32,
    pub ki_inc_per_s_q16: u32,
    /// Scale the error by the measured cutting stiffness (see module docs).
    pub normalise: bool,
    /// s without normalisation, and its floor with it (override per unit ef, Q16).
    pub fixed_scale_q16: u32,
    /// Feed clamps while cutting, and the feed in air.
    pub feed_min: Rate,
    pub feed_max: Rate,
    pub feed_air: Rate,
    pub contact: ContactStrategy,
    /// Below this spindle speed (milli-rev/s) the feed holds with `SpindleStopped`.
    pub min_spindle_mrev_s: u32,
}

/// Why a control setup was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControlConfigError {
    /// Need 0 < contact < nominal < trip.
    Thresholds,
    /// Control rate below 1 kHz or above 100 kHz.
    Rate,
    /// Feed clamps out of order or above 2.0.
    Feeds,
    /// Steps per second is zero or too fast for the position ring.
    Speed,
}

/// One control update's inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlInput {
    /// Force to regulate (the tooth peak), mN.
    pub force_mn: u32,
    /// The last whole tooth period, control updates.
    pub tooth_updates: u32,
    /// Axis position in steps (what reached the pins).
    pub position_steps: i64,
    pub spindle_mrev_s: u32,
    /// A fault the force chain reported this update.
    pub chain_fault: Option<FaultCode>,
}

/// Where the controller is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Feed 0 while the chain tares, updates left.
    Tare(u32),
    Air,
    /// Algorithm A's slow-feed hold, updates left.
    ContactSlow(u32),
    /// Algorithm B's stop, updates left.
    ContactStop(u32),
    /// Algorithm B's reduced-gain PI, updates left.
    Reduced(u32),
    Cutting,
    /// Latched: feed hold until reset.
    Faulted(FaultCode),
}

/// One control update's outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlOutput {
    /// Feed override for `Command::SetOverride`.
    pub feed: Rate,
    /// Issue `Command::Hold` (latched with `fault`).
    pub hold: bool,
    pub fault: Option<FaultCode>,
    /// Tell the chain the tool is in air (tare allowed, stuck check off).
    pub air: bool,
}

/// The controller's state.
#[derive(Clone, Debug)]
pub struct ForceController {
    p: ControlParams,
    inv_fnom_q48: i64,
    /// Steps per update at override 1.0, Q16.
    steps_per_update_q16: u64,
    ki_dec_q16: i64,
    ki_inc_q16: i64,
    air_updates: u32,
    slow_updates: u32,
    stop_updates: u32,
    reduced_updates: u32,
    mode: Mode,
    below: u32,
    integ_q30: i64,
    u_q30: i64,
    rebase: bool,
    pos: [i32; POS_RING],
    at: u8,
}

fn ms_to_updates(ms: u32, hz: u32) -> u32 {
    ((ms as u64 * hz as u64) / 1000).min(u32::MAX as u64) as u32
}

impl ForceController {
    /// Checks and converts the setup (this is where the divisions are).
    pub fn new(p: ControlParams) -> Result<Self, ControlConfigError> {
        let spu_q16 = Self::check(&p)?;
        let hz = p.control_hz;
        let (slow, stop, reduced) = match p.contact {
            ContactStrategy::Direct => (0, 0, 0),
            ContactStrategy::SlowHold { hold_ms, .. } => (ms_to_updates(hold_ms, hz), 0, 0),
            ContactStrategy::StopReduced { stop_ms, reduced_ms, .. } => {
                (0, ms_to_updates(stop_ms, hz), ms_to_updates(reduced_ms, hz))
            }
        };
        Ok(ForceController {
            p,
            inv_fnom_q48: ((1u64 << 48) / p.fnom_mn as u64) as i64,
            steps_per_update_q16: spu_q16,
            ki_dec_q16: (p.ki_dec_per_s_q16 / hz) as i64,
            ki_inc_q16: (p.ki_inc_per_s_q16 / hz) as i64,
            air_updates: ms_to_updates(p.air_after_ms, hz).max(1),
            slow_updates: slow,
            stop_updates: stop,
            reduced_updates: reduced,
            mode: Mode::Tare(ms_to_updates(p.tare_ms, hz).max(1)),
            below: 0,
            integ_q30: 0,
            u_q30: p.feed_air.to_bits() as i64,
            rebase: true,
            pos: [0; POS_RING],
            at: 0,
        })
    }

    /// The checks of [`Self::new`] without building the controller (it is large); returns the
    /// steps per update at override 1.0, Q16.
    pub fn check(p: &ControlParams) -> Result<u64, ControlConfigError> {
        if p.contact_mn == 0 || p.contact_mn >= p.fnom_mn || p.fnom_mn >= p.trip_mn {
            return Err(ControlConfigError::Thresholds);
        }
        if !(1000..=100_000).contains(&p.control_hz) {
            return Err(ControlConfigError::Rate);
        }
        let two = Rate::from_bits(2 << 30);
        if p.feed_min > p.feed_max || p.feed_max > two || p.feed_air > two {
            return Err(ControlConfigError::Feeds);
        }
        let spu_q16 = ((p.steps_per_s_at_one as u64) << 16) / p.control_hz as u64;
        // dx over a tooth (<= 255 updates at override 2) must stay below 2^14 steps.
        if spu_q16 == 0 || spu_q16 * 2 * 255 >= (1 << 30) {
            return Err(ControlConfigError::Speed);
        }
        Ok(spu_q16)
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The last commanded override.
    pub fn feed(&self) -> Rate {
        Rate::from_bits(self.u_q30.clamp(0, 2 * ONE_Q30) as u32)
    }

    /// One control update. Integer-only, no division, bounded time.
    pub fn update(&mut self, inp: &ControlInput) -> ControlOutput {
        self.at = self.at.wrapping_add(1);
        self.pos[self.at as usize] = inp.position_steps as i32;
        if let Mode::Faulted(code) = self.mode {
            return self.hold(code);
        }
        let fault = if let Some(code) = inp.chain_fault {
            Some(code)
        } else if inp.spindle_mrev_s < self.p.min_spindle_mrev_s {
            Some(FaultCode::SpindleStopped)
        } else if inp.force_mn > self.p.trip_mn {
            Some(FaultCode::ForceTrip)
        } else {
            None
        };
        if let Some(code) = fault {
            self.mode = Mode::Faulted(code);
            self.u_q30 = 0;
            return self.hold(code);
        }
        let f = inp.force_mn;
        let in_contact = f >= self.p.contact_mn;
        self.mode = match self.mode {
            Mode::Tare(n) if n > 1 => Mode::Tare(n - 1),
            Mode::Tare(_) => Mode::Air,
            Mode::Air if in_contact => self.contact(),
            Mode::Air => Mode::Air,
            Mode::ContactSlow(n) if n > 1 => Mode::ContactSlow(n - 1),
            Mode::ContactStop(n) if n > 1 => Mode::ContactStop(n - 1),
            Mode::ContactSlow(_) => self.enter(Mode::Cutting),
            Mode::ContactStop(_) => self.enter(Mode::Reduced(self.reduced_updates)),
            Mode::Reduced(n) if n > 1 => Mode::Reduced(n - 1),
            Mode::Reduced(_) => self.enter(Mode::Cutting),
            m => m,
        };
        // Leaving the cut: enough updates in a row below the contact threshold.
        if matches!(self.mode, Mode::Cutting | Mode::Reduced(_)) {
            self.below = if in_contact { 0 } else { self.below + 1 };
            if self.below >= self.air_updates {
                self.mode = Mode::Air;
                self.below = 0;
            }
        }
        self.u_q30 = match self.mode {
            Mode::Tare(_) => 0,
            Mode::Air => self.p.feed_air.to_bits() as i64,
            Mode::ContactSlow(_) => match self.p.contact {
                ContactStrategy::SlowHold { slow, .. } => slow.to_bits() as i64,
                _ => self.p.feed_min.to_bits() as i64,
            },
            Mode::ContactStop(_) => 0,
            Mode::Reduced(_) => {
                let g = match self.p.contact {
                    ContactStrategy::StopReduced { reduced_gain_q16, .. } => reduced_gain_q16,
                    _ => 1 << 16,
                };
                self.pi(f, inp.tooth_updates, g as i64)
            }
            Mode::Cutting => self.pi(f, inp.tooth_updates, ONE_Q16),
            Mode::Faulted(_) => 0,
        };
        ControlOutput {
            feed: self.feed(),
            hold: false,
            fault: None,
            air: matches!(self.mode, Mode::Air | Mode::Tare(_)),
        }
    }

    fn hold(&self, code: FaultCode) -> ControlOutput {
        ControlOutput { feed: Rate::ZERO, hold: true, fault: Some(code), air: false }
    }

    fn contact(&mut self) -> Mode {
        self.below = 0;
        match self.p.contact {
            ContactStrategy::Direct => self.enter(Mode::Cutting),
            ContactStrategy::SlowHold { .. } => Mode::ContactSlow(self.slow_updates.max(1)),
            ContactStrategy::StopReduced { .. } => Mode::ContactStop(self.stop_updates.max(1)),
        }
    }

    fn enter(&mut self, m: Mode) -> Mode {
        self.rebase = true;
        m
    }

    /// The feed that cut the last tooth's chip, as an override, Q30.
    fn cut_feed_q30(&self, tooth_updates: u32) -> u64 {
        let l = tooth_updates.clamp(1, POS_RING as u32 - 1);
        let then = self.at.wrapping_sub(l as u8);
        let dx = self.pos[self.at as usize].wrapping_sub(self.pos[then as usize]);
        let dx = dx.clamp(0, 1 << 14) as u64;
        ratio_u64(dx << 46, l as u64 * self.steps_per_update_q16).min(2 << 30)
    }

    /// The PI with gains scaled by `gain_q16`; returns the clamped override, Q30.
    fn pi(&mut self, force_mn: u32, tooth_updates: u32, gain_q16: i64) -> i64 {
        let fnom = self.p.fnom_mn as i64;
        // ef in [-7, 1] keeps the product inside i64.
        let diff = (fnom - force_mn as i64).max(-7 * fnom);
        let ef_q16 = (diff * self.inv_fnom_q48) >> 32;
        let floor = self.p.fixed_scale_q16 as i64;
        let s_q16 = if self.p.normalise {
            let u_cut = self.cut_feed_q30(tooth_updates);
            let q_q16 = ratio_u64((self.p.fnom_mn as u64) << 16, force_mn as u64).min(64 << 16);
            (((u_cut * q_q16) >> 30) as i64).max(floor)
        } else {
            floor
        };
        let e_q16 = (ef_q16 * s_q16) >> 16;
        let (kp, ki) = if ef_q16 < 0 {
            (self.p.kp_dec_q16 as i64, self.ki_dec_q16)
        } else {
            (self.p.kp_inc_q16 as i64, self.ki_inc_q16)
        };
        let kp = (kp * gain_q16) >> 16;
        let ki = (ki * gain_q16) >> 16;
        // Q16 * Q16 = Q32 -> Q30.
        let p_q30 = (kp * e_q16) >> 2;
        if self.rebase {
            self.integ_q30 = self.u_q30 - p_q30;
            self.rebase = false;
        }
        self.integ_q30 += (ki * e_q16) >> 2;
        let (lo, hi) = (self.p.feed_min.to_bits() as i64, self.p.feed_max.to_bits() as i64);
        // Anti-windup: the integrator never carries the output past a clamp. `max` then `min`
        // rather than `clamp`, which asserts its bounds' order: no panic branch at interrupt
        // rate (the params check keeps feed_min <= feed_max).
        self.integ_q30 = self.integ_q30.max(lo - p_q30).min(hi - p_q30);
        (self.integ_q30 + p_q30).max(lo).min(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(contact: ContactStrategy) -> ControlParams {
        // The Case A setup, with a shorter tare so the unit tests reach the cut sooner.
        ControlParams {
            tare_ms: 10,
            contact,
            ..crate::milling::scenario::control_params(18_000_000)
        }
    }

    /// A plant at control rate: the feed moves the axis at once (no ramp), force is
    /// `mn_per_step` times the steps of the last 60 updates (one tooth), zero before `wall`.
    struct Sim {
        ctl: ForceController,
        x_q16: i64,
        hist: [i64; 64],
        k: usize,
        wall: i64,
        mn_per_step: i64,
    }

    impl Sim {
        fn new(contact: ContactStrategy, mn_per_step: i64) -> Self {
            let ctl = ForceController::new(params(contact)).unwrap();
            Sim { ctl, x_q16: 0, hist: [0; 64], k: 0, wall: 300, mn_per_step }
        }

        fn step(&mut self) -> ControlOutput {
            let x = self.x_q16 >> 16;
            let pen = (x - self.wall).max(0);
            let then = self.hist[(self.k + 4) % 64];
            self.hist[self.k % 64] = pen;
            self.k += 1;
            let f = ((pen - then).max(0) * self.mn_per_step) as u32;
            let o = self.ctl.update(&ControlInput {
                force_mn: f,
                tooth_updates: 60,
                position_steps: x,
                spindle_mrev_s: 8333,
                chain_fault: None,
            });
            // 12 700 steps/s at 2 kHz = 6.35 steps per update at 1.0.
            self.x_q16 += (o.feed.to_bits() as i64 * 416_154) >> 30;
            o
        }
    }

    #[test]
    fn algorithm_a_slow_feed_hold_then_bumpless_pi() {
        let slow = Rate::lit("0.01");
        let mut s = Sim::new(ContactStrategy::SlowHold { slow, hold_ms: 100 }, 41_000);
        let mut contact_at = None;
        let mut prev = Rate::ZERO;
        for k in 0..3000 {
            let o = s.step();
            if contact_at.is_none() && matches!(s.ctl.mode(), Mode::ContactSlow(_)) {
                contact_at = Some(k);
            }
            if let Some(c) = contact_at {
                if k < c + 200 {
                    assert_eq!(o.feed, slow, "update {k}");
                } else if k == c + 200 {
                    // Bumpless: the PI starts from the slow feed (its first step is one P move).
                    assert!(o.feed.to_bits() - prev.to_bits() < Rate::lit("0.3").to_bits());
                }
            }
            prev = o.feed;
        }
        assert!(contact_at.is_some());
        // 41 N per step, Fnom 4100 N: 100 steps per tooth = 1.667 steps/update = 0.2625.
        let u = s.ctl.feed().to_num::<f64>();
        assert!((u - 0.2625).abs() < 0.01, "{u}");
    }

    #[test]
    fn algorithm_b_stops_then_reduced_then_full() {
        let c =
            ContactStrategy::StopReduced { stop_ms: 40, reduced_ms: 100, reduced_gain_q16: 21_845 };
        let mut s = Sim::new(c, 41_000);
        let mut modes = std::vec::Vec::new();
        for _ in 0..3000 {
            let o = s.step();
            if let Mode::ContactStop(_) = s.ctl.mode() {
                assert_eq!(o.feed, Rate::ZERO);
            }
            let m = core::mem::discriminant(&s.ctl.mode());
            if modes.last() != Some(&m) {
                modes.push(m);
            }
        }
        let want =
            [Mode::Tare(0), Mode::Air, Mode::ContactStop(0), Mode::Reduced(0), Mode::Cutting]
                .map(|m| core::mem::discriminant(&m));
        assert_eq!(modes, want);
        let u = s.ctl.feed().to_num::<f64>();
        assert!((u - 0.2625).abs() < 0.01, "{u}");
    }

    /// Anti-windup: after a long stretch clamped at the top feed with force far below Fnom, a
    /// force above Fnom cuts the feed at the next update.
    #[test]
    fn no_windup_at_the_clamp() {
        let mut s = Sim::new(ContactStrategy::Direct, 2_000);
        for _ in 0..2000 {
            s.step();
        }
        assert_eq!(s.ctl.feed(), Rate::ONE, "clamped at the top");
        // 381 steps per tooth at 15 N: 5.7 kN, above Fnom and below the trip level.
        s.mn_per_step = 15_000;
        let mut k = 0;
        loop {
            let o = s.step();
            assert_eq!(o.fault, None);
            if o.feed != Rate::ONE {
                break;
            }
            k += 1;
        }
        assert!(k <= 1, "left the clamp after {k} updates");
    }

    #[test]
    fn faults_latch_a_hold() {
        let mut s = Sim::new(ContactStrategy::Direct, 41_000);
        for _ in 0..500 {
            s.step();
        }
        let o = s.ctl.update(&ControlInput {
            force_mn: 18_000_001,
            tooth_updates: 60,
            position_steps: 0,
            spindle_mrev_s: 8333,
            chain_fault: None,
        });
        assert_eq!((o.hold, o.fault), (true, Some(FaultCode::ForceTrip)));
        let o = s.step();
        assert_eq!((o.hold, o.fault, o.feed), (true, Some(FaultCode::ForceTrip), Rate::ZERO));
        let mut s = Sim::new(ContactStrategy::Direct, 41_000);
        let o = s.ctl.update(&ControlInput {
            force_mn: 0,
            tooth_updates: 60,
            position_steps: 0,
            spindle_mrev_s: 100,
            chain_fault: None,
        });
        assert_eq!(o.fault, Some(FaultCode::SpindleStopped));
    }

    #[test]
    fn thresholds_must_be_ordered() {
        let mut p = params(ContactStrategy::Direct);
        p.trip_mn = p.fnom_mn;
        assert_eq!(ForceController::new(p).unwrap_err(), ControlConfigError::Thresholds);
        let mut p = params(ContactStrategy::Direct);
        p.control_hz = 500;
        assert_eq!(ForceController::new(p).unwrap_err(), ControlConfigError::Rate);
    }
}
