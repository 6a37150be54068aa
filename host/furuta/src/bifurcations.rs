//! The parametric model's bifurcation values: the heteroclinic connection of the saddle
//! cycles, the loss of stability of the 2-torus, the fate of small starts, and how these
//! move with the training choices (sensitivity rows).

use serde::Serialize;
use ssm::portrait::{
    Fate, FixedPoint, HeteroclinicEvent, HopfEvent, PointKind, PortraitOptions, ScanOptions, fixed_points,
    heteroclinic_dt, torus_hopf_dt, trajectory,
};

use ssm::normal_form::PolarNormalForm;

use crate::Error;
use crate::parametric::{FurutaOptions, ParametricModel, furuta_parametric};

/// Box of the amplitude plane drawn and searched: the fitted models saw |theta| <= 0.3 rad.
pub const RHO_MAX: [f64; 2] = [0.6, 0.3];

/// The model's bifurcation values: heteroclinic connection of the saddle cycles and the
/// loss of stability of the 2-torus, found on the linearly interpolated normal forms.
pub struct ModelBifurcations {
    pub heteroclinic: Option<HeteroclinicEvent>,
    pub hopf: Option<HopfEvent>,
    /// The 2-torus at 30.8 ms: amplitudes (rad) and frequencies (Hz).
    pub torus_30p8: Option<FixedPoint>,
}

/// The model's heteroclinic and torus-Hopf values over its training range and its 2-torus at
/// 30.8 ms, on the linearly interpolated normal forms.
pub fn model_bifurcations(pm: &ParametricModel) -> Result<ModelBifurcations, Error> {
    let (lo, hi) = pm.range();
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let sopts = ScanOptions {
        portrait: PortraitOptions { rho_max: RHO_MAX, ..ScanOptions::default().portrait },
        ..ScanOptions::default()
    };
    let nf_at = |dt: f64| pm.normal_form_at(dt);
    let heteroclinic = heteroclinic_dt(nf_at, lo, hi, &sopts)?;
    let hopf = torus_hopf_dt(nf_at, lo, hi, &sopts)?;
    let torus_30p8 = fixed_points(&pm.normal_form_at(30.8)?, &popts)?.into_iter().find(|f| f.kind == PointKind::Torus2);
    Ok(ModelBifurcations { heteroclinic, hopf, torus_30p8 })
}

/// Where the model sends a small start: the fate of the interior unstable branch of the
/// fast-mode saddle cycle (small starts grow along the fast mode to that cycle first, then
/// follow this branch; the full system's runs do the same, see `crate::full_system`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum SmallStartFate {
    /// Reaches the 2-torus continued from 30.8 ms (stable) or circles it on a 3-torus.
    Principal,
    /// Reaches another attractor, leaves the box or stops otherwise.
    Elsewhere,
}

/// The model's fate of a small start at `dt` (see [`SmallStartFate`]); `principal` is the
/// continued torus position (updated).
fn small_start_fate(
    nf_at: &impl Fn(f64) -> Result<PolarNormalForm, Error>,
    dt: f64,
    principal: &mut [f64; 2],
) -> Result<SmallStartFate, Error> {
    let nf = nf_at(dt)?;
    let o = PortraitOptions { rho_max: RHO_MAX, ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() };
    let fps = fixed_points(&nf, &o)?;
    let Some(fc) = fps
        .iter()
        .filter(|f| f.kind == (PointKind::LimitCycle { mode: 2 }))
        .min_by(|a, b| a.rho[1].total_cmp(&b.rho[1]))
    else {
        return Ok(SmallStartFate::Elsewhere);
    };
    let torus = fps
        .iter()
        .filter(|f| f.kind == PointKind::Torus2)
        .min_by(|a, b| {
            let d = |f: &FixedPoint| (f.rho[0] - principal[0]).hypot(f.rho[1] - principal[1]);
            d(a).total_cmp(&d(b))
        })
        .map(|f| f.rho);
    let Some(tc) = torus else { return Ok(SmallStartFate::Elsewhere) };
    *principal = tc;
    let (pts, fate) = trajectory(&nf, [1e-4, fc.rho[1]], 4000.0, &o)?;
    Ok(match fate {
        Fate::Converges { .. } => {
            let last = pts.last().copied().unwrap_or((f64::NAN, f64::NAN));
            if (last.0 - tc[0]).hypot(last.1 - tc[1]) < 1e-3 {
                SmallStartFate::Principal
            } else {
                SmallStartFate::Elsewhere
            }
        }
        Fate::TimeLimit => {
            // On a 3-torus when the last quarter circles the torus point (both sides of it in
            // rho_1 and in rho_2) without leaving.
            let tail = &pts[pts.len() * 3 / 4..];
            let around = |i: usize| {
                let v = |p: &(f64, f64)| if i == 0 { p.0 } else { p.1 };
                tail.iter().any(|p| v(p) < tc[i]) && tail.iter().any(|p| v(p) > tc[i])
            };
            if around(0) && around(1) { SmallStartFate::Principal } else { SmallStartFate::Elsewhere }
        }
        _ => SmallStartFate::Elsewhere,
    })
}

