//! Spectral submanifold of a polynomial map by the parametrization method, with the reduced
//! map in extended normal form (the equation-driven counterpart of a fitted SSM model).
//!
//! Input: a polynomial map `F(s) = A s + G(P s)` on `R^D` ([`PolynomialMap`]: linear part
//! `A`, a projection `P` onto `m` variables and the polynomial `G` of degree 2..=K in
//! them; `P = I` gives a plain polynomial map), and the spectral subspace: the `pairs`
//! complex-conjugate multiplier pairs of largest modulus. Knows no plant.
//!
//! # Algorithm
//! Complex diagonal coordinates `z = (z_1, conj z_1, z_2, conj z_2, ...)`, pairs ordered by
//! increasing `|arg mu|` (mode 1 the slowest). The manifold `s = W(z)` and the reduced map
//! `z -> R(z)` solve the invariance equation `F(W(z)) = W(R(z))`, order by order: `W_1 = V`
//! (right eigenvectors `v_j`, scaled so that `c . v_j = 1/2` for the observable row `c`:
//! at linear order `c . s = sum_j rho_j cos theta_j`, the convention of
//! [`Normalization::Observable`]), `R_1 = diag(mu)`. At order `k`, for each monomial
//! `z^m`, `(A - mu^m) W_m = V R_m + E_m` with `E_m = [W_{<k}(R_{<k})]_m - [G(P W_{<k})]_m`
//! known. With left eigenvectors `u_j` (`u_j^T v_l = delta_jl`):
//! * along master direction `j`: the divisor is `mu_j - mu^m`, and
//!   `(mu_j - mu^m) u_j^T W_m = u_j^T E_m + R_{m,j}`. The term is *resonant* if it
//!   is structural (it survives in polar form: `z_j |z_1|^{2a} |z_2|^{2b}` in the equation
//!   of `z_j`) or if `|mu_j - mu^m| < resonance_tol`: it is kept in `R`, never divided.
//!   A non-structural one (reported in [`MapSsm::extra_resonances`]) has `u_j^T W_m = 0`,
//!   `R_{m,j} = -u_j^T E_m`. For a structural one `u_j^T W_m = alpha` is free; it fixes what
//!   the amplitudes mean ([`Amplitude`]): `alpha` such that `c . W_m = 0`
//!   ([`Amplitude::Observable`]: `rho_j` is the observable's first harmonic on a torus) or
//!   `alpha = 0` ([`Amplitude::Spectral`]), and `R_{m,j} = (mu_j - mu^m) alpha - u_j^T E_m`.
//!   Otherwise `R_{m,j} = 0` and `u_j^T W_m = u_j^T E_m / (mu_j - mu^m)`; the smallest such
//!   divisor is reported.
//! * in the complementary invariant subspace: the bordered system
//!   `[[A - mu^m, V], [U^T, 0]] [x; c] = [E_m - V U^T E_m; 0]`, nonsingular whatever `mu^m`,
//!   with the smallest distance of `mu^m` to a non-master multiplier reported.
//!
//! The reduced map is then `z_j -> z_j M_j(|z_1|^2, |z_2|^2, ...)` plus any reported extra
//! resonances; its polar form is converted to the continuous-time amplitude equations of
//! [`PolarNormalForm`] exactly as a fitted map's (the flow whose time-`dt` map it is), so
//! coefficients compare one to one with [`crate::normal_form`]'s.

#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;

use faer::Mat;
use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::normal_form::{self, ExtraResonance, Normalization, PolarNormalForm};
use crate::poly;

type C = Complex<f64>;

/// Largest order of [`map_ssm`].
pub const MAX_ORDER: u32 = 9;

/// Errors of [`map_ssm`].
#[derive(Debug, Error)]
pub enum MapSsmError {
    #[error("polynomial map: {0}")]
    BadMap(String),
    #[error("invalid option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error("eigen-decomposition of the linear part failed: {0}")]
    Eigen(String),
    #[error(
        "the {index}-th largest multiplier {re:.6e} + {im:.3e} i is real: the master subspace must be complex pairs"
    )]
    RealMaster { index: usize, re: f64, im: f64 },
    #[error("the bordered system of monomial {monomial:?} is singular")]
    Singular { monomial: Vec<u32> },
    #[error(transparent)]
    NormalForm(#[from] normal_form::NormalFormError),
}

/// `F(s) = A s + G(P s)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PolynomialMap {
    /// State dimension D.
    pub dim: usize,
    /// `A`, row-major `D x D`.
    pub linear: Vec<f64>,
    /// Number of projected variables m.
    pub nproj: usize,
    /// `P`, row-major `m x D`.
    pub proj: Vec<f64>,
    /// Exponents (length m, total degree >= 2) of the monomials of `G`.
    pub exps: Vec<Vec<u32>>,
    /// `coef[r][k]`: coefficient of `exps[k]` in component `r` of `G` (`D` rows).
    pub coef: Vec<Vec<f64>>,
}

