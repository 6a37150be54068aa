//! Taylor expansion of the sampled-data closed loop's one-period map at the upright
//! equilibrium (the input of an equation-driven SSM).
//!
//! Without quantization and saturation the loop over one sampling period is a smooth map on
//! the augmented state (plant state plus the delayed samples the controller reads). Its only
//! nonlinear piece is the plant's flow over one period under the held input,
//! `phi_dt(x, u)`; the law and the shift registers are linear. The flow's Taylor expansion
//! ([`flow_expansion`]) comes from integrating the plant's own right-hand side in truncated
//! multivariate Taylor arithmetic ([`Tps`]): the expansion point is an equilibrium, so the
//! degree-`k` coefficients obey `c_k' = A c_k + (products of lower degrees)`, a cascade
//! whose only stiffness is the linear part `A` (the Furuta pendulum's fast mode near
//! -1.5e4 1/s).
//!
//! # Integrator
//! Classical RK4 on a graded mesh: the input jump at the period start excites the fast
//! mode, whose transient `e^{lambda t}` forces every higher-degree coefficient, the
//! degree-`K` ones through products decaying like `e^{K lambda t}` (K times stiffer). The
//! step starts at `h K |lambda| = 0.05` (`K` the order, at least [`MESH_ORDER`]: the
//! coefficients of a degree do not depend on the order the series is truncated at) and grows like `e^{|lambda| t / 5}` (the transient's
//! local error `e^{lambda t} (h K lambda)^5` stays level) up to `h |lambda| = 0.5` (RK4 is
//! stable up to 2.78, but the slaved fast components of the high degrees need the smaller
//! step: 1.5 left large relative errors in degree 7; the stability bound holds for every degree
//! since each obeys `c_k' = A c_k + ...`), with `lambda` the largest-modulus eigenvalue of the
//! linearization. [`FlowOptions::refine`] splits every step; the truncation error is
//! measured by comparing `refine` and `2 refine` (RK4: a factor ~16).
//!
//! # The secondary coordinate
//! The arm angle of the Furuta pendulum (the cart position) does not enter the right-hand
//! side: it is dropped from the variables (its output is its increment over the period), and
//! this is checked on the jets (the right-hand side's jet must not change when the secondary
//! coordinate is moved). The period map is then written in the coordinates of
//! [`ClosedLoopMap::deflated`](crate::linear::ClosedLoopMap::deflated) (the stored copies of
//! the secondary angle relative to its current value), which removes the structural
//! multiplier 1 exactly: [`period_map`].

pub mod tps;

use nalgebra::DMatrix;
use shared::ControllerConfig;

use crate::closed_loop::AnyPlant;
use crate::linear::{LinearError, eigenvalues};
use crate::ode::{Integrator, Method, OdeError};
use crate::plant::{Plant, Scalar, linearize};

pub use tps::{TPS_CAPACITY, Tps, TpsTable, monomial_count};

/// The time mesh and the series product's kernel, public only for the crate's tests
/// (`tests/taylor/`): not part of the API.
#[doc(hidden)]
pub mod internals {
    pub use super::mesh;
    pub use super::tps::{SCRATCH, mul_flat};
}

/// Step size at the period start, times the linearization's spectral radius and the order
/// (at least [`MESH_ORDER`]).
pub const FIRST_STEP: f64 = 0.05;
/// Every order up to this one is integrated on this order's mesh, so an expansion to a
/// lower order is the truncation of this order's, bit for bit ([`FlowExpansion::truncated`]):
/// the report's orders 5, 7 and 9 share one expansion.
pub const MESH_ORDER: u32 = 9;
/// Largest step, times the linearization's spectral radius (RK4 is stable below 2.78;
/// accuracy of the slaved fast components asks for less).
pub const MAX_STEP: f64 = 0.5;

