//! Exact linear stability of the sampled-data, delayed loop at the upright equilibrium.
//!
//! Input is plant-generic: the continuous linearization `x' = A x + B u` (N states, one
//! input), the index of the primary (stabilized) angle `y = x[primary]` and of the
//! secondary angle `z = x[secondary]` that the controller reads, and a
//! [`ControllerConfig`]. The module
//!
//! 1. discretizes the plant exactly under zero-order hold ([`LinearPlant::discretize`]):
//!    `Phi = e^{A dt}`, `Gamma = int_0^dt e^{A s} ds B`, both read off the exponential of
//!    the augmented matrix `[[A, B], [0, 0]] dt` (scaling and squaring, Padé 13);
//! 2. builds the closed-loop map of the delayed law ([`Zoh::closed_loop`]) on the state
//!    `(x_i, y_{i-1}, ..., y_{i-r-1}, z_{i-1}, ..., z_{i-r-1} [, x_I,i-1])`;
//! 3. returns its eigenvalues, the closed-loop multipliers ([`Multiplier`]), all of them
//!    or with the structural multiplier 1 of the secondary-angle shift removed exactly
//!    ([`ClosedLoopMap::dominant_multipliers`]).
//!
//! The map is that of the *unquantized, unsaturated* loop: saturation is inactive at the
//! equilibrium and quantization has no linearization, so `u_max` and `quant` of the
//! configuration play no part here (by definition, not by omission).
//!
//! Integral action (`ki != 0`) follows `shared::ControllerConfig`: the running sum is
//! updated before use, `x_I,i = x_I,i-1 + dt*y_{i-r}` and `u_i = ... - ki*x_I,i`; the
//! sum is then one more state. With `ki == 0` it is left out (it would only add an
//! uncontrolled multiplier 1).
//!
//! This module owns no plant: it never evaluates a nonlinear right-hand side.

mod eig;
mod expm;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use serde::Serialize;
use shared::ControllerConfig;

pub use eig::eigenvalues;
pub use expm::{ExpmFailure, expm};

/// Largest delay accepted, in samples (the map has `N + 2(r+1) [+1]` states).
pub const MAX_DELAY: u32 = 1000;

/// Largest 1-norm of the exponent `[[A, B], [0, 0]] dt` whose exponential is trusted
/// (scaling and squaring then takes at most 11 squarings, each of which can amplify the
/// rounding of a non-normal matrix).
pub const EXPONENT_NORM_MAX: f64 = 1e4;

/// Largest accepted rounding bound of a multiplier: `n eps ||M||_F`, the backward error of
/// the eigenvalues of the `n x n` closed-loop map `M` (before any ill-conditioning of the
/// eigenvalue amplifies it). Beyond it `|mu|` cannot be compared with 1.
pub const MULTIPLIER_ERROR_MAX: f64 = 1e-6;

/// Largest accepted rounding bound of a rate `ln|mu| / dt`, relative to the plant's own
/// rate scale `max(||A||_1, 1 1/s)`: `n eps ||M||_F / dt` must stay below this fraction.
pub const RATE_ERROR_MAX: f64 = 1e-6;

