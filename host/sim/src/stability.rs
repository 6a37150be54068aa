//! Scene-level linear stability: builds the plant a scene names, linearizes it at the upright
//! equilibrium (exact dual-number Jacobian) and hands it to `linear` / `chart`. Quantization
//! and saturation are nonlinear effects and do not enter the linearization; integral action,
//! the delay and the sampling period do.

use crate::chart::{Axis, Chart, ChartError, Crossing, Panel, assemble_panel, classify, plant_chart};
use crate::closed_loop::{SimError, build_plant};
use crate::linear::{LinearError, LinearPlant, Multiplier};
use crate::plant::{Plant, linearize};
use crate::scene::Scene;

#[derive(Debug, thiserror::Error)]
pub enum StabilityError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("scene {scene}: {}{source}", key_prefix(.source))]
    Linear { scene: String, source: LinearError },
    #[error("scene {scene}: chart: {source}")]
    Chart { scene: String, source: ChartError },
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
}
