use sim::scalar::*;

#[test]
fn dual_derivatives_match_calculus() {
    // f(x, y) = sin(x) * y / (1 + x*y), at (0.3, 2.0).
    let x = Dual::<2>::var(0.3, 0);
    let y = Dual::<2>::var(2.0, 1);
    let (s, _) = x.sin_cos();
    let f = s * y / (x * y + 1.0);
    let (xv, yv) = (0.3f64, 2.0f64);
    let den = 1.0 + xv * yv;
    let dfdx = (xv.cos() * yv * den - xv.sin() * yv * yv) / (den * den);
    let dfdy = (xv.sin() * den - xv.sin() * yv * xv) / (den * den);
    assert!((f.v - xv.sin() * yv / den).abs() < 1e-15);
    assert!((f.d[0] - dfdx).abs() < 1e-14, "{} vs {}", f.d[0], dfdx);
    assert!((f.d[1] - dfdy).abs() < 1e-14, "{} vs {}", f.d[1], dfdy);
}