/// Why a linear stability computation could not be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinearError {
    #[error("non-finite entry {value} in {what} at ({row}, {col})")]
    NonFinite { what: &'static str, row: usize, col: usize, value: f64 },
    #[error("A is {rows}x{cols} and B has {b_rows} rows: A must be square and B must match it")]
    Shape { rows: usize, cols: usize, b_rows: usize },
    #[error("the plant has no states")]
    Empty,
    #[error("{which} index {index} is out of range for a plant with {n} states")]
    IndexOutOfRange { which: &'static str, index: usize, n: usize },
    #[error("primary and secondary index are both {0}: the controller needs two different coordinates")]
    SameIndex(usize),
    #[error("sampling period dt = {0} s must be finite and > 0")]
    BadDt(f64),
    #[error(
        "sampling period dt = {dt:e} s underflows: dt times the plant's rate scale {rate_scale:e} 1/s is {product:e}, \
         below the spacing of double precision near 1 ({eps:e}), so one period does not move the state (its map \
         rounds to the identity)",
        product = .dt * .rate_scale,
        eps = f64::EPSILON
    )]
    StepUnderflow { dt: f64, rate_scale: f64 },
    #[error("controller gain {name} = {value} is not finite")]
    BadGain { name: &'static str, value: f64 },
    #[error("delay r = {0} samples exceeds the supported maximum {MAX_DELAY}")]
    DelayTooLarge(u32),
    #[error("controller dt = {config} s differs from the discretization dt = {zoh} s")]
    DtMismatch { config: f64, zoh: f64 },
    #[error("matrix exponential of [[A, B], [0, 0]]*dt failed at dt = {dt} s: {failure:?}")]
    Exponential { dt: f64, failure: ExpmFailure },
    #[error(
        "sampling period dt = {dt} s: the exponent [[A, B], [0, 0]]*dt has 1-norm {norm:e} > {EXPONENT_NORM_MAX:e}; its exponential cannot be trusted"
    )]
    ExponentTooLarge { dt: f64, norm: f64 },
    #[error(
        "{cause}: the closed-loop map has norm {norm:e}, so its multipliers are only known to +-{error:e} (n eps ||M||, limit {MULTIPLIER_ERROR_MAX:e}); refusing to report them"
    )]
    MultipliersInaccurate { cause: String, norm: f64, error: f64 },
    #[error(
        "sampling period dt = {dt:e} s: the rates ln|mu|/dt are only known to +-{error:e} 1/s (n eps ||M|| / dt), more than {RATE_ERROR_MAX:e} of the plant's rate scale {scale:e} 1/s; refusing to report them"
    )]
    RatesInaccurate { dt: f64, error: f64, scale: f64 },
    #[error("the controller measures no coordinate (empty gain vector)")]
    NoGains,
    #[error(
        "the secondary coordinate {index} is fed back with a P gain or integral action: there is no \
         structural multiplier 1 to remove"
    )]
    SecondaryControlled { index: usize },
    #[error("eigenvalue computation failed for the {n}x{n} closed-loop map: {reason}")]
    Eigen { n: usize, reason: String },
    #[error(
        "the secondary coordinate {index} enters the dynamics (A[{row}][{index}] = {value}): \
         there is no structural multiplier 1 to remove"
    )]
    SecondaryCouples { index: usize, row: usize, value: f64 },
    #[error(
        "structural deflation check failed: column {col} of the transformed map has off-diagonal \
         magnitude {residual:e} (expected rounding level)"
    )]
    Deflation { col: usize, residual: f64 },
}

impl LinearError {
    /// The scene key an error is caused by, when it is one: a sampling period that is not
    /// positive, underflows, or makes the discretization or the rates meaningless is
    /// `controller.dt_ms`'s; a delay beyond the maximum is `controller.delay`'s.
    pub fn scene_key(&self) -> Option<&'static str> {
        match self {
            LinearError::BadDt(_)
            | LinearError::StepUnderflow { .. }
            | LinearError::Exponential { .. }
            | LinearError::ExponentTooLarge { .. }
            | LinearError::RatesInaccurate { .. } => Some("controller.dt_ms"),
            LinearError::DelayTooLarge(_) => Some("controller.delay"),
            _ => None,
        }
    }
}

/// One closed-loop multiplier `mu` (eigenvalue of the one-period map).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Multiplier {
    pub re: f64,
    pub im: f64,
    /// `|mu|`.
    pub abs: f64,
    /// `|arg mu| / (2 pi dt)`, Hz (0 for a positive real multiplier, Nyquist for a negative one).
    pub freq_hz: f64,
    /// `ln|mu| / dt`, 1/s: the growth rate of the equivalent continuous mode;
    /// `-inf` for `mu = 0` (serialized by serde_json as `null`).
    pub rate: f64,
}

impl Multiplier {
    /// The multiplier `re + i im` of a map with sampling period `dt`.
    pub fn new(re: f64, im: f64, dt: f64) -> Self {
        let abs = re.hypot(im);
        let arg = if abs == 0.0 { 0.0 } else { im.atan2(re).abs() };
        let rate = if abs == 0.0 { f64::NEG_INFINITY } else { abs.ln() / dt };
        Self { re, im, abs, freq_hz: arg / (2.0 * std::f64::consts::PI * dt), rate }
    }
}

