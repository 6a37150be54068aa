//! Scene-level linear stability: builds the plant a scene names, linearizes it at the upright
//! equilibrium (exact dual-number Jacobian) and hands it to `linear` / `chart`. Quantization
//! and saturation are nonlinear effects and do not enter the linearization; integral action,
//! the delay and the sampling period do.

use crate::chart::{
    Axis, Chart, ChartError, Crossing, MAX_PANELS, Panel, assemble_panel, assemble_panel_with, classify,
    compute_chart_with, plant_chart, summarize,
};
use crate::closed_loop::{SimError, build_plant};
use crate::linear::{LinearError, LinearPlant, Multiplier};
use crate::plant::{Plant, linearize};
use crate::scene::Scene;
use crate::scene::axis::SceneAxis;
use rayon::prelude::*;
use shared::ControllerConfig;
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum StabilityError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("scene {scene}: {}{source}", key_prefix(.source))]
    Linear { scene: String, source: LinearError },
    #[error("scene {scene}: chart: {source}")]
    Chart { scene: String, source: ChartError },
    #[error("at {axis} = {value}: {source}")]
    AtPoint { axis: String, value: f64, source: Box<StabilityError> },
}

/// "`KEY`: " for an error caused by one scene key (see [`LinearError::scene_key`]).
fn key_prefix(e: &LinearError) -> String {
    e.scene_key().map(|k| format!("`{k}`: ")).unwrap_or_default()
}

fn lin<P: Plant<N>, const N: usize>(p: &P) -> Result<LinearPlant, LinearError> {
    let (a, b) = linearize(p);
    LinearPlant::new(&a, &b, P::PRIMARY, P::SECONDARY)
}

/// The continuous linearization of the scene's plant at the origin.
pub fn linear_plant(scene: &Scene) -> Result<LinearPlant, StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    crate::with_plant!(build_plant(scene)?, p => lin(&p).map_err(le))
}

/// Every closed-loop multiplier (structural 1 included), largest modulus first.
pub fn scene_multipliers(scene: &Scene) -> Result<Vec<Multiplier>, StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    linear_plant(scene)?.closed_loop(&scene.controller_config()).map_err(le)?.multipliers().map_err(le)
}

/// The non-structural multipliers with one entry per complex-conjugate pair (the one with
/// im >= 0), largest modulus first (all multipliers when the secondary coordinate enters the
/// dynamics: then there is no structural one).
pub fn dominant_pairs(scene: &Scene) -> Result<Vec<Multiplier>, StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    let map = linear_plant(scene)?.closed_loop(&scene.controller_config()).map_err(le)?;
    // A secondary coordinate that enters the dynamics (a plant written as equations whose
    // second coordinate is not cyclic), or that the law feeds back with a P gain, has no
    // structural multiplier 1 to remove.
    let all = match map.dominant_multipliers() {
        Err(LinearError::SecondaryCouples { .. } | LinearError::SecondaryControlled { .. }) => map.multipliers(),
        other => other,
    }
    .map_err(le)?;
    Ok(all.into_iter().filter(|m| m.im >= 0.0).collect())
}

/// The (KP, KD) stability chart of the scene's plant for several sampling periods (ms, as
/// on the command line), and the wall time of its computation in seconds.
pub fn scene_chart(
    scene: &Scene,
    dts_ms: &[f64],
    kp: (f64, f64, usize),
    kd: (f64, f64, usize),
) -> Result<(Chart, f64), StabilityError> {
    let ce = |source| StabilityError::Chart { scene: scene.name.clone(), source };
    let dts: Vec<f64> = dts_ms.iter().map(|&d| crate::units::ms_to_s(d)).collect();
    let cfg = scene.controller_config();
    fn go<P: Plant<N>, const N: usize>(
        p: &P,
        cfg: &shared::ControllerConfig,
        dts: &[f64],
        kp: (f64, f64, usize),
        kd: (f64, f64, usize),
    ) -> Result<(Chart, f64), ChartError> {
        let (a, b) = linearize(p);
        plant_chart(&a, &b, P::PRIMARY, P::SECONDARY, cfg, dts, kp, kd)
    }
    crate::with_plant!(build_plant(scene)?, p => go(&p, &cfg, &dts, kp, kd).map_err(ce))
}

