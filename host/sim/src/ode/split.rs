//! The `phi`-functions of `exprb43` applied to vectors with the fast mode split off: when the
//! Jacobian `J` has one real eigenvalue `lambda` far larger in modulus than all others (the
//! Furuta pendulum's back-EMF mode, about -1.5e4 1/s against -11, 0 and +4.4 1/s), the
//! spectral projector `P = v w^T` (`J v = lambda v`, `w^T J = lambda w^T`, `w^T v = 1`) splits
//!
//! ```text
//! phi_k(hJ) y = phi_k(h lambda) v (w^T y) + phi_k(h J_s) (y - v (w^T y)),   J_s = J - lambda v w^T
//! ```
//!
//! exactly (`P` commutes with `J`, and `J_s` equals `J` on the range of `I - P`). The scalar
//! `phi_k(h lambda)` take a few flops at any `|h lambda|`; `h J_s` has a small norm (the slow
//! eigenvalues, the coupling), so `phi_k(h J_s)` applied to a vector is a short Taylor sum of
//! matrix-vector products: no matrix exponential, no scaling and squaring, no matrix products.
//! A step costs a few hundred flops instead of the ~3,000 of the matrix functions at the steps
//! the pendulum takes.
//!
//! The pair comes from power iteration on `J` and `J^T` (convergence factor
//! `|lambda_2 / lambda_1|`, about 1e-3 here), checked by its residuals (`exprb-lean`: from the
//! last step's pair, in closed form where `J` has the second-order layout of a state `(q, q')`,
//! by Rayleigh quotient iteration otherwise; [`dominant_pair_lean`]). Where there is no such
//! dominant eigenvalue, or `h J_s` is too large for the Taylor sum, [`Split::new`] returns
//! `None` and the caller uses the full matrix functions ([`super::exprb::phis`]).

/// Power iterations at most (each one matrix-vector product on `J` and one on `J^T`).
const MAX_POWER_ITERS: usize = 12;
/// Largest relative eigen-residual `|J v - lambda v| / (|lambda| |v|)` accepted (inf norms):
/// an eigenvector error `eps` perturbs the result by about `|h lambda| eps` relative.
const PAIR_TOL: f64 = 1e-14;
/// Largest 1-norm of `h J_s` handled by the Taylor sums.
const RHO_MAX: f64 = 1.0;
/// Taylor terms at most: `RHO_MAX^j / (j+1)!` is below `1e-18` from `j = 18` on.
const MAX_TERMS: usize = 19;
/// Bound on the first dropped Taylor term relative to the vector the sum is applied to.
const TERM_TOL: f64 = 1e-18;

/// `1/k!` for `k = 0..=29`.
const INV_FACT: [f64; 30] = {
    let mut t = [1.0; 30];
    let mut k = 1;
    while k < 30 {
        t[k] = t[k - 1] / k as f64;
        k += 1;
    }
    t
};

/// `phi_k(z)`, `k = 0..=4`, of a real scalar: for `|z| < 2` the Taylor series of `phi_4`
/// (to a term below `cut` of the first, `1e-18` for full precision, a cut tied to the step's
/// tolerance in `exprb-lean`; at most 25 terms) and the stable backward recurrence
/// `phi_{k-1} = 1/(k-1)! + z phi_k`; otherwise `exp(z)` and the forward recurrence
/// `phi_k = (phi_{k-1} - 1/(k-1)!)/z`, which loses at most a factor `k/|z| <= 2.5` per level
/// there.
#[inline]
pub fn phi_scalar_cut(z: f64, cut: f64) -> [f64; 5] {
    let mut p = [0.0; 5];
    let a = z.abs();
    if a < 2.0 {
        // Degree n: |z|^(n+1) / (n+5)! below cut / 24.
        let mut n = 0;
        let mut t = INV_FACT[4];
        while n < 24 {
            t *= a / (n + 5) as f64;
            if t < cut * INV_FACT[4] {
                break;
            }
            n += 1;
        }
        let mut s = INV_FACT[4 + n];
        for j in (0..n).rev() {
            s = INV_FACT[j + 4] + z * s;
        }
        p[4] = s;
        for k in (0..4).rev() {
            p[k] = INV_FACT[k] + z * p[k + 1];
        }
    } else {
        p[0] = z.exp();
        for k in 1..5 {
            p[k] = (p[k - 1] - INV_FACT[k - 1]) / z;
        }
    }
    p
}

/// `phi_k(z)`, `k = 0..=4`, and `phi_1(z/2)`, with one exponential where `|z| >= 4`; the
/// series cut of [`phi_scalar_cut`].
#[inline]
pub fn phi_scalar_and_half_cut(z: f64, cut: f64) -> ([f64; 5], f64) {
    let half = 0.5 * z;
    if half.abs() < 2.0 {
        return (phi_scalar_cut(z, cut), phi_scalar_cut(half, cut)[1]);
    }
    let eh = half.exp();
    let mut p = [0.0; 5];
    p[0] = eh * eh;
    for k in 1..5 {
        p[k] = (p[k - 1] - INV_FACT[k - 1]) / z;
    }
    (p, (eh - 1.0) / half)
}

