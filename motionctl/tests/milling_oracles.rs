//! Elbestawi (1980) oracles: every thesis number here is recomputed by `motionctl::milling` and
//! compared with the printed value.

use motionctl::milling::{case_a, pass_growth, rapid_feed, root_locus};
use root_locus::{closed_loop_poles, OpenLoop, C64};

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

/// §4.5 Case A, tau = 30 ms: 3900 N at 12.7 mm/s, 15 600 N at the step, 3.333 mm/s after.
#[test]
fn case_a_statics_tau_30ms() {
    let s = case_a::statics(0.030);
    assert_eq!(s.feed_before_mm_s, case_a::RAPID_MM_S, "13.33 mm/s would exceed the rapid limit");
    // The unclamped feed the thesis quotes: f_t = 0.4 mm, v = 13.333 mm/s.
    let free = case_a::FNOM_N / (case_a::K_N_PER_MM3 * case_a::A_MM * 2.5 * 0.030);
    assert!((free - 13.333).abs() < 1e-3, "{free}");
    // Printed to 2-3 significant figures: 3904.9 -> "3900", 15 620 -> "15,600".
    assert!(rel(s.force_before_n, 3900.0) < 0.002, "{}", s.force_before_n);
    assert!(rel(s.force_at_step_n, 15_600.0) < 0.002, "{}", s.force_at_step_n);
    assert!((s.feed_after_mm_s - 3.333).abs() < 1e-3, "{}", s.feed_after_mm_s);
}

/// tau = 60 ms (N = 250 rpm): Fnom reached at 6.66 mm/s before the step, 16 400 N peak at it.
#[test]
fn case_a_statics_tau_60ms() {
    let s = case_a::statics(0.060);
    // The thesis truncates 6.667 to "6.66".
    assert!((s.feed_before_mm_s - 6.66).abs() < 0.01, "{}", s.feed_before_mm_s);
    assert!((s.force_before_n - case_a::FNOM_N).abs() < 1e-6);
    assert!(rel(s.force_at_step_n, 16_400.0) < 1e-9, "{}", s.force_at_step_n);
}

/// The stop distance the firmware's feed hold needs from the rapid traverse, at the thesis's
/// table acceleration (478 mm/s^2) and at the sim's 500 mm/s^2: steppers cannot stop at once.
#[test]
fn stop_distance_from_rapid() {
    let (d, t) = case_a::stop_distance(12.7, 478.0);
    assert!((d - 0.1687).abs() < 1e-4 && (t - 0.02657).abs() < 1e-4, "{d} {t}");
    let (d, t) = case_a::stop_distance(12.7, 500.0);
    assert!((d - 0.16129).abs() < 1e-4 && (t - 0.0254).abs() < 1e-6, "{d} {t}");
}

fn assert_pole(p: C64, re: f64, im: f64) {
    assert!((p.re - re).abs() < 2e-3 && (p.im.abs() - im).abs() < 2e-3, "{p:?} vs {re} +/- j{im}");
}

/// §5.7.1, Ks = 7030 N/mm: -7.864 +/- j2.248, zeta = 0.96.
#[test]
fn root_locus_ks_7030() {
    let p = closed_loop_poles(OpenLoop { gain: 34_305.0, zero: 25.0, pole: 30.936 });
    assert_pole(p[0], -7.864, 2.248);
    assert_pole(p[1], -7.864, 2.248);
    assert!((p[0].damping() - 0.96).abs() < 0.005);
    assert!(p.iter().all(|r| r.re < 0.0));
}

/// §5.7.1, Ks = 2285 N/mm: -3.934 +/- j4.710, zeta = 0.64.
#[test]
fn root_locus_ks_2285() {
    let p = closed_loop_poles(OpenLoop { gain: 10_816.0, zero: 25.0, pole: 9.753 });
    assert_pole(p[0], -3.934, 4.710);
    assert!((p[0].damping() - 0.64).abs() < 0.005);
}

/// §5.7.2: Kc = 3465 -> all real, dominant -1.806; Kc = 13 860 -> -6.509 +/- j7.026 (the thesis;
/// the printed coefficients give -6.510 +/- j7.025), zeta printed 0.67 (computed 0.680).
#[test]
fn root_locus_cutting_stiffness() {
    let p = closed_loop_poles(OpenLoop { gain: 34_305.0, zero: 25.0, pole: 80.434 });
    assert!(p.iter().all(|r| r.im.abs() < 1e-9), "overdamped: {p:?}");
    assert!((p[0].re + 1.806).abs() < 2e-3, "{:?}", p[0]);
    let p = closed_loop_poles(OpenLoop { gain: 34_305.0, zero: 25.0, pole: 20.108 });
    assert_pole(p[0], -6.509, 7.026);
    assert!((p[0].damping() - 0.67).abs() < 0.011, "{}", p[0].damping());
}

/// §5.7.3: lower Fnom raises the gain and lowers the damping. The thesis prints gains
/// 11 436.642 (3960 N) and 68 619.854 (660 N) but no roots: the 3960 N loop is overdamped and
/// slow, the 660 N one oscillatory.
#[test]
fn root_locus_fnom_trend() {
    let hi = closed_loop_poles(OpenLoop { gain: 11_436.642, zero: 25.0, pole: 30.936 });
    let lo = closed_loop_poles(OpenLoop { gain: 68_619.854, zero: 25.0, pole: 30.936 });
    assert!(hi[0].im.abs() < 1e-9 && hi[0].re > -2.0, "{hi:?}");
    assert!(lo[0].im.abs() > 8.0 && lo[0].damping() < 0.70, "{lo:?}");
    // The printed gains scale as 1/Fnom: 34 305 * 1320/3960 and 34 305 * 1320/660.
    assert!(rel(11_436.642, 34_305.0 * 1320.0 / 3960.0) < 2e-4);
    assert!(rel(68_619.854, 34_305.0 * 1320.0 / 660.0) < 2e-4);
}

