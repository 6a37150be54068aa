//! Extended normal form of polynomial SSM-reduced dynamics, in polar coordinates (paper
//! appendix A, "Polynomial reduced dynamics", and the normal-form table of section 3.1).
//!
//! # Algorithm
//!
//! 1. Modal coordinates. The linear part `A` of the reduced dynamics (`DR(0)` of a flow,
//!    `DF(0)` of a map) must have `d/2` complex-conjugate pairs. Pairs are ordered by
//!    increasing frequency (continuous-time imaginary part, `arg(mu)/dt` for maps), so mode 1
//!    is the slowest oscillation. With `w_j` the eigenvector of the eigenvalue with positive
//!    imaginary part, `eta = W q`, `W = [w_1, conj w_1, w_2, conj w_2, ...]`,
//!    `q = (z_1, conj z_1, z_2, conj z_2, ...)`.
//! 2. Near-identity transformations `q = u + h(u)`, order by order (2..=K), solving the
//!    homological equation `(m.lambda - lambda_i) h_{i,m} + n_{i,m} = g_{i,m}` for a flow and
//!    `(mu^m - mu_i) h_{i,m} + n_{i,m} = g_{i,m}` for a map, where `g` collects the order-`m`
//!    terms of the field composed with the lower-order transformation. A term is kept in the
//!    normal form (`h = 0`, `n = g`) when it is *structurally near-resonant*: in the equation
//!    of `z_i` the monomial is `z_i |z_1|^{2a} |z_2|^{2b}` (exactly the terms that survive in
//!    polar form; their divisors are the real parts of eigenvalue combinations, small near
//!    the bifurcation). Any other term whose divisor is below `small_divisor` (relative to
//!    `|lambda_i|` for flows, absolute for maps) is kept as well and reported in
//!    [`PolarNormalForm::extra_resonances`]: it is part of the normal form but has no place
//!    in the rotation-invariant polar table.
//! 3. Polar form. A flow normal form `z_i' = z_i (lambda_i + sum beta_{i,ab} P_1^a P_2^b)`,
//!    `P_j = rho_j^2`, gives `rho_i' = rho_i (Re lambda_i + sum Re beta P^ab)` and
//!    `theta_i' = Im lambda_i + sum Im beta P^ab`. A map normal form
//!    `z_i -> z_i M_i(P)` is converted to the flow whose time-`dt` map it is (its logarithm):
//!    the polar map `P_i -> P_i |M_i(P)|^2`, `theta_i -> theta_i + arg M_i(P)` is matched
//!    coefficient by coefficient by the exact time-`dt` map of the polar flow
//!    `P_i' = 2 P_i A_i(P)`, `theta_i' = Omega_i(P)`, computed with Lie series (fixed-point
//!    iteration on the coefficients). The linear terms are then exactly `ln|mu_i|/dt` and
//!    `arg(mu_i)/dt` (principal branch), the convention of `stability::dominant_pairs`.
//!
//! # Amplitude normalization
//!
//! Nonlinear coefficients scale with the eigenvector normalization (`rho -> s rho` turns the
//! coefficient of `rho^(2k+1)` into `s^-2k` times itself); the phase of `w_j` does not
//! matter for the polar coefficients. Two conventions ([`Normalization`]):
//! * `Observable(c)`: `c . w_j = 1/2` (real), where `c` is the linear observable row, e.g.
//!   the first row of the manifold's tangent basis `V1` (the observable `x_n` itself). Then
//!   at linear order `x = sum_j rho_j cos(theta_j)`: `rho_j` is the amplitude of mode `j` in
//!   the observable's units. This is independent of the embedding (`p`, shift) and of `V1`'s
//!   orientation, so coefficients are comparable across fits and sampling periods. It is the
//!   convention of [`SsmModel`]-based calls.
//! * `UnitEigenvectors`: `|w_j|_2 = 1` in reduced coordinates `eta` (MATLAB-`eig`-like;
//!   depends on the embedding).

// Index loops mirror the formulas over small fixed dimensions.
#![allow(clippy::needless_range_loop)]

use std::collections::{BTreeMap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use faer::Mat;
use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::dynamics::ReducedDynamics;
use super::fit::SsmModel;
use super::poly::{self, Poly};

type C = Complex<f64>;

/// A sparse complex polynomial: exponent vector -> coefficient.
type SPoly = BTreeMap<Vec<u32>, C>;

/// Errors of the normal-form computation.
#[derive(Debug, Error)]
pub enum NormalFormError {
    #[error("normal form needs polynomial reduced dynamics (flow or map), got an RBF map")]
    NotPolynomial,
    #[error("normal form needs an even SSM dimension (complex-conjugate pairs), got d = {0}")]
    OddDimension(usize),
    #[error("normal form order {0} unsupported (need 1..=9)")]
    Order(u32),
    #[error(
        "the linear part has a real eigenvalue {re:.6e} (+ {im:.3e} i); the polar normal form needs oscillatory modes"
    )]
    RealEigenvalue { re: f64, im: f64 },
    #[error("eigen-decomposition of the linear part failed: {0}")]
    Eigen(&'static str),
    #[error("normalization: {0}")]
    Normalization(String),
    #[error("map-to-flow conversion did not converge (residual {residual:.3e} after {iterations} iterations)")]
    NoConvergence { residual: f64, iterations: usize },
}

/// Eigenvector scaling convention (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Normalization {
    /// `c . w_j = 1/2`: `rho_j` is the mode amplitude in the observable `c . eta`.
    Observable(Vec<f64>),
    /// The observable `x(eta)`, a scalar polynomial (`dim_out = 1`, degrees `1..`): its
    /// linear row normalizes the eigenvectors as `Observable` does, and the resonant part of
    /// the near-identity transformation (free in the homological equation) is chosen so
    /// that the first-harmonic part of `x(W (u + h(u)))` is exactly
    /// `sum_j (z_j + conj z_j) / 2` at every order: on an invariant torus of the polar
    /// form, `rho_j` is the observable's first-harmonic amplitude at mode `j`'s frequency
    /// (the convention of `map_ssm::Amplitude::Observable` on the equation side).
    FirstHarmonic(Poly),
    /// `|w_j|_2 = 1` in reduced coordinates.
    UnitEigenvectors,
}

/// Options of the normal-form computation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NormalFormOptions {
    /// Highest order kept (defaults to the polynomial's order).
    pub order: Option<u32>,
    /// Small-divisor threshold (relative to `|lambda_i|` for flows, absolute for maps).
    pub small_divisor: f64,
    pub normalization: Normalization,
}

impl Default for NormalFormOptions {
    fn default() -> Self {
        NormalFormOptions { order: None, small_divisor: 1e-3, normalization: Normalization::UnitEigenvectors }
    }
}

/// A non-structural term kept because of a small divisor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExtraResonance {
    /// Equation (0-based index into `(z_1, conj z_1, z_2, ...)`).
    pub equation: usize,
    /// Exponents of `(z_1, conj z_1, z_2, conj z_2, ...)`.
    pub exponents: Vec<u32>,
    pub coefficient: (f64, f64),
    pub divisor: f64,
}

/// Polar extended normal form `rho_i' = rho_i sum_k amp[i][k] P^pexps[k]`,
/// `theta_i' = sum_k phase[i][k] P^pexps[k]`, `P_j = rho_j^2`, modes ordered by frequency.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PolarNormalForm {
    /// Number of oscillatory modes (d / 2).
    pub modes: usize,
    /// Highest order in rho (odd).
    pub order: u32,
    /// Exponent vectors of `P = (rho_1^2, rho_2^2, ...)`, total degree `0..=(order-1)/2`,
    /// in [`poly::exponents`] order.
    pub pexps: Vec<Vec<u32>>,
    /// Amplitude coefficients, `modes x pexps.len()`.
    pub amp: Vec<Vec<f64>>,
    /// Phase (frequency) coefficients in rad/s, `modes x pexps.len()`.
    pub phase: Vec<Vec<f64>>,
    /// Continuous-time eigenvalues (re, im) of the modes, im > 0, in mode order.
    pub eigenvalues: Vec<(f64, f64)>,
    pub normalization: Normalization,
    /// Non-structural terms kept because of small divisors.
    pub extra_resonances: Vec<ExtraResonance>,
    /// Smallest divisor met among removed terms (relative for flows, absolute for maps).
    pub min_divisor: f64,
    /// `Some(dt)` when computed from a map (then converted to the flow as described).
    pub map_dt: Option<f64>,
}

/// One row of a normal-form coefficient table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableRow {
    /// 1-based mode of the equation (`rho_i'`).
    pub mode: usize,
    /// Exponents of `(rho_1, rho_2, ...)` of the monomial.
    pub rho_exps: Vec<u32>,
    /// The monomial as text, e.g. `rho_1 rho_2^2`.
    pub monomial: String,
    pub value: f64,
}