impl PolynomialMap {
    fn validate(&self) -> Result<(), MapSsmError> {
        let bad = |s: String| Err(MapSsmError::BadMap(s));
        let (d, m) = (self.dim, self.nproj);
        if d == 0 || m == 0 {
            return bad(format!("dimension {d} and projected variables {m} must be positive"));
        }
        if self.linear.len() != d * d {
            return bad(format!("linear part has {} entries, want {}", self.linear.len(), d * d));
        }
        if self.proj.len() != m * d {
            return bad(format!("projection has {} entries, want {}", self.proj.len(), m * d));
        }
        if self.coef.len() != d || self.coef.iter().any(|r| r.len() != self.exps.len()) {
            return bad(format!("coefficients must be {d} rows of {} entries", self.exps.len()));
        }
        for (k, e) in self.exps.iter().enumerate() {
            if e.len() != m || e.iter().sum::<u32>() < 2 {
                return bad(format!("monomial {k} {e:?}: want {m} exponents of total degree >= 2"));
            }
        }
        if let Some(i) =
            self.linear.iter().chain(&self.proj).chain(self.coef.iter().flatten()).position(|v| !v.is_finite())
        {
            return bad(format!("non-finite entry (flattened index {i})"));
        }
        Ok(())
    }

    /// Largest degree of `G`.
    pub fn order(&self) -> u32 {
        poly::max_degree(&self.exps)
    }

    /// `F(s)` at a complex point (real in, real out for real `s`).
    #[doc(hidden)]
    pub fn eval_c(&self, s: &[C]) -> Vec<C> {
        let (d, m) = (self.dim, self.nproj);
        let v: Vec<C> = (0..m).map(|k| (0..d).map(|j| s[j] * self.proj[k * d + j]).sum()).collect();
        let pows = powers(&v, poly::max_degree(&self.exps));
        let mono: Vec<C> = self.exps.iter().map(|e| monomial_times(C::new(1.0, 0.0), e, &pows)).collect();
        (0..d)
            .map(|r| {
                let lin: C = (0..d).map(|j| s[j] * self.linear[r * d + j]).sum();
                lin + self.coef[r].iter().zip(&mono).map(|(c, x)| x * *c).sum::<C>()
            })
            .collect()
    }
}

/// Options of [`map_ssm`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapSsmOptions {
    /// Order of `W` and `R` (1..=[`MAX_ORDER`]).
    pub order: u32,
    /// Master pairs: the `pairs` complex pairs of largest modulus.
    pub pairs: usize,
    /// A non-structural term whose divisor `|mu_j - mu^m|` is below this is kept in the
    /// reduced map (and reported) instead of divided.
    pub resonance_tol: f64,
    /// Observable row `c` (length D): `c . v_j = 1/2`.
    pub observable: Vec<f64>,
    /// Sampling period of the map, s (for the continuous-time polar form).
    pub dt: f64,
    /// What the amplitudes `rho_j` of the polar form measure beyond linear order (the
    /// normalization of the resonant terms of `W`).
    pub amplitude: Amplitude,
}

/// The normalization of the resonant part of the parametrization `W`, which fixes what the
/// normal-form amplitudes `rho_j` are beyond linear order (at linear order both give
/// `c . s = sum_j rho_j cos theta_j`). The reduced map's polar coefficients depend on it at
/// every nonlinear order: a change `rho_i -> rho_i (1 + sum_j k_ij rho_j^2 + ...)` shifts
/// the cubic `rho_i rho_j^2` coefficient by `2 k_ij Re lambda_j` and every fixed point's
/// amplitudes by `O(rho^3)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Amplitude {
    /// `c . W_m = 0` for every structural monomial `m` of degree >= 2 (in the equation of
    /// its mode): the observable has no nonlinear part at a mode's own frequency, so on an
    /// invariant torus or circle of the polar form (`|z_j| = rho_j`) `rho_j` is exactly the
    /// first-harmonic amplitude of the observable at mode `j`'s frequency: what a
    /// measurement on a time series (e.g. `crate::spectrum::mode_amplitudes`) returns, and
    /// (up to the small change of a delay embedding's projection with frequency) what a
    /// data-driven model fitted on that observable's delay embedding calls `rho_j`.
    Observable,
    /// `u_j^T W_m = 0` for resonant `m` (the graph-style parametrization over the spectral
    /// subspace): `rho_j` is the first harmonic of the master coordinate `u_j^T s`, which
    /// differs from the observable's by `O(rho^3)`.
    Spectral,
}

/// Dense graded monomial table in `n` variables up to `order`.
#[doc(hidden)]
pub struct Table {
    #[doc(hidden)]
    pub exps: Vec<Vec<u32>>,
    deg: Vec<u32>,
    deg_start: Vec<usize>,
    prod: Vec<Vec<u32>>,
    #[doc(hidden)]
    pub index: HashMap<Vec<u32>, usize>,
}