/// The stability chart of the scene over any two of its quantities ([`SceneAxis`]: gains
/// or plant parameters) for several sampling periods (ms), and the wall time of its
/// computation in seconds. Over two gains the plant is linearized once and the D-curves are
/// drawn (the closed-loop map is affine in the gains); over a plant parameter every grid
/// point has its own linearization and there are no D-curves. The marked point is the
/// scene's own values.
pub fn scene_chart_axes(
    scene: &Scene,
    dts_ms: &[f64],
    (xa, xr): (&SceneAxis, Axis),
    (ya, yr): (&SceneAxis, Axis),
) -> Result<(Chart, f64), StabilityError> {
    let t0 = Instant::now();
    let ce = |source| StabilityError::Chart { scene: scene.name.clone(), source };
    let xr = xr.check(xa.name()).map_err(ce)?;
    let yr = yr.check(ya.name()).map_err(ce)?;
    if xa.same_quantity(ya) {
        return Err(ce(ChartError::BadAxis {
            axis: ya.name().into(),
            reason: "both axes set the same quantity".into(),
        }));
    }
    let dts: Vec<f64> = dts_ms.iter().map(|&d| crate::units::ms_to_s(d)).collect();
    if dts.is_empty() {
        return Err(ce(ChartError::NoPeriods));
    }
    if dts.len() > MAX_PANELS {
        return Err(ce(ChartError::TooManyPanels(dts.len())));
    }
    if let Some(&dt) = dts.iter().find(|dt| !(dt.is_finite() && **dt > 0.0)) {
        return Err(ce(ChartError::BadPeriod(dt)));
    }
    let base = scene.controller_config();
    let set = |c: &mut ControllerConfig, a: f64, b: f64| {
        xa.set_gain(c, a);
        ya.set_gain(c, b);
    };
    let mut chart = if xa.is_gain() && ya.is_gain() {
        let plant = linear_plant(scene)?;
        compute_chart_with(&plant, &base, &dts, (xr, xa.name()), (yr, ya.name()), &set).map_err(ce)?
    } else {
        let panels =
            dts.iter().map(|&dt| parameter_panel(scene, &base, dt, (xa, xr), (ya, yr))).collect::<Result<_, _>>()?;
        Chart { kp: xr, kd: yr, base, panels, names: None, base_point: None }
    };
    chart.names = Some([xa.name().into(), ya.name().into()]);
    chart.base_point = Some((xa.value(scene).map_err(SimError::from)?, ya.value(scene).map_err(SimError::from)?));
    Ok((chart, t0.elapsed().as_secs_f64()))
}

/// A chart panel over axes of which at least one is a plant parameter: one linearization
/// per distinct plant, every point classified as [`classify`] does.
fn parameter_panel(
    scene: &Scene,
    base: &ControllerConfig,
    dt: f64,
    (xa, xr): (&SceneAxis, Axis),
    (ya, yr): (&SceneAxis, Axis),
) -> Result<Panel, StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    // The plants: one per value of each parameter axis (a gain axis does not change it).
    let nx = if xa.is_gain() { 1 } else { xr.n };
    let ny = if ya.is_gain() { 1 } else { yr.n };
    let at = |axis: &SceneAxis, s: &Scene, v: f64| {
        axis.apply(s, v).map_err(|e| StabilityError::AtPoint {
            axis: axis.name().into(),
            value: v,
            source: Box::new(StabilityError::Sim(e.into())),
        })
    };
    let zoh_of = |k: usize| -> Result<crate::linear::Zoh, StabilityError> {
        let (i, j) = (k / nx, k % nx);
        let mut s = scene.clone();
        let mut point = Vec::new();
        if !xa.is_gain() {
            s = at(xa, &s, xr.at(j))?;
            point.push((xa.name(), xr.at(j)));
        }
        if !ya.is_gain() {
            s = at(ya, &s, yr.at(i))?;
            point.push((ya.name(), yr.at(i)));
        }
        let wrap = |e: StabilityError| {
            point.iter().rev().fold(e, |e, &(axis, value)| StabilityError::AtPoint {
                axis: axis.into(),
                value,
                source: Box::new(e),
            })
        };
        linear_plant(&s).and_then(|p| p.discretize(dt).map_err(le)).map_err(wrap)
    };
    let zohs =
        (0..nx * ny).into_par_iter().map(zoh_of).collect::<Vec<_>>().into_iter().collect::<Result<Vec<_>, _>>()?;
    let point = |i: usize, j: usize| -> Result<(f64, Option<Crossing>), StabilityError> {
        let zoh = &zohs[(if ya.is_gain() { 0 } else { i }) * nx + if xa.is_gain() { 0 } else { j }];
        let mut c = ControllerConfig { dt, ..*base };
        xa.set_gain(&mut c, xr.at(j));
        ya.set_gain(&mut c, yr.at(i));
        classify(zoh, &c).map_err(le)
    };
    let rows = (0..yr.n)
        .into_par_iter()
        .map(|i| (0..xr.n).map(|j| point(i, j)).collect::<Result<Vec<_>, _>>())
        .collect::<Vec<_>>();
    let points = rows.into_iter().collect::<Result<Vec<_>, _>>()?.concat();
    curveless_panel(scene, base, dt, xr, yr, points)
}

