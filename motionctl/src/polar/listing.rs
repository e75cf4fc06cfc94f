//! The thesis listing's (App. C, FORTRAN) own method, reproduced for its oracles: the start
//! point (subroutine GAMA with EQUA = limacon), and the arc-length integrand bug (SR integrates
//! r1 alone).

use super::contour::PolarEq;

/// Listing geometry at contour angle theta1: alpha = pi/2 - atan(r1'/r1), r_c^2 = r1^2 + Rr^2 +
/// 2 r1 Rr sin(alpha), lambda = asin(Rr cos(alpha) / r_c). Returns (r_c, lambda).
pub fn tool_centre_polar(eq: &impl PolarEq, theta1: f64, rr: f64) -> (f64, f64) {
    let (r1, d1, _) = eq.r(theta1);
    let alpha = std::f64::consts::FRAC_PI_2 - (d1 / r1).atan();
    let rc = (r1 * r1 + rr * rr + 2.0 * r1 * rr * alpha.sin()).sqrt();
    (rc, (rr * alpha.cos() / rc).asin())
}

/// The listing's start point: the machine angle THE where the angular equation
/// F = RI sin(EPS - THE) - RR cos(THE - theta1 - alpha) - r1 sin(THE - theta1) vanishes at
/// theta1, found by Newton on THE (tolerance 1e-12), and the radius
/// AL = r_c sin(EPS + lambda - theta1) / sin(EPS - THE). Angles in radians.
pub fn start_point(
    eq: &impl PolarEq,
    ri: f64,
    eps: f64,
    rr: f64,
    theta1: f64,
) -> Option<(f64, f64)> {
    let (r1, d1, _) = eq.r(theta1);
    let alpha = std::f64::consts::FRAC_PI_2 - (d1 / r1).atan();
    let f = |th: f64| {
        ri * (eps - th).sin() - rr * (th - theta1 - alpha).cos() - r1 * (th - theta1).sin()
    };
    let df = |th: f64| {
        -ri * (eps - th).cos() + rr * (th - theta1 - alpha).sin() - r1 * (th - theta1).cos()
    };
    let mut th = theta1;
    for _ in 0..100 {
        let step = f(th) / df(th);
        th -= step;
        if step.abs() < 1e-12 {
            let (rc, lambda) = tool_centre_polar(eq, theta1, rr);
            return Some((th, rc * (eps + lambda - theta1).sin() / (eps - th).sin()));
        }
    }
    None
}

/// Speed error the listing's SR integrand (r1 alone) causes at theta1: the true arc length per
/// radian is sqrt(r1^2 + r1'^2), so the events come that much too fast.
pub fn listing_speed_error(eq: &impl PolarEq, theta1: f64) -> f64 {
    let (r1, d1, _) = eq.r(theta1);
    (r1 * r1 + d1 * d1).sqrt() / r1
}
