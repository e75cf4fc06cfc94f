//! Pass-by-pass force growth with a compliant spindle (digest §2, oracle 8).
//!
//! Pass n cuts the nominal chip plus what the deflection y_{n-1} = F_{n-1}/Ks of the previous pass
//! left, minus its own deflection: F_n = Kc (h + y_{n-1} - y_n). With mu = Kc/Ks this gives
//! F_n (1 + mu) = Kc h + mu F_{n-1}, whose solution from F_0 = 0 is the closed form
//! F_n = F [1 - (mu/(1 + mu))^n], F = Kc h.

/// F_n / F by iterating the pass recurrence (not the closed form).
pub fn iterate(mu: f64, passes: usize) -> Vec<f64> {
    let mut f = 0.0;
    (0..passes)
        .map(|_| {
            f = (1.0 + mu * f) / (1.0 + mu);
            f
        })
        .collect()
}

/// The thesis's closed form F_n / F = 1 - (mu/(1 + mu))^n.
pub fn closed_form(mu: f64, n: u32) -> f64 {
    1.0 - (mu / (1.0 + mu)).powi(n as i32)
}
