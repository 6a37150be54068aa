//! The tests of `ssm::manifold`.

use faer::{Mat, MatRef};
use ssm::error::FitError;
use ssm::manifold::*;
use ssm::poly::{self, Poly, PolyScratch};
use ssm::ridge::Ridge;
use ssm::weight::RowWeight;

/// The column-at-a-time design matrix before the row blocks (kept to compare with).
fn design_matrix_old(eta: MatRef<'_, f64>, scale: &[f64], exps: &[Vec<u32>]) -> Mat<f64> {
    let (n, d) = (eta.nrows(), eta.ncols());
    let stride = poly::max_degree(exps) as usize + 1;
    // pow[(j * stride + m) * n + i] = (eta[i, j] / scale[j])^m.
    let mut pow = vec![1.0; d * stride * n];
    for j in 0..d {
        let z: Vec<f64> = (0..n).map(|i| eta[(i, j)] / scale[j]).collect();
        let block = &mut pow[j * stride * n..(j + 1) * stride * n];
        for m in 1..stride {
            let (prev, cur) = block.split_at_mut(m * n);
            for ((c, p), zi) in cur[..n].iter_mut().zip(&prev[(m - 1) * n..]).zip(&z) {
                *c = p * zi;
            }
        }
    }
    let mut out = Mat::<f64>::zeros(n, exps.len());
    for (k, e) in exps.iter().enumerate() {
        let col = out.col_as_slice_mut(k);
        col.fill(1.0);
        for (j, &m) in e.iter().enumerate().take(d) {
            let p = &pow[(j * stride + m as usize) * n..][..n];
            for (c, v) in col.iter_mut().zip(p) {
                *c *= v;
            }
        }
    }
    out
}

/// The column-wise design matrix is the row-by-row monomial evaluation
/// (`poly::eval_monomials`, as before), bit for bit, for maps and manifolds of several
/// orders and a single degree block.
#[test]
fn design_matrix_equals_the_row_by_row_monomials() {
    let mut r = ssm::testing::lcg_centered(9);
    for (d, lo, hi, n) in [(4usize, 1u32, 7u32, 257usize), (4, 4, 7, 100), (2, 1, 3, 31), (3, 2, 2, 10)] {
        let eta = Mat::from_fn(n, d, |_, _| r());
        let scale: Vec<f64> = (0..d).map(|_| 0.3 + r().abs()).collect();
        let exps = poly::exponents(d, lo, hi);
        let a = design_matrix(eta.as_ref(), &scale, &exps);
        let (mut pow, mut phi) = (Vec::new(), vec![0.0; exps.len()]);
        for i in 0..n {
            let z: Vec<f64> = (0..d).map(|j| eta[(i, j)] / scale[j]).collect();
            poly::eval_monomials(&exps, &z, poly::max_degree(&exps), &mut pow, &mut phi);
            for (k, v) in phi.iter().enumerate() {
                assert_eq!(a[(i, k)].to_bits(), v.to_bits(), "d {d} degrees {lo}..={hi}: row {i} monomial {k}");
            }
        }
    }
}

/// The row-blocked design matrix is the column-at-a-time one it replaced, bit for bit:
/// the Furuta map regression's size (36,001 pairs of 4 coordinates, degrees 1..=7, 329
/// columns; the last block partial), a manifold's (degrees 1..=3), several blocks in 2
/// variables, and 6 variables (monomials of 5 and 6 factors), values of every magnitude.
#[test]
fn design_matrix_equals_the_column_at_a_time_one() {
    let mut r = ssm::testing::lcg_centered(17);
    for (d, lo, hi, n) in [
        (4usize, 1u32, 7u32, 36_001usize),
        (4, 1, 3, 5_000),
        (4, 2, 3, 1_300),
        (2, 1, 3, 513),
        (6, 1, 6, 700),
        (3, 0, 2, 40),
    ] {
        let eta = Mat::from_fn(n, d, |i, _| {
            let v = r();
            if i % 7 == 3 { v * 1e-9 } else { v }
        });
        let scale: Vec<f64> = (0..d).map(|_| 0.3 + r().abs()).collect();
        let exps = poly::exponents(d, lo, hi);
        let a = design_matrix(eta.as_ref(), &scale, &exps);
        let b = design_matrix_old(eta.as_ref(), &scale, &exps);
        assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
        for k in 0..a.ncols() {
            for i in 0..n {
                assert_eq!(a[(i, k)].to_bits(), b[(i, k)].to_bits(), "d {d} degrees {lo}..={hi}: row {i} monomial {k}");
            }
        }
    }
}

