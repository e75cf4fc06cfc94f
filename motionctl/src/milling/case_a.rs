//! Case A statics (thesis §4.5, L1184-1215): force model eq 4.17, F = K a b [x(t) - x(t - tau)],
//! in steady state F = K a b v tau, with the feed clamped at the rapid traverse.

/// Eq 4.17 coefficient, N/mm^3.
pub const K_N_PER_MM3: f64 = 205.0;
/// Radial depth of cut a, mm.
pub const A_MM: f64 = 20.0;
/// Rapid traverse limit, mm/s.
pub const RAPID_MM_S: f64 = 12.7;
/// Nominal force, N.
pub const FNOM_N: f64 = 4100.0;

/// Steady-state force at feed `v_mm_s` (eq 4.17 with x(t) - x(t - tau) = v tau).
pub fn steady_force_n(b_mm: f64, tau_s: f64, v_mm_s: f64) -> f64 {
    K_N_PER_MM3 * A_MM * b_mm * v_mm_s * tau_s
}

/// Feed that holds `FNOM_N` at axial depth `b_mm`, clamped at the rapid traverse.
pub fn steady_feed_mm_s(b_mm: f64, tau_s: f64) -> f64 {
    (FNOM_N / (K_N_PER_MM3 * A_MM * b_mm * tau_s)).min(RAPID_MM_S)
}

/// The three Case A statics for tooth period `tau_s`: (force before the step, force right at the
/// step before the feed reacts, feed after the step), b stepping 2.5 -> 10 mm.
pub fn statics(tau_s: f64) -> CaseAStatics {
    let v1 = steady_feed_mm_s(2.5, tau_s);
    CaseAStatics {
        feed_before_mm_s: v1,
        force_before_n: steady_force_n(2.5, tau_s, v1),
        force_at_step_n: steady_force_n(10.0, tau_s, v1),
        feed_after_mm_s: steady_feed_mm_s(10.0, tau_s),
    }
}

/// See [`statics`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaseAStatics {
    pub feed_before_mm_s: f64,
    pub force_before_n: f64,
    pub force_at_step_n: f64,
    pub feed_after_mm_s: f64,
}

/// Stop distance (mm) and time (s) from `v_mm_s` at a constant deceleration `a_mm_s2`.
pub fn stop_distance(v_mm_s: f64, a_mm_s2: f64) -> (f64, f64) {
    (v_mm_s * v_mm_s / (2.0 * a_mm_s2), v_mm_s / a_mm_s2)
}
