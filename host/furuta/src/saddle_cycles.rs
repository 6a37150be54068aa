//! The saddle cycles of the full (unquantized) system, computed on the exact period map,
//! against the fixed points of the equation-driven and data-driven amplitude equations
//! (docs/decisions/0001).
//!
//! A limit cycle of mode `j` of the amplitude equations (`rho_j = rho*`, the other amplitude
//! 0) is, in the sampled loop, an invariant circle of the one-period map `F` on which `F`
//! turns by the mode's phase per period. It is computed as a Fourier-collocated
//! parametrization `K(theta)` (`n` points, `n` odd) with rotation `omega`:
//! `F(K(theta_i)) = K(theta_i + omega)`, the shift by trigonometric interpolation, plus the
//! phase condition `sum_i K_i[theta] sin(theta_i) = 0`; Newton's method on the `n D + 1`
//! unknowns with a central-difference Jacobian of the exact map (RODAS4, [`crate::convergence::EXACT_METHOD`]),
//! no Taylor truncation anywhere. Normally hyperbolic (saddle) circles are regular zeros of
//! this system, so they converge like stable ones. The start is the equation-driven SSM's
//! circle `W(rho* e^{i theta})`; `dt` continuation reuses the previous circle.
//!
//! Coordinate-free measures of a circle: the first-harmonic amplitude of theta (rad) and
//! the rotation per period. The equation-driven model's `rho*` is theta's first harmonic
//! on its circle `W(rho* e^{i theta})` at every order (`ssm::map_ssm::Amplitude::Observable`);
//! the first harmonic is still computed and reported as a check.

use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};
use sim::scene::Scene;
use ssm::map_ssm::{Amplitude, MapSsm, MapSsmOptions, map_ssm};
use ssm::normal_form::PolarNormalForm;
use ssm::portrait::{FixedPoint, PointKind, PortraitOptions, fixed_points};

use crate::Error;
use crate::bifurcations::RHO_MAX;
use crate::convergence::ExactMap;
use crate::equation_ssm::{RESONANCE_TOL, polynomial_map};

type C = Complex<f64>;

/// Options of [`invariant_circle`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CircleOptions {
    /// Collocation points (odd, 5..=201).
    pub n: usize,
    /// Newton stops when the collocation residual (inf norm, state units) is below this.
    pub tol: f64,
    pub max_steps: usize,
    /// Central-difference step of the Jacobian, relative to `max(1, |s_k|)`.
    pub fd_step: f64,
}

impl Default for CircleOptions {
    fn default() -> Self {
        CircleOptions { n: 33, tol: 1e-10, max_steps: 20, fd_step: 1e-6 }
    }
}

/// An invariant circle of the exact period map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InvariantCircle {
    pub dt_ms: f64,
    /// Rotation per period (rad, in `(-pi, pi]` as found by Newton from the start).
    pub omega: f64,
    /// `omega / (2 pi dt)` (Hz).
    pub freq_hz: f64,
    /// `K(theta_i)`, `n` states.
    pub points: Vec<Vec<f64>>,
    /// First-harmonic amplitude of the primary angle along the circle (rad).
    pub theta_amplitude: f64,
    /// `max |theta|` at the collocation points (rad).
    pub theta_max: f64,
    /// `max_i ||F(K_i) - K(theta_i + omega)||_inf` at the collocation points.
    pub residual: f64,
    /// The same at the midpoints between collocation points (`K` by trigonometric
    /// interpolation): the discretization error.
    pub residual_midpoints: f64,
    pub newton_steps: usize,
}

/// Shift matrix `S(omega)` of trigonometric interpolation on `n` (odd) points and its
/// derivative in `omega`: `K(theta_i + omega) = sum_j S_ij K_j`.
fn shift_matrix(n: usize, omega: f64, offset: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let h = (n as i64 - 1) / 2;
    let th = |i: usize| std::f64::consts::TAU * i as f64 / n as f64;
    let mut s = DMatrix::zeros(n, n);
    let mut ds = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..n {
            let x = th(i) + offset + omega - th(j);
            let (mut a, mut b) = (1.0, 0.0);
            for k in 1..=h {
                let kf = k as f64;
                a += 2.0 * (kf * x).cos();
                b -= 2.0 * kf * (kf * x).sin();
            }
            s[(i, j)] = a / n as f64;
            ds[(i, j)] = b / n as f64;
        }
    }
    (s, ds)
}

