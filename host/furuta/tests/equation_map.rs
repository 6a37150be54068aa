//! The tests of `furuta::equation_map`.

use furuta::Error;
use furuta::equation_map::*;
use furuta::equation_ssm::furuta_graph_ssm;
use furuta::map_global::{ConnectionOptions, map_connection};
use nalgebra::Complex;
use ssm::dynamics::ReducedDynamics;
use ssm::dynamics::StepScratch;
use ssm::fit::SsmModel;
use ssm::interp::Interp;
use ssm::poly::PolyScratch;

/// Pinned values of [`golden_order5_connection_and_torus`] (ms, printed by it): the
/// connection bracket's midpoint and the torus growth onset, against regressions.
const GOLDEN_CONNECTION: f64 = 31.3234;
const GOLDEN_ONSET: f64 = 31.7072;
/// Pinned value of [`golden_order5_small_start_switch`] (ms, printed by it): the
/// bracket's midpoint, inside the full system's bracket.
const GOLDEN_SWITCH: f64 = 31.3359;

fn theta(m: &SsmModel, eta: &[f64]) -> f64 {
    let mut out = vec![0.0; 1];
    m.manifold.lift_into(eta, &mut PolyScratch::default(), &mut out);
    out[0]
}

/// The model's step is the graph-style SSM's `R` and its observable is `c . W`, to
/// rounding; one step of the model and one of the exact period-map expansion `F` agree in
/// theta to the invariance error `F(W(z)) - W(R(z))` on that radius (graph style: `U^T W(z)
/// = z`, so the reduced coordinates of `W(z)` are `z`).
#[test]
fn equation_map_is_the_reduced_map() {
    let (pm, s) = furuta_graph_ssm(31.0, 5).unwrap();
    let m = furuta_equation_map(31.0, 5).unwrap();
    assert_eq!((m.manifold.dim, m.manifold.p), (4, 1));
    assert_eq!(m.manifold.v1.iter().map(|x| (x * 1e12).round() / 1e12).collect::<Vec<_>>(), vec![1.0, 0.0, 1.0, 0.0]);
    // Graph style: no term removed, U^T W_m = 0.
    assert!(s.min_divisor.is_infinite());
    let map = furuta::equation_ssm::polynomial_map(&pm);
    let inv = s.invariance_error(&map, 5, 0.02, 8);
    eprintln!("graph-style invariance error at r = 0.02: {:.3e} (rel {:.3e})", inv.abs, inv.rel);
    let dt = m.dynamics.map_dt().unwrap();
    for (k, eta) in [[0.012, 0.005, 0.01, -0.004], [-0.003, 0.014, 0.006, 0.009]].iter().enumerate() {
        let z: Vec<Complex<f64>> =
            [Complex::new(eta[0], eta[1]), Complex::new(eta[2], eta[3])].iter().flat_map(|z| [*z, z.conj()]).collect();
        let w: Vec<f64> = s.manifold_at(&z, 5).iter().map(|x| x.re).collect();
        let rz = s.reduced_at(&z, 5);
        let mut e = eta.to_vec();
        m.dynamics.step(&mut e, dt, &mut StepScratch::default());
        let want = [rz[0].re, rz[0].im, rz[2].re, rz[2].im];
        for i in 0..4 {
            assert!((e[i] - want[i]).abs() < 1e-14, "{k} {i}: {} vs {}", e[i], want[i]);
        }
        assert!((theta(&m, eta) - w[pm.primary]).abs() < 1e-15);
        let fw = pm.eval(&w).unwrap();
        let d = (theta(&m, &e) - fw[pm.primary]).abs();
        eprintln!("start {k}: |theta(R) - theta(F(W))| = {d:.3e}");
        assert!(d <= inv.abs, "{d} vs {}", inv.abs);
    }
}

