//! One step of `exprb43`, the exponential Rosenbrock method of order 4 with an embedded
//! order-3 solution (Hochbruck, Ostermann & Schweitzer, "Exponential Rosenbrock-type
//! methods", SIAM J. Numer. Anal. 47(1):786-803, 2009, doi:10.1137/080717717; also
//! Hochbruck & Ostermann, "Exponential integrators", Acta Numerica 19:209-286, 2010, sec. 2.4).
//!
//! For the autonomous `y' = f(y)` (the input is a parameter held over the step) with
//! `J = f'(y_n)` and the remainder `g(y) = f(y) - J y`, write `D(U) = g(U) - g(y_n) =
//! f(U) - f(y_n) - J (U - y_n)`. Then
//!
//! ```text
//! U2 = y_n + (h/2) phi1(hJ/2) f(y_n)
//! U3 = y_n + h phi1(hJ) (f(y_n) + D(U2))
//! y_{n+1} = y_n + h phi1(hJ) f(y_n) + h phi3(hJ) (16 D2 - 2 D3) + h phi4(hJ) (-48 D2 + 12 D3)
//! ```
//!
//! and the embedded order-3 solution drops the `phi4` term, so the error estimate is
//! `h phi4(hJ) (12 D3 - 48 D2)`. The linear part (the stiff, nearly linear transient of the
//! Furuta pendulum after an input jump) is integrated exactly: `D` vanishes on a linear
//! right-hand side, and the step is `y_n + h phi1(hJ) f(y_n)`, the exact flow.
//!
//! The `phi_k(hJ)` matrices (`phi0 = exp`, `phi_{k}(z) = (phi_{k-1}(z) - 1/(k-1)!)/z`) come
//! from scaling and squaring: a Taylor polynomial of `phi4` at `X = hJ/2^s` (Horner), the
//! recurrence `phi_{k-1}(X) = I/(k-1)! + X phi_k(X)` down to `exp`, then `s` doublings with
//! `phi_k(2X) = 2^-k [exp(X) phi_k(X) + sum_{j=1..k} phi_j(X)/(k-j)!]` (Skaflestad & Wright,
//! "The scaling and modified squaring method for matrix functions related to the exponential",
//! Appl. Numer. Math. 59:783-799, 2009). The doubling before the last gives `phi1(hJ/2)` for
//! the first stage at no extra cost. All matrices are `N x N` on the stack.

use nalgebra::{SMatrix, SVector};

/// Taylor degree of `phi4` at the scaled argument; `exp` then carries degree `DEG + 4`.
const DEG: usize = 10;
/// Largest 1-norm of the scaled argument: the truncation of `exp` is below
/// `THETA^15/15! = 2.3e-17` there.
const THETA: f64 = 0.5;
/// More doublings than this means `|hJ|_1 > 0.5 * 2^60`: treat as a blow-up.
const MAX_DOUBLINGS: i32 = 60;

type M<const N: usize> = SMatrix<f64, N, N>;
type V<const N: usize> = SVector<f64, N>;

/// `phi1(hJ/2)`, `phi1(hJ)`, `phi3(hJ)`, `phi4(hJ)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Phis<const N: usize> {
    pub p1_half: M<N>,
    pub p1: M<N>,
    pub p3: M<N>,
    pub p4: M<N>,
}

/// `1/k!` for `k = 0..=DEG+4`.
const INV_FACT: [f64; DEG + 5] = {
    let mut t = [1.0; DEG + 5];
    let mut k = 1;
    while k < DEG + 5 {
        t[k] = t[k - 1] / k as f64;
        k += 1;
    }
    t
};