/// Points on a quartic graph over span(e1, e2) in R^5, with graph functions even in
/// (e1, e2) jointly, on a symmetric grid: the data covariance is block diagonal, so the
/// SVD returns exactly span(e1, e2) and the K = 4 fit must reproduce every point to
/// rounding, with `V1^T V_k = 0`.
#[test]
fn recovers_known_quartic_graph() {
    let mut cols = Vec::new();
    for i in -12..=12 {
        for j in -12..=12 {
            let (e1, e2) = (i as f64 / 12.0, j as f64 / 12.0);
            let h1 = 0.2 * (e1 * e1 - 0.5 * e1 * e2 + 0.3 * e2 * e2) + 0.1 * e1 * e1 * e2 * e2;
            let h2 = 0.15 * e2.powi(4) - 0.1 * e1 * e2;
            cols.push([e1, e2, h1, h2, h1]);
        }
    }
    let y = Mat::from_fn(5, cols.len(), |i, j| cols[j][i]);
    let m = Manifold::fit(std::slice::from_ref(&y), 2, 4, Ridge::Fixed(0.0)).unwrap();
    assert!(m.constraint_defect() < 1e-13, "defect {}", m.constraint_defect());
    // V1 spans e1, e2: no components along e3..e5.
    for j in 0..2 {
        for i in 2..5 {
            assert!(m.v1[j * 5 + i].abs() < 1e-13, "V1[{i},{j}] = {}", m.v1[j * 5 + i]);
        }
    }
    let mut sc = PolyScratch::default();
    let mut out = vec![0.0; 5];
    let prepared = m.prepare();
    assert!(prepared.poly.is_some());
    for j in 0..y.ncols() {
        let yj: Vec<f64> = (0..5).map(|i| y[(i, j)]).collect();
        m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
        for i in 0..5 {
            assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
            // One coordinate alone, plain and prepared: the same bits.
            assert_eq!(m.lift_one(&m.reduce(&yj), &mut sc, i).to_bits(), out[i].to_bits(), "point {j} coord {i}");
            assert_eq!(
                prepared.lift_one(&m.reduce(&yj), &mut sc, i).to_bits(),
                out[i].to_bits(),
                "prepared: point {j} coord {i}"
            );
        }
        let mut all = vec![0.0; 5];
        prepared.lift_into(&m.reduce(&yj), &mut sc, &mut all);
        assert_eq!(
            all.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "prepared lift_into: point {j}"
        );
    }
    assert!(m.lift_one(&[0.1, 0.2], &mut sc, 5).is_nan());
    assert!(prepared.lift_one(&[0.1, 0.2], &mut sc, 5).is_nan());
    let c = m.conditioning.unwrap();
    assert!(c.cond.is_finite() && c.cond > 1.0 && c.rel_residual < 1e-12, "{c:?}");
}

