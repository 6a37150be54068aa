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

#[doc(hidden)]
pub fn add_into(acc: &mut SPoly, p: &SPoly, s: C) {
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
#[doc(hidden)]
pub fn mul(a: &SPoly, b: &SPoly, maxdeg: u32) -> SPoly {
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
#[doc(hidden)]
pub fn mul_btree(a: &SPoly, b: &SPoly, maxdeg: u32) -> SPoly {
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

#[doc(hidden)]
pub fn one(nvar: usize) -> SPoly {
    let mut p = SPoly::new();
    p.insert(vec![0; nvar], C::new(1.0, 0.0));
    p
}

#[doc(hidden)]
pub fn var(nvar: usize, j: usize) -> SPoly {
    let mut e = vec![0; nvar];
    e[j] = 1;
    let mut p = SPoly::new();
    p.insert(e, C::new(1.0, 0.0));
    p
}

/// `f(sub)`: each component of `f` (polynomials in `sub.len()` variables) with variable `j`
/// replaced by `sub[j]`, truncated at total degree `maxdeg` (in the variables of `sub`).
/// Every `sub[j]` must vanish at the origin (no constant term).
#[doc(hidden)]
pub fn compose(f: &[SPoly], sub: &[SPoly], nvar: usize, maxdeg: u32) -> Vec<SPoly> {
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
    let unit = one(nvar);
    f.iter()
        .map(|fi| {
            let mut out = SPoly::new();
            // A monomial's term is the product of its factors `sub[j]^k` taken in `j`'s order
            // from 1; the monomials come in exponent order, so neighbours share their leading
            // factors: `prefix[m]` is the product of the first `m + 1` factors of the last
            // monomial (`factors` them), reused while they agree (the same products).
            let mut factors: Vec<(usize, u32)> = Vec::new();
            let mut prefix: Vec<SPoly> = Vec::new();
            let mut next: Vec<(usize, u32)> = Vec::new();
            // `sub` has no constant terms, so monomials above `maxdeg` contribute nothing.
            for (e, c) in fi.iter().filter(|(e, _)| deg(e) <= maxdeg) {
                next.clear();
                next.extend(e.iter().enumerate().filter(|(_, k)| **k > 0).map(|(j, &k)| (j, k)));
                let same = factors.iter().zip(&next).take_while(|(a, b)| a == b).count();
                prefix.truncate(same);
                for &(j, k) in &next[same..] {
                    let term = mul(prefix.last().unwrap_or(&unit), &powers[j][k as usize], maxdeg);
                    prefix.push(term);
                }
                std::mem::swap(&mut factors, &mut next);
                add_into(&mut out, prefix.last().unwrap_or(&unit), *c);
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
#[doc(hidden)]
pub fn map_to_flow(
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

#[doc(hidden)]
pub fn normal_form_parts(
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