/// The first dt in `[lo, hi]` (grid of `n`, then bisection to 1e-3 ms) at which the model's
/// small-start fate stops being [`SmallStartFate::Principal`]: the model's counterpart of
/// the full system's bounded-vs-escape switch of small starts.
pub fn model_small_start_switch(pm: &ParametricModel, lo: f64, hi: f64, n: usize) -> Result<Option<(f64, f64)>, Error> {
    small_start_switch(|dt| pm.normal_form_at(dt), lo, hi, n)
}

/// [`model_small_start_switch`] of any family of normal forms `nf_at(dt)` (e.g. the
/// equation-driven model's, `crate::equation_ssm`).
pub fn small_start_switch(
    nf_at: impl Fn(f64) -> Result<PolarNormalForm, Error>,
    lo: f64,
    hi: f64,
    n: usize,
) -> Result<Option<(f64, f64)>, Error> {
    let pm = &nf_at;
    let mut principal = [0.1, 0.03];
    let mut prev = lo;
    for k in 0..n {
        let dt = lo + (hi - lo) * k as f64 / (n - 1) as f64;
        if small_start_fate(pm, dt, &mut principal)? == SmallStartFate::Elsewhere {
            if k == 0 {
                return Ok(None);
            }
            let (mut a, mut b) = (prev, dt);
            let mut pa = principal;
            while b - a > 1e-3 {
                let m = 0.5 * (a + b);
                let mut pm_ = pa;
                if small_start_fate(pm, m, &mut pm_)? == SmallStartFate::Principal {
                    a = m;
                    pa = pm_;
                } else {
                    b = m;
                }
            }
            return Ok(Some((a, b)));
        }
        prev = dt;
    }
    Ok(None)
}

/// One training variant of the sensitivity study and the model's bifurcation values.
#[derive(Clone, Debug, Serialize)]
pub struct SensitivityRow {
    pub variant: String,
    pub dts_ms: Vec<f64>,
    pub max_theta: f64,
    pub heteroclinic_dt_ms: Option<f64>,
    pub torus_hopf_dt_ms: Option<f64>,
    pub small_start_switch_dt_ms: Option<f64>,
    /// The 2-torus at 30.8 ms (rad).
    pub torus_30p8_rho: Option<[f64; 2]>,
    /// Fit time of the variant's model (`None`: the report's own model, fitted above).
    pub fit_seconds: Option<f64>,
}

/// The model's bifurcation values for one training variant (fits the parametric model).
pub fn sensitivity_row(variant: &str, o: &FurutaOptions) -> Result<SensitivityRow, Error> {
    let t0 = std::time::Instant::now();
    let pm = furuta_parametric(o)?;
    let fit_seconds = t0.elapsed().as_secs_f64();
    model_row(variant, o, &pm, Some(fit_seconds))
}

/// The bifurcation values of `pm`, fitted with options `o` (`fit_seconds`: its fit time,
/// `None` when it was fitted elsewhere).
pub fn model_row(
    variant: &str,
    o: &FurutaOptions,
    pm: &ParametricModel,
    fit_seconds: Option<f64>,
) -> Result<SensitivityRow, Error> {
    let bif = model_bifurcations(pm)?;
    let sw = model_default_switch(pm)?;
    Ok(row_from(variant, o, &bif, sw, fit_seconds))
}

/// The model's small-start switch on the study's grid: [`model_small_start_switch`] from
/// 30.8 ms to the end of its range (at most 32.3 ms), 76 points. The report's full-system
/// section and [`model_row`] both read it, so [`row_from`] may take either's.
pub fn model_default_switch(pm: &ParametricModel) -> Result<Option<(f64, f64)>, Error> {
    let (_, hi) = pm.range();
    model_small_start_switch(pm, 30.8, hi.min(32.3), 76)
}

/// [`model_row`] of a model whose [`model_bifurcations`] and small-start switch
/// ([`model_default_switch`]) were
/// computed already (the report's own model: the portraits and full-system sections), the
/// same row without computing them again.
pub fn row_from(
    variant: &str,
    o: &FurutaOptions,
    bif: &ModelBifurcations,
    switch: Option<(f64, f64)>,
    fit_seconds: Option<f64>,
) -> SensitivityRow {
    SensitivityRow {
        variant: variant.to_string(),
        dts_ms: o.dts_ms.clone(),
        max_theta: o.max_theta,
        heteroclinic_dt_ms: bif.heteroclinic.as_ref().map(|h| h.dt),
        torus_hopf_dt_ms: bif.hopf.as_ref().map(|h| h.dt),
        small_start_switch_dt_ms: switch.map(|b| 0.5 * (b.0 + b.1)),
        torus_30p8_rho: bif.torus_30p8.as_ref().map(|f| f.rho),
        fit_seconds,
    }
}

