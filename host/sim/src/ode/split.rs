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
/// (to a term below `1e-18` of the first; at most 25 terms) and the stable backward recurrence
/// `phi_{k-1} = 1/(k-1)! + z phi_k`; otherwise `exp(z)` and the forward recurrence
/// `phi_k = (phi_{k-1} - 1/(k-1)!)/z`, which loses at most a factor `k/|z| <= 2.5` per level
/// there.
#[cfg(test)]
pub(crate) fn phi_scalar(z: f64) -> [f64; 5] {
    phi_scalar_cut(z, 1e-18)
}

/// [`phi_scalar`] with the Taylor series (for `|z| < 2`) stopped at a term below `cut` of the
/// first instead of `1e-18` (`exprb-lean`: a cut tied to the step's tolerance).
#[inline]
pub(crate) fn phi_scalar_cut(z: f64, cut: f64) -> [f64; 5] {
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

/// `phi_k(z)`, `k = 0..=4`, and `phi_1(z/2)`, with one exponential where `|z| >= 4`.
#[cfg(test)]
fn phi_scalar_and_half(z: f64) -> ([f64; 5], f64) {
    phi_scalar_and_half_cut(z, 1e-18)
}

/// [`phi_scalar_and_half`] with the series cut of [`phi_scalar_cut`].
#[inline]
fn phi_scalar_and_half_cut(z: f64, cut: f64) -> ([f64; 5], f64) {
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
pub(crate) struct Cut {
    /// Taylor sums stop at a first dropped term below `term` (relative).
    pub(crate) term: f64,
    /// Scalar `phi`-functions from `expm1` at `|z| >= z_min`, from their Taylor series below.
    pub(crate) z_min: f64,
}

impl Cut {
    /// `term = 1e-3 rtol` (within `[1e-18, 1e-6]`); `z_min` where the forward recurrence from
    /// `phi_1 = expm1(z)/z` (relative error about `24 eps / |z|^3` in `phi_4`) reaches `term`.
    pub(crate) fn for_rtol(rtol: f64) -> Self {
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
fn phi_lean(z: f64, cut: &Cut) -> ([f64; 5], f64) {
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
pub(crate) fn matvec<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
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
pub(crate) fn matvec_unit_rows<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    let mut s = matvec(a, x);
    (s[0], s[2]) = (0.0 + x[1], 0.0 + x[3]);
    s
}

#[inline(always)]
fn matvec_t<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    let mut s = [0.0; N];
    for i in 0..N {
        for j in 0..N {
            s[j] += a[i][j] * x[i];
        }
    }
    s
}

#[inline(always)]
pub(crate) fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
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
fn norm_inf<const N: usize>(a: &[f64; N]) -> f64 {
    a.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// `(lambda, v, w)`: a dominant eigenvalue with its right and left eigenvectors, `w^T v = 1`.
pub(crate) type Pair<const N: usize> = (f64, [f64; N], [f64; N]);

/// The dominant eigenpair of `J`: `(lambda, v, w)` with `J v = lambda v`, `w^T J = lambda w^T`,
/// `w^T v = 1`, or `None` if power iteration does not converge to [`PAIR_TOL`] (no single real
/// eigenvalue dominating) or the pair is ill-conditioned. `start` (the pair of a nearby
/// Jacobian, e.g. the previous step's) seeds the iteration; without it, the largest column and
/// row of `J` do.
pub(crate) fn dominant_pair<const N: usize>(jac: &[[f64; N]; N], start: Option<&Pair<N>>) -> Option<Pair<N>> {
    power_iteration(jac, start, 2, PAIR_TOL)
}

/// `exprb-lean`'s eigenpair: two-sided Rayleigh quotient iteration from a warm start (the
/// previous step's pair). The shift is the Rayleigh quotient `w^T J v / w^T v` of the start at
/// the new Jacobian (its error is the product of the vectors' errors), then of the improved
/// pair; each iteration solves `(J - mu I) v' = v` and `(J - mu I)^T w' = w` with one LU.
/// From the last step's pair (on the Furuta bench the left vector is further off than the
/// right) the first iteration leaves the right vector at rounding and the left one close to
/// it, the second both at rounding; the residual test `tol` (relative, as [`PAIR_TOL`]) is
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
#[cfg(test)]
pub(crate) fn dominant_pair_lean<const N: usize>(
    jac: &[[f64; N]; N],
    start: Option<&Pair<N>>,
    tol: f64,
) -> Option<Pair<N>> {
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
fn second_order_layout<const N: usize>(jac: &[[f64; N]; N]) -> Option<[(usize, usize); 2]> {
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
fn second_order_pair<const N: usize>(
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
/// [`normalized_pair`] gives): the same result bit for bit, the products with the exact zeros
/// and ones left out. In `matvec`'s and `matvec_t`'s sums, which start from `+0.0` and add in
/// row (column) order, a term `0 x` is `+-0` for finite `x` and leaves the running sum as it
/// is (the sum is never `-0`: `+0.0 + a` is `+0` for `a = -0`, and `+0 + -0 = +0`), and a term
/// `1 x` is `x`; so `(J v)_0 = 0.0 + v_1`, `(J^T w)_1 = ((0.0 + w_0) + J_11 w_1) + J_31 w_3`,
/// and so on. Checked against [`checked_pair`] in the tests.
#[inline]
fn checked_pair_furuta<const N: usize>(
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
fn checked_pair<const N: usize>(
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

fn rayleigh_iteration<const N: usize>(jac: &[[f64; N]; N], start: &Pair<N>, tol: f64) -> Option<Pair<N>> {
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
struct ShiftedLu<const N: usize> {
    /// `L` below the diagonal (unit diagonal implied), `U` on and above it.
    a: [[f64; N]; N],
    /// Row `i` of `P A` is row `perm[i]` of `A`.
    perm: [usize; N],
    /// `1 / U[k][k]`.
    inv_diag: [f64; N],
}

impl<const N: usize> ShiftedLu<N> {
    #[inline]
    fn new(jac: &[[f64; N]; N], mu: f64) -> Self {
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
    fn solve(&self, b: &[f64; N]) -> [f64; N] {
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
    fn solve_t(&self, b: &[f64; N]) -> [f64; N] {
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
fn power_iteration<const N: usize>(
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
pub(crate) struct Split<const N: usize> {
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
pub(crate) fn unit_rows<const N: usize>(jac: &[[f64; N]; N]) -> bool {
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
    pub(crate) fn new(jac: &[[f64; N]; N], pair: &Pair<N>, h: f64) -> Option<Self> {
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
    fn apply<const H1: bool, const P1: bool, const P3: bool, const P4: bool>(&self, y: &[f64; N]) -> [[f64; N]; 4] {
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
pub(crate) fn step<const N: usize>(
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::plant::{Furuta, jacobian};
    use nalgebra::SVector;

    /// Uniform draws in `[lo, hi)` from a 64-bit LCG (Knuth's MMIX constants) seeded with
    /// `seed`: the random Jacobians and states of the pair tests.
    fn uniform_stream(mut seed: u64) -> impl FnMut(f64, f64) -> f64 {
        move |lo, hi| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    /// `phi_k(z)` by the series `sum_j z^j/(j+k)!` (60 terms) for `|z| <= 1`, the closed form
    /// `(e^z - sum_{j<k} z^j/j!)/z^k` beyond (no cancellation there for `k <= 4`).
    pub(crate) fn phi_ref(k: usize, z: f64) -> f64 {
        let fact = |n: usize| (1..=n).fold(1.0f64, |a, i| a * i as f64);
        if z.abs() <= 1.0 {
            (0..60).map(|j| z.powi(j as i32) / fact(j + k)).sum()
        } else {
            let mut s = z.exp();
            for j in 0..k {
                s -= z.powi(j as i32) / fact(j);
            }
            s / z.powi(k as i32)
        }
    }

    #[test]
    fn scalar_phi_functions_match_series_and_closed_form() {
        for z in [0.0, 1e-8, -1e-3, 0.37, -1.0, -1.99, 1.999, -2.0, 2.5, -3.0, -7.5, -21.0, -480.0, -1e4, 6.0] {
            let p = phi_scalar(z);
            for (k, got) in p.iter().enumerate() {
                let want = phi_ref(k, z);
                let tol = if z.abs() <= 1.0 { 4e-15 } else { 2e-14 };
                assert!((got - want).abs() <= tol * want.abs(), "phi_{k}({z}) = {got:e}, want {want:e}");
            }
        }
    }

    #[test]
    fn lean_scalar_phi_functions_meet_their_cut() {
        for rtol in [1e-6, 1e-8, 1e-10, 1e-12, 1e-15] {
            let cut = Cut::for_rtol(rtol);
            for z in [
                0.0, 1e-9, -1e-4, -0.01, -0.05, 0.07, -0.1, -0.3, -0.99, 1.5, -1.99, -2.0, -3.0, -7.5, -21.0, -480.0,
                -1e4, 6.0,
            ] {
                let (p, half) = phi_lean(z, &cut);
                for (k, got) in p.iter().enumerate() {
                    let want = phi_ref(k, z);
                    let tol = cut.term.max(4e-15) * if k == 0 { want.abs().max(1.0) } else { want.abs() };
                    assert!((got - want).abs() <= tol, "rtol {rtol:e}: phi_{k}({z}) = {got:e}, want {want:e}");
                }
                let want = phi_ref(1, 0.5 * z);
                assert!(
                    (half - want).abs() <= 4e-15 * want.abs(),
                    "rtol {rtol:e}: phi_1({z}/2) = {half:e}, want {want:e}"
                );
            }
        }
    }

    #[test]
    fn scalar_phi_and_half_agree_with_the_single_evaluations() {
        for z in [0.0, -1.0, -3.9, -4.0, 4.5, -7.5, -21.0, -480.0] {
            let (p, h) = phi_scalar_and_half(z);
            let q = phi_scalar(z);
            for k in 0..5 {
                assert!((p[k] - q[k]).abs() <= 4e-16 * q[k].abs(), "phi_{k}({z}): {} vs {}", p[k], q[k]);
            }
            let want = phi_ref(1, 0.5 * z);
            assert!((h - want).abs() <= 4e-15 * want.abs(), "phi_1({z}/2): {h} vs {want}");
        }
    }

    /// The split phi-functions against the full matrix functions (scaling and squaring,
    /// itself checked against an eigendecomposition in `exprb.rs`), at Furuta states from the
    /// upright to a tilted, fast-moving one, for steps from 10 us to a period.
    #[test]
    fn split_phi_functions_match_the_matrix_functions_on_the_furuta_jacobian() {
        let p = Furuta::paper();
        let mut used = 0;
        for (x, u) in [
            ([0.0, 0.0, 0.0, 0.0], 0.0),
            ([0.05, 1.0, 0.3, 0.5], 0.7),
            ([-0.1, -2.0, 1.0, 3.0], -2.0),
            ([0.15, -3.0, 0.0, 2.0], -2.0),
        ] {
            let (_, jac) = jacobian(&p, &x, u);
            let pair =
                dominant_pair(&jac, None).expect("the Furuta Jacobian has a dominant eigenvalue near the upright");
            // The back-EMF mode: about -K Jp / Delta(theta).
            let delta = p.delta(x[0]);
            let want_lambda = -p.params().k * p.params().jp / delta;
            assert!((pair.0 / want_lambda - 1.0).abs() < 0.05, "lambda {} vs {want_lambda}", pair.0);
            // A warm start from a nearby Jacobian converges to the same pair.
            let (_, jac0) = jacobian(&p, &[0.0; 4], 0.0);
            let pair0 = dominant_pair(&jac0, None).unwrap();
            let warm = dominant_pair(&jac, Some(&pair0)).unwrap();
            assert!((warm.0 - pair.0).abs() < 1e-12 * pair.0.abs());
            for h in [1e-5, 1e-4, 1e-3, 3e-3, 0.0308] {
                let Some(s) = Split::new(&jac, &pair, h) else {
                    // Only large steps at tilted states leave the Taylor range.
                    assert!(h >= 1e-3, "no split at h = {h}, x = {x:?}");
                    continue;
                };
                used += 1;
                let phis = super::super::exprb::phis(&jac, h).unwrap();
                for y in [[0.3, -1.0, 2.0, 5.0], pair.1, [1.0, 0.0, 0.0, 0.0]] {
                    let got = s.apply::<true, true, true, true>(&y);
                    let yv = SVector::<f64, 4>::from_column_slice(&y);
                    let want = [phis.p1_half * yv, phis.p1 * yv, phis.p3 * yv, phis.p4 * yv];
                    for k in 0..4 {
                        let scale = want[k].abs().max();
                        for i in 0..4 {
                            let e = (got[k][i] - want[k][i]).abs() / scale;
                            assert!(e < 1e-13, "x {x:?} h {h}: function {k} component {i}: relative error {e:e}");
                        }
                    }
                }
            }
        }
        assert!(used >= 12, "split used {used} times");
    }

    /// exprb-lean's pair: Rayleigh quotient iteration from the pair of a nearby Jacobian gives
    /// the power iteration's pair (same eigenvalue, same vectors to rounding), in a residual of
    /// `tol`; without a start, power iteration.
    #[test]
    fn rayleigh_pair_from_a_warm_start_matches_power_iteration() {
        let p = Furuta::paper();
        let states = [
            ([0.0, 0.0, 0.0, 0.0], 0.0),
            ([0.05, 1.0, 0.3, 0.5], 0.7),
            ([0.05, 1.05, 0.3, 0.8], 0.7),
            ([-0.1, -2.0, 1.0, 3.0], -2.0),
        ];
        let mut prev: Option<Pair<4>> = None;
        for (x, u) in states {
            let (_, jac) = jacobian(&p, &x, u);
            let want = dominant_pair(&jac, None).unwrap();
            let got = dominant_pair_lean(&jac, prev.as_ref(), 1e-14).unwrap();
            assert!((got.0 - want.0).abs() <= 1e-13 * want.0.abs(), "lambda {} vs {}", got.0, want.0);
            // Same normalization (inf norm 1 for v, w^T v = 1): the vectors agree up to sign.
            let sign = if dot(&got.1, &want.1) < 0.0 { -1.0 } else { 1.0 };
            for i in 0..4 {
                assert!((sign * got.1[i] - want.1[i]).abs() <= 1e-12, "v: {:?} vs {:?}", got.1, want.1);
                assert!(
                    (sign * got.2[i] - want.2[i]).abs() <= 1e-12 * norm_inf(&want.2),
                    "w: {:?} vs {:?}",
                    got.2,
                    want.2
                );
            }
            prev = Some(got);
        }
        // A start that is no eigenpair at all still ends on a checked pair or on None.
        let (_, jac) = jacobian(&p, &[0.05, 1.0, 0.3, 0.5], 0.7);
        let bad = (1.0, [1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]);
        if let Some((l, v, w)) = dominant_pair_lean(&jac, Some(&bad), 1e-12) {
            let jv = matvec(&jac, &v);
            let jw = matvec_t(&jac, &w);
            for i in 0..4 {
                assert!((jv[i] - l * v[i]).abs() <= 1e-11 * l.abs());
                assert!((jw[i] - l * w[i]).abs() <= 1e-11 * l.abs() * norm_inf(&w));
            }
        }
        // A shift exactly at an eigenvalue: the zero pivot is floored, the solve stays finite.
        let lu = ShiftedLu::new(&[[2.0, 0.0], [0.0, -3.0]], 2.0);
        let x = lu.solve(&[1.0, 1.0]);
        assert!(x.iter().all(|v| v.is_finite()) && x[0].abs() > 1e10 * x[1].abs(), "{x:?}");
        let x = lu.solve_t(&[1.0, 1.0]);
        assert!(x.iter().all(|v| v.is_finite()) && x[0].abs() > 1e10 * x[1].abs(), "{x:?}");
    }

    /// The relative residuals `(|J v - lambda v|, |J^T w - lambda w| / |w|)` of a pair (inf
    /// norms, over `|lambda|`).
    fn residuals(jac: &[[f64; 4]; 4], (l, v, w): &Pair<4>) -> (f64, f64) {
        let (jv, jw) = (matvec(jac, v), matvec_t(jac, w));
        let rv = (0..4).map(|i| (jv[i] - l * v[i]).abs()).fold(0.0, f64::max) / (l.abs() * norm_inf(v));
        let rw = (0..4).map(|i| (jw[i] - l * w[i]).abs()).fold(0.0, f64::max) / (l.abs() * norm_inf(w));
        (rv, rw)
    }

    /// `(lambda, v, w)` of two pairs with the same normalization (`|v| = 1`, `w^T v = 1`):
    /// the largest relative differences of `lambda`, `v` and `w` (`w` relative to its norm),
    /// signs aligned.
    fn pair_diff(a: &Pair<4>, b: &Pair<4>) -> [f64; 3] {
        let sign = if dot(&a.1, &b.1) < 0.0 { -1.0 } else { 1.0 };
        let dv = (0..4).map(|i| (sign * a.1[i] - b.1[i]).abs()).fold(0.0, f64::max);
        let dw = (0..4).map(|i| (sign * a.2[i] - b.2[i]).abs()).fold(0.0, f64::max) / norm_inf(&b.2);
        [(a.0 - b.0).abs() / b.0.abs(), dv, dw]
    }

    /// The closed-form pair of a second-order Jacobian (the Furuta plant's closed form, random
    /// states from the upright to 0.6 rad, fast arm) from the eigenvalue of a nearby state's
    /// pair against power iteration from a cold start (accepted at residuals of 1e-14): the
    /// closed form's residuals at rounding (below 1e-15), the same eigenvalue to 1e-15, `v` to
    /// 1e-14 and `w` to 3e-14 (power iteration's own error sets these two), and
    /// `dominant_pair_lean` takes it. The worst values are printed.
    #[test]
    fn second_order_pair_matches_power_iteration_on_the_furuta_jacobian() {
        use crate::plant::Plant;
        let plant = Furuta::paper();
        let mut uniform = uniform_stream(0x9e37_79b9_7f4a_7c15);
        let (mut worst, mut worst_res, mut used) = ([0.0f64; 3], [0.0f64; 2], 0);
        for k in 0..400 {
            let r = if k < 200 { 0.1 } else { 0.6 };
            let x = [uniform(-1.0, 1.0) * r, uniform(-10.0, 10.0) * r, uniform(-10.0, 10.0), uniform(-30.0, 30.0) * r];
            let u = uniform(-12.0, 12.0);
            let (_, jac) = plant.rhs_and_jacobian(&x, u);
            assert_eq!(second_order_layout(&jac), Some([(0, 1), (2, 3)]));
            let Some(want) = dominant_pair(&jac, None) else { continue };
            // The start: the pair at a state a step away (1e-3 of the state's scale).
            let near: [f64; 4] = core::array::from_fn(|i| x[i] + 1e-3 * uniform(-1.0, 1.0) * [1.0, 10.0, 1.0, 30.0][i]);
            let start = dominant_pair(&plant.rhs_and_jacobian(&near, u).1, None).unwrap_or(want);
            let got = second_order_pair(&jac, &start, 1e-14, unit_rows(&jac))
                .expect("the closed-form pair passes the residual test");
            let lean = dominant_pair_lean(&jac, Some(&start), 1e-14).unwrap();
            assert_eq!(lean.0.to_bits(), got.0.to_bits(), "dominant_pair_lean takes the closed form");
            let d = pair_diff(&got, &want);
            for i in 0..3 {
                worst[i] = worst[i].max(d[i]);
            }
            let r = residuals(&jac, &got);
            assert!(r.0 <= 1e-15 && r.1 <= 1e-15, "x {x:?} u {u}: residuals {r:?}");
            worst_res = [worst_res[0].max(r.0), worst_res[1].max(r.1)];
            assert!(d[0] <= 1e-15 && d[1] <= 1e-14 && d[2] <= 3e-14, "x {x:?} u {u}: [lambda, v, w] differ by {d:?}");
            used += 1;
        }
        eprintln!(
            "second-order pair vs power iteration, {used} Jacobians: [lambda, v, w] worst {worst:?}, residuals (v, w) {worst_res:?}"
        );
        assert!(used >= 300, "{used} Jacobians with a dominant pair");
    }

    /// The pairs of the Jacobians met along a closed-loop run (the paper's delayed PD loop
    /// from 0.05 rad, 100 periods of 30.8 ms, each advanced by exprb-filtered in 20 pieces, a
    /// Jacobian at each piece's end), each from the last one's pair: the closed-form chain
    /// against the Rayleigh chain (the old `dominant_pair_lean`) at the tolerances of the
    /// report's integrators (`pair_tol` 3e-13) and the tightest (1e-14): every closed-form pair
    /// passes with residuals (relative, inf norms) at rounding, below 1e-15, the Rayleigh
    /// pairs' up to `tol`; the eigenvalues agree to 1e-15, the vectors to `1.5 tol` (the
    /// Rayleigh pair's own error is up to about `tol`). The worst values are printed.
    #[test]
    fn second_order_pair_along_a_run_matches_the_rayleigh_pair() {
        use crate::ode::{Integrator, Method};
        use crate::plant::Plant;
        let plant = Furuta::paper();
        let (dt, kp, kd, kphi) = (0.0308, 15.5, 5.45, 1.5);
        for tol in [3e-13, 1e-14] {
            let mut integ = Integrator::<4>::new(Method::ExprbFiltered { rtol: 3e-11, atol: 3e-11 }).unwrap();
            let mut x = [0.05, 0.0, 0.0, 0.0];
            let (mut s1, mut s2) = ((x[0], x[2]), (x[0], x[2]));
            let (mut old, mut new): (Option<Pair<4>>, Option<Pair<4>>) = (None, None);
            let (mut worst_res, mut worst_diff, mut n) = ([0.0f64; 4], [0.0f64; 3], 0);
            for _ in 0..100 {
                let u = -kp * s1.0 - kd * (s1.0 - s2.0) / dt + kphi * (s1.1 - s2.1) / dt;
                s2 = s1;
                s1 = (x[0], x[2]);
                for _ in 0..20 {
                    integ.advance(&plant, &mut x, u, dt / 20.0).unwrap();
                    let (_, jac) = plant.rhs_and_jacobian(&x, u);
                    let o = old
                        .as_ref()
                        .and_then(|s| rayleigh_iteration(&jac, s, tol))
                        .or_else(|| power_iteration(&jac, None, 2, tol));
                    // Every pair after the first (cold, power iteration) is the closed form's.
                    let w = match new.as_ref() {
                        Some(s) => second_order_pair(&jac, s, tol, unit_rows(&jac)),
                        None => power_iteration(&jac, None, 2, tol),
                    };
                    let (o, w) = (o.expect("a Rayleigh pair"), w.expect("a closed-form pair"));
                    let cold = new.is_none();
                    (old, new) = (Some(o), Some(w));
                    if cold {
                        continue;
                    }
                    let (ro, rn) = (residuals(&jac, &o), residuals(&jac, &w));
                    for (k, r) in [ro.0, ro.1, rn.0, rn.1].into_iter().enumerate() {
                        worst_res[k] = worst_res[k].max(r);
                    }
                    let d = pair_diff(&w, &o);
                    for k in 0..3 {
                        worst_diff[k] = worst_diff[k].max(d[k]);
                    }
                    assert!(rn.0 <= 1e-15 && rn.1 <= 1e-15, "x {x:?}: closed-form residuals {rn:?}");
                    assert!(ro.0 <= tol && ro.1 <= tol, "x {x:?}: Rayleigh residuals {ro:?}");
                    assert!(
                        d[0] <= 1e-15 && d[1] <= 1.5 * tol && d[2] <= 1.5 * tol,
                        "x {x:?}: [lambda, v, w] differ by {d:?}"
                    );
                    n += 1;
                }
            }
            eprintln!(
                "tol {tol:e}, {n} Jacobians along the run: residuals (v, w) rayleigh {:?} closed form {:?}; [lambda, v, w] differ by {worst_diff:?}",
                &worst_res[..2],
                &worst_res[2..]
            );
        }
    }

    /// Without the second-order layout (a unit row off by one ulp, rows pointing at each
    /// other, a 3-state Jacobian) there is no closed-form pair and `dominant_pair_lean` is the
    /// Rayleigh quotient iteration's, bit for bit.
    #[test]
    fn without_the_second_order_layout_the_rayleigh_pair_is_used() {
        use crate::plant::Plant;
        let plant = Furuta::paper();
        let (_, jac) = plant.rhs_and_jacobian(&[0.05, 1.0, 0.3, 0.5], 0.7);
        let start = dominant_pair(&plant.rhs_and_jacobian(&[0.051, 1.0, 0.3, 0.6], 0.7).1, None).unwrap();
        let mut off = jac;
        off[0][1] = 1.0 + f64::EPSILON;
        let mut swapped = jac;
        swapped[0] = [0.0, 0.0, 1.0, 0.0];
        swapped[2] = [1.0, 0.0, 0.0, 0.0];
        for j in [off, swapped] {
            assert_eq!(second_order_layout(&j), None);
            assert!(second_order_pair(&j, &start, 1e-14, unit_rows(&j)).is_none());
            let want = rayleigh_iteration(&j, &start, 1e-14);
            let got = dominant_pair_lean(&j, Some(&start), 1e-14);
            assert_eq!(format!("{got:?}"), format!("{want:?}"));
        }
        // The blocked layout (q, q') is found as well.
        let perm = [0, 2, 1, 3];
        let blocked: [[f64; 4]; 4] = core::array::from_fn(|i| core::array::from_fn(|k| jac[perm[i]][perm[k]]));
        assert_eq!(second_order_layout(&blocked), Some([(0, 2), (1, 3)]));
        let s = (start.0, perm.map(|i| start.1[i]), perm.map(|i| start.2[i]));
        let (a, b) = (
            second_order_pair(&blocked, &s, 1e-14, unit_rows(&blocked)).unwrap(),
            second_order_pair(&jac, &start, 1e-14, unit_rows(&jac)).unwrap(),
        );
        assert!((a.0 - b.0).abs() <= 1e-15 * b.0.abs(), "{a:?} vs {b:?}");
        let j3 = [[1.0, 2.0, 0.5], [-4.0, 0.3, 1.0], [2.0, -1.0, 3.0]];
        assert_eq!(second_order_layout(&j3), None);
        // A start far from every eigenvalue: Newton's root is refused, not taken.
        if let Some(p) = second_order_pair(&jac, &(-3.0, start.1, start.2), 1e-14, unit_rows(&jac)) {
            assert!((p.0 + 3.0).abs() <= 1.5, "{p:?}");
        }
    }

    /// `checked_pair_furuta` is `checked_pair` bit for bit on Jacobians with the Furuta layout:
    /// the closed form's pairs (which pass), the same pairs perturbed (which fail, `Err(Some)`,
    /// the Rayleigh quotient compared by its bits), vectors with exact and negative zeros, and
    /// nearly orthogonal ones (`Err(None)`); on the plant's closed-form Jacobians at random
    /// states and on Jacobians with random entries (and zeros) in rows 1 and 3.
    #[test]
    fn checked_pair_furuta_equals_checked_pair_bit_for_bit() {
        use crate::plant::Plant;
        let plant = Furuta::paper();
        let mut uniform = uniform_stream(0x1234_5678_9abc_def1);
        let key = |r: Result<Pair<4>, Option<f64>>| -> Vec<u64> {
            match r {
                Ok((l, v, w)) => [l].iter().chain(&v).chain(&w).map(|x| x.to_bits()).collect(),
                Err(Some(l)) => vec![1, l.to_bits()],
                Err(None) => vec![2],
            }
        };
        let (mut ok, mut fail, mut none) = (0, 0, 0);
        for k in 0..3000 {
            let r = if k % 2 == 0 { 0.1 } else { 1.0 };
            let x = [uniform(-1.0, 1.0) * r, uniform(-10.0, 10.0) * r, uniform(-10.0, 10.0), uniform(-30.0, 30.0) * r];
            let u = uniform(-12.0, 12.0);
            let (_, mut jac) = plant.rhs_and_jacobian(&x, u);
            if k % 3 == 2 {
                // Random rows 1 and 3, some entries exactly zero or negative zero.
                for i in [1, 3] {
                    for j in 0..4 {
                        jac[i][j] = match (k + i + j) % 7 {
                            0 => 0.0,
                            1 => -0.0,
                            _ => uniform(-1e4, 1e4),
                        };
                    }
                }
            }
            assert_eq!(second_order_layout(&jac), Some([(0, 1), (2, 3)]));
            let start = dominant_pair(&jac, None).map_or((-1.5e4, [0.0; 4], [0.0; 4]), |p| p);
            let (mut v, mut w) = match second_order_pair(&jac, &start, 1e-14, unit_rows(&jac)) {
                Some((_, v, w)) => (v, w),
                None => (core::array::from_fn(|_| uniform(-1.0, 1.0)), core::array::from_fn(|_| uniform(-1.0, 1.0))),
            };
            match k % 5 {
                1 => v[(k / 5) % 4] += 1e-9 * uniform(-1.0, 1.0),
                2 => w[(k / 5) % 4] = -0.0,
                3 => (v[0], w[2]) = (0.0, -0.0),
                4 => (v, w) = ([1.0, 0.0, -0.0, 0.0], [0.0, 1.0, 0.0, -0.0]),
                _ => {}
            }
            for tol in [1e-14, 3e-13, 1e-2] {
                let want = key(checked_pair(&jac, &v, &w, tol));
                let got = key(checked_pair_furuta(&jac, &v, &w, tol));
                assert_eq!(got, want, "k {k} tol {tol:e}: jac {jac:?} v {v:?} w {w:?}");
                match want[..] {
                    [2] => none += 1,
                    [1, _] => fail += 1,
                    _ => ok += 1,
                }
            }
        }
        eprintln!(
            "checked_pair_furuta vs checked_pair: {ok} accepted, {fail} refused, {none} orthogonal, all bit for bit"
        );
        assert!(ok >= 1000 && fail >= 1000 && none >= 100, "{ok} {fail} {none}");
    }

    /// `matvec_unit_rows` is `matvec` bit for bit on Jacobians with [`unit_rows`] and finite
    /// vectors (random entries, exact and negative zeros); `unit_rows` finds exactly that layout.
    #[test]
    fn matvec_unit_rows_equals_matvec_bit_for_bit() {
        use crate::plant::Plant;
        let plant = Furuta::paper();
        let mut uniform = uniform_stream(0x0bad_cafe_f00d_1234);
        for k in 0..5000 {
            let x = [uniform(-1.0, 1.0), uniform(-10.0, 10.0), uniform(-10.0, 10.0), uniform(-30.0, 30.0)];
            let (_, jac) = plant.rhs_and_jacobian(&x, uniform(-12.0, 12.0));
            assert!(unit_rows(&jac));
            let mut y: [f64; 4] = core::array::from_fn(|_| uniform(-1.0, 1.0) * 10f64.powi((k % 13) as i32 - 6));
            match k % 4 {
                1 => y[(k / 4) % 4] = 0.0,
                2 => (y[1], y[3]) = (-0.0, -0.0),
                3 => y = [-0.0, -0.0, 0.0, -0.0],
                _ => {}
            }
            let (a, b) = (matvec_unit_rows(&jac, &y), matvec(&jac, &y));
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "y {y:?}: {a:?} vs {b:?}");
        }
        let (_, jac) = plant.rhs_and_jacobian(&[0.1, 0.2, 0.3, 0.4], 1.0);
        for (i, j, x) in [(0, 1, 1.0 + f64::EPSILON), (2, 2, 1e-300), (2, 3, -1.0)] {
            let mut off = jac;
            off[i][j] = x;
            assert!(!unit_rows(&off), "{i} {j} {x}");
        }
        // A negative zero is a zero, as in `second_order_layout` (its products are zeros too).
        let mut neg = jac;
        neg[0][0] = -0.0;
        assert!(unit_rows(&neg) && second_order_layout(&neg) == Some([(0, 1), (2, 3)]));
        assert!(!unit_rows(&[[0.0, 1.0], [2.0, 3.0]]));
    }

    #[test]
    fn shifted_lu_solves_both_ways() {
        let j = [[1.0, 2.0, 0.5], [-4.0, 0.3, 1.0], [2.0, -1.0, 3.0]];
        let lu = ShiftedLu::new(&j, 0.7);
        let b = [0.3, -1.0, 2.0];
        let x = lu.solve(&b);
        let xt = lu.solve_t(&b);
        for i in 0..3 {
            let r: f64 = (0..3).map(|k| (j[i][k] - if i == k { 0.7 } else { 0.0 }) * x[k]).sum();
            let rt: f64 = (0..3).map(|k| (j[k][i] - if i == k { 0.7 } else { 0.0 }) * xt[k]).sum();
            assert!((r - b[i]).abs() < 1e-14 && (rt - b[i]).abs() < 1e-14, "{i}: {r} {rt}");
        }
    }

    #[test]
    fn no_dominant_eigenvalue_means_no_split() {
        // Far from upright and spinning: the back-EMF mode is no longer dominant.
        let (_, jac) = jacobian(&Furuta::paper(), &[1.0, 3.0, 0.0, 20.0], 10.0);
        assert!(dominant_pair(&jac, None).is_none());
        // A rotation: a complex pair dominates; power iteration cannot converge.
        let rot = [[0.0, 5.0], [-5.0, 0.0]];
        assert!(dominant_pair(&rot, None).is_none());
        // Non-finite or zero Jacobians.
        assert!(dominant_pair(&[[f64::NAN, 0.0], [0.0, 1.0]], None).is_none());
        assert!(dominant_pair(&[[0.0; 2]; 2], None).is_none());
        // A clear dominant eigenvalue but a step too long for the Taylor sums of the rest.
        let j = [[-1e4, 0.0], [0.0, -10.0]];
        let pair = dominant_pair(&j, None).unwrap();
        assert!((pair.0 + 1e4).abs() < 1e-9);
        assert!(Split::new(&j, &pair, 0.05).is_some());
        assert!(Split::new(&j, &pair, 0.2).is_none());
    }
}
