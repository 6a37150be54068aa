//! Graph-style polynomial parametrization of a d-dimensional SSM in the delay-embedding
//! space (paper appendix A, "Data-driven modeling of the spectral submanifold").
//!
//! * Tangent space: `V1` = the first `d` left singular vectors of the matrix of all embedded
//!   training points (columns), so `V1^T V1 = I`. Each column's sign is fixed so that its
//!   largest-magnitude entry is positive (deterministic output).
//! * Reduced coordinates: `eta = V1^T y`.
//! * Parametrization: `M(eta) = V1 eta + sum_{2<=|k|<=K} V_k (eta/s)^k`, with `s` the
//!   per-coordinate max |eta| on the training data (see [`super::poly`] for the monomial
//!   order). The nonlinear coefficients are the ridge least-squares fit of the residual
//!   `y - V1 V1^T y`, which lies in the orthogonal complement of `V1`; every `V_k` is a
//!   linear combination of residual vectors, so `V1^T V_k = 0` holds by construction (up to
//!   rounding; [`Manifold::constraint_defect`] measures it).

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use super::error::FitError;
use super::poly::{self, Poly, PolyScratch, PreparedPoly};
use super::ridge::{self, Conditioning, Ridge};
use super::weight::{RowWeight, scale_rows};

/// A fitted SSM parametrization.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifold {
    /// SSM dimension d.
    pub dim: usize,
    /// Embedding dimension p.
    pub p: usize,
    /// Tangent basis V1, `p x d`, column-major (column j contiguous).
    pub v1: Vec<f64>,
    /// All singular values of the embedded training data (descending).
    pub singular_values: Vec<f64>,
    /// Per-coordinate scale of eta used for the monomials.
    pub eta_scale: Vec<f64>,
    /// Nonlinear part `sum V_k (eta/s)^k` (degrees 2..=K), absent for K = 1.
    pub nonlinear: Option<Poly>,
    /// Conditioning of the nonlinear regression, absent for K = 1.
    pub conditioning: Option<Conditioning>,
}

impl Manifold {
    /// Fits the manifold to embedded trajectories `ys` (each `p x M_i`).
    pub fn fit(ys: &[Mat<f64>], dim: usize, order: u32, ridge: Ridge) -> Result<Self, FitError> {
        let (v1, singular_values) = tangent_space(ys, dim)?;
        Self::fit_on(ys, v1, singular_values, order, 2, ridge, None)
    }

    /// [`Manifold::fit`] (tangent `V1` = this data's SVD) with a degree-1 normal part
    /// `W_1 eta` (`V1^T W_1 = 0`) fitted jointly with the higher degrees, as in
    /// [`Manifold::fit_with_tangent`]. The SVD tangent of finite-amplitude data is tilted
    /// against the SSM's tangent space at the fixed point (the nonlinear parts of the data
    /// correlate with their linear part), so over it the manifold has a linear normal part;
    /// without one the degree-2.. coefficients absorb it (on the Furuta data the cubic
    /// `rho_1^2 rho_2` of the map's normal form is then much further off than with it).
    /// Alone (no higher degrees) the degree-1 part is zero: the SVD residual is orthogonal
    /// to `eta`.
    pub fn fit_with_linear_normal(ys: &[Mat<f64>], dim: usize, order: u32, ridge: Ridge) -> Result<Self, FitError> {
        let (v1, singular_values) = tangent_space(ys, dim)?;
        Self::fit_on(ys, v1, singular_values, order, 1, ridge, None)
    }

    /// Fits the manifold as a graph over a GIVEN tangent basis `v1` (`p x dim`,
    /// column-major, orthonormal columns), e.g. one shared by several fits so that their
    /// reduced coordinates agree. Unlike [`Manifold::fit`], the normal part also has
    /// degree-1 terms (`order >= 1` always fits them): `v1` is in general not the tangent
    /// space of this data set, and the linear normal part `W_1 eta` (with `V1^T W_1 = 0`)
    /// absorbs the tilt. `singular_values` are those of this data set.
    pub fn fit_with_tangent(
        ys: &[Mat<f64>],
        v1: &[f64],
        dim: usize,
        order: u32,
        ridge: Ridge,
    ) -> Result<Self, FitError> {
        Self::fit_with_tangent_weighted(ys, v1, dim, order, ridge, None)
    }