/// All `phi_k(a)`, `k = 0..=4`, of a matrix `a`, plus `phi1(a/2)`. `None` if `a` is not
/// finite or too large to scale.
pub(crate) fn phis_of<const N: usize>(a: &M<N>) -> Option<(M<N>, [M<N>; 5])> {
    if a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // 1-norm: largest absolute column sum.
    let mut norm = 0.0f64;
    for c in a.column_iter() {
        norm = norm.max(c.iter().map(|v| v.abs()).sum());
    }
    if !norm.is_finite() {
        return None;
    }
    // At least one doubling, so that the level before the last is phi(a/2).
    let s = if norm > THETA { (norm / THETA).log2().ceil() as i32 } else { 1 }.max(1);
    if s > MAX_DOUBLINGS {
        return None;
    }
    let x = a * 0.5f64.powi(s);
    let id = M::<N>::identity();
    // phi4(x) = sum_{j=0..DEG} x^j / (j+4)!
    let mut p4 = id * INV_FACT[DEG + 4];
    for j in (0..DEG).rev() {
        p4 = id * INV_FACT[j + 4] + x * p4;
    }
    let p3 = id * INV_FACT[3] + x * p4;
    let p2 = id * INV_FACT[2] + x * p3;
    let p1 = id + x * p2;
    let e = id + x * p1;
    let mut p = [e, p1, p2, p3, p4];
    let mut half = p[1];
    for level in 0..s {
        if level == s - 1 {
            half = p[1];
        }
        p = double(&p);
    }
    Some((half, p))
}

/// `phi_k(2X)` from `phi_k(X)`, `k = 0..=4`.
#[inline]
fn double<const N: usize>(p: &[M<N>; 5]) -> [M<N>; 5] {
    let [e, p1, p2, p3, p4] = p;
    let e2 = e * e;
    let q1 = (e * p1 + p1) * 0.5;
    let q2 = (e * p2 + p1 + p2) * 0.25;
    let q3 = (e * p3 + p1 * 0.5 + p2 + p3) * 0.125;
    let q4 = (e * p4 + p1 * INV_FACT[3] + p2 * 0.5 + p3 + p4) * 0.0625;
    [e2, q1, q2, q3, q4]
}

/// The matrix functions one `exprb43` step of size `h` needs, at Jacobian `jac`.
#[inline]
pub(crate) fn phis<const N: usize>(jac: &[[f64; N]; N], h: f64) -> Option<Phis<N>> {
    let a = M::<N>::from_fn(|i, j| h * jac[i][j]);
    let (p1_half, p) = phis_of(&a)?;
    let [_, p1, _, p3, p4] = p;
    Some(Phis { p1_half, p1, p3, p4 })
}

#[inline(always)]
fn v<const N: usize>(x: &[f64; N]) -> V<N> {
    V::<N>::from_column_slice(x)
}

#[inline(always)]
fn arr<const N: usize>(x: &V<N>) -> [f64; N] {
    core::array::from_fn(|i| x[i])
}