fn first_harmonic(values: &[f64]) -> f64 {
    let n = values.len() as f64;
    let c: C = values.iter().enumerate().map(|(i, v)| C::from_polar(*v, -std::f64::consts::TAU * i as f64 / n)).sum();
    2.0 * c.norm() / n
}

/// The invariant circle of `ex` near `guess` (`opts.n` states at `theta_i = 2 pi i / n`)
/// with rotation near `omega0` (rad per period).
pub fn invariant_circle(
    ex: &ExactMap,
    guess: &[Vec<f64>],
    omega0: f64,
    opts: &CircleOptions,
) -> Result<InvariantCircle, Error> {
    let p = ex.pm.primary;
    let mut row = vec![0.0; ex.dim()];
    row[p] = 1.0;
    invariant_circle_of(&|s: &[f64]| ex.eval(s), &|s: &[f64]| s[p], &row, ex.pm.dt, guess, omega0, opts)
}

/// A map on `R^d` for [`invariant_circle_of`].
pub type MapFn<'a> = dyn Fn(&[f64]) -> Result<Vec<f64>, Error> + Sync + 'a;

/// [`invariant_circle`] of any smooth map `f` on `R^d` (`d` = the guess's state length), e.g. a
/// fitted reduced map: `observable(s)` is the theta the amplitudes are measured in, and the
/// phase condition is `sum_i (phase_row . K_i) sin(theta_i) = 0`; `dt` (s) converts the
/// rotation to Hz.
pub fn invariant_circle_of(
    f: &MapFn<'_>,
    observable: &(dyn Fn(&[f64]) -> f64 + Sync),
    phase_row: &[f64],
    dt: f64,
    guess: &[Vec<f64>],
    omega0: f64,
    opts: &CircleOptions,
) -> Result<InvariantCircle, Error> {
    let n = opts.n;
    let d = phase_row.len();
    if n % 2 == 0 || !(5..=201).contains(&n) {
        return Err(Error::BadOption { what: "n", why: format!("collocation points must be odd, 5..=201, got {n}") });
    }
    if guess.len() != n || guess.iter().any(|g| g.len() != d || g.iter().any(|v| !v.is_finite())) {
        return Err(Error::BadInput { what: "guess", why: format!("need {n} finite states of {d} entries") });
    }
    if !(opts.tol > 0.0 && opts.fd_step > 0.0 && omega0.is_finite()) {
        return Err(Error::BadOption {
            what: "circle options",
            why: format!("tol and fd_step must be > 0, omega finite: {opts:?}, omega {omega0}"),
        });
    }
    let th = |i: usize| std::f64::consts::TAU * i as f64 / n as f64;
    let ph = |s: &[f64]| -> f64 { phase_row.iter().zip(s).map(|(a, b)| a * b).sum() };
    let mut k: Vec<Vec<f64>> = guess.to_vec();
    let mut omega = omega0;
    // Residual (and images) at the current iterate.
    let residual = |k: &[Vec<f64>], omega: f64| -> Result<(DVector<f64>, f64), Error> {
        let fk = crate::par_map(k, |s| f(s))?;
        let (s, _) = shift_matrix(n, omega, 0.0);
        let mut r = DVector::zeros(n * d + 1);
        let mut worst = 0.0f64;
        for i in 0..n {
            for c in 0..d {
                let shifted: f64 = (0..n).map(|j| s[(i, j)] * k[j][c]).sum();
                let v = fk[i][c] - shifted;
                worst = worst.max(v.abs());
                r[i * d + c] = v;
            }
        }
        r[n * d] = (0..n).map(|i| ph(&k[i]) * th(i).sin()).sum::<f64>();
        Ok((r, worst))
    };
    let (mut r, mut worst) = residual(&k, omega)?;
    let mut steps = 0;
    while worst > opts.tol && steps < opts.max_steps {
        steps += 1;
        // Jacobians of F at every point, central differences.
        let jacs = crate::par_map(&k, |s| -> Result<DMatrix<f64>, Error> {
            let mut j = DMatrix::zeros(d, d);
            for c in 0..d {
                let h = opts.fd_step * s[c].abs().max(1.0);
                let mut sp = s.clone();
                let mut sm = s.clone();
                sp[c] += h;
                sm[c] -= h;
                let (fp, fm) = (f(&sp)?, f(&sm)?);
                for row in 0..d {
                    j[(row, c)] = (fp[row] - fm[row]) / (2.0 * h);
                }
            }
            Ok(j)
        })?;
        let (s, ds) = shift_matrix(n, omega, 0.0);
        let m = n * d + 1;
        let mut jm = DMatrix::<f64>::zeros(m, m);
        for i in 0..n {
            for row in 0..d {
                for c in 0..d {
                    jm[(i * d + row, i * d + c)] += jacs[i][(row, c)];
                }
                for j in 0..n {
                    jm[(i * d + row, j * d + row)] -= s[(i, j)];
                }
                jm[(i * d + row, n * d)] = -(0..n).map(|j| ds[(i, j)] * k[j][row]).sum::<f64>();
            }
            for c in 0..d {
                jm[(n * d, i * d + c)] = phase_row[c] * th(i).sin();
            }
        }
        let step = jm.lu().solve(&(-&r)).ok_or_else(|| Error::BadInput {
            what: "invariant circle",
            why: format!("singular Newton matrix at step {steps}"),
        })?;
        // Damped update: halve until the residual falls.
        let mut lambda = 1.0;
        loop {
            let kt: Vec<Vec<f64>> =
                (0..n).map(|i| (0..d).map(|c| k[i][c] + lambda * step[i * d + c]).collect()).collect();
            let ot = omega + lambda * step[n * d];
            let (rt, wt) = residual(&kt, ot)?;
            if wt < worst || lambda < 1e-3 {
                k = kt;
                omega = ot;
                r = rt;
                worst = wt;
                break;
            }
            lambda *= 0.5;
        }
        if !worst.is_finite() {
            return Err(Error::BadInput { what: "invariant circle", why: format!("Newton diverged at step {steps}") });
        }
    }
    // Discretization error: the residual at the midpoints.
    let (smid, _) = shift_matrix(n, 0.0, std::f64::consts::PI / n as f64);
    let (smid_om, _) = shift_matrix(n, omega, std::f64::consts::PI / n as f64);
    let mid: Vec<Vec<f64>> =
        (0..n).map(|i| (0..d).map(|c| (0..n).map(|j| smid[(i, j)] * k[j][c]).sum()).collect()).collect();
    let fmid = crate::par_map(&mid, |s| f(s))?;
    let mut residual_midpoints = 0.0f64;
    for i in 0..n {
        for c in 0..d {
            let target: f64 = (0..n).map(|j| smid_om[(i, j)] * k[j][c]).sum();
            residual_midpoints = residual_midpoints.max((fmid[i][c] - target).abs());
        }
    }
    let thetas: Vec<f64> = k.iter().map(|s| observable(s)).collect();
    Ok(InvariantCircle {
        dt_ms: dt * 1e3,
        omega,
        freq_hz: omega / (std::f64::consts::TAU * dt),
        theta_amplitude: first_harmonic(&thetas),
        theta_max: thetas.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        points: k,
        residual: worst,
        residual_midpoints,
        newton_steps: steps,
    })
}