    /// [`Manifold::fit_with_tangent`] with the normal part's regression rows (the points)
    /// weighted by `weight` ([`RowWeight`]: the envelope of `||eta||` over one oscillation of
    /// the point's trajectory, as the reduced map's regression weighs its pairs). A smooth
    /// amplitude cut for the graph's truncated polynomial: points far past the knee no longer
    /// bend its low-degree terms. `None` is [`Manifold::fit_with_tangent`]. The conditioning's
    /// residual is the unweighted one.
    pub fn fit_with_tangent_weighted(
        ys: &[Mat<f64>],
        v1: &[f64],
        dim: usize,
        order: u32,
        ridge: Ridge,
        weight: Option<&RowWeight>,
    ) -> Result<Self, FitError> {
        if let Some(wt) = weight {
            wt.validate()?;
            if wt.low_degrees.is_some() {
                return Err(FitError::BadOption {
                    what: "manifold row weight",
                    why: "the low-degree stage applies to the dynamics regression only".into(),
                });
            }
        }
        let p = ys.first().map(|y| y.nrows()).ok_or(FitError::NoTrainingData)?;
        if v1.len() != p * dim {
            return Err(FitError::BadOption {
                what: "v1",
                why: format!("need p x dim = {p} x {dim} entries, got {}", v1.len()),
            });
        }
        for a in 0..dim {
            for b in 0..dim {
                let dot: f64 = v1[a * p..(a + 1) * p].iter().zip(&v1[b * p..(b + 1) * p]).map(|(x, y)| x * y).sum();
                let want = if a == b { 1.0 } else { 0.0 };
                if (dot - want).abs() >= 1e-9 || !dot.is_finite() {
                    return Err(FitError::BadOption {
                        what: "v1",
                        why: format!("columns not orthonormal: v{a} . v{b} = {dot}"),
                    });
                }
            }
        }
        let all = stack_points(ys, p)?.0;
        let singular_values: Vec<f64> =
            all.singular_values().map_err(|_| FitError::Svd { what: "embedded data SVD" })?;
        Self::fit_on(ys, v1.to_vec(), singular_values, order, 1, ridge, weight)
    }

