//! The tests of `chaos::zero_one`.

use chaos::ChaosError;
use chaos::rng::SplitMix;
use chaos::zero_one::*;

fn logistic(r: f64, n: usize) -> Vec<f64> {
    let mut x = 0.4;
    for _ in 0..1000 {
        x = r * x * (1.0 - x);
    }
    (0..n)
        .map(|_| {
            x = r * x * (1.0 - x);
            x
        })
        .collect()
}

/// Gottwald-Melbourne's own examples: the logistic map at r = 3.97 (chaotic, K -> 1) and at
/// r = 3.55 (period 8, K -> 0).
#[test]
fn logistic_map_chaotic_and_periodic() {
    let p = ZeroOneParams::default();
    let chaotic = zero_one_test(&logistic(3.97, 5000), &p).unwrap();
    assert!(chaotic.k > 0.95, "{chaotic:?}");
    let periodic = zero_one_test(&logistic(3.55, 5000), &p).unwrap();
    assert!(periodic.k.abs() < 0.05, "{periodic:?}");
}

/// Two incommensurate frequencies (a torus): bounded translation variables, K ~ 0.
#[test]
fn quasi_periodic_is_regular() {
    let x: Vec<f64> = (0..5000).map(|j| (j as f64 * 0.7).sin() + 0.6 * (j as f64 * 0.7 * 2f64.sqrt()).cos()).collect();
    let r = zero_one_test(&x, &ZeroOneParams::default()).unwrap();
    assert!(r.k.abs() < 0.1, "{r:?}");
}

/// The same torus with phases diffusing (a noise-driven torus, no chaos). With enough
/// diffusion over n_cut samples the test says K ~ 1: it cannot tell this from chaos. With
/// weak diffusion (phase spread ~1 rad over n_cut) it gives an intermediate K, neither
/// answer.
#[test]
fn noise_driven_torus_looks_chaotic() {
    let torus = |sigma: f64| {
        let mut rng = SplitMix::new(7);
        let (mut a, mut b) = (0.0f64, 0.0f64);
        let x: Vec<f64> = (0..5000)
            .map(|_| {
                a += 0.7 + sigma * rng.normal();
                b += 0.7 * 2f64.sqrt() + sigma * rng.normal();
                a.sin() + 0.6 * b.cos()
            })
            .collect();
        zero_one_test(&x, &ZeroOneParams::default()).unwrap()
    };
    let strong = torus(0.2);
    assert!(strong.k > 0.8, "{strong:?}");
    let weak = torus(0.05);
    assert!(weak.k > 0.2 && weak.k < 0.8, "{weak:?}");
}

/// A flow sampled far faster than its correlation time: the Lorenz x component at
/// dt = 0.01 reads as regular over n_cut lags (K well below 1); coarsened to one sample per
/// 0.2 time units it reads as chaotic.
#[test]
fn oversampled_flow_needs_coarsening() {
    let l = chaos::reference::Lorenz::default();
    let x: Vec<f64> = l.orbit(10_000, 0.01, 1, 2000).iter().map(|s| s[0]).collect();
    let fine = zero_one_test(&x, &ZeroOneParams { n_c: 20, ..Default::default() }).unwrap();
    let coarse = zero_one_test(&x, &ZeroOneParams { stride: 20, ..Default::default() }).unwrap();
    assert!(fine.k < 0.7, "{fine:?}");
    assert!(coarse.k > 0.9, "{coarse:?}");
    assert_eq!(coarse.n_used, 500);
}

#[test]
fn bad_inputs_are_named() {
    let p = ZeroOneParams::default();
    assert!(matches!(zero_one_test(&[1.0; 500], &p), Err(ChaosError::ZeroVariance { .. })));
    assert!(matches!(zero_one_test(&[0.5; 50], &p), Err(ChaosError::TooShort { have: 50, .. })));
    let x = logistic(3.97, 500);
    assert!(matches!(zero_one_test(&x, &ZeroOneParams { stride: 0, ..p }), Err(ChaosError::BadParameter { .. })));
    assert!(matches!(
        zero_one_test(&x, &ZeroOneParams { n_cut_fraction: 0.9, ..p }),
        Err(ChaosError::BadParameter { name: "n_cut_fraction", .. })
    ));
    let mut y = x.clone();
    y[3] = f64::NAN;
    assert!(matches!(zero_one_test(&y, &p), Err(ChaosError::NonFinite { index: 3, .. })));
}