/// Why an expansion could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaylorError {
    #[error("sampling period dt = {0} s must be finite and > 0")]
    BadDt(f64),
    #[error(
        "order {order} in {nvar} variables needs more than {TPS_CAPACITY} Taylor coefficients (or order > {max}): lower the order",
        max = tps::TPS_MAX_ORDER
    )]
    Order { order: u32, nvar: usize },
    #[error("refine must be at least 1")]
    Refine,
    #[error(
        "sampling period dt = {dt} s: the expansion over one period needs more than {limit} RK4 steps (the linearization's spectral radius is {rate:.4e} 1/s, so a step is at most {max_h:.3e} s); refused rather than run without bound: use a shorter sampling period"
    )]
    TooManySteps { dt: f64, rate: f64, max_h: f64, limit: usize },
    #[error("the origin is not an equilibrium: component {component} of the right-hand side is {value:e} there")]
    NotEquilibrium { component: usize, value: f64 },
    #[error(
        "the secondary coordinate {index} enters the right-hand side (component {component} of its jet changes by {change:e} when it moves): it cannot be dropped"
    )]
    SecondaryEnters { index: usize, component: usize, change: f64 },
    #[error("Taylor coefficient of degree {degree} of component {component} is not finite")]
    NonFinite { component: usize, degree: u32 },
    #[error("integral action (ki = {0}) is not supported by the period-map expansion")]
    Integral(f64),
    #[error(transparent)]
    Linear(#[from] LinearError),
    #[error("reference flow: {0}")]
    Ode(#[from] OdeError),
    #[error("state has {got} entries, the period map has {want}")]
    Dimension { got: usize, want: usize },
}

/// Integration options of [`flow_expansion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowOptions {
    /// Equal sub-steps per step of the base mesh (see the module docs); >= 1.
    pub refine: u32,
}

impl Default for FlowOptions {
    fn default() -> Self {
        // Refine 2 is converged: refine 2 and 4 differ far less than refine 1 and 4 at every
        // degree (`step_halving_converges_at_fourth_order` checks and prints it).
        FlowOptions { refine: 2 }
    }
}

/// Taylor expansion of the plant flow `phi_dt(x, u)` over one period at the equilibrium.
#[derive(Clone, Debug)]
pub struct FlowExpansion {
    pub dt: f64,
    pub order: u32,
    /// Number of plant states N.
    pub n_plant: usize,
    /// The plant state left out of the variables (a cyclic coordinate: its output is its
    /// increment), if any.
    pub secondary: Option<usize>,
    /// Plant state of each variable but the last, which is the held input `u`.
    pub state_of_var: Vec<usize>,
    pub table: &'static TpsTable,
    /// Coefficients (table order) of each plant state after `dt`, `outputs[i]`.
    pub outputs: Vec<Vec<f64>>,
    /// RK4 steps taken.
    pub steps: usize,
    /// Spectral radius of the linearization, 1/s (sets the mesh).
    pub stiff_rate: f64,
}

impl FlowExpansion {
    /// Number of variables (plant states but the dropped secondary, then `u`).
    pub fn nvar(&self) -> usize {
        self.table.nvar()
    }

    /// The expansion to `order` (at most its own): the coefficients of degree <= `order`,
    /// a prefix in the graded order. Bit for bit [`flow_expansion`] to `order` when both
    /// orders are at most [`MESH_ORDER`] (the same mesh, and a truncated product's
    /// coefficients are the same sums in the same order at any truncation).
    pub fn truncated(&self, order: u32) -> Result<FlowExpansion, TaylorError> {
        let nvar = self.nvar();
        if order > self.order {
            return Err(TaylorError::Order { order, nvar });
        }
        let table = TpsTable::get(nvar, order).ok_or(TaylorError::Order { order, nvar })?;
        let n = table.len();
        Ok(FlowExpansion {
            order,
            table,
            outputs: self.outputs.iter().map(|c| c[..n].to_vec()).collect(),
            ..self.clone()
        })
    }

    /// Evaluates the expansion at the variables `v` (states but the dropped secondary, then `u`).
    pub fn eval(&self, v: &[f64]) -> Vec<f64> {
        let mono: Vec<f64> =
            self.table.exponents().iter().map(|e| e.iter().zip(v).map(|(&k, x)| x.powi(k as i32)).product()).collect();
        self.outputs.iter().map(|c| c.iter().zip(&mono).map(|(a, b)| a * b).sum()).collect()
    }
}

/// Most RK4 steps (after refinement) of one expansion: the work (and the mesh's memory) is
/// bounded before it starts; the report's periods take a few thousand.
pub const MAX_FLOW_STEPS: usize = 50_000;