/// The `rho_i'` coefficient table (paper section 3.1 layout: all rows of `rho_1'`, then
/// all rows of `rho_2'`, each by increasing order).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NormalFormTable {
    pub rows: Vec<TableRow>,
}

fn monomial_text(e: &[u32]) -> String {
    let parts: Vec<String> = e
        .iter()
        .enumerate()
        .filter(|(_, k)| **k > 0)
        .map(|(j, &k)| if k == 1 { format!("rho_{}", j + 1) } else { format!("rho_{}^{k}", j + 1) })
        .collect();
    if parts.is_empty() { "1".into() } else { parts.join(" ") }
}

impl NormalFormTable {
    /// Coefficient of `monomial` (text as in [`TableRow::monomial`]) in `rho_mode'`.
    pub fn get(&self, mode: usize, monomial: &str) -> Option<f64> {
        self.rows.iter().find(|r| r.mode == mode && r.monomial == monomial).map(|r| r.value)
    }

    /// Plain-text table: one line per row, `rho_i'  monomial  value`.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for r in &self.rows {
            s.push_str(&format!("rho_{}'  {:<20} {:>12.5}\n", r.mode, r.monomial, r.value));
        }
        s
    }
}

impl PolarNormalForm {
    /// Linear growth rates `Re lambda_i` (1/s), in mode order.
    pub fn linear_rates(&self) -> Vec<f64> {
        self.amp.iter().map(|a| a[0]).collect()
    }

    /// The `rho_i'` table rows: for mode `i`, the monomials `rho_i P^k`, by increasing order.
    pub fn table(&self) -> NormalFormTable {
        let mut rows = Vec::new();
        for i in 0..self.modes {
            for (k, pe) in self.pexps.iter().enumerate() {
                let mut e: Vec<u32> = pe.iter().map(|p| 2 * p).collect();
                e[i] += 1;
                rows.push(TableRow { mode: i + 1, monomial: monomial_text(&e), rho_exps: e, value: self.amp[i][k] });
            }
        }
        NormalFormTable { rows }
    }

    /// Evaluates `(rho', theta')` at amplitudes `rho`.
    pub fn eval(&self, rho: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let p: Vec<f64> = rho.iter().map(|r| r * r).collect();
        let mono: Vec<f64> =
            self.pexps.iter().map(|e| e.iter().zip(&p).map(|(&k, x)| x.powi(k as i32)).product()).collect();
        let dr =
            (0..self.modes).map(|i| rho[i] * self.amp[i].iter().zip(&mono).map(|(a, m)| a * m).sum::<f64>()).collect();
        let dth = (0..self.modes).map(|i| self.phase[i].iter().zip(&mono).map(|(a, m)| a * m).sum::<f64>()).collect();
        (dr, dth)
    }
}

// ---------------------------------------------------------------- polynomial algebra

fn deg(e: &[u32]) -> u32 {
    e.iter().sum()
}

fn add_into(acc: &mut SPoly, p: &SPoly, s: C) {
    for (e, c) in p {
        *acc.entry(e.clone()).or_insert(C::new(0.0, 0.0)) += c * s;
    }
}

/// The product truncated at total degree `maxdeg`. Every coefficient is the sum, from
/// `0`, of the products `ca * cb` in the order of `a`'s then `b`'s monomials (the maps'
/// order), and the product has an entry for every exponent some pair reaches (a zero
/// sum included). Exponents are packed into one `u64` (first variable in the high bits, so
/// the packed order is the maps' order; a sum of packed exponents is the packed sum as no
/// field can exceed `maxdeg`) and summed in a hash table; [`mul_btree`] (the same sums
/// through the map) when they do not fit.
fn mul(a: &SPoly, b: &SPoly, maxdeg: u32) -> SPoly {
    let Some(nvar) = a.keys().chain(b.keys()).next().map(Vec::len) else {
        return SPoly::new();
    };
    let bits = u32::BITS - maxdeg.leading_zeros();
    let packable = nvar > 0
        && (nvar as u32).saturating_mul(bits.max(1)) <= u64::BITS
        && a.keys().chain(b.keys()).all(|e| e.len() == nvar);
    if !packable {
        return mul_btree(a, b, maxdeg);
    }
    let bits = bits.max(1);
    // Only monomials of degree <= maxdeg can enter a product (their exponents fit `bits`).
    let pack = |p: &SPoly| -> Vec<(u64, u32, C)> {
        p.iter()
            .filter(|(e, _)| deg(e) <= maxdeg)
            .map(|(e, c)| (e.iter().fold(0u64, |k, &x| (k << bits) | u64::from(x)), deg(e), *c))
            .collect()
    };
    let (pa, pb) = (pack(a), pack(b));
    let mut slot: HashMap<u64, usize, BuildHasherDefault<PackedHasher>> = HashMap::default();
    let mut acc: Vec<(u64, C)> = Vec::new();
    for &(ka, da, ca) in &pa {
        for &(kb, db, cb) in &pb {
            if da + db > maxdeg {
                continue;
            }
            let k = ka + kb;
            let i = *slot.entry(k).or_insert_with(|| {
                acc.push((k, C::new(0.0, 0.0)));
                acc.len() - 1
            });
            acc[i].1 += ca * cb;
        }
    }
    acc.sort_unstable_by_key(|&(k, _)| k);
    let mask = (1u64 << bits) - 1;
    acc.into_iter()
        .map(|(k, c)| {
            let e: Vec<u32> = (0..nvar).map(|j| ((k >> (bits * (nvar - 1 - j) as u32)) & mask) as u32).collect();
            (e, c)
        })
        .collect()
}

/// [`mul`] through the map itself (any exponent sizes).
fn mul_btree(a: &SPoly, b: &SPoly, maxdeg: u32) -> SPoly {
    let mut out = SPoly::new();
    for (ea, ca) in a {
        let da = deg(ea);
        for (eb, cb) in b {
            if da + deg(eb) > maxdeg {
                continue;
            }
            let e: Vec<u32> = ea.iter().zip(eb).map(|(x, y)| x + y).collect();
            *out.entry(e).or_insert(C::new(0.0, 0.0)) += ca * cb;
        }
    }
    out
}

/// Hasher of [`mul`]'s packed exponents (one `u64` each): a multiplicative mix, the high
/// bits folded down (the table indexes by the low bits).
#[derive(Default)]
struct PackedHasher(u64);

impl Hasher for PackedHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u64(&mut self, k: u64) {
        let h = (self.0 ^ k).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 = h ^ (h >> 29);
    }
}

fn one(nvar: usize) -> SPoly {
    let mut p = SPoly::new();
    p.insert(vec![0; nvar], C::new(1.0, 0.0));
    p
}

fn var(nvar: usize, j: usize) -> SPoly {
    let mut e = vec![0; nvar];
    e[j] = 1;
    let mut p = SPoly::new();
    p.insert(e, C::new(1.0, 0.0));
    p
}

/// `f(sub)`: each component of `f` (polynomials in `sub.len()` variables) with variable `j`
/// replaced by `sub[j]`, truncated at total degree `maxdeg` (in the variables of `sub`).
/// Every `sub[j]` must vanish at the origin (no constant term).
fn compose(f: &[SPoly], sub: &[SPoly], nvar: usize, maxdeg: u32) -> Vec<SPoly> {
    // powers[j][k] = sub[j]^k
    let mut powers: Vec<Vec<SPoly>> = Vec::with_capacity(sub.len());
    for s in sub {
        let mut v = vec![one(nvar)];
        for k in 1..=maxdeg as usize {
            let next = mul(&v[k - 1], s, maxdeg);
            v.push(next);
        }
        powers.push(v);
    }
    f.iter()
        .map(|fi| {
            let mut out = SPoly::new();
            // `sub` has no constant terms, so monomials above `maxdeg` contribute nothing.
            for (e, c) in fi.iter().filter(|(e, _)| deg(e) <= maxdeg) {
                let mut term = one(nvar);
                for (j, &k) in e.iter().enumerate() {
                    if k > 0 {
                        term = mul(&term, &powers[j][k as usize], maxdeg);
                    }
                }
                add_into(&mut out, &term, *c);
            }
            out
        })
        .collect()
}

fn degree_part(p: &SPoly, k: u32) -> SPoly {
    p.iter().filter(|(e, _)| deg(e) == k).map(|(e, c)| (e.clone(), *c)).collect()
}

fn derivative(p: &SPoly, j: usize) -> SPoly {
    let mut out = SPoly::new();
    for (e, c) in p {
        if e[j] > 0 {
            let mut e2 = e.clone();
            e2[j] -= 1;
            *out.entry(e2).or_insert(C::new(0.0, 0.0)) += c * e[j] as f64;
        }
    }
    out
}

// ---------------------------------------------------------------- modal coordinates