impl Table {
    #[doc(hidden)]
    pub fn new(n: usize, order: u32) -> Self {
        let exps = poly::exponents(n, 0, order);
        let deg: Vec<u32> = exps.iter().map(|e| e.iter().sum()).collect();
        let mut deg_start = vec![0; order as usize + 2];
        for d in 0..=order as usize + 1 {
            deg_start[d] = deg.iter().position(|&x| x as usize >= d).unwrap_or(exps.len());
        }
        let index: HashMap<Vec<u32>, usize> = exps.iter().enumerate().map(|(i, e)| (e.clone(), i)).collect();
        let prod = exps
            .iter()
            .zip(&deg)
            .map(|(ei, &di)| {
                exps[..deg_start[(order - di) as usize + 1]]
                    .iter()
                    .map(|ej| index[&ei.iter().zip(ej).map(|(a, b)| a + b).collect::<Vec<u32>>()] as u32)
                    .collect()
            })
            .collect();
        Self { exps, deg, deg_start, prod, index }
    }
    fn len(&self) -> usize {
        self.exps.len()
    }
    /// `a * b` truncated at degree `maxdeg`.
    fn mul(&self, a: &[C], b: &[C], maxdeg: u32) -> Vec<C> {
        let mut out = vec![C::new(0.0, 0.0); self.len()];
        for i in 0..self.deg_start[maxdeg as usize + 1] {
            let x = a[i];
            if x.re == 0.0 && x.im == 0.0 {
                continue;
            }
            let end = self.deg_start[(maxdeg - self.deg[i]) as usize + 1];
            for (y, &k) in b[..end].iter().zip(&self.prod[i][..end]) {
                out[k as usize] += x * y;
            }
        }
        out
    }
    /// Values (as polynomials truncated at `maxdeg`) of every monomial of `exps` of degree
    /// <= maxdeg in the polynomials `v` (the monomial `v^e`), via a tree: each monomial is
    /// its parent (one unit of the first nonzero exponent less) times one variable.
    #[doc(hidden)]
    pub fn monomials(&self, exps: &[Vec<u32>], v: &[Vec<C>], maxdeg: u32) -> Vec<Option<Vec<C>>> {
        let mut cache: HashMap<Vec<u32>, Vec<C>> = HashMap::new();
        let mut one = vec![C::new(0.0, 0.0); self.len()];
        one[0] = C::new(1.0, 0.0);
        cache.insert(vec![0; v.len()], one);
        let mut sorted: Vec<&Vec<u32>> = exps.iter().collect();
        sorted.sort_by_key(|e| e.iter().sum::<u32>());
        for e in sorted {
            if e.iter().sum::<u32>() > maxdeg {
                continue;
            }
            self.monomial(e, v, maxdeg, &mut cache);
        }
        exps.iter().map(|e| cache.get(e).cloned()).collect()
    }
    fn monomial(&self, e: &[u32], v: &[Vec<C>], maxdeg: u32, cache: &mut HashMap<Vec<u32>, Vec<C>>) {
        if cache.contains_key(e) {
            return;
        }
        let Some(j) = e.iter().position(|&k| k > 0) else { return };
        let mut parent = e.to_vec();
        parent[j] -= 1;
        self.monomial(&parent, v, maxdeg, cache);
        let val = self.mul(&cache[&parent], &v[j], maxdeg);
        cache.insert(e.to_vec(), val);
    }
}

/// Size of the terms of one order (conditioning of the expansion).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrderStats {
    pub order: u32,
    /// Largest `|W_m|` (max over components) of this order.
    pub w_max: f64,
    /// Largest `|R_m|` of this order.
    pub r_max: f64,
}

/// The computed SSM and its reduced map.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MapSsm {
    pub order: u32,
    pub dt: f64,
    /// Master multipliers in variable order `(mu_1, conj mu_1, mu_2, ...)`, as (re, im).
    pub multipliers: Vec<(f64, f64)>,
    /// Exponents of the monomials in `z` (graded order), shared by `w` and `r`.
    pub exps: Vec<Vec<u32>>,
    /// `w[row][k]`: coefficient (re, im) of `z^exps[k]` in state component `row`.
    pub w: Vec<Vec<(f64, f64)>>,
    /// `r[j][k]`: coefficient of `z^exps[k]` in the reduced map of `z_j`.
    pub r: Vec<Vec<(f64, f64)>>,
    /// Left eigenvectors `u_j` (length D each, variable order), `u_j^T v_l = delta_jl`: the
    /// master coordinates of a state are `u_j^T s` at linear order.
    #[serde(default)]
    pub left: Vec<Vec<(f64, f64)>>,
    /// Non-structural terms kept because their divisor was below the tolerance.
    pub extra_resonances: Vec<ExtraResonance>,
    /// Smallest master divisor `|mu_j - mu^m|` among the terms removed.
    pub min_divisor: f64,
    /// Smallest `|lambda - mu^m|` over non-master multipliers `lambda`.
    pub min_complement_divisor: f64,
    pub order_stats: Vec<OrderStats>,
    /// The polar amplitude equations (continuous-time, per second).
    pub polar: PolarNormalForm,
    pub resonance_tol: f64,
}

