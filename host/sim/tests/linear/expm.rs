use nalgebra::DMatrix;
use sim::linear::{ExpmFailure, expm};

fn max_abs_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).iter().fold(0.0, |m, v| m.max(v.abs()))
}

#[test]
fn diagonal_matrix_matches_scalar_exponentials() {
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-400.0, -1.0, 0.0, 2.5]));
    let e = expm(&d).unwrap();
    for (i, l) in [-400.0f64, -1.0, 0.0, 2.5].iter().enumerate() {
        // The relative condition number of e^x is |x|, and the 7 squarings chosen for the
        // largest entry (-400) amplify rounding of the small ones by about 2^7 (the
        // overscaling Higham 2009 later addressed): allow 1e-12 relative.
        let want = l.exp();
        let tol = 1e-12;
        assert!((e[(i, i)] / want - 1.0).abs() <= tol, "{i}: {} vs {want}", e[(i, i)]);
    }
    assert!(e.iter().enumerate().all(|(k, v)| k % 5 == 0 || *v == 0.0));
}

#[test]
fn rotation_and_jordan_block() {
    // e^{[[0, w], [-w, 0]] t} is a rotation by w t; e^{[[l, 1], [0, l]]} = e^l [[1, 1], [0, 1]].
    let w = 37.0;
    let m = DMatrix::from_row_slice(2, 2, &[0.0, w, -w, 0.0]);
    let e = expm(&m).unwrap();
    let want = DMatrix::from_row_slice(2, 2, &[w.cos(), w.sin(), -w.sin(), w.cos()]);
    assert!(max_abs_diff(&e, &want) < 1e-12, "{e}");
    let l = -3.0f64;
    let j = DMatrix::from_row_slice(2, 2, &[l, 1.0, 0.0, l]);
    let e = expm(&j).unwrap();
    let want = DMatrix::from_row_slice(2, 2, &[l.exp(), l.exp(), 0.0, l.exp()]);
    assert!(max_abs_diff(&e, &want) < 1e-15, "{e}");
}

#[test]
fn rejects_non_finite() {
    let m = DMatrix::from_row_slice(2, 2, &[0.0, f64::NAN, 0.0, 0.0]);
    assert_eq!(expm(&m), Err(ExpmFailure::NonFinite));
}
