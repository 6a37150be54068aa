//! Row weights of the weighted polynomial regressions (the reduced dynamics' and the
//! manifold's): the amplitude envelope of each row, the smooth cut [`RowWeight`] with its
//! optional low-degree first stage [`LowDegreeStage`], and row scaling. Below both
//! `dynamics` and `manifold`, so neither imports the other for it.

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use super::error::FitError;

/// Envelope of row `i` of `x`: the max `||x||` over the rows of its trajectory (group)
/// within one oscillation of it (the largest gap between successive local maxima of `||x||`
/// in the group) on either side.
pub(crate) fn envelope(x: MatRef<'_, f64>, groups: &[std::ops::Range<usize>]) -> Vec<f64> {
    let (n, d) = (x.nrows(), x.ncols());
    let norm: Vec<f64> = (0..n).map(|i| (0..d).map(|j| x[(i, j)] * x[(i, j)]).sum::<f64>().sqrt()).collect();
    let mut env = vec![0.0; n];
    for g in groups {
        let r = g.clone();
        // local maxima of ||x|| in the group; the window is the largest gap between them
        let peaks: Vec<usize> = (r.start + 1..r.end.saturating_sub(1))
            .filter(|&i| norm[i] >= norm[i - 1] && norm[i] > norm[i + 1])
            .collect();
        let half = peaks.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(r.len()).max(1);
        for i in r.clone() {
            let (lo, hi) = (i.saturating_sub(half).max(r.start), (i + half + 1).min(r.end));
            env[i] = norm[lo..hi].iter().copied().fold(0.0, f64::max);
        }
    }
    env
}

/// Row weights of a polynomial dynamics regression ([`crate::dynamics::ReducedDynamics::fit_weighted`]): the
/// pair of row `i` weighs `1 / (1 + (env_i / knee)^power)` in the squared residual, `env_i`
/// the envelope of `||eta||` around it (its max over one oscillation of the trajectory). A
/// smooth cut in amplitude: 1 well inside the knee, 1/2 at it, `(knee / env)^power` beyond.
/// For data that run past the range a truncated polynomial can follow (escaping
/// trajectories), the fit then no longer depends on how far past the knee they were kept.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowWeight {
    /// Envelope of `||eta||` where the weight is 1/2 (> 0).
    pub knee: f64,
    /// Steepness (>= 1).
    pub power: f64,
    /// A first stage for the low degrees (polynomial dynamics with the plain linear anchor
    /// only): see [`LowDegreeStage`]. `None` (and files written before the option): one
    /// weighted fit of every degree above the linear one.
    #[serde(default)]
    pub low_degrees: Option<LowDegreeStage>,
}

/// The two-stage fit of a weighted polynomial regression's nonlinear degrees: first every
/// degree `2..=K` on the pairs weighted by this stage's own (lower) knee, keeping only its
/// degrees `2..=max_degree`; then the degrees above `max_degree` on what those leave, with
/// the [`RowWeight`]'s own knee. The low degrees (which fix the normal form's cubic terms)
/// then come from the small-amplitude data, where the order-K truncation does not bend
/// them, and the high degrees still follow the data up to the main knee (the global
/// bifurcations). The linear part stays the anchored one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LowDegreeStage {
    /// Highest degree taken from the first stage (2 ..= K - 1).
    pub max_degree: u32,
    /// Knee of the first stage's weight (envelope of `||eta||`, > 0).
    pub knee: f64,
    /// Its steepness (1 ..= 64).
    pub power: f64,
}

impl LowDegreeStage {
    /// The first stage's own row weight (its knee and power, no further stage).
    pub fn weight(&self) -> RowWeight {
        RowWeight { knee: self.knee, power: self.power, low_degrees: None }
    }
}

impl RowWeight {
    /// Checks `knee > 0` and `1 <= power <= 64`, both finite.
    pub fn validate(&self) -> Result<(), FitError> {
        if !(self.knee.is_finite() && self.knee > 0.0) {
            return Err(FitError::BadOption {
                what: "row weight knee",
                why: format!("must be positive and finite, got {}", self.knee),
            });
        }
        if !(self.power.is_finite() && (1.0..=64.0).contains(&self.power)) {
            return Err(FitError::BadOption {
                what: "row weight power",
                why: format!("must be in [1, 64], got {}", self.power),
            });
        }
        if let Some(st) = &self.low_degrees {
            st.weight().validate().map_err(|e| match e {
                FitError::BadOption { why, .. } => FitError::BadOption { what: "row weight low-degree stage", why },
                e => e,
            })?;
            if st.max_degree < 2 {
                return Err(FitError::BadOption {
                    what: "row weight low-degree stage",
                    why: format!("max_degree must be >= 2, got {}", st.max_degree),
                });
            }
        }
        Ok(())
    }

    /// Square roots of the weights of the rows of `x` (trajectories `groups`): the factors
    /// of the rows of a weighted least-squares problem.
    pub fn row_factors(&self, x: MatRef<'_, f64>, groups: &[std::ops::Range<usize>]) -> Vec<f64> {
        // (env / knee)^power may overflow to infinity: the weight is then 0.
        envelope(x, groups).iter().map(|e| (1.0 / (1.0 + (e / self.knee).powf(self.power))).sqrt()).collect()
    }
}

/// `m` with row `i` multiplied by `f[i]`.
pub(crate) fn scale_rows(mut m: Mat<f64>, f: &[f64]) -> Mat<f64> {
    for j in 0..m.ncols() {
        for (i, fi) in f.iter().enumerate().take(m.nrows()) {
            m[(i, j)] *= fi;
        }
    }
    m
}