/// Largest modulus in `ms` (0 for an empty list).
pub fn spectral_radius(ms: &[Multiplier]) -> f64 {
    ms.iter().fold(0.0, |m, x| m.max(x.abs))
}

/// A validated continuous linearization `x' = A x + B u` with the coordinates the
/// controller reads.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearPlant {
    a: DMatrix<f64>,
    b: DVector<f64>,
    primary: usize,
    secondary: usize,
}

impl LinearPlant {
    /// From fixed-size matrices (as `crate::plant::linearize` returns them).
    pub fn new<const N: usize>(
        a: &SMatrix<f64, N, N>,
        b: &SVector<f64, N>,
        primary: usize,
        secondary: usize,
    ) -> Result<Self, LinearError> {
        Self::from_dynamic(
            DMatrix::from_column_slice(N, N, a.as_slice()),
            DVector::from_column_slice(b.as_slice()),
            primary,
            secondary,
        )
    }

    /// From dynamically sized matrices.
    pub fn from_dynamic(
        a: DMatrix<f64>,
        b: DVector<f64>,
        primary: usize,
        secondary: usize,
    ) -> Result<Self, LinearError> {
        let n = a.nrows();
        if a.ncols() != n || b.nrows() != n {
            return Err(LinearError::Shape { rows: n, cols: a.ncols(), b_rows: b.nrows() });
        }
        if n == 0 {
            return Err(LinearError::Empty);
        }
        for col in 0..n {
            for row in 0..n {
                let value = a[(row, col)];
                if !value.is_finite() {
                    return Err(LinearError::NonFinite { what: "A", row, col, value });
                }
            }
        }
        if let Some((row, &value)) = b.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(LinearError::NonFinite { what: "B", row, col: 0, value });
        }
        for (which, index) in [("primary", primary), ("secondary", secondary)] {
            if index >= n {
                return Err(LinearError::IndexOutOfRange { which, index, n });
            }
        }
        if primary == secondary {
            return Err(LinearError::SameIndex(primary));
        }
        Ok(Self { a, b, primary, secondary })
    }

    /// Number of plant states N.
    pub fn dim(&self) -> usize {
        self.a.nrows()
    }

    pub fn a(&self) -> &DMatrix<f64> {
        &self.a
    }

    pub fn b(&self) -> &DVector<f64> {
        &self.b
    }

    pub fn primary(&self) -> usize {
        self.primary
    }

    pub fn secondary(&self) -> usize {
        self.secondary
    }

    /// Exact zero-order-hold discretization with period `dt` (s).
    pub fn discretize(&self, dt: f64) -> Result<Zoh, LinearError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(LinearError::BadDt(dt));
        }
        // A step too short to move the state on the f64 grid: `Phi = I` to rounding.
        let rate_scale = one_norm(&self.a).max(1.0);
        if !(dt * rate_scale >= f64::EPSILON) {
            return Err(LinearError::StepUnderflow { dt, rate_scale });
        }
        let n = self.dim();
        let mut aug = DMatrix::<f64>::zeros(n + 1, n + 1);
        aug.view_mut((0, 0), (n, n)).copy_from(&(&self.a * dt));
        aug.view_mut((0, n), (n, 1)).copy_from(&(&self.b * dt));
        let norm = one_norm(&aug);
        if !(norm <= EXPONENT_NORM_MAX) {
            return Err(LinearError::ExponentTooLarge { dt, norm });
        }
        let e = expm(&aug).map_err(|failure| LinearError::Exponential { dt, failure })?;
        Ok(Zoh {
            dt,
            phi: e.view((0, 0), (n, n)).into_owned(),
            gamma: e.view((0, n), (n, 1)).column(0).into_owned(),
            primary: self.primary,
            secondary: self.secondary,
            secondary_coupling: self.secondary_coupling(),
            rate_scale,
        })
    }

    /// The first nonzero entry of column `secondary` of A, if any: `(row, value)`.
    fn secondary_coupling(&self) -> Option<(usize, f64)> {
        self.a.column(self.secondary).iter().copied().enumerate().find(|(_, v)| *v != 0.0)
    }

    /// Closed-loop map for `cfg` (discretizes at `cfg.dt`).
    pub fn closed_loop(&self, cfg: &ControllerConfig) -> Result<ClosedLoopMap, LinearError> {
        self.discretize(cfg.dt)?.closed_loop(cfg)
    }
}

