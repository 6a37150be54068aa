//! Interpolation of fitted coefficients in a system parameter (the sampling period of the
//! parametric models): weights that are linear in the node values, so one set of weights
//! serves every coefficient of a model at once; [`mix_models`] applies them to whole models.

use serde::{Deserialize, Serialize};

use crate::dynamics::ReducedDynamics;
use crate::fit::SsmModel;
use crate::poly::Poly;

/// Interpolation nodes or a query point that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InterpError {
    #[error("interpolation nodes: need finite, strictly increasing nodes, got {0:?}")]
    BadNodes(Vec<f64>),
    #[error("parameter {x} outside the training range [{lo}, {hi}] (no extrapolation)")]
    OutOfRange { x: f64, lo: f64, hi: f64 },
}

/// How coefficients are interpolated in the system parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Interp {
    /// Piecewise linear between the two bracketing training periods.
    Linear,
    /// Natural cubic spline (zero second derivative at the end periods) through all
    /// training periods.
    Spline,
}

/// Weights `w_i` such that the interpolant at `x` of values `f_i` at `nodes` (strictly
/// increasing) is `sum_i w_i f_i`. Both interpolants are linear in the node values, so the
/// weights serve every coefficient at once. No extrapolation: `x` outside the nodes is an
/// error. With one node the weight is 1; with two the spline is the straight line.
pub fn interp_weights(nodes: &[f64], x: f64, interp: Interp) -> Result<Vec<f64>, InterpError> {
    let n = nodes.len();
    if n == 0 || nodes.iter().any(|v| !v.is_finite()) || nodes.windows(2).any(|w| w[1] <= w[0]) {
        return Err(InterpError::BadNodes(nodes.to_vec()));
    }
    let (lo, hi) = (nodes[0], nodes[n - 1]);
    if !(x >= lo && x <= hi) {
        return Err(InterpError::OutOfRange { x, lo, hi });
    }
    let mut w = vec![0.0; n];
    if n == 1 {
        w[0] = 1.0;
        return Ok(w);
    }
    let k = nodes.windows(2).position(|s| x <= s[1]).unwrap_or(n - 2);
    let h = nodes[k + 1] - nodes[k];
    let (a, b) = ((nodes[k + 1] - x) / h, (x - nodes[k]) / h);
    w[k] += a;
    w[k + 1] += b;
    if interp == Interp::Linear || n == 2 {
        return Ok(w);
    }
    // Second derivatives m = S y (m_0 = m_{n-1} = 0) from the tridiagonal system
    // h_{i-1} m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_i m_{i+1} = 6 (dy_i/h_i - dy_{i-1}/h_{i-1});
    // the value is a y_k + b y_{k+1} + ((a^3 - a) m_k + (b^3 - b) m_{k+1}) h^2 / 6.
    let m = second_derivative_operator(nodes);
    for (j, wj) in w.iter_mut().enumerate() {
        *wj += ((a * a * a - a) * m[k][j] + (b * b * b - b) * m[k + 1][j]) * h * h / 6.0;
    }
    Ok(w)
}

/// How [`mix_models`] treats the manifold's linear part `V1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum V1Mix {
    /// Each model has its own `V1`: mixed with the weights like the polynomials.
    Mixed,
    /// The models share one `V1` (one tangent space): the base model's is copied, not
    /// mixed (a weighted sum of equal vectors is not bit-equal to them).
    Shared,
}

/// Models whose coefficients cannot be mixed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixError {
    #[error("mixing models: {weights} weights for {models} models (base index {base})")]
    Count { models: usize, weights: usize, base: usize },
    #[error("model {index} has other monomials, scales or outputs than model {base} in its {part}")]
    Mismatch { index: usize, base: usize, part: &'static str },
    #[error("model {index} is not a discrete map: only map increments are mixed")]
    NotAMap { index: usize },
}

