//! Polar contouring on the host (Fahim 1983): contours, the software digitizer (timed
//! single-axis step events), the listing's start-point method, drive limits and pole placement.
//! Lengths in inches (`_in`) like the thesis's listing; SI where the thesis's dynamics use it.

pub mod bench;
pub mod cli;
pub mod contour;
pub mod copy;
pub mod copy_sim;
pub mod digitize;
pub mod drive;
pub mod dump;
pub mod figure;
pub mod listing;
pub mod pole;
pub mod run;
pub mod segments;
pub mod sim;
pub mod work_area;

/// Radial resolution dR, inches (0.001 in = 2.54e-3 cm).
pub const DR_IN: f64 = 0.001;
/// Angular resolution dTheta = 2 pi / 16000 rad.
pub const DTHETA_RAD: f64 = 2.0 * std::f64::consts::PI / 16000.0;
/// Work area: 3 in (7.62 cm) < r < 13 in (33.02 cm), 0 < theta < 2.8 rad.
pub const R_MIN_IN: f64 = 3.0;
pub const R_MAX_IN: f64 = 13.0;
pub const THETA_MAX_RAD: f64 = 2.8;
pub const CM_PER_IN: f64 = 2.54;

/// Machine resolutions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolution {
    pub dr_in: f64,
    pub dtheta_rad: f64,
}

impl Resolution {
    pub const THESIS: Resolution = Resolution { dr_in: DR_IN, dtheta_rad: DTHETA_RAD };

    /// K = dR / dTheta: below this radius the deviation error is radial-limited (eq 4.1).
    pub fn k_in(&self) -> f64 {
        self.dr_in / self.dtheta_rad
    }

    /// Deviation error of eq 4.1 at radius r: dR for r <= K, else r dTheta.
    pub fn deviation_in(&self, r_in: f64) -> f64 {
        if r_in <= self.k_in() {
            self.dr_in
        } else {
            r_in * self.dtheta_rad
        }
    }
}