/// Exact ZOH discretization `x_{i+1} = Phi x_i + Gamma u_i`.
#[derive(Debug, Clone, PartialEq)]
pub struct Zoh {
    pub dt: f64,
    pub phi: DMatrix<f64>,
    pub gamma: DVector<f64>,
    primary: usize,
    secondary: usize,
    /// First nonzero entry `(row, value)` of column `secondary` of A, if any.
    secondary_coupling: Option<(usize, f64)>,
    /// The plant's rate scale `max(||A||_1, 1)`, 1/s (see [`RATE_ERROR_MAX`]).
    rate_scale: f64,
}

/// The Frobenius norm, scaled so that it overflows only when the matrix does (entries of
/// 1e200 have a norm of about 1e200, not inf).
fn frobenius(m: &DMatrix<f64>) -> f64 {
    let big = m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(big > 0.0) || !big.is_finite() {
        return if big.is_nan() { f64::NAN } else { big };
    }
    big * m.iter().map(|v| (v / big) * (v / big)).sum::<f64>().sqrt()
}

/// The 1-norm (largest absolute column sum) of a matrix.
fn one_norm(m: &DMatrix<f64>) -> f64 {
    m.column_iter().map(|c| c.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max)
}

/// Where each part of the augmented closed-loop state sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AugmentedLayout {
    /// Plant states N (indices `0..n_plant`).
    pub n_plant: usize,
    /// Delay r.
    pub delay: usize,
    /// Index of `y_{i-1}` (the first measured coordinate); `y_{i-1-k}` is at `y_start + k`,
    /// `k = 0..=r`.
    pub y_start: usize,
    /// Index of `z_{i-1}` (the second measured coordinate, if any; else the end of the
    /// sample registers); `z_{i-1-k}` is at `z_start + k`, `k = 0..=r`.
    pub z_start: usize,
    /// Number of measured coordinates; coordinate `j`'s samples start at
    /// `y_start + j (r + 1)`.
    pub measured: usize,
    /// Index of the integral sum `x_I,i-1`, if `ki != 0`.
    pub integral: Option<usize>,
    /// Total dimension.
    pub dim: usize,
}

impl AugmentedLayout {
    fn new(n_plant: usize, delay: usize, measured: usize, integral: bool) -> Self {
        let y_start = n_plant;
        let z_start = y_start + delay + 1;
        let end = y_start + measured * (delay + 1);
        let integral = integral.then_some(end);
        Self { n_plant, delay, y_start, z_start, measured, integral, dim: end + usize::from(integral.is_some()) }
    }

    /// Index of the samples of measured coordinate `j`, `q_j,{i-1}`.
    pub fn start(&self, j: usize) -> usize {
        self.y_start + j * (self.delay + 1)
    }
}

/// Names of the gains in errors: the shorthand's, or `p0`, `d1`, ...
const P_NAMES: [&str; shared::MAX_GAINS] = ["p0", "p1", "p2", "p3"];
const D_NAMES: [&str; shared::MAX_GAINS] = ["d0", "d1", "d2", "d3"];