    /// The graph fit over `v1`, normal-part degrees `min_deg..=order`, rows weighted by
    /// `weight` if given.
    fn fit_on(
        ys: &[Mat<f64>],
        v1: Vec<f64>,
        singular_values: Vec<f64>,
        order: u32,
        min_deg: u32,
        ridge: Ridge,
        weight: Option<&RowWeight>,
    ) -> Result<Self, FitError> {
        let p = ys.first().map(|y| y.nrows()).ok_or(FitError::NoTrainingData)?;
        let dim = v1.len() / p;
        if dim == 0 || dim >= p {
            return Err(FitError::BadOption { what: "dim", why: format!("need 1 <= dim < p = {p}, got {dim}") });
        }
        if order == 0 {
            return Err(FitError::BadOption { what: "manifold_order", why: "must be >= 1".into() });
        }
        let (all, groups) = stack_points(ys, p)?;
        let total = all.nrows();
        // eta = Y V1 (rows are points), residual = Y - eta V1^T.
        let v1m = Mat::from_fn(p, dim, |i, j| v1[j * p + i]);
        let eta = &all * &v1m;
        let mut eta_scale = vec![0.0; dim];
        for j in 0..dim {
            let m = (0..total).map(|i| eta[(i, j)].abs()).fold(0.0, f64::max);
            if m <= 0.0 || !m.is_finite() {
                return Err(FitError::NonFinite { what: "reduced coordinates (zero or non-finite range)" });
            }
            eta_scale[j] = m;
        }
        let mut m = Manifold { dim, p, v1, singular_values, eta_scale, nonlinear: None, conditioning: None };
        if order >= min_deg {
            let nm = poly::count(dim, min_deg, order).unwrap_or(usize::MAX);
            crate::limits::check_matrix("manifold regression", total, nm, true)?;
            let resid = &all - &eta * v1m.transpose();
            let exps = poly::exponents(dim, min_deg, order);
            let design = design_matrix(eta.as_ref(), &m.eta_scale, &exps);
            let (w, cond) = match weight {
                None => ridge::fit(design.as_ref(), resid.as_ref(), &groups, ridge, "manifold regression")?,
                Some(wt) => {
                    let f = wt.row_factors(eta.as_ref(), &groups);
                    let (a, b) = (scale_rows(design.clone(), &f), scale_rows(resid.clone(), &f));
                    let (w, mut cond) = ridge::fit(a.as_ref(), b.as_ref(), &groups, ridge, "manifold regression")?;
                    cond.rel_residual = ridge::rel_residual(design.as_ref(), resid.as_ref(), w.as_ref());
                    (w, cond)
                }
            };
            let nm = exps.len();
            let mut coef = vec![0.0; nm * p];
            for k in 0..nm {
                for i in 0..p {
                    coef[k * p + i] = w[(k, i)];
                }
            }
            m.nonlinear = Some(Poly { dim_in: dim, dim_out: p, scale: m.eta_scale.clone(), exps, coef });
            m.conditioning = Some(cond);
        }
        Ok(m)
    }

    /// The linear observable row: `d x_0 / d eta` at the origin, i.e. the first row of `V1`
    /// plus the first row of a degree-1 normal part (present after
    /// [`Manifold::fit_with_tangent`] and [`Manifold::fit_with_linear_normal`]).
    pub fn observable_row(&self) -> Vec<f64> {
        let mut row: Vec<f64> = (0..self.dim).map(|j| self.v1[j * self.p]).collect();
        if let Some(poly) = &self.nonlinear {
            for (k, e) in poly.exps.iter().enumerate() {
                if e.iter().sum::<u32>() == 1
                    && let Some(j) = e.iter().position(|&q| q == 1)
                {
                    row[j] += poly.coef[k * self.p] / poly.scale[j];
                }
            }
        }
        row
    }

    /// The observable `x_0` (first embedding coordinate) on the manifold as a scalar
    /// polynomial in `eta` (degrees 1..=K, scales `eta_scale`): the first row of `V1` plus
    /// the first row of the normal part. Its linear part is [`Manifold::observable_row`].
    pub fn observable_poly(&self) -> Poly {
        let d = self.dim;
        let scale = self.nonlinear.as_ref().map_or_else(|| self.eta_scale.clone(), |p| p.scale.clone());
        let mut exps = poly::exponents(d, 1, 1);
        let mut coef: Vec<f64> = (0..d).map(|j| self.v1[j * self.p] * scale[j]).collect();
        if let Some(nl) = &self.nonlinear {
            for (k, e) in nl.exps.iter().enumerate() {
                let c = nl.coef[k * nl.dim_out];
                match exps.iter().position(|x| x == e) {
                    Some(q) => coef[q] += c,
                    None => {
                        exps.push(e.clone());
                        coef.push(c);
                    }
                }
            }
        }
        Poly { dim_in: d, dim_out: 1, scale, exps, coef }
    }

    /// Reduced coordinates of one embedded point: `eta = V1^T y`.
    pub fn reduce(&self, y: &[f64]) -> Vec<f64> {
        (0..self.dim).map(|j| self.v1[j * self.p..(j + 1) * self.p].iter().zip(y).map(|(a, b)| a * b).sum()).collect()
    }