/// The SSM's circle of mode `mode` (1 or 2) at normal-form amplitude `rho`:
/// `W(z)` with `z_mode = rho e^{i theta_i}`, the other mode 0, truncated at `order`.
pub fn ssm_circle(s: &MapSsm, mode: usize, rho: f64, order: u32, n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| {
            let zj = C::from_polar(rho, std::f64::consts::TAU * i as f64 / n as f64);
            let zero = C::new(0.0, 0.0);
            let z = if mode == 1 { [zj, zj.conj(), zero, zero] } else { [zero, zero, zj, zj.conj()] };
            s.manifold_at(&z, order).iter().map(|c| c.re).collect()
        })
        .collect()
}

/// A limit cycle (`mode` 1 or 2) among the fixed points of `nf` (box [`RHO_MAX`]).
pub fn model_cycle(nf: &PolarNormalForm, mode: usize) -> Result<Option<FixedPoint>, Error> {
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    Ok(fixed_points(nf, &popts)?.into_iter().find(|f| f.kind == PointKind::LimitCycle { mode }))
}

/// The equation-driven model's cycle at one order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EquationCycle {
    pub order: u32,
    /// `rho*` (rad), `None` if the amplitude equations have no such cycle in the box.
    pub rho: Option<f64>,
    /// Theta's first harmonic along `W(rho* e^{i theta})` (rad).
    pub theta_amplitude: Option<f64>,
    /// Frequency on the cycle (Hz).
    pub freq_hz: Option<f64>,
}

