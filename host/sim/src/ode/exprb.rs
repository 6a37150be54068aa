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
pub const DEG: usize = 10;
/// Largest 1-norm of the scaled argument: the truncation of `exp` is below
/// `THETA^15/15! = 2.3e-17` there.
pub const THETA: f64 = 0.5;
/// More doublings than this means `|hJ|_1 > 0.5 * 2^60`: treat as a blow-up.
pub const MAX_DOUBLINGS: i32 = 60;

pub type M<const N: usize> = SMatrix<f64, N, N>;
pub type V<const N: usize> = SVector<f64, N>;

/// `phi1(hJ/2)`, `phi1(hJ)`, `phi3(hJ)`, `phi4(hJ)`.
#[derive(Clone, Copy, Debug)]
pub struct Phis<const N: usize> {
    pub p1_half: M<N>,
    pub p1: M<N>,
    pub p3: M<N>,
    pub p4: M<N>,
}

/// `1/k!` for `k = 0..=DEG+4`.
pub const INV_FACT: [f64; DEG + 5] = {
    let mut t = [1.0; DEG + 5];
    let mut k = 1;
    while k < DEG + 5 {
        t[k] = t[k - 1] / k as f64;
        k += 1;
    }
    t
};

/// A matrix as its columns (nalgebra's storage order): `m[j][i]` is row `i`, column `j`.
pub type Cols<const N: usize> = [[f64; N]; N];

/// `a * b` with nalgebra's operations in nalgebra's order (its `gemm` for fixed sizes: column
/// `j` of the product is `a[:,0] b[0,j]`, then `a[:,k] b[k,j] + (sum so far)` for `k = 1..N`),
/// so bit for bit nalgebra's product, inlined, with no zero fill or dispatch.
#[inline(always)]
pub fn mm<const N: usize>(a: &Cols<N>, b: &Cols<N>) -> Cols<N> {
    let mut c = [[0.0; N]; N];
    for (y, bj) in c.iter_mut().zip(b) {
        for i in 0..N {
            y[i] = a[0][i] * bj[0];
        }
        for k in 1..N {
            for i in 0..N {
                y[i] = a[k][i] * bj[k] + y[i];
            }
        }
    }
    c
}

/// `f(i, j, x[j][i])` for every entry (column-major, like nalgebra's element-wise operations).
#[inline(always)]
fn map<const N: usize>(x: &Cols<N>, f: impl Fn(usize, usize, f64) -> f64) -> Cols<N> {
    let mut c = [[0.0; N]; N];
    for (j, (cj, xj)) in c.iter_mut().zip(x).enumerate() {
        for (i, (o, &v)) in cj.iter_mut().zip(xj).enumerate() {
            *o = f(i, j, v);
        }
    }
    c
}

/// `s I + m` entry by entry, as nalgebra's `id * s + m` (`s` on the diagonal, `0.0` off it:
/// `0.0 + m` is kept, which turns `-0.0` into `+0.0` as there).
#[inline(always)]
fn diag_plus<const N: usize>(s: f64, m: &Cols<N>) -> Cols<N> {
    map(m, |i, j, v| if i == j { s } else { 0.0 } + v)
}

#[inline(always)]
pub fn to_m<const N: usize>(x: &Cols<N>) -> M<N> {
    M::<N>::from_fn(|i, j| x[j][i])
}

