//! The tests of `ssm::poly`.

use ssm::poly::*;

fn binom(n: usize, k: usize) -> usize {
    (0..k).fold(1, |acc, i| acc * (n - i) / (i + 1))
}

/// One output alone ([`Poly::eval_one`]) is [`Poly::eval_into`]'s, bit for bit, with a
/// scratch reused across polynomials of other degrees; out of range: NaN.
#[test]
fn one_output_is_the_same_bits() {
    let mut r = ssm::testing::lcg_centered(3);
    let mut sc = PolyScratch::default();
    for (d, max, q) in [(4usize, 7u32, 4usize), (4, 3, 21), (2, 5, 3)] {
        let exps = exponents(d, 1, max);
        let scale: Vec<f64> = (0..d).map(|_| 0.5 + r().abs()).collect();
        let coef: Vec<f64> = (0..exps.len() * q).map(|_| r()).collect();
        let p = Poly { dim_in: d, dim_out: q, scale, exps, coef };
        let mut out = vec![0.0; q];
        for _ in 0..5 {
            let eta: Vec<f64> = (0..d).map(|_| r()).collect();
            p.eval_into(&eta, &mut sc, &mut out);
            for (i, o) in out.iter().enumerate() {
                assert_eq!(p.eval_one(&eta, &mut sc, i).to_bits(), o.to_bits(), "d {d} order {max} output {i}");
            }
        }
        assert!(p.eval_one(&vec![0.1; d], &mut sc, q).is_nan());
    }
}