/// The model `sum_i weights[i] models[i]`: a clone of `models[base]` whose manifold
/// polynomial (the nonlinear part), map increment and, with [`V1Mix::Mixed`], `V1` hold the
/// weighted sums of the models' coefficients (each `0 + w_0 c_0 + w_1 c_1 + ...`, in model
/// order), stepping `dt` seconds (`dt` and the map's step), its continuous-time eigenvalues
/// recomputed. Every model must be a map with the base's monomials, scales and output
/// dimension (manifold and increment) and, when mixed, the base's `V1` length. The rest
/// (fit records, `eta_range`, ...) is the base's. The weights come from
/// [`interp_weights`] over the models' parameter values.
pub fn mix_models(
    models: &[&SsmModel],
    weights: &[f64],
    base: usize,
    v1_mix: V1Mix,
    dt: f64,
) -> Result<SsmModel, crate::Error> {
    let Some(first) = models.get(base).filter(|_| models.len() == weights.len()) else {
        return Err(MixError::Count { models: models.len(), weights: weights.len(), base }.into());
    };
    fn increment(m: &SsmModel) -> Option<&Poly> {
        match &m.dynamics {
            ReducedDynamics::Map { increment, .. } => Some(increment),
            _ => None,
        }
    }
    let same = |p: &Poly, q: &Poly| {
        p.exps == q.exps && p.scale == q.scale && p.dim_out == q.dim_out && p.coef.len() == q.coef.len()
    };
    for (index, m) in models.iter().enumerate() {
        let mismatch = |part| MixError::Mismatch { index, base, part };
        let (Some(p), Some(q)) = (increment(m), increment(first)) else {
            return Err(MixError::NotAMap { index }.into());
        };
        if !same(p, q) {
            return Err(mismatch("map increment").into());
        }
        match (&m.manifold.nonlinear, &first.manifold.nonlinear) {
            (None, None) => {}
            (Some(p), Some(q)) if same(p, q) => {}
            _ => return Err(mismatch("manifold polynomial").into()),
        }
        if v1_mix == V1Mix::Mixed && m.manifold.v1.len() != first.manifold.v1.len() {
            return Err(mismatch("tangent basis V1").into());
        }
    }
    let mix = |get: &dyn Fn(&SsmModel) -> &[f64], len: usize| -> Vec<f64> {
        let mut acc = vec![0.0; len];
        for (m, wi) in models.iter().zip(weights) {
            acc.iter_mut().zip(get(m)).for_each(|(a, x)| *a += wi * x);
        }
        acc
    };
    fn inc_coef(m: &SsmModel) -> &[f64] {
        increment(m).map_or(&[], |p| p.coef.as_slice())
    }
    fn obs_coef(m: &SsmModel) -> &[f64] {
        m.manifold.nonlinear.as_ref().map_or(&[], |p| p.coef.as_slice())
    }
    fn v1(m: &SsmModel) -> &[f64] {
        m.manifold.v1.as_slice()
    }
    let mut out = (*first).clone();
    if let ReducedDynamics::Map { increment, dt: step, .. } = &mut out.dynamics {
        increment.coef = mix(&inc_coef, increment.coef.len());
        *step = dt;
    }
    if let Some(p) = &mut out.manifold.nonlinear {
        p.coef = mix(&obs_coef, p.coef.len());
    }
    if v1_mix == V1Mix::Mixed {
        out.manifold.v1 = mix(&v1, first.manifold.v1.len());
    }
    out.dt = dt;
    out.eigenvalues_ct = out.dynamics.eigenvalues_ct()?;
    Ok(out)
}

/// Matrix `S` (`n x n`, rows = nodes) with `m = S y` the natural spline's second
/// derivatives at the nodes (`n >= 3`), by the Thomas algorithm on each unit vector.
fn second_derivative_operator(x: &[f64]) -> Vec<Vec<f64>> {
    let n = x.len();
    let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mut s = vec![vec![0.0; n]; n];
    let inner = n - 2;
    for j in 0..n {
        // right-hand side for y = e_j
        let y = |i: usize| if i == j { 1.0 } else { 0.0 };
        let rhs: Vec<f64> =
            (1..n - 1).map(|i| 6.0 * ((y(i + 1) - y(i)) / h[i] - (y(i) - y(i - 1)) / h[i - 1])).collect();
        let diag: Vec<f64> = (1..n - 1).map(|i| 2.0 * (h[i - 1] + h[i])).collect();
        let mut c = vec![0.0; inner];
        let mut d = vec![0.0; inner];
        for r in 0..inner {
            let lower = if r > 0 { h[r] } else { 0.0 }; // coefficient of m_{r} in row r+1
            let upper = if r + 1 < inner { h[r + 1] } else { 0.0 };
            let den = diag[r] - lower * if r > 0 { c[r - 1] } else { 0.0 };
            c[r] = upper / den;
            d[r] = (rhs[r] - lower * if r > 0 { d[r - 1] } else { 0.0 }) / den;
        }
        let mut m = vec![0.0; inner];
        for r in (0..inner).rev() {
            m[r] = d[r] - if r + 1 < inner { c[r] * m[r + 1] } else { 0.0 };
        }
        for (row, mr) in s[1..n - 1].iter_mut().zip(&m) {
            row[j] = *mr;
        }
    }
    s
}