struct Modal {
    /// Eigenvalues in variable order (z_1, conj z_1, ...): flow lambda or map mu.
    lam: Vec<C>,
    /// Nonlinear part of the modal field / map, one SPoly per equation.
    f: Vec<SPoly>,
    /// Eigenvector matrix: `eta = W q` (columns `w_1, conj w_1, ...`, normalized).
    w: DMatrix<C>,
    /// [`Normalization::FirstHarmonic`]: the observable's nonlinear part (degrees
    /// 2..=order) in `q`; its linear part in `q` is `1/2` for every variable.
    obs: Option<SPoly>,
}

/// Eigenvector of real `a` (d x d) for eigenvalue `lam` by inverse iteration.
fn eigenvector(a: &[f64], d: usize, lam: C) -> Result<DVector<C>, NormalFormError> {
    let shift = lam + C::new(1e-9 * lam.norm().max(1e-12), 1e-9 * lam.norm().max(1e-12));
    let m = DMatrix::from_fn(d, d, |i, j| C::new(a[i * d + j], 0.0) - if i == j { shift } else { C::new(0.0, 0.0) });
    let lu = m.lu();
    let mut x = DVector::from_fn(d, |i, _| C::new(1.0 + 0.1 * i as f64, 0.3 - 0.05 * i as f64));
    for _ in 0..4 {
        x = lu.solve(&x).ok_or(NormalFormError::Eigen("singular shifted matrix in inverse iteration"))?;
        let n = x.norm();
        if !n.is_finite() || n == 0.0 {
            return Err(NormalFormError::Eigen("inverse iteration diverged"));
        }
        x /= C::new(n, 0.0);
    }
    Ok(x)
}

/// Modal decomposition of polynomial dynamics. `is_map`: `poly` is the increment of
/// `F(eta) = eta + poly(eta)` at step `dt`; otherwise the field of `eta' = poly(eta)`.
fn modal(
    poly: &Poly,
    is_map: bool,
    dt: f64,
    order: u32,
    norm: &Normalization,
) -> Result<(Modal, Vec<(f64, f64)>), NormalFormError> {
    let d = poly.dim_in;
    if d == 0 || d % 2 == 1 {
        return Err(NormalFormError::OddDimension(d));
    }
    let mut a = poly.linear_part();
    if is_map {
        for i in 0..d {
            a[i * d + i] += 1.0;
        }
    }
    let am = Mat::from_fn(d, d, |i, j| a[i * d + j]);
    let ev = am.eigenvalues().map_err(|_| NormalFormError::Eigen("eigenvalues did not converge"))?;
    let scale = ev.iter().map(|z| z.re.hypot(z.im)).fold(0.0, f64::max).max(1e-300);
    let mut pos: Vec<C> = Vec::new();
    for z in ev.iter() {
        if z.im.abs() <= 1e-9 * scale {
            return Err(NormalFormError::RealEigenvalue { re: z.re, im: z.im });
        }
        if z.im > 0.0 {
            pos.push(C::new(z.re, z.im));
        }
    }
    if pos.len() * 2 != d {
        return Err(NormalFormError::Eigen("eigenvalues do not form conjugate pairs"));
    }
    let ct = |z: C| if is_map { C::new(z.norm().ln() / dt, z.im.atan2(z.re) / dt) } else { z };
    let row: Option<Vec<f64>> = match norm {
        Normalization::UnitEigenvectors => None,
        Normalization::Observable(c) => Some(c.clone()),
        Normalization::FirstHarmonic(x) => {
            if x.dim_in != d || x.dim_out != 1 || x.scale.len() != d || x.coef.len() != x.exps.len() {
                return Err(NormalFormError::Normalization(format!(
                    "the first-harmonic observable must map {d} inputs to 1 output, got {} -> {} ({} scales, {} coefficients for {} monomials)",
                    x.dim_in,
                    x.dim_out,
                    x.scale.len(),
                    x.coef.len(),
                    x.exps.len()
                )));
            }
            if let Some(k) = x.exps.iter().position(|e| e.len() != d || e.iter().sum::<u32>() == 0) {
                return Err(NormalFormError::Normalization(format!(
                    "first-harmonic observable monomial {k} {:?}: want {d} exponents of degree >= 1",
                    x.exps[k]
                )));
            }
            if x.scale.iter().chain(&x.coef).any(|v| !v.is_finite()) || x.scale.iter().any(|&v| v == 0.0) {
                return Err(NormalFormError::Normalization(
                    "first-harmonic observable: non-finite coefficient or zero scale".into(),
                ));
            }
            Some(x.linear_part())
        }
    };
    pos.sort_by(|x, y| ct(*x).im.total_cmp(&ct(*y).im));
    let mut cols: Vec<DVector<C>> = Vec::with_capacity(d);
    let mut lam = Vec::with_capacity(d);
    for &l in &pos {
        let mut w = eigenvector(&a, d, l)?;
        let s = match norm {
            Normalization::UnitEigenvectors => {
                // |w| = 1 already; fix the phase: largest-modulus entry real positive.
                let big = w.iter().copied().max_by(|x, y| x.norm().total_cmp(&y.norm())).unwrap_or(C::new(1.0, 0.0));
                big.conj() / big.norm()
            }
            Normalization::Observable(_) | Normalization::FirstHarmonic(_) => {
                let c = row.as_deref().unwrap_or(&[]);
                if c.len() != d {
                    return Err(NormalFormError::Normalization(format!(
                        "observable row has {} entries, d = {d}",
                        c.len()
                    )));
                }
                let cw: C = c.iter().zip(w.iter()).map(|(ci, wi)| wi * *ci).sum();
                if cw.norm() < 1e-12 * c.iter().map(|x| x * x).sum::<f64>().sqrt() {
                    return Err(NormalFormError::Normalization(
                        "the observable does not see a mode (c . w = 0); use UnitEigenvectors".into(),
                    ));
                }
                C::new(0.5, 0.0) / cw
            }
        };
        w *= s;
        cols.push(w.map(|x| x.conj()));
        let wl = cols.len() - 1;
        cols.insert(wl, w);
        lam.push(l);
        lam.push(l.conj());
    }
    let wm = DMatrix::from_fn(d, d, |i, j| cols[j][i]);
    let winv = wm.clone().try_inverse().ok_or(NormalFormError::Eigen("eigenvector matrix is singular"))?;
    // eta_j = sum_l W_jl q_l; a polynomial of `scale` takes eta_j / scale_j.
    let eta_in_q = |scale: &[f64]| -> Vec<SPoly> {
        (0..d)
            .map(|j| {
                let mut p = SPoly::new();
                for l in 0..d {
                    let mut e = vec![0; d];
                    e[l] = 1;
                    p.insert(e, wm[(j, l)] / scale[j]);
                }
                p
            })
            .collect()
    };
    // The degree 2..=order terms of each output of a polynomial, as complex polynomials.
    let nonlinear = |p: &Poly| -> Vec<SPoly> {
        (0..p.dim_out)
            .map(|o| {
                p.exps
                    .iter()
                    .enumerate()
                    .filter(|(_, e)| deg(e) >= 2 && deg(e) <= order)
                    .map(|(k, e)| (e.clone(), C::new(p.coef[k * p.dim_out + o], 0.0)))
                    .collect()
            })
            .collect()
    };
    let in_eta = compose(&nonlinear(poly), &eta_in_q(&poly.scale), d, order);
    let f: Vec<SPoly> = (0..d)
        .map(|i| {
            let mut out = SPoly::new();
            for j in 0..d {
                add_into(&mut out, &in_eta[j], winv[(i, j)]);
            }
            out.retain(|e, _| deg(e) >= 2);
            out
        })
        .collect();
    let obs = match norm {
        Normalization::FirstHarmonic(x) => {
            // `x` is a scalar (`dim_out = 1`, checked above).
            let mut q = compose(&nonlinear(x), &eta_in_q(&x.scale), d, order).pop().unwrap_or_default();
            q.retain(|e, _| deg(e) >= 2);
            Some(q)
        }
        _ => None,
    };
    let eig_ct: Vec<(f64, f64)> = pos.iter().map(|&z| (ct(z).re, ct(z).im)).collect();
    Ok((Modal { lam, f, w: wm, obs }, eig_ct))
}

/// Structural resonance: in the equation of variable `i` (pair `i/2`, conjugate if odd),
/// `m_{2j} - m_{2j+1} = +-delta_{j, i/2}` for every pair `j`.
fn structural(i: usize, m: &[u32]) -> bool {
    let sign: i64 = if i % 2 == 0 { 1 } else { -1 };
    (0..m.len() / 2).all(|j| m[2 * j] as i64 - m[2 * j + 1] as i64 == if j == i / 2 { sign } else { 0 })
}

struct Normalized {
    /// Normal-form nonlinear terms per equation.
    n: Vec<SPoly>,
    /// Near-identity transformation `q = u + h(u)`, nonlinear part per variable.
    h: Vec<SPoly>,
    extra: Vec<ExtraResonance>,
    min_div: f64,
}