/// The base mesh refined `refine` times: step sizes summing to `dt`; `Err` when it would
/// take more than [`MAX_FLOW_STEPS`] steps (checked as it is built).
#[doc(hidden)]
pub fn mesh(dt: f64, rate: f64, order: u32, refine: u32) -> Result<Vec<f64>, TaylorError> {
    let mut steps = Vec::new();
    let rate = rate.max(1e-300);
    let mut t = 0.0;
    loop {
        let rem = dt - t;
        if !(rem > 0.0) {
            break;
        }
        let first = FIRST_STEP / (rate * order.max(1) as f64);
        let mut h = (first * (rate * t / 5.0).min(700.0).exp()).min(MAX_STEP / rate);
        let last = 1.25 * h >= rem;
        if last {
            h = rem;
        }
        if steps.len().saturating_add(refine as usize) > MAX_FLOW_STEPS {
            return Err(TaylorError::TooManySteps { dt, rate, max_h: MAX_STEP / rate, limit: MAX_FLOW_STEPS });
        }
        steps.extend(std::iter::repeat_n(h / refine as f64, refine as usize));
        if last {
            break;
        }
        t += h;
    }
    Ok(steps)
}

fn check_dt(dt: f64) -> Result<(), TaylorError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(TaylorError::BadDt(dt));
    }
    Ok(())
}

/// Taylor expansion to `order` of the flow of `plant` over `dt` under a held input, at the
/// upright equilibrium (`x = 0`, `u = 0`), in the variables (plant states without
/// `P::SECONDARY`, then `u`); the secondary coordinate must not enter the right-hand side.
pub fn flow_expansion<P: Plant<N>, const N: usize>(
    plant: &P,
    dt: f64,
    order: u32,
    opts: &FlowOptions,
) -> Result<FlowExpansion, TaylorError> {
    flow_expansion_dropping(plant, dt, order, opts, Some(P::SECONDARY))
}

/// The variables' table and the plant state of each variable but `u`, `drop` left out.
fn flow_variables<const N: usize>(
    order: u32,
    drop: Option<usize>,
) -> Result<(&'static TpsTable, Vec<usize>), TaylorError> {
    let state_of_var: Vec<usize> = (0..N).filter(|&i| Some(i) != drop).collect();
    let nvar = state_of_var.len() + 1;
    let table = TpsTable::get(nvar, order).ok_or(TaylorError::Order { order, nvar })?;
    Ok((table, state_of_var))
}

/// The plant's state as jets: the variables at 0, the dropped state the constant 0.
fn jets<const N: usize>(table: &'static TpsTable, state_of_var: &[usize]) -> [Tps; N] {
    let mut x: [Tps; N] = core::array::from_fn(|_| Tps::constant(table, 0.0));
    for (k, &i) in state_of_var.iter().enumerate() {
        if let Some(slot) = x.get_mut(i) {
            *slot = Tps::var(table, k, 0.0);
        }
    }
    x
}