/// Where the printed coefficients came from, and where they drift: 6398.424 B Ks / Fnom gives
/// 34 076 (printed 34 305, 0.7 % off) and Ks/K'c = 31.35 (printed pole 30.936, 1.3 % off).
#[test]
fn root_locus_printed_coefficients_vs_formula() {
    let g = root_locus::gain_from_parameters(1.0, 7030.0, 1320.0);
    assert!(rel(g, 34_305.0) < 0.01 && rel(g, 34_305.0) > 0.005, "{g}");
    let pole = 7030.0 / 224.25;
    assert!(rel(pole, 30.936) < 0.015 && rel(pole, 30.936) > 0.01, "{pole}");
    // K'c = 8970 / (4 * 10) = 224.25 N/(mm/s) for 4 teeth at 600 rpm (10 rev/s).
    assert_eq!(8970.0 / (4.0 * 10.0), 224.25);
}

#[test]
fn root_finder_recovers_known_roots() {
    // (s + 3)(s + 4)(s^2 + 2 s + 5): roots -1 +/- 2j, -3, -4.
    let p = root_locus::poly_mul(&[1.0, 7.0, 12.0], &[1.0, 2.0, 5.0]);
    let r = root_locus::roots(&p);
    assert_pole(r[0], -1.0, 2.0);
    assert_pole(r[1], -1.0, 2.0);
    assert!((r[2].re + 3.0).abs() < 1e-9 && (r[3].re + 4.0).abs() < 1e-9, "{r:?}");
}

/// Oracle 8: the pass recurrence reproduces 1 - (mu/(1+mu))^n and the printed values.
#[test]
fn pass_growth_series() {
    for (mu, printed) in [(1.0, &[0.5, 0.75, 0.875][..]), (0.5, &[0.667, 0.889][..])] {
        let it = pass_growth::iterate(mu, printed.len());
        for (n, (&f, &p)) in it.iter().zip(printed).enumerate() {
            assert!((f - pass_growth::closed_form(mu, n as u32 + 1)).abs() < 1e-12);
            assert!((f - p).abs() < 5e-4, "mu={mu} n={} {f} vs {p}", n + 1);
        }
    }
}

/// Table 5.1: f_r from the printed eq 5.35 agrees with every printed f_r within 1 %, and every
/// f_tr within half the printed last digit (0.05 mm).
#[test]
fn table_5_1_safe_rapid_feed() {
    let mut worst = 0.0f64;
    for (l, ftr, fr) in rapid_feed::TABLE_5_1 {
        for (k, &(d, z)) in rapid_feed::TABLE_CUTTERS.iter().enumerate() {
            let f = rapid_feed::feed_per_tooth_printed_mm(d, l);
            assert!((f - ftr[k]).abs() <= 0.05 + 1e-9, "L={l} d={d}: {f} vs {}", ftr[k]);
            let r = rapid_feed::table_feed_mm_min(f, z, d);
            worst = worst.max(rel(r, fr[k]));
            assert!(rel(r, fr[k]) < 0.01, "L={l} d={d}: {r} vs {}", fr[k]);
        }
    }
    assert!(worst > 0.005, "the table is rounded, so some entry differs: {worst}");
}

/// Eq 5.35 from its parts: 0.3 F_C,max / K_t with K_t of eq 5.34 is 0.9 (sigma/E) L^2/d, and with
/// E = 30e6 psi the constant is 0.00653, 2 % above the printed 0.0064.
#[test]
fn eq_5_35_derivation() {
    let k = 0.9 * rapid_feed::SIGMA_S_N_MM2 / rapid_feed::E_N_MM2;
    assert!((k - 0.006_527).abs() < 1e-6, "{k}");
    assert!(rel(k, rapid_feed::PRINTED_CONSTANT) > 0.015 && rel(k, 0.0064) < 0.025);
    let (d, l) = (12.5, 75.0);
    let f = rapid_feed::feed_per_tooth_mm(d, l, rapid_feed::tool_stiffness_thesis(d, l));
    assert!(rel(f, k * l * l / d) < 1e-12, "{f}");
}

/// Caution: eq 5.34 takes the cutter as E I / L^3, a third of the textbook end-loaded cantilever
/// 3 E I / L^3. With the textbook stiffness the safe rapid feed is 3x smaller than Table 5.1: a
/// firmware must not take Table 5.1 as its approach speed without measuring the tool's stiffness.
#[test]
fn table_5_1_tool_stiffness_caution() {
    for (l, _, fr) in rapid_feed::TABLE_5_1 {
        for (k, &(d, z)) in rapid_feed::TABLE_CUTTERS.iter().enumerate() {
            let kt = rapid_feed::tool_stiffness_thesis(d, l);
            let kc = rapid_feed::tool_stiffness_cantilever(d, l);
            assert!(rel(kc / kt, 3.0) < 1e-12);
            let f = rapid_feed::feed_per_tooth_mm(d, l, kc);
            let r = rapid_feed::table_feed_mm_min(f, z, d);
            assert!(rel(r * 3.0, fr[k]) < 0.03, "L={l} d={d}: {r} x3 vs {}", fr[k]);
            assert!(r < 0.36 * fr[k]);
        }
    }
}