/// Structural resonance of monomial `m` in the equation of variable `i` (see
/// [`crate::normal_form`]).
#[doc(hidden)]
pub fn structural(i: usize, m: &[u32]) -> bool {
    let sign: i64 = if i % 2 == 0 { 1 } else { -1 };
    (0..m.len() / 2).all(|j| m[2 * j] as i64 - m[2 * j + 1] as i64 == if j == i / 2 { sign } else { 0 })
}

fn eigvec(a: &DMatrix<f64>, lam: C) -> Result<DVector<C>, MapSsmError> {
    let d = a.nrows();
    let eps = 1e-10 * lam.norm().max(1e-12);
    let shift = lam + C::new(eps, eps);
    let m = DMatrix::from_fn(d, d, |i, j| C::new(a[(i, j)], 0.0) - if i == j { shift } else { C::new(0.0, 0.0) });
    let lu = m.lu();
    let mut x = DVector::from_fn(d, |i, _| C::new(1.0 + 0.1 * i as f64, 0.3 - 0.05 * i as f64));
    for _ in 0..5 {
        x = lu.solve(&x).ok_or_else(|| MapSsmError::Eigen("singular shifted matrix".into()))?;
        let n = x.norm();
        if !n.is_finite() || n == 0.0 {
            return Err(MapSsmError::Eigen("inverse iteration diverged".into()));
        }
        x /= C::new(n, 0.0);
    }
    Ok(x)
}

