//! Host tests of the spindle sources against the simulated spindle.

use super::*;
use crate::protocol::errors::FaultCode;
use proptest::prelude::*;

const HZ: u32 = 50_000;
const CPR: u32 = 40_000;

fn enc_cfg() -> EncoderConfig {
    EncoderConfig {
        counts_per_rev: CPR,
        index_tolerance_counts: 0,
        window_log2: 8,
        stop_counts_per_window: 8,
    }
}

fn res_cfg() -> ResolverConfig {
    ResolverConfig {
        tick_hz: HZ,
        amplitude_lsb: 1800,
        amplitude_min_lsb: 1200,
        amplitude_max_lsb: 2300,
        loss_ticks: 4,
        bandwidth_hz: 100,
        stop_speed_turn_q32_per_tick: 1000,
    }
}

/// Angle difference in turns (signed, wrapped).
fn angle_err_turn(a: u32, b: u32) -> f64 {
    a.wrapping_sub(b) as i32 as f64 / 4_294_967_296.0
}

/// Runs both sources for `ticks` with a speed profile; returns worst angle error (turns) over
/// the last half for the encoder and resolver and the final speed estimates (rpm).
fn run(profile: impl Fn(u32) -> u32, ticks: u32) -> (f64, f64, f64, f64, Option<FaultCode>) {
    let mut sim = SimSpindle::new(0x1234_5678);
    let (c0, _) = sim.encoder(CPR);
    let mut enc = QuadratureEncoder::new(enc_cfg(), c0).unwrap();
    let mut res = Resolver::new(res_cfg()).unwrap();
    let mut seed = 1u32;
    let (mut we, mut wr) = (0.0f64, 0.0f64);
    for t in 0..ticks {
        sim.advance(profile(t));
        let (c, idx) = sim.encoder(CPR);
        enc.update(c, idx);
        let (s, co) = sim.resolver(1800, 2, &mut seed);
        res.update(s, co);
        if t > ticks / 2 {
            we = we.max(angle_err_turn(enc.angle_turn_q32(), sim.angle_turn_q32()).abs());
            wr = wr.max(angle_err_turn(res.angle_turn_q32(), sim.angle_turn_q32()).abs());
        }
    }
    let rpm = |s: i32| rpm_milli(s, HZ) as f64 / 1000.0;
    (
        we,
        wr,
        rpm(enc.speed_turn_q32_per_tick()),
        rpm(res.speed_turn_q32_per_tick()),
        enc.fault().or(res.fault()),
    )
}

#[test]
fn tracking_at_300_and_360_rpm() {
    for rpm in [300u64, 360] {
        let v = speed_turn_q32_per_tick(rpm * 1000, HZ) as u32;
        let (we, wr, se, sr, f) = run(|_| v, HZ);
        eprintln!(
            "{rpm} rpm: encoder angle err {:.2} counts, speed {se:.3} rpm; resolver angle err \
             {:.4} deg, speed {sr:.3} rpm",
            we * CPR as f64,
            wr * 360.0
        );
        assert_eq!(f, None);
        // Encoder: the count is the floor of the angle, so the angle is at most one count late.
        assert!(we * CPR as f64 <= 1.0 + 1e-6, "{we}");
        assert!((se - rpm as f64).abs() < 0.5, "{se}");
        // Resolver with +-2 LSB noise on 1800 (0.06 deg per sample) through a 100 Hz loop.
        assert!(wr * 360.0 < 0.05, "{wr}");
        assert!((sr - rpm as f64).abs() < 1.0, "{sr}");
    }
}

#[test]
fn speed_step_of_20_percent() {
    // 360 rpm, then a 20 % step to 432 rpm over 10 ms (a real spindle cannot jump): both sources
    // follow; the resolver's lag during the ramp is alpha / Ki and vanishes after it.
    let v0 = speed_turn_q32_per_tick(360_000, HZ) as i64;
    let v1 = speed_turn_q32_per_tick(432_000, HZ) as i64;
    let ramp = 500u32;
    let profile = |t: u32| -> u32 {
        let start = HZ / 2;
        if t < start {
            v0 as u32
        } else if t < start + ramp {
            (v0 + (v1 - v0) * (t - start) as i64 / ramp as i64) as u32
        } else {
            v1 as u32
        }
    };
    let (we, wr, se, sr, f) = run(profile, HZ + HZ / 2);
    eprintln!(
        "speed step 360 -> 432 rpm: encoder err {:.2} counts, {se:.2} rpm; resolver err {:.4} \
         deg, {sr:.2} rpm",
        we * CPR as f64,
        wr * 360.0
    );
    assert_eq!(f, None);
    assert!((se - 432.0).abs() < 0.5 && (sr - 432.0).abs() < 1.0, "{se} {sr}");
    assert!(we * CPR as f64 <= 1.0 + 1e-6);
    assert!(wr * 360.0 < 0.5, "{wr}");
}