/// Whether the scaled argument `x` has the layout of the Furuta (and cart) Jacobian
/// `[[0, I], [A, B]]` with an absent coordinate: `N = 4`, rows 0 and 2 zero but for
/// `x[0][1]` and `x[2][3]` (the identity block times `h/2^s`), column 2 zero (the arm angle
/// or cart position appears nowhere in the right-hand side). Zeros of either sign.
///
/// Then every `phi_k(x)` has column 2 equal to `phi_k(0) e_2` (`+0.0` off the diagonal), and
/// the products of `phis_before_last` skip the terms that are zero: the Horner products
/// `x p` (followed by `c I + .`, which maps either zero to `+0.0`) keep 3 terms in rows 1
/// and 3 and one in rows 0 and 2, of columns 0, 1 and 3 only; the doubling products `e m`
/// (`e`'s column 2 is `e_2`) skip column 2. Bit for bit the full products: a zero term `t`
/// leaves a sum `a + t` equal to `a` for `a != 0` and changes at most the sign of a zero
/// sum, and the Horner sums end in `c + .` or `0.0 + .`, which forget that sign (see
/// `horner_sparse`); a doubling product's column 2 is `+0.0` off the diagonal (one
/// `+0.0 * m[2][2]` term, `m[2][2] > 0`, among zeros) and `m[2][2]` on it. This needs finite
/// operands (`0 * inf` is NaN): the Horner stage is finite (`|x|_1 <= 1/2`), and a doubling
/// level with a non-finite entry in a matrix leaves one in the same matrix, in columns 0, 1
/// or 3, at every later level (each `q_k` adds `e p_k`, which spreads it over a column or a
/// row; column 2 is never computed from it), so finite columns 0, 1, 3 at the last level
/// mean finite operands everywhere; `phis_before_last` checks that (after at least one
/// doubling) and else recomputes with the full products.
#[inline(always)]
pub fn sparse_layout<const N: usize>(x: &Cols<N>) -> bool {
    N == 4 && [x[0][0], x[2][0], x[3][0], x[0][2], x[1][2], x[2][2], x[2][1], x[2][3]].iter().all(|&v| v == 0.0)
}

/// A [`sparse_layout`] Horner iterate: its columns 0, 1, 3 (column 2 is `c e_2`), each as
/// rows `(0, 2)` and rows `(1, 3)`, the pairs its product with `x` takes and gives.
type Pairs = [[[f64; 2]; 2]; 3];

/// The entries of a [`sparse_layout`] `x` that may be non-zero as pairs of rows `(0, 2)`
/// and `(1, 3)`: `(x01, x23)`, then `(x1k, x3k)` for `k = 0, 1, 3`.
struct SparseX {
    pos: [f64; 2],
    vel: [[f64; 2]; 3],
}

#[inline(always)]
fn mul2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] * b[0], a[1] * b[1]]
}

#[inline(always)]
fn add2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

/// `c I + x p` for a [`sparse_layout`] `x` and `p` with column 2 zero off the diagonal
/// (a Horner iterate) up to the sign of zero entries: [`diag_plus`] of [`mm`] with the zero
/// terms left out, and `c` added on the diagonal only (`0.0 +` elsewhere, which maps `-0.0`
/// to `+0.0`, is left to [`pairs_to_cols`]). Row 0 is `x01 p1j`, row 2 `x23 p3j`, row
/// `i = 1, 3` is `xi3 p3j + (xi1 p1j + xi0 p0j)` (mm's order without the `k = 2` term).
/// Column 2 stays `c e_2` (its products are zero).
///
/// The sign of zeros may stay open over the whole Horner stage: products and sums of
/// operands equal up to the sign of zeros are equal up to the sign of zeros (a term that is
/// zero, or left out, changes a sum only if the rest is zero, and then only its sign), so
/// every iterate is the full code's up to the sign of zeros; the full code's iterates hold
/// no `-0.0` (`0.0 + y` and `c + y`, `c > 0`, never are), so one `0.0 +` at the end gives
/// them bit for bit.
#[inline(always)]
fn horner_sparse(x: &SparseX, p: &Pairs, c: f64) -> Pairs {
    let [v0, v1, v3] = x.vel;
    let col = |[ev, od]: [[f64; 2]; 2]| {
        let y_ev = mul2(x.pos, od);
        let y_od = add2(mul2(v3, [od[1]; 2]), add2(mul2(v1, [od[0]; 2]), mul2(v0, [ev[0]; 2])));
        [y_ev, y_od]
    };
    let [[e0, o0], [e1, o1], [e3, o3]] = [col(p[0]), col(p[1]), col(p[2])];
    // c on the diagonal: (0, 0), (1, 1), (3, 3); 0.0 on the other lane changes at most the
    // sign of a zero.
    [[add2(e0, [c, 0.0]), o0], [e1, add2(o1, [c, 0.0])], [e3, add2(o3, [0.0, c])]]
}

/// A [`Pairs`] iterate as a matrix, `c22` its entry `(2, 2)`, every entry `0.0 +` (the
/// sign of zero [`horner_sparse`] left open: `+0.0`, as `c I + x p` gives).
#[inline(always)]
fn pairs_to_cols<const N: usize>(p: &Pairs, c22: f64) -> Cols<N> {
    let mut out = [[0.0; N]; N];
    for (&[ev, od], j) in p.iter().zip([0, 1, 3]) {
        let (ev, od) = (add2([0.0; 2], ev), add2([0.0; 2], od));
        out[j][0] = ev[0];
        out[j][1] = od[0];
        out[j][2] = ev[1];
        out[j][3] = od[1];
    }
    out[2][2] = c22;
    out
}