fn check_gains(cfg: &ControllerConfig, n: usize) -> Result<(), LinearError> {
    if let Some((kp, kd, kphi_d)) = cfg.as_shorthand() {
        for (name, value) in [("kp", kp), ("kd", kd), ("kphi_d", kphi_d)] {
            if !value.is_finite() {
                return Err(LinearError::BadGain { name, value });
            }
        }
    }
    for (j, g) in cfg.gains.iter().enumerate() {
        for (name, value) in
            [(P_NAMES.get(j).copied().unwrap_or("p"), g.p), (D_NAMES.get(j).copied().unwrap_or("d"), g.d)]
        {
            if !value.is_finite() {
                return Err(LinearError::BadGain { name, value });
            }
        }
        if usize::from(g.index) >= n {
            return Err(LinearError::IndexOutOfRange { which: "measured", index: usize::from(g.index), n });
        }
    }
    if cfg.gains.is_empty() {
        return Err(LinearError::NoGains);
    }
    if !cfg.ki.is_finite() {
        return Err(LinearError::BadGain { name: "ki", value: cfg.ki });
    }
    if !(cfg.dt.is_finite() && cfg.dt > 0.0) {
        return Err(LinearError::BadDt(cfg.dt));
    }
    if cfg.delay > MAX_DELAY {
        return Err(LinearError::DelayTooLarge(cfg.delay));
    }
    Ok(())
}

impl Zoh {
    /// The closed-loop one-period map of the delayed law of `cfg` (`cfg.dt` must equal
    /// the discretization period): `u_i = -sum_j [p_j q_j,{i-r} + d_j (q_j,{i-r} -
    /// q_j,{i-r-1}) / dt] - ki x_I,i` over the measured coordinates `q_j = x[index_j]`.
    pub fn closed_loop(&self, cfg: &ControllerConfig) -> Result<ClosedLoopMap, LinearError> {
        let n = self.phi.nrows();
        check_gains(cfg, n)?;
        if cfg.dt != self.dt {
            return Err(LinearError::DtMismatch { config: cfg.dt, zoh: self.dt });
        }
        let r = cfg.delay as usize;
        let lay = AugmentedLayout::new(n, r, cfg.gains.len(), cfg.ki != 0.0);
        let dt = self.dt;
        // Index of the delayed sample q_j,{i-d} in the augmented state.
        let at = |j: usize, d: usize| {
            if d == 0 { cfg.gains.get(j).map_or(0, |g| usize::from(g.index)) } else { lay.start(j) + d - 1 }
        };
        // The law as a row: u_i = g . state_i.
        let mut g = DVector::<f64>::zeros(lay.dim);
        for (j, gain) in cfg.gains.iter().enumerate() {
            g[at(j, r)] += -(gain.p + gain.d / dt);
            g[at(j, r + 1)] += gain.d / dt;
        }
        if let Some(s) = lay.integral {
            g[at(0, r)] -= cfg.ki * dt;
            g[s] -= cfg.ki;
        }
        let mut m = DMatrix::<f64>::zeros(lay.dim, lay.dim);
        m.view_mut((0, 0), (n, n)).copy_from(&self.phi);
        m.view_mut((0, 0), (n, lay.dim)).ger(1.0, &self.gamma, &g, 1.0);
        // Shift registers: the new q_j,i (stored as q_j,{(i+1)-1}) is x_i[index_j].
        for (j, gain) in cfg.gains.iter().enumerate() {
            m[(lay.start(j), usize::from(gain.index))] = 1.0;
            for k in 1..=r {
                m[(lay.start(j) + k, lay.start(j) + k - 1)] = 1.0;
            }
        }
        if let Some(s) = lay.integral {
            m[(s, s)] = 1.0;
            m[(s, at(0, r))] += dt;
        }
        // What each gain puts into the map (its coefficients in the law row times |Gamma|),
        // to name the one responsible when the map is too large to be trusted.
        let gn = self.gamma.norm();
        let mut gains = Vec::new();
        match cfg.as_shorthand() {
            Some((kp, kd, kphi_d)) => {
                gains.push(("kp", kp, kp.abs() * gn));
                gains.push(("kd", kd, (kd / dt).abs() * 2.0 * gn));
                gains.push(("kphi_d", kphi_d, (kphi_d / dt).abs() * 2.0 * gn));
            }
            None => {
                for (j, gain) in cfg.gains.iter().enumerate() {
                    gains.push((P_NAMES.get(j).copied().unwrap_or("p"), gain.p, gain.p.abs() * gn));
                    gains.push((D_NAMES.get(j).copied().unwrap_or("d"), gain.d, (gain.d / dt).abs() * 2.0 * gn));
                }
            }
        }
        gains.push(("ki", cfg.ki, (cfg.ki.abs() * dt + cfg.ki.abs()) * gn));
        // The registers of the secondary coordinate, if it is measured (the structural
        // multiplier 1 shifts it and its stored copies together).
        let secondary_block =
            cfg.gains.iter().position(|g| usize::from(g.index) == self.secondary).map(|j| lay.start(j));
        // A P term (or the integral) on the secondary coordinate makes its shift visible to the law.
        let secondary_controlled = cfg
            .gains
            .iter()
            .enumerate()
            .any(|(j, g)| usize::from(g.index) == self.secondary && (g.p != 0.0 || (j == 0 && cfg.ki != 0.0)));
        Ok(ClosedLoopMap {
            matrix: m,
            layout: lay,
            dt,
            secondary: self.secondary,
            secondary_block,
            secondary_controlled,
            secondary_coupling: self.secondary_coupling,
            rate_scale: self.rate_scale,
            gains,
        })
    }
}

