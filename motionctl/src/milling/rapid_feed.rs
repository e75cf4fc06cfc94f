//! Safe rapid approach with a flexible cutter (thesis §5.10, eqs 5.30-5.35, Table 5.1).
//!
//! The first tooth's chip is reduced by the cutter's deflection: F_C = f_t K_t / 0.3 (5.32). Setting
//! it to the breaking limit F_C,max = sigma_s pi d^3 / (32 L) (5.33; the printed text dropped the
//! "/32 L" of the bending section modulus, the 0.9 factor of 5.35 needs it) with the tool stiffness
//! of 5.34, K_t = pi d^4 E / (1.5 * 64 L^3), gives f_tr = 0.9 (sigma_s/E) L^2/d (5.35).

use std::f64::consts::PI;

/// Safe stress, N/mm^2 (eq 5.33).
pub const SIGMA_S_N_MM2: f64 = 1500.0;
/// E = 30e6 lb/in^2 in N/mm^2.
pub const E_N_MM2: f64 = 30.0e6 * 4.448_221_615_260_5 / (25.4 * 25.4);
/// The printed constant of eq 5.35, mm^-1.
pub const PRINTED_CONSTANT: f64 = 0.0064;
/// Cutting speed of Table 5.1, mm/min.
pub const V_MM_MIN: f64 = 40_000.0;
/// Collet flexibility factor of eq 5.34.
pub const COLLET_FACTOR: f64 = 1.5;

/// Tool stiffness of eq 5.34 (N/mm): a cantilever taken as pi d^4 E / (64 L^3) = E I / L^3,
/// softened by the collet factor.
pub fn tool_stiffness_thesis(d_mm: f64, l_mm: f64) -> f64 {
    PI * d_mm.powi(4) * E_N_MM2 / (COLLET_FACTOR * 64.0 * l_mm.powi(3))
}

/// Textbook end-loaded cantilever 3 E I / L^3 with the same collet factor: 3x stiffer than 5.34.
pub fn tool_stiffness_cantilever(d_mm: f64, l_mm: f64) -> f64 {
    3.0 * PI * d_mm.powi(4) * E_N_MM2 / (COLLET_FACTOR * 64.0 * l_mm.powi(3))
}

/// Breaking-limit force (N) at the cutter's root: sigma_s times the section modulus over L.
pub fn max_force_n(d_mm: f64, l_mm: f64) -> f64 {
    SIGMA_S_N_MM2 * PI * d_mm.powi(3) / (32.0 * l_mm)
}

/// Safe rapid feed per tooth (mm) from eq 5.32 for a given tool stiffness: f_tr = 0.3 F_C,max / K_t.
pub fn feed_per_tooth_mm(d_mm: f64, l_mm: f64, stiffness_n_mm: f64) -> f64 {
    0.3 * max_force_n(d_mm, l_mm) / stiffness_n_mm
}

/// Eq 5.35 with the printed constant.
pub fn feed_per_tooth_printed_mm(d_mm: f64, l_mm: f64) -> f64 {
    PRINTED_CONSTANT * l_mm * l_mm / d_mm
}

/// Table velocity (mm/min) for a feed per tooth: f_r = f_tr z N, N = V/(pi d).
pub fn table_feed_mm_min(f_tr_mm: f64, teeth: u32, d_mm: f64) -> f64 {
    f_tr_mm * teeth as f64 * V_MM_MIN / (PI * d_mm)
}

/// Table 5.1's columns: cutter diameter (mm) and tooth count.
pub const TABLE_CUTTERS: [(f64, u32); 4] = [(6.25, 2), (12.5, 2), (18.75, 4), (25.0, 4)];

/// Table 5.1 as printed: (L mm, f_tr mm per column, f_r mm/min per column).
pub const TABLE_5_1: [(f64, [f64; 4], [f64; 4]); 3] = [
    (50.0, [2.6, 1.3, 0.9, 0.6], [10_400.0, 2_600.0, 2_320.0, 1_300.0]),
    (75.0, [5.8, 2.9, 1.9, 1.4], [23_400.0, 5_860.0, 5_200.0, 2_920.0]),
    (100.0, [10.2, 5.1, 3.4, 2.6], [41_700.0, 10_400.0, 9_200.0, 5_200.0]),
];
