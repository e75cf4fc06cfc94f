//! The firmware's fixed-point Z command (`motion::turning`) against the f64 surface the table
//! models: the accurate tool-centre command (meridian envelope) of the Douglass paraboloid.

use motion::turning::douglass_table::DOUGLASS_POWER;
use motion::turning::{CoefficientTable, Interp};
use motionctl::turning::accurate::{self, z_command_in, AccurateOptions, ToolNoseModel};
use motionctl::turning::firmware_table::{
    douglass_accurate, harmonic_table, power_table, IN_Q24, IN_Q32,
};
use motionctl::turning::OffAxisParaboloid;
use std::f64::consts::PI;

struct Stats {
    rms_uin: f64,
    max_uin: f64,
}

/// Error of `eval` over X = 0..8 in (`nx` + 1 points, including points between the grid nodes)
/// and `nphi` angles per X, against the f64 command.
fn error_over<const R: usize, const W: usize>(
    t: &CoefficientTable<R, W>,
    interp: Interp,
    nx: usize,
    nphi: usize,
) -> Stats {
    let par = OffAxisParaboloid::douglass_problem();
    let (mut sum2, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for i in 0..=nx {
        let x_q24 = (8.0 * i as f64 / nx as f64 * IN_Q24).round() as i32;
        let x = x_q24 as f64 / IN_Q24;
        for j in 0..nphi {
            // An angle that is not a multiple of any table's step: j + 1/3 of a step.
            let turn = (j as f64 + 1.0 / 3.0) / nphi as f64;
            let a = (turn * 4_294_967_296.0) as u32;
            let phi = a as f64 / 4_294_967_296.0 * 2.0 * PI;
            let z = t.eval(x_q24, a, interp).z_in_q32 as f64 / IN_Q32;
            let truth = z_command_in(&par, x, phi, ToolNoseModel::MeridianEnvelope).unwrap();
            let e = (z - truth).abs() * 1e6;
            sum2 += e * e;
            max = max.max(e);
            n += 1;
        }
    }
    Stats { rms_uin: (sum2 / n as f64).sqrt(), max_uin: max }
}

#[test]
fn fixed_point_command_within_0_1_uin_rms() {
    // 1601 X values (5 per 0.1 in cell, off the nodes too) x 180 angles.
    let s = error_over(&DOUGLASS_POWER, Interp::Cubic, 1600, 180);
    eprintln!("power form, cubic, 0.1 in grid: RMS {:.4} uin, max {:.4} uin", s.rms_uin, s.max_uin);
    assert!(s.rms_uin <= 0.1, "{}", s.rms_uin);
    let l = error_over(&DOUGLASS_POWER, Interp::Linear, 1600, 90);
    eprintln!(
        "power form, linear, 0.1 in grid: RMS {:.4} uin, max {:.4} uin",
        l.rms_uin, l.max_uin
    );
    // Digest D: linear on 0.1 in is < 0.5 uin mid-interval (thesis); ours must not be worse.
    assert!(l.max_uin < 0.6 && l.rms_uin > s.rms_uin, "{} {}", l.max_uin, l.rms_uin);
}

#[test]
fn harmonic_form_within_0_1_uin_rms() {
    let acc = douglass_accurate().unwrap();
    let h4 = harmonic_table::<81, 9>(0.0, 0.1, &acc.harmonics).unwrap();
    let s = error_over(&h4, Interp::Cubic, 800, 90);
    eprintln!("harmonic form K = 4, cubic: RMS {:.4} uin, max {:.4} uin", s.rms_uin, s.max_uin);
    assert!(s.rms_uin <= 0.1, "{}", s.rms_uin);
    // The power form keeps only C0, S1, C2, S3; K = 4 adds C4 (5e-8 in at X = 8): no worse.
    let p = error_over(&power_table::<81>(&acc.table).unwrap(), Interp::Cubic, 800, 90);
    assert!(s.max_uin <= p.max_uin + 1e-3, "{} {}", s.max_uin, p.max_uin);
}

fn pp_mil<const R: usize>(t: &CoefficientTable<R, 4>, x_in: f64) -> f64 {
    let x_q24 = (x_in * IN_Q24) as i32;
    let (mut lo, mut hi) = (i32::MAX, i32::MIN);
    for j in 0..3600u64 {
        let z = t.eval(x_q24, ((j << 32) / 3600) as u32, Interp::Cubic).z_in_q32;
        lo = lo.min(z);
        hi = hi.max(z);
    }
    (hi - lo) as f64 / IN_Q32 * 1e3
}

#[test]
fn z_peak_to_peak_at_x_8_is_7_79_mil() {
    // Digest E: "slightly less than 0.008 in", 7.79 mil peak to peak at X = 8 in. That is the
    // surface itself (sharp tool). The checked-in table commands the tool centre of a 0.125 in
    // nose, which touches the surface further out (X1 = 8.006 in), so its peak-to-peak is larger;
    // it is checked against the f64 envelope instead.
    let par = OffAxisParaboloid::douglass_problem().with_tool_nose_radius(0.0).unwrap();
    let opts = AccurateOptions { tool_nose: ToolNoseModel::None, ..AccurateOptions::default() };
    let sharp = accurate::table(&par, 0.1, &opts).unwrap();
    let sharp = power_table::<81>(&sharp.table).unwrap();
    let pp_sharp = pp_mil(&sharp, 8.0);
    eprintln!(
        "Z peak-to-peak at X = 8 in, fixed point, sharp tool: {pp_sharp:.4} mil (thesis 7.79)"
    );
    assert!((pp_sharp - 7.79).abs() < 0.005, "{pp_sharp}");
    let pp_tool = pp_mil(&DOUGLASS_POWER, 8.0);
    let envelope = OffAxisParaboloid::douglass_problem();
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for j in 0..3600 {
        let phi = j as f64 / 3600.0 * 2.0 * PI;
        let z = z_command_in(&envelope, 8.0, phi, ToolNoseModel::MeridianEnvelope).unwrap();
        lo = lo.min(z);
        hi = hi.max(z);
    }
    let pp_f64 = (hi - lo) * 1e3;
    eprintln!("tool-centre command at X = 8 in: fixed point {pp_tool:.5} mil, f64 {pp_f64:.5} mil");
    assert!((pp_tool - pp_f64).abs() < 1e-4, "{pp_tool} {pp_f64}");
}