/// `Err(SecondaryEnters)` when moving state `s` changes the right-hand side's jet (in the
/// other states and `u`, to `order`): then it cannot be dropped from the variables.
fn check_cyclic<P: Plant<N>, const N: usize>(plant: &P, s: usize, order: u32) -> Result<(), TaylorError> {
    let (table, state_of_var) = flow_variables::<N>(order, Some(s))?;
    let x = jets::<N>(table, &state_of_var);
    let u = Tps::var(table, table.nvar() - 1, 0.0);
    let f0 = plant.rhs(&x, u);
    for shift in [1.2345, -0.731] {
        let mut xs = x;
        if let Some(slot) = xs.get_mut(s) {
            *slot = Tps::constant(table, shift);
        }
        let f1 = plant.rhs(&xs, u);
        for (component, (a, b)) in f0.iter().zip(&f1).enumerate() {
            let scale = a.coefficients().iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let change = a.coefficients().iter().zip(b.coefficients()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            if !(change <= 1e-13 * scale) {
                return Err(TaylorError::SecondaryEnters { index: s, component, change });
            }
        }
    }
    Ok(())
}

/// [`flow_expansion`] with `drop` (a cyclic coordinate, checked on the jets) left out of the
/// variables, or every plant state a variable (`None`).
pub fn flow_expansion_dropping<P: Plant<N>, const N: usize>(
    plant: &P,
    dt: f64,
    order: u32,
    opts: &FlowOptions,
    drop: Option<usize>,
) -> Result<FlowExpansion, TaylorError> {
    check_dt(dt)?;
    if opts.refine == 0 {
        return Err(TaylorError::Refine);
    }
    let (table, state_of_var) = flow_variables::<N>(order, drop)?;
    let mut x = jets::<N>(table, &state_of_var);
    let u = Tps::var(table, table.nvar() - 1, 0.0);
    // Equilibrium and independence of the dropped coordinate, on the jets.
    let f0 = plant.rhs(&x, u);
    for (component, f) in f0.iter().enumerate() {
        let scale = 1.0 + f.degree_norm(1);
        if !(f.re().abs() <= 1e-12 * scale) {
            return Err(TaylorError::NotEquilibrium { component, value: f.re() });
        }
    }
    if let Some(s) = drop {
        check_cyclic(plant, s, order)?;
    }
    let (a, _) = linearize(plant);
    let am = DMatrix::from_fn(N, N, |i, j| a[(i, j)]);
    let stiff_rate = eigenvalues(&am)?.iter().map(|z| z.norm()).fold(0.0, f64::max);
    let steps = mesh(dt, stiff_rate, order.max(MESH_ORDER), opts.refine)?;
    // Classical RK4, the stages and the update in place (a `Tps` is 5.7 kB: no copies of
    // the operands), with the roundings of `x + k * (h / 2)` and
    // `x + (k1 + (k2 + k3) * 2 + k4) * (h / 6)`.
    let mut xs = x;
    for &h in &steps {
        let k1 = plant.rhs(&x, u);
        for ((s, xi), k) in xs.iter_mut().zip(&x).zip(&k1) {
            s.assign_axpy(xi, k, 0.5 * h);
        }
        let k2 = plant.rhs(&xs, u);
        for ((s, xi), k) in xs.iter_mut().zip(&x).zip(&k2) {
            s.assign_axpy(xi, k, 0.5 * h);
        }
        let k3 = plant.rhs(&xs, u);
        for ((s, xi), k) in xs.iter_mut().zip(&x).zip(&k3) {
            s.assign_axpy(xi, k, h);
        }
        let k4 = plant.rhs(&xs, u);
        for (i, xi) in x.iter_mut().enumerate() {
            xi.rk4_update([&k1[i], &k2[i], &k3[i], &k4[i]], h / 6.0);
        }
    }
    let outputs: Vec<Vec<f64>> = x.iter().map(|j| j.coefficients().to_vec()).collect();
    for (component, c) in outputs.iter().enumerate() {
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(TaylorError::NonFinite { component, degree: table.exponents()[i].iter().sum() });
        }
    }
    Ok(FlowExpansion {
        dt,
        order,
        n_plant: N,
        secondary: drop,
        state_of_var,
        table,
        outputs,
        steps: steps.len(),
        stiff_rate,
    })
}

/// The closed loop's one-period map, `F(s) = M s + G(P s)`: `M` the linear part, `P` the
/// projection onto the flow's variables (plant states but a dropped secondary, then the held
/// input `u` of the law), `G` the flow expansion's terms of degree 2..=order placed in the
/// rows they feed.
///
/// Coordinates: the plant states (without the secondary when it is dropped), then for each
/// measured coordinate `q_j` of the gain vector, in gain order, its samples `q_j,{i-1} ..
/// q_j,{i-1-r}`. When the secondary coordinate is cyclic (it does not enter the right-hand
/// side) and the law reads only its differences (no P gain on it), the map is deflated as
/// [`ClosedLoopMap::deflated`](crate::linear::ClosedLoopMap::deflated): the secondary is
/// dropped and its stored samples are kept relative to its current value, `w_k = z_{i-1-k} -
/// x_i[secondary]`, which removes the structural multiplier 1 exactly. For the Furuta's
/// shorthand law that is `x, y_{i-1} .. y_{i-1-r}, w_0 .. w_r`.
#[derive(Clone, Debug)]
pub struct PeriodMap {
    pub dt: f64,
    pub order: u32,
    /// Coordinate names.
    pub names: Vec<String>,
    /// `dim x dim`.
    pub linear: DMatrix<f64>,
    /// `m x dim`: the flow's variables as linear functions of the state.
    pub proj: DMatrix<f64>,
    /// Exponents (in the `m` flow variables) of the nonlinear monomials, degrees 2..=order.
    pub exps: Vec<Vec<u32>>,
    /// `coef[row][k]`: coefficient of monomial `exps[k]` in component `row`.
    pub coef: Vec<Vec<f64>>,
    /// Index of the primary angle in the state.
    pub primary: usize,
    /// The plant flow's expansion it was built from.
    pub flow: FlowExpansion,
    cfg: ControllerConfig,
}