/// One `exprb43` step of size `h` from `y` with `f0 = f(y)`, Jacobian `jac` and its `phis`.
/// `rhs` evaluates `f` (called twice). Returns the new state and the error estimate (new
/// state minus the embedded order-3 state).
#[inline]
pub(crate) fn step<const N: usize>(
    rhs: &mut impl FnMut(&[f64; N]) -> [f64; N],
    jac: &[[f64; N]; N],
    phis: &Phis<N>,
    y: &[f64; N],
    f0: &[f64; N],
    h: f64,
) -> ([f64; N], [f64; N]) {
    let j = M::<N>::from_fn(|r, c| jac[r][c]);
    let yv = v(y);
    let fv = v(f0);
    // D(U) = f(U) - f0 - J (U - y), with U - y passed as `du`.
    let mut remainder = |du: &V<N>| -> V<N> {
        let u = arr(&(yv + du));
        v(&rhs(&u)) - fv - j * du
    };
    let du2 = phis.p1_half * fv * (0.5 * h);
    let d2 = remainder(&du2);
    let lin = phis.p1 * fv * h;
    let du3 = lin + phis.p1 * d2 * h;
    let d3 = remainder(&du3);
    let err = phis.p4 * (d3 * 12.0 - d2 * 48.0) * h;
    let y1 = yv + lin + phis.p3 * (d2 * 16.0 - d3 * 2.0) * h + err;
    (arr(&y1), arr(&err))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `phi_k(a)` for diagonalizable `a` with real eigenvalues via `V phi_k(Lambda) V^-1`,
    /// the scalar `phi_k` from its series (small |z|) or its closed form.
    fn phi_scalar(k: usize, z: f64) -> f64 {
        if z.abs() < 0.1 {
            (0..30).map(|j| z.powi(j as i32) * INV_FACT_LONG(j + k)).sum()
        } else {
            // phi_k(z) = (e^z - sum_{j<k} z^j/j!) / z^k
            let mut s = z.exp();
            for j in 0..k {
                s -= z.powi(j as i32) * INV_FACT_LONG(j);
            }
            s / z.powi(k as i32)
        }
    }

    #[allow(non_snake_case)]
    fn INV_FACT_LONG(k: usize) -> f64 {
        (1..=k).fold(1.0, |a, i| a / i as f64)
    }

    #[test]
    fn phi_functions_of_a_stiff_non_normal_matrix_match_eigendecomposition() {
        // A = V diag(lambda) V^-1 with eigenvalues spread like the Furuta Jacobian times a
        // period (-1.56e4, -11.1, 0, 4.39) * 30.8 ms and an ill-conditioned V (entries up to 1e3).
        let lam = [-1.56e4 * 0.0308, -11.1 * 0.0308, 0.0, 4.39 * 0.0308];
        let vm = M::<4>::new(
            1.0, 0.3, 0.0, 2.0, //
            -4.0e2, 1.0, 0.5, 1.0, //
            0.0, 0.2, 1.0, -0.7, //
            1.0e3, -3.0, 0.1, 1.0,
        );
        let vinv = vm.try_inverse().unwrap();
        let a = vm * M::<4>::from_diagonal(&V::<4>::from_column_slice(&lam)) * vinv;
        assert!(a.abs().max() > 1e3, "not non-normal enough: {}", a.abs().max());
        let (half, p) = phis_of(&a).unwrap();
        for (k, got) in p.iter().enumerate() {
            let d = V::<4>::from_fn(|i, _| phi_scalar(k, lam[i]));
            let want = vm * M::<4>::from_diagonal(&d) * vinv;
            let err = (got - want).abs().max() / want.abs().max();
            // The reference itself carries cond(V) * eps ~ 1e-12.
            assert!(err < 1e-11, "phi_{k}: relative error {err:e}");
        }
        let d = V::<4>::from_fn(|i, _| phi_scalar(1, 0.5 * lam[i]));
        let want = vm * M::<4>::from_diagonal(&d) * vinv;
        let err = (half - want).abs().max() / want.abs().max();
        assert!(err < 1e-11, "phi_1(A/2): relative error {err:e}");
    }

    #[test]
    fn phi_functions_of_a_rotation_match_closed_form() {
        // a = [[0, w], [-w, 0]]: exp = rotation, phi1 = (exp - I) a^-1.
        let w = 7.5;
        let a = SMatrix::<f64, 2, 2>::new(0.0, w, -w, 0.0);
        let (_, p) = phis_of(&a).unwrap();
        let e = SMatrix::<f64, 2, 2>::new(w.cos(), w.sin(), -w.sin(), w.cos());
        assert!((p[0] - e).abs().max() < 1e-13, "{}", p[0]);
        let p1 = (e - SMatrix::<f64, 2, 2>::identity()) * a.try_inverse().unwrap();
        assert!((p[1] - p1).abs().max() < 1e-13, "{}", p[1]);
    }

    #[test]
    fn non_finite_or_huge_argument_is_refused() {
        let mut a = M::<4>::zeros();
        a[(1, 2)] = f64::NAN;
        assert!(phis_of(&a).is_none());
        // Beyond 2^60 * THETA in norm: more doublings than allowed.
        a[(1, 2)] = 1e30;
        assert!(phis_of(&a).is_none());
        a[(1, 2)] = 1e3;
        assert!(phis_of(&a).is_some());
    }
}
