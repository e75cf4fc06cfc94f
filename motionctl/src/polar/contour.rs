//! Contours in the contour frame (pole O1 at the origin): polar equations r1(theta1), Cartesian
//! graphs, and Cartesian points through a cubic spline. Each gives the point and its first two
//! derivatives with respect to its parameter u.

use std::f64::consts::PI;

/// Point, first and second derivative with respect to the parameter.
pub type Jet = [[f64; 2]; 3];

/// A parametric contour. Closed contours run counter-clockwise over `range()` and end where they
/// start.
pub trait Contour {
    fn jet(&self, u: f64) -> Jet;
    fn range(&self) -> (f64, f64);
    fn closed(&self) -> bool;
}

/// A polar equation r1(theta1) with its derivatives, u = theta1.
pub trait PolarEq {
    /// (r1, r1', r1'').
    fn r(&self, theta1: f64) -> (f64, f64, f64);
}

/// Turns a polar equation into a parametric contour over `range`.
pub struct Polar<E> {
    pub eq: E,
    pub from: f64,
    pub to: f64,
    pub closed: bool,
}

impl<E: PolarEq> Polar<E> {
    /// The full closed curve, theta1 from 0 to 2 pi.
    pub fn closed(eq: E) -> Self {
        Polar { eq, from: 0.0, to: 2.0 * PI, closed: true }
    }
}

impl<E: PolarEq> Contour for Polar<E> {
    fn jet(&self, u: f64) -> Jet {
        let (r, r1, r2) = self.eq.r(u);
        let (s, c) = u.sin_cos();
        let e = [c, s];
        let n = [-s, c];
        [
            [r * e[0], r * e[1]],
            [r1 * e[0] + r * n[0], r1 * e[1] + r * n[1]],
            [(r2 - r) * e[0] + 2.0 * r1 * n[0], (r2 - r) * e[1] + 2.0 * r1 * n[1]],
        ]
    }
    fn range(&self) -> (f64, f64) {
        (self.from, self.to)
    }
    fn closed(&self) -> bool {
        self.closed
    }
}

/// Circle of radius a about the contour pole.
#[derive(Clone, Copy, Debug)]
pub struct Circle {
    pub a: f64,
}

impl PolarEq for Circle {
    fn r(&self, _: f64) -> (f64, f64, f64) {
        (self.a, 0.0, 0.0)
    }
}

/// Limacon of Pascal r1 = b + a cos(theta1) (the listing's BB + AA cos).
#[derive(Clone, Copy, Debug)]
pub struct Limacon {
    pub b: f64,
    pub a: f64,
}

impl PolarEq for Limacon {
    fn r(&self, t: f64) -> (f64, f64, f64) {
        let (s, c) = t.sin_cos();
        (self.b + self.a * c, -self.a * s, -self.a * c)
    }
}

/// A Cartesian graph y = f(x) for x in [x0, x1], u = x (open contour).
pub struct Graph<F> {
    /// (f, f', f'').
    pub f: F,
    pub x0: f64,
    pub x1: f64,
}

impl<F: Fn(f64) -> (f64, f64, f64)> Contour for Graph<F> {
    fn jet(&self, x: f64) -> Jet {
        let (y, y1, y2) = (self.f)(x);
        [[x, y], [1.0, y1], [0.0, y2]]
    }
    fn range(&self) -> (f64, f64) {
        (self.x0, self.x1)
    }
    fn closed(&self) -> bool {
        false
    }
}

/// Witch of Agnesi y = 8 a^3 / (x^2 + 4 a^2) (eq 4.18).
pub fn witch(a: f64, x0: f64, x1: f64) -> Graph<impl Fn(f64) -> (f64, f64, f64)> {
    let f = move |x: f64| {
        let d = x * x + 4.0 * a * a;
        let y = 8.0 * a * a * a / d;
        let y1 = -2.0 * x * y / d;
        let y2 = y * (6.0 * x * x - 8.0 * a * a) / (d * d);
        (y, y1, y2)
    };
    Graph { f, x0, x1 }
}

