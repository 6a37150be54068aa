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
    poly: Option<PreparedPoly<'a>>,
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The column-at-a-time design matrix before the row blocks (kept to compare with).
    fn design_matrix_old(eta: MatRef<'_, f64>, scale: &[f64], exps: &[Vec<u32>]) -> Mat<f64> {
        let (n, d) = (eta.nrows(), eta.ncols());
        let stride = poly::max_degree(exps) as usize + 1;
        // pow[(j * stride + m) * n + i] = (eta[i, j] / scale[j])^m.
        let mut pow = vec![1.0; d * stride * n];
        for j in 0..d {
            let z: Vec<f64> = (0..n).map(|i| eta[(i, j)] / scale[j]).collect();
            let block = &mut pow[j * stride * n..(j + 1) * stride * n];
            for m in 1..stride {
                let (prev, cur) = block.split_at_mut(m * n);
                for ((c, p), zi) in cur[..n].iter_mut().zip(&prev[(m - 1) * n..]).zip(&z) {
                    *c = p * zi;
                }
            }
        }
        let mut out = Mat::<f64>::zeros(n, exps.len());
        for (k, e) in exps.iter().enumerate() {
            let col = out.col_as_slice_mut(k);
            col.fill(1.0);
            for (j, &m) in e.iter().enumerate().take(d) {
                let p = &pow[(j * stride + m as usize) * n..][..n];
                for (c, v) in col.iter_mut().zip(p) {
                    *c *= v;
                }
            }
        }
        out
    }

    /// The column-wise design matrix is the row-by-row monomial evaluation
    /// (`poly::eval_monomials`, as before), bit for bit, for maps and manifolds of several
    /// orders and a single degree block.
    #[test]
    fn design_matrix_equals_the_row_by_row_monomials() {
        let mut r = crate::testing::lcg_centered(9);
        for (d, lo, hi, n) in [(4usize, 1u32, 7u32, 257usize), (4, 4, 7, 100), (2, 1, 3, 31), (3, 2, 2, 10)] {
            let eta = Mat::from_fn(n, d, |_, _| r());
            let scale: Vec<f64> = (0..d).map(|_| 0.3 + r().abs()).collect();
            let exps = poly::exponents(d, lo, hi);
            let a = design_matrix(eta.as_ref(), &scale, &exps);
            let (mut pow, mut phi) = (Vec::new(), vec![0.0; exps.len()]);
            for i in 0..n {
                let z: Vec<f64> = (0..d).map(|j| eta[(i, j)] / scale[j]).collect();
                poly::eval_monomials(&exps, &z, poly::max_degree(&exps), &mut pow, &mut phi);
                for (k, v) in phi.iter().enumerate() {
                    assert_eq!(a[(i, k)].to_bits(), v.to_bits(), "d {d} degrees {lo}..={hi}: row {i} monomial {k}");
                }
            }
        }
    }

    /// The row-blocked design matrix is the column-at-a-time one it replaced, bit for bit:
    /// the Furuta map regression's size (36,001 pairs of 4 coordinates, degrees 1..=7, 329
    /// columns; the last block partial), a manifold's (degrees 1..=3), several blocks in 2
    /// variables, and 6 variables (monomials of 5 and 6 factors), values of every magnitude.
    #[test]
    fn design_matrix_equals_the_column_at_a_time_one() {
        let mut r = crate::testing::lcg_centered(17);
        for (d, lo, hi, n) in [
            (4usize, 1u32, 7u32, 36_001usize),
            (4, 1, 3, 5_000),
            (4, 2, 3, 1_300),
            (2, 1, 3, 513),
            (6, 1, 6, 700),
            (3, 0, 2, 40),
        ] {
            let eta = Mat::from_fn(n, d, |i, _| {
                let v = r();
                if i % 7 == 3 { v * 1e-9 } else { v }
            });
            let scale: Vec<f64> = (0..d).map(|_| 0.3 + r().abs()).collect();
            let exps = poly::exponents(d, lo, hi);
            let a = design_matrix(eta.as_ref(), &scale, &exps);
            let b = design_matrix_old(eta.as_ref(), &scale, &exps);
            assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
            for k in 0..a.ncols() {
                for i in 0..n {
                    assert_eq!(
                        a[(i, k)].to_bits(),
                        b[(i, k)].to_bits(),
                        "d {d} degrees {lo}..={hi}: row {i} monomial {k}"
                    );
                }
            }
        }
    }

    /// Points on a quartic graph over span(e1, e2) in R^5, with graph functions even in
    /// (e1, e2) jointly, on a symmetric grid: the data covariance is block diagonal, so the
    /// SVD returns exactly span(e1, e2) and the K = 4 fit must reproduce every point to
    /// rounding, with `V1^T V_k = 0`.
    #[test]
    fn recovers_known_quartic_graph() {
        let mut cols = Vec::new();
        for i in -12..=12 {
            for j in -12..=12 {
                let (e1, e2) = (i as f64 / 12.0, j as f64 / 12.0);
                let h1 = 0.2 * (e1 * e1 - 0.5 * e1 * e2 + 0.3 * e2 * e2) + 0.1 * e1 * e1 * e2 * e2;
                let h2 = 0.15 * e2.powi(4) - 0.1 * e1 * e2;
                cols.push([e1, e2, h1, h2, h1]);
            }
        }
        let y = Mat::from_fn(5, cols.len(), |i, j| cols[j][i]);
        let m = Manifold::fit(std::slice::from_ref(&y), 2, 4, Ridge::Fixed(0.0)).unwrap();
        assert!(m.constraint_defect() < 1e-13, "defect {}", m.constraint_defect());
        // V1 spans e1, e2: no components along e3..e5.
        for j in 0..2 {
            for i in 2..5 {
                assert!(m.v1[j * 5 + i].abs() < 1e-13, "V1[{i},{j}] = {}", m.v1[j * 5 + i]);
            }
        }
        let mut sc = PolyScratch::default();
        let mut out = vec![0.0; 5];
        let prepared = m.prepare();
        assert!(prepared.poly.is_some());
        for j in 0..y.ncols() {
            let yj: Vec<f64> = (0..5).map(|i| y[(i, j)]).collect();
            m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
            for i in 0..5 {
                assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
                // One coordinate alone, plain and prepared: the same bits.
                assert_eq!(m.lift_one(&m.reduce(&yj), &mut sc, i).to_bits(), out[i].to_bits(), "point {j} coord {i}");
                assert_eq!(
                    prepared.lift_one(&m.reduce(&yj), &mut sc, i).to_bits(),
                    out[i].to_bits(),
                    "prepared: point {j} coord {i}"
                );
            }
            let mut all = vec![0.0; 5];
            prepared.lift_into(&m.reduce(&yj), &mut sc, &mut all);
            assert_eq!(
                all.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "prepared lift_into: point {j}"
            );
        }
        assert!(m.lift_one(&[0.1, 0.2], &mut sc, 5).is_nan());
        assert!(prepared.lift_one(&[0.1, 0.2], &mut sc, 5).is_nan());
        let c = m.conditioning.unwrap();
        assert!(c.cond.is_finite() && c.cond > 1.0 && c.rel_residual < 1e-12, "{c:?}");
    }

    /// A curve in R^3 that is an exact graph over its own SVD tangent `e1` with a degree-1 AND a
    /// degree-2 normal part: `y = e e1 + e w1 + e^2 w2`, `w1, w2` normal to `e1`, `w1 = -w2
    /// m3 / m2` (`mk` the k-th moment of the samples `e`, skewed so `m3 != 0`), which makes
    /// `e1` an eigenvector of the data's covariance (and the top one). `fit_with_linear_normal`
    /// recovers `w1` and every point to rounding; `fit` (no degree-1 part) cannot, and its
    /// degree-2 part absorbs the missing linear one; alone (order 1) the degree-1 part is zero.
    #[test]
    fn linear_normal_part_over_the_own_tangent() {
        let es: Vec<f64> = (0..=40).map(|k| -0.5 + 1.5 * k as f64 / 40.0).collect();
        let m2: f64 = es.iter().map(|e| e * e).sum();
        let m3: f64 = es.iter().map(|e| e * e * e).sum();
        let w2 = [0.0, 0.3, -0.2];
        let w1: Vec<f64> = w2.iter().map(|w| -w * m3 / m2).collect();
        assert!(w1[1].abs() > 0.05, "the test needs a sizeable linear part: {w1:?}");
        let y = Mat::from_fn(3, es.len(), |i, j| if i == 0 { es[j] } else { w1[i] * es[j] + w2[i] * es[j] * es[j] });
        let m = Manifold::fit_with_linear_normal(std::slice::from_ref(&y), 1, 2, Ridge::Fixed(0.0)).unwrap();
        assert!((m.v1[0] - 1.0).abs() < 1e-13 && m.v1[1].abs() < 1e-13 && m.v1[2].abs() < 1e-13, "V1 = {:?}", m.v1);
        let poly = m.nonlinear.as_ref().unwrap();
        let k1 = poly.exps.iter().position(|e| e == &vec![1]).unwrap();
        let k2 = poly.exps.iter().position(|e| e == &vec![2]).unwrap();
        for i in 0..3 {
            let got1 = poly.coef[k1 * 3 + i] / poly.scale[0];
            let got2 = poly.coef[k2 * 3 + i] / (poly.scale[0] * poly.scale[0]);
            assert!((got1 - w1[i]).abs() < 1e-12, "degree 1, coord {i}: {got1} vs {}", w1[i]);
            assert!((got2 - w2[i]).abs() < 1e-12, "degree 2, coord {i}: {got2} vs {}", w2[i]);
        }
        // observable_row includes the degree-1 part (first coordinate: zero there).
        assert!((m.observable_row()[0] - 1.0).abs() < 1e-13);
        let worst = |m: &Manifold| {
            let (mut sc, mut out, mut w) = (PolyScratch::default(), vec![0.0; 3], 0.0f64);
            for j in 0..y.ncols() {
                let yj: Vec<f64> = (0..3).map(|i| y[(i, j)]).collect();
                m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
                w = (0..3).fold(w, |w, i| w.max((out[i] - yj[i]).abs()));
            }
            w
        };
        assert!(worst(&m) < 1e-13, "with the degree-1 part: {}", worst(&m));
        let plain = Manifold::fit(std::slice::from_ref(&y), 1, 2, Ridge::Fixed(0.0)).unwrap();
        assert!(worst(&plain) > 1e-2, "without it: {}", worst(&plain));
        // Order 1: the degree-1 part alone is the regression of the SVD residual on eta, zero.
        let lin = Manifold::fit_with_linear_normal(std::slice::from_ref(&y), 1, 1, Ridge::Fixed(0.0)).unwrap();
        let c = &lin.nonlinear.as_ref().unwrap().coef;
        assert!(c.iter().all(|v| v.abs() < 1e-13), "order-1 degree-1 part {c:?}");
    }

    /// `observable_poly` is the first coordinate of `lift_into` (a normal part with degree-1
    /// terms, as after `fit_with_tangent`, and scales), and its linear part is
    /// `observable_row`.
    #[test]
    fn observable_poly_is_the_first_lifted_coordinate() {
        let (p, d) = (3, 2);
        let v1 = vec![0.6, 0.8, 0.0, -0.8, 0.6, 0.0];
        let exps = poly::exponents(d, 1, 3);
        let coef: Vec<f64> = (0..exps.len() * p).map(|k| 0.1 * ((k * 7 % 11) as f64 - 5.0)).collect();
        let scale = vec![0.5, 2.0];
        let nonlinear = Some(Poly { dim_in: d, dim_out: p, scale: scale.clone(), exps, coef });
        let m =
            Manifold { dim: d, p, v1, singular_values: vec![1.0; p], eta_scale: scale, nonlinear, conditioning: None };
        let x = m.observable_poly();
        let mut sc = PolyScratch::default();
        let mut out = vec![0.0; p];
        for eta in [[0.3, -0.2], [-1.1, 0.7], [0.05, 0.9]] {
            m.lift_into(&eta, &mut sc, &mut out);
            let got = x.eval(&eta)[0];
            assert!((got - out[0]).abs() < 1e-14, "{eta:?}: {got} vs {}", out[0]);
        }
        for (a, b) in x.linear_part().iter().zip(m.observable_row()) {
            assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        }
    }

    /// With data symmetric so that the SVD returns exactly span(e1, e2), a graph of a
    /// quadratic is recovered to rounding.
    #[test]
    fn recovers_quadratic_graph_exactly() {
        let mut cols = Vec::new();
        for i in -10..=10 {
            for j in -10..=10 {
                let (e1, e2) = (0.1 * i as f64, 0.1 * j as f64);
                // e1*e2 is odd in each coordinate: orthogonal to e1, e2 on this symmetric grid.
                let h = 0.3 * e1 * e2;
                cols.push([e1, e2, h, -2.0 * h]);
            }
        }
        let y = Mat::from_fn(4, cols.len(), |i, j| cols[j][i]);
        let m = Manifold::fit(std::slice::from_ref(&y), 2, 2, Ridge::Fixed(0.0)).unwrap();
        let mut sc = PolyScratch::default();
        let mut out = vec![0.0; 4];
        for j in (0..y.ncols()).step_by(17) {
            let yj: Vec<f64> = (0..4).map(|i| y[(i, j)]).collect();
            m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
            for i in 0..4 {
                assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
            }
        }
        assert!(m.constraint_defect() < 1e-13);
    }
    /// [`Manifold::fit_with_tangent_weighted`]: `None` is the unweighted fit bit for bit; an
    /// exact graph (degree 1 and 2 normal parts) is recovered with weights too; on a graph
    /// the order does not reach the weights change the fit; the dynamics' low-degree stage
    /// is refused.
    #[test]
    fn weighted_graph_over_a_given_tangent() {
        let v1 = vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
        let graph = |cubic: f64| {
            let mut cols = Vec::new();
            for i in -10..=10 {
                for j in -10..=10 {
                    let (e1, e2) = (0.05 * i as f64, 0.05 * j as f64);
                    cols.push([e1, e2, 0.2 * e1 + 0.3 * e1 * e2 + cubic * e1.powi(3), -0.1 * e2 + e1 * e1]);
                }
            }
            Mat::from_fn(4, cols.len(), |i, j| cols[j][i])
        };
        let wt = RowWeight { knee: 0.3, power: 8.0, low_degrees: None };
        let exact = graph(0.0);
        let a = Manifold::fit_with_tangent(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0)).unwrap();
        let b = Manifold::fit_with_tangent_weighted(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0), None)
            .unwrap();
        assert_eq!(a.nonlinear.as_ref().unwrap().coef, b.nonlinear.as_ref().unwrap().coef);
        let w =
            Manifold::fit_with_tangent_weighted(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0), Some(&wt))
                .unwrap();
        let (mut sc, mut out) = (PolyScratch::default(), vec![0.0; 4]);
        for j in (0..exact.ncols()).step_by(13) {
            let yj: Vec<f64> = (0..4).map(|i| exact[(i, j)]).collect();
            w.lift_into(&w.reduce(&yj), &mut sc, &mut out);
            for i in 0..4 {
                assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
            }
        }
        assert!(w.conditioning.unwrap().rel_residual < 1e-12);
        let off = graph(2.0);
        let (u, v) = (
            Manifold::fit_with_tangent(std::slice::from_ref(&off), &v1, 2, 2, Ridge::Fixed(0.0)).unwrap(),
            Manifold::fit_with_tangent_weighted(std::slice::from_ref(&off), &v1, 2, 2, Ridge::Fixed(0.0), Some(&wt))
                .unwrap(),
        );
        let gap = u
            .nonlinear
            .unwrap()
            .coef
            .iter()
            .zip(&v.nonlinear.unwrap().coef)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(gap > 1e-4, "weights changed nothing: {gap}");
        let staged = RowWeight {
            low_degrees: Some(crate::weight::LowDegreeStage { max_degree: 3, knee: 0.1, power: 8.0 }),
            ..wt
        };
        let e = Manifold::fit_with_tangent_weighted(
            std::slice::from_ref(&exact),
            &v1,
            2,
            2,
            Ridge::Fixed(0.0),
            Some(&staged),
        )
        .unwrap_err();
        assert!(matches!(e, FitError::BadOption { what: "manifold row weight", .. }), "{e}");
    }
}
