//! Reference systems with published chaotic statistics, for tests, calibrations and
//! demonstrations: the Hénon map (a = 1.4, b = 0.3: D2 = 1.21 +- 0.01, Grassberger &
//! Procaccia 1983; largest exponent 0.419 per iteration) and the flows [`Lorenz`] (sigma =
//! 10, rho = 28, beta = 8/3: largest exponent about 0.906 1/s), [`Rossler`] (about 0.071
//! 1/s), [`HyperRossler`] (two positive exponents) and [`Lorenz96`]. Every flow implements
//! [`Flow`] (right-hand side and exact Jacobian-vector product), so [`rk4_flow`] advances
//! state and tangent together for [`crate::benettin_tangent`].

/// An autonomous flow `x' = f(x)` with its exact tangent `v' = J(x) v`, on slices of the
/// flow's dimension.
pub trait Flow: Sync {
    /// `out = f(x)`.
    fn rhs(&self, x: &[f64], out: &mut [f64]);
    /// `out = J(x) v`.
    fn jvp(&self, x: &[f64], v: &[f64], out: &mut [f64]);
}

/// `steps` classical RK4 steps of size `dt / steps` of the state `x` and a tangent vector `v`
/// together (the tangent map of the RK4 step to O(h^5)). `x` and `v` have the flow's dimension.
pub fn rk4_flow<F: Flow + ?Sized>(f: &F, x: &mut [f64], v: &mut [f64], dt: f64, steps: usize) {
    let n = x.len();
    assert_eq!(v.len(), n, "rk4_flow: tangent of length {} for a state of length {n}", v.len());
    let steps = steps.max(1);
    let h = dt / steps as f64;
    let g = |s: &[f64], out: &mut [f64]| {
        let (a, b) = out.split_at_mut(n);
        f.rhs(&s[..n], a);
        f.jvp(&s[..n], &s[n..], b);
    };
    // One allocation: the stage state s and the work vectors k1..k4, t.
    let mut buf = vec![0.0; 12 * n];
    let (s, rest) = buf.split_at_mut(2 * n);
    let (k1, rest) = rest.split_at_mut(2 * n);
    let (k2, rest) = rest.split_at_mut(2 * n);
    let (k3, rest) = rest.split_at_mut(2 * n);
    let (k4, t) = rest.split_at_mut(2 * n);
    s[..n].copy_from_slice(x);
    s[n..].copy_from_slice(v);
    for _ in 0..steps {
        g(s, k1);
        t.iter_mut().zip(s.iter()).zip(k1.iter()).for_each(|((t, s), k)| *t = s + 0.5 * h * k);
        g(t, k2);
        t.iter_mut().zip(s.iter()).zip(k2.iter()).for_each(|((t, s), k)| *t = s + 0.5 * h * k);
        g(t, k3);
        t.iter_mut().zip(s.iter()).zip(k3.iter()).for_each(|((t, s), k)| *t = s + h * k);
        g(t, k4);
        for i in 0..2 * n {
            s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    x.copy_from_slice(&s[..n]);
    v.copy_from_slice(&s[n..]);
}

/// The Rössler system `x' = -y - z`, `y' = x + a y`, `z' = b + z (x - c)`, at the classic
/// a = b = 0.2, c = 5.7 by default (largest exponent about 0.071 1/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rossler {
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

impl Default for Rossler {
    fn default() -> Self {
        Self { a: 0.2, b: 0.2, c: 5.7 }
    }
}

impl Flow for Rossler {
    fn rhs(&self, x: &[f64], o: &mut [f64]) {
        o[0] = -x[1] - x[2];
        o[1] = x[0] + self.a * x[1];
        o[2] = self.b + x[2] * (x[0] - self.c);
    }
    fn jvp(&self, x: &[f64], v: &[f64], o: &mut [f64]) {
        o[0] = -v[1] - v[2];
        o[1] = v[0] + self.a * v[1];
        o[2] = x[2] * v[0] + (x[0] - self.c) * v[2];
    }
}

/// Rössler's hyperchaotic flow (1979): `x' = -y - z`, `y' = x + 0.25 y + w`,
/// `z' = 3 + x z`, `w' = -0.5 z + 0.05 w` (exponents about 0.11, 0.02, 0, -25).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HyperRossler;

impl Flow for HyperRossler {
    fn rhs(&self, x: &[f64], o: &mut [f64]) {
        o[0] = -x[1] - x[2];
        o[1] = x[0] + 0.25 * x[1] + x[3];
        o[2] = 3.0 + x[0] * x[2];
        o[3] = -0.5 * x[2] + 0.05 * x[3];
    }
    fn jvp(&self, x: &[f64], v: &[f64], o: &mut [f64]) {
        o[0] = -v[1] - v[2];
        o[1] = v[0] + 0.25 * v[1] + v[3];
        o[2] = x[2] * v[0] + x[0] * v[2];
        o[3] = -0.5 * v[2] + 0.05 * v[3];
    }
}

/// Lorenz-96 with `n` sites and forcing `f`: `x_i' = (x_{i+1} - x_{i-2}) x_{i-1} - x_i + f`
/// (indices cyclic).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lorenz96 {
    pub n: usize,
    pub f: f64,
}

impl Flow for Lorenz96 {
    fn rhs(&self, x: &[f64], o: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            o[i] = (x[(i + 1) % n] - x[(i + n - 2) % n]) * x[(i + n - 1) % n] - x[i] + self.f;
        }
    }
    fn jvp(&self, x: &[f64], v: &[f64], o: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let (p, m2, m1) = ((i + 1) % n, (i + n - 2) % n, (i + n - 1) % n);
            o[i] = (v[p] - v[m2]) * x[m1] + (x[p] - x[m2]) * v[m1] - v[i];
        }
    }
}

