//! The global bifurcations read off the fitted reduced *map* itself (the shared-tangent SSM
//! model iterated, no normal form), each next to the full system's under the same rule
//! (docs/decisions/0001):
//!
//! - [`map_connection`] / [`full_connection`]: the saddle connection as the fate of the
//!   interior unstable branch of the FAST saddle cycle. The cycle is an invariant circle of
//!   the one-period map (of the fitted map, [`map_fast_circle`]; of the exact period map,
//!   [`crate::saddle_cycles::saddle_cycles`]); starts on it are pushed along the slow mode (its
//!   unstable direction: the linear slow eigenvector, theta amplitude
//!   [`ConnectionOptions::push`], several slow phases) and iterated: bounded (onto the
//!   2-torus) or escape (|theta| > [`ESCAPE_THETA`]) within [`ConnectionOptions::periods`].
//!   The connection is the first dt at which a pushed start escapes, by grid and bisection
//!   ([`crate::bifurcations::first_escape_switch`]).
//! - [`map_torus_continuation`]: the 2-torus followed across dt on the map, the full system's
//!   rule ([`crate::basin::torus_step`], as [`crate::basin::torus_continuation`]).
//! - [`map_basin`]: the map's bounded/escape verdict on the full system's basin grid
//!   ([`crate::basin::BasinOptions`]), each cell started from the full system's first delay
//!   vector ([`crate::bifurcations::map_outcome`]).
//!
//! Owns none of the models: a family of maps is any `model_at(dt_ms)` (e.g.
//! `SharedParametricModel::model_at`).

use nalgebra::{Complex, DMatrix};
use serde::Serialize;
use ssm::dynamics::StepScratch;
use ssm::fit::SsmModel;
use ssm::poly::PolyScratch;

use crate::Error;
use crate::basin::{BasinOptions, TorusContinuation, torus_step};
use crate::bifurcations::{MapSwitch, first_escape_switch, iterate_outcome, map_outcome};
use crate::full_system::{ESCAPE_THETA, Outcome, Start, outcome_of, run, start_from_rho, start_from_rho_in};
use crate::parametric::ModeBasis;
use crate::saddle_cycles::{CircleOptions, InvariantCircle, saddle_cycles};

type C = Complex<f64>;

/// Options of the saddle-connection rule.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ConnectionOptions {
    /// Theta amplitude (rad) of the push along the slow eigenvector.
    pub push: f64,
    /// Number of slow phases `pi k / phases` of the push (one start each).
    pub phases: usize,
    /// Horizon of every start (sampling periods).
    pub periods: u64,
    /// Theta amplitude (rad) of the linear guess of the fitted map's fast circle.
    pub fast_guess: f64,
    /// Collocation of the circles.
    pub circle: CircleOptions,
    /// Order of the equation-driven SSM whose circle starts Newton on the exact period map
    /// (3..=9; the circle found does not depend on it, only the cost: 3 is enough at
    /// theta ~0.07 rad).
    pub guess_order: u32,
}

impl Default for ConnectionOptions {
    /// Push 1e-3 rad at 4 phases, 8,000 periods (the switch scans' horizon), fast circle
    /// guessed at 0.07 rad (the full system's at 31.3 ms), 21 collocation points (on the
    /// exact map's fast circle at 31.3 ms the residual between the points stays far below the
    /// push of 1e-3), Newton on the exact map from the order-3 equation-driven circle (cheaper
    /// than 33 points from order 7, for the same circle).
    fn default() -> Self {
        ConnectionOptions {
            push: 1e-3,
            phases: 4,
            periods: crate::full_system::DEFAULT_SCAN_PERIODS,
            fast_guess: 0.07,
            circle: CircleOptions { n: 21, ..CircleOptions::default() },
            guess_order: 3,
        }
    }
}