/// `exprb-lean`'s accuracy knobs, from its relative tolerance.
#[derive(Clone, Copy, Debug)]
pub struct Cut {
    /// Taylor sums stop at a first dropped term below `term` (relative).
    pub term: f64,
    /// Scalar `phi`-functions from `expm1` at `|z| >= z_min`, from their Taylor series below.
    pub(crate) z_min: f64,
}

impl Cut {
    /// `term = 1e-3 rtol` (within `[1e-18, 1e-6]`); `z_min` where the forward recurrence from
    /// `phi_1 = expm1(z)/z` (relative error about `24 eps / |z|^3` in `phi_4`) reaches `term`.
    pub fn for_rtol(rtol: f64) -> Self {
        let term = (1e-3 * rtol).clamp(1e-18, 1e-6);
        Self { term, z_min: (24.0 * f64::EPSILON / term).cbrt().min(2.0) }
    }
}

/// `phi_k(z)`, `k = 0..=4`, and `phi_1(z/2)` for `exprb-lean`: below `cut.z_min` the Taylor
/// series (cut at `cut.term`); above, one `expm1(z/2)`: `phi_1(z/2) = expm1(z/2)/(z/2)`,
/// `expm1(z) = e (e + 2)` with `e = expm1(z/2)` (no cancellation), `phi_1 = expm1(z)/z`, and
/// the forward recurrence for `phi_2..phi_4`. `phi_0 = (1 + e)^2`, which the step does not
/// use, carries an absolute (not relative) error of a few `eps` where `e^z` is tiny.
#[inline]
pub fn phi_lean(z: f64, cut: &Cut) -> ([f64; 5], f64) {
    if z.abs() < cut.z_min {
        return (phi_scalar_cut(z, cut.term), phi_scalar_cut(0.5 * z, cut.term)[1]);
    }
    let half = 0.5 * z;
    let e = half.exp_m1();
    let e1 = e * (e + 2.0);
    let iz = 1.0 / z;
    let p1 = e1 * iz;
    let p2 = (p1 - 1.0) * iz;
    let p3 = (p2 - 0.5) * iz;
    let p4 = (p3 - INV_FACT[3]) * iz;
    let eh = e + 1.0;
    ([eh * eh, p1, p2, p3, p4], e / half)
}

#[inline(always)]
pub fn matvec<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    matvec_from(a, x, 0.0)
}

/// `a x` with each row's sum started from `s0`: `0.0` for [`matvec`]; `-0.0` for the Taylor
/// sums of [`Split::apply`]. `-0.0` is the identity of `+` (`-0.0 + x` is `x` for every `x`,
/// so the compiler drops it), `+0.0` is not (`+0.0 + -0.0` is `+0.0`): one dependent add
/// fewer per term on the step's critical path. The two can differ only in the sign of an exact
/// zero component of `t`, which no output sees: `t` goes only into further products and into
/// sums that start from `+0.0` (`out`), where a zero of either sign leaves the sum as it is.
#[inline(always)]
pub(crate) fn matvec_from<const N: usize>(a: &[[f64; N]; N], x: &[f64; N], s0: f64) -> [f64; N] {
    core::array::from_fn(|i| {
        let mut s = s0;
        for j in 0..N {
            s += a[i][j] * x[j];
        }
        s
    })
}

/// [`matvec`] for a Jacobian with [`unit_rows`] (`N = 4`): rows 0 and 2 as `0.0 + x_1`,
/// `0.0 + x_3`. For finite `x` that is `matvec`'s sum bit for bit (each `0 x_j` is `+-0` and
/// leaves the running sum, never `-0`, as it is; see [`checked_pair_furuta`]). For `x` with a
/// non-finite component `x_k` the two differ (`0 x_k` is NaN), but [`step`]'s trial is then
/// non-finite in every component either way: rows 1 and 3 hold `J_1k x_k` (NaN or infinite,
/// also for `J_1k = 0`), so the remainder's component 1 is, and with it `w^T d`, every Taylor
/// term and the new state; the driver rejects the trial the same way.
#[inline(always)]
pub fn matvec_unit_rows<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    let mut s = matvec(a, x);
    (s[0], s[2]) = (0.0 + x[1], 0.0 + x[3]);
    s
}

#[inline(always)]
pub fn matvec_t<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    let mut s = [0.0; N];
    for i in 0..N {
        for j in 0..N {
            s[j] += a[i][j] * x[i];
        }
    }
    s
}

#[inline(always)]
pub fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    let mut s = 0.0;
    for i in 0..N {
        s += a[i] * b[i];
    }
    s
}

