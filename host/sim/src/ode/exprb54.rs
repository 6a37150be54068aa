//! One step of `exprb54s4`, the four-stage exponential Rosenbrock method of order 5 with an
//! embedded order-4 solution (Luan & Ostermann, "Exponential Rosenbrock methods of order five
//! -- construction, analysis and numerical comparisons", J. Comput. Appl. Math. 255:417-431,
//! 2014, doi:10.1016/j.cam.2013.04.041), opt-in as [`super::Method::Exprb54`].
//!
//! With `J = f'(y_n)`, `Z = hJ`, `F = f(y_n)` and `D(U) = f(U) - F - J (U - y_n)` as in
//! `exprb.rs` (zero on a linear right-hand side, so the method is exact there too):
//!
//! ```text
//! U2 = y_n + (h/4)  phi1(Z/4)   F
//! U3 = y_n + (h/2)  phi1(Z/2)   F + 4 h phi3(Z/2) D2
//! U4 = y_n + (9h/10) phi1(9Z/10) F + (729/125) h phi3(9Z/10) D3
//! y5 = y_n + h phi1(Z) F + h phi3(Z) (18 D3 - 250/81 D4) + h phi4(Z) (-60 D3 + 500/27 D4)
//! y4 = y_n + h phi1(Z) F + h phi3(Z) (64 D2 - 8 D3) + h phi4(Z) (-60 D2 - 285/8 D3 + 125/8 D4)
//! ```
//!
//! `Di = D(Ui)`. The step goes on with `y5` (local extrapolation); the error estimate is
//! `y5 - y4 = h phi3(Z) (-64 D2 + 26 D3 - 250/81 D4) + h phi4(Z) (60 D2 - 195/8 D3 + 625/216 D4)`,
//! formed directly (no cancellation of the two solutions), of order `h^5`: the driver's
//! controller takes its fifth root. Per step: one Jacobian and three right-hand sides (exprb43:
//! one and two).
//!
//! The stages satisfy the stiff order conditions `psi_{3,i} = 0` (`a_32 c_2^2/2 = c_3^3
//! phi3(c_3 Z)`, `a_43 c_3^2/2 = c_4^3 phi3(c_4 Z)`), the weights `sum b_i c_i^2 = 2 phi3`,
//! `sum b_i c_i^3 = 6 phi4`, and `sum b_i c_i^4 = 24 phi5` at `Z = 0` (checked in the tests).
//!
//! The `phi`-functions are applied to vectors as in `split.rs`: the dominant (fast) mode in
//! closed form, the rest (`Z_s = h J_s`) by Taylor sums, each vector's powers `Z_s^j t` formed
//! once and weighted by `c^j / (j+k)!` for every `(c, k)` the step needs of it (constant
//! tables). Where there is no dominant eigenpair or `|Z_s|_1` exceeds [`RHO_MAX`], the full
//! matrix functions by scaling and squaring (`exprb.rs`'s): `phi_k(Z/4)` doubled to `Z/2` and
//! `Z`, and `phi_k(9Z/10)` separately.

//!
//! A trial step costs more than exprb-filtered's (three right-hand sides, four Taylor
//! sequences). Unfiltered, it takes as many steps as exprb-filtered (the steps go to the
//! transient after each input jump); with the filter (`exprb54-filtered`) fewer, for a smaller
//! error at the same rtol (`docs/performance.md`; the tests print errors and steps). Its step
//! order is 5 on the Furuta plant's smooth regime and 4 on a stiff Prothero-Robinson problem
//! (the weakened fifth-order condition).

use super::exprb::{self, Cols};
use super::split::{self, Cut, Pair};

/// Largest 1-norm of `h J_s` handled by the Taylor sums (exprb43's split: 1.0; the longer
/// steps of an order-5 method reach further, and the sums stay well conditioned: every term is
/// below `2^j / j!` of the vector).
const RHO_MAX: f64 = 2.0;
/// Taylor terms at most: `RHO_MAX^j / (j+1)!` is below `1e-18` from `j = 25` on.
pub const MAX_TERMS: usize = 25;