/// Known answers of the start projection at 31.0 ms: (a) a start on the linear modes
/// with amplitudes `rho` and phases `p` ([`furuta::full_system::start_from_rho`]) has `z_j =
/// rho_j e^{i p_j}` (theta = `Re z_1 + Re z_2` at linear order, mode 1 slow); (b) the left
/// eigenvectors from the exact linear map equal the order-5 graph SSM's own to 1e-9
/// (relative); (c) a start exactly on the manifold, `s = W(z0)` given as a plant state and
/// pre-history, projects to `z0`, and the map's theta series from there equals that of
/// the period map's expansion `F` iterated from `s` and that of the full system run from
/// the start (the layout of the deflated coordinates) over 100 periods, to the stated
/// tolerance 1e-7 rad (the differences, printed, are the order-5 truncation; a wrong
/// layout of the pre-history moves theta by O(rho) = 1e-2).
#[test]
fn start_projection_known_answers() {
    let dt = 31.0;
    let proj = StartProjection::furuta(dt).unwrap();
    assert_eq!(proj.delay, 1);
    for (rho, ph) in [([0.03, 0.01], [0.0, 0.0]), ([0.02, 0.005], [0.7, -1.2]), ([0.0, 0.02], [0.0, 2.0])] {
        let (x, h) = furuta::full_system::start_from_rho(dt, rho, ph).unwrap();
        let eta = proj.eta(&(x, Some(h))).unwrap();
        let want = [rho[0] * ph[0].cos(), rho[0] * ph[0].sin(), rho[1] * ph[1].cos(), rho[1] * ph[1].sin()];
        let err = eta.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        eprintln!("mode start rho {rho:?} phases {ph:?}: eta {eta:?}, error {err:.2e}");
        assert!(err < 1e-12, "{eta:?} vs {want:?}");
    }
    let (pm, s) = furuta_graph_ssm(dt, 5).unwrap();
    let unorm = s.left.iter().flatten().fold(0.0f64, |m, &(a, b)| m.max(a.hypot(b)));
    let du = [0usize, 2].iter().flat_map(|&j| s.left[j].iter().enumerate().map(move |(k, &(a, b))| (j, k, a, b))).fold(
        0.0f64,
        |m, (j, k, a, b)| {
            let r = &proj.rows[j];
            m.max((r[k] - a).abs()).max((proj.rows[j + 1][k] - b).abs())
        },
    );
    eprintln!("left eigenvectors: exact linear map vs the SSM's: {:.2e} (relative)", du / unorm);
    assert!(du / unorm < 1e-9);
    // A point on the manifold as a full-system start (phi = 0.3 rad, any: phi is cyclic).
    let z0 = [Complex::new(0.02, 0.008), Complex::new(0.012, -0.006)];
    let z: Vec<Complex<f64>> = z0.iter().flat_map(|z| [*z, z.conj()]).collect();
    let w: Vec<f64> = s.manifold_at(&z, 5).iter().map(|x| x.re).collect();
    assert_eq!(pm.names, ["x0", "x1", "x3", "y[i-1]", "y[i-2]", "z[i-1]-x2", "z[i-2]-x2"]);
    let phi = 0.3;
    let start: furuta::full_system::Start =
        ([w[0], w[1], phi, w[2]], Some(vec![[w[4], w[6] + phi], [w[3], w[5] + phi]]));
    let back = proj.deflated(&start).unwrap();
    assert!(back.iter().zip(&w).all(|(a, b)| (a - b).abs() < 1e-15), "{back:?} vs {w:?}");
    assert_eq!(proj.deflated(&furuta::map_global::start_of_deflated(&w).unwrap()).unwrap(), w);
    let eta = proj.eta(&start).unwrap();
    let want = [z0[0].re, z0[0].im, z0[1].re, z0[1].im];
    let err = eta.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    eprintln!("manifold start: eta error {err:.2e}");
    assert!(err < 1e-10, "{eta:?} vs {want:?}");
    let m = furuta_equation_map(dt, 5).unwrap();
    let n = 100;
    let step = m.dynamics.map_dt().unwrap();
    let mut e = eta.clone();
    let mut sf = w.clone();
    let full = furuta::full_system::run(dt, &start, n, 10.0).unwrap().primary();
    let (mut d_f, mut d_full, mut amp) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..=n as usize {
        let th = theta(&m, &e);
        d_f = d_f.max((th - sf[0]).abs());
        d_full = d_full.max((th - full[k]).abs());
        amp = amp.max(th.abs());
        m.dynamics.step(&mut e, step, &mut StepScratch::default());
        sf = pm.eval(&sf).unwrap();
    }
    eprintln!("theta over {n} periods (max |theta| {amp:.4}): map vs F {d_f:.2e}, map vs full system {d_full:.2e}");
    assert!(d_f < 1e-7 && d_full < 1e-7, "{d_f} {d_full}");
    // Refused: a start with the wrong pre-history length; a map at another dt.
    assert!(matches!(
        proj.eta(&([0.01, 0.0, 0.0, 0.0], Some(vec![[0.0, 0.0]]))),
        Err(Error::BadInput { what: "start", .. })
    ));
    let other = furuta_equation_map(31.5, 5).unwrap();
    assert!(matches!(
        equation_map_outcome(&other, &proj, &start, 10, 1.0),
        Err(Error::BadInput { what: "projection", .. })
    ));
}