/// The training variants of the sensitivity study (besides the default options): the
/// amplitude cut of the training runs (0.3, 0.15 rad) and seven training periods instead of
/// the paper's four (cut 0.2 and 0.3 rad).
pub fn sensitivity_variants() -> Vec<(&'static str, FurutaOptions)> {
    let base = FurutaOptions::default();
    let dense = vec![30.5, 31.0, 31.25, 31.5, 31.75, 32.0, 32.5];
    vec![
        ("cut 0.3 rad", FurutaOptions { max_theta: 0.3, ..base.clone() }),
        ("cut 0.15 rad", FurutaOptions { max_theta: 0.15, ..base.clone() }),
        ("7 periods, cut 0.2 rad", FurutaOptions { dts_ms: dense.clone(), ..base.clone() }),
        ("7 periods, cut 0.3 rad", FurutaOptions { dts_ms: dense, max_theta: 0.3, ..base }),
    ]
}

// ---------------------------------------------------------------------------------------
// The global bifurcation read off the fitted map itself (no normal form)
// ---------------------------------------------------------------------------------------

/// Iterates a reduced map from `eta0` for `steps` steps (step `dt` s; sample 0 is `eta0`
/// itself, at time `t0`) and classifies it as the full-system scans do: escape at the first
/// sample with |`obs(eta)`| > `escape_theta` (or a non-finite state), else bounded.
/// `step` advances `eta` in place by one period.
pub fn iterate_outcome(
    mut step: impl FnMut(&mut [f64]),
    obs: impl Fn(&[f64]) -> f64,
    eta0: &[f64],
    steps: u64,
    t0: f64,
    dt: f64,
    escape_theta: f64,
) -> crate::full_system::Outcome {
    let mut eta = eta0.to_vec();
    let mut max_theta = 0.0f64;
    for n in 0..=steps {
        let th = obs(&eta);
        if !th.is_finite() || eta.iter().any(|v| !v.is_finite()) || th.abs() > escape_theta {
            return crate::full_system::Outcome {
                escape_t: Some(t0 + n as f64 * dt),
                max_theta: if th.is_finite() { max_theta.max(th.abs()) } else { f64::INFINITY },
            };
        }
        max_theta = max_theta.max(th.abs());
        if n < steps {
            step(&mut eta);
        }
    }
    crate::full_system::Outcome { escape_t: None, max_theta }
}

/// The fitted map's fate of one full-system start at `dt_ms`: the first `p` samples of theta
/// (the delay-embedding window, `p` = the model's embedding dimension) come from the full
/// system (as a prediction is started from the first `p` test samples), are projected to
/// `eta0 = V1^T y0`, and the map is iterated for the rest of `periods` periods; theta is the
/// newest coordinate of the lifted point. Escape: |theta| > `escape_theta` (also in the
/// first `p` samples).
pub fn map_outcome(
    model: &ssm::fit::SsmModel,
    dt_ms: f64,
    start: &crate::full_system::Start,
    periods: u64,
    escape_theta: f64,
) -> Result<crate::full_system::Outcome, Error> {
    use ssm::dynamics::StepScratch;
    let p = model.manifold.p;
    if model.observables != 1 {
        return Err(Error::BadInput {
            what: "model",
            why: format!("needs one observable (theta), has {}", model.observables),
        });
    }
    let dt = model.dynamics.map_dt().ok_or(Error::NotAMap)?;
    if (dt - sim::units::ms_to_s(dt_ms)).abs() > 1e-9 * dt {
        return Err(Error::BadInput {
            what: "dt_ms",
            why: format!("{dt_ms} ms, but the model's map steps {} ms", dt * 1e3),
        });
    }
    if periods < p as u64 {
        return Err(Error::BadInput {
            what: "periods",
            why: format!("{periods} is shorter than the embedding window ({p} samples)"),
        });
    }
    let head = crate::full_system::run(dt_ms, start, p as u64, f64::MAX)?.primary();
    let Some(y0) = head.get(..p) else {
        return Err(Error::BadInput {
            what: "start",
            why: format!("full-system run gave {} samples, need {p}", head.len()),
        });
    };
    let head_max = y0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if let Some(k) = y0.iter().position(|v| v.abs() > escape_theta) {
        return Ok(crate::full_system::Outcome { escape_t: Some(k as f64 * dt), max_theta: head_max });
    }
    let eta0 = model.manifold.reduce(y0);
    let mut scratch = StepScratch::default();
    // Theta is the lifted point's newest coordinate: only that one is evaluated. Map and
    // lift prepared once for the run (the same bits as the plain step and lift).
    let (map, manifold) = (model.dynamics.prepare(), model.manifold.prepare());
    let lift = std::cell::RefCell::new(ssm::poly::PolyScratch::default());
    let obs = |e: &[f64]| manifold.lift_one(e, &mut lift.borrow_mut(), p - 1);
    let o = iterate_outcome(
        |e| map.step(e, dt, &mut scratch),
        obs,
        &eta0,
        periods - (p as u64 - 1),
        (p - 1) as f64 * dt,
        dt,
        escape_theta,
    );
    Ok(crate::full_system::Outcome { escape_t: o.escape_t, max_theta: o.max_theta.max(head_max) })
}