    /// Reduced coordinates of the columns of `y` (`p x M`), returned as `M x d` (rows = points).
    pub fn reduce_points(&self, y: MatRef<'_, f64>) -> Mat<f64> {
        let v1m = Mat::from_fn(self.p, self.dim, |i, j| self.v1[j * self.p + i]);
        y.transpose() * &v1m
    }

    /// The point `M(eta)` in embedding space, written into `out` (length p).
    pub fn lift_into(&self, eta: &[f64], scratch: &mut PolyScratch, out: &mut [f64]) {
        match &self.nonlinear {
            Some(poly) => poly.eval_into(eta, scratch, out),
            None => out.iter_mut().for_each(|o| *o = 0.0),
        }
        self.plus_linear_into(out, eta);
    }

    /// `out += V1 eta`, in [`Manifold::lift_into`]'s order.
    fn plus_linear_into(&self, out: &mut [f64], eta: &[f64]) {
        for (j, e) in eta.iter().enumerate() {
            for (o, v) in out.iter_mut().zip(&self.v1[j * self.p..(j + 1) * self.p]) {
                *o += v * e;
            }
        }
    }

    /// Coordinate `i` of [`Manifold::lift_into`] alone (`i < p`, else `NaN`), the same bits:
    /// a map iterated for its observable (the newest embedding coordinate) needs only that one.
    pub fn lift_one(&self, eta: &[f64], scratch: &mut PolyScratch, i: usize) -> f64 {
        if i >= self.p {
            return f64::NAN;
        }
        let o = match &self.nonlinear {
            Some(poly) => poly.eval_one(eta, scratch, i),
            None => 0.0,
        };
        self.plus_linear_one(o, eta, i)
    }

    /// `o` plus coordinate `i` of `V1 eta`, added in [`Manifold::lift_into`]'s order.
    fn plus_linear_one(&self, mut o: f64, eta: &[f64], i: usize) -> f64 {
        for (j, e) in eta.iter().enumerate() {
            o += self.v1[j * self.p + i] * e;
        }
        o
    }

    /// The lift prepared for many points ([`PreparedLift::lift_one`]: the same bits as
    /// [`Manifold::lift_one`], the polynomial evaluated by [`PreparedPoly`]).
    pub fn prepare(&self) -> PreparedLift<'_> {
        PreparedLift { m: self, poly: self.nonlinear.as_ref().and_then(PreparedPoly::new) }
    }

    /// Largest violation of the constraints: `max(|V1^T V1 - I|, |V1^T V_k|)` (entrywise,
    /// `V_k` in the scaled-monomial coefficients).
    pub fn constraint_defect(&self) -> f64 {
        let p = self.p;
        let col = |j: usize| &self.v1[j * p..(j + 1) * p];
        let mut worst: f64 = 0.0;
        for a in 0..self.dim {
            for b in 0..self.dim {
                let dot: f64 = col(a).iter().zip(col(b)).map(|(x, y)| x * y).sum();
                worst = worst.max((dot - if a == b { 1.0 } else { 0.0 }).abs());
            }
            if let Some(poly) = &self.nonlinear {
                for k in 0..poly.exps.len() {
                    let vk = &poly.coef[k * p..(k + 1) * p];
                    let dot: f64 = col(a).iter().zip(vk).map(|(x, y)| x * y).sum();
                    worst = worst.max(dot.abs());
                }
            }
        }
        worst
    }
}

/// Embedded points of all trajectories as rows of one matrix, with the row range of each.
fn stack_points(ys: &[Mat<f64>], p: usize) -> Result<(Mat<f64>, Vec<std::ops::Range<usize>>), FitError> {
    if let Some(y) = ys.iter().find(|y| y.nrows() != p) {
        return Err(FitError::BadOption {
            what: "embedded data",
            why: format!("mixed embedding dimensions {} and {p}", y.nrows()),
        });
    }
    let total: usize = ys.iter().map(|y| y.ncols()).sum();
    crate::limits::check_matrix("tangent space SVD", total, p, true)?;
    let mut all = Mat::<f64>::zeros(total, p); // points as rows
    let mut groups = Vec::with_capacity(ys.len());
    let mut off = 0;
    for y in ys {
        for j in 0..y.ncols() {
            for i in 0..p {
                all[(off + j, i)] = y[(i, j)];
            }
        }
        groups.push(off..off + y.ncols());
        off += y.ncols();
    }
    Ok((all, groups))
}

