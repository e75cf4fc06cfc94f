//! A small linear-system simulator for the CSMP runs of Douglass (1983), Appendix C (the Z-slide
//! position loop): a chain of CSMP blocks from the position error to the slide position `Z`,
//! closed by unity feedback (`ERR = R - Z`), driven by `STEP(0.)` or `RAMP(0.)`, integrated by
//! classical Runge-Kutta with a fixed small step (CSMP used variable-step RKS).
//!
//! (This is the Z servo, not the coefficient tables; it lives here only because this module is
//! where the Douglass work was assigned. It can move to a servo module unchanged.)
//!
//! Block semantics (CSMP): `LEDLAG(P1, P2, X) = (1 + P1 s) / (1 + P2 s) X`,
//! `REALPL(0., P, X) = X / (1 + P s)`, `CMPLXPL(0., 0., ZETA, W, X) = X / (s^2 + 2 ZETA W s + W^2)`,
//! `INTGRL(0., X) = X / s`, and a gain.

use super::{finite, positive, Result, TurningError};

/// One CSMP block (all initial conditions zero, as in every run of Appendix C).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Block {
    Gain(f64),
    /// `LEDLAG(p1_s, p2_s)`: `(1 + p1 s) / (1 + p2 s)`.
    LedLag {
        p1_s: f64,
        p2_s: f64,
    },
    /// `REALPL(0., p_s)`: `1 / (1 + p s)`.
    RealPole {
        p_s: f64,
    },
    /// `CMPLXPL(0., 0., zeta, w)`: `1 / (s^2 + 2 zeta w s + w^2)`.
    ComplexPole {
        zeta: f64,
        w_rad_s: f64,
    },
    /// `INTGRL(0.)`: `1 / s`.
    Integrator,
}

impl Block {
    fn states(&self) -> usize {
        match self {
            Block::Gain(_) => 0,
            Block::LedLag { .. } | Block::RealPole { .. } | Block::Integrator => 1,
            Block::ComplexPole { .. } => 2,
        }
    }

    fn has_feedthrough(&self) -> bool {
        matches!(self, Block::Gain(_) | Block::LedLag { .. })
    }

    fn validate(&self) -> Result<()> {
        match *self {
            Block::Gain(k) => finite("gain", k).map(|_| ()),
            Block::LedLag { p1_s, p2_s } => {
                finite("LEDLAG P1 (s)", p1_s)?;
                positive("LEDLAG P2 (s)", p2_s).map(|_| ())
            }
            Block::RealPole { p_s } => positive("REALPL P (s)", p_s).map(|_| ()),
            Block::ComplexPole { zeta, w_rad_s } => {
                finite("CMPLXPL zeta", zeta)?;
                positive("CMPLXPL w (rad/s)", w_rad_s).map(|_| ())
            }
            Block::Integrator => Ok(()),
        }
    }

    /// Output from the state and input (input only used with feedthrough).
    fn output(&self, x: &[f64], u: f64) -> f64 {
        match *self {
            Block::Gain(k) => k * u,
            Block::LedLag { p1_s, p2_s } => {
                let r = p1_s / p2_s;
                r * u + (1.0 - r) * x[0]
            }
            Block::RealPole { .. } | Block::Integrator | Block::ComplexPole { .. } => x[0],
        }
    }

    fn derivative(&self, x: &[f64], u: f64, dx: &mut [f64]) {
        match *self {
            Block::Gain(_) => {}
            Block::LedLag { p2_s, .. } => dx[0] = (u - x[0]) / p2_s,
            Block::RealPole { p_s } => dx[0] = (u - x[0]) / p_s,
            Block::Integrator => dx[0] = u,
            Block::ComplexPole { zeta, w_rad_s: w } => {
                dx[0] = x[1];
                dx[1] = u - 2.0 * zeta * w * x[1] - w * w * x[0];
            }
        }
    }
}

/// The reference input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// `STEP(0.)`: 1 from t = 0.
    Step,
    /// `RAMP(0.)`: t from t = 0.
    Ramp,
}

impl Input {
    fn at(&self, t_s: f64) -> f64 {
        match self {
            Input::Step => 1.0,
            Input::Ramp => t_s,
        }
    }
}

/// One output sample: time, slide position `Z` and error `ERR = R - Z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub t_s: f64,
    pub z: f64,
    pub err: f64,
}

/// A unity-feedback loop: `ERR = R - Z`, `Z = chain(ERR)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Loop {
    chain: Vec<Block>,
}

impl Loop {
    /// The last block must have no direct feedthrough (it holds `Z`), as in every CSMP run here.
    pub fn new(chain: Vec<Block>) -> Result<Self> {
        for b in &chain {
            b.validate()?;
        }
        match chain.last() {
            Some(b) if !b.has_feedthrough() => Ok(Self { chain }),
            _ => Err(TurningError::Table("the loop's last block must be a pole or an integrator")),
        }
    }

