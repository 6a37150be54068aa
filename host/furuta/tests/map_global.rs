//! The tests of `furuta::map_global`.

use furuta::Error;
use furuta::basin::{BasinOptions, TorusContinuation};
use furuta::basin::{agreement, full_basin};
use furuta::bifurcations::map_outcome;
use furuta::full_system::{ESCAPE_THETA, run, start_from_rho};
use furuta::map_global::*;
use furuta::parametric::FurutaOptions;
use furuta::shared_tangent::SharedParametricModel;
use nalgebra::{Complex, DMatrix};
use sim::chart::Axis;
use ssm::interp::Interp;
use std::sync::OnceLock;

type C = Complex<f64>;

/// The report's shared-tangent model (default training options), fitted once per test
/// process (`crate::shared_tangent::test_model`).
fn model() -> &'static SharedParametricModel {
    crate::shared_tangent::test_model()
}

/// The report model's torus continuation on the report's quick grid (31.4-32.0 ms by 0.1,
/// 8,000 periods, linear in dt), computed once for the two tests that check it.
fn model_torus() -> &'static TorusContinuation {
    static T: OnceLock<TorusContinuation> = OnceLock::new();
    T.get_or_init(|| {
        let dts: Vec<f64> = (0..=6).map(|k| ((31.4 + 0.1 * k as f64) * 1e4).round() / 1e4).collect();
        map_torus_continuation(|dt| Ok(model().model_at(dt, Interp::Linear)?), &dts, [0.097, 0.0277], 8000).unwrap()
    })
}

/// A deflated state of the exact period map and the full-system start made of it agree:
/// one simulated period from the start lands on the exact map's image (plant state, with
/// phi = 0 at the start; the deflated `w_phi` and stored samples shift with phi).
#[test]
fn deflated_state_is_the_full_system_start() {
    let dt_ms = 31.3;
    let scene = furuta::full_system::scene_at(dt_ms).unwrap();
    let ex = furuta::convergence::ExactMap::new(&scene, 3).unwrap();
    assert_eq!(ex.dim(), 7);
    let s = [0.03, -0.1, 0.05, 0.025, 0.02, -0.01, 0.004];
    let (x, h) = start_of_deflated(&s).unwrap();
    let h = h.unwrap();
    assert_eq!(x, [0.03, -0.1, 0.0, 0.05]);
    // Oldest first: [y_{i-2}, z_{i-2}], [y_{i-1}, z_{i-1}].
    assert_eq!(h, vec![[0.02, 0.004], [0.025, -0.01]]);
    let img = ex.eval(&s).unwrap();
    let tr = run(dt_ms, &(x, Some(h)), 1, ESCAPE_THETA).unwrap();
    let phi1 = tr.state(1, 2);
    // theta, w_theta, w_phi after one period; the newest stored sample is theta at the start;
    // w_0 = z_i - phi_{i+1} = 0 - phi1.
    let want = [tr.state(1, 0), tr.state(1, 1), tr.state(1, 3), 0.03, 0.025, -phi1, -0.01 - phi1];
    for (k, (a, b)) in img.iter().zip(&want).enumerate() {
        assert!((a - b).abs() < 1e-7, "component {k}: exact map {a}, simulator {b}");
    }
    assert!(matches!(start_of_deflated(&[0.0; 6]), Err(Error::BadInput { .. })));
}

/// The eigenvector helper on a known block matrix: rotation by 0.1 (modulus 1.01) and by 1.6
/// (modulus 0.99) plus a tiny real mode; the slow multiplier is `1.01 e^{0.1 i}` and the
/// pushed displacement `2 Re(v z)` has theta (`row . x`) equal to `Re z`.
#[test]
fn slow_eigenvector_of_a_block_matrix() {
    let rot = |r: f64, a: f64| [[r * a.cos(), -r * a.sin()], [r * a.sin(), r * a.cos()]];
    let (s, f) = (rot(1.01, 0.1), rot(0.99, 1.6));
    let mut a = DMatrix::<f64>::zeros(5, 5);
    for i in 0..2 {
        for j in 0..2 {
            a[(i, j)] = s[i][j];
            a[(2 + i, 2 + j)] = f[i][j];
        }
    }
    a[(4, 4)] = 1e-3;
    let mu = slow_multiplier(&a).unwrap();
    assert!((mu - C::from_polar(1.01, 0.1)).norm() < 1e-12, "{mu}");
    let row = [1.0, 0.0, 1.0, 0.0, 0.0];
    let v = eigenvector(&a, mu, &row).unwrap();
    // An eigenvector: A v = mu v.
    for i in 0..5 {
        let av: C = (0..5).map(|j| v[j] * a[(i, j)]).sum();
        assert!((av - mu * v[i]).norm() < 1e-9, "row {i}");
    }
    assert!(v[2].norm() < 1e-9 && v[3].norm() < 1e-9 && v[4].norm() < 1e-9);
    let z = C::from_polar(1e-3, 0.7);
    let theta: f64 = (0..5).map(|i| row[i] * 2.0 * (v[i] * z).re).sum();
    assert!((theta - z.re).abs() < 1e-15, "{theta}");
}

