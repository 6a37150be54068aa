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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop::simulate;

    fn scene(name: &str, o: &[&str]) -> Scene {
        Scene::load(name, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
    }

    /// The simulator at small amplitude follows the exact ZOH linear map of the delayed loop
    /// (an exact reference: `crate::linear`), sample by sample.
    #[test]
    fn small_amplitude_run_follows_the_exact_linear_map() {
        for dt in ["25", "30.8", "32.3"] {
            let s = scene(
                &format!("furuta-dt{dt}"),
                &["run.periods=80", "initial.state=[1e-6,0,0,0]", "integrator.rtol=1e-12", "integrator.atol=1e-18"],
            );
            let tr = simulate(&s, None).unwrap();
            let map = linear_plant(&s).unwrap().closed_loop(&s.controller_config()).unwrap();
            let l = &map.layout;
            let mut st = nalgebra::DVector::<f64>::zeros(l.dim);
            st[0] = 1e-6;
            for k in 0..=l.delay {
                st[l.y_start + k] = 1e-6; // at rest at theta0 before t = 0
            }
            let mut worst = 0.0_f64;
            let mut scale = 0.0_f64;
            for i in 0..tr.rows() {
                worst = worst.max((tr.state(i, 0) - st[0]).abs());
                scale = scale.max(st[0].abs());
                st = &map.matrix * st;
            }
            // Nonlinear terms are O(theta^2) ~ 1e-12 relative 1e-6; integrator rtol 1e-12.
            assert!(worst < 1e-5 * scale, "dt {dt}: deviation {worst:e} vs amplitude {scale:e}");
        }
    }

    /// A chart assembled from points computed one by one (a sharded sweep's cells) is the
    /// chart computed in one piece, bit for bit: radius, kinds, D-curves and summary.
    #[test]
    fn points_one_by_one_assemble_the_same_chart() {
        let base = scene("furuta-dt25", &[]);
        let (kp, kd) = ((0.0, 40.0, 5), (0.0, 8.0, 4));
        let (chart, _) = scene_chart(&base, &[25.0, 30.8], kp, kd).unwrap();
        for (dt_ms, panel) in [25.0, 30.8].into_iter().zip(&chart.panels) {
            let mut points = Vec::new();
            for i in 0..kd.2 {
                for j in 0..kp.2 {
                    let s = base.clone().builder().dt_ms(dt_ms).kp(chart.kp.at(j)).kd(chart.kd.at(i)).build().unwrap();
                    points.push(scene_point(&s).unwrap());
                }
            }
            let assembled = scene_panel(&base, dt_ms, chart.kp, chart.kd, &points).unwrap();
            assert_eq!(&assembled, panel, "dt {dt_ms}");
        }
        let short = scene_panel(&base, 25.0, chart.kp, chart.kd, &[(0.5, None)]).unwrap_err().to_string();
        assert!(short.contains("1 points given for a 5 x 4 grid"), "{short}");
    }

    /// The chart over named axes: `kp`, `kd` by name is the classic chart (same grid and
    /// D-curves); over a gain pair of the cart-pole and over a plant parameter each grid point
    /// is the multipliers of the scene with that value set as a `--set` override.
    #[test]
    fn named_axes_charts_match_point_by_point_overrides() {
        let f = scene("furuta-dt25", &[]);
        let (kp, kd) = ((0.0, 40.0, 5), (0.0, 8.0, 4));
        let (classic, _) = scene_chart(&f, &[25.0], kp, kd).unwrap();
        let ax = |s: &Scene, n: &str| SceneAxis::parse(s, n).unwrap();
        let (named, _) =
            scene_chart_axes(&f, &[25.0], (&ax(&f, "theta.p"), kp.into()), (&ax(&f, "kd"), kd.into())).unwrap();
        assert_eq!(named.panels, classic.panels);
        assert_eq!(named.base_point, Some((15.5, 5.45)));

        let c = scene("cartpole-pd", &[]);
        let (x, y): (Axis, Axis) = ((-30.0, -10.0, 3).into(), (-20.0, -10.0, 3).into());
        let (chart, _) = scene_chart_axes(&c, &[10.0], (&ax(&c, "x.p"), x), (&ax(&c, "x.d"), y)).unwrap();
        let panel = &chart.panels[0];
        assert!(!panel.curves.is_empty());
        for i in 0..3 {
            for j in 0..3 {
                let o = [format!("controller.gains.x.p={}", x.at(j)), format!("controller.gains.x.d={}", y.at(i))];
                let (r, _) = scene_point(&Scene::load("cartpole-pd", &o).unwrap()).unwrap();
                assert_eq!(panel.radius[i * 3 + j], r, "x.p {} x.d {}", x.at(j), y.at(i));
            }
        }
        // On a D-curve a multiplier is on the unit circle.
        for curve in &panel.curves {
            let (p, d) = curve.points[curve.points.len() / 2];
            let o = [format!("controller.gains.x.p={p}"), format!("controller.gains.x.d={d}")];
            let s = Scene::load("cartpole-pd", &o).unwrap();
            let ms = scene_multipliers(&s).unwrap();
            let near = ms.iter().map(|m| (m.abs - 1.0).abs()).fold(f64::INFINITY, f64::min);
            assert!(near < 1e-6, "{:?} at ({p}, {d}): closest |mu| - 1 = {near:e}", curve.kind);
        }

        let p = scene("pendulum-pd", &[]);
        let (m, g): (Axis, Axis) = ((0.1, 0.5, 3).into(), (2.0, 4.0, 3).into());
        let (chart, _) = scene_chart_axes(&p, &[20.0], (&ax(&p, "plant.parameters.m"), m), (&ax(&p, "kp"), g)).unwrap();
        assert!(chart.panels[0].curves.is_empty());
        for i in 0..3 {
            for j in 0..3 {
                let o = [format!("plant.parameters.m={}", m.at(j)), format!("controller.kp={}", g.at(i))];
                let (r, _) = scene_point(&Scene::load("pendulum-pd", &o).unwrap()).unwrap();
                assert_eq!(chart.panels[0].radius[i * 3 + j], r);
            }
        }
        // A plant that is invalid at a grid point is an error naming the axis value.
        let e =
            scene_chart_axes(&c, &[10.0], (&ax(&c, "plant.parameters.M"), (-1.0, 1.0, 3).into()), (&ax(&c, "x.d"), y))
                .unwrap_err()
                .to_string();
        assert!(e.contains("plant.parameters.M = -1"), "{e}");
    }
}