fn normalize(md: &Modal, order: u32, is_map: bool, small: f64) -> Normalized {
    let d = md.lam.len();
    let mut h: Vec<SPoly> = vec![SPoly::new(); d];
    let mut n: Vec<SPoly> = vec![SPoly::new(); d];
    let mut extra = Vec::new();
    let mut min_div = f64::INFINITY;
    for k in 2..=order {
        let t: Vec<SPoly> = (0..d)
            .map(|i| {
                let mut p = var(d, i);
                add_into(&mut p, &h[i], C::new(1.0, 0.0));
                p
            })
            .collect();
        let ft = compose(&md.f, &t, d, k);
        let mut g: Vec<SPoly> = ft.iter().map(|p| degree_part(p, k)).collect();
        if is_map {
            // subtract [h_{<k}(Lambda u + n_{<k}(u))]_k
            let nmap: Vec<SPoly> = (0..d)
                .map(|i| {
                    let mut p = SPoly::new();
                    let mut e = vec![0; d];
                    e[i] = 1;
                    p.insert(e, md.lam[i]);
                    add_into(&mut p, &n[i], C::new(1.0, 0.0));
                    p
                })
                .collect();
            let hn = compose(&h, &nmap, d, k);
            for i in 0..d {
                add_into(&mut g[i], &degree_part(&hn[i], k), C::new(-1.0, 0.0));
            }
        } else {
            // subtract [Dh_{<k} n_{<k}]_k
            for i in 0..d {
                for j in 0..d {
                    let dh = derivative(&h[i], j);
                    let prod = mul(&dh, &n[j], k);
                    add_into(&mut g[i], &degree_part(&prod, k), C::new(-1.0, 0.0));
                }
            }
        }
        let divisor = |i: usize, m: &[u32]| -> C {
            if is_map {
                let mut mu = C::new(1.0, 0.0);
                for (j, &p) in m.iter().enumerate() {
                    mu *= md.lam[j].powu(p);
                }
                mu - md.lam[i]
            } else {
                let s: C = m.iter().zip(&md.lam).map(|(&p, l)| l * p as f64).sum();
                s - md.lam[i]
            }
        };
        // Structural terms wait until the non-resonant part of h at this order is known.
        let mut resonant: Vec<(usize, Vec<u32>, C)> = Vec::new();
        for i in 0..d {
            for (m, c) in &g[i] {
                let div = divisor(i, m);
                let rel = if is_map { div.norm() } else { div.norm() / md.lam[i].norm() };
                if structural(i, m) {
                    resonant.push((i, m.clone(), *c));
                } else if rel < small {
                    extra.push(ExtraResonance {
                        equation: i,
                        exponents: m.clone(),
                        coefficient: (c.re, c.im),
                        divisor: rel,
                    });
                    n[i].insert(m.clone(), *c);
                } else {
                    min_div = min_div.min(rel);
                    h[i].insert(m.clone(), c / div);
                }
            }
        }
        if let Some(obs) = &md.obs {
            // First harmonic: the coefficient of the structural monomial m (equation i) in
            // x(W (u + h(u))) is [obs(u + h_{<k})]_m + (1/2) sum_l h_{l,m} (c . w_l = 1/2);
            // h_{i,m} = alpha makes it vanish, and the homological equation then keeps
            // n_{i,m} = g_{i,m} - divisor * alpha.
            let x = compose(std::slice::from_ref(obs), &t, d, k).pop().unwrap_or_default();
            for (m, _) in x.iter().filter(|(m, _)| deg(m) == k) {
                for i in 0..d {
                    if structural(i, m) && !resonant.iter().any(|(j, e, _)| *j == i && e == m) {
                        resonant.push((i, m.clone(), C::new(0.0, 0.0)));
                    }
                }
            }
            for (i, m, c) in resonant {
                let xm = x.get(&m).copied().unwrap_or(C::new(0.0, 0.0));
                let others: C = (0..d).filter_map(|l| h[l].get(&m)).sum();
                let alpha = -2.0 * xm - others;
                h[i].insert(m.clone(), alpha);
                n[i].insert(m.clone(), c - divisor(i, &m) * alpha);
            }
        } else {
            for (i, m, c) in resonant {
                n[i].insert(m, c);
            }
        }
    }
    Normalized { n, h, extra, min_div }
}

/// Extracts `beta_{i,ab}` (complex, indexed by `pexps`) from the equation of `z_i`.
fn resonant_coefficients(n: &[SPoly], modes: usize, pexps: &[Vec<u32>]) -> Vec<Vec<C>> {
    (0..modes)
        .map(|i| {
            pexps
                .iter()
                .map(|pe| {
                    let mut m = vec![0u32; 2 * modes];
                    for j in 0..modes {
                        m[2 * j] = pe[j];
                        m[2 * j + 1] = pe[j];
                    }
                    m[2 * i] += 1;
                    n[2 * i].get(&m).copied().unwrap_or(C::new(0.0, 0.0))
                })
                .collect()
        })
        .collect()
}

/// Lie-series time-`dt` map of the polar flow `P_i' = 2 P_i A_i(P)`, `theta_i' = Om_i(P)`:
/// returns (`P_i(dt) / P_i` as polynomials, `theta_i(dt) - theta_i`), truncated at
/// degree `kmax` in P.
fn polar_flow_map(a: &[SPoly], om: &[SPoly], dt: f64, kmax: u32) -> (Vec<SPoly>, Vec<SPoly>) {
    let m = a.len();
    // L g = sum_j 2 P_j A_j dg/dP_j
    let vf: Vec<SPoly> = (0..m)
        .map(|j| {
            let mut p = mul(&var(m, j), &a[j], kmax + 1);
            p.values_mut().for_each(|c| *c *= 2.0);
            p
        })
        .collect();
    let lie = |g: &SPoly| {
        let mut out = SPoly::new();
        for j in 0..m {
            add_into(&mut out, &mul(&derivative(g, j), &vf[j], kmax + 1), C::new(1.0, 0.0));
        }
        out
    };
    let series = |g0: SPoly, start: i32| {
        // sum_{k>=0} dt^(k+start)/(k+start)! L^k g0
        let mut acc = SPoly::new();
        let mut term = g0;
        let mut fac = 1.0;
        for s in 1..=start {
            fac *= dt / s as f64;
        }
        for k in 0..200 {
            add_into(&mut acc, &term, C::new(fac, 0.0));
            let size = term.values().map(|c| c.norm()).fold(0.0, f64::max) * fac;
            let accs = acc.values().map(|c| c.norm()).fold(0.0, f64::max);
            if size <= 1e-17 * accs.max(1e-300) && k > 2 {
                break;
            }
            term = lie(&term);
            fac *= dt / (k as i32 + 1 + start) as f64;
        }
        acc
    };
    let pm: Vec<SPoly> = (0..m)
        .map(|i| {
            let full = series(var(m, i), 0);
            // divide by P_i
            full.into_iter()
                .filter(|(e, _)| e[i] >= 1)
                .map(|(mut e, c)| {
                    e[i] -= 1;
                    (e, c)
                })
                .filter(|(e, _)| deg(e) <= kmax)
                .collect()
        })
        .collect();
    let th: Vec<SPoly> =
        (0..m).map(|i| series(om[i].clone(), 1).into_iter().filter(|(e, _)| deg(e) <= kmax).collect()).collect();
    (pm, th)
}

fn to_dense(p: &SPoly, pexps: &[Vec<u32>]) -> Vec<f64> {
    pexps.iter().map(|e| p.get(e).map(|c| c.re).unwrap_or(0.0)).collect()
}

fn from_dense(v: &[f64], pexps: &[Vec<u32>]) -> SPoly {
    pexps.iter().zip(v).map(|(e, &x)| (e.clone(), C::new(x, 0.0))).collect()
}