/// `a * b` as [`mm`], or for the [`sparse_layout`] (`SPARSE`: `a`'s column 2 is `e_2`, `b`'s
/// column 2 zero off the diagonal) column 2 as `(+0.0, +0.0, b[2][2], +0.0)`, bit for bit.
#[inline(always)]
fn mm_l<const N: usize, const SPARSE: bool>(a: &Cols<N>, b: &Cols<N>) -> Cols<N> {
    if !SPARSE {
        return mm(a, b);
    }
    let mut c = [[0.0; N]; N];
    for j in [0, 1, 3] {
        let (y, bj) = (&mut c[j], &b[j]);
        for i in 0..N {
            y[i] = a[0][i] * bj[0];
        }
        for k in 1..N {
            for i in 0..N {
                y[i] = a[k][i] * bj[k] + y[i];
            }
        }
    }
    c[2][2] = b[2][2];
    c
}

/// [`map`], or for the [`sparse_layout`] (`SPARSE`) column 2 as `(+0.0, +0.0, f(2, 2, .),
/// +0.0)`: the doubling maps keep `+0.0` off the diagonal there.
#[inline(always)]
fn map_l<const N: usize, const SPARSE: bool>(x: &Cols<N>, f: impl Fn(usize, usize, f64) -> f64) -> Cols<N> {
    if !SPARSE {
        return map(x, f);
    }
    let mut c = [[0.0; N]; N];
    for j in [0, 1, 3] {
        for (i, (o, &v)) in c[j].iter_mut().zip(&x[j]).enumerate() {
            *o = f(i, j, v);
        }
    }
    c[2][2] = f(2, 2, x[2][2]);
    c
}

/// `double::<N, true>` in place, column by column: column `j` of the products `e m` needs
/// `e` and column `j` of `m`, column `j` of the `q_k` column `j` of the `p_k`, so each column
/// is replaced once computed (`e` kept aside); column 2 only on the diagonal (`+0.0` stays
/// `+0.0` off it). The same operations in the same order.
#[inline(always)]
fn double_sparse_in_place<const N: usize>(p: &mut [Cols<N>; 5]) {
    let e = p[0];
    // A loop, not unrolled: one column's work at a time.
    for j in 0..N {
        if j == 2 {
            continue;
        }
        let col = |m: &[f64; N]| {
            let mut y = [0.0; N];
            for i in 0..N {
                y[i] = e[0][i] * m[0];
            }
            for k in 1..N {
                for i in 0..N {
                    y[i] = e[k][i] * m[k] + y[i];
                }
            }
            y
        };
        let [c0, c1, c2, c3, c4] = [p[0][j], p[1][j], p[2][j], p[3][j], p[4][j]];
        let (e2, ep1, ep2, ep3, ep4) = (col(&c0), col(&c1), col(&c2), col(&c3), col(&c4));
        for i in 0..N {
            p[0][j][i] = e2[i];
            p[1][j][i] = (ep1[i] + c1[i]) * 0.5;
            p[2][j][i] = ((ep2[i] + c1[i]) + c2[i]) * 0.25;
            p[3][j][i] = (((ep3[i] + c1[i] * 0.5) + c2[i]) + c3[i]) * 0.125;
            p[4][j][i] = ((((ep4[i] + c1[i] * INV_FACT[3]) + c2[i] * 0.5) + c3[i]) + c4[i]) * 0.0625;
        }
    }
    // Column 2 of e m is m[2][2] e_2; e[2][2] = 1 stays.
    let c: [f64; 5] = core::array::from_fn(|k| p[k][2][2]);
    p[1][2][2] = (c[1] + c[1]) * 0.5;
    p[2][2][2] = ((c[2] + c[1]) + c[2]) * 0.25;
    p[3][2][2] = (((c[3] + c[1] * 0.5) + c[2]) + c[3]) * 0.125;
    p[4][2][2] = ((((c[4] + c[1] * INV_FACT[3]) + c[2] * 0.5) + c[3]) + c[4]) * 0.0625;
}