/// Computes the SSM of `map` tangent to the `opts.pairs` dominant multiplier pairs.
pub fn map_ssm(map: &PolynomialMap, opts: &MapSsmOptions) -> Result<MapSsm, MapSsmError> {
    map.validate()?;
    let d = map.dim;
    if opts.order == 0 || opts.order > MAX_ORDER {
        return Err(MapSsmError::BadOption {
            what: "order",
            why: format!("must be 1..={MAX_ORDER}, got {}", opts.order),
        });
    }
    if opts.pairs == 0 || 2 * opts.pairs > d {
        return Err(MapSsmError::BadOption {
            what: "pairs",
            why: format!("need 1..={} pairs for dimension {d}, got {}", d / 2, opts.pairs),
        });
    }
    if !(opts.resonance_tol >= 0.0 && opts.resonance_tol.is_finite()) {
        return Err(MapSsmError::BadOption {
            what: "resonance_tol",
            why: format!("must be finite and >= 0, got {}", opts.resonance_tol),
        });
    }
    if opts.observable.len() != d || opts.observable.iter().any(|v| !v.is_finite()) {
        return Err(MapSsmError::BadOption {
            what: "observable",
            why: format!("need {d} finite entries, got {}", opts.observable.len()),
        });
    }
    if !(opts.dt > 0.0 && opts.dt.is_finite()) {
        return Err(MapSsmError::BadOption { what: "dt", why: format!("must be finite and > 0, got {}", opts.dt) });
    }
    let k_max = opts.order;
    let terms = poly::count(2 * opts.pairs, 0, k_max).unwrap_or(usize::MAX);
    if terms > crate::limits::MAX_TERMS {
        return Err(MapSsmError::BadOption {
            what: "pairs",
            why: format!(
                "{} pairs at order {k_max} need {terms} monomials, above ssm::limits::MAX_TERMS = {}",
                opts.pairs,
                crate::limits::MAX_TERMS
            ),
        });
    }
    let g_terms = map.exps.len().saturating_mul(map.dim);
    if d > crate::limits::MAX_DIM * 8 || g_terms > crate::limits::MAX_MATRIX_ENTRIES {
        return Err(MapSsmError::BadMap(format!(
            "dimension {d} with {} monomials exceeds the size limits (ssm::limits)",
            map.exps.len()
        )));
    }
    let a = DMatrix::from_row_slice(d, d, &map.linear);
    let am = Mat::from_fn(d, d, |i, j| a[(i, j)]);
    let ev = am.eigenvalues().map_err(|_| MapSsmError::Eigen("eigenvalues did not converge".into()))?;
    let mut ev: Vec<C> = ev.iter().map(|z| C::new(z.re, z.im)).collect();
    ev.sort_by(|x, y| y.norm().total_cmp(&x.norm()).then(y.im.total_cmp(&x.im)));
    let n = 2 * opts.pairs;
    let scale = ev.first().map_or(1.0, |z| z.norm()).max(1e-300);
    let mut pos = Vec::new();
    for (index, z) in ev[..n].iter().enumerate() {
        if z.im.abs() <= 1e-9 * scale {
            return Err(MapSsmError::RealMaster { index, re: z.re, im: z.im });
        }
        if z.im > 0.0 {
            pos.push(*z);
        }
    }
    if pos.len() != opts.pairs {
        return Err(MapSsmError::Eigen("the dominant multipliers do not form conjugate pairs".into()));
    }
    let others: Vec<C> = ev[n..].to_vec();
    pos.sort_by(|x, y| x.arg().abs().total_cmp(&y.arg().abs()));
    // Right and left eigenvectors, variable order (z_1, conj z_1, ...).
    let at = a.transpose();
    let mut vcols: Vec<DVector<C>> = Vec::with_capacity(n);
    let mut ucols: Vec<DVector<C>> = Vec::with_capacity(n);
    let mut mu: Vec<C> = Vec::with_capacity(n);
    for &l in &pos {
        let mut v = eigvec(&a, l)?;
        let cv: C = opts.observable.iter().zip(v.iter()).map(|(c, x)| x * *c).sum();
        if cv.norm() < 1e-12 * opts.observable.iter().map(|x| x.abs()).fold(0.0, f64::max) {
            return Err(MapSsmError::BadOption {
                what: "observable",
                why: "it does not see a master mode (c . v = 0)".into(),
            });
        }
        v *= C::new(0.5, 0.0) / cv;
        let mut u = eigvec(&at, l)?;
        let uv: C = u.iter().zip(v.iter()).map(|(x, y)| x * y).sum();
        u /= uv;
        vcols.push(v.clone());
        vcols.push(v.map(|x| x.conj()));
        ucols.push(u.clone());
        ucols.push(u.map(|x| x.conj()));
        mu.push(l);
        mu.push(l.conj());
    }
    let tab = Table::new(n, k_max);
    let nt = tab.len();
    let zero = C::new(0.0, 0.0);
    let mut w: Vec<Vec<C>> = vec![vec![zero; nt]; d];
    let mut r: Vec<Vec<C>> = vec![vec![zero; nt]; n];
    for j in 0..n {
        let mut e = vec![0u32; n];
        e[j] = 1;
        let idx = tab.index[&e];
        for row in 0..d {
            w[row][idx] = vcols[j][row];
        }
        r[j][idx] = mu[j];
    }
    let vmat = DMatrix::from_fn(d, n, |i, j| vcols[j][i]);
    let umat = DMatrix::from_fn(n, d, |i, j| ucols[i][j]);
    let mut extra = Vec::new();
    let mut min_div = f64::INFINITY;
    let mut min_comp = f64::INFINITY;
    let mut stats = vec![OrderStats {
        order: 1,
        w_max: vmat.iter().fold(0.0, |m, x| m.max(x.norm())),
        r_max: mu.iter().fold(0.0, |m, x| m.max(x.norm())),
    }];
    let m_proj = map.nproj;
    for k in 2..=k_max {
        // [G(P W_{<k})]_k
        let pw: Vec<Vec<C>> = (0..m_proj)
            .map(|i| {
                let mut p = vec![zero; nt];
                for j in 0..d {
                    let c = map.proj[i * d + j];
                    if c != 0.0 {
                        for (a, b) in p.iter_mut().zip(&w[j]) {
                            *a += b * c;
                        }
                    }
                }
                p
            })
            .collect();
        let gm = tab.monomials(&map.exps, &pw, k);
        // [W_{2..k-1}(R_{<k})]_k
        let wexps: Vec<Vec<u32>> =
            tab.exps.iter().filter(|e| (2..k).contains(&e.iter().sum::<u32>())).cloned().collect();
        let rm = tab.monomials(&wexps, &r, k);
        let range = tab.deg_start[k as usize]..tab.deg_start[k as usize + 1];
        let mut w_max = 0.0f64;
        let mut r_max = 0.0f64;
        for idx in range {
            let m = tab.exps[idx].clone();
            let mut e_m = DVector::<C>::zeros(d);
            for row in 0..d {
                let mut acc = zero;
                for (q, g) in gm.iter().enumerate() {
                    if let Some(g) = g {
                        acc -= g[idx] * map.coef[row][q];
                    }
                }
                for (q, we) in wexps.iter().enumerate() {
                    let wi = tab.index[we];
                    if let Some(rv) = &rm[q] {
                        acc += w[row][wi] * rv[idx];
                    }
                }
                e_m[row] = acc;
            }
            let mum: C = m.iter().zip(&mu).fold(C::new(1.0, 0.0), |acc, (&p, l)| acc * l.powu(p));
            let proj = &umat * &e_m;
            let mut coords = DVector::<C>::zeros(n);
            // The master direction for which `m` is structural (at most one).
            let mut structural_j = None;
            for j in 0..n {
                let div = mu[j] - mum;
                let resonant = structural(j, &m) || div.norm() < opts.resonance_tol;
                if resonant {
                    // u_j^T W_m = 0 for now (the `Spectral` normalization); R_m,j = -u_j^T E_m.
                    r[j][idx] = -proj[j];
                    if structural(j, &m) {
                        structural_j = Some(j);
                    } else {
                        r_max = r_max.max(proj[j].norm());
                        extra.push(ExtraResonance {
                            equation: j,
                            exponents: m.clone(),
                            coefficient: (-proj[j].re, -proj[j].im),
                            divisor: div.norm(),
                        });
                    }
                } else {
                    min_div = min_div.min(div.norm());
                    coords[j] = proj[j] / div;
                }
            }
            for l in &others {
                min_comp = min_comp.min((l - mum).norm());
            }
            // Complement: bordered system.
            let rhs_top = &e_m - &vmat * &proj;
            let nb = d + n;
            let mut bm = DMatrix::<C>::zeros(nb, nb);
            for i in 0..d {
                for j in 0..d {
                    bm[(i, j)] = C::new(a[(i, j)], 0.0) - if i == j { mum } else { zero };
                }
                for j in 0..n {
                    bm[(i, d + j)] = vmat[(i, j)];
                    bm[(d + j, i)] = umat[(j, i)];
                }
            }
            let mut rhs = DVector::<C>::zeros(nb);
            for i in 0..d {
                rhs[i] = rhs_top[i];
            }
            let sol = bm.lu().solve(&rhs).ok_or_else(|| MapSsmError::Singular { monomial: m.clone() })?;
            let mut wm: Vec<C> =
                (0..d).map(|row| sol[row] + (0..n).map(|j| vmat[(row, j)] * coords[j]).sum::<C>()).collect();
            if let Some(j) = structural_j {
                if opts.amplitude == Amplitude::Observable {
                    // The resonant freedom: W_m += alpha v_j, R_m,j += (mu_j - mu^m) alpha,
                    // with alpha making c . W_m = 0 (c . v_j = 1/2).
                    let cw: C = opts.observable.iter().zip(&wm).map(|(c, x)| x * *c).sum();
                    let cv: C = opts.observable.iter().zip(vcols[j].iter()).map(|(c, x)| x * *c).sum();
                    let alpha = -cw / cv;
                    for (row, x) in wm.iter_mut().enumerate() {
                        *x += vmat[(row, j)] * alpha;
                    }
                    r[j][idx] += (mu[j] - mum) * alpha;
                }
                r_max = r_max.max(r[j][idx].norm());
            }
            for (row, val) in wm.into_iter().enumerate() {
                w[row][idx] = val;
                w_max = w_max.max(val.norm());
            }
        }
        stats.push(OrderStats { order: k, w_max, r_max });
    }
    // Polar form: beta[i][pe] from the equation of z_i.
    let modes = opts.pairs;
    let odd = if k_max % 2 == 0 { k_max.saturating_sub(1).max(1) } else { k_max };
    let pexps = poly::exponents(modes, 0, (odd - 1) / 2);
    let beta: Vec<Vec<C>> = (0..modes)
        .map(|i| {
            pexps
                .iter()
                .map(|pe| {
                    let mut m = vec![0u32; n];
                    for j in 0..modes {
                        m[2 * j] = pe[j];
                        m[2 * j + 1] = pe[j];
                    }
                    m[2 * i] += 1;
                    tab.index.get(&m).map_or(zero, |&q| r[2 * i][q])
                })
                .collect()
        })
        .collect();
    let mu_modes: Vec<C> = (0..modes).map(|i| mu[2 * i]).collect();
    let (amp, phase) = normal_form::map_to_flow(&beta, &mu_modes, &pexps, opts.dt)?;
    let eigenvalues = mu_modes.iter().map(|z| (z.norm().ln() / opts.dt, z.arg() / opts.dt)).collect();
    let polar = PolarNormalForm {
        modes,
        order: odd,
        pexps,
        amp,
        phase,
        eigenvalues,
        normalization: Normalization::Observable(opts.observable.clone()),
        extra_resonances: extra.clone(),
        min_divisor: min_div,
        map_dt: Some(opts.dt),
    };
    let pair = |c: &C| (c.re, c.im);
    Ok(MapSsm {
        order: k_max,
        dt: opts.dt,
        multipliers: mu.iter().map(pair).collect(),
        exps: tab.exps.clone(),
        w: w.iter().map(|row| row.iter().map(pair).collect()).collect(),
        r: r.iter().map(|row| row.iter().map(pair).collect()).collect(),
        left: ucols.iter().map(|u| u.iter().map(pair).collect()).collect(),
        extra_resonances: extra,
        min_divisor: min_div,
        min_complement_divisor: min_comp,
        order_stats: stats,
        polar,
        resonance_tol: opts.resonance_tol,
    })
}