/// Tangent basis `V1` (`p x dim`, column-major) of embedded trajectories `ys`: the first
/// `dim` right singular vectors of the point matrix (rows = points), each column's sign
/// fixed so that its largest-magnitude entry is positive; and all singular values.
pub fn tangent_space(ys: &[Mat<f64>], dim: usize) -> Result<(Vec<f64>, Vec<f64>), FitError> {
    let p = ys.first().map(|y| y.nrows()).ok_or(FitError::NoTrainingData)?;
    if dim == 0 || dim >= p {
        return Err(FitError::BadOption { what: "dim", why: format!("need 1 <= dim < p = {p}, got {dim}") });
    }
    let all = stack_points(ys, p)?.0;
    let svd = all.thin_svd().map_err(|_| FitError::Svd { what: "tangent space SVD" })?;
    let singular_values: Vec<f64> = (0..p).map(|i| svd.S()[i]).collect();
    let vs = svd.V();
    let mut v1 = vec![0.0; p * dim];
    for j in 0..dim {
        let col = vs.col(j);
        let (mut big, mut sign) = (0.0, 1.0);
        for i in 0..p {
            if col[i].abs() > big {
                big = col[i].abs();
                sign = col[i].signum();
            }
        }
        for i in 0..p {
            v1[j * p + i] = sign * col[i];
        }
    }
    Ok((v1, singular_values))
}

/// Design matrix of monomials `exps` evaluated at the rows of `eta` divided by `scale`.
///
/// Each entry is the product of [`poly::eval_monomials`] for its row: the powers `z_j^m`
/// (each the previous power times `z_j`, `z_j^1 = 1 * z_j = z_j`), the monomial
/// `1 * z_1^{k_1} * ... * z_d^{k_d}` multiplied left to right. Multiplying by 1 is exact
/// (the factor `z_j^0` and the leading 1), so the same value is the product, left to right,
/// of the powers of the non-zero exponents alone: one pass per column writing each entry
/// once, over blocks of `DESIGN_BLOCK` (512) rows whose powers stay in cache. The same bits as
/// the row-by-row evaluation (checked in the tests).
pub fn design_matrix(eta: MatRef<'_, f64>, scale: &[f64], exps: &[Vec<u32>]) -> Mat<f64> {
    design_matrix_in(Mat::new(), eta, scale, exps)
}