/// One sampling period of [`saddle_cycles`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaddleCycleRow {
    pub dt_ms: f64,
    /// Mode (1 slow, 2 fast).
    pub mode: usize,
    /// The equation-driven model's cycle at each requested order.
    pub equation: Vec<EquationCycle>,
    /// The full system's circle (Newton from the previous `dt`'s circle or the highest
    /// order's model circle).
    pub full: Option<InvariantCircle>,
    /// Why the full system's circle was not found, if not.
    pub full_failure: Option<String>,
}

/// The mode-`mode` saddle cycles of the full system over `dts_ms` (continuation in the
/// given order), next to the equation-driven model's at `orders` (each 3..=9; the period
/// map is expanded once, to the highest).
pub fn saddle_cycles(
    dts_ms: &[f64],
    mode: usize,
    orders: &[u32],
    opts: &CircleOptions,
) -> Result<Vec<SaddleCycleRow>, Error> {
    if !(mode == 1 || mode == 2) {
        return Err(Error::BadOption { what: "mode", why: format!("must be 1 or 2, got {mode}") });
    }
    let top = orders.iter().copied().max().unwrap_or(0);
    if orders.iter().any(|k| !(3..=ssm::map_ssm::MAX_ORDER).contains(k)) || orders.is_empty() {
        return Err(Error::BadOption {
            what: "orders",
            why: format!("need orders in 3..={}, got {orders:?}", ssm::map_ssm::MAX_ORDER),
        });
    }
    let mut out = Vec::new();
    let mut prev: Option<InvariantCircle> = None;
    for &dt in dts_ms {
        let scene: Scene = crate::full_system::scene_at(dt)?;
        let ex = ExactMap::new(&scene, top)?;
        let map = polynomial_map(&ex.pm);
        let mut observable = vec![0.0; ex.dim()];
        observable[ex.pm.primary] = 1.0;
        let p = ex.pm.primary;
        let mut equation = Vec::new();
        let mut start = None;
        for &order in orders {
            let s = map_ssm(
                &map,
                &MapSsmOptions {
                    order,
                    pairs: 2,
                    resonance_tol: RESONANCE_TOL,
                    observable: observable.clone(),
                    dt: ex.pm.dt,
                    amplitude: Amplitude::Observable,
                },
            )
            .map_err(|e| Error::from(ssm::Error::from(e)))?;
            let mut row = EquationCycle { order, rho: None, theta_amplitude: None, freq_hz: None };
            if let Some(f) = model_cycle(&s.polar, mode)? {
                let rho = f.rho[mode - 1];
                let circ = ssm_circle(&s, mode, rho, order, opts.n);
                row.rho = Some(rho);
                row.theta_amplitude = Some(first_harmonic(&circ.iter().map(|x| x[p]).collect::<Vec<_>>()));
                row.freq_hz = Some(f.freqs_hz[mode - 1]);
                if order == top {
                    start = Some((circ, std::f64::consts::TAU * f.freqs_hz[mode - 1] * ex.pm.dt));
                }
            }
            equation.push(row);
        }
        // Continuation: the previous dt's circle first, the model's circle otherwise.
        let mut full = None;
        let mut failure = None;
        let mut tries: Vec<(Vec<Vec<f64>>, f64)> = Vec::new();
        if let Some(pc) = &prev {
            tries.push((pc.points.clone(), pc.omega));
        }
        if let Some(st) = start {
            tries.push(st);
        }
        for (g, om) in tries {
            match invariant_circle(&ex, &g, om, opts) {
                Ok(c) if c.residual <= opts.tol => {
                    full = Some(c);
                    break;
                }
                Ok(c) => {
                    failure =
                        Some(format!("Newton stopped at residual {:.2e} after {} steps", c.residual, c.newton_steps))
                }
                Err(e) => failure = Some(e.to_string()),
            }
        }
        if full.is_none() && failure.is_none() {
            failure = Some("no start (the model has no such cycle and there is no previous circle)".into());
        }
        if full.is_some() {
            failure = None;
        }
        prev = full.clone().or(prev);
        out.push(SaddleCycleRow { dt_ms: dt, mode, equation, full, full_failure: failure });
    }
    Ok(out)
}

