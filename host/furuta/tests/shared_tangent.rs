//! The tests of `furuta::shared_tangent`.

use furuta::Error;
use furuta::parametric::FurutaOptions;
use furuta::shared_tangent::*;
use ssm::dynamics::ReducedDynamics;
use ssm::interp::Interp;

/// The plain fit (runs simulated per period) and the fit on shared runs give the same
/// model, bit for bit: small options (two periods, three short runs each, a low order) as
/// the sharing tests of `parametric` use; the report's model is fitted on shared runs.
#[test]
fn shared_fit_on_shared_runs_is_the_plain_fit() {
    let base = FurutaOptions::default();
    let o = FurutaOptions {
        dts_ms: vec![30.5, 32.5],
        initial_states: vec![[0.01, 0.0, 0.0, 0.0], [0.05, 0.0, 0.0, 0.5]],
        slow_starts: vec![(0.004, 0.7)],
        periods: 900,
        fit: ssm::fit::FitOptions { embed: 9, dyn_order: 3, ..base.fit },
        // The row weight's low-degree stage needs an order above 3; what is checked
        // here is the series the fits get, not the weight.
        map_weight: None,
        ..base
    };
    let wider = FurutaOptions { max_theta: 0.3, ..o.clone() };
    let runs = furuta::parametric::TrainingRuns::simulate(&[&o, &wider]).unwrap();
    let plain = serde_json::to_string(&shared_parametric(&o).unwrap()).unwrap();
    assert_eq!(serde_json::to_string(&shared_parametric_from(&o, &runs).unwrap()).unwrap(), plain);
}