/// [`design_matrix`] in the storage of `buf` (its values ignored): a fit that builds
/// several design matrices of the same rows in turn (the stages of an anchored or weighted
/// regression, the residual's) reuses one allocation, whose pages are then already mapped
/// (the page faults of a fresh large matrix cost about as much as its values). The same
/// values, and the same layout as a fresh matrix (the column stride depends on the row
/// count alone), so faer's factorizations of it give the same bits.
pub fn design_matrix_in(mut buf: Mat<f64>, eta: MatRef<'_, f64>, scale: &[f64], exps: &[Vec<u32>]) -> Mat<f64> {
    let (n, d) = (eta.nrows(), eta.ncols());
    let stride = poly::max_degree(exps) as usize + 1;
    let nb = DESIGN_BLOCK;
    // Per monomial, the powers of its non-zero exponents in variable order, as offsets
    // `(j * stride + m) * nb` into a block's powers.
    let plan: Vec<Vec<usize>> = exps
        .iter()
        .map(|e| {
            e.iter()
                .enumerate()
                .take(d)
                .filter(|&(_, &m)| m != 0)
                .map(|(j, &m)| (j * stride + m as usize) * nb)
                .collect()
        })
        .collect();
    // A buffer of another column stride (made for another row count) would lay the matrix
    // out otherwise: start afresh then.
    if buf.col_stride() != Mat::<f64>::with_capacity(n, 0).col_stride() {
        buf = Mat::new();
    }
    buf.truncate(0, 0);
    buf.resize_with(n, exps.len(), |_, _| 0.0);
    let mut out = buf;
    // pow[(j * stride + m) * nb + r] = (eta[i0 + r, j] / scale[j])^m for the block's rows.
    let mut pow = vec![1.0; d * stride * nb];
    let mut i0 = 0;
    while i0 < n {
        let b = nb.min(n - i0);
        for j in 0..d {
            let block = &mut pow[j * stride * nb..(j + 1) * stride * nb];
            if stride > 1 {
                for (r, z) in block[nb..nb + b].iter_mut().enumerate() {
                    *z = eta[(i0 + r, j)] / scale[j];
                }
            }
            for m in 2..stride {
                let (prev, cur) = block.split_at_mut(m * nb);
                let (zs, prev) = (&prev[nb..nb + b], &prev[(m - 1) * nb..(m - 1) * nb + b]);
                for ((c, p), z) in cur[..b].iter_mut().zip(prev).zip(zs) {
                    *c = p * z;
                }
            }
        }
        for (k, f) in plan.iter().enumerate() {
            let col = &mut out.col_as_slice_mut(k)[i0..i0 + b];
            let at = |o: usize| &pow[o..o + b];
            match f.as_slice() {
                [] => col.fill(1.0),
                &[a] => col.copy_from_slice(at(a)),
                &[a, b2] => {
                    for ((c, x), y) in col.iter_mut().zip(at(a)).zip(at(b2)) {
                        *c = x * y;
                    }
                }
                &[a, b2, c3] => {
                    for (((c, x), y), z) in col.iter_mut().zip(at(a)).zip(at(b2)).zip(at(c3)) {
                        *c = x * y * z;
                    }
                }
                &[a, b2, c3, d4] => {
                    for ((((c, x), y), z), w) in col.iter_mut().zip(at(a)).zip(at(b2)).zip(at(c3)).zip(at(d4)) {
                        *c = x * y * z * w;
                    }
                }
                [first, rest @ ..] => {
                    col.copy_from_slice(at(*first));
                    for &o in rest {
                        for (c, v) in col.iter_mut().zip(at(o)) {
                            *c *= v;
                        }
                    }
                }
            }
        }
        i0 += b;
    }
    out
}

/// Rows per block of [`design_matrix`]: a block's powers (`d * (K + 1)` slices of this many
/// values, 128 KiB for d = 4, K = 7) stay in the L2 cache.
const DESIGN_BLOCK: usize = 512;

/// [`Manifold`] prepared for many lifts ([`Manifold::prepare`]).
#[derive(Clone, Debug)]
pub struct PreparedLift<'a> {
    m: &'a Manifold,
    /// The nonlinear part prepared (`None`: linear manifold, or a polynomial of inconsistent
    /// shape, lifted the plain way).
    #[doc(hidden)]
    pub poly: Option<PreparedPoly<'a>>,
}

impl PreparedLift<'_> {
    /// [`Manifold::lift_into`], the same bits.
    pub fn lift_into(&self, eta: &[f64], scratch: &mut PolyScratch, out: &mut [f64]) {
        let (m, Some(pp)) = (self.m, &self.poly) else {
            return self.m.lift_into(eta, scratch, out);
        };
        pp.eval_into(eta, scratch, out);
        m.plus_linear_into(out, eta);
    }

    /// [`Manifold::lift_one`], the same bits.
    pub fn lift_one(&self, eta: &[f64], scratch: &mut PolyScratch, i: usize) -> f64 {
        let (m, Some(pp)) = (self.m, &self.poly) else {
            return self.m.lift_one(eta, scratch, i);
        };
        if i >= m.p {
            return f64::NAN;
        }
        m.plus_linear_one(pp.eval_one(eta, scratch, i), eta, i)
    }
}
