//! Reference systems with published chaotic statistics, for tests and demonstrations:
//! the Hénon map (a = 1.4, b = 0.3: D2 = 1.21 +- 0.01, Grassberger & Procaccia 1983;
//! largest exponent 0.419 per iteration) and the Lorenz system (sigma = 10, rho = 28,
//! beta = 8/3: largest exponent about 0.906 1/s).

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

    /// Right-hand side of state + variational equation `v' = J(x) v`.
    fn rhs6(&self, s: &[f64; 6]) -> [f64; 6] {
        let (x, v) = ([s[0], s[1], s[2]], [s[3], s[4], s[5]]);
        let f = self.rhs(&x);
        [
            f[0],
            f[1],
            f[2],
            self.sigma * (v[1] - v[0]),
            (self.rho - x[2]) * v[0] - v[1] - x[0] * v[2],
            x[1] * v[0] + x[0] * v[1] - self.beta * v[2],
        ]
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
    /// of the RK4 step to O(h^5)), for [`crate::benettin_tangent`].
    pub fn rk4_tangent_step(&self, x: &mut [f64], v: &mut [f64], h: f64) {
        let s = [x[0], x[1], x[2], v[0], v[1], v[2]];
        let add = |a: &[f64; 6], k: &[f64; 6], c: f64| std::array::from_fn::<f64, 6, _>(|i| a[i] + c * k[i]);
        let k1 = self.rhs6(&s);
        let k2 = self.rhs6(&add(&s, &k1, h / 2.0));
        let k3 = self.rhs6(&add(&s, &k2, h / 2.0));
        let k4 = self.rhs6(&add(&s, &k3, h));
        let n: [f64; 6] = std::array::from_fn(|i| s[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        x.copy_from_slice(&n[..3]);
        v.copy_from_slice(&n[3..]);
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