/// A curve in R^3 that is an exact graph over its own SVD tangent `e1` with a degree-1 AND a
/// degree-2 normal part: `y = e e1 + e w1 + e^2 w2`, `w1, w2` normal to `e1`, `w1 = -w2
/// m3 / m2` (`mk` the k-th moment of the samples `e`, skewed so `m3 != 0`), which makes
/// `e1` an eigenvector of the data's covariance (and the top one). `fit_with_linear_normal`
/// recovers `w1` and every point to rounding; `fit` (no degree-1 part) cannot, and its
/// degree-2 part absorbs the missing linear one; alone (order 1) the degree-1 part is zero.
#[test]
fn linear_normal_part_over_the_own_tangent() {
    let es: Vec<f64> = (0..=40).map(|k| -0.5 + 1.5 * k as f64 / 40.0).collect();
    let m2: f64 = es.iter().map(|e| e * e).sum();
    let m3: f64 = es.iter().map(|e| e * e * e).sum();
    let w2 = [0.0, 0.3, -0.2];
    let w1: Vec<f64> = w2.iter().map(|w| -w * m3 / m2).collect();
    assert!(w1[1].abs() > 0.05, "the test needs a sizeable linear part: {w1:?}");
    let y = Mat::from_fn(3, es.len(), |i, j| if i == 0 { es[j] } else { w1[i] * es[j] + w2[i] * es[j] * es[j] });
    let m = Manifold::fit_with_linear_normal(std::slice::from_ref(&y), 1, 2, Ridge::Fixed(0.0)).unwrap();
    assert!((m.v1[0] - 1.0).abs() < 1e-13 && m.v1[1].abs() < 1e-13 && m.v1[2].abs() < 1e-13, "V1 = {:?}", m.v1);
    let poly = m.nonlinear.as_ref().unwrap();
    let k1 = poly.exps.iter().position(|e| e == &vec![1]).unwrap();
    let k2 = poly.exps.iter().position(|e| e == &vec![2]).unwrap();
    for i in 0..3 {
        let got1 = poly.coef[k1 * 3 + i] / poly.scale[0];
        let got2 = poly.coef[k2 * 3 + i] / (poly.scale[0] * poly.scale[0]);
        assert!((got1 - w1[i]).abs() < 1e-12, "degree 1, coord {i}: {got1} vs {}", w1[i]);
        assert!((got2 - w2[i]).abs() < 1e-12, "degree 2, coord {i}: {got2} vs {}", w2[i]);
    }
    // observable_row includes the degree-1 part (first coordinate: zero there).
    assert!((m.observable_row()[0] - 1.0).abs() < 1e-13);
    let worst = |m: &Manifold| {
        let (mut sc, mut out, mut w) = (PolyScratch::default(), vec![0.0; 3], 0.0f64);
        for j in 0..y.ncols() {
            let yj: Vec<f64> = (0..3).map(|i| y[(i, j)]).collect();
            m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
            w = (0..3).fold(w, |w, i| w.max((out[i] - yj[i]).abs()));
        }
        w
    };
    assert!(worst(&m) < 1e-13, "with the degree-1 part: {}", worst(&m));
    let plain = Manifold::fit(std::slice::from_ref(&y), 1, 2, Ridge::Fixed(0.0)).unwrap();
    assert!(worst(&plain) > 1e-2, "without it: {}", worst(&plain));
    // Order 1: the degree-1 part alone is the regression of the SVD residual on eta, zero.
    let lin = Manifold::fit_with_linear_normal(std::slice::from_ref(&y), 1, 1, Ridge::Fixed(0.0)).unwrap();
    let c = &lin.nonlinear.as_ref().unwrap().coef;
    assert!(c.iter().all(|v| v.abs() < 1e-13), "order-1 degree-1 part {c:?}");
}

/// `observable_poly` is the first coordinate of `lift_into` (a normal part with degree-1
/// terms, as after `fit_with_tangent`, and scales), and its linear part is
/// `observable_row`.
#[test]
fn observable_poly_is_the_first_lifted_coordinate() {
    let (p, d) = (3, 2);
    let v1 = vec![0.6, 0.8, 0.0, -0.8, 0.6, 0.0];
    let exps = poly::exponents(d, 1, 3);
    let coef: Vec<f64> = (0..exps.len() * p).map(|k| 0.1 * ((k * 7 % 11) as f64 - 5.0)).collect();
    let scale = vec![0.5, 2.0];
    let nonlinear = Some(Poly { dim_in: d, dim_out: p, scale: scale.clone(), exps, coef });
    let m = Manifold { dim: d, p, v1, singular_values: vec![1.0; p], eta_scale: scale, nonlinear, conditioning: None };
    let x = m.observable_poly();
    let mut sc = PolyScratch::default();
    let mut out = vec![0.0; p];
    for eta in [[0.3, -0.2], [-1.1, 0.7], [0.05, 0.9]] {
        m.lift_into(&eta, &mut sc, &mut out);
        let got = x.eval(&eta)[0];
        assert!((got - out[0]).abs() < 1e-14, "{eta:?}: {got} vs {}", out[0]);
    }
    for (a, b) in x.linear_part().iter().zip(m.observable_row()) {
        assert!((a - b).abs() < 1e-15, "{a} vs {b}");
    }
}