/// The fitted map's fast circle and the rule's verdicts on both sides of the connection: at 31.1 ms
/// every pushed start stays bounded, at 31.6 ms they escape, on the map and on the full
/// system; the fast circles agree to 2 % in theta amplitude.
#[test]
fn connection_rule_brackets_on_the_map_and_the_full_system() {
    let o = ConnectionOptions::default();
    let sm = model();
    let mut amps = Vec::new();
    for (dt, bounded) in [(31.1, true), (31.6, false)] {
        let m = map_connection_fates(&sm.model_at(dt, Interp::Linear).unwrap(), dt, &o).unwrap();
        let f = full_connection_fates(dt, &o).unwrap();
        eprintln!("{dt}: map {m:?}\n      full {f:?}");
        assert_eq!(m.outcomes.len(), 4);
        assert!(m.escapes().iter().all(|&e| e != bounded), "map at {dt}: {m:?}");
        assert!(f.escapes().iter().all(|&e| e != bounded), "full at {dt}: {f:?}");
        assert!(m.circle_residual <= 1e-10 && f.circle_residual <= 1e-10);
        assert!(
            (m.circle_theta_amplitude / f.circle_theta_amplitude - 1.0).abs() < 0.02,
            "{} {}",
            m.circle_theta_amplitude,
            f.circle_theta_amplitude
        );
        amps.push(f.circle_theta_amplitude);
    }
    // The full system's fast cycle at 31.3 ms (saddle_cycles' test pins it) lies between: it grows with dt.
    assert!(amps[0] < 0.0695 && amps[1] > 0.0695, "{amps:?}");
    let bad = ConnectionOptions { push: 0.0, ..o };
    assert!(matches!(
        map_connection_fates(&sm.model_at(31.3, Interp::Linear).unwrap(), 31.3, &bad),
        Err(Error::BadOption { what: "push", .. })
    ));
    assert!(matches!(
        map_connection_fates(&sm.model_at(31.3, Interp::Linear).unwrap(), 31.4, &o),
        Err(Error::BadInput { what: "dt_ms", .. })
    ));
}

/// The map's verdict on a small basin grid at 31.5 ms against the full system's: the same
/// cell order (each cell is `map_outcome` from the mode start), and disagreement on at most
/// one cell of nine.
#[test]
fn map_basin_agrees_with_the_full_system_on_a_small_grid() {
    let o = BasinOptions {
        dts_ms: vec![31.5],
        rho1: Axis { lo: 0.02, hi: 0.2, n: 3 },
        rho2: Axis { lo: 0.01, hi: 0.1, n: 3 },
        phases: [0.0, 0.0],
        periods: 1500,
        method: None,
    };
    let at = |dt: f64| Ok(model().model_at(dt, Interp::Linear)?);
    let mb = map_basin(at, &o).unwrap();
    let full = full_basin(&o).unwrap().bounded_at(0);
    assert_eq!((mb.len(), mb[0].len()), (1, 9));
    let (r1, r2) = o.values();
    let m = at(31.5).unwrap();
    for (i, &x) in r1.iter().enumerate() {
        for (j, &y) in r2.iter().enumerate() {
            let (s, h) = start_from_rho(31.5, [x, y], o.phases).unwrap();
            assert_eq!(mb[0][i * 3 + j], map_outcome(&m, 31.5, &(s, Some(h)), 1500, ESCAPE_THETA).unwrap().bounded());
        }
    }
    let fates: Vec<furuta::basin::ModelFate> = mb[0]
        .iter()
        .map(|&b| if b { furuta::basin::ModelFate::Principal } else { furuta::basin::ModelFate::LeavesBox })
        .collect();
    let a = agreement(&fates, &full).unwrap();
    eprintln!("map {:?}\nfull {full:?}\n{a:?}", mb[0]);
    assert!(full.contains(&true) && full.contains(&false), "{full:?}");
    assert!(a.model_bounded_full_escaped + a.model_escaped_full_bounded <= 1, "{a:?}");
}