impl ConnectionOptions {
    fn check(&self) -> Result<(), Error> {
        if !(self.push.is_finite() && self.push > 0.0 && self.push < 0.1) {
            return Err(Error::BadOption { what: "push", why: format!("need 0 < push < 0.1 rad, got {}", self.push) });
        }
        if !(1..=64).contains(&self.phases) {
            return Err(Error::BadOption { what: "phases", why: format!("need 1..=64, got {}", self.phases) });
        }
        if self.periods == 0 {
            return Err(Error::BadOption { what: "periods", why: "must be at least 1".into() });
        }
        if !(3..=ssm::map_ssm::MAX_ORDER).contains(&self.guess_order) {
            return Err(Error::BadOption {
                what: "guess_order",
                why: format!("need 3..={}, got {}", ssm::map_ssm::MAX_ORDER, self.guess_order),
            });
        }
        if !(self.fast_guess.is_finite() && self.fast_guess > 0.0) {
            return Err(Error::BadOption {
                what: "fast_guess",
                why: format!("must be positive, got {}", self.fast_guess),
            });
        }
        Ok(())
    }
}

/// The pushed starts of one dt and their fates.
#[derive(Clone, Debug, Serialize)]
pub struct ConnectionFates {
    pub dt_ms: f64,
    /// The fast saddle cycle: theta's first harmonic (rad), frequency (Hz), collocation
    /// residual.
    pub circle_theta_amplitude: f64,
    pub circle_freq_hz: f64,
    pub circle_residual: f64,
    /// One per slow phase, in order.
    pub outcomes: Vec<Outcome>,
}

impl ConnectionFates {
    /// Escape flags, in phase order.
    pub fn escapes(&self) -> Vec<bool> {
        self.outcomes.iter().map(|o| !o.bounded()).collect()
    }
}

/// A saddle connection located by grid and bisection.
#[derive(Clone, Debug, Serialize)]
pub struct Connection {
    pub switch: MapSwitch,
    pub options: ConnectionOptions,
}

/// The eigenvector of the real matrix `a` (`d x d`) for its eigenvalue near `mu` (inverse
/// iteration, [`crate::parametric::eigenvector_near`]), scaled so that `row . v = 1/2`: then `2 Re(v z)` has
/// theta (`row . x`) equal to `Re z`.
pub fn eigenvector(a: &DMatrix<f64>, mu: Complex<f64>, row: &[f64]) -> Result<Vec<Complex<f64>>, Error> {
    let v = crate::parametric::eigenvector_near(a, mu)
        .ok_or_else(|| Error::BadInput { what: "eigenvector", why: format!("singular shifted matrix at mu = {mu}") })?;
    let c: C = row.iter().zip(v.iter()).map(|(r, x)| x * *r).sum();
    if !(c.norm() > 1e-12) {
        return Err(Error::BadInput {
            what: "eigenvector",
            why: format!("the slow mode does not show in theta (|row . v| = {:.1e})", c.norm()),
        });
    }
    Ok(v.iter().map(|x| x * C::new(0.5, 0.0) / c).collect())
}

/// The slow multiplier of `a`: of the two oscillatory pairs of largest modulus, the one with
/// the smaller rotation (positive imaginary part).
pub fn slow_multiplier(a: &DMatrix<f64>) -> Result<Complex<f64>, Error> {
    let mut ev: Vec<C> = a.complex_eigenvalues().iter().copied().filter(|z| z.im > 0.0).collect();
    ev.sort_by(|x, y| y.norm().total_cmp(&x.norm()));
    ev.truncate(2);
    if ev.len() < 2 {
        return Err(Error::BadInput {
            what: "linear part",
            why: format!("needs two oscillatory pairs, has {}", ev.len()),
        });
    }
    ev.sort_by(|x, y| x.arg().abs().total_cmp(&y.arg().abs()));
    Ok(ev[0])
}