/// With data symmetric so that the SVD returns exactly span(e1, e2), a graph of a
/// quadratic is recovered to rounding.
#[test]
fn recovers_quadratic_graph_exactly() {
    let mut cols = Vec::new();
    for i in -10..=10 {
        for j in -10..=10 {
            let (e1, e2) = (0.1 * i as f64, 0.1 * j as f64);
            // e1*e2 is odd in each coordinate: orthogonal to e1, e2 on this symmetric grid.
            let h = 0.3 * e1 * e2;
            cols.push([e1, e2, h, -2.0 * h]);
        }
    }
    let y = Mat::from_fn(4, cols.len(), |i, j| cols[j][i]);
    let m = Manifold::fit(std::slice::from_ref(&y), 2, 2, Ridge::Fixed(0.0)).unwrap();
    let mut sc = PolyScratch::default();
    let mut out = vec![0.0; 4];
    for j in (0..y.ncols()).step_by(17) {
        let yj: Vec<f64> = (0..4).map(|i| y[(i, j)]).collect();
        m.lift_into(&m.reduce(&yj), &mut sc, &mut out);
        for i in 0..4 {
            assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
        }
    }
    assert!(m.constraint_defect() < 1e-13);
}
/// [`Manifold::fit_with_tangent_weighted`]: `None` is the unweighted fit bit for bit; an
/// exact graph (degree 1 and 2 normal parts) is recovered with weights too; on a graph
/// the order does not reach the weights change the fit; the dynamics' low-degree stage
/// is refused.
#[test]
fn weighted_graph_over_a_given_tangent() {
    let v1 = vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
    let graph = |cubic: f64| {
        let mut cols = Vec::new();
        for i in -10..=10 {
            for j in -10..=10 {
                let (e1, e2) = (0.05 * i as f64, 0.05 * j as f64);
                cols.push([e1, e2, 0.2 * e1 + 0.3 * e1 * e2 + cubic * e1.powi(3), -0.1 * e2 + e1 * e1]);
            }
        }
        Mat::from_fn(4, cols.len(), |i, j| cols[j][i])
    };
    let wt = RowWeight { knee: 0.3, power: 8.0, low_degrees: None };
    let exact = graph(0.0);
    let a = Manifold::fit_with_tangent(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0)).unwrap();
    let b =
        Manifold::fit_with_tangent_weighted(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0), None).unwrap();
    assert_eq!(a.nonlinear.as_ref().unwrap().coef, b.nonlinear.as_ref().unwrap().coef);
    let w = Manifold::fit_with_tangent_weighted(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0), Some(&wt))
        .unwrap();
    let (mut sc, mut out) = (PolyScratch::default(), vec![0.0; 4]);
    for j in (0..exact.ncols()).step_by(13) {
        let yj: Vec<f64> = (0..4).map(|i| exact[(i, j)]).collect();
        w.lift_into(&w.reduce(&yj), &mut sc, &mut out);
        for i in 0..4 {
            assert!((out[i] - yj[i]).abs() < 1e-12, "point {j} coord {i}: {} vs {}", out[i], yj[i]);
        }
    }
    assert!(w.conditioning.unwrap().rel_residual < 1e-12);
    let off = graph(2.0);
    let (u, v) = (
        Manifold::fit_with_tangent(std::slice::from_ref(&off), &v1, 2, 2, Ridge::Fixed(0.0)).unwrap(),
        Manifold::fit_with_tangent_weighted(std::slice::from_ref(&off), &v1, 2, 2, Ridge::Fixed(0.0), Some(&wt))
            .unwrap(),
    );
    let gap = u
        .nonlinear
        .unwrap()
        .coef
        .iter()
        .zip(&v.nonlinear.unwrap().coef)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(gap > 1e-4, "weights changed nothing: {gap}");
    let staged =
        RowWeight { low_degrees: Some(ssm::weight::LowDegreeStage { max_degree: 3, knee: 0.1, power: 8.0 }), ..wt };
    let e =
        Manifold::fit_with_tangent_weighted(std::slice::from_ref(&exact), &v1, 2, 2, Ridge::Fixed(0.0), Some(&staged))
            .unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "manifold row weight", .. }), "{e}");
}