/// `v` and `w` scaled to unit inf-norm; `None` if either is zero or not finite.
fn normalized_pair<const N: usize>(v: &[f64; N], w: &[f64; N]) -> Option<([f64; N], [f64; N])> {
    let nv = norm_inf(v);
    let nw = norm_inf(w);
    if !(nv > 0.0 && nw > 0.0 && nv.is_finite() && nw.is_finite()) {
        return None;
    }
    let (iv, iw) = (1.0 / nv, 1.0 / nw);
    Some((v.map(|x| x * iv), w.map(|x| x * iw)))
}

#[inline(always)]
pub fn norm_inf<const N: usize>(a: &[f64; N]) -> f64 {
    a.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// `(lambda, v, w)`: a dominant eigenvalue with its right and left eigenvectors, `w^T v = 1`.
pub type Pair<const N: usize> = (f64, [f64; N], [f64; N]);

/// The dominant eigenpair of `J`: `(lambda, v, w)` with `J v = lambda v`, `w^T J = lambda w^T`,
/// `w^T v = 1`, or `None` if power iteration does not converge to `PAIR_TOL` (no single real
/// eigenvalue dominating) or the pair is ill-conditioned. `start` (the pair of a nearby
/// Jacobian, e.g. the previous step's) seeds the iteration; without it, the largest column and
/// row of `J` do.
pub fn dominant_pair<const N: usize>(jac: &[[f64; N]; N], start: Option<&Pair<N>>) -> Option<Pair<N>> {
    power_iteration(jac, start, 2, PAIR_TOL)
}

/// `exprb-lean`'s eigenpair: two-sided Rayleigh quotient iteration from a warm start (the
/// previous step's pair). The shift is the Rayleigh quotient `w^T J v / w^T v` of the start at
/// the new Jacobian (its error is the product of the vectors' errors), then of the improved
/// pair; each iteration solves `(J - mu I) v' = v` and `(J - mu I)^T w' = w` with one LU.
/// From the last step's pair (on the Furuta bench the left vector is further off than the
/// right) the first iteration leaves the right vector at rounding and the left one close to
/// it, the second both at rounding; the residual test `tol` (relative, as `PAIR_TOL`) is
/// applied after each. Power iteration takes more iterations. The pair found is an eigenpair
/// of `J` checked by its residuals (the split is exact for any eigenpair; a pair that is not
/// the dominant one shows as a large `|h J_s|` and the step falls back). Where the Jacobian has
/// the second-order layout of a state `(q, q')` (the Furuta and cart plants), the pair comes
/// first in closed form from the start's eigenvalue ([`second_order_pair`]: Newton on a quartic,
/// the same residual test; fewer instructions a step than the Rayleigh quotient iteration,
/// callgrind on a basin run, `simspeed exprb-filtered 3e-11 3000 1 noref 1 furuta-dt30.5
/// 0.02 31.5`) and the Rayleigh quotient
/// iteration only where it fails. Without a start, or if both fail, power iteration from the
/// cold start ([`dominant_pair`] with `tol`).
pub fn dominant_pair_lean<const N: usize>(jac: &[[f64; N]; N], start: Option<&Pair<N>>, tol: f64) -> Option<Pair<N>> {
    dominant_pair_lean_with(jac, start, tol, unit_rows(jac))
}

/// [`dominant_pair_lean`] with `unit_rows(jac)` known to the caller ([`unit_rows`], once per
/// Jacobian: the layout test of [`second_order_layout`] then passes without a comparison).
#[inline]
pub(crate) fn dominant_pair_lean_with<const N: usize>(
    jac: &[[f64; N]; N],
    start: Option<&Pair<N>>,
    tol: f64,
    unit_rows: bool,
) -> Option<Pair<N>> {
    start
        .and_then(|s| second_order_pair(jac, s, tol, unit_rows).or_else(|| rayleigh_iteration(jac, s, tol)))
        .or_else(|| power_iteration(jac, None, 2, tol))
}

/// Newton iterations on the quartic of [`second_order_pair`] at most.
const MAX_NEWTON_ITERS: usize = 8;
/// Newton stops after a correction below this (relative): the root's error is then about
/// `3 d^2` (quadratic convergence at a root about `|lambda|` from the others), below rounding.
/// From the last step's eigenvalue two iterations usually suffice.
const NEWTON_TOL: f64 = 1e-8;

/// The second-order layout of a 4-state Jacobian: `[(p0, v0), (p1, v1)]` with rows `p0`, `p1`
/// exactly the unit rows `e_v0`, `e_v1` (`d x_p / dt = x_v`: a position and its velocity) and
/// `{p0, p1, v0, v1} = {0, 1, 2, 3}`; `None` for any other `N` or Jacobian. Read from the
/// exact zeros and ones that both the dual-number Jacobian and a closed form give for a state
/// `(q, q')` (the Furuta and cart plants: `(theta, w_theta, phi, w_phi)`, rows 0 and 2).
pub fn second_order_layout<const N: usize>(jac: &[[f64; N]; N]) -> Option<[(usize, usize); 2]> {
    if N != 4 {
        return None;
    }
    let unit = |row: &[f64; N], k: usize| row.iter().enumerate().all(|(j, &x)| x == if j == k { 1.0 } else { 0.0 });
    // The Furuta and cart plants' layout first (8 comparisons), then any other.
    if unit(&jac[0], 1) && unit(&jac[2], 3) {
        return Some([(0, 1), (2, 3)]);
    }
    // The column of row i's single exact 1 (all else exactly 0), N if none.
    let target = |row: &[f64; N]| -> usize {
        let mut k = N;
        for (j, &x) in row.iter().enumerate() {
            if x == 1.0 && k == N {
                k = j;
            } else if x != 0.0 {
                return N;
            }
        }
        k
    };
    let t: [usize; N] = core::array::from_fn(|i| target(&jac[i]));
    for p0 in 0..N {
        for p1 in p0 + 1..N {
            let (v0, v1) = (t[p0], t[p1]);
            if v0 < N && v1 < N && v0 != v1 && v0 != p0 && v0 != p1 && v1 != p0 && v1 != p1 {
                return Some([(p0, v0), (p1, v1)]);
            }
        }
    }
    None
}

/// `exprb-lean`'s eigenpair where the Jacobian has the second-order layout
/// ([`second_order_layout`]): `J = [[0, I], [A, B]]` in (positions, velocities), so
/// `J v = lambda v` is `v = (q, lambda q)` with `M(lambda) q = 0`, `M(lambda) = lambda^2 I -
/// lambda B - A` (2x2), and `w^T J = lambda w^T` is `w = (A^T r / lambda, r)` with `r^T M(lambda)
/// = 0`. `lambda` is the root of the quartic `det M` by Newton from the start's eigenvalue
/// (quadratic convergence; a root more than half the start's modulus away is refused), `q` and
/// `r` the null vectors of `M` from its larger row and column. The pair then passes the same
/// test as [`rayleigh_iteration`]'s (each vector scaled to inf-norm 1, the two-sided Rayleigh
/// quotient as `lambda`, both residuals below `tol |lambda|`), or `None`: the caller falls back
/// to the Rayleigh quotient iteration.
pub fn second_order_pair<const N: usize>(
    jac: &[[f64; N]; N],
    start: &Pair<N>,
    tol: f64,
    unit_rows: bool,
) -> Option<Pair<N>> {
    let [(p0, v0), (p1, v1)] = if unit_rows && N == 4 { [(0, 1), (2, 3)] } else { second_order_layout(jac)? };
    let (a11, a12, a21, a22) = (jac[v0][p0], jac[v0][p1], jac[v1][p0], jac[v1][p1]);
    let (b11, b12, b21, b22) = (jac[v0][v0], jac[v0][v1], jac[v1][v0], jac[v1][v1]);
    let m = |l: f64| [l * (l - b11) - a11, -(l * b12 + a12), -(l * b21 + a21), l * (l - b22) - a22];
    let l0 = start.0;
    let mut l = l0;
    let mut converged = false;
    for _ in 0..MAX_NEWTON_ITERS {
        let [m11, m12, m21, m22] = m(l);
        let p = m11 * m22 - m12 * m21;
        let dp = (2.0 * l - b11) * m22 + m11 * (2.0 * l - b22) + b12 * m21 + m12 * b21;
        let d = p / dp;
        l -= d;
        if !l.is_finite() {
            return None;
        }
        if d.abs() <= NEWTON_TOL * l.abs() {
            converged = true;
            break;
        }
    }
    if !(converged && l != 0.0 && (l - l0).abs() <= 0.5 * l0.abs()) {
        return None;
    }
    let [m11, m12, m21, m22] = m(l);
    // Right null vector from the larger row, left from the larger column.
    let (q0, q1) = if m11.abs().max(m12.abs()) >= m21.abs().max(m22.abs()) { (m12, -m11) } else { (m22, -m21) };
    let (r0, r1) = if m11.abs().max(m21.abs()) >= m12.abs().max(m22.abs()) { (m21, -m11) } else { (m22, -m12) };
    let il = 1.0 / l;
    let mut v = [0.0; N];
    let mut w = [0.0; N];
    (v[p0], v[p1], v[v0], v[v1]) = (q0, q1, l * q0, l * q1);
    (w[p0], w[p1], w[v0], w[v1]) = ((a11 * r0 + a21 * r1) * il, (a12 * r0 + a22 * r1) * il, r0, r1);
    let (v, w) = normalized_pair(&v, &w)?;
    if N == 4 && [(p0, v0), (p1, v1)] == [(0, 1), (2, 3)] {
        return checked_pair_furuta(jac, &v, &w, tol).ok();
    }
    checked_pair(jac, &v, &w, tol).ok()
}

/// [`checked_pair`] for a Jacobian with the Furuta and cart plants' layout (rows 0 and 2 the
/// unit rows `e_1`, `e_3`, [`second_order_layout`]) and finite `v`, `w` (as
/// `normalized_pair` gives): the same result bit for bit, the products with the exact zeros
/// and ones left out. In `matvec`'s and `matvec_t`'s sums, which start from `+0.0` and add in
/// row (column) order, a term `0 x` is `+-0` for finite `x` and leaves the running sum as it
/// is (the sum is never `-0`: `+0.0 + a` is `+0` for `a = -0`, and `+0 + -0 = +0`), and a term
/// `1 x` is `x`; so `(J v)_0 = 0.0 + v_1`, `(J^T w)_1 = ((0.0 + w_0) + J_11 w_1) + J_31 w_3`,
/// and so on. Checked against [`checked_pair`] in the tests.
#[inline]
pub fn checked_pair_furuta<const N: usize>(
    jac: &[[f64; N]; N],
    v: &[f64; N],
    w: &[f64; N],
    tol: f64,
) -> Result<Pair<N>, Option<f64>> {
    let wv = dot(w, v);
    if !(wv.abs() > 1e-8) {
        return Err(None);
    }
    let row = |i: usize| {
        let mut s = 0.0;
        for j in 0..N {
            s += jac[i][j] * v[j];
        }
        s
    };
    let mut jv = [0.0; N];
    (jv[0], jv[1], jv[2], jv[3]) = (0.0 + v[1], row(1), 0.0 + v[3], row(3));
    let lambda = dot(w, &jv) / wv;
    let (j1, j3) = (&jac[1], &jac[3]);
    let mut jw = [0.0; N];
    (jw[0], jw[1], jw[2], jw[3]) = (
        (0.0 + j1[0] * w[1]) + j3[0] * w[3],
        ((0.0 + w[0]) + j1[1] * w[1]) + j3[1] * w[3],
        (0.0 + j1[2] * w[1]) + j3[2] * w[3],
        ((0.0 + j1[3] * w[1]) + w[2]) + j3[3] * w[3],
    );
    residual_verdict(lambda, v, w, wv, &jv, &jw, tol)
}

/// The acceptance test of [`rayleigh_iteration`] and [`second_order_pair`] for `v` and `w` of
/// inf-norm 1: `lambda = w^T J v / w^T v`, then `Ok((lambda, v, w / (w^T v)))` if both
/// residuals `|J v - lambda v|`, `|J^T w - lambda w|` (inf norms) are at most `tol |lambda|`;
/// `Err(Some(lambda))` if not, `Err(None)` if `|w^T v| <= 1e-8` (nearly orthogonal vectors).
#[inline]
pub fn checked_pair<const N: usize>(
    jac: &[[f64; N]; N],
    v: &[f64; N],
    w: &[f64; N],
    tol: f64,
) -> Result<Pair<N>, Option<f64>> {
    let wv = dot(w, v);
    if !(wv.abs() > 1e-8) {
        return Err(None);
    }
    let jv = matvec(jac, v);
    let lambda = dot(w, &jv) / wv;
    let jw = matvec_t(jac, w);
    residual_verdict(lambda, v, w, wv, &jv, &jw, tol)
}

/// The residual test shared by [`checked_pair`] and [`checked_pair_furuta`]: with
/// `jv = J v`, `jw = J^T w` and `wv = w^T v`, `Ok((lambda, v, w / wv))` if both residuals
/// (inf norms) are at most `tol |lambda|` and `lambda` is finite, else `Err(Some(lambda))`.
#[inline(always)]
fn residual_verdict<const N: usize>(
    lambda: f64,
    v: &[f64; N],
    w: &[f64; N],
    wv: f64,
    jv: &[f64; N],
    jw: &[f64; N],
    tol: f64,
) -> Result<Pair<N>, Option<f64>> {
    let tol_abs = tol * lambda.abs();
    let rv = (0..N).map(|i| (jv[i] - lambda * v[i]).abs()).fold(0.0, f64::max);
    let rw = (0..N).map(|i| (jw[i] - lambda * w[i]).abs()).fold(0.0, f64::max);
    if rv <= tol_abs && rw <= tol_abs && lambda.is_finite() {
        let iwv = 1.0 / wv;
        return Ok((lambda, *v, w.map(|x| x * iwv)));
    }
    Err(Some(lambda))
}

/// Iterations of [`dominant_pair_lean`]'s Rayleigh quotient iteration at most.
const MAX_RAYLEIGH_ITERS: usize = 3;

pub fn rayleigh_iteration<const N: usize>(jac: &[[f64; N]; N], start: &Pair<N>, tol: f64) -> Option<Pair<N>> {
    let &(_, mut v, mut w) = start;
    let wv = dot(&w, &v);
    if !(wv.abs() > 1e-8) {
        return None;
    }
    let mut mu = dot(&w, &matvec(jac, &v)) / wv;
    for _ in 0..MAX_RAYLEIGH_ITERS {
        if !mu.is_finite() {
            return None;
        }
        let lu = ShiftedLu::new(jac, mu);
        v = lu.solve(&v);
        w = lu.solve_t(&w);
        (v, w) = normalized_pair(&v, &w)?;
        match checked_pair(jac, &v, &w, tol) {
            Ok(pair) => return Some(pair),
            Err(None) => return None,
            Err(Some(lambda)) => mu = lambda,
        }
    }
    None
}

/// `P (J - mu I) = L U` by partial pivoting, for the shifted solves of the Rayleigh quotient
/// iteration. A shift at an eigenvalue makes the matrix singular to rounding: that is the
/// point (the solution is dominated by the eigenvector); a pivot that is exactly zero is
/// replaced by `eps` times the matrix's largest entry so the solve stays finite.
pub struct ShiftedLu<const N: usize> {
    /// `L` below the diagonal (unit diagonal implied), `U` on and above it.
    a: [[f64; N]; N],
    /// Row `i` of `P A` is row `perm[i]` of `A`.
    perm: [usize; N],
    /// `1 / U[k][k]`.
    inv_diag: [f64; N],
}

impl<const N: usize> ShiftedLu<N> {
    #[inline]
    pub fn new(jac: &[[f64; N]; N], mu: f64) -> Self {
        let mut a = *jac;
        let mut big = 0.0f64;
        for (i, row) in a.iter_mut().enumerate() {
            row[i] -= mu;
            big = big.max(norm_inf(row));
        }
        let floor = f64::EPSILON * big.max(f64::MIN_POSITIVE);
        let mut perm: [usize; N] = core::array::from_fn(|i| i);
        let mut inv_diag = [0.0; N];
        for k in 0..N {
            let mut p = k;
            for i in k + 1..N {
                if a[i][k].abs() > a[p][k].abs() {
                    p = i;
                }
            }
            if p != k {
                a.swap(p, k);
                perm.swap(p, k);
            }
            if a[k][k] == 0.0 {
                a[k][k] = floor;
            }
            let inv = 1.0 / a[k][k];
            inv_diag[k] = inv;
            for i in k + 1..N {
                let l = a[i][k] * inv;
                a[i][k] = l;
                for j in k + 1..N {
                    a[i][j] -= l * a[k][j];
                }
            }
        }
        Self { a, perm, inv_diag }
    }

    /// `x` with `(J - mu I) x = b`.
    #[inline]
    pub fn solve(&self, b: &[f64; N]) -> [f64; N] {
        let a = &self.a;
        let mut x: [f64; N] = core::array::from_fn(|i| b[self.perm[i]]);
        for i in 0..N {
            for j in 0..i {
                x[i] -= a[i][j] * x[j];
            }
        }
        for i in (0..N).rev() {
            for j in i + 1..N {
                x[i] -= a[i][j] * x[j];
            }
            x[i] *= self.inv_diag[i];
        }
        x
    }

    /// `x` with `(J - mu I)^T x = b`: `U^T z = b`, `L^T y = z`, `x = P^T y`.
    #[inline]
    pub fn solve_t(&self, b: &[f64; N]) -> [f64; N] {
        let a = &self.a;
        let mut z = *b;
        for i in 0..N {
            for j in 0..i {
                z[i] -= a[j][i] * z[j];
            }
            z[i] *= self.inv_diag[i];
        }
        for i in (0..N).rev() {
            for j in i + 1..N {
                z[i] -= a[j][i] * z[j];
            }
        }
        let mut x = [0.0; N];
        for i in 0..N {
            x[self.perm[i]] = z[i];
        }
        x
    }
}

/// Power iteration on `J` and `J^T` from `start` (or the largest column and row), the residual
/// test skipped in the first `skip` iterations, accepted at relative residual `pair_tol`.
#[inline]
pub fn power_iteration<const N: usize>(
    jac: &[[f64; N]; N],
    start: Option<&Pair<N>>,
    skip: usize,
    pair_tol: f64,
) -> Option<Pair<N>> {
    let (mut v, mut w) = match start {
        Some(&(_, v, w)) => (v, w),
        None => {
            let mut best_c = (0, -1.0);
            let mut best_r = (0, -1.0);
            for k in 0..N {
                let c: f64 = (0..N).map(|i| jac[i][k].abs()).sum();
                let r: f64 = jac[k].iter().map(|v| v.abs()).sum();
                if c > best_c.1 {
                    best_c = (k, c);
                }
                if r > best_r.1 {
                    best_r = (k, r);
                }
            }
            (core::array::from_fn(|i| jac[i][best_c.0]), jac[best_r.0])
        }
    };
    for it in 0..MAX_POWER_ITERS {
        (v, w) = normalized_pair(&v, &w)?;
        let jv = matvec(jac, &v);
        let jw = matvec_t(jac, &w);
        // Even from the last step's pair the left vector starts far off (its
        // components along slowly varying columns of J move): the first two iterations
        // (factor ~1e-3 each) cannot pass the test, so it is not computed there.
        if it < skip {
            v = jv;
            w = jw;
            continue;
        }
        let wv = dot(&w, &v);
        // w and v (each of inf norm 1) nearly orthogonal: an ill-conditioned eigenvalue, or
        // not yet converged; iterate on.
        if wv.abs() > 1e-8 {
            let lambda = dot(&w, &jv) / wv;
            let tol = pair_tol * lambda.abs();
            let rv = (0..N).map(|i| (jv[i] - lambda * v[i]).abs()).fold(0.0, f64::max);
            let rw = (0..N).map(|i| (jw[i] - lambda * w[i]).abs()).fold(0.0, f64::max);
            if rv <= tol && rw <= tol && lambda.is_finite() {
                let iwv = 1.0 / wv;
                return Some((lambda, v, w.map(|x| x * iwv)));
            }
        }
        v = jv;
        w = jw;
    }
    None
}

/// The `phi`-functions of `hJ` for one `exprb43` step, split into the fast mode and the rest.
#[derive(Clone, Copy, Debug)]
pub struct Split<const N: usize> {
    /// Right eigenvector of the fast mode.
    v: [f64; N],
    /// Left eigenvector, `w^T v = 1`.
    w: [f64; N],
    /// `h J_s = h (J - lambda v w^T)`.
    a: [[f64; N]; N],
    /// `phi_k(h lambda)`, `k = 0..=4`.
    fast: [f64; 5],
    /// `phi_1(h lambda / 2)`.
    fast_half: f64,
    /// Taylor terms needed for `phi_k(h J_s)`, `k >= 1`.
    terms: usize,
    /// `J`'s rows 0 and 2 are the unit rows `e_1`, `e_3` ([`unit_rows`]): [`step`]'s `J du`
    /// without the products by the exact zeros and ones.
    unit_rows: bool,
}

/// Whether `jac` (`N = 4`) has rows 0 and 2 exactly the unit rows `e_1`, `e_3`: the layout of
/// the Furuta and cart plants' state `(theta, w_theta, phi, w_phi)` ([`second_order_layout`]).
#[inline]
pub fn unit_rows<const N: usize>(jac: &[[f64; N]; N]) -> bool {
    N == 4 && (0..N).all(|j| jac[0][j] == if j == 1 { 1.0 } else { 0.0 } && jac[2][j] == if j == 3 { 1.0 } else { 0.0 })
}

/// The slow part of a step's matrix, `Z_s = h J - (h lambda) v w^T` for the dominant `pair
/// = (lambda, v, w)`, and how many Taylor terms its sums take: `None` if `|Z_s|_1` exceeds
/// `rho_max`; else terms `j = 0..terms-1`, the first dropped one (`rho^terms / (terms+1)!`
/// bounds it) below `cut`, at most `max_terms` ([`Split`] and exprb54's split share it).
#[inline(always)]
pub(crate) fn deflated<const N: usize>(
    jac: &[[f64; N]; N],
    pair: &Pair<N>,
    h: f64,
    rho_max: f64,
    max_terms: usize,
    cut: f64,
) -> Option<([[f64; N]; N], usize)> {
    let &(lambda, v, w) = pair;
    let hl = h * lambda;
    let a: [[f64; N]; N] = core::array::from_fn(|i| {
        let hv = hl * v[i];
        core::array::from_fn(|j| h * jac[i][j] - hv * w[j])
    });
    let mut rho = 0.0f64;
    for j in 0..N {
        let mut c = 0.0;
        for row in &a {
            c += row[j].abs();
        }
        rho = rho.max(c);
    }
    if !(rho <= rho_max) {
        return None;
    }
    let mut terms = 1;
    let mut t = 1.0;
    while terms < max_terms {
        t *= rho / (terms + 1) as f64;
        if t < cut {
            break;
        }
        terms += 1;
    }
    Some((a, terms))
}

impl<const N: usize> Split<N> {
    /// The split at Jacobian `jac` with its dominant `pair`, for the step `h`; `None` if
    /// `|h J_s|_1` exceeds [`RHO_MAX`].
    #[inline]
    pub fn new(jac: &[[f64; N]; N], pair: &Pair<N>, h: f64) -> Option<Self> {
        Self::build(jac, pair, h, TERM_TOL, None, false)
    }

    /// [`Split::new`] with the Taylor sums (matrix and scalar) stopped at a first dropped term
    /// below `cut` (relative) instead of [`TERM_TOL`]: `exprb-lean` ties it to the tolerance.
    /// `unit_rows`: [`unit_rows`]`(jac)`, known to the caller (once per Jacobian).
    #[inline]
    pub(crate) fn with_cut(jac: &[[f64; N]; N], pair: &Pair<N>, h: f64, cut: &Cut, unit_rows: bool) -> Option<Self> {
        Self::build(jac, pair, h, cut.term, Some(cut), unit_rows)
    }

    #[inline(always)]
    fn build(
        jac: &[[f64; N]; N],
        pair: &Pair<N>,
        h: f64,
        cut: f64,
        lean: Option<&Cut>,
        unit_rows: bool,
    ) -> Option<Self> {
        let &(lambda, v, w) = pair;
        let hl = h * lambda;
        let (a, terms) = deflated(jac, pair, h, RHO_MAX, MAX_TERMS, cut)?;
        let (fast, fast_half) = match lean {
            Some(c) => phi_lean(hl, c),
            None => phi_scalar_and_half_cut(hl, cut),
        };
        Some(Self { v, w, a, fast, fast_half, terms, unit_rows: unit_rows && N == 4 })
    }

    /// `[phi_1(hJ/2) y, phi_1(hJ) y, phi_3(hJ) y, phi_4(hJ) y]`, each computed only where its
    /// flag is set (zeros elsewhere).
    #[inline(always)]
    pub fn apply<const H1: bool, const P1: bool, const P3: bool, const P4: bool>(&self, y: &[f64; N]) -> [[f64; N]; 4] {
        let c = dot(&self.w, y);
        let mut t: [f64; N] = core::array::from_fn(|i| y[i] - c * self.v[i]);
        let mut out = [[0.0; N]; 4];
        let mut half_pow = 1.0;
        for j in 0..self.terms {
            if j > 0 {
                t = matvec_from(&self.a, &t, -0.0);
                half_pow *= 0.5;
            }
            for i in 0..N {
                if H1 {
                    out[0][i] += (half_pow * INV_FACT[j + 1]) * t[i];
                }
                if P1 {
                    out[1][i] += INV_FACT[j + 1] * t[i];
                }
                if P3 {
                    out[2][i] += INV_FACT[j + 3] * t[i];
                }
                if P4 {
                    out[3][i] += INV_FACT[j + 4] * t[i];
                }
            }
        }
        let f = [self.fast_half, self.fast[1], self.fast[3], self.fast[4]];
        let on = [H1, P1, P3, P4];
        #[allow(clippy::needless_range_loop)] // indexed: fewer instructions than the zips
        for k in 0..4 {
            if on[k] {
                let s = f[k] * c;
                for i in 0..N {
                    out[k][i] += s * self.v[i];
                }
            }
        }
        out
    }
}

/// `f(u) - f0 - J du` of [`step`] (a function, not a closure: the closure, called twice, was
/// not inlined once the unit-row case was added).
#[inline(always)]
pub(crate) fn remainder<const N: usize>(
    jac: &[[f64; N]; N],
    unit_rows: bool,
    f0: &[f64; N],
    fu: [f64; N],
    du: &[f64; N],
) -> [f64; N] {
    let jd = if unit_rows { matvec_unit_rows(jac, du) } else { matvec(jac, du) };
    core::array::from_fn(|i| fu[i] - f0[i] - jd[i])
}

/// One `exprb43` step with split `phi`-functions: the same formulas as [`super::exprb::step`]
/// (see `exprb.rs`). Returns the new state and the error estimate.
#[inline]
pub fn step<const N: usize>(
    rhs: &mut impl FnMut(&[f64; N]) -> [f64; N],
    jac: &[[f64; N]; N],
    sp: &Split<N>,
    y: &[f64; N],
    f0: &[f64; N],
    h: f64,
) -> ([f64; N], [f64; N]) {
    let remainder = |fu: [f64; N], du: &[f64; N]| remainder(jac, sp.unit_rows, f0, fu, du);
    let [pf_half, pf1, _, _] = sp.apply::<true, true, false, false>(f0);
    let du2: [f64; N] = core::array::from_fn(|i| 0.5 * h * pf_half[i]);
    let u2: [f64; N] = core::array::from_fn(|i| y[i] + du2[i]);
    let d2 = remainder(rhs(&u2), &du2);
    let [_, pd2_1, pd2_3, pd2_4] = sp.apply::<false, true, true, true>(&d2);
    let du3: [f64; N] = core::array::from_fn(|i| h * (pf1[i] + pd2_1[i]));
    let u3: [f64; N] = core::array::from_fn(|i| y[i] + du3[i]);
    let d3 = remainder(rhs(&u3), &du3);
    let [_, _, pd3_3, pd3_4] = sp.apply::<false, false, true, true>(&d3);
    let err: [f64; N] = core::array::from_fn(|i| h * (12.0 * pd3_4[i] - 48.0 * pd2_4[i]));
    let y1: [f64; N] = core::array::from_fn(|i| y[i] + h * pf1[i] + h * (16.0 * pd2_3[i] - 2.0 * pd3_3[i]) + err[i]);
    (y1, err)
}
