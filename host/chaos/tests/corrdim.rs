//! The tests of `chaos::corrdim`.

use chaos::corrdim::*;
use chaos::internals::{Binner, accumulate, accumulate_any};
use chaos::{ChaosError, Norm, Points};

#[test]
fn ssm_dimension_rule() {
    assert_eq!(ssm_dimension(4.39).unwrap(), 6);
    assert_eq!(ssm_dimension(4.0).unwrap(), 6);
    assert_eq!(ssm_dimension(3.9).unwrap(), 4);
    assert_eq!(ssm_dimension(1.22).unwrap(), 2);
    assert_eq!(ssm_dimension(0.0).unwrap(), 2);
    assert!(ssm_dimension(f64::NAN).is_err());
}

#[test]
fn binner_matches_exact_search() {
    // Bin = index of the first grid radius strictly above d, checked against a linear
    // search, on grid edges themselves, their float neighbours and values in between.
    for ppd in [1usize, 7, 20, 50] {
        let k_len = 6 * ppd + 1;
        let ln_r0 = -3.7;
        let scale = ppd as f64 / std::f64::consts::LN_10;
        let b = Binner::new(ln_r0, scale, k_len);
        let exact = |d2: f64| (0..k_len).find(|&k| d2 < b.edges2[k]).unwrap_or(k_len);
        let mut probes = vec![0.0, 1e-300, 1e300];
        for k in 0..k_len {
            let e = b.edges2[k];
            probes.extend([
                e,
                f64::from_bits(e.to_bits() - 1),
                f64::from_bits(e.to_bits() + 1),
                e * 1.0001,
                e * 0.9999,
            ]);
        }
        for i in 0..20_000 {
            probes.push((ln_r0 - 1.0 + 16.0 * i as f64 / 20_000.0).exp());
        }
        for d2 in probes {
            assert_eq!(b.bin(d2), exact(d2), "ppd {ppd}, d2 {d2:e}");
        }
    }
}

/// The unrolled, two-histogram `accumulate` gives the plain loop's counts and largest
/// distance bit for bit (the plain loop is `accumulate_any`, the code before), for every
/// dimension and norm, odd and even partner counts, repeated points (zero distances) and
/// points on the grid's edges.
#[test]
fn accumulate_matches_the_plain_loop() {
    let mut rng = chaos::rng::SplitMix::new(7);
    let k_len = 6 * 20 + 1;
    let b = Binner::new(-4.0, 20.0 / std::f64::consts::LN_10, k_len);
    for dim in 1..=9 {
        for n in [0usize, 1, 2, 3, 7, 64, 501] {
            let mut data: Vec<f64> =
                (0..(n + 1) * dim).map(|_| if rng.uniform() < 0.1 { 0.25 } else { rng.normal() }).collect();
            // A repeat of the reference and a point at a grid edge's distance.
            if n >= 3 {
                let a: Vec<f64> = data[..dim].to_vec();
                data[dim..2 * dim].copy_from_slice(&a);
                data[2 * dim..3 * dim].copy_from_slice(&a);
                data[2 * dim] += b.edges2[60].sqrt();
            }
            let (a, others) = data.split_at(dim);
            for norm in [Norm::Euclidean, Norm::Max] {
                let mut want = vec![0u64; k_len + 1];
                let want_max = accumulate_any(a, others, norm, &b, &mut want);
                let (mut h1, mut h2) = (vec![0u64; k_len + 1], vec![0u64; k_len + 1]);
                let got_max = accumulate(a, others, norm, &b, &mut h1, &mut h2);
                let got: Vec<u64> = h1.iter().zip(&h2).map(|(x, y)| x + y).collect();
                assert_eq!(got, want, "dim {dim}, n {n}, {norm:?}");
                assert_eq!(got_max.to_bits(), want_max.to_bits(), "dim {dim}, n {n}, {norm:?}");
            }
        }
    }
}

#[test]
fn counts_exact_pairs_without_self_pairs() {
    // Points on a line at 0,1,...,9: pair distances are |i-j|. With theiler 0 (self
    // pairs excluded only) and all points as references, pairs closer than r = 1.5 are
    // the 9 neighbours; closer than 2.5: 9 + 8.
    let p = Points::from_series(&(0..10).map(|v| v as f64).collect::<Vec<_>>()).unwrap();
    let prm = CorrSumParams { theiler: 0, radii_per_decade: 50, decades: 2, ..Default::default() };
    let c = correlation_sum(&p, &prm).unwrap();
    assert_eq!(c.total_pairs, 45);
    assert_eq!(c.diameter, 9.0);
    let at = |r: f64| {
        let k = c.radius.iter().position(|&x| x > r).unwrap();
        (c.radius[k], c.count[k])
    };
    assert_eq!(at(1.0).1, 9, "{:?}", at(1.0));
    assert_eq!(at(2.0).1, 17);
    // Theiler window 1 removes the 9 nearest-in-time pairs.
    let c1 = correlation_sum(&p, &CorrSumParams { theiler: 1, ..prm }).unwrap();
    assert_eq!(c1.total_pairs, 36);
    assert_eq!(c1.count[0], 8);
}

#[test]
fn subsampled_references_match_all_pairs_on_average() {
    let x: Vec<f64> = (0..4000).map(|i| ((i as f64) * 0.37).sin()).collect();
    let p = chaos::delay_embed(&x, 2, 4).unwrap();
    let full = correlation_sum(&p, &CorrSumParams { max_reference: 10_000, ..Default::default() }).unwrap();
    let sub = correlation_sum(&p, &CorrSumParams { max_reference: 500, ..Default::default() }).unwrap();
    // Compare C at a mid radius.
    let r = 0.2;
    let cf = full.c[full.radius.iter().position(|&v| v > r).unwrap()];
    let cs = sub.c[sub.radius.iter().position(|&v| v > r).unwrap()];
    assert!((cf / cs - 1.0).abs() < 0.05, "{cf} {cs}");
}

#[test]
fn rejects_short_and_constant() {
    let p = Points::from_series(&[0.0, 1.0, 2.0, 3.0]).unwrap();
    let e = correlation_sum(&p, &CorrSumParams { theiler: 2, ..Default::default() }).unwrap_err();
    assert!(matches!(e, ChaosError::TooShort { param: "theiler (pairs outside the window)", .. }), "{e}");
    let q = Points::from_flat(2, vec![1.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0, 1.0, 4.0]).unwrap();
    assert!(matches!(
        correlation_sum(&q, &CorrSumParams { theiler: 0, ..Default::default() }),
        Err(ChaosError::ZeroVariance { coord: 0, .. })
    ));
}