/// `c^j / (j+k)!` for `j = 0..MAX_TERMS`.
const fn weights(c: f64, k: usize) -> [f64; MAX_TERMS] {
    let mut f = 1.0;
    let mut i = 1;
    while i <= k {
        f /= i as f64;
        i += 1;
    }
    let mut t = [0.0; MAX_TERMS];
    let mut cp = 1.0;
    let mut j = 0;
    while j < MAX_TERMS {
        t[j] = cp * f;
        cp *= c;
        f /= (j + k + 1) as f64;
        j += 1;
    }
    t
}

/// The stage abscissae `c_2, c_3, c_4` and 1.
pub const C2: f64 = 0.25;
pub const C3: f64 = 0.5;
pub const C4: f64 = 0.9;
pub const W1_C2: [f64; MAX_TERMS] = weights(C2, 1);
const W1_C3: [f64; MAX_TERMS] = weights(C3, 1);
pub const W1_C4: [f64; MAX_TERMS] = weights(C4, 1);
const W1: [f64; MAX_TERMS] = weights(1.0, 1);
pub const W3_C3: [f64; MAX_TERMS] = weights(C3, 3);
const W3_C4: [f64; MAX_TERMS] = weights(C4, 3);
const W3: [f64; MAX_TERMS] = weights(1.0, 3);
pub const W4: [f64; MAX_TERMS] = weights(1.0, 4);

/// The `phi`-function products one step needs, by vector.
pub trait Phi54<const N: usize> {
    /// `phi1(c Z) F` for `c = 1/4, 1/2, 9/10, 1`.
    fn on_f(&self, f: &[f64; N]) -> [[f64; N]; 4];
    /// `phi3(Z/2) d`, `phi3(Z) d`, `phi4(Z) d`.
    fn on_d2(&self, d: &[f64; N]) -> [[f64; N]; 3];
    /// `phi3(9Z/10) d`, `phi3(Z) d`, `phi4(Z) d`.
    fn on_d3(&self, d: &[f64; N]) -> [[f64; N]; 3];
    /// `phi3(Z) d`, `phi4(Z) d`.
    fn on_d4(&self, d: &[f64; N]) -> [[f64; N]; 2];
    /// `J`'s rows 0 and 2 are the unit rows `e_1`, `e_3` (`split::unit_rows`).
    fn unit_rows(&self) -> bool;
}

/// `phi_k(z)`, `k = 0..=4`, of a real scalar for the split: below `cut.z_min` the Taylor
/// series cut at `cut.term` (`split::phi_scalar_cut`), above it `expm1(z)` and the forward
/// recurrence (relative error about `24 eps / |z|^3` in `phi4`, at most `cut.term` there).
#[inline]
fn phi_fast(z: f64, cut: &Cut) -> [f64; 5] {
    if z.abs() < cut.z_min {
        return split::phi_scalar_cut(z, cut.term);
    }
    phi_from_expm1(z, z.exp_m1())
}

/// `phi_k(z)`, `k = 0..=4`, from `e = expm1(z)` by the forward recurrence.
#[inline(always)]
fn phi_from_expm1(z: f64, e: f64) -> [f64; 5] {
    let iz = 1.0 / z;
    let p1 = e * iz;
    let p2 = (p1 - 1.0) * iz;
    let p3 = (p2 - 0.5) * iz;
    let p4 = (p3 - 1.0 / 6.0) * iz;
    [e + 1.0, p1, p2, p3, p4]
}

/// The split `phi`-functions of one step (see `split.rs`).
#[derive(Clone, Copy, Debug)]
pub struct Split54<const N: usize> {
    v: [f64; N],
    w: [f64; N],
    /// `h J_s = h (J - lambda v w^T)`.
    a: [[f64; N]; N],
    /// Taylor terms of the sums.
    terms: usize,
    /// `phi1(c h lambda)`, `c = 1/4, 1/2, 9/10, 1`.
    pub f1: [f64; 4],
    /// `phi3(c h lambda)`, `c = 1/2, 9/10, 1`.
    pub f3: [f64; 3],
    /// `phi4(h lambda)`.
    pub f4: f64,
    unit_rows: bool,
}