/// `phi_k(x)`, `k = 0..=4`, at the scaled argument, then `doublings` doublings; `SPARSE`:
/// `x` has the [`sparse_layout`].
#[inline(always)]
fn taylor_and_doublings<const N: usize, const SPARSE: bool>(x: &Cols<N>, doublings: i32) -> [Cols<N>; 5] {
    let mut p = if SPARSE {
        let xs = SparseX { pos: [x[1][0], x[3][2]], vel: [[x[0][1], x[0][3]], [x[1][1], x[1][3]], [x[3][1], x[3][3]]] };
        // phi4(x) = sum_{j=0..DEG} x^j / (j+4)!, from c I.
        let c = INV_FACT[DEG + 4];
        let mut p4: Pairs = [[[c, 0.0], [0.0, 0.0]], [[0.0, 0.0], [c, 0.0]], [[0.0, 0.0], [0.0, c]]];
        for j in (0..DEG).rev() {
            p4 = horner_sparse(&xs, &p4, INV_FACT[j + 4]);
        }
        let p3 = horner_sparse(&xs, &p4, INV_FACT[3]);
        let p2 = horner_sparse(&xs, &p3, INV_FACT[2]);
        let p1 = horner_sparse(&xs, &p2, 1.0);
        let e = horner_sparse(&xs, &p1, 1.0);
        [
            pairs_to_cols(&e, 1.0),
            pairs_to_cols(&p1, 1.0),
            pairs_to_cols(&p2, INV_FACT[2]),
            pairs_to_cols(&p3, INV_FACT[3]),
            pairs_to_cols(&p4, INV_FACT[4]),
        ]
    } else {
        let mut p4 = map(x, |i, j, _| if i == j { INV_FACT[DEG + 4] } else { 0.0 });
        for j in (0..DEG).rev() {
            p4 = diag_plus(INV_FACT[j + 4], &mm(x, &p4));
        }
        let p3 = diag_plus(INV_FACT[3], &mm(x, &p4));
        let p2 = diag_plus(INV_FACT[2], &mm(x, &p3));
        let p1 = diag_plus(1.0, &mm(x, &p2));
        let e = diag_plus(1.0, &mm(x, &p1));
        [e, p1, p2, p3, p4]
    };
    for _ in 0..doublings {
        if SPARSE {
            double_sparse_in_place(&mut p);
        } else {
            p = double::<N, false>(&p);
        }
    }
    p
}

/// `phi_k(a/2)`, `k = 0..=4` (the level before the last doubling): the Taylor polynomial at
/// `a / 2^s` and `s - 1` doublings, and whether the [`sparse_layout`] products made them
/// (then valid for the last doubling too). `None` if `a` is not finite or too large to scale.
pub(crate) fn phis_before_last<const N: usize>(a: &Cols<N>) -> Option<([Cols<N>; 5], bool)> {
    // 1-norm: largest absolute column sum. A non-finite entry makes its column's sum
    // non-finite (sums of magnitudes), as does an overflow: refused either way.
    let mut norm = 0.0f64;
    for c in a {
        let sum: f64 = c.iter().map(|v| v.abs()).sum();
        if !sum.is_finite() {
            return None;
        }
        norm = norm.max(sum);
    }
    // At least one doubling, so that the level before the last is phi(a/2).
    let s = if norm > THETA { ceil_log2(norm / THETA) } else { 1 }.max(1);
    if s > MAX_DOUBLINGS {
        return None;
    }
    let f = pow2(-s);
    let x = map(a, |_, _, v| v * f);
    if sparse_layout(&x) {
        let p = taylor_and_doublings::<N, true>(&x, s - 1);
        // Finite (the sum of finite entries may still overflow: then the full products). The
        // Taylor stage is; a level's non-finite entry stays in every later level's columns
        // 0, 1, 3, which the doublings compute in full.
        if s == 1 || p.iter().flat_map(|m| [&m[0], &m[1], &m[3]]).flatten().sum::<f64>().is_finite() {
            return Some((p, true));
        }
    }
    Some((taylor_and_doublings::<N, false>(&x, s - 1), false))
}

