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

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-built map model whose every coefficient is affine in `a`: mixing models at
    /// `a_i` with weights summing to 1 gives the model at `sum w_i a_i` (to rounding).
    fn map_model(a: f64) -> SsmModel {
        let mut m = crate::backbone::tests::model(0.3, 1.0 + a);
        let exps = crate::poly::exponents(2, 1, 3);
        let coef = (0..exps.len() * 2).map(|k| 0.01 * (k as f64 + 1.0) * (1.0 - 0.5 * a) + 0.001 * a).collect();
        m.dynamics = ReducedDynamics::Map {
            increment: Poly { dim_in: 2, dim_out: 2, scale: vec![1.0, 1.0], exps, coef },
            dt: 0.01,
            conditioning: crate::ridge::Conditioning::NONE,
        };
        m.manifold.v1.iter_mut().for_each(|v| *v *= 1.0 + a);
        m
    }

    #[test]
    fn mix_models_mixes_coefficients() {
        let (m0, m1, m2) = (map_model(0.0), map_model(1.0), map_model(0.25));
        let w = [0.75, 0.25];
        let max_diff = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        let inc = |m: &SsmModel| match &m.dynamics {
            ReducedDynamics::Map { increment, dt, .. } => (increment.coef.clone(), *dt),
            _ => (Vec::new(), 0.0),
        };
        let nl = |m: &SsmModel| m.manifold.nonlinear.as_ref().map(|p| p.coef.clone()).unwrap_or_default();
        let mixed = mix_models(&[&m0, &m1], &w, 0, V1Mix::Mixed, 0.02).unwrap();
        assert!(max_diff(&inc(&mixed).0, &inc(&m2).0) < 1e-16 && max_diff(&nl(&mixed), &nl(&m2)) < 1e-15);
        assert!(max_diff(&mixed.manifold.v1, &m2.manifold.v1) < 1e-15);
        assert_eq!((inc(&mixed).1, mixed.dt), (0.02, 0.02));
        assert_eq!(mixed.eigenvalues_ct, mixed.dynamics.eigenvalues_ct().unwrap());
        // Shared: the base's V1 bit for bit, everything else mixed as before.
        let shared = mix_models(&[&m0, &m1], &w, 1, V1Mix::Shared, 0.02).unwrap();
        assert_eq!(shared.manifold.v1, m1.manifold.v1);
        assert_eq!(inc(&shared).0, inc(&mixed).0);
        // Refused: counts, other monomials, not a map.
        assert!(matches!(
            mix_models(&[&m0, &m1], &[1.0], 0, V1Mix::Mixed, 0.02),
            Err(crate::Error::Mix(MixError::Count { .. }))
        ));
        let mut other = map_model(1.0);
        if let ReducedDynamics::Map { increment, .. } = &mut other.dynamics {
            increment.scale[0] = 2.0;
        }
        assert!(matches!(
            mix_models(&[&m0, &other], &w, 0, V1Mix::Mixed, 0.02),
            Err(crate::Error::Mix(MixError::Mismatch { index: 1, base: 0, part: "map increment" }))
        ));
        let flow = crate::backbone::tests::model(0.3, 1.0);
        assert!(matches!(
            mix_models(&[&m0, &flow], &w, 0, V1Mix::Mixed, 0.02),
            Err(crate::Error::Mix(MixError::NotAMap { index: 1 }))
        ));
    }

    #[test]
    fn spline_weights() {
        // Node values reproduced exactly, by both interpolants.
        let nodes = [30.5, 31.0, 32.0, 32.5];
        for interp in [Interp::Linear, Interp::Spline] {
            for (i, &x) in nodes.iter().enumerate() {
                let w = interp_weights(&nodes, x, interp).unwrap();
                for (j, wj) in w.iter().enumerate() {
                    assert!((wj - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14, "{interp:?} node {i}: {w:?}");
                }
            }
        }
        // Hand-derived natural spline through (0,0), (1,1), (2,0): m_1 = -3, so on [0,1]
        // S(x) = -x^3/2 + 3x/2, and by symmetry S(2-x) = S(x).
        let n3 = [0.0, 1.0, 2.0];
        let y3 = [0.0, 1.0, 0.0];
        let ev =
            |x: f64| interp_weights(&n3, x, Interp::Spline).unwrap().iter().zip(&y3).map(|(w, y)| w * y).sum::<f64>();
        for x in [0.1, 0.25, 0.5, 0.9] {
            let s = -x * x * x / 2.0 + 1.5 * x;
            assert!((ev(x) - s).abs() < 1e-14 && (ev(2.0 - x) - s).abs() < 1e-14, "x {x}: {} vs {s}", ev(x));
        }
        // A natural spline is exact for straight lines; on the training nodes a cubic
        // y = (x - 31)^3 is NOT reproduced (its ends have nonzero curvature), but the
        // interpolant is C2 with zero end curvature: check by finite differences.
        let f = |x: f64| 2.0 - 0.3 * x;
        let yc: Vec<f64> = nodes.iter().map(|&x| (x - 31.0f64).powi(3)).collect();
        let s = |x: f64, y: &[f64]| {
            interp_weights(&nodes, x, Interp::Spline).unwrap().iter().zip(y).map(|(w, v)| w * v).sum::<f64>()
        };
        let yl: Vec<f64> = nodes.iter().map(|&x| f(x)).collect();
        for x in [30.6, 30.9, 31.3, 31.77, 32.2, 32.45] {
            assert!((s(x, &yl) - f(x)).abs() < 1e-12, "line at {x}");
        }
        let h = 1e-4;
        let d2 = |x: f64| (s(x + h, &yc) - 2.0 * s(x, &yc) + s(x - h, &yc)) / (h * h);
        let d1 = |x: f64, side: f64| (s(x + side * h, &yc) - s(x, &yc)) / (side * h);
        assert!(
            d2(30.5 + h).abs() < 5e-3 && d2(32.5 - h).abs() < 5e-3 && d2(31.5).abs() > 0.5,
            "end curvature {} {}",
            d2(30.5 + h),
            d2(32.5 - h)
        );
        for &xi in &nodes[1..3] {
            // one-sided slopes agree to O(h), second derivatives on both sides too
            assert!((d1(xi, 1.0) - d1(xi, -1.0)).abs() < 1e-2, "C1 at {xi}");
            assert!(
                (d2(xi + 2.0 * h) - d2(xi - 2.0 * h)).abs() < 0.1,
                "C2 at {xi}: {} vs {}",
                d2(xi + 2.0 * h),
                d2(xi - 2.0 * h)
            );
        }
        assert!(matches!(interp_weights(&nodes, 32.6, Interp::Spline), Err(InterpError::OutOfRange { .. })));
        assert!(matches!(interp_weights(&[1.0, 1.0], 1.0, Interp::Linear), Err(InterpError::BadNodes(_))));
    }
}
