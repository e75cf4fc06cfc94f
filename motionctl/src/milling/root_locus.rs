//! Root loci of §5.7 (eq 5.21): closed-loop poles of the A/C loop around the NC servo (eq 5.20)
//! from the printed open-loop gain, zero and poles, with a small polynomial root finder.
//!
//! Open loop: G(s) = g (s + z) / [s (s + p_1) (s + p_2) (s + p_3)]; closed-loop characteristic
//! polynomial: s (s + p_1)(s + p_2)(s + p_3) + g (s + z) = 0.

/// A complex number (just what the root finder needs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct C64 {
    pub re: f64,
    pub im: f64,
}

impl C64 {
    pub const fn new(re: f64, im: f64) -> Self {
        C64 { re, im }
    }
    fn add(self, o: C64) -> C64 {
        C64::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: C64) -> C64 {
        C64::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: C64) -> C64 {
        C64::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
    fn div(self, o: C64) -> C64 {
        let d = o.re * o.re + o.im * o.im;
        C64::new((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    /// Damping ratio of a pole: -Re / |s|.
    pub fn damping(self) -> f64 {
        -self.re / self.abs()
    }
}

/// Product of polynomials, coefficients highest power first.
pub fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            r[i + j] += x * y;
        }
    }
    r
}

fn eval(c: &[f64], z: C64) -> C64 {
    c.iter().fold(C64::new(0.0, 0.0), |acc, &k| acc.mul(z).add(C64::new(k, 0.0)))
}

/// All roots of a polynomial (highest power first, leading coefficient non-zero) by the
/// Durand-Kerner iteration, sorted by real part, closest to the imaginary axis first.
pub fn roots(coeffs: &[f64]) -> Vec<C64> {
    let n = coeffs.len() - 1;
    let lead = coeffs[0];
    let c: Vec<f64> = coeffs.iter().map(|k| k / lead).collect();
    // Starting points on a spiral scaled to the root bound (Cauchy), none real or conjugate.
    let bound = 1.0 + c[1..].iter().fold(0.0f64, |m, k| m.max(k.abs()));
    let seed = C64::new(0.4, 0.9);
    let mut z: Vec<C64> = (0..n)
        .scan(C64::new(1.0, 0.0), |p, _| {
            *p = p.mul(seed);
            Some(C64::new(p.re * bound, p.im * bound))
        })
        .collect();
    for _ in 0..2000 {
        let mut moved = 0.0f64;
        for i in 0..n {
            let mut den = C64::new(1.0, 0.0);
            for j in 0..n {
                if j != i {
                    den = den.mul(z[i].sub(z[j]));
                }
            }
            let step = eval(&c, z[i]).div(den);
            z[i] = z[i].sub(step);
            moved = moved.max(step.abs());
        }
        if moved < 1e-13 * bound {
            break;
        }
    }
    z.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
    z
}

/// The printed open loop of one §5.7 case.
#[derive(Clone, Copy, Debug)]
pub struct OpenLoop {
    pub gain: f64,
    pub zero: f64,
    /// The Ks/K'c pole as printed.
    pub pole: f64,
}

/// NC servo poles of eq 5.20.
pub const SERVO_POLES: [f64; 2] = [14.970, 427.414];

/// Closed-loop poles of `ol`: roots of s (s + pole)(s + 14.970)(s + 427.414) + g (s + z).
pub fn closed_loop_poles(ol: OpenLoop) -> Vec<C64> {
    let mut p = vec![1.0, 0.0];
    for q in [ol.pole, SERVO_POLES[0], SERVO_POLES[1]] {
        p = poly_mul(&p, &[1.0, q]);
    }
    let k = p.len();
    p[k - 2] += ol.gain;
    p[k - 1] += ol.gain * ol.zero;
    roots(&p)
}

/// Open-loop gain 6398.424 B Ks / Fnom of eq 5.21.
pub fn gain_from_parameters(b: f64, ks_n_mm: f64, fnom_n: f64) -> f64 {
    6398.424 * b * ks_n_mm / fnom_n
}
