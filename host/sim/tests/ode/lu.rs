use sim::ode::internals::lu::*;

#[test]
fn solves_against_nalgebra() {
    // A matrix that needs pivoting (zero leading entry) and is badly scaled.
    let a = [[0.0, 2.0, -1.0, 3.0], [1e4, 1.0, 0.5, -2.0], [3.0, -7.0, 1e-3, 4.0], [-1.0, 0.25, 6.0, 1.0]];
    let b = [1.0, -2.0, 3.5, 0.125];
    let x = Lu::new(a).unwrap().solve(&b);
    let m = nalgebra::Matrix4::from_fn(|i, j| a[i][j]);
    let want = m.lu().solve(&nalgebra::Vector4::from_column_slice(&b)).unwrap();
    for i in 0..4 {
        assert!((x[i] - want[i]).abs() < 1e-13 * want[i].abs().max(1.0), "{x:?} vs {want}");
    }
    // Residual.
    for i in 0..4 {
        let r: f64 = (0..4).map(|j| a[i][j] * x[j]).sum::<f64>() - b[i];
        assert!(r.abs() < 1e-11, "residual {r}");
    }
}

#[test]
fn singular_and_nan_rejected() {
    assert!(Lu::new([[1.0, 2.0], [2.0, 4.0]]).is_none());
    assert!(Lu::new([[f64::NAN, 0.0], [0.0, 1.0]]).is_none());
    assert!(Lu::new([[0.0, 0.0], [0.0, 0.0]]).is_none());
}