/// `2^k` for `-1022 <= k <= 1023`: what `0.5f64.powi(-k)` gives (exact squarings and
/// products of powers of two).
#[inline(always)]
pub fn pow2(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// `q.log2().ceil() as i32` for `q > 1`: `e + 1` for `q = m 2^e` with `m` at least `2^-20`
/// from 1 and 2 (then `log2 q` is at least `1.4e-6` from an integer, far beyond the error of
/// any `log2`), else the library's `log2`.
#[inline(always)]
pub fn ceil_log2(q: f64) -> i32 {
    const MARGIN: u64 = 1 << 32;
    let bits = q.to_bits();
    let (biased, frac) = ((bits >> 52) & 0x7ff, bits & ((1 << 52) - 1));
    if biased != 0x7ff && (MARGIN..=(1 << 52) - MARGIN).contains(&frac) {
        biased as i32 - 1022
    } else {
        q.log2().ceil() as i32
    }
}

/// All `phi_k(a)`, `k = 0..=4`, of a matrix `a`, plus `phi1(a/2)`. `None` if `a` is not
/// finite or too large to scale.
pub fn phis_of<const N: usize>(a: &M<N>) -> Option<(M<N>, [M<N>; 5])> {
    let a: Cols<N> = core::array::from_fn(|j| core::array::from_fn(|i| a[(i, j)]));
    let (p, sparse) = phis_before_last(&a)?;
    let last = if sparse { double::<N, true>(&p) } else { double::<N, false>(&p) };
    Some((to_m(&p[1]), last.map(|m| to_m(&m))))
}

/// `q1 = (e p1 + p1) / 2`, `q3 = (e p3 + p1/2 + p2 + p3) / 8`,
/// `q4 = (e p4 + p1/6 + p2/2 + p3 + p4) / 16`: [`double`]'s `phi_1`, `phi_3`, `phi_4`.
#[inline(always)]
fn double_134<const N: usize, const SPARSE: bool>(p: &[Cols<N>; 5]) -> [Cols<N>; 3] {
    let [e, p1, p2, p3, p4] = p;
    let (ep1, ep3, ep4) = (mm_l::<N, SPARSE>(e, p1), mm_l::<N, SPARSE>(e, p3), mm_l::<N, SPARSE>(e, p4));
    let q1 = map_l::<N, SPARSE>(&ep1, |i, j, v| (v + p1[j][i]) * 0.5);
    let q3 = map_l::<N, SPARSE>(&ep3, |i, j, v| (((v + p1[j][i] * 0.5) + p2[j][i]) + p3[j][i]) * 0.125);
    let q4 = map_l::<N, SPARSE>(&ep4, |i, j, v| {
        ((((v + p1[j][i] * INV_FACT[3]) + p2[j][i] * 0.5) + p3[j][i]) + p4[j][i]) * 0.0625
    });
    [q1, q3, q4]
}

/// `phi_k(2X)` from `phi_k(X)`, `k = 0..=4`.
#[inline(always)]
pub(crate) fn double<const N: usize, const SPARSE: bool>(p: &[Cols<N>; 5]) -> [Cols<N>; 5] {
    let [e, p1, p2, _, _] = p;
    let e2 = mm_l::<N, SPARSE>(e, e);
    let ep2 = mm_l::<N, SPARSE>(e, p2);
    let q2 = map_l::<N, SPARSE>(&ep2, |i, j, v| ((v + p1[j][i]) + p2[j][i]) * 0.25);
    let [q1, q3, q4] = double_134::<N, SPARSE>(p);
    [e2, q1, q2, q3, q4]
}

/// The matrix functions one `exprb43` step of size `h` needs, at Jacobian `jac`: the
/// doublings on plain arrays with nalgebra's operations in its order (bit for bit the former
/// nalgebra code), the last doubling only for `phi1`, `phi3` and `phi4`.
#[inline]
pub fn phis<const N: usize>(jac: &[[f64; N]; N], h: f64) -> Option<Phis<N>> {
    let a: Cols<N> = core::array::from_fn(|j| core::array::from_fn(|i| h * jac[i][j]));
    let (p, sparse) = phis_before_last(&a)?;
    let [p1, p3, p4] = if sparse { double_134::<N, true>(&p) } else { double_134::<N, false>(&p) };
    Some(Phis { p1_half: to_m(&p[1]), p1: to_m(&p1), p3: to_m(&p3), p4: to_m(&p4) })
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
pub fn step<const N: usize>(
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