/// The starts of the rule: the circle's point at angle 0 plus `2 Re(v push e^{i phi_k})`,
/// `phi_k = pi k / phases` (half a turn: the loop is odd in its angles, `phi + pi` is the
/// mirror start).
fn pushed_starts(circle: &InvariantCircle, v: &[C], o: &ConnectionOptions) -> Vec<Vec<f64>> {
    let k0 = circle.points.first().cloned().unwrap_or_default();
    (0..o.phases)
        .map(|k| {
            let z = C::from_polar(o.push, std::f64::consts::PI * k as f64 / o.phases as f64);
            k0.iter().zip(v).map(|(x, vi)| x + 2.0 * (vi * z).re).collect()
        })
        .collect()
}

/// The fast (mode-2) saddle cycle of a fitted map: its invariant circle from the linear
/// fast-mode circle of theta amplitude `o.fast_guess` (Newton,
/// [`crate::saddle_cycles::fitted_map_cycle`]).
pub fn map_fast_circle(model: &SsmModel, o: &ConnectionOptions) -> Result<InvariantCircle, Error> {
    let dt = model.dynamics.map_dt().ok_or(Error::NotAMap)?;
    let mut up: Vec<(f64, f64)> = model.eigenvalues_ct.iter().copied().filter(|e| e.1 > 0.0).collect();
    up.sort_by(|a, b| b.1.total_cmp(&a.1));
    let omega0 = up
        .first()
        .map(|e| e.1 * dt)
        .ok_or_else(|| Error::BadInput { what: "fitted map", why: "no oscillatory pair".into() })?;
    crate::saddle_cycles::fitted_map_cycle(model, 2, o.fast_guess, omega0, &o.circle)
}

/// The rule on a fitted map at `dt_ms`: the fast circle, the pushed starts in the reduced
/// coordinates (slow eigenvector of the map's linear part, theta = the lifted first
/// embedding coordinate), each iterated for `o.periods` periods (escape: |theta of the
/// newest embedding coordinate| > [`ESCAPE_THETA`], as [`map_outcome`]).
pub fn map_connection_fates(model: &SsmModel, dt_ms: f64, o: &ConnectionOptions) -> Result<ConnectionFates, Error> {
    o.check()?;
    let dt = model.dynamics.map_dt().ok_or(Error::NotAMap)?;
    if (dt - sim::units::ms_to_s(dt_ms)).abs() > 1e-9 * dt {
        return Err(Error::BadInput {
            what: "dt_ms",
            why: format!("{dt_ms} ms, but the model's map steps {} ms", dt * 1e3),
        });
    }
    let circle = map_fast_circle(model, o)?;
    if !(circle.residual <= o.circle.tol) {
        return Err(Error::BadInput {
            what: "fast circle",
            why: format!("dt = {dt_ms} ms: Newton stopped at residual {:.1e}", circle.residual),
        });
    }
    let d = model.manifold.dim;
    let a = DMatrix::from_row_slice(d, d, &model.dynamics.linear_part()?);
    let v = eigenvector(&a, slow_multiplier(&a)?, &model.manifold.observable_row())?;
    let p = model.manifold.p;
    let (map, manifold) = (model.dynamics.prepare(), model.manifold.prepare());
    let outcomes = pushed_starts(&circle, &v, o)
        .iter()
        .map(|eta0| {
            let mut scratch = StepScratch::default();
            let lift = std::cell::RefCell::new(PolyScratch::default());
            let obs = |e: &[f64]| manifold.lift_one(e, &mut lift.borrow_mut(), p - 1);
            iterate_outcome(|e| map.step(e, dt, &mut scratch), obs, eta0, o.periods, 0.0, dt, ESCAPE_THETA)
        })
        .collect();
    Ok(ConnectionFates {
        dt_ms,
        circle_theta_amplitude: circle.theta_amplitude,
        circle_freq_hz: circle.freq_hz,
        circle_residual: circle.residual,
        outcomes,
    })
}

/// [`map_connection_fates`] over dt on the family `model_at`, switch located on `[lo, hi]`
/// (grid of `n` on the rayon pool, bisection to `tol` ms).
pub fn map_connection(
    model_at: impl Fn(f64) -> Result<SsmModel, Error> + Sync,
    lo: f64,
    hi: f64,
    n: usize,
    tol: f64,
    o: &ConnectionOptions,
) -> Result<Connection, Error> {
    o.check()?;
    let switch = first_escape_switch(|dt| Ok(map_connection_fates(&model_at(dt)?, dt, o)?.escapes()), lo, hi, n, tol)?;
    Ok(Connection { switch, options: *o })
}

