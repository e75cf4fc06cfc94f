//! Thesis oracles for the polar digitizer (Fahim 1983), each computed by the code.

use motionctl::polar::contour::{Limacon, PolarEq};
use motionctl::polar::drive::{self, TABLE_5_1};
use motionctl::polar::{listing, Resolution, CM_PER_IN};

#[test]
fn listing_start_point_for_the_limacon() {
    // RI = 5.0 in, EPS = 70 deg, RR = 0.125 in, limacon 3 + 2 cos, theta1 = 0.
    let lim = Limacon { b: 3.0, a: 2.0 };
    let (th, al) = listing::start_point(&lim, 5.0, 70f64.to_radians(), 0.125, 0.0).unwrap();
    println!(
        "start point: theta = {:.8} deg (thesis 34.50471682), r = {al:.9} in (thesis 8.294224337)",
        th.to_degrees()
    );
    assert!((th.to_degrees() - 34.504_716_82).abs() < 1e-6);
    assert!((al - 8.294_224_337).abs() < 1e-8);
}

#[test]
fn resolutions() {
    let r = Resolution::THESIS;
    assert!((r.dtheta_rad - 3.927e-4).abs() < 1e-7, "{}", r.dtheta_rad);
    assert!((r.dtheta_rad.to_degrees() - 0.0225).abs() < 1e-12);
    assert!((r.k_in() - 2.546).abs() < 5e-4, "K = {}", r.k_in());
    // Angular resolution dA = r dTheta: 0.00299 cm at 7.62 cm, 0.0130 cm at 33.02 cm.
    assert!((r.deviation_in(3.0) * CM_PER_IN - 0.00299).abs() < 1e-5);
    assert!((r.deviation_in(13.0) * CM_PER_IN - 0.0130).abs() < 1e-4);
    // Below K the deviation is radial-limited.
    assert_eq!(r.deviation_in(2.0), r.dr_in);
}

#[test]
fn listing_integrand_bug_gives_1_20x_speed_error() {
    let lim = Limacon { b: 3.0, a: 2.0 };
    let e = listing::listing_speed_error(&lim, std::f64::consts::FRAC_PI_2);
    println!("r1-only integrand speed error at theta1 = pi/2: {e:.4}");
    assert!((e - 1.20).abs() < 0.005);
    // Our integrand: |P'| of the polar contour equals sqrt(r1^2 + r1'^2).
    use motionctl::polar::contour::{Contour, Polar};
    let c = Polar::closed(lim);
    let [_, d1, _] = c.jet(1.0);
    let (r, r1, _) = lim.r(1.0);
    assert!((d1[0].hypot(d1[1]) - (r * r + r1 * r1).sqrt()).abs() < 1e-12);
}

#[test]
fn template_digitizer_speed_error() {
    // Roller diameter = template thickness = 0.3175 cm, rho = 5 cm.
    let (h, rr, rho) = (0.3175, 0.3175 / 2.0, 5.0);
    let same = drive::template_speed_ratio(rho, rr, h, true);
    let opp = drive::template_speed_ratio(rho, rr, h, false);
    println!("template speed ratio: {same:.4} (0.938), {opp:.4} (1.066)");
    assert!((same - 0.938).abs() < 5e-4);
    assert!((opp - 1.066).abs() < 5e-4);
    // The printed eq 3.3 lacks a factor 2: it would give about half.
    assert!((drive::template_speed_ratio_as_printed(rho, rr, h, true) - 0.469).abs() < 1e-3);
}

#[test]
fn pull_out_torques_of_table_5_1() {
    for (hs, thesis) in [(0.0, 0.330), (1000.0, 0.316), (5000.0, 0.254), (10000.0, 0.183)] {
        let t = TABLE_5_1.pull_out_nm(hs);
        println!("pull-out at {hs} half-steps/s: {t:.4} N m (thesis {thesis})");
        assert!((t - thesis).abs() < 6e-4, "{hs}: {t}");
    }
    // Pure radial at the max Vt 1.746 cm/s = 5500 half-steps/s -> 0.246 N m.
    let hs = 1.746 / CM_PER_IN * drive::R_HALF_STEPS_PER_IN;
    assert!((hs - 5500.0).abs() < 1.0);
    assert!((TABLE_5_1.pull_out_nm(hs) - 0.246).abs() < 1e-3);
}

#[test]
fn curvature_speed_limit_grows_with_radius_and_respects_torque() {
    let a = drive::curvature_speed_limit_in_per_s(0.5);
    let b = drive::curvature_speed_limit_in_per_s(2.0);
    assert!(a < b);
    // At the limit, the centripetal radial torque K2 Mc v^2 / rho equals the pull-out torque.
    let v_m = a * CM_PER_IN / 100.0;
    let rho_m = 0.5 * CM_PER_IN / 100.0;
    let need = drive::K2_M * drive::MC_KG * v_m * v_m / rho_m;
    let hs = a * drive::R_HALF_STEPS_PER_IN;
    assert!((need - TABLE_5_1.pull_out_nm(hs)).abs() < 1e-6, "{need}");
}