impl<const N: usize> Split54<N> {
    /// The split at Jacobian `jac` with its dominant `pair` for the step `h`, the sums cut at
    /// `cut.term`; `None` if `|h J_s|_1` exceeds [`RHO_MAX`].
    #[inline]
    pub fn new(jac: &[[f64; N]; N], pair: &Pair<N>, h: f64, cut: &Cut, unit_rows: bool) -> Option<Self> {
        let &(lambda, v, w) = pair;
        let hl = h * lambda;
        let (a, terms) = split::deflated(jac, pair, h, RHO_MAX, MAX_TERMS, cut.term)?;
        // Where |h lambda / 4| >= z_min, one expm1 serves c = 1/4, 1/2 and 1: `expm1(2z) =
        // e (e + 2)`, `e = expm1(z)` (no cancellation; a few ulps relative per doubling).
        let zq = C2 * hl;
        let (q, hf, o) = if zq.abs() >= cut.z_min {
            let eq = zq.exp_m1();
            let eh = eq * (eq + 2.0);
            (phi_from_expm1(zq, eq), phi_from_expm1(C3 * hl, eh), phi_from_expm1(hl, eh * (eh + 2.0)))
        } else {
            (phi_fast(zq, cut), phi_fast(C3 * hl, cut), phi_fast(hl, cut))
        };
        let n = phi_fast(C4 * hl, cut);
        Some(Self {
            v,
            w,
            a,
            terms,
            f1: [q[1], hf[1], n[1], o[1]],
            f3: [hf[3], n[3], o[3]],
            f4: o[4],
            unit_rows: unit_rows && N == 4,
        })
    }

    /// `sum_j wts[m][j] Z_s^j (y - v w^T y) + fast[m] v (w^T y)` for each output `m`.
    #[inline(always)]
    pub fn apply<const K: usize>(&self, y: &[f64; N], wts: [&[f64; MAX_TERMS]; K], fast: [f64; K]) -> [[f64; N]; K] {
        let c = split::dot(&self.w, y);
        let mut t: [f64; N] = core::array::from_fn(|i| y[i] - c * self.v[i]);
        let mut out = [[0.0; N]; K];
        for j in 0..self.terms {
            if j > 0 {
                t = split::matvec_from(&self.a, &t, -0.0);
            }
            for m in 0..K {
                let wj = wts[m][j];
                for i in 0..N {
                    out[m][i] += wj * t[i];
                }
            }
        }
        for m in 0..K {
            let s = fast[m] * c;
            for i in 0..N {
                out[m][i] += s * self.v[i];
            }
        }
        out
    }
}

impl<const N: usize> Phi54<N> for Split54<N> {
    #[inline(always)]
    fn on_f(&self, f: &[f64; N]) -> [[f64; N]; 4] {
        self.apply(f, [&W1_C2, &W1_C3, &W1_C4, &W1], self.f1)
    }
    #[inline(always)]
    fn on_d2(&self, d: &[f64; N]) -> [[f64; N]; 3] {
        self.apply(d, [&W3_C3, &W3, &W4], [self.f3[0], self.f3[2], self.f4])
    }
    #[inline(always)]
    fn on_d3(&self, d: &[f64; N]) -> [[f64; N]; 3] {
        self.apply(d, [&W3_C4, &W3, &W4], [self.f3[1], self.f3[2], self.f4])
    }
    #[inline(always)]
    fn on_d4(&self, d: &[f64; N]) -> [[f64; N]; 2] {
        self.apply(d, [&W3, &W4], [self.f3[2], self.f4])
    }
    #[inline(always)]
    fn unit_rows(&self) -> bool {
        self.unit_rows
    }
}

/// The full matrix functions of one step (columns, as `exprb.rs`).
#[derive(Clone, Copy, Debug)]
pub struct Full54<const N: usize> {
    /// `phi1(c Z)`, `c = 1/4, 1/2, 9/10, 1`.
    p1: [Cols<N>; 4],
    /// `phi3(c Z)`, `c = 1/2, 9/10, 1`.
    p3: [Cols<N>; 3],
    /// `phi4(Z)`.
    p4: Cols<N>,
}