/// A state of the exact period map (deflated coordinates of `sim::taylor::PeriodMap`:
/// `theta, w_theta, w_phi`, the samples `y_{i-1} .. y_{i-1-r}`, then `w_k = z_{i-1-k} -
/// phi_i`) as a full-system start with `phi = 0`: plant `[theta, w_theta, 0, w_phi]` and
/// the `r + 1` previous samples `[y, z]`, oldest first.
pub fn start_of_deflated(s: &[f64]) -> Result<Start, Error> {
    let n = s.len();
    if n < 5 || (n - 3) % 2 != 0 {
        return Err(Error::BadInput {
            what: "deflated state",
            why: format!("need 3 + 2 (delay + 1) entries, got {n}"),
        });
    }
    let k = (n - 3) / 2;
    let hist = (0..k).rev().map(|j| [s[3 + j], s[3 + k + j]]).collect();
    Ok(([s[0], s[1], 0.0, s[2]], Some(hist)))
}

/// The inverse of [`start_of_deflated`] for any `phi`: a full-system start (controller delay
/// `delay`; no pre-history = the plant at rest at its initial angles, as the simulator takes
/// it) in the period map's deflated coordinates.
pub fn deflated_of_start(start: &Start, delay: usize) -> Result<Vec<f64>, Error> {
    let (x, hist) = start;
    let rest = vec![[x[0], x[2]]; delay + 1];
    let h = hist.as_deref().unwrap_or(&rest);
    if h.len() != delay + 1 {
        return Err(Error::BadInput {
            what: "start",
            why: format!("pre-history has {} samples, the delay {delay} needs {}", h.len(), delay + 1),
        });
    }
    if x.iter().chain(h.iter().flatten()).any(|v| !v.is_finite()) {
        return Err(Error::BadInput { what: "start", why: format!("state and pre-history must be finite, got {x:?}") });
    }
    // Oldest first: h[delay - k] = (y_{-1-k}, z_{-1-k}).
    let mut s = vec![x[0], x[1], x[3]];
    s.extend((0..=delay).map(|k| h[delay - k][0]));
    s.extend((0..=delay).map(|k| h[delay - k][1] - x[2]));
    Ok(s)
}

/// The rule on the full system at `dt_ms`: the fast saddle cycle of the exact period map
/// ([`saddle_cycles`], Newton from the equation-driven circle of order `o.guess_order`), the pushed starts
/// (slow eigenvector of the exact ZOH map in the same deflated coordinates), each run by the
/// simulator ([`run`], escape at [`ESCAPE_THETA`]) for `o.periods` periods.
pub fn full_connection_fates(dt_ms: f64, o: &ConnectionOptions) -> Result<ConnectionFates, Error> {
    full_connection_fates_with(None, dt_ms, o)
}