/// Index bookkeeping of the period map's coordinates.
struct Layout {
    /// The dropped (deflated) secondary coordinate, if any.
    dropped: Option<usize>,
    delay: usize,
    /// Plant state of each measured coordinate, in gain order.
    measured: Vec<usize>,
    /// Index of the first sample register.
    reg_start: usize,
    dim: usize,
}

impl Layout {
    fn new(n_plant: usize, dropped: Option<usize>, delay: usize, cfg: &ControllerConfig) -> Self {
        let reg_start = n_plant - usize::from(dropped.is_some());
        let measured: Vec<usize> = cfg.gains.iter().map(|g| usize::from(g.index)).collect();
        let dim = reg_start + measured.len() * (delay + 1);
        Self { dropped, delay, measured, reg_start, dim }
    }
    /// Index of plant state `i`, `None` for the dropped one.
    fn plant(&self, i: usize) -> Option<usize> {
        match self.dropped {
            Some(s) if i == s => None,
            Some(s) if i > s => Some(i - 1),
            _ => Some(i),
        }
    }
    /// Index of the register of measured coordinate `j`'s sample `q_j,{i-1-k}`.
    fn reg(&self, j: usize, k: usize) -> usize {
        self.reg_start + j * (self.delay + 1) + k
    }
    /// Index of `q_j,{i-d}` (relative to the current secondary when that is dropped: `None`
    /// for `d = 0`, which is zero).
    fn sample(&self, j: usize, d: usize) -> Option<usize> {
        if d == 0 { self.measured.get(j).and_then(|&i| self.plant(i)) } else { Some(self.reg(j, d - 1)) }
    }
    /// The law `u = g . s`.
    fn law(&self, cfg: &ControllerConfig) -> Vec<f64> {
        let r = self.delay;
        let dt = cfg.dt;
        let mut g = vec![0.0; self.dim];
        for (j, gain) in cfg.gains.iter().enumerate() {
            if let Some(k) = self.sample(j, r) {
                g[k] += -(gain.p + gain.d / dt);
            }
            if let Some(k) = self.sample(j, r + 1) {
                g[k] += gain.d / dt;
            }
        }
        g
    }
    /// Name of register `reg(j, k)`: `y[i-1]` for the first measured coordinate, `z[i-1]-x2`
    /// for a dropped secondary, `q<state>[i-1]` for others.
    fn reg_name(&self, j: usize, k: usize) -> String {
        let i = self.measured.get(j).copied().unwrap_or(0);
        match self.dropped {
            Some(s) if i == s => format!("z[i-{}]-x{s}", k + 1),
            _ if j == 0 => format!("y[i-{}]", k + 1),
            _ => format!("q{i}[i-{}]", k + 1),
        }
    }
}

/// The gain vector's checks for the expansion: finite gains on existing states, no
/// integral action, a bounded delay.
fn check_cfg<const N: usize>(cfg: &ControllerConfig) -> Result<(), TaylorError> {
    if cfg.ki != 0.0 {
        return Err(TaylorError::Integral(cfg.ki));
    }
    if cfg.gains.is_empty() {
        return Err(TaylorError::Linear(LinearError::NoGains));
    }
    if let Some((kp, kd, kphi_d)) = cfg.as_shorthand() {
        for (name, value) in [("kp", kp), ("kd", kd), ("kphi_d", kphi_d)] {
            if !value.is_finite() {
                return Err(TaylorError::Linear(LinearError::BadGain { name, value }));
            }
        }
    }
    const P_NAMES: [&str; shared::MAX_GAINS] = ["p0", "p1", "p2", "p3"];
    const D_NAMES: [&str; shared::MAX_GAINS] = ["d0", "d1", "d2", "d3"];
    for (j, g) in cfg.gains.iter().enumerate() {
        for (name, value) in
            [(P_NAMES.get(j).copied().unwrap_or("p"), g.p), (D_NAMES.get(j).copied().unwrap_or("d"), g.d)]
        {
            if !value.is_finite() {
                return Err(TaylorError::Linear(LinearError::BadGain { name, value }));
            }
        }
        if usize::from(g.index) >= N {
            return Err(TaylorError::Linear(LinearError::IndexOutOfRange {
                which: "measured",
                index: usize::from(g.index),
                n: N,
            }));
        }
    }
    if cfg.delay > crate::linear::MAX_DELAY {
        return Err(TaylorError::Linear(LinearError::DelayTooLarge(cfg.delay)));
    }
    Ok(())
}