/// Golden value, order 5 on 5 nodes (spline), the fitted map's settings (the full
/// system's starts, 8000 periods, grid of 11 on [31.0, 32.0] ms, bisection to 0.005 ms):
/// the equation map's small-start switch ([`GOLDEN_SWITCH`], within 0.005 ms); the
/// normal-form-style family is refused (its reduced coordinates are not `U^T s`).
#[test]
fn golden_order5_small_start_switch() {
    let fam = EquationMapFamily::furuta(&[30.5, 31.0, 31.5, 32.0, 32.5], 5).unwrap();
    let t0 = std::time::Instant::now();
    let sw = equation_map_switch(
        &fam,
        Interp::Spline,
        furuta::full_system::default_ics,
        (31.0, 32.0, 11, 0.005),
        furuta::full_system::DEFAULT_SCAN_PERIODS,
    )
    .unwrap();
    eprintln!("order 5 switch: {sw:?} ({:.1} s)", t0.elapsed().as_secs_f64());
    let (a, b) = sw.bracket.unwrap();
    assert!(b - a <= 0.005 + 1e-12);
    assert!((0.5 * (a + b) - GOLDEN_SWITCH).abs() < 0.005, "{a} {b}");
    assert!(sw.monotone);
    let nf = EquationMapFamily::furuta_styled(&[30.5, 31.0], 5, MapStyle::NormalForm).unwrap();
    assert!(matches!(
        equation_map_switch(&nf, Interp::Spline, furuta::full_system::default_ics, (30.5, 31.0, 3, 0.005), 10),
        Err(Error::BadInput { what: "family", .. })
    ));
}

/// Measurement (not a check): the equation map's small-start switch at orders 5, 7, 9
/// with the full report's nodes (9, 30.5..32.5 ms, spline) and the fitted map's settings;
/// per start, the first escaping grid dt.
#[test]
#[ignore]
fn measure_equation_map_switch() {
    let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
    let orders: Vec<u32> = std::env::var("EQMAP_ORDERS")
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![5, 7, 9]);
    for order in orders {
        let t0 = std::time::Instant::now();
        let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
        let sw = equation_map_switch(
            &fam,
            Interp::Spline,
            furuta::full_system::default_ics,
            (31.0, 32.0, 11, 0.005),
            furuta::full_system::DEFAULT_SCAN_PERIODS,
        )
        .unwrap();
        eprintln!("order {order}: {sw:?} ({:.1} s)", t0.elapsed().as_secs_f64());
    }
}

/// Measurement (not a check): per start, the escape time (s) of the full system and of the
/// order-`EQMAP_ORDER` (default 7) equation map (9 nodes, spline) at dt in `EQMAP_DTS`
/// (default 31.33..31.36 ms), 8000 periods: which start switches first and how its escape
/// time differs, to place the full system's switch inside its coarse grid bracket.
#[test]
#[ignore]
fn measure_switch_starts() {
    let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
    let order: u32 = std::env::var("EQMAP_ORDER").map(|s| s.parse().unwrap()).unwrap_or(7);
    let dts: Vec<f64> = std::env::var("EQMAP_DTS")
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![31.33, 31.335, 31.34, 31.3425, 31.345, 31.35, 31.36]);
    let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
    let periods = furuta::full_system::DEFAULT_SCAN_PERIODS;
    for &dt in &dts {
        let ics = furuta::full_system::default_ics(dt).unwrap();
        let m = fam.model_at(dt, Interp::Spline).unwrap();
        let proj = StartProjection::furuta(dt).unwrap();
        let full = furuta::full_system::switch_scan(&[dt], &ics, periods, furuta::full_system::ESCAPE_THETA).unwrap();
        let map: Vec<_> = ics
            .iter()
            .map(|ic| equation_map_outcome(&m, &proj, ic, periods, furuta::full_system::ESCAPE_THETA).unwrap())
            .collect();
        let t = |e: Option<f64>| e.map_or("-".to_string(), |t| format!("{t:.1}"));
        eprintln!(
            "dt {dt}: escape t full [{}], map [{}]",
            full.outcomes[0].iter().map(|o| t(o.escape_t)).collect::<Vec<_>>().join(", "),
            map.iter().map(|o| t(o.escape_t)).collect::<Vec<_>>().join(", ")
        );
    }
}