/// The mode-`mode` (1 slow, 2 fast) cycle of a fitted reduced *map* (no normal form):
/// the invariant circle of `model.dynamics` near its linear mode circle of theta amplitude
/// `theta_amp`, turning by about `omega0` rad per period; amplitudes in the lifted
/// observable (the first embedding coordinate). Tells whether the fitted map, before its
/// normal form, has the full system's saddle cycle.
pub fn fitted_map_cycle(
    model: &ssm::fit::SsmModel,
    mode: usize,
    theta_amp: f64,
    omega0: f64,
    opts: &CircleOptions,
) -> Result<InvariantCircle, Error> {
    use ssm::dynamics::StepScratch;
    let dyn_ = &model.dynamics;
    let dt = dyn_.map_dt().ok_or(Error::NotAMap)?;
    let a = dyn_.linear_part()?;
    let d = model.manifold.dim;
    let row = model.manifold.observable_row();
    // Eigenvector of the pair of `mode` (ordered by |arg mu|), by the SVD of A - mu I.
    let am = nalgebra::DMatrix::from_row_slice(d, d, &a);
    let mut ev: Vec<C> = am.complex_eigenvalues().iter().copied().filter(|z| z.im > 0.0).collect();
    ev.sort_by(|x, y| x.arg().abs().total_cmp(&y.arg().abs()));
    let mu = *ev
        .get(mode - 1)
        .ok_or_else(|| Error::BadInput { what: "fitted map", why: format!("no oscillatory pair {mode}") })?;
    let shifted =
        nalgebra::DMatrix::from_fn(d, d, |i, j| C::new(a[i * d + j], 0.0) - if i == j { mu } else { C::new(0.0, 0.0) });
    let svd = shifted.svd(false, true);
    let vt = svd.v_t.ok_or_else(|| Error::BadInput { what: "fitted map", why: "SVD failed".into() })?;
    let kmin = (0..d).min_by(|&x, &y| svd.singular_values[x].total_cmp(&svd.singular_values[y])).unwrap_or(0);
    let mut v: Vec<C> = (0..d).map(|j| vt[(kmin, j)].conj()).collect();
    let cv: C = row.iter().zip(&v).map(|(c, x)| x * *c).sum();
    v.iter_mut().for_each(|x| *x *= C::new(0.5, 0.0) / cv);
    let guess: Vec<Vec<f64>> = (0..opts.n)
        .map(|i| {
            let z = C::from_polar(theta_amp, std::f64::consts::TAU * i as f64 / opts.n as f64);
            v.iter().map(|x| 2.0 * (x * z).re).collect()
        })
        .collect();
    let step = |s: &[f64]| -> Result<Vec<f64>, Error> {
        let mut e = s.to_vec();
        let mut scratch = StepScratch::default();
        dyn_.step(&mut e, dt, &mut scratch);
        Ok(e)
    };
    let obs = |s: &[f64]| -> f64 {
        let mut out = vec![0.0; model.manifold.p];
        let mut sc = ssm::poly::PolyScratch::default();
        model.manifold.lift_into(s, &mut sc, &mut out);
        out[0]
    };
    invariant_circle_of(&step, &obs, &row, dt, &guess, omega0, opts)
}