/// Whether the period map of the loop `cfg` around `plant` is deflated (see [`PeriodMap`]):
/// the secondary coordinate is cyclic to `order` and has no P gain.
fn deflates<P: Plant<N>, const N: usize>(plant: &P, cfg: &ControllerConfig, order: u32) -> Result<bool, TaylorError> {
    let s = P::SECONDARY;
    if cfg.gains.iter().any(|g| usize::from(g.index) == s && g.p != 0.0) {
        return Ok(false);
    }
    match check_cyclic(plant, s, order) {
        Ok(()) => Ok(true),
        Err(TaylorError::SecondaryEnters { .. }) => Ok(false),
        Err(e) => Err(e),
    }
}

/// [`period_map`] of a plant built from a scene: not generic, so the expansion's code is
/// compiled here, at this crate's optimization level, however many crates call it.
pub fn period_map_any(
    plant: &AnyPlant,
    cfg: &ControllerConfig,
    order: u32,
    opts: &FlowOptions,
) -> Result<PeriodMap, TaylorError> {
    crate::with_plant!(plant, p => period_map(p, cfg, order, opts))
}

/// Taylor expansion to `order` of the one-period map of the loop `cfg` around `plant`
/// (unquantized, unsaturated; `cfg.ki` must be 0), deflated when the secondary coordinate
/// allows it ([`PeriodMap`]).
pub fn period_map<P: Plant<N>, const N: usize>(
    plant: &P,
    cfg: &ControllerConfig,
    order: u32,
    opts: &FlowOptions,
) -> Result<PeriodMap, TaylorError> {
    check_cfg::<N>(cfg)?;
    check_dt(cfg.dt)?;
    let dropped = deflates(plant, cfg, order)?.then_some(P::SECONDARY);
    let flow = flow_expansion_dropping(plant, cfg.dt, order, opts, dropped)?;
    let lay = Layout::new(N, dropped, cfg.delay as usize, cfg);
    let dim = lay.dim;
    let m = flow.nvar();
    let g = lay.law(cfg);
    let mut proj = DMatrix::<f64>::zeros(m, dim);
    for (k, &i) in flow.state_of_var.iter().enumerate() {
        if let Some(c) = lay.plant(i) {
            proj[(k, c)] = 1.0;
        }
    }
    for (j, gj) in g.iter().enumerate() {
        proj[(m - 1, j)] = *gj;
    }
    let t = flow.table;
    let lin_range = t.degree_range(1);
    let nl_range = t.degree_range(2).start..t.len();
    let exps: Vec<Vec<u32>> = t.exponents()[nl_range.clone()].to_vec();
    // Linear part of each plant output as a row over the state: sum_k c_k P_k.
    let lin_row = |i: usize| -> Vec<f64> {
        let c = &flow.outputs[i][lin_range.clone()];
        (0..dim).map(|j| (0..m).map(|k| c[k] * proj[(k, j)]).sum()).collect()
    };
    let mut linear = DMatrix::<f64>::zeros(dim, dim);
    let mut coef = vec![vec![0.0; exps.len()]; dim];
    for &i in &flow.state_of_var {
        let Some(row) = lay.plant(i) else { continue };
        for (j, v) in lin_row(i).into_iter().enumerate() {
            linear[(row, j)] = v;
        }
        coef[row].copy_from_slice(&flow.outputs[i][nl_range.clone()]);
    }
    let dphi = dropped.map(lin_row);
    for (j, &i) in lay.measured.iter().enumerate() {
        match (lay.plant(i), dropped, &dphi) {
            // Shift registers: the new q_j,{i+1-1} is the current state.
            (Some(c), _, _) => {
                linear[(lay.reg(j, 0), c)] = 1.0;
                for k in 1..=lay.delay {
                    linear[(lay.reg(j, k), lay.reg(j, k - 1))] = 1.0;
                }
            }
            // The dropped secondary's registers: w'_0 = -dphi, w'_k = w_{k-1} - dphi.
            (None, Some(s), Some(dphi)) => {
                for k in 0..=lay.delay {
                    let row = lay.reg(j, k);
                    for (c, v) in dphi.iter().enumerate() {
                        linear[(row, c)] = -v;
                    }
                    if k > 0 {
                        linear[(row, row - 1)] += 1.0;
                    }
                    for (c, d) in coef[row].iter_mut().zip(&flow.outputs[s][nl_range.clone()]) {
                        *c = -d;
                    }
                }
            }
            _ => {}
        }
    }
    let mut names: Vec<String> = (0..N).filter(|&i| Some(i) != dropped).map(|i| format!("x{i}")).collect();
    for j in 0..lay.measured.len() {
        names.extend((0..=lay.delay).map(|k| lay.reg_name(j, k)));
    }
    let primary = lay.plant(P::PRIMARY).ok_or(TaylorError::Dimension { got: 0, want: N })?;
    Ok(PeriodMap { dt: cfg.dt, order, names, linear, proj, exps, coef, primary, flow, cfg: *cfg })
}