/// The map's torus continuation from 31.4 ms: attracting at 31.4 ms near the full system's
/// torus, lost by 31.9 ms (the continuation stops at the first step that loses it, so the
/// quick grid's longer tail changes nothing before); bad grids refused.
#[test]
fn map_torus_continuation_loses_the_torus_on_the_grid() {
    let at = |dt: f64| Ok(model().model_at(dt, Interp::Linear)?);
    let c = model_torus();
    eprintln!("{c:?}");
    let first = &c.steps[0];
    assert!(!first.lost);
    let rho = first.rho.unwrap();
    assert!((0.05..0.15).contains(&rho[0]) && (0.01..0.05).contains(&rho[1]), "{rho:?}");
    let (a, b) = c.lost_between.unwrap();
    assert!(31.5 <= a && b <= 31.9, "{a} {b}");
    assert!(matches!(
        map_torus_continuation(at, &[31.5, 31.4], [0.1, 0.03], 100),
        Err(Error::BadInput { what: "dts_ms", .. })
    ));
}

/// The fitted map's torus does not depend on the training cut. Runs cut at 0.3
/// rad (past the slow saddle cycle at 32 and 32.5 ms) fitted with the default row weight
/// (`FurutaOptions::map_weight`) lose the torus where the default's map does; unweighted they
/// lose it far earlier. Continuation on the report's quick grid (31.4-32.0 ms by 0.1, 8,000
/// periods), linear in dt. The default's is the report model's (`model_torus`); all are
/// fitted on the same runs (`crate::parametric::test_runs::training_runs`).
#[test]
fn map_torus_does_not_depend_on_the_training_cut() {
    use furuta::shared_tangent::shared_parametric_from;
    let cut = crate::parametric::test_runs::cut_03();
    let raw = FurutaOptions { map_weight: None, ..cut.clone() };
    let runs = crate::parametric::test_runs::training_runs();
    let dts: Vec<f64> = (0..=6).map(|k| ((31.4 + 0.1 * k as f64) * 1e4).round() / 1e4).collect();
    let cont = |o: &FurutaOptions| {
        let sm = shared_parametric_from(o, runs).unwrap();
        map_torus_continuation(|dt| Ok(sm.model_at(dt, Interp::Linear)?), &dts, [0.097, 0.0277], 8000).unwrap()
    };
    let (b, c, r) = (model_torus(), &cont(&cut), &cont(&raw));
    for (name, t) in [("default", b), ("cut 0.3", c), ("cut 0.3 unweighted", r)] {
        eprintln!(
            "{name}: onset {:?}, lost {:?}, first dt lost {}",
            t.growth_onset,
            t.lost_between,
            t.lost_at_first_dt()
        );
    }
    let (ob, oc) = (b.growth_onset.unwrap(), c.growth_onset.unwrap());
    assert!((ob - oc).abs() <= 0.1, "onsets {ob} vs {oc}");
    let mid = |t: &furuta::basin::TorusContinuation| t.lost_between.map(|(x, y)| 0.5 * (x + y));
    let (lb, lc) = (mid(b).unwrap(), mid(c).unwrap());
    assert!((lb - lc).abs() <= 0.1 + 1e-9, "lost at {lb} vs {lc}");
    assert!(r.lost_at_first_dt() || mid(r).is_some_and(|l| l < lb - 0.2), "unweighted: {:?}", r.lost_between);
}

/// Options are checked before anything is computed.
#[test]
fn bad_connection_options_are_refused() {
    let o = ConnectionOptions::default();
    for (bad, what) in [
        (ConnectionOptions { push: f64::NAN, ..o }, "push"),
        (ConnectionOptions { phases: 0, ..o }, "phases"),
        (ConnectionOptions { periods: 0, ..o }, "periods"),
        (ConnectionOptions { guess_order: 11, ..o }, "guess_order"),
        (ConnectionOptions { fast_guess: -0.1, ..o }, "fast_guess"),
    ] {
        assert!(
            matches!(full_connection_fates(31.3, &bad), Err(Error::BadOption { what: w, .. }) if w == what),
            "{what}"
        );
        assert!(
            matches!(full_connection(31.0, 32.0, 6, 0.005, &bad), Err(Error::BadOption { what: w, .. }) if w == what),
            "{what}"
        );
    }
}