    /// Appendix C-1/C-2: first lag-compensated system.
    pub fn appendix_c1() -> Self {
        let (k1, p1, p2, w1, w2, ko) = (419.14, 0.75988, 2663.668, 290.0, 2.9, 79.432);
        Self {
            chain: vec![
                Block::Gain(ko),
                Block::LedLag { p1_s: 1.0 / w1, p2_s: 1.0 / w2 },
                Block::ComplexPole { zeta: p1, w_rad_s: p2 },
                Block::Gain(k1 * (p2 * p2)),
                Block::Integrator,
            ],
        }
    }

    /// Appendix C-3/C-4: lead-lag compensated system, no velocity feedback.
    pub fn appendix_c3() -> Self {
        let (p1, p2, kp) = (302.5, 3808.0, 2582.0);
        let (w1, w2, w3, w4, ko) = (35.0, 1.0, 100.0, 3500.0, 7.5);
        Self {
            chain: vec![
                Block::Gain(ko),
                Block::LedLag { p1_s: 1.0 / w1, p2_s: 1.0 / w2 },
                Block::LedLag { p1_s: 1.0 / w3, p2_s: 1.0 / w4 },
                Block::Gain(kp),
                Block::RealPole { p_s: 1.0 / p1 },
                Block::RealPole { p_s: 1.0 / p2 },
                Block::Integrator,
            ],
        }
    }

    /// Appendix C-5/C-6: final lag-compensated system.
    pub fn appendix_c5() -> Self {
        let (p1, p2, kp) = (1162.4, 7634.1, 674.0);
        let (w1, w2, w3, ko) = (4.16667, 0.378788, 3030.3, 6.0);
        Self {
            chain: vec![
                Block::Gain(ko),
                Block::LedLag { p1_s: 1.0 / w1, p2_s: 1.0 / w2 },
                Block::RealPole { p_s: 1.0 / w3 },
                Block::Gain(kp),
                Block::RealPole { p_s: 1.0 / p1 },
                Block::RealPole { p_s: 1.0 / p2 },
                Block::Integrator,
            ],
        }
    }

    fn z(&self, x: &[f64]) -> f64 {
        let n = x.len();
        let last = self.chain[self.chain.len() - 1];
        last.output(&x[n - last.states()..], 0.0)
    }

    fn derivative(&self, t: f64, input: Input, x: &[f64], dx: &mut [f64]) {
        let mut u = input.at(t) - self.z(x);
        let mut k = 0;
        for b in &self.chain {
            let n = b.states();
            b.derivative(&x[k..k + n], u, &mut dx[k..k + n]);
            u = b.output(&x[k..k + n], u);
            k += n;
        }
    }

    /// Simulates from rest to `final_s`, sampling every `output_s` (CSMP `FINTIM`, `OUTDEL`),
    /// with `steps_per_output` Runge-Kutta steps between samples.
    pub fn simulate(
        &self,
        input: Input,
        final_s: f64,
        output_s: f64,
        steps_per_output: usize,
    ) -> Result<Vec<Sample>> {
        positive("final time (s)", final_s)?;
        positive("output interval (s)", output_s)?;
        if steps_per_output == 0 {
            return Err(TurningError::Table("need at least one step per output interval"));
        }
        let outputs = (final_s / output_s).round() as usize;
        let n: usize = self.chain.iter().map(Block::states).sum();
        let mut x = vec![0.0; n];
        let h = output_s / steps_per_output as f64;
        let (mut k1, mut k2, mut k3, mut k4, mut tmp) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut out = Vec::with_capacity(outputs + 1);
        let sample = |t: f64, x: &[f64]| {
            let z = self.z(x);
            Sample { t_s: t, z, err: input.at(t) - z }
        };
        out.push(sample(0.0, &x));
        for i in 0..outputs {
            let t0 = i as f64 * output_s;
            for j in 0..steps_per_output {
                let t = t0 + j as f64 * h;
                self.derivative(t, input, &x, &mut k1);
                for q in 0..n {
                    tmp[q] = x[q] + 0.5 * h * k1[q];
                }
                self.derivative(t + 0.5 * h, input, &tmp, &mut k2);
                for q in 0..n {
                    tmp[q] = x[q] + 0.5 * h * k2[q];
                }
                self.derivative(t + 0.5 * h, input, &tmp, &mut k3);
                for q in 0..n {
                    tmp[q] = x[q] + h * k3[q];
                }
                self.derivative(t + h, input, &tmp, &mut k4);
                for q in 0..n {
                    x[q] += h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]);
                }
            }
            if x.iter().any(|v| !v.is_finite()) {
                return Err(TurningError::Table("the simulation diverged"));
            }
            out.push(sample((i + 1) as f64 * output_s, &x));
        }
        Ok(out)
    }
}