/// One shared fit (the costly part, shared with `map_global`'s tests) reused for every
/// check.
#[test]
fn shared_tangent_rates_and_predictions() {
    let pm = test_model();
    // 1. The shared-V1 maps keep the exact linear rates like the own-V1 fits (anchored
    //    linear part; the errors are printed).
    for n in &pm.nodes {
        let err =
            [(n.rates[0] - n.exact.rates[0]) / n.exact.rates[0], (n.rates[1] - n.exact.rates[1]) / n.exact.rates[1]];
        eprintln!("node {:5.2}: rate errors slow {:+.2e}, fast {:+.2e}", n.dt_ms, err[0], err[1]);
        assert!(err[0].abs() < 0.01 && err[1].abs() < 0.01, "dt {}: {:?} vs {:?}", n.dt_ms, n.rates, n.exact.rates);
        let f = [
            (n.freqs_hz[0] - n.exact.freqs_hz[0]) / n.exact.freqs_hz[0],
            (n.freqs_hz[1] - n.exact.freqs_hz[1]) / n.exact.freqs_hz[1],
        ];
        if n.dt_ms <= 31.0 {
            assert!(
                f[0].abs() < 1e-3 && f[1].abs() < 1e-4,
                "dt {}: freqs {:?} vs {:?}",
                n.dt_ms,
                n.freqs_hz,
                n.exact.freqs_hz
            );
        }
    }
    // 2. At a training period both interpolants return that period's model exactly.
    let node = &pm.nodes[1];
    for interp in [Interp::Linear, Interp::Spline] {
        let m = pm.model_at(node.dt_ms, interp).unwrap();
        let (ReducedDynamics::Map { increment: a, .. }, ReducedDynamics::Map { increment: b, .. }) =
            (&m.dynamics, &node.model.dynamics)
        else {
            panic!("map dynamics expected")
        };
        assert_eq!(a.coef, b.coef, "{interp:?}");
        assert_eq!(m.manifold.nonlinear.as_ref().unwrap().coef, node.model.manifold.nonlinear.as_ref().unwrap().coef);
    }
    // 3. Normal-form spline interpolation (ParametricModel::normal_form_at_with) on
    //    normal forms of the shared nodes: nodes reproduced, Linear = normal_form_at.
    let pmod = furuta::parametric::ParametricModel {
        trained: pm
            .nodes
            .iter()
            .map(|n| furuta::parametric::TrainedDt {
                dt_ms: n.dt_ms,
                model: n.model.clone(),
                normal_form: pm.normal_form_at(n.dt_ms, Interp::Linear).unwrap(),
                exact: n.exact.clone(),
            })
            .collect(),
    };
    for t in &pmod.trained {
        let nf = pmod.normal_form_at_with(t.dt_ms, Interp::Spline).unwrap();
        for (u, v) in nf.amp.iter().flatten().zip(t.normal_form.amp.iter().flatten()) {
            assert!((u - v).abs() <= 1e-12 * v.abs().max(1.0), "dt {}: {u} vs {v}", t.dt_ms);
        }
        // linear rates of the shared normal form = ln|mu|/dt of the map
        let r = t.normal_form.linear_rates();
        let node = pm.nodes.iter().find(|n| n.dt_ms == t.dt_ms).unwrap();
        assert!(
            (r[0] - node.rates[0]).abs() < 1e-9 && (r[1] - node.rates[1]).abs() < 1e-9,
            "{r:?} vs {:?}",
            node.rates
        );
    }
    assert_eq!(pmod.normal_form_at_with(30.8, Interp::Linear).unwrap().amp, pmod.normal_form_at(30.8).unwrap().amp);
    // 4. Predictions at the six unseen periods, both interpolants: full horizon, no
    //    blow-up, finite metrics (all printed). At 30.8 ms (linear) the bound 3e-3 leaves
    //    room for rounding differences between platforms but fails for a model off by a
    //    few percent in rate or amplitude over the 30 s run. As an independent scale:
    //    predicting 0 gives NMTE = mean|theta| / max|theta|; every period must do better
    //    than a quarter of that.
    let o = PredictOptions::default();
    let tests = test_series_all(&o).unwrap();
    for interp in [Interp::Linear, Interp::Spline] {
        let res = predictions(&pm, &o, interp).unwrap();
        assert_eq!(res.len(), 6);
        // The report's path (test runs simulated once, read by both interpolations) gives
        // the same results, bit for bit.
        let shared = predictions_on(&pm, &o, &tests, interp).unwrap();
        for (a, b) in res.iter().zip(&shared) {
            assert!(
                a.dt_ms == b.dt_ms
                    && a.nmte == b.nmte
                    && a.dtw_nmte == b.dtw_nmte
                    && a.t == b.t
                    && a.x_true == b.x_true
                    && a.x_pred == b.x_pred,
                "dt {}",
                a.dt_ms
            );
        }
        for r in &res {
            let zero = r.x_true.iter().map(|v| v.abs()).sum::<f64>()
                / r.x_true.len() as f64
                / r.x_true.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let peak = r
                .spectrum_true
                .amp
                .iter()
                .zip(&r.spectrum_true.freq_hz)
                .skip(1)
                .fold((0.0, 0.0), |m, (a, f)| if *a > m.0 { (*a, *f) } else { m });
            eprintln!(
                "{interp:?} dt {:5.2}: NMTE {:.4}, DTW-NMTE {:.4} (zero predictor {:.3}), {} samples, stop {:?}, cut {:?}, true peak {:.2e} rad at {:.2} Hz",
                r.dt_ms,
                r.nmte,
                r.dtw_nmte,
                zero,
                r.x_pred.len(),
                r.stop,
                r.test_cut,
                peak.0,
                peak.1
            );
            assert!(r.stop.is_none() && r.x_pred.len() == r.x_true.len(), "dt {}: {:?}", r.dt_ms, r.stop);
            assert!(r.t.last().unwrap() - r.t[0] > 20.0, "dt {}: horizon", r.dt_ms);
            assert!(r.nmte.is_finite() && r.dtw_nmte.is_finite());
            assert!(r.nmte < 0.25 * zero, "dt {}: NMTE {} vs zero predictor {}", r.dt_ms, r.nmte, zero);
            if r.dt_ms == 30.8 && interp == Interp::Linear {
                assert!(r.nmte < 3e-3, "30.8 ms NMTE {}", r.nmte);
            }
            // A regression bound for the weighted map on runs cut at 0.2 rad (unweighted with
            // the 0.3 rad cut it fails by far).
            assert!(r.nmte < 0.005, "dt {}: NMTE {}", r.dt_ms, r.nmte);
        }
    }
    // 5. The fitted map's own small-start switch (furuta::bifurcations::map_small_start_switch,
    //    linear interpolation, 8000 periods; the report sets its bracket beside the full
    //    system's): direct runs of the map from the full system's starts on both sides of
    //    it. At 31.25 ms (a bisection point below the bracket) every start stays bounded;
    //    at 31.3 ms (the switch scan's grid point after it) one of the eight escapes
    //    |theta| > 1.
    use furuta::bifurcations::map_outcome;
    use furuta::full_system::{DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics};
    for (dt, escapes) in [(31.25, false), (31.3, true)] {
        let m = pm.model_at(dt, Interp::Linear).unwrap();
        let outs: Vec<_> = default_ics(dt)
            .unwrap()
            .iter()
            .map(|ic| map_outcome(&m, dt, ic, DEFAULT_SCAN_PERIODS, ESCAPE_THETA).unwrap())
            .collect();
        eprintln!("map at {dt} ms: {outs:?}");
        assert_eq!(outs.iter().any(|o| !o.bounded()), escapes, "dt {dt}: {outs:?}");
        if !escapes {
            assert!(outs.iter().all(|o| o.max_theta < 0.25), "{outs:?}");
        }
    }
    // The map steps at its own period only.
    let m = pm.model_at(31.0, Interp::Linear).unwrap();
    let ic = &default_ics(31.0).unwrap()[0];
    assert!(matches!(map_outcome(&m, 31.1, ic, 100, ESCAPE_THETA), Err(Error::BadInput { what: "dt_ms", .. })));
    assert!(matches!(map_outcome(&m, 31.0, ic, 5, ESCAPE_THETA), Err(Error::BadInput { what: "periods", .. })));
}

/// The report's shared-tangent model (default training options, fitted on the shared
/// training runs as the report fits it), fitted once per test process: this module's tests
/// check it against the exact rates and the full system, `map_global`'s iterate it.
pub(crate) fn test_model() -> &'static SharedParametricModel {
    static M: std::sync::OnceLock<SharedParametricModel> = std::sync::OnceLock::new();
    M.get_or_init(|| {
        shared_parametric_from(&FurutaOptions::default(), crate::parametric::test_runs::training_runs()).unwrap()
    })
}