/// Converts a polar map normal form `z_i -> z_i M_i(P)` into the polar flow whose time-`dt`
/// map it is. Returns (`amp`, `phase`).
pub(crate) fn map_to_flow(
    beta: &[Vec<C>],
    mu: &[C],
    pexps: &[Vec<u32>],
    dt: f64,
) -> Result<(Vec<Vec<f64>>, Vec<Vec<f64>>), NormalFormError> {
    let m = mu.len();
    let kmax = poly::max_degree(pexps);
    let mut targ_p = Vec::with_capacity(m);
    let mut targ_th = Vec::with_capacity(m);
    for i in 0..m {
        let mi: SPoly =
            pexps.iter().zip(&beta[i]).map(|(e, &b)| (e.clone(), if deg(e) == 0 { mu[i] } else { b })).collect();
        let mic: SPoly = mi.iter().map(|(e, c)| (e.clone(), c.conj())).collect();
        targ_p.push(to_dense(&mul(&mi, &mic, kmax), pexps));
        // arg M = Im log M = arg mu + Im sum (-1)^(k+1) x^k / k, x = (M - mu)/mu
        let x: SPoly = mi.iter().filter(|(e, _)| deg(e) > 0).map(|(e, c)| (e.clone(), c / mu[i])).collect();
        let mut lg = SPoly::new();
        let mut xp = one(m);
        for k in 1..=kmax.max(1) {
            xp = mul(&xp, &x, kmax);
            let s = if k % 2 == 1 { 1.0 } else { -1.0 } / k as f64;
            add_into(&mut lg, &xp, C::new(s, 0.0));
        }
        let mut th: Vec<f64> = pexps.iter().map(|e| lg.get(e).map(|c| c.im).unwrap_or(0.0)).collect();
        th[0] = mu[i].im.atan2(mu[i].re);
        targ_th.push(th);
    }
    let mut amp: Vec<Vec<f64>> = (0..m)
        .map(|i| {
            let mut v: Vec<f64> = targ_p[i].iter().map(|t| t / (2.0 * dt * mu[i].norm_sqr())).collect();
            v[0] = mu[i].norm().ln() / dt;
            v
        })
        .collect();
    let mut phase: Vec<Vec<f64>> = targ_th.iter().map(|t| t.iter().map(|x| x / dt).collect()).collect();
    let scale_p: f64 = targ_p.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max).max(1e-300);
    let scale_t: f64 = targ_th.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max).max(1e-300);
    let max_it = 200;
    let mut res = f64::INFINITY;
    for _ in 0..max_it {
        let a: Vec<SPoly> = amp.iter().map(|v| from_dense(v, pexps)).collect();
        let o: Vec<SPoly> = phase.iter().map(|v| from_dense(v, pexps)).collect();
        let (pm, th) = polar_flow_map(&a, &o, dt, kmax);
        res = 0.0;
        for i in 0..m {
            let cur_p = to_dense(&pm[i], pexps);
            let cur_t = to_dense(&th[i], pexps);
            for k in 1..pexps.len() {
                let rp = targ_p[i][k] - cur_p[k];
                let rt = targ_th[i][k] - cur_t[k];
                res = res.max(rp.abs() / scale_p).max(rt.abs() / scale_t);
                amp[i][k] += rp / (2.0 * dt * mu[i].norm_sqr());
                phase[i][k] += rt / dt;
            }
        }
        if res < 1e-14 {
            return Ok((amp, phase));
        }
    }
    Err(NormalFormError::NoConvergence { residual: res, iterations: max_it })
}

/// The change of coordinates of a normal form: reduced coordinates
/// `eta = W (u + h(u))` of the normal-form coordinates `u = (z_1, conj z_1, z_2, ...)`,
/// `z_j = rho_j e^{i theta_j}`, with `W` the normalized eigenvectors and `h` the
/// near-identity transformation (degrees 2..=order) that removed the non-resonant terms.
/// Truncated at the normal form's order: a trajectory of the polar normal form mapped
/// through it follows the reduced dynamics up to `O(rho^(order+1))`.
#[derive(Clone, Debug)]
pub struct NormalFormTransform {
    w: DMatrix<C>,
    h: Vec<SPoly>,
}

fn eval_spoly(p: &SPoly, u: &[C]) -> C {
    p.iter().map(|(e, c)| e.iter().zip(u).fold(*c, |acc, (&k, &x)| if k == 0 { acc } else { acc * x.powu(k) })).sum()
}

impl NormalFormTransform {
    /// Dimension d of the reduced coordinates.
    pub fn dim(&self) -> usize {
        self.w.nrows()
    }

    /// Reduced coordinates `eta` (length d) at amplitudes `rho` and phases `theta` (one
    /// per mode, mode order of the normal form).
    pub fn eta(&self, rho: &[f64], theta: &[f64]) -> Vec<f64> {
        let d = self.dim();
        let mut u = Vec::with_capacity(d);
        for (r, th) in rho.iter().zip(theta) {
            let z = C::from_polar(*r, *th);
            u.push(z);
            u.push(z.conj());
        }
        let q: Vec<C> = (0..d).map(|i| u[i] + eval_spoly(&self.h[i], &u)).collect();
        (0..d).map(|r| (0..d).map(|l| self.w[(r, l)] * q[l]).sum::<C>().re).collect()
    }
}

fn dynamics_poly(dynamics: &ReducedDynamics) -> Result<(&Poly, Option<f64>), NormalFormError> {
    match dynamics {
        ReducedDynamics::Flow { field, .. } => Ok((field, None)),
        ReducedDynamics::Map { increment, dt, .. } => Ok((increment, Some(*dt))),
        ReducedDynamics::Rbf(_) => Err(NormalFormError::NotPolynomial),
    }
}

/// Normal form of polynomial reduced dynamics (`Flow` or `Map`).
pub fn normal_form(dynamics: &ReducedDynamics, opts: &NormalFormOptions) -> Result<PolarNormalForm, NormalFormError> {
    let (poly, map_dt) = dynamics_poly(dynamics)?;
    normal_form_of_poly(poly, map_dt, opts)
}

/// [`normal_form`] together with its change of coordinates (e.g. to map normal-form
/// amplitudes to reduced coordinates, and through the manifold to an observable).
pub fn normal_form_with_transform(
    dynamics: &ReducedDynamics,
    opts: &NormalFormOptions,
) -> Result<(PolarNormalForm, NormalFormTransform), NormalFormError> {
    let (poly, map_dt) = dynamics_poly(dynamics)?;
    normal_form_parts(poly, map_dt, opts)
}

/// Normal form of `eta' = poly(eta)` (`map_dt = None`) or of the map
/// `eta -> eta + poly(eta)` at step `map_dt`.
pub fn normal_form_of_poly(
    poly: &Poly,
    map_dt: Option<f64>,
    opts: &NormalFormOptions,
) -> Result<PolarNormalForm, NormalFormError> {
    normal_form_parts(poly, map_dt, opts).map(|(nf, _)| nf)
}

fn normal_form_parts(
    poly: &Poly,
    map_dt: Option<f64>,
    opts: &NormalFormOptions,
) -> Result<(PolarNormalForm, NormalFormTransform), NormalFormError> {
    let order = opts.order.unwrap_or_else(|| poly::max_degree(&poly.exps).max(1));
    if order == 0 || order > 9 {
        return Err(NormalFormError::Order(order));
    }
    let is_map = map_dt.is_some();
    let dt = map_dt.unwrap_or(1.0);
    let (md, eig) = modal(poly, is_map, dt, order, &opts.normalization)?;
    let modes = md.lam.len() / 2;
    let nz = normalize(&md, order, is_map, opts.small_divisor);
    let odd = if order % 2 == 0 { order - 1 } else { order };
    let pexps = poly::exponents(modes, 0, (odd - 1) / 2);
    let beta = resonant_coefficients(&nz.n, modes, &pexps);
    let (amp, phase) = if is_map {
        let mu: Vec<C> = (0..modes).map(|i| md.lam[2 * i]).collect();
        map_to_flow(&beta, &mu, &pexps, dt)?
    } else {
        let amp = (0..modes)
            .map(|i| {
                pexps.iter().zip(&beta[i]).map(|(e, b)| if deg(e) == 0 { md.lam[2 * i].re } else { b.re }).collect()
            })
            .collect();
        let phase = (0..modes)
            .map(|i| {
                pexps.iter().zip(&beta[i]).map(|(e, b)| if deg(e) == 0 { md.lam[2 * i].im } else { b.im }).collect()
            })
            .collect();
        (amp, phase)
    };
    let nf = PolarNormalForm {
        modes,
        order: odd,
        pexps,
        amp,
        phase,
        eigenvalues: eig,
        normalization: opts.normalization.clone(),
        extra_resonances: nz.extra,
        min_divisor: nz.min_div,
        map_dt,
    };
    Ok((nf, NormalFormTransform { w: md.w, h: nz.h }))
}

/// Normal form of a fitted model with the [`Normalization::Observable`] convention on the
/// observable itself (first row of the tangent basis `V1`): `rho_j` is the amplitude of
/// mode `j` in the measured signal. `opts.normalization` is overridden.
pub fn model_normal_form(model: &SsmModel, opts: &NormalFormOptions) -> Result<PolarNormalForm, NormalFormError> {
    normal_form(&model.dynamics, &model_options(model, opts))
}

/// [`model_normal_form`] with its change of coordinates ([`normal_form_with_transform`]).
pub fn model_normal_form_with_transform(
    model: &SsmModel,
    opts: &NormalFormOptions,
) -> Result<(PolarNormalForm, NormalFormTransform), NormalFormError> {
    normal_form_with_transform(&model.dynamics, &model_options(model, opts))
}