/// At a node the interpolated family is that node's map (to 1e-12, spline and linear);
/// between nodes the step stays within 1e-3 relative of the map computed there.
#[test]
fn family_interpolates_the_node_maps() {
    let fam = EquationMapFamily::furuta(&[30.5, 31.0, 31.5, 32.0], 5).unwrap();
    let inc = |m: &SsmModel| match &m.dynamics {
        ReducedDynamics::Map { increment, .. } => increment.coef.clone(),
        _ => panic!("not a map"),
    };
    for interp in [Interp::Linear, Interp::Spline] {
        let at = fam.model_at(31.0, interp).unwrap();
        let node = &fam.maps[1];
        let err = inc(&at).iter().zip(inc(node)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let err_obs = at
            .manifold
            .nonlinear
            .as_ref()
            .unwrap()
            .coef
            .iter()
            .zip(&node.manifold.nonlinear.as_ref().unwrap().coef)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12 && err_obs < 1e-12, "{interp:?}: {err} {err_obs}");
        assert_eq!(at.dynamics.map_dt(), node.dynamics.map_dt());
    }
    let direct = furuta_equation_map(31.25, 5).unwrap();
    let mid = fam.model_at(31.25, Interp::Spline).unwrap();
    let eta = [0.05, 0.02, 0.02, -0.01];
    let dt = mid.dynamics.map_dt().unwrap();
    let (mut a, mut b) = (eta.to_vec(), eta.to_vec());
    mid.dynamics.step(&mut a, dt, &mut StepScratch::default());
    direct.dynamics.step(&mut b, dt, &mut StepScratch::default());
    let rel = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / 0.05;
    eprintln!("spline step at 31.25 ms vs direct: {rel:.2e}");
    assert!(rel < 1e-3, "{rel}");
    assert!(matches!(fam.model_at(33.0, Interp::Linear), Err(_)));
    assert!(matches!(EquationMapFamily::furuta(&[31.0], 5), Err(Error::BadOption { what: "nodes_ms", .. })));
}