#[test]
fn index_mismatch_and_loss_fault() {
    let v = speed_turn_q32_per_tick(360_000, HZ) as u32;
    // Mismatch: the encoder is configured for one count more than the disc has.
    let mut sim = SimSpindle::new(0);
    let cfg = EncoderConfig { counts_per_rev: CPR + 1, ..enc_cfg() };
    let mut enc = QuadratureEncoder::new(cfg, sim.encoder(CPR).0).unwrap();
    let mut first_fault_rev = None;
    for _ in 0..HZ {
        sim.advance(v);
        let (c, i) = sim.encoder(CPR);
        enc.update(c, i);
        if enc.fault().is_some() && first_fault_rev.is_none() {
            first_fault_rev = Some(sim.turns());
        }
    }
    assert_eq!(enc.fault(), Some(FaultCode::EncoderIndex));
    // The first index references; the second checks (40000 != 40001).
    assert_eq!(first_fault_rev, Some(2));
    // Loss: the index stops after 3 revs; the fault comes one revolution (plus tolerance) later.
    let mut sim = SimSpindle::new(0);
    let mut enc = QuadratureEncoder::new(enc_cfg(), sim.encoder(CPR).0).unwrap();
    let mut fault_at = None;
    for t in 0..HZ {
        sim.advance(v);
        let (c, i) = sim.encoder(CPR);
        enc.update(c, if sim.turns() <= 3 { i } else { None });
        if enc.fault().is_some() && fault_at.is_none() {
            fault_at = Some((t, sim.turns(), sim.angle_turn_q32()));
        }
    }
    let (_, turns, frac) = fault_at.unwrap();
    assert_eq!(enc.fault(), Some(FaultCode::EncoderIndex));
    // Last index at the start of turn 3; one revolution later, at the start of turn 4.
    assert_eq!(turns, 4);
    assert!(frac < 4_294_967_296u64 as u32 / 1000 + (v * 2), "{frac}");
}

#[test]
fn counter_wraps_many_times() {
    // 40000 counts/rev on a 16-bit counter: it wraps every 1.64 revolutions. 30 s at 432 rpm
    // is 216 revolutions and ~130 wraps; position and angle stay exact.
    let v = speed_turn_q32_per_tick(432_000, HZ) as u32;
    let mut sim = SimSpindle::new(0);
    let mut enc = QuadratureEncoder::new(enc_cfg(), 0).unwrap();
    for _ in 0..30 * HZ {
        sim.advance(v);
        let (c, i) = sim.encoder(CPR);
        enc.update(c, i);
    }
    let expect =
        sim.turns() as i64 * CPR as i64 + ((sim.angle_turn_q32() as u64 * CPR as u64) >> 32) as i64;
    assert_eq!(enc.position_counts(), expect);
    assert!(expect > 100 * 65_536);
    assert_eq!(enc.fault(), None);
    assert!(angle_err_turn(enc.angle_turn_q32(), sim.angle_turn_q32()).abs() * CPR as f64 <= 1.0);
}

#[test]
fn resolver_loss_and_stop() {
    let v = speed_turn_q32_per_tick(360_000, HZ) as u32;
    let mut sim = SimSpindle::new(0);
    let mut res = Resolver::new(res_cfg()).unwrap();
    let mut seed = 7;
    for _ in 0..HZ / 2 {
        sim.advance(v);
        let (s, c) = sim.resolver(1800, 3, &mut seed);
        res.update(s, c);
    }
    assert_eq!(res.fault(), None);
    assert!(!res.is_stopped());
    // A broken excitation: amplitude collapses to 10 %. Three bad samples are tolerated, the
    // fourth latches the fault.
    for k in 0..4 {
        assert_eq!(res.fault(), None, "{k}");
        sim.advance(v);
        let (s, c) = sim.resolver(180, 0, &mut seed);
        res.update(s, c);
    }
    assert_eq!(res.fault(), Some(FaultCode::ResolverLoss));
    // Stopped spindle with an encoder: no counts over the window.
    let mut enc = QuadratureEncoder::new(enc_cfg(), 5).unwrap();
    for _ in 0..200 {
        enc.update(5, None);
    }
    assert!(enc.is_stopped());
}

proptest! {
    #[test]
    fn encoder_never_panics(
        steps in proptest::collection::vec((any::<u16>(), proptest::option::of(any::<u16>())), 1..300),
        cpr in 4u32..70_000, tol in 0u32..3, w in 0u8..=8,
    ) {
        let cfg = EncoderConfig { counts_per_rev: cpr, index_tolerance_counts: tol, window_log2: w, stop_counts_per_window: 1 };
        if let Ok(mut e) = QuadratureEncoder::new(cfg, 0) {
            for (c, i) in steps {
                e.update(c, i);
                let _ = (e.angle_turn_q32(), e.speed_turn_q32_per_tick(), e.is_stopped(), e.fault());
            }
        }
    }

    #[test]
    fn resolver_never_panics(
        samples in proptest::collection::vec((any::<i16>(), any::<i16>()), 1..300),
        amp in 16u16..16384, bw in 1u32..5000,
    ) {
        let cfg = ResolverConfig { amplitude_lsb: amp, amplitude_min_lsb: amp / 2, amplitude_max_lsb: amp + amp / 2 + 1, bandwidth_hz: bw, ..res_cfg() };
        if let Ok(mut r) = Resolver::new(cfg) {
            for (s, c) in samples {
                r.update(s, c);
                let _ = (r.angle_turn_q32(), r.speed_turn_q32_per_tick(), r.is_stopped(), r.fault());
            }
        }
    }
}

#[test]
fn a_requested_speed_is_converted_as_setup_does_and_refused_past_half_a_turn_per_tick() {
    for rpm_milli in [0u32, 360_000, 6_000_000, 1_000_000_000] {
        assert_eq!(
            checked_speed_turn_q32_per_tick(rpm_milli, HZ),
            Some(speed_turn_q32_per_tick(rpm_milli as u64, HZ))
        );
    }
    // Half a turn per tick at 50 kHz is 1.5 M rpm: the first speed that no longer fits.
    let half_turn_rpm_milli = 60_000 * HZ / 2;
    assert!(checked_speed_turn_q32_per_tick(half_turn_rpm_milli - 1, HZ).is_some());
    assert_eq!(checked_speed_turn_q32_per_tick(half_turn_rpm_milli, HZ), None);
    assert_eq!(checked_speed_turn_q32_per_tick(u32::MAX, 0), None);
}