/// The closed-loop one-period map `s_{i+1} = M s_i` on the augmented state.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoopMap {
    pub matrix: DMatrix<f64>,
    pub layout: AugmentedLayout,
    pub dt: f64,
    secondary: usize,
    /// Start of the secondary coordinate's sample registers, if it is measured.
    secondary_block: Option<usize>,
    /// The law feeds the secondary coordinate itself back (P gain or integral).
    secondary_controlled: bool,
    secondary_coupling: Option<(usize, f64)>,
    /// The plant's rate scale (see [`RATE_ERROR_MAX`]).
    rate_scale: f64,
    /// (name, value, size of its entries in the map) of each gain.
    gains: Vec<(&'static str, f64, f64)>,
}

impl ClosedLoopMap {
    /// Every eigenvalue of the map, sorted by modulus, largest first.
    pub fn multipliers(&self) -> Result<Vec<Multiplier>, LinearError> {
        self.check_accuracy()?;
        to_multipliers(&self.matrix, self.dt)
    }

    /// Refuses a map whose multipliers or rates cannot be trusted in double precision: the
    /// eigenvalues of `M` carry an absolute error of about `n eps ||M||_F` (the backward
    /// error of the Schur decomposition), which must stay below [`MULTIPLIER_ERROR_MAX`]
    /// (or `|mu|` cannot be compared with 1: `kp = 1e200` gave `|mu| = 1.016`), and that error
    /// divided by `dt` (the error of `ln|mu| / dt`) below [`RATE_ERROR_MAX`] of the plant's
    /// rate scale (`dt = 1e-303 s` gave a rate of 4e291 1/s). The error names the gain whose
    /// entries dominate the map, or `dt`.
    pub fn check_accuracy(&self) -> Result<(), LinearError> {
        let n = self.matrix.nrows() as f64;
        let norm = frobenius(&self.matrix);
        let error = n * f64::EPSILON * norm;
        if !(error <= MULTIPLIER_ERROR_MAX) {
            let biggest = self.gains.iter().copied().max_by(|a, b| a.2.total_cmp(&b.2));
            let cause = match biggest {
                Some((name, value, size)) if !(size <= 0.5 * norm) || !size.is_finite() => {
                    format!("controller gain {name} = {value:e}")
                }
                _ => format!("sampling period dt = {:e} s (e^(A dt) is large)", self.dt),
            };
            return Err(LinearError::MultipliersInaccurate { cause, norm, error });
        }
        let rate_error = error / self.dt;
        if !(rate_error <= RATE_ERROR_MAX * self.rate_scale) {
            return Err(LinearError::RatesInaccurate { dt: self.dt, error: rate_error, scale: self.rate_scale });
        }
        Ok(())
    }

    /// The structural eigenvector of multiplier 1: a shift of the secondary coordinate and
    /// of every stored copy of it by the same constant (an eigenvector only if column
    /// `secondary` of A is zero).
    pub fn structural_eigenvector(&self) -> DVector<f64> {
        let mut v = DVector::zeros(self.layout.dim);
        v[self.secondary] = 1.0;
        if let Some(z) = self.secondary_block {
            for k in 0..=self.layout.delay {
                v[z + k] = 1.0;
            }
        }
        v
    }

