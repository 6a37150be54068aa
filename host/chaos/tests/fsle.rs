//! The tests of `chaos::fsle`.

use chaos::ChaosError;
use chaos::fsle::*;
use chaos::reference::{Henon, Lorenz};

/// Twin runs of the Lorenz system 1e-7 apart: a plateau at the largest exponent (0.906)
/// at small scales, and a rate falling well below it near the attractor's size (~20).
#[test]
fn lorenz_twins_plateau_then_saturation() {
    let l = Lorenz::default();
    let h = 0.01;
    let starts = l.orbit(60, h, 150, 2000);
    let delta = thresholds(1e-6, 2f64.sqrt(), 40).unwrap(); // 1e-6 .. 1e-6 * 2^19.5 ~ 0.74 .. the last band ~ 0.74
    let big = thresholds(1.0, 2f64.sqrt(), 12).unwrap(); // 1 .. 45
    let mut seps = Vec::new();
    for s in &starts {
        let (mut a, mut b) = (s.to_vec(), s.to_vec());
        b[0] += 1e-7;
        let mut d = Vec::new();
        for _ in 0..4000 {
            d.push(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt());
            l.rk4_step(&mut a, h);
            l.rk4_step(&mut b, h);
        }
        seps.push(d);
    }
    let small = fsle_from_separations(&seps, h, &delta).unwrap();
    let lam: Vec<f64> = small.iter().filter_map(|r| r.lambda).collect();
    assert_eq!(lam.len(), 39);
    let mean = lam.iter().sum::<f64>() / lam.len() as f64;
    assert!((mean - 0.906).abs() < 0.12, "plateau {mean}: {small:?}");
    // Near the attractor's size the separation saturates: the rate falls.
    let large = fsle_from_separations(&seps, h, &big).unwrap();
    let top = large.iter().rev().find(|r| r.lambda.is_some() && r.pairs >= 10).unwrap();
    assert!(top.delta > 10.0 && top.lambda.unwrap() < 0.5, "{large:?}");
    assert!(scaling_slope(&small, 10).unwrap().abs() < 0.1);
}

/// Henon twins: plateau at 0.419 per iteration.
#[test]
fn henon_twins_plateau() {
    let m = Henon::default();
    let starts = m.orbit(200, 1000);
    let delta = thresholds(1e-9, 2.0, 20).unwrap();
    let mut seps = Vec::new();
    for s in starts.iter().step_by(1) {
        let (mut a, mut b) = (*s, [s[0] + 1e-10, s[1]]);
        let (mut na, mut nb) = ([0.0; 2], [0.0; 2]);
        let mut d = Vec::new();
        for _ in 0..80 {
            d.push(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt());
            m.map(&a, &mut na);
            m.map(&b, &mut nb);
            (a, b) = (na, nb);
        }
        seps.push(d);
    }
    let rows = fsle_from_separations(&seps, 1.0, &delta).unwrap();
    let lam: Vec<f64> = rows.iter().filter_map(|r| r.lambda).collect();
    let mean = lam.iter().sum::<f64>() / lam.len() as f64;
    assert!((mean - 0.419).abs() < 0.06, "{mean}: {rows:?}");
}

/// Data: Henon's x series embedded (m = 2) has a plateau near 0.42 at small scales; a
/// noise-driven torus (two phases drifting with Brownian increments, no chaos) shows
/// lambda ~ delta^-2 over the scales below its size.
#[test]
fn data_fsle_tells_chaos_from_diffusion() {
    let h: Vec<f64> = Henon::default().orbit(20_000, 1000).iter().map(|p| p[0]).collect();
    let pts = chaos::delay_embed(&h, 2, 1).unwrap();
    let delta = thresholds(2e-3, 2.0, 7).unwrap();
    let p = FsleSeriesParams { theiler: 10, max_refs: 1500, horizon: 40, dt: 1.0 };
    let (rows, pairs) = fsle_series(&pts, &delta, &p).unwrap();
    assert!(pairs > 1000, "{pairs}");
    let plateau: Vec<f64> = rows.iter().take(4).filter_map(|r| r.lambda).collect();
    assert_eq!(plateau.len(), 4);
    for l in &plateau {
        assert!((l - 0.42).abs() < 0.12, "{rows:?}");
    }
    let henon_slope = scaling_slope(&rows, 50).unwrap();
    let mut rng = chaos::rng::SplitMix::new(3);
    let (mut a, mut b) = (0.0f64, 0.0f64);
    let x: Vec<f64> = (0..20_000)
        .map(|_| {
            a += 0.3 + 0.01 * rng.normal();
            b += 0.3 * 2f64.sqrt() + 0.01 * rng.normal();
            a.sin() + 0.6 * b.cos()
        })
        .collect();
    let pts = chaos::delay_embed(&x, 4, 5).unwrap();
    let delta = thresholds(0.05, 2f64.sqrt(), 8).unwrap();
    let (rows, pairs) =
        fsle_series(&pts, &delta, &FsleSeriesParams { theiler: 50, max_refs: 1500, horizon: 3000, dt: 1.0 }).unwrap();
    assert!(pairs > 1000, "{pairs}");
    let slope = scaling_slope(&rows, 50).unwrap();
    eprintln!("noise-driven torus: FSLE slope {slope:.3} over {pairs} pairs");
    // Diffusion: -2 in the ideal limit; shallower here (first passages from pairs that start
    // anywhere below delta_0, and the embedding's curvature at the larger scales).
    assert!(slope < -1.2 && slope > -2.4, "slope {slope}: {rows:?}");
    // Against the chaotic plateau: the Henon rows' slope is near 0.
    assert!(henon_slope.abs() < 0.05, "{henon_slope}");
}

#[test]
fn bad_inputs_are_named() {
    assert!(matches!(thresholds(0.0, 2.0, 5), Err(ChaosError::BadParameter { .. })));
    assert!(matches!(thresholds(1.0, 1.0, 5), Err(ChaosError::BadParameter { .. })));
    assert!(matches!(fsle_from_separations(&[vec![0.0, 1.0]], 1.0, &[1.0, 0.5]), Err(ChaosError::BadParameter { .. })));
    assert!(matches!(
        fsle_from_separations(&[vec![0.0, f64::NAN]], 1.0, &[1.0, 2.0]),
        Err(ChaosError::NonFinite { .. })
    ));
    // A separation that starts above the first threshold is not a pair.
    let r = fsle_from_separations(&[vec![3.0, 4.0, 8.0]], 1.0, &[1.0, 2.0]).unwrap();
    assert_eq!(r[0].pairs, 0);
    assert!(r[0].lambda.is_none());
    // Exact passage times: e-folding every 2 samples.
    let s: Vec<f64> = (0..20).map(|k| 1e-3 * (k as f64 / 2.0).exp()).collect();
    let r = fsle_from_separations(&[s], 0.5, &thresholds(2e-3, std::f64::consts::E, 4).unwrap()).unwrap();
    for row in &r {
        assert_eq!(row.mean_time, Some(1.0)); // 2 samples of 0.5
        assert!((row.lambda.unwrap() - 1.0).abs() < 1e-12);
    }
}