/// Invariance error of the order-`order` truncation on the sphere `|rho| = radius`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InvarianceError {
    pub order: u32,
    pub radius: f64,
    /// `max ||F(W(z)) - W(R(z))||_inf` over the sample points.
    pub abs: f64,
    /// The same over `max ||W(z)||_inf`.
    pub rel: f64,
}

/// `x^k` (`powu`) of every variable `x` of `v` for `k = 0..=max`: `out[j][k]`.
fn powers(v: &[C], max: u32) -> Vec<Vec<C>> {
    v.iter().map(|x| (0..=max).map(|k| x.powu(k)).collect()).collect()
}

/// `c * v_0^e_0 * v_1^e_1 * ...` (left to right) from the powers of [`powers`], the factors
/// with `e_j = 0` left out. The same sums as multiplying by `v_j.powu(0) = 1` too, bit for bit
/// (finite values): `a * (1 + 0i)` is `a` up to the signs of zero parts, later products by the
/// same factors keep "equal up to signed zeros", and such terms give the same sum (a sum
/// started at `+0.0` is never `-0.0` in round-to-nearest, so a zero term never changes it).
fn monomial_times(c: C, e: &[u32], pows: &[Vec<C>]) -> C {
    e.iter().zip(pows).fold(c, |acc, (&k, p)| if k == 0 { acc } else { acc * p[k as usize] })
}