/// [`full_connection_fates`] with the scene's integrator replaced by `integrator` (`None`: the
/// scene's; [`crate::full_system::run_with`]).
pub fn full_connection_fates_with(
    integrator: Option<&sim::scene::IntegratorSpec>,
    dt_ms: f64,
    o: &ConnectionOptions,
) -> Result<ConnectionFates, Error> {
    o.check()?;
    let rows = saddle_cycles(&[dt_ms], 2, &[o.guess_order], &o.circle)?;
    let row =
        rows.first().ok_or_else(|| Error::BadInput { what: "fast circle", why: format!("dt = {dt_ms} ms: no row") })?;
    let circle = row.full.clone().ok_or_else(|| Error::BadInput {
        what: "fast circle",
        why: format!("dt = {dt_ms} ms: {}", row.full_failure.clone().unwrap_or_default()),
    })?;
    let scene = crate::full_system::scene_at(dt_ms)?;
    let le = |source| sim::stability::StabilityError::Linear { scene: scene.name.clone(), source };
    let a = sim::stability::linear_plant(&scene)?
        .closed_loop(&scene.controller_config())
        .map_err(le)?
        .deflated()
        .map_err(le)?;
    if a.nrows() != circle.points.first().map_or(0, Vec::len) {
        return Err(Error::Shape { expected: circle.points.first().map_or(0, Vec::len), got: a.nrows() });
    }
    let mut row = vec![0.0; a.nrows()];
    row[0] = 1.0;
    let v = eigenvector(&a, slow_multiplier(&a)?, &row)?;
    let starts = pushed_starts(&circle, &v, o);
    let outcomes = crate::par_map(&starts, |s| -> Result<Outcome, Error> {
        Ok(outcome_of(&crate::full_system::run_with(
            integrator,
            dt_ms,
            &start_of_deflated(s)?,
            o.periods,
            ESCAPE_THETA,
        )?))
    })?;
    Ok(ConnectionFates {
        dt_ms,
        circle_theta_amplitude: circle.theta_amplitude,
        circle_freq_hz: circle.freq_hz,
        circle_residual: circle.residual,
        outcomes,
    })
}

/// [`full_connection_fates`] over dt, switch located on `[lo, hi]` (grid of `n`, bisection
/// to `tol` ms).
pub fn full_connection(lo: f64, hi: f64, n: usize, tol: f64, o: &ConnectionOptions) -> Result<Connection, Error> {
    full_connection_with(None, lo, hi, n, tol, o)
}

/// [`full_connection`] with the scene's integrator replaced by `integrator` (`None`: the
/// scene's; the report passes [`crate::full_system::verdict_integrator`]).
pub fn full_connection_with(
    integrator: Option<&sim::scene::IntegratorSpec>,
    lo: f64,
    hi: f64,
    n: usize,
    tol: f64,
    o: &ConnectionOptions,
) -> Result<Connection, Error> {
    o.check()?;
    let switch =
        first_escape_switch(|dt| Ok(full_connection_fates_with(integrator, dt, o)?.escapes()), lo, hi, n, tol)?;
    Ok(Connection { switch, options: *o })
}

/// The fitted map's 2-torus followed across `dts_ms` (strictly increasing), the full
/// system's rule ([`torus_step`]): the first run starts from the reduced point of the full
/// system's first delay vector from the mode start at `start_rho` (phases 0, at the first
/// dt), every further run from the end of the previous one (the reduced coordinates mean the
/// same at every dt of a shared-tangent family); `periods` map steps each; theta is the lifted
/// newest embedding coordinate. Stops after the first step where the torus is lost.
pub fn map_torus_continuation(
    model_at: impl Fn(f64) -> Result<SsmModel, Error>,
    dts_ms: &[f64],
    start_rho: [f64; 2],
    periods: u64,
) -> Result<TorusContinuation, Error> {
    check_continuation(dts_ms, periods)?;
    let first = model_at(dts_ms[0])?;
    let p = first.manifold.p;
    let (x, h) = start_from_rho(dts_ms[0], start_rho, [0.0, 0.0])?;
    let head = run(dts_ms[0], &(x, Some(h)), p as u64, f64::MAX)?.primary();
    let y0 = head.get(..p).ok_or_else(|| Error::BadInput {
        what: "start",
        why: format!("full-system run gave {} samples, need {p}", head.len()),
    })?;
    let eta = first.manifold.reduce(y0);
    map_torus_continuation_from(model_at, dts_ms, start_rho, eta, periods)
}

/// The continuation's inputs: at least one dt, strictly increasing; at least 3 periods.
fn check_continuation(dts_ms: &[f64], periods: u64) -> Result<(), Error> {
    if dts_ms.is_empty() || dts_ms.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::BadInput {
            what: "dts_ms",
            why: format!("need at least one, strictly increasing, got {dts_ms:?}"),
        });
    }
    if periods < 3 {
        return Err(Error::BadInput { what: "periods", why: format!("need at least 3, got {periods}") });
    }
    Ok(())
}

