use sim::plant::cart::*;
use sim::plant::{Plant, PlantError};

#[test]
fn rhs_solves_the_lagrange_equations() {
    // Plug the accelerations back into the un-inverted equations of motion.
    let cart = Cart::reference();
    let p = *cart.params();
    for (x, u) in [([0.2, -0.5, 0.1, 0.3], 3.0), ([-1.3, 2.0, -0.4, -1.0], -10.0)] {
        let [th, w, _, v] = x;
        let d = cart.rhs(&x, u);
        let (wd, vd) = (d[1], d[3]);
        let (s, c) = th.sin_cos();
        let mt = p.mc + p.m;
        let force = (p.n * u - p.k * v / p.rho) / p.rho;
        let e1 = p.jp * wd - p.m * p.l * c * vd - (p.m * p.g * p.l * s - p.bp * w);
        let e2 = -p.m * p.l * c * wd + mt * vd - (force - p.bc * v - p.m * p.l * s * w * w);
        assert!(e1.abs() < 1e-12 && e2.abs() < 1e-12, "{e1} {e2}");
        assert_eq!((d[0], d[2]), (w, v));
    }
}

#[test]
fn energy_rate_equals_power_balance() {
    let cart = Cart::reference();
    let p = *cart.params();
    let x = [0.4, -0.7, 0.2, 1.3];
    let u = 2.0;
    let dx = cart.rhs(&x, u);
    let eps = 1e-6;
    let xp: [f64; 4] = core::array::from_fn(|i| x[i] + eps * dx[i]);
    let xm: [f64; 4] = core::array::from_fn(|i| x[i] - eps * dx[i]);
    let de = (cart.energy(&xp) - cart.energy(&xm)) / (2.0 * eps);
    let force = (p.n * u - p.k * x[3] / p.rho) / p.rho;
    let power = force * x[3] - p.bc * x[3] * x[3] - p.bp * x[1] * x[1];
    assert!((de - power).abs() < 1e-7 * power.abs().max(1.0), "{de} vs {power}");
}

#[test]
fn validation_names_the_field() {
    let base = CartParams::default();
    let e = Cart::new(CartParams { rho: 0.0, ..base }).unwrap_err();
    assert_eq!(e, PlantError::NotPositive { field: "rho", value: 0.0 });
    assert!(e.to_string().contains("`rho`"));
    let e = Cart::new(CartParams { bc: -1.0, ..base }).unwrap_err();
    assert_eq!(e, PlantError::Negative { field: "bc", value: -1.0 });
    let e = Cart::new(CartParams { mc: f64::NAN, ..base }).unwrap_err();
    assert!(matches!(e, PlantError::NotFinite { field: "mc", .. }), "{e}");
    // A pendulum inertia below m l^2 with a massless cart: Jp*m < (m l)^2.
    let e = Cart::new(CartParams { mc: 1e-6, jp: 0.5 * base.m * base.l * base.l, ..base }).unwrap_err();
    assert!(matches!(e, PlantError::SingularMassMatrix { delta_min, .. } if delta_min < 0.0), "{e}");
}