impl MapSsm {
    /// One row of `W` or `R` at the point whose powers are `pows`, truncated at `order`.
    fn eval(&self, coef: &[(f64, f64)], pows: &[Vec<C>], order: u32) -> C {
        self.exps
            .iter()
            .zip(coef)
            .filter(|(e, _)| e.iter().sum::<u32>() <= order)
            .map(|(e, &(re, im))| monomial_times(C::new(re, im), e, pows))
            .sum()
    }

    /// `W(z)` truncated at `order`.
    pub fn manifold_at(&self, z: &[C], order: u32) -> Vec<C> {
        let pows = powers(z, order.min(poly::max_degree(&self.exps)));
        self.w.iter().map(|row| self.eval(row, &pows, order)).collect()
    }

    /// `R(z)` truncated at `order`.
    pub fn reduced_at(&self, z: &[C], order: u32) -> Vec<C> {
        let pows = powers(z, order.min(poly::max_degree(&self.exps)));
        self.r.iter().map(|row| self.eval(row, &pows, order)).collect()
    }

    /// The reduced map and an observable in the real coordinates
    /// `eta = (Re z_1, Im z_1, Re z_2, Im z_2, ...)`, the form of a data-driven model (a map
    /// of reduced coordinates, an observable on the manifold): the increment
    /// `R(z(eta)) - eta` (`dim_out = dim_in = 2 pairs`) and `observable . W(z(eta))` (a
    /// scalar), both of degrees 1..=order with unit scales. Their
    /// `crate::normal_form::Normalization::FirstHarmonic` normal form is the
    /// `Amplitude::Observable` polar form whatever this SSM's amplitude normalization.
    pub fn real_form(&self, observable: &[f64]) -> Result<(poly::Poly, poly::Poly), MapSsmError> {
        let n = self.multipliers.len();
        if observable.len() != self.w.len() || observable.iter().any(|v| !v.is_finite()) {
            return Err(MapSsmError::BadOption {
                what: "observable",
                why: format!("need {} finite entries, got {}", self.w.len(), observable.len()),
            });
        }
        let tab = Table::new(n, self.order);
        let nt = tab.len();
        // z_j = eta_2j + i eta_2j+1, conj z_j = eta_2j - i eta_2j+1.
        let zv: Vec<Vec<C>> = (0..n)
            .map(|v| {
                let mut p = vec![C::new(0.0, 0.0); nt];
                let (re, im) = (2 * (v / 2), 2 * (v / 2) + 1);
                let unit = |j: usize| {
                    let mut e = vec![0u32; n];
                    e[j] = 1;
                    tab.index[&e]
                };
                p[unit(re)] = C::new(1.0, 0.0);
                p[unit(im)] = C::new(0.0, if v % 2 == 0 { 1.0 } else { -1.0 });
                p
            })
            .collect();
        let mono = tab.monomials(&self.exps, &zv, self.order);
        let sum = |coef: &[(f64, f64)]| -> Vec<C> {
            let mut out = vec![C::new(0.0, 0.0); nt];
            for (m, &(re, im)) in mono.iter().zip(coef) {
                if let Some(m) = m {
                    for (o, x) in out.iter_mut().zip(m) {
                        *o += x * C::new(re, im);
                    }
                }
            }
            out
        };
        let exps = poly::exponents(n, 1, self.order);
        let mut inc = vec![0.0; exps.len() * n];
        for j in 0..n / 2 {
            let r = sum(&self.r[2 * j]);
            for (k, e) in exps.iter().enumerate() {
                let c = r[tab.index[e]];
                inc[k * n + 2 * j] = c.re - if e[2 * j] == 1 && e.iter().sum::<u32>() == 1 { 1.0 } else { 0.0 };
                inc[k * n + 2 * j + 1] = c.im - if e[2 * j + 1] == 1 && e.iter().sum::<u32>() == 1 { 1.0 } else { 0.0 };
            }
        }
        let cw: Vec<(f64, f64)> = (0..self.exps.len())
            .map(|k| {
                let v: C = observable.iter().zip(&self.w).map(|(c, row)| C::new(row[k].0, row[k].1) * *c).sum();
                (v.re, v.im)
            })
            .collect();
        let x = sum(&cw);
        let obs: Vec<f64> = exps.iter().map(|e| x[tab.index[e]].re).collect();
        let ones = vec![1.0; n];
        Ok((
            poly::Poly { dim_in: n, dim_out: n, scale: ones.clone(), exps: exps.clone(), coef: inc },
            poly::Poly { dim_in: n, dim_out: 1, scale: ones, exps, coef: obs },
        ))
    }