/// [`map_torus_continuation`] from the reduced point `eta0` (for a map whose reduced
/// coordinates of a full-system start are known otherwise, e.g.
/// [`crate::equation_map::torus_start`]); `start_rho` is recorded as the start.
pub fn map_torus_continuation_from(
    model_at: impl Fn(f64) -> Result<SsmModel, Error>,
    dts_ms: &[f64],
    start_rho: [f64; 2],
    eta0: Vec<f64>,
    periods: u64,
) -> Result<TorusContinuation, Error> {
    check_continuation(dts_ms, periods)?;
    let mut eta = eta0;
    let p = model_at(dts_ms[0])?.manifold.p;
    let mut steps = Vec::new();
    for &dt_ms in dts_ms {
        let model = model_at(dt_ms)?;
        let dt = model.dynamics.map_dt().ok_or(Error::NotAMap)?;
        if model.manifold.p != p || model.manifold.dim != eta.len() {
            return Err(Error::Shape { expected: p, got: model.manifold.p });
        }
        let (mut scratch, mut sc) = (StepScratch::default(), PolyScratch::default());
        let (map, manifold) = (model.dynamics.prepare(), model.manifold.prepare());
        let mut theta = Vec::with_capacity(periods as usize + 1);
        let mut escape_t = None;
        for k in 0..=periods {
            let th = manifold.lift_one(&eta, &mut sc, p - 1);
            if !th.is_finite() || eta.iter().any(|v| !v.is_finite()) || th.abs() > ESCAPE_THETA {
                escape_t = Some(k as f64 * dt);
                break;
            }
            theta.push(th);
            if k < periods {
                map.step(&mut eta, dt, &mut scratch);
            }
        }
        let step = torus_step(dt_ms, &theta, dt, escape_t)?;
        let lost = step.lost;
        steps.push(step);
        if lost {
            break;
        }
    }
    Ok(TorusContinuation::from_steps(start_rho, periods, steps))
}

/// The fitted map's verdict on the basin grid `opts`: per dt (in order) the bounded flags of
/// the starts `(rho1[i], rho2[j])`, `rho_1`-major as [`crate::basin::FullBasin::bounded_at`]
/// (each from the full system's first delay vector of the mode start, [`map_outcome`], for
/// `opts.periods` periods, escape at [`ESCAPE_THETA`]). Every cell on the rayon pool.
pub fn map_basin(
    model_at: impl Fn(f64) -> Result<SsmModel, Error> + Sync,
    opts: &BasinOptions,
) -> Result<Vec<Vec<bool>>, Error> {
    if opts.dts_ms.is_empty() || opts.dts_ms.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::BadInput {
            what: "dts_ms",
            why: format!("need at least one, strictly increasing, got {:?}", opts.dts_ms),
        });
    }
    // The model and the linear eigenvectors of the starts once per dt (not per cell).
    let models = crate::par_map(&opts.dts_ms, |&dt| Ok::<_, Error>((model_at(dt)?, ModeBasis::at(dt)?)))?;
    let (r1, r2) = opts.values();
    let mut cells: Vec<(usize, f64, f64)> = Vec::with_capacity(opts.dts_ms.len() * r1.len() * r2.len());
    for k in 0..opts.dts_ms.len() {
        for &x in &r1 {
            cells.extend(r2.iter().map(|&y| (k, x, y)));
        }
    }
    let bounded = crate::par_map(&cells, |&(k, x, y)| -> Result<bool, Error> {
        let dt = opts.dts_ms[k];
        let (model, basis) = &models[k];
        let (s, h) = start_from_rho_in(basis, [x, y], opts.phases)?;
        Ok(map_outcome(model, dt, &(s, Some(h)), opts.periods, ESCAPE_THETA)?.bounded())
    })?;
    Ok(bounded.chunks(r1.len() * r2.len()).map(<[bool]>::to_vec).collect())
}