/// A bounded-to-escape switch located by a grid and bisection.
#[derive(Clone, Debug, Serialize)]
pub struct MapSwitch {
    /// `(lo, hi)`: every start bounded at `lo`, some start escapes at `hi`, `hi - lo <= tol`.
    /// `None` when no grid point has an escape or the first one already has one.
    pub bracket: Option<(f64, f64)>,
    /// Number of escaping starts per grid point (grid order).
    pub grid: Vec<(f64, usize)>,
    /// Whether the escape counts on the grid never decrease (a clean switch).
    pub monotone: bool,
    /// Number of (dt, start) evaluations.
    pub evaluations: usize,
}

/// The first `dt` in `[lo, hi]` at which any start escapes: `escapes(dt)` returns the
/// per-start escape flags; grid of `n` points (rayon pool, input order), then bisection
/// between the last all-bounded grid point and the first escaping one to `tol` ms.
pub fn first_escape_switch(
    escapes: impl Fn(f64) -> Result<Vec<bool>, Error> + Sync,
    lo: f64,
    hi: f64,
    n: usize,
    tol: f64,
) -> Result<MapSwitch, Error> {
    if !(lo.is_finite() && hi.is_finite() && lo < hi) || n < 2 {
        return Err(Error::BadInput {
            what: "switch range",
            why: format!("need lo < hi finite and n >= 2, got [{lo}, {hi}], n = {n}"),
        });
    }
    if !(tol.is_finite() && tol > 0.0) {
        return Err(Error::BadInput { what: "tol", why: format!("must be positive, got {tol}") });
    }
    let dts: Vec<f64> = (0..n).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64).collect();
    let rows = crate::par_map(&dts, |&dt| escapes(dt))?;
    let mut evaluations: usize = rows.iter().map(Vec::len).sum();
    let grid: Vec<(f64, usize)> = dts.iter().zip(&rows).map(|(&d, r)| (d, r.iter().filter(|&&e| e).count())).collect();
    let monotone = grid.windows(2).all(|w| w[1].1 >= w[0].1);
    let bracket = match grid.iter().position(|g| g.1 > 0) {
        None | Some(0) => None,
        Some(i) => {
            let (mut a, mut b) = (dts[i - 1], dts[i]);
            while b - a > tol {
                let m = 0.5 * (a + b);
                let r = escapes(m)?;
                evaluations += r.len();
                if r.iter().any(|&e| e) {
                    b = m;
                } else {
                    a = m;
                }
            }
            Some((a, b))
        }
    };
    Ok(MapSwitch { bracket, grid, monotone, evaluations })
}

/// The fitted map's small-start switch: at each `dt` the map `model_at(dt)` (e.g. the
/// shared-tangent model's, `|dt| sm.model_at(dt, Interp::Linear)`) is iterated from the full system's starts `ics_at(dt)` (e.g.
/// [`crate::full_system::default_ics`]) for `periods` periods ([`map_outcome`]); the switch
/// is the first dt with an escape (|theta| > [`crate::full_system::ESCAPE_THETA`]), located by
/// [`first_escape_switch`] on `[lo, hi]` (grid `n`, bisection to `tol` ms). The map's
/// counterpart of [`crate::full_system::default_switch_scan`], no normal form involved.
pub fn map_small_start_switch(
    model_at: impl Fn(f64) -> Result<ssm::fit::SsmModel, Error> + Sync,
    ics_at: impl Fn(f64) -> Result<Vec<crate::full_system::Start>, Error> + Sync,
    lo: f64,
    hi: f64,
    n: usize,
    periods: u64,
    tol: f64,
) -> Result<MapSwitch, Error> {
    let escapes = |dt: f64| -> Result<Vec<bool>, Error> {
        let m = model_at(dt)?;
        let ics = ics_at(dt)?;
        let outs = crate::par_map(&ics, |ic| map_outcome(&m, dt, ic, periods, crate::full_system::ESCAPE_THETA))?;
        Ok(outs.iter().map(|o| !o.bounded()).collect())
    };
    first_escape_switch(escapes, lo, hi, n, tol)
}