/// Serpentine y = a b x / (a^2 + x^2) (eq 4.20).
pub fn serpentine(a: f64, b: f64, x0: f64, x1: f64) -> Graph<impl Fn(f64) -> (f64, f64, f64)> {
    let f = move |x: f64| {
        let d = a * a + x * x;
        let y = a * b * x / d;
        let y1 = a * b * (a * a - x * x) / (d * d);
        let y2 = 2.0 * a * b * x * (x * x - 3.0 * a * a) / (d * d * d);
        (y, y1, y2)
    };
    Graph { f, x0, x1 }
}

/// Natural cubic spline through Cartesian points, parametrised by cumulative chord length: the
/// generic form for a contour given as points (open).
#[derive(Clone, Debug)]
pub struct Spline {
    u: Vec<f64>,
    /// Per coordinate: values and second derivatives at the knots.
    y: [Vec<f64>; 2],
    m: [Vec<f64>; 2],
}

impl Spline {
    /// At least 3 distinct consecutive points.
    pub fn new(points: &[[f64; 2]]) -> Option<Self> {
        if points.len() < 3 {
            return None;
        }
        let mut u = vec![0.0];
        for w in points.windows(2) {
            let d = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
            if d <= 0.0 {
                return None;
            }
            u.push(u[u.len() - 1] + d);
        }
        let y: [Vec<f64>; 2] =
            [points.iter().map(|p| p[0]).collect(), points.iter().map(|p| p[1]).collect()];
        let m = [natural_m(&u, &y[0]), natural_m(&u, &y[1])];
        Some(Spline { u, y, m })
    }
}

/// Second derivatives of the natural cubic spline (tridiagonal solve).
fn natural_m(u: &[f64], y: &[f64]) -> Vec<f64> {
    let n = u.len();
    let mut m = vec![0.0; n];
    let mut c = vec![0.0; n];
    let mut d = vec![0.0; n];
    for i in 1..n - 1 {
        let h0 = u[i] - u[i - 1];
        let h1 = u[i + 1] - u[i];
        let a = h0 / 6.0;
        let b = (h0 + h1) / 3.0 - a * c[i - 1];
        let rhs = (y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0;
        c[i] = (h1 / 6.0) / b;
        d[i] = (rhs - a * d[i - 1]) / b;
    }
    for i in (1..n - 1).rev() {
        m[i] = d[i] - c[i] * m[i + 1];
    }
    m
}

impl Contour for Spline {
    fn jet(&self, t: f64) -> Jet {
        let n = self.u.len();
        let i = match self.u.partition_point(|&k| k <= t) {
            0 => 0,
            k => (k - 1).min(n - 2),
        };
        let (u0, u1) = (self.u[i], self.u[i + 1]);
        let h = u1 - u0;
        let (a, b) = ((u1 - t) / h, (t - u0) / h);
        let mut out = [[0.0; 2]; 3];
        #[allow(clippy::needless_range_loop)] // k walks three parallel arrays.
        for k in 0..2 {
            let (y0, y1, m0, m1) = (self.y[k][i], self.y[k][i + 1], self.m[k][i], self.m[k][i + 1]);
            out[0][k] =
                a * y0 + b * y1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
            out[1][k] =
                (y1 - y0) / h + ((1.0 - 3.0 * a * a) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
            out[2][k] = a * m0 + b * m1;
        }
        out
    }
    fn range(&self) -> (f64, f64) {
        (0.0, self.u[self.u.len() - 1])
    }
    fn closed(&self) -> bool {
        false
    }
}

/// A contour scaled by `k` about its pole (a user's contour in mm, with `k` = 1 / 25.4, is the
/// same contour in the digitizer's inches). The parameter is unchanged.
pub struct Scaled {
    inner: Box<dyn Contour>,
    k: f64,
}

impl Scaled {
    pub fn new(inner: Box<dyn Contour>, k: f64) -> Self {
        Scaled { inner, k }
    }
}

impl Contour for Scaled {
    fn jet(&self, u: f64) -> Jet {
        let k = self.k;
        self.inner.jet(u).map(|v| [v[0] * k, v[1] * k])
    }
    fn range(&self) -> (f64, f64) {
        self.inner.range()
    }
    fn closed(&self) -> bool {
        self.inner.closed()
    }
}
