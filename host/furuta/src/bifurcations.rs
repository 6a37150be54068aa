//! The parametric model's bifurcation values: the heteroclinic connection of the saddle
//! cycles, the loss of stability of the 2-torus, the fate of small starts, and how these
//! move with the training choices (sensitivity rows).

use serde::Serialize;
use ssm::portrait::{
    Fate, FixedPoint, HeteroclinicEvent, HopfEvent, PointKind, PortraitOptions, ScanOptions, fixed_points, heteroclinic_dt,
    torus_hopf_dt, trajectory,
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
    let sopts = ScanOptions { portrait: PortraitOptions { rho_max: RHO_MAX, ..ScanOptions::default().portrait }, ..ScanOptions::default() };
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
fn small_start_fate(nf_at: &impl Fn(f64) -> Result<PolarNormalForm, Error>, dt: f64, principal: &mut [f64; 2]) -> Result<SmallStartFate, Error> {
    let nf = nf_at(dt)?;
    let o = PortraitOptions { rho_max: RHO_MAX, ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() };
    let fps = fixed_points(&nf, &o)?;
    let Some(fc) = fps.iter().filter(|f| f.kind == (PointKind::LimitCycle { mode: 2 })).min_by(|a, b| a.rho[1].total_cmp(&b.rho[1])) else {
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
            if (last.0 - tc[0]).hypot(last.1 - tc[1]) < 1e-3 { SmallStartFate::Principal } else { SmallStartFate::Elsewhere }
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
pub fn small_start_switch(nf_at: impl Fn(f64) -> Result<PolarNormalForm, Error>, lo: f64, hi: f64, n: usize) -> Result<Option<(f64, f64)>, Error> {
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
pub fn model_row(variant: &str, o: &FurutaOptions, pm: &ParametricModel, fit_seconds: Option<f64>) -> Result<SensitivityRow, Error> {
    let (lo, hi) = pm.range();
    let sopts = ScanOptions { portrait: PortraitOptions { rho_max: RHO_MAX, ..ScanOptions::default().portrait }, ..ScanOptions::default() };
    let nf_at = |dt: f64| pm.normal_form_at(dt);
    let het = heteroclinic_dt(nf_at, lo, hi, &sopts)?;
    let hopf = torus_hopf_dt(nf_at, lo, hi, &sopts)?;
    let sw = model_small_start_switch(pm, 30.8, hi.min(32.3), 76)?;
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let torus = fixed_points(&pm.normal_form_at(30.8)?, &popts)?.into_iter().find(|f| f.kind == PointKind::Torus2).map(|f| f.rho);
    Ok(SensitivityRow {
        variant: variant.to_string(),
        dts_ms: o.dts_ms.clone(),
        max_theta: o.max_theta,
        heteroclinic_dt_ms: het.map(|h| h.dt),
        torus_hopf_dt_ms: hopf.map(|h| h.dt),
        small_start_switch_dt_ms: sw.map(|b| 0.5 * (b.0 + b.1)),
        torus_30p8_rho: torus,
        fit_seconds,
    })
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