    /// The map with the structural multiplier removed, of dimension `dim - 1`.
    ///
    /// Change of coordinates `w_k = z_{i-1-k} - x_i[secondary]` (all other coordinates
    /// kept): it sends the structural eigenvector to the unit vector of
    /// `x[secondary]`, so in the new coordinates that column is `e_secondary` and
    /// dropping its row and column removes exactly that eigenvalue. The column is checked
    /// to be `e_secondary` to rounding level.
    pub fn deflated(&self) -> Result<DMatrix<f64>, LinearError> {
        if let Some((row, value)) = self.secondary_coupling {
            return Err(LinearError::SecondaryCouples { index: self.secondary, row, value });
        }
        if self.secondary_controlled {
            return Err(LinearError::SecondaryControlled { index: self.secondary });
        }
        let lay = &self.layout;
        let s = self.secondary;
        // The secondary's registers (none when it is not measured: then T = I).
        let zs: Vec<usize> = self.secondary_block.map(|z| (z..=z + lay.delay).collect()).unwrap_or_default();
        // M' = T M T^{-1}, T = I - sum_k e_{z_k} e_s^T, T^{-1} = I + sum_k e_{z_k} e_s^T.
        // M T^{-1}: column s gains the sum of the z columns.
        let mut mt = self.matrix.clone();
        for &z in &zs {
            let zc = self.matrix.column(z).clone_owned();
            let mut col_s = mt.column_mut(s);
            col_s += zc;
        }
        // T (M T^{-1}): each z row loses row s.
        let row_s = mt.row(s).clone_owned();
        for &z in &zs {
            let mut row = mt.row_mut(z);
            row -= &row_s;
        }
        let scale = mt.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let residual =
            mt.column(s).iter().enumerate().filter(|(i, _)| *i != s).fold(0.0f64, |m, (_, v)| m.max(v.abs()));
        if residual > 1e-10 * scale || (mt[(s, s)] - 1.0).abs() > 1e-10 * scale {
            return Err(LinearError::Deflation { col: s, residual });
        }
        Ok(mt.remove_row(s).remove_column(s))
    }

    /// The multipliers without the structural one, sorted by modulus, largest first: the
    /// list that decides stability.
    pub fn dominant_multipliers(&self) -> Result<Vec<Multiplier>, LinearError> {
        self.check_accuracy()?;
        to_multipliers(&self.deflated()?, self.dt)
    }
}

fn to_multipliers(m: &DMatrix<f64>, dt: f64) -> Result<Vec<Multiplier>, LinearError> {
    let ev = eigenvalues(m)?;
    let mut out: Vec<Multiplier> = ev.iter().map(|c| Multiplier::new(c.re, c.im, dt)).collect();
    out.sort_by(|a, b| b.abs.total_cmp(&a.abs).then(b.im.total_cmp(&a.im)));
    Ok(out)
}

/// Every closed-loop multiplier of the loop `cfg` around the plant `(a, b)`, sorted by
/// modulus, largest first (includes the structural multiplier 1).
pub fn multipliers<const N: usize>(
    a: &SMatrix<f64, N, N>,
    b: &SVector<f64, N>,
    primary: usize,
    secondary: usize,
    cfg: &ControllerConfig,
) -> Result<Vec<Multiplier>, LinearError> {
    LinearPlant::new(a, b, primary, secondary)?.closed_loop(cfg)?.multipliers()
}

/// The closed-loop multipliers without the structural multiplier 1 of the secondary-angle
/// shift (removed by exact deflation), sorted by modulus, largest first. Errors with
/// [`LinearError::SecondaryCouples`] if A depends on the secondary coordinate.
pub fn dominant_multipliers<const N: usize>(
    a: &SMatrix<f64, N, N>,
    b: &SVector<f64, N>,
    primary: usize,
    secondary: usize,
    cfg: &ControllerConfig,
) -> Result<Vec<Multiplier>, LinearError> {
    LinearPlant::new(a, b, primary, secondary)?.closed_loop(cfg)?.dominant_multipliers()
}