/// Normal form of a fitted model on the first-harmonic basis
/// ([`Normalization::FirstHarmonic`] of the observable on the manifold,
/// `Manifold::observable_poly`): `rho_j` is the measured signal's first-harmonic amplitude
/// of mode `j` on an invariant torus, at every order (as the equation-driven
/// `map_ssm::Amplitude::Observable`). `opts.normalization` is overridden.
pub fn model_normal_form_first_harmonic(
    model: &SsmModel,
    opts: &NormalFormOptions,
) -> Result<PolarNormalForm, NormalFormError> {
    let o = NormalFormOptions {
        normalization: Normalization::FirstHarmonic(model.manifold.observable_poly()),
        ..opts.clone()
    };
    normal_form(&model.dynamics, &o)
}

fn model_options(model: &SsmModel, opts: &NormalFormOptions) -> NormalFormOptions {
    let m = &model.manifold;
    let row: Vec<f64> = (0..m.dim).map(|j| m.v1[j * m.p]).collect();
    NormalFormOptions { normalization: Normalization::Observable(row), ..opts.clone() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The packed-key product against the map product: the same entries (keys, and the
    /// coefficients bit for bit), on random sparse polynomials in 1..6 variables with
    /// repeated, zero and negative-zero coefficients, terms above the truncation degree, and
    /// products truncated at 0..9; `NF_MUL_BENCH=packed` / `btree` time one of them.
    #[test]
    fn packed_product_equals_the_map_product() {
        let mut rng = crate::testing::XorShift64::new(0x2545_f491_4f6c_dd1d);
        let mut rnd = move || rng.next_u64();
        let poly = |nvar: usize, terms: usize, top: u32, rnd: &mut dyn FnMut() -> u64| {
            let mut p = SPoly::new();
            for _ in 0..terms {
                let e: Vec<u32> = (0..nvar).map(|_| (rnd() % u64::from(top + 1)) as u32).collect();
                let v = |r: u64| match r % 5 {
                    0 => 0.0,
                    1 => -0.0,
                    _ => (r >> 11) as f64 / (1u64 << 53) as f64 - 0.5,
                };
                let c = C::new(v(rnd()), v(rnd()));
                p.insert(e, c);
            }
            p
        };
        let same = |x: &SPoly, y: &SPoly| {
            x.len() == y.len()
                && x.iter().zip(y).all(|((ea, ca), (eb, cb))| {
                    ea == eb && ca.re.to_bits() == cb.re.to_bits() && ca.im.to_bits() == cb.im.to_bits()
                })
        };
        for nvar in 1..=6 {
            for maxdeg in 0..=9 {
                for _ in 0..3 {
                    let a = poly(nvar, 40, 5, &mut rnd);
                    let b = poly(nvar, 60, 4, &mut rnd);
                    assert!(same(&mul(&a, &b, maxdeg), &mul_btree(&a, &b, maxdeg)), "nvar {nvar} maxdeg {maxdeg}");
                    // Products of products (sums of many terms per key).
                    let ab = mul_btree(&a, &b, maxdeg);
                    assert!(
                        same(&mul(&ab, &a, maxdeg), &mul_btree(&ab, &a, maxdeg)),
                        "nvar {nvar} maxdeg {maxdeg} (ab a)"
                    );
                }
            }
        }
        assert!(mul(&SPoly::new(), &one(3), 4).is_empty());
        // Exponents that do not fit the packing (11 variables of 6 bits) take the map product.
        let a = poly(11, 30, 3, &mut rnd);
        assert!(same(&mul(&a, &a, 40), &mul_btree(&a, &a, 40)));
        if let Ok(kind) = std::env::var("NF_MUL_BENCH") {
            let a = poly(4, 300, 7, &mut rnd);
            let t = std::time::Instant::now();
            let mut n = 0;
            for _ in 0..50 {
                n += if kind == "packed" { mul(&a, &a, 7) } else { mul_btree(&a, &a, 7) }.len();
            }
            eprintln!("50 {kind} products of 300 terms: {n} entries, {:?}", t.elapsed());
        }
    }

    /// `z_j = x_{2j} + i x_{2j+1}` and its conjugate, `x = M^-1 eta`, as linear polynomials in
    /// `eta` (the order `z_1, conj z_1, z_2, ...`).
    fn z_of_eta(m: &DMatrix<f64>) -> Vec<SPoly> {
        let d = m.nrows();
        let minv = m.clone().try_inverse().unwrap();
        let mut sub = Vec::new();
        for j in 0..d / 2 {
            for sgn in [1.0, -1.0] {
                let mut p = SPoly::new();
                for l in 0..d {
                    let mut e = vec![0; d];
                    e[l] = 1;
                    p.insert(e, C::new(minv[(2 * j, l)], sgn * minv[(2 * j + 1, l)]));
                }
                sub.push(p);
            }
        }
        sub
    }

    /// Real polynomial (as a [`Poly`] with the given scales, degrees 1..=order) of the field
    /// `eta' = M x'` where `x = (Re z_j, Im z_j)_j = M^-1 eta` and `z_j' = zdot[j](z, conj z)`.
    fn real_field(zdot: &[SPoly], m: &DMatrix<f64>, scale: &[f64], order: u32) -> Poly {
        let d = m.nrows();
        let zd = compose(zdot, &z_of_eta(m), d, order);
        // x'_{2j} = Re z_j', x'_{2j+1} = Im z_j' (eta real); eta' = M x'.
        let exps = poly::exponents(d, 1, order);
        let mut coef = vec![0.0; exps.len() * d];
        for (k, e) in exps.iter().enumerate() {
            let sc: f64 = e.iter().zip(scale).map(|(&p, s)| s.powi(p as i32)).product();
            for o in 0..d {
                let mut v = 0.0;
                for j in 0..d / 2 {
                    let c = zd[j].get(e).copied().unwrap_or(C::new(0.0, 0.0));
                    v += m[(o, 2 * j)] * c.re + m[(o, 2 * j + 1)] * c.im;
                }
                coef[k * d + o] = v * sc;
            }
        }
        Poly { dim_in: d, dim_out: d, scale: scale.to_vec(), exps, coef }
    }

    fn term(e: &[u32], c: C) -> (Vec<u32>, C) {
        (e.to_vec(), c)
    }

    /// Hopf normal form plus a non-resonant quadratic term g11 z conj z, mixed by a linear
    /// map: the cubic coefficient must be b + |g11|^2 / lambda (hand-derived from one
    /// near-identity step), the quintic c exactly when g11 = 0.
    #[test]
    fn flow_d2_known_coefficients() {
        let lam = C::new(-0.07, 3.1);
        let (b, c) = (C::new(-0.8, 0.4), C::new(0.25, -0.6));
        let m = DMatrix::from_row_slice(2, 2, &[1.3, -0.4, 0.2, 0.9]);
        let obs: Vec<f64> = m.clone().try_inverse().unwrap().row(0).iter().copied().collect();
        for g11 in [C::new(0.0, 0.0), C::new(0.5, -0.3)] {
            let zdot: SPoly =
                [term(&[1, 0], lam), term(&[1, 1], g11), term(&[2, 1], b), term(&[3, 2], c)].into_iter().collect();
            let p = real_field(&[zdot], &m, &[0.6, 1.7], 5);
            let opts =
                NormalFormOptions { normalization: Normalization::Observable(obs.clone()), ..Default::default() };
            let nf = normal_form_of_poly(&p, None, &opts).unwrap();
            assert_eq!(nf.modes, 1);
            assert_eq!(nf.pexps, vec![vec![0], vec![1], vec![2]]);
            let b3 = b + g11.norm_sqr() / lam;
            assert!((nf.amp[0][0] - lam.re).abs() < 1e-12 && (nf.phase[0][0] - lam.im).abs() < 1e-12, "{nf:?}");
            assert!((nf.amp[0][1] - b3.re).abs() < 1e-11, "{} vs {}", nf.amp[0][1], b3.re);
            assert!((nf.phase[0][1] - b3.im).abs() < 1e-11, "{} vs {}", nf.phase[0][1], b3.im);
            if g11.norm() == 0.0 {
                assert!((nf.amp[0][2] - c.re).abs() < 1e-11 && (nf.phase[0][2] - c.im).abs() < 1e-11, "{nf:?}");
            }
            let t = nf.table();
            assert_eq!(t.rows.iter().map(|r| r.monomial.as_str()).collect::<Vec<_>>(), ["rho_1", "rho_1^3", "rho_1^5"]);
            assert!(nf.extra_resonances.is_empty());
        }
    }

    /// Two modes in normal form with cross terms, a generic 4x4 mixing and unequal scales. All polar coefficients are recovered, modes ordered by frequency although
    /// the fast mode comes first in x.
    #[test]
    fn flow_d4_cross_terms_recovered() {
        let (l1, l2) = (C::new(-0.11, 2.7), C::new(0.27, 53.0));
        // z1' = z1 (l1 + b1 P1 + c1 P2 + ...), z2' likewise; P = |z|^2.
        let b = [
            [C::new(0.04, 0.1), C::new(11.65, -2.0), C::new(1.2, 0.3), C::new(41.0, 1.0), C::new(110.0, -5.0)],
            [C::new(-2.1, 0.7), C::new(-8.2, 1.1), C::new(-2.2, 0.0), C::new(-27.4, 2.0), C::new(-22.5, 3.0)],
        ];
        // exponents of (P1, P2) in that order: P1, P2, P1^2, P1 P2, P2^2 (for mode 2: P1, P2, P1^2, P1 P2, P2^2)
        let pe = [[1u32, 0], [0, 1], [2, 0], [1, 1], [0, 2]];
        // variable order in x: fast mode first.
        let mut z_fast = SPoly::new();
        let mut z_slow = SPoly::new();
        z_slow.insert(vec![0, 0, 1, 0], l1);
        z_fast.insert(vec![1, 0, 0, 0], l2);
        for (k, e) in pe.iter().enumerate() {
            // variables (z2, conj z2, z1, conj z1)
            z_slow.insert(vec![e[1], e[1], e[0] + 1, e[0]], b[0][k]);
            z_fast.insert(vec![e[1] + 1, e[1], e[0], e[0]], b[1][k]);
        }
        let m = DMatrix::from_row_slice(
            4,
            4,
            &[1.0, 0.2, -0.1, 0.3, 0.1, 0.9, 0.2, -0.2, -0.3, 0.1, 1.1, 0.2, 0.2, -0.3, 0.1, 0.8],
        );
        let minv = m.clone().try_inverse().unwrap();
        let obs: Vec<f64> = (0..4).map(|j| minv[(0, j)] + minv[(2, j)]).collect();
        let p = real_field(&[z_fast, z_slow], &m, &[0.5, 0.8, 1.2, 2.0], 5);
        let opts = NormalFormOptions { normalization: Normalization::Observable(obs), ..Default::default() };
        let nf = normal_form_of_poly(&p, None, &opts).unwrap();
        assert_eq!(nf.pexps, vec![vec![0, 0], vec![1, 0], vec![0, 1], vec![2, 0], vec![1, 1], vec![0, 2]]);
        assert!((nf.eigenvalues[0].1 - l1.im).abs() < 1e-10 && (nf.eigenvalues[1].1 - l2.im).abs() < 1e-10);
        for i in 0..2 {
            let l = if i == 0 { l1 } else { l2 };
            assert!((nf.amp[i][0] - l.re).abs() < 1e-10);
            for k in 0..5 {
                let want = b[i][k];
                // roundoff of the order-5 expansion through a generic 4x4 mixing, with a wide margin
                let tol = 1e-7 * want.norm().max(1.0);
                assert!(
                    (nf.amp[i][k + 1] - want.re).abs() < tol,
                    "mode {i} k {k}: {} vs {}",
                    nf.amp[i][k + 1],
                    want.re
                );
                assert!(
                    (nf.phase[i][k + 1] - want.im).abs() < tol,
                    "mode {i} k {k}: {} vs {}",
                    nf.phase[i][k + 1],
                    want.im
                );
            }
        }
        let t = nf.table();
        let names: Vec<_> = t.rows.iter().map(|r| r.monomial.clone()).collect();
        assert_eq!(
            names,
            [
                "rho_1",
                "rho_1^3",
                "rho_1 rho_2^2",
                "rho_1^5",
                "rho_1^3 rho_2^2",
                "rho_1 rho_2^4",
                "rho_2",
                "rho_1^2 rho_2",
                "rho_2^3",
                "rho_1^4 rho_2",
                "rho_1^2 rho_2^3",
                "rho_2^5"
            ]
        );
        assert!((t.get(1, "rho_1 rho_2^2").unwrap() - 11.65).abs() < 1e-8);
        assert!((t.get(2, "rho_2^3").unwrap() + 8.2).abs() < 1e-8);
    }

    /// Map path: z -> mu z (1 + k1 P + k2 P^2) with real k's chosen so that the polar map is
    /// the time-dt map of the Bernoulli flow P' = 2 P (a + A1 P) (exact solution
    /// P(t) = P0 E / (1 - (A1/a) (E - 1) P0), E = e^{2 a t}), truncated at P^3.
    #[test]
    fn map_to_flow_matches_bernoulli() {
        let (a, a1, om, dt): (f64, f64, f64, f64) = (0.27, -8.2, 53.0, 0.0308);
        let e = (2.0 * a * dt).exp();
        let kappa = a1 / a * (e - 1.0);
        let (k1, k2) = (kappa / 2.0, 3.0 * kappa * kappa / 8.0);
        let mu = C::from_polar((a * dt).exp(), om * dt);
        let zmap: SPoly = [term(&[1, 0], mu), term(&[2, 1], mu * k1), term(&[3, 2], mu * k2)].into_iter().collect();
        let m = DMatrix::from_row_slice(2, 2, &[0.7, 0.1, -0.3, 1.2]);
        let mut p = real_field(&[zmap], &m, &[1.0, 1.0], 5);
        // increment = F - identity
        for i in 0..2 {
            p.coef[i * 2 + i] -= 1.0;
        }
        let obs: Vec<f64> = m.clone().try_inverse().unwrap().row(0).iter().copied().collect();
        let opts = NormalFormOptions { normalization: Normalization::Observable(obs), ..Default::default() };
        let nf = normal_form_of_poly(&p, Some(dt), &opts).unwrap();
        assert!((nf.amp[0][0] - a).abs() < 1e-12, "{nf:?}");
        assert!((nf.phase[0][0] - om).abs() < 1e-10, "{nf:?}");
        assert!((nf.amp[0][1] - a1).abs() < 1e-9 * a1.abs(), "{} vs {a1}", nf.amp[0][1]);
        assert!(nf.amp[0][2].abs() < 1e-9, "{}", nf.amp[0][2]);
        assert!(nf.phase[0][1].abs() < 1e-9 && nf.phase[0][2].abs() < 1e-9, "{nf:?}");
    }

    /// Conjugate partner of a polynomial in `(z_1, conj z_1, z_2, ...)`: coefficients
    /// conjugated, exponents of each pair swapped.
    fn conj_poly(p: &SPoly) -> SPoly {
        p.iter()
            .map(|(e, c)| {
                let mut f = e.clone();
                for j in 0..e.len() / 2 {
                    f.swap(2 * j, 2 * j + 1);
                }
                (f, c.conj())
            })
            .collect()
    }

    /// A real scalar `x(eta)` (a [`Poly`] with the given scales, degrees 1..=order) of a
    /// real-valued polynomial `xq(z, conj z)`, `x = (Re z_j, Im z_j)_j = M^-1 eta`.
    fn real_scalar(xq: &SPoly, m: &DMatrix<f64>, scale: &[f64], order: u32) -> Poly {
        let d = m.nrows();
        let x = compose(std::slice::from_ref(xq), &z_of_eta(m), d, order).pop().unwrap();
        let exps = poly::exponents(d, 1, order);
        let coef = exps
            .iter()
            .map(|e| {
                let c = x.get(e).copied().unwrap_or(C::new(0.0, 0.0));
                assert!(c.im.abs() < 1e-12, "observable not real: {e:?} {c}");
                c.re * e.iter().zip(scale).map(|(&p, s)| s.powi(p as i32)).product::<f64>()
            })
            .collect();
        Poly { dim_in: d, dim_out: 1, scale: scale.to_vec(), exps, coef }
    }

    /// Known answer of the first-harmonic basis: a two-mode map normal form
    /// `u_j -> u_j (mu_j + sum beta_j,ab P_1^a P_2^b)` seen through a known near-identity
    /// change `q = u + k(u)` with resonant and non-resonant terms, mixed by a real 4x4 `M`,
    /// and an observable whose first harmonic in `u` is exactly `Re u_1 + Re u_2` plus
    /// non-first-harmonic terms (`|u_1|^2`, `Re u_1^2`, `Re u_1^3`, `Re u_1^2 conj u_2`, `Re u_1^3 conj u_2^2`, ...).
    /// `FirstHarmonic` must recover the beta's (as the flow coefficients of `map_to_flow`)
    /// to 1e-9; `Observable` (linear row only) must not (the resonant part of `k` moves it).
    #[test]
    fn first_harmonic_recovers_a_known_map_normal_form() {
        let order = 5;
        let dt = 0.03;
        let mu = [C::from_polar(0.995, 0.15), C::from_polar(1.008, 1.63)];
        let pe = [[1u32, 0], [0, 1], [2, 0], [1, 1], [0, 2]];
        let beta = [
            [C::new(0.8, -0.3), C::new(-1.7, 0.4), C::new(2.5, 1.0), C::new(-3.0, 0.7), C::new(1.1, -2.0)],
            [C::new(-0.6, 0.2), C::new(-1.2, -0.5), C::new(0.9, 0.3), C::new(2.2, -1.4), C::new(-0.7, 0.6)],
        ];
        let d = 4;
        // Normal form N(u), z-equations only (variables u_1, conj u_1, u_2, conj u_2).
        let mut nz = vec![SPoly::new(), SPoly::new()];
        for i in 0..2 {
            let mut e = vec![0u32; d];
            e[2 * i] = 1;
            nz[i].insert(e, mu[i]);
            for (k, p) in pe.iter().enumerate() {
                let mut e = vec![p[0], p[0], p[1], p[1]];
                e[2 * i] += 1;
                nz[i].insert(e, mu[i] * beta[i][k]);
            }
        }
        let full = |z: &[SPoly]| -> Vec<SPoly> { z.iter().flat_map(|p| [p.clone(), conj_poly(p)]).collect() };
        // k(u): non-resonant (u_1^2, |u_1|^2, u_2 conj u_1, u_2^3, u_1 u_2, conj u_1^2) and
        // resonant (u_1 |u_1|^2, u_1 |u_2|^2, u_2 |u_2|^2, u_2 |u_1|^4) terms.
        let kz: Vec<SPoly> = vec![
            [
                term(&[2, 0, 0, 0], C::new(0.4, -0.2)),
                term(&[1, 1, 0, 0], C::new(-0.3, 0.1)),
                term(&[0, 1, 1, 0], C::new(0.25, 0.3)),
                term(&[0, 0, 3, 0], C::new(-0.2, 0.1)),
                term(&[2, 1, 0, 0], C::new(0.7, -0.4)),
                term(&[1, 0, 1, 1], C::new(-0.5, 0.2)),
            ]
            .into_iter()
            .collect(),
            [
                term(&[1, 0, 1, 0], C::new(0.3, 0.2)),
                term(&[0, 2, 0, 0], C::new(-0.1, 0.35)),
                term(&[0, 0, 2, 1], C::new(0.6, 0.3)),
                term(&[2, 2, 1, 0], C::new(-0.8, 0.5)),
            ]
            .into_iter()
            .collect(),
        ];
        let kf = full(&kz);
        // T(u) = u + k(u); T^-1(q) = q - k(T^-1(q)) by fixed point, truncated at `order`.
        let ids: Vec<SPoly> = (0..d).map(|i| var(d, i)).collect();
        let mut inv = ids.clone();
        for _ in 0..order {
            let kv = compose(&kf, &inv, d, order);
            inv = (0..d)
                .map(|i| {
                    let mut p = ids[i].clone();
                    add_into(&mut p, &kv[i], C::new(-1.0, 0.0));
                    p
                })
                .collect();
        }
        // F(q) = T(N(T^-1(q))), z-equations.
        let nf_full = full(&nz);
        let t: Vec<SPoly> = (0..d)
            .map(|i| {
                let mut p = ids[i].clone();
                add_into(&mut p, &kf[i], C::new(1.0, 0.0));
                p
            })
            .collect();
        let tn = compose(&t, &nf_full, d, order);
        let fq = compose(&tn, &inv, d, order);
        let fz = vec![fq[0].clone(), fq[2].clone()];
        // Observable in u: Re u_1 + Re u_2 + terms with no first harmonic.
        let half = C::new(0.5, 0.0);
        let mut xu: SPoly = [
            term(&[1, 0, 0, 0], half),
            term(&[0, 1, 0, 0], half),
            term(&[0, 0, 1, 0], half),
            term(&[0, 0, 0, 1], half),
            term(&[1, 1, 0, 0], C::new(0.7, 0.0)),
            term(&[0, 0, 1, 1], C::new(-0.6, 0.0)),
        ]
        .into_iter()
        .collect();
        for (e, c) in [
            ([2u32, 0, 0, 0], C::new(0.3, 0.2)),
            ([1, 0, 1, 0], C::new(-0.2, 0.4)),
            ([3, 0, 0, 0], C::new(-0.4, 0.1)),
            ([2, 0, 0, 1], C::new(0.5, -0.3)),
            ([3, 0, 0, 2], C::new(0.2, 0.2)),
        ] {
            let p: SPoly = [term(&e, c)].into_iter().collect();
            add_into(&mut xu, &p, C::new(1.0, 0.0));
            add_into(&mut xu, &conj_poly(&p), C::new(1.0, 0.0));
        }
        let xq = compose(std::slice::from_ref(&xu), &inv, d, order).pop().unwrap();
        let m = DMatrix::from_row_slice(
            4,
            4,
            &[1.0, 0.2, -0.1, 0.3, 0.1, 0.9, 0.2, -0.2, -0.3, 0.1, 1.1, 0.2, 0.2, -0.3, 0.1, 0.8],
        );
        let scale = [0.5, 0.8, 1.2, 2.0];
        let mut p = real_field(&fz, &m, &scale, order);
        // increment = F - identity (a degree-1 coefficient multiplies eta_i / scale_i)
        for i in 0..d {
            let mut e = vec![0u32; d];
            e[i] = 1;
            let k = p.exps.iter().position(|x| *x == e).unwrap();
            p.coef[k * d + i] -= scale[i];
        }
        let x = real_scalar(&xq, &m, &[0.7, 1.3, 0.9, 1.1], order);
        let pexps = poly::exponents(2, 0, 2);
        let bfull: Vec<Vec<C>> = (0..2)
            .map(|i| std::iter::once(C::new(0.0, 0.0)).chain(beta[i].iter().map(|b| mu[i] * b)).collect())
            .collect();
        let (want_amp, want_phase) = map_to_flow(&bfull, &mu, &pexps, dt).unwrap();
        let fh = NormalFormOptions {
            order: Some(order),
            normalization: Normalization::FirstHarmonic(x.clone()),
            ..Default::default()
        };
        let nf = normal_form_of_poly(&p, Some(dt), &fh).unwrap();
        assert!(nf.extra_resonances.is_empty());
        for i in 0..2 {
            for k in 0..pexps.len() {
                let sc = want_amp[i][k].abs().max(want_phase[i][k].abs()).max(1.0);
                assert!(
                    (nf.amp[i][k] - want_amp[i][k]).abs() < 1e-9 * sc,
                    "amp {i} {k}: {} vs {}",
                    nf.amp[i][k],
                    want_amp[i][k]
                );
                assert!(
                    (nf.phase[i][k] - want_phase[i][k]).abs() < 1e-9 * sc,
                    "phase {i} {k}: {} vs {}",
                    nf.phase[i][k],
                    want_phase[i][k]
                );
            }
        }
        // The transform's observable has exactly the first harmonic rho_j on a torus.
        let (_, tr) = normal_form_parts(&p, Some(dt), &fh).unwrap();
        let rho = [0.03, 0.02];
        let n = 16;
        let mut h1 = [C::new(0.0, 0.0); 2];
        for a in 0..n {
            for b in 0..n {
                let th = [std::f64::consts::TAU * a as f64 / n as f64, std::f64::consts::TAU * b as f64 / n as f64];
                let xv = x.eval(&tr.eta(&rho, &th))[0];
                h1[0] += C::from_polar(xv, -th[0]) / (n * n) as f64;
                h1[1] += C::from_polar(xv, -th[1]) / (n * n) as f64;
            }
        }
        for j in 0..2 {
            // O(rho^6) from the truncation of x(W(u + h(u))) at the order.
            assert!(
                (2.0 * h1[j].norm() - rho[j]).abs() < 1e-8 * rho[j],
                "mode {j}: first harmonic {} vs rho {}",
                2.0 * h1[j].norm(),
                rho[j]
            );
        }
        let lin = NormalFormOptions {
            order: Some(order),
            normalization: Normalization::Observable(x.linear_part()),
            ..Default::default()
        };
        let nl = normal_form_of_poly(&p, Some(dt), &lin).unwrap();
        assert!(
            (nl.amp[0][1] - want_amp[0][1]).abs() > 1e-3,
            "{} vs {}: the test needs a resonant k",
            nl.amp[0][1],
            want_amp[0][1]
        );
    }

    #[test]
    fn rejects_real_eigenvalues_and_odd_dimension() {
        let exps = poly::exponents(2, 1, 1);
        let p = Poly { dim_in: 2, dim_out: 2, scale: vec![1.0, 1.0], exps, coef: vec![-1.0, 0.0, 0.0, -2.0] };
        let e = normal_form_of_poly(&p, None, &NormalFormOptions::default()).unwrap_err();
        assert!(matches!(e, NormalFormError::RealEigenvalue { .. }), "{e}");
        let exps = poly::exponents(3, 1, 1);
        let p3 = Poly { dim_in: 3, dim_out: 3, scale: vec![1.0; 3], exps, coef: vec![0.0; 9] };
        assert!(matches!(
            normal_form_of_poly(&p3, None, &NormalFormOptions::default()),
            Err(NormalFormError::OddDimension(3))
        ));
    }
}