    /// Parametrization coordinates `z` (variable order, conjugate pairs) of the state `s`
    /// (length D) on the order-`order` truncation: the solution of `U^T W(z) = U^T s` (the
    /// master projections agree; `s` off the manifold is projected along the complement),
    /// by Newton's method from `z = U^T s` with a finite-difference Jacobian, to a residual
    /// below `tol` (absolute, in the observable's units). `None` when Newton does not
    /// converge in 50 steps (e.g. `s` beyond a fold of the truncated `W`).
    pub fn master_coordinates(&self, s: &[f64], order: u32, tol: f64) -> Option<Vec<C>> {
        let n = self.left.len();
        let modes = n / 2;
        if s.len() != self.w.len() || n == 0 {
            return None;
        }
        let proj = |x: &[C]| -> Vec<C> {
            (0..modes).map(|j| self.left[2 * j].iter().zip(x).map(|(&(re, im), y)| C::new(re, im) * y).sum()).collect()
        };
        let sc: Vec<C> = s.iter().map(|&x| C::new(x, 0.0)).collect();
        let target = proj(&sc);
        let full = |h: &[C]| -> Vec<C> { h.iter().flat_map(|x| [*x, x.conj()]).collect() };
        let resid = |h: &[C]| -> Vec<C> {
            let w = self.manifold_at(&full(h), order);
            proj(&w).iter().zip(&target).map(|(a, b)| a - b).collect()
        };
        let mut h = target.clone();
        for _ in 0..50 {
            let f = resid(&h);
            let norm = f.iter().fold(0.0f64, |m, x| m.max(x.norm()));
            if !norm.is_finite() {
                return None;
            }
            if norm <= tol {
                return Some(full(&h));
            }
            // Real 2m x 2m Jacobian by central differences.
            let m2 = 2 * modes;
            let scale = h.iter().fold(0.0f64, |m, x| m.max(x.norm())).max(1e-8);
            let eps = 1e-6 * scale;
            let mut jac = DMatrix::<f64>::zeros(m2, m2);
            for c in 0..m2 {
                let dz = if c % 2 == 0 { C::new(eps, 0.0) } else { C::new(0.0, eps) };
                let mut hp = h.clone();
                let mut hm = h.clone();
                hp[c / 2] += dz;
                hm[c / 2] -= dz;
                let (fp, fm) = (resid(&hp), resid(&hm));
                for r in 0..modes {
                    let d = (fp[r] - fm[r]) / (2.0 * eps);
                    jac[(2 * r, c)] = d.re;
                    jac[(2 * r + 1, c)] = d.im;
                }
            }
            let rhs = DVector::from_fn(m2, |i, _| if i % 2 == 0 { -f[i / 2].re } else { -f[i / 2].im });
            let step = jac.lu().solve(&rhs)?;
            for j in 0..modes {
                h[j] += C::new(step[2 * j], step[2 * j + 1]);
            }
        }
        None
    }

    /// Invariance error of the order-`order` truncation against `map`, on the sphere of
    /// normal-form amplitudes `sqrt(sum rho_j^2) = radius` (in the observable's units):
    /// `steps` directions in the amplitudes times `steps^modes` phase combinations.
    pub fn invariance_error(&self, map: &PolynomialMap, order: u32, radius: f64, steps: usize) -> InvarianceError {
        let modes = self.multipliers.len() / 2;
        let steps = steps.max(2);
        let mut abs = 0.0f64;
        let mut size = 0.0f64;
        let n_dir = if modes == 1 { 1 } else { steps };
        let n_ph = steps.pow(modes as u32);
        for a in 0..n_dir {
            // Amplitude directions on the positive part of the sphere (modes <= 2 spread by angle).
            let alpha = if modes == 1 { 0.0 } else { (a as f64 + 0.5) / n_dir as f64 * std::f64::consts::FRAC_PI_2 };
            let rho: Vec<f64> = (0..modes)
                .map(|j| match (modes, j) {
                    (1, _) => radius,
                    (_, 0) => radius * alpha.cos(),
                    (_, 1) => radius * alpha.sin(),
                    _ => radius / (modes as f64).sqrt(),
                })
                .collect();
            for p in 0..n_ph {
                let mut q = p;
                let mut z = Vec::with_capacity(2 * modes);
                for j in 0..modes {
                    let th = (q % steps) as f64 / steps as f64 * std::f64::consts::TAU + 0.3 * j as f64;
                    q /= steps;
                    let zj = C::from_polar(rho[j], th);
                    z.push(zj);
                    z.push(zj.conj());
                }
                let s = self.manifold_at(&z, order);
                let fs = map.eval_c(&s);
                let rz = self.reduced_at(&z, order);
                let ws = self.manifold_at(&rz, order);
                for (x, y) in fs.iter().zip(&ws) {
                    abs = abs.max((x - y).norm());
                }
                size = size.max(s.iter().fold(0.0, |m, x| m.max(x.norm())));
            }
        }
        InvarianceError { order, radius, abs, rel: abs / size.max(1e-300) }
    }
}
