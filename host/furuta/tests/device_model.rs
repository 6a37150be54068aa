//! The tests of `furuta::device_model`.

use controller::predictor::{Predictor, SqrtFlavour};
use furuta::device_model::*;
use shared::model::Model;
use sim::scene::Scene;
use ssm::device::{encode, to_device_model};
use ssm::{Dynamics, SsmModel, TimeSeries, fit};

/// A fitted RBF model of the Furuta loop at dt = 25 ms (theta series, 4D SSM).
fn fitted() -> (SsmModel, TimeSeries) {
    fit_scene_rbf(&Scene::load("furuta-dt25", &[]).unwrap(), 1200).unwrap()
}

#[test]
fn polynomial_dynamics_are_refused() {
    let (m, ts) = fitted();
    let mut opts = m.options.clone();
    opts.dynamics = Dynamics::Map;
    opts.dyn_order = 3;
    let poly = fit(std::slice::from_ref(&ts), &opts).unwrap();
    let e = to_device_model(&poly, shared::ControllerConfig::paper(0.025)).unwrap_err().to_string();
    assert!(e.contains("rbf"), "{e}");
}

#[test]
fn device_f32_predictor_matches_host_f64_model() {
    let (m, ts) = fitted();
    let owned = to_device_model(&m, shared::ControllerConfig::paper(0.025)).unwrap();
    let blob = encode(&owned).unwrap();
    let model = Model::<16, 6, 128, 64>::decode(&blob).unwrap();
    let pred = Predictor::<16, 6, 128, 64, 64>::from_model(model, SqrtFlavour::Libm).unwrap();
    let (p, d) = (m.manifold.p, m.manifold.dim);
    let range = ts.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let mut worst = 0.0_f64;
    let mut scratch = ssm::dynamics::StepScratch::default();
    let mut ps = ssm::poly::PolyScratch::default();
    for start in (0..ts.x.len() - p - 60).step_by(97) {
        let y0: Vec<f64> = ts.x[start..start + p].to_vec();
        let mut eta = m.manifold.reduce(&y0);
        let mut e32 = [0.0f32; 6];
        let y32: [f32; 16] = core::array::from_fn(|i| if i < p { y0[i] as f32 } else { 0.0 });
        let r = pred.project(&y32);
        e32[..d].copy_from_slice(&r[..d]);
        let mut out = vec![0.0; p];
        for _ in 0..50 {
            m.dynamics.step(&mut eta, m.dt, &mut scratch);
            e32 = pred.step(&e32);
            m.manifold.lift_into(&eta, &mut ps, &mut out);
            let dev = pred.lift(&e32) as f64;
            worst = worst.max((dev - out[0]).abs() / range);
        }
    }
    // f32 rounding through 50 map steps; the f64 model is the reference.
    assert!(worst < 1e-4, "worst f32-vs-f64 deviation {worst:e} of the signal range");
    assert!(worst > 0.0, "f32 and f64 cannot agree exactly");
}