impl PeriodMap {
    /// The map to `order` (at most its own): the nonlinear monomials of degree <= `order`
    /// (a prefix of [`PeriodMap::exps`]) and the truncated flow; bit for bit [`period_map`]
    /// to `order` when both orders are at most [`MESH_ORDER`].
    pub fn truncated(&self, order: u32) -> Result<PeriodMap, TaylorError> {
        let flow = self.flow.truncated(order)?;
        let keep = flow.table.len() - flow.table.degree_range(2).start;
        Ok(PeriodMap {
            order,
            exps: self.exps[..keep].to_vec(),
            coef: self.coef.iter().map(|row| row[..keep].to_vec()).collect(),
            flow,
            ..self.clone()
        })
    }

    /// Dimension of the state.
    pub fn dim(&self) -> usize {
        self.linear.nrows()
    }

    /// `F(s)`, the polynomial map at a state.
    pub fn eval(&self, s: &[f64]) -> Result<Vec<f64>, TaylorError> {
        let dim = self.dim();
        if s.len() != dim {
            return Err(TaylorError::Dimension { got: s.len(), want: dim });
        }
        let v: Vec<f64> = (0..self.proj.nrows()).map(|k| (0..dim).map(|j| self.proj[(k, j)] * s[j]).sum()).collect();
        let mono: Vec<f64> =
            self.exps.iter().map(|e| e.iter().zip(&v).map(|(&k, x)| x.powi(k as i32)).product()).collect();
        Ok((0..dim)
            .map(|r| {
                let lin: f64 = (0..dim).map(|j| self.linear[(r, j)] * s[j]).sum();
                lin + self.coef[r].iter().zip(&mono).map(|(a, b)| a * b).sum::<f64>()
            })
            .collect())
    }

    /// [`PeriodMap::exact`] on a plant built from a scene: not generic, so the integration's
    /// code is compiled here.
    pub fn exact_any(&self, plant: &AnyPlant, s: &[f64], method: Method) -> Result<Vec<f64>, TaylorError> {
        crate::with_plant!(plant, p => self.exact(p, s, method))
    }

    /// The exact one-period map (no truncation) at a state, by integrating the plant with
    /// `method` in `f64`: the reference the expansion is checked against.
    pub fn exact<P: Plant<N>, const N: usize>(
        &self,
        plant: &P,
        s: &[f64],
        method: Method,
    ) -> Result<Vec<f64>, TaylorError> {
        let dim = self.dim();
        if s.len() != dim {
            return Err(TaylorError::Dimension { got: s.len(), want: dim });
        }
        let dropped = self.flow.secondary;
        let lay = Layout::new(N, dropped, self.cfg.delay as usize, &self.cfg);
        let g = lay.law(&self.cfg);
        let u: f64 = g.iter().zip(s).map(|(a, b)| a * b).sum();
        let mut x = [0.0; N];
        for (i, xi) in x.iter_mut().enumerate() {
            if let Some(c) = lay.plant(i) {
                *xi = s[c];
            }
        }
        let mut integ = Integrator::<N>::new(method)?;
        integ.advance(plant, &mut x, u, self.dt)?;
        let mut out = vec![0.0; dim];
        for (i, xi) in x.iter().enumerate() {
            if let Some(c) = lay.plant(i) {
                out[c] = *xi;
            }
        }
        for (j, &i) in lay.measured.iter().enumerate() {
            match lay.plant(i) {
                Some(c) => out[lay.reg(j, 0)] = s[c],
                // The dropped secondary (cyclic, started at 0): its increment is x[i].
                None => out[lay.reg(j, 0)] = -x[i],
            }
            for k in 1..=lay.delay {
                let prev = s[lay.reg(j, k - 1)];
                out[lay.reg(j, k)] = if lay.plant(i).is_some() { prev } else { prev - x[i] };
            }
        }
        Ok(out)
    }
}