/// `x' = 1 - a x^2 + y`, `y' = b x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Henon {
    pub a: f64,
    pub b: f64,
}

impl Default for Henon {
    fn default() -> Self {
        Self { a: 1.4, b: 0.3 }
    }
}

impl Henon {
    pub fn map(&self, x: &[f64], out: &mut [f64]) {
        out[0] = 1.0 - self.a * x[0] * x[0] + x[1];
        out[1] = self.b * x[0];
    }
    /// Row-major Jacobian `[[-2 a x, 1], [b, 0]]`.
    pub fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        out.copy_from_slice(&[-2.0 * self.a * x[0], 1.0, self.b, 0.0]);
    }
    /// State and tangent step for [`crate::benettin_tangent`].
    pub fn tangent_step(&self, x: &mut [f64], v: &mut [f64]) {
        let v0 = -2.0 * self.a * x[0] * v[0] + v[1];
        let v1 = self.b * v[0];
        let x0 = 1.0 - self.a * x[0] * x[0] + x[1];
        let x1 = self.b * x[0];
        x[0] = x0;
        x[1] = x1;
        v[0] = v0;
        v[1] = v1;
    }
    /// `n` states after `transient` iterations from `(0.1, 0.1)`, row-major.
    pub fn orbit(&self, n: usize, transient: usize) -> Vec<[f64; 2]> {
        let mut x = [0.1, 0.1];
        let mut nx = [0.0; 2];
        let mut out = Vec::with_capacity(n);
        for k in 0..(n + transient) {
            self.map(&x, &mut nx);
            x = nx;
            if k >= transient {
                out.push(x);
            }
        }
        out
    }
}

/// The Lorenz system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lorenz {
    pub sigma: f64,
    pub rho: f64,
    pub beta: f64,
}

impl Default for Lorenz {
    fn default() -> Self {
        Self { sigma: 10.0, rho: 28.0, beta: 8.0 / 3.0 }
    }
}

impl Lorenz {
    pub fn rhs(&self, x: &[f64; 3]) -> [f64; 3] {
        [self.sigma * (x[1] - x[0]), x[0] * (self.rho - x[2]) - x[1], x[0] * x[1] - self.beta * x[2]]
    }

    /// One classical RK4 step of size `h`.
    pub fn rk4_step(&self, x: &mut [f64], h: f64) {
        let s = [x[0], x[1], x[2]];
        let add = |a: &[f64; 3], k: &[f64; 3], c: f64| [a[0] + c * k[0], a[1] + c * k[1], a[2] + c * k[2]];
        let k1 = self.rhs(&s);
        let k2 = self.rhs(&add(&s, &k1, h / 2.0));
        let k3 = self.rhs(&add(&s, &k2, h / 2.0));
        let k4 = self.rhs(&add(&s, &k3, h));
        for i in 0..3 {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }

    /// One RK4 step of the state and the variational equation together (the tangent map
    /// of the RK4 step to O(h^5)), for [`crate::benettin_tangent`]: [`rk4_flow`] with one step.
    pub fn rk4_tangent_step(&self, x: &mut [f64], v: &mut [f64], h: f64) {
        rk4_flow(self, x, v, h, 1);
    }

    /// `n` samples every `sample_every` RK4 steps of size `h`, after `transient` steps, from
    /// `(1, 1, 1)`.
    pub fn orbit(&self, n: usize, h: f64, sample_every: usize, transient: usize) -> Vec<[f64; 3]> {
        let mut x = [1.0, 1.0, 1.0];
        for _ in 0..transient {
            self.rk4_step(&mut x, h);
        }
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(x);
            for _ in 0..sample_every.max(1) {
                self.rk4_step(&mut x, h);
            }
        }
        out
    }
}

impl Flow for Lorenz {
    fn rhs(&self, x: &[f64], o: &mut [f64]) {
        o[..3].copy_from_slice(&Lorenz::rhs(self, &[x[0], x[1], x[2]]));
    }
    fn jvp(&self, x: &[f64], v: &[f64], o: &mut [f64]) {
        o[0] = self.sigma * (v[1] - v[0]);
        o[1] = (self.rho - x[2]) * v[0] - v[1] - x[0] * v[2];
        o[2] = x[1] * v[0] + x[0] * v[1] - self.beta * v[2];
    }
}