/// [`PreparedPoly`] against [`Poly::eval_into`] / [`Poly::eval_one`] bit for bit on random
/// points (and on points whose powers overflow, underflow or are signed zeros): full degree
/// ranges (every parent a monomial), ranges without the low degrees and lists in another
/// order (hidden parents), the constant monomial, one to six outputs (registers and the
/// general sum). A scratch is shared with the plain path, as a caller may.
#[test]
fn prepared_is_the_same_bits() {
    let mut r = ssm::testing::lcg_centered(11);
    let mut shuffled = exponents(3, 1, 4);
    shuffled.reverse();
    shuffled.swap(2, 17);
    let cases: Vec<(usize, Vec<Vec<u32>>, usize)> = vec![
        (4, exponents(4, 1, 7), 4),
        (4, exponents(4, 2, 3), 21),
        (4, exponents(4, 2, 3), 1),
        (2, exponents(2, 1, 5), 3),
        (1, exponents(1, 1, 9), 2),
        (3, exponents(3, 3, 6), 5),
        (3, shuffled, 6),
        (2, exponents(2, 0, 4), 4),
        (5, vec![vec![0, 0, 3, 0, 1], vec![2, 0, 0, 0, 0], vec![0, 0, 3, 0, 1]], 2),
    ];
    let (mut plain, mut prep) = (PolyScratch::default(), PolyScratch::default());
    for (d, exps, q) in cases {
        let scale: Vec<f64> = (0..d).map(|_| 0.5 + r().abs()).collect();
        let coef: Vec<f64> = (0..exps.len() * q).map(|_| r()).collect();
        let p = Poly { dim_in: d, dim_out: q, scale, exps, coef };
        let pp = PreparedPoly::new(&p).unwrap();
        // A full degree range from 1 is formed in monomial order (one pass), others not.
        assert_eq!(
            pp.in_order(),
            p.exps.first().is_some_and(|e| e.iter().sum::<u32>() == 1)
                && p.exps == exponents(d, 1, max_degree(&p.exps)),
            "d {d} q {q}"
        );
        let (mut want, mut got) = (vec![0.0; q], vec![1.0; q]);
        let mut points: Vec<Vec<f64>> = (0..20).map(|_| (0..d).map(|_| 3.0 * r()).collect()).collect();
        points.push((0..d).map(|i| if i % 2 == 0 { 1e80 } else { -1e-80 }).collect());
        points.push((0..d).map(|i| if i % 2 == 0 { -0.0 } else { 0.0 }).collect());
        for eta in &points {
            p.eval_into(eta, &mut plain, &mut want);
            pp.eval_into(eta, &mut prep, &mut got);
            for i in 0..q {
                assert_eq!(
                    got[i].to_bits(),
                    want[i].to_bits(),
                    "d {d} q {q} at {eta:?}: output {i} {} vs {}",
                    got[i],
                    want[i]
                );
                assert_eq!(pp.eval_one(eta, &mut plain, i).to_bits(), want[i].to_bits(), "d {d} q {q} eval_one {i}");
            }
        }
        assert!(pp.eval_one(&vec![0.1; d], &mut prep, q).is_nan());
        // A longer output buffer is left as the plain path leaves it (zeros past dim_out).
        let (mut w2, mut g2) = (vec![7.0; q + 2], vec![7.0; q + 2]);
        p.eval_into(&points[0], &mut plain, &mut w2);
        pp.eval_into(&points[0], &mut prep, &mut g2);
        assert_eq!(
            w2.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            g2.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
    // Inconsistent shapes are refused, not evaluated.
    let good = Poly { dim_in: 2, dim_out: 1, scale: vec![1.0; 2], exps: exponents(2, 1, 2), coef: vec![1.0; 5] };
    assert!(PreparedPoly::new(&good).is_some());
    assert!(PreparedPoly::new(&Poly { coef: vec![1.0; 4], ..good.clone() }).is_none());
    assert!(PreparedPoly::new(&Poly { scale: vec![1.0], ..good.clone() }).is_none());
    assert!(
        PreparedPoly::new(&Poly { exps: vec![vec![1, 0], vec![1], vec![0, 1], vec![2, 0], vec![0, 2]], ..good })
            .is_none()
    );
}

#[test]
fn order_and_count() {
    let e = exponents(2, 1, 3);
    let expect: Vec<Vec<u32>> = vec![
        vec![1, 0],
        vec![0, 1],
        vec![2, 0],
        vec![1, 1],
        vec![0, 2],
        vec![3, 0],
        vec![2, 1],
        vec![1, 2],
        vec![0, 3],
    ];
    assert_eq!(e, expect);
    for d in 1..=4usize {
        for k in 1..=6u32 {
            let n = exponents(d, k, k).len();
            assert_eq!(n, binom(d + k as usize - 1, k as usize), "d={d} k={k}");
            assert_eq!(count(d, 1, k), Some(exponents(d, 1, k).len()), "d={d} k={k}");
            assert_eq!(count(d, 2, k), Some(exponents(d, 2, k).len()), "d={d} k={k}");
        }
    }
    // Counted without listing, overflow reported.
    assert_eq!(count(100, 1, 3), Some(176_850));
    assert_eq!(count(usize::MAX, 1, 3), None);
}

#[test]
fn eval_matches_direct_formula() {
    // f(eta) = [3 z1 - z1 z2^2, 2 z2^3] with z = eta / scale.
    let exps = exponents(2, 1, 3);
    let mut coef = vec![0.0; exps.len() * 2];
    coef[0] = 3.0; // z1 -> out 0
    coef[7 * 2] = -1.0; // z1 z2^2 -> out 0
    coef[8 * 2 + 1] = 2.0; // z2^3 -> out 1
    let p = Poly { dim_in: 2, dim_out: 2, scale: vec![2.0, 0.5], exps, coef };
    let eta = [0.7, -0.3];
    let (z1, z2) = (0.7 / 2.0, -0.3 / 0.5);
    let v = p.eval(&eta);
    assert!((v[0] - (3.0 * z1 - z1 * z2 * z2)).abs() < 1e-15);
    assert!((v[1] - 2.0 * z2 * z2 * z2).abs() < 1e-15);
    let a = p.linear_part();
    assert_eq!(a, vec![1.5, 0.0, 0.0, 0.0]);
}