impl<const N: usize> Full54<N> {
    /// `None` if `h J` is not finite or too large to scale.
    #[inline(never)]
    pub fn new(jac: &[[f64; N]; N], h: f64) -> Option<Self> {
        let scaled = |s: f64| -> Cols<N> { core::array::from_fn(|j| core::array::from_fn(|i| s * jac[i][j])) };
        // phi_k(Z/4) (the level before the last doubling of Z/2), then Z/2 and Z.
        // The levels before the last are bit for bit the full products' (the sparse layout's
        // too); the doublings here take the full products (for any level, finite or not).
        let (q, _) = exprb::phis_before_last(&scaled(0.5 * h))?;
        let hf = exprb::double::<N, false>(&q);
        let o = exprb::double::<N, false>(&hf);
        let n = exprb::double::<N, false>(&exprb::phis_before_last(&scaled(C4 * h))?.0);
        Some(Self { p1: [q[1], hf[1], n[1], o[1]], p3: [hf[3], n[3], o[3]], p4: o[4] })
    }
}

#[inline(always)]
fn mv<const N: usize>(m: &Cols<N>, x: &[f64; N]) -> [f64; N] {
    let mut s = [0.0; N];
    for j in 0..N {
        for i in 0..N {
            s[i] += m[j][i] * x[j];
        }
    }
    s
}

impl<const N: usize> Phi54<N> for Full54<N> {
    fn on_f(&self, f: &[f64; N]) -> [[f64; N]; 4] {
        self.p1.map(|m| mv(&m, f))
    }
    fn on_d2(&self, d: &[f64; N]) -> [[f64; N]; 3] {
        [mv(&self.p3[0], d), mv(&self.p3[2], d), mv(&self.p4, d)]
    }
    fn on_d3(&self, d: &[f64; N]) -> [[f64; N]; 3] {
        [mv(&self.p3[1], d), mv(&self.p3[2], d), mv(&self.p4, d)]
    }
    fn on_d4(&self, d: &[f64; N]) -> [[f64; N]; 2] {
        [mv(&self.p3[2], d), mv(&self.p4, d)]
    }
    fn unit_rows(&self) -> bool {
        false
    }
}

/// One `exprb54s4` step of size `h` from `y` with `f0 = f(y)`, Jacobian `jac` and its
/// `phi`-functions `ph`. `rhs` evaluates `f` (called three times). Returns the order-5 state
/// and the error estimate (it minus the embedded order-4 state).
#[inline]
pub fn step<const N: usize, P: Phi54<N>>(
    rhs: &mut impl FnMut(&[f64; N]) -> [f64; N],
    jac: &[[f64; N]; N],
    ph: &P,
    y: &[f64; N],
    f0: &[f64; N],
    h: f64,
) -> ([f64; N], [f64; N]) {
    let unit_rows = ph.unit_rows();
    let remainder = |fu: [f64; N], du: &[f64; N]| split::remainder(jac, unit_rows, f0, fu, du);
    let [pf2, pf3, pf4, pf1] = ph.on_f(f0);
    let du2: [f64; N] = core::array::from_fn(|i| (C2 * h) * pf2[i]);
    let u2: [f64; N] = core::array::from_fn(|i| y[i] + du2[i]);
    let d2 = remainder(rhs(&u2), &du2);
    let [a3c, a3, a4] = ph.on_d2(&d2);
    let du3: [f64; N] = core::array::from_fn(|i| (C3 * h) * pf3[i] + (4.0 * h) * a3c[i]);
    let u3: [f64; N] = core::array::from_fn(|i| y[i] + du3[i]);
    let d3 = remainder(rhs(&u3), &du3);
    let [b3c, b3, b4] = ph.on_d3(&d3);
    let du4: [f64; N] = core::array::from_fn(|i| (C4 * h) * pf4[i] + (729.0 / 125.0 * h) * b3c[i]);
    let u4: [f64; N] = core::array::from_fn(|i| y[i] + du4[i]);
    let d4 = remainder(rhs(&u4), &du4);
    let [c3, c4] = ph.on_d4(&d4);
    let err: [f64; N] = core::array::from_fn(|i| {
        h * ((-64.0 * a3[i] + 26.0 * b3[i] - 250.0 / 81.0 * c3[i])
            + (60.0 * a4[i] - 195.0 / 8.0 * b4[i] + 625.0 / 216.0 * c4[i]))
    });
    let y1: [f64; N] = core::array::from_fn(|i| {
        y[i] + h * pf1[i] + h * ((18.0 * b3[i] - 250.0 / 81.0 * c3[i]) + (-60.0 * b4[i] + 500.0 / 27.0 * c4[i]))
    });
    (y1, err)
}