/// Golden values, order 5 on 5 nodes (spline): the graph-style map's saddle connection
/// by the fitted map's rule falls in the full system's bracket region (the full report's
/// bifurcation table) and its torus growth onset near the full system's; the
/// normal-form-style map of the same SSM (phases averaged) connects more than 0.1 ms away
/// (the normal form's truncation, not the map). The values are printed.
#[test]
fn golden_order5_connection_and_torus() {
    let nodes = [30.5, 31.0, 31.5, 32.0, 32.5];
    let co = ConnectionOptions::default();
    let torus_dts: Vec<f64> = (0..=6).map(|k| ((31.6 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    let graph = EquationMapFamily::furuta(&nodes, 5).unwrap();
    let g =
        equation_map_global(&graph, Interp::Spline, (31.2, 31.6, 3, 0.005), &co, &torus_dts, [0.097, 0.0277], 16_000);
    let nf = EquationMapFamily::furuta_styled(&nodes, 5, MapStyle::NormalForm).unwrap();
    let n = map_connection(|dt| nf.model_at(dt, Interp::Spline), 31.0, 31.4, 3, 0.005, &co).unwrap();
    let gb = g.connection.as_ref().unwrap().switch.bracket.unwrap();
    let t = g.torus.as_ref().unwrap();
    let nb = n.switch.bracket.unwrap();
    eprintln!(
        "graph: connection {gb:?}, torus lost {:?}, onset {:?}; normal-form map: connection {nb:?}",
        t.lost_between, t.growth_onset
    );
    assert!(gb.1 - gb.0 <= 0.005 + 1e-12);
    assert!((0.5 * (gb.0 + gb.1) - GOLDEN_CONNECTION).abs() < 0.01, "{gb:?}");
    assert_eq!(t.lost_between, Some((31.8, 31.85)));
    assert!((t.growth_onset.unwrap() - GOLDEN_ONSET).abs() < 0.01, "{:?}", t.growth_onset);
    assert!((0.5 * (nb.0 + nb.1) - 0.5 * (gb.0 + gb.1)).abs() > 0.1, "{nb:?} {gb:?}");
}

/// Measurement (not a check): the equation map's connection and torus loss at orders
/// 5, 7, 9 with the full report's settings (9 nodes 30.5..32.5 ms, spline).
#[test]
#[ignore]
fn measure_equation_map_by_order() {
    let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
    let torus_dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    let orders: Vec<u32> = std::env::var("EQMAP_ORDERS")
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![5, 7, 9]);
    for order in orders {
        let t0 = std::time::Instant::now();
        let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
        let t1 = t0.elapsed().as_secs_f64();
        let g = equation_map_global(
            &fam,
            Interp::Spline,
            (31.0, 32.0, 6, 0.005),
            &ConnectionOptions::default(),
            &torus_dts,
            [0.097, 0.0277],
            16_000,
        );
        let c = g.connection.as_ref().map(|c| (c.switch.bracket, c.switch.grid.clone()));
        let t = g.torus.as_ref().map(|t| {
            (
                t.lost_between,
                t.growth_onset,
                t.steps.iter().map(|s| (s.dt_ms, s.rho, s.growth_rate, s.lost)).collect::<Vec<_>>(),
            )
        });
        eprintln!(
            "order {order}: family {t1:.1} s, total {:.1} s\n connection {c:?}\n torus {t:?}",
            t0.elapsed().as_secs_f64()
        );
    }
}

/// Measurement (not a check): at order 7, what separates the polar normal form from the
/// map. (a) The normal-form-style reduced map iterated (same SSM as the polar form, phases
/// averaged at every order, no map-to-flow step) by the same rules; (b) at a few dt: the
/// fast saddle cycle's theta amplitude of the graph map, of the normal-form map, of the
/// polar form (`saddle_cycles`' equation row) and of the full system.
#[test]
#[ignore]
fn measure_polar_vs_map() {
    use furuta::map_global::map_fast_circle;
    let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
    let torus_dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    let order: u32 = std::env::var("EQMAP_ORDER").map(|s| s.parse().unwrap()).unwrap_or(7);
    let co = ConnectionOptions::default();
    let nf = EquationMapFamily::furuta_styled(&nodes, order, MapStyle::NormalForm).unwrap();
    let graph = EquationMapFamily::furuta(&nodes, order).unwrap();
    for dt in [31.0, 31.3, 31.45] {
        let g = map_fast_circle(&graph.model_at(dt, Interp::Spline).unwrap(), &co).unwrap();
        let n = map_fast_circle(&nf.model_at(dt, Interp::Spline).unwrap(), &co).unwrap();
        let rows = furuta::saddle_cycles::saddle_cycles(&[dt], 2, &[order], &co.circle).unwrap();
        let eq = &rows[0].equation[0];
        let full = rows[0].full.as_ref().map(|c| c.theta_amplitude);
        eprintln!(
            "dt {dt}: fast cycle theta amplitude: graph map {:.6} ({:.4} Hz), normal-form map {:.6} ({:.4} Hz), polar form rho {:?} theta {:?} ({:?} Hz), full {full:?}",
            g.theta_amplitude, g.freq_hz, n.theta_amplitude, n.freq_hz, eq.rho, eq.theta_amplitude, eq.freq_hz
        );
        let pf = furuta::equation_ssm::furuta_equation_polar(dt, order).unwrap();
        let popts = ssm::portrait::PortraitOptions {
            rho_max: furuta::bifurcations::RHO_MAX,
            ..ssm::portrait::PortraitOptions::default()
        };
        let fps = ssm::portrait::fixed_points(&pf, &popts).unwrap();
        eprintln!("  polar fixed points: {:?}", fps.iter().map(|f| (f.kind, f.rho)).collect::<Vec<_>>());
    }
    let g = equation_map_global(&nf, Interp::Spline, (31.0, 32.0, 6, 0.005), &co, &torus_dts, [0.097, 0.0277], 16_000);
    let c = g.connection.as_ref().map(|c| (c.switch.bracket, c.switch.grid.clone()));
    let t = g.torus.as_ref().map(|t| {
        (
            t.lost_between,
            t.growth_onset,
            t.steps.iter().map(|s| (s.dt_ms, s.rho, s.growth_rate, s.lost)).collect::<Vec<_>>(),
        )
    });
    eprintln!("normal-form map, order {order}:\n connection {c:?}\n torus {t:?}");
}