/// A panel without D-curves (an axis is a plant parameter) from its grid points.
fn curveless_panel(
    scene: &Scene,
    base: &ControllerConfig,
    dt: f64,
    xr: Axis,
    yr: Axis,
    points: Vec<(f64, Option<Crossing>)>,
) -> Result<Panel, StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    let (radius, unstable_kind): (Vec<f64>, Vec<Option<Crossing>>) = points.into_iter().unzip();
    let zoh = linear_plant(scene)?.discretize(dt).map_err(le)?;
    let (base_radius, _) = classify(&zoh, &ControllerConfig { dt, ..*base }).map_err(le)?;
    let summary = summarize(dt, xr, yr, &radius, &unstable_kind, base_radius);
    Ok(Panel { dt_s: dt, radius, unstable_kind, curves: Vec::new(), summary })
}

/// A chart panel of the scene over two named axes at `dt_ms` from grid points computed
/// elsewhere ([`scene_point`] of the scene with the axes set, e.g. by a sharded sweep;
/// `points[i * x.n + j]` at `(x.at(j), y.at(i))`): the panel [`scene_chart_axes`] computes.
pub fn scene_panel_axes(
    scene: &Scene,
    dt_ms: f64,
    (xa, xr): (&SceneAxis, Axis),
    (ya, yr): (&SceneAxis, Axis),
    points: &[(f64, Option<Crossing>)],
) -> Result<Panel, StabilityError> {
    let ce = |source| StabilityError::Chart { scene: scene.name.clone(), source };
    let base = scene.controller_config();
    let dt = crate::units::ms_to_s(dt_ms);
    if xa.is_gain() && ya.is_gain() {
        let set = |c: &mut ControllerConfig, a: f64, b: f64| {
            xa.set_gain(c, a);
            ya.set_gain(c, b);
        };
        let plant = linear_plant(scene)?;
        return assemble_panel_with(&plant, &base, dt, (xr, xa.name()), (yr, ya.name()), points, &set).map_err(ce);
    }
    let xr = xr.check(xa.name()).map_err(ce)?;
    let yr = yr.check(ya.name()).map_err(ce)?;
    if points.len() != xr.n * yr.n {
        return Err(ce(ChartError::BadAxis {
            axis: format!("{} x {}", xa.name(), ya.name()),
            reason: format!("{} points given for a {} x {} grid", points.len(), xr.n, yr.n),
        }));
    }
    curveless_panel(scene, &base, dt, xr, yr, points.to_vec())
}

/// One point of a stability chart at the scene's own gains and sampling period: the
/// spectral radius of the non-structural multipliers and, if it is at least 1, how the
/// largest one sits ([`classify`], the arithmetic of [`scene_chart`]'s grid points).
pub fn scene_point(scene: &Scene) -> Result<(f64, Option<Crossing>), StabilityError> {
    let le = |source| StabilityError::Linear { scene: scene.name.clone(), source };
    let cfg = scene.controller_config();
    let zoh = linear_plant(scene)?.discretize(cfg.dt).map_err(le)?;
    classify(&zoh, &cfg).map_err(le)
}

/// A chart panel of the scene's plant at `dt_ms` from grid points computed elsewhere
/// ([`scene_point`] per point, e.g. by a sharded sweep; `points[i * kp.n + j]` at
/// `(kp.at(j), kd.at(i))`): the D-curves and the summary are computed here.
pub fn scene_panel(
    scene: &Scene,
    dt_ms: f64,
    kp: Axis,
    kd: Axis,
    points: &[(f64, Option<Crossing>)],
) -> Result<Panel, StabilityError> {
    let ce = |source| StabilityError::Chart { scene: scene.name.clone(), source };
    let plant = linear_plant(scene)?;
    assemble_panel(&plant, &scene.controller_config(), crate::units::ms_to_s(dt_ms), kp, kd, points).map_err(ce)
}
