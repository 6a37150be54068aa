use sim::chart::Axis;
use sim::closed_loop::simulate;
use sim::scene::Scene;
use sim::scene::axis::SceneAxis;
use sim::stability::*;

fn scene(name: &str, o: &[&str]) -> Scene {
    Scene::load(name, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
}

/// The simulator at small amplitude follows the exact ZOH linear map of the delayed loop
/// (an exact reference: `sim::linear`), sample by sample.
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
    let e = scene_chart_axes(&c, &[10.0], (&ax(&c, "plant.parameters.M"), (-1.0, 1.0, 3).into()), (&ax(&c, "x.d"), y))
        .unwrap_err()
        .to_string();
    assert!(e.contains("plant.parameters.M = -1"), "{e}");
}
