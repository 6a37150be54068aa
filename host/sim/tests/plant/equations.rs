use nalgebra::{DMatrix, SMatrix};
use shared::ControllerConfig;
use sim::expr::Tape;
use sim::linear::{LinearPlant, Multiplier};
use sim::plant::equations::internals::{lu_solve, upper_index};
use sim::plant::equations::*;
use sim::plant::{Dual, Furuta, FurutaParams, jacobian, linearize};
use sim::plant::{Plant, Scalar};
use std::sync::Arc;

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| x.to_string()).collect()
}

fn furuta_parameters() -> Vec<(String, f64)> {
    let p = FurutaParams::default();
    [
        ("m", p.m),
        ("l", p.l),
        ("r", p.r),
        ("g", p.g),
        ("Jp", p.jp),
        ("Ja", p.ja),
        ("b1", p.b1),
        ("b2", p.b2),
        ("N", p.n),
        ("K", p.k),
    ]
    .into_iter()
    .map(|(n, v)| (n.to_string(), v))
    .collect()
}

/// The Furuta pendulum of `shared/MODEL.md` written as equations (the scene
/// `furuta-equations` writes the same).
pub(crate) fn furuta_spec(lagrangian: bool) -> EquationsSpec {
    let form = if lagrangian {
        Form::Lagrangian {
            lagrangian: "0.5*Jp*theta_dot^2 + 0.5*(Ja + Jp*sin(theta)^2)*phi_dot^2 \
                         - m*r*l*cos(theta)*theta_dot*phi_dot - m*g*l*cos(theta)"
                .into(),
            generalized_forces: s(&["-b1*theta_dot", "N*u - K*phi_dot - b2*phi_dot"]),
        }
    } else {
        Form::Mass {
            mass: vec![s(&["Jp", "-m*r*l*cos(theta)"]), s(&["-m*r*l*cos(theta)", "Ja + Jp*sin(theta)^2"])],
            forces: s(&[
                "Jp*sin(theta)*cos(theta)*phi_dot^2 - b1*theta_dot + m*g*l*sin(theta)",
                "N*u - K*phi_dot - 2*Jp*sin(theta)*cos(theta)*theta_dot*phi_dot - b2*phi_dot \
                 - m*r*l*sin(theta)*theta_dot^2",
            ]),
        }
    };
    EquationsSpec { coordinates: s(&["theta", "phi"]), parameters: furuta_parameters(), form, equilibrium: None }
}

fn cart_pole_parameters() -> Vec<(String, f64)> {
    [("M", 0.5), ("m", 0.2), ("l", 0.3), ("g", 9.81), ("b", 0.1), ("c", 0.002)]
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect()
}

/// The cart-pole of the issue, both forms.
fn cart_pole_spec(lagrangian: bool) -> EquationsSpec {
    let form = if lagrangian {
        Form::Lagrangian {
            lagrangian: "0.5*(M+m)*x_dot^2 + m*l*cos(theta)*x_dot*theta_dot + 0.5*m*l^2*theta_dot^2 \
                         - m*g*l*cos(theta)"
                .into(),
            generalized_forces: s(&["u - b*x_dot", "-c*theta_dot"]),
        }
    } else {
        Form::Mass {
            mass: vec![s(&["M + m", "m*l*cos(theta)"]), s(&["m*l*cos(theta)", "m*l^2"])],
            forces: s(&["u + m*l*theta_dot^2*sin(theta) - b*x_dot", "m*g*l*sin(theta) - c*theta_dot"]),
        }
    };
    EquationsSpec { coordinates: s(&["x", "theta"]), parameters: cart_pole_parameters(), form, equilibrium: None }
}

/// A single inverted pendulum: `m l^2 theta'' = m g l sin(theta) - c theta' + u`.
fn pendulum_spec(c: f64) -> EquationsSpec {
    EquationsSpec {
        coordinates: s(&["theta"]),
        parameters: [("m", 0.3), ("l", 0.6), ("g", 9.81), ("c", c)]
            .into_iter()
            .map(|(n, v)| (n.to_string(), v))
            .collect(),
        form: Form::Mass { mass: vec![s(&["m*l^2"])], forces: s(&["m*g*l*sin(theta) - c*theta_dot + u"]) },
        equilibrium: None,
    }
}

fn plant<const N: usize>(spec: &EquationsSpec) -> EquationsPlant<N> {
    let model = EquationsModel::new(spec).unwrap_or_else(|e| panic!("{e}"));
    EquationsPlant::new(Arc::new(model)).unwrap()
}

/// States spread over a box, deterministic.
fn states<const N: usize>(count: usize) -> Vec<[f64; N]> {
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..count).map(|_| core::array::from_fn(|i| if i % 2 == 0 { 3.0 * next() } else { 4.0 * next() })).collect()
}

fn assert_rhs_close<const N: usize>(a: &impl Plant<N>, b: &impl Plant<N>, rtol: f64, what: &str) {
    for (k, x) in states::<N>(200).iter().enumerate() {
        let u = (k as f64 * 0.37).sin() * 5.0;
        let (fa, fb) = (a.rhs(x, u), b.rhs(x, u));
        let scale = fa.iter().chain(&fb).fold(1.0f64, |m, v| m.max(v.abs()));
        for i in 0..N {
            assert!((fa[i] - fb[i]).abs() <= rtol * scale, "{what}: x = {x:?}, u = {u}: f{i} {} vs {}", fa[i], fb[i]);
        }
    }
}

/// The Furuta pendulum as equations equals the built-in plant: right-hand side (mass and
/// Lagrangian forms) to rounding, Jacobians too.
#[test]
fn furuta_as_equations_equals_the_builtin_rhs() {
    let builtin = Furuta::paper();
    for lagrangian in [false, true] {
        let eq = plant::<4>(&furuta_spec(lagrangian));
        // Delta(0) loses about a digit to cancellation in both formulas.
        assert_rhs_close(&builtin, &eq, 1e-12, if lagrangian { "lagrangian" } else { "mass" });
        for x in states::<4>(20) {
            let (_, ja) = jacobian(&builtin, &x, 1.3);
            let (_, jb) = jacobian(&eq, &x, 1.3);
            for i in 0..4 {
                let scale = ja[i].iter().fold(1.0f64, |m, v| m.max(v.abs()));
                for j in 0..4 {
                    assert!((ja[i][j] - jb[i][j]).abs() <= 1e-11 * scale, "J[{i}][{j}] at {x:?}");
                }
            }
        }
        assert_eq!(eq.state_names(), ["theta", "theta_dot", "phi", "phi_dot"]);
    }
    // The Lagrangian form's energy function is the plant's energy.
    let eq = plant::<4>(&furuta_spec(true));
    for x in states::<4>(10) {
        let (e1, e2) = (builtin.energy(&x), eq.energy(&x));
        assert!((e1 - e2).abs() <= 1e-14 * e1.abs().max(1e-3), "{e1} vs {e2}");
    }
    assert!(plant::<4>(&furuta_spec(false)).energy(&[0.0; 4]).is_nan());
}

/// The Lagrangian form equals the mass-matrix form of the same plant to rounding.
#[test]
fn lagrangian_form_equals_mass_form() {
    assert_rhs_close(&plant::<4>(&cart_pole_spec(false)), &plant::<4>(&cart_pole_spec(true)), 1e-13, "cart-pole");
    assert_rhs_close(&plant::<4>(&furuta_spec(false)), &plant::<4>(&furuta_spec(true)), 1e-12, "furuta");
}

/// P and D on state `primary`, D (`-kphi_d`, the shorthand's sign) on state `secondary`.
fn cfg_at(primary: u8, secondary: u8, kp: f64, kd: f64, kphi_d: f64, dt: f64) -> ControllerConfig {
    let gains = shared::Gains::from_array([
        shared::Gain { index: primary, p: kp, d: kd, h_adc: 0.0 },
        shared::Gain { index: secondary, p: 0.0, d: -kphi_d, h_adc: 0.0 },
    ]);
    ControllerConfig { gains, ..ControllerConfig::shorthand(kp, kd, kphi_d, dt) }
}

/// P and D on the single coordinate of a one-coordinate plant.
fn cfg1(kp: f64, kd: f64, dt: f64) -> ControllerConfig {
    let gains = shared::Gains::from_array([shared::Gain { index: 0, p: kp, d: kd, h_adc: 0.0 }]);
    ControllerConfig { gains, ..ControllerConfig::shorthand(kp, kd, 0.0, dt) }
}

fn code_multipliers<const N: usize>(
    p: &impl Plant<N>,
    primary: usize,
    secondary: usize,
    c: &ControllerConfig,
) -> Vec<Multiplier> {
    let (a, b) = linearize(p);
    LinearPlant::new(&a, &b, primary, secondary).unwrap().closed_loop(c).unwrap().multipliers().unwrap()
}

/// Linear multipliers of the Furuta as equations equal the built-in plant's to 1e-10 of the
/// spectral radius (the scale of the eigenvalues' backward error: the multipliers near 0 of
/// the fast mode carry the same absolute rounding as the large ones).
#[test]
fn furuta_as_equations_has_the_builtin_multipliers() {
    let builtin = Furuta::paper();
    for dt in [0.025, 0.0308, 0.0323] {
        let c = ControllerConfig::paper(dt);
        let a = code_multipliers(&builtin, 0, 2, &c);
        for lagrangian in [false, true] {
            let b = code_multipliers(&plant::<4>(&furuta_spec(lagrangian)), 0, 2, &c);
            assert_same_multipliers(&a, &b, 1e-10 * a[0].abs.max(1.0), &format!("dt {dt}"));
        }
    }
}

/// The multipliers of two maps agree: those above 1e-6 pair up within `tol`; the rest are
/// the zeros of the sample registers' nilpotent (defective) blocks, which an eigensolver
/// returns only to about `sqrt(eps)`.
pub(crate) fn assert_same_multipliers(a: &[Multiplier], b: &[Multiplier], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    let big = |v: &[Multiplier]| v.iter().filter(|m| m.abs > 1e-6).count();
    assert_eq!(big(a), big(b), "{what}: {a:?} vs {b:?}");
    for x in a.iter().filter(|m| m.abs > 1e-6) {
        let best = b.iter().map(|y| (x.re - y.re).hypot(x.im - y.im)).fold(f64::INFINITY, f64::min);
        assert!(best <= tol, "{what}: {x:?} has no partner within {tol:e} (closest {best:e}) in {b:?}");
    }
    for y in a.iter().chain(b).filter(|m| m.abs <= 1e-6) {
        assert!(y.abs < 1e-6, "{what}: {y:?}");
    }
}

/// `e^M` by Taylor series with scaling and squaring, written here independently of
/// `sim::linear::expm` (Pade 13).
fn expm_taylor(m: &DMatrix<f64>) -> DMatrix<f64> {
    let norm = m.iter().fold(0.0f64, |a, v| a + v.abs());
    let mut k = 0;
    while norm / 2f64.powi(k) > 0.1 {
        k += 1;
    }
    let a = m / 2f64.powi(k);
    let n = m.nrows();
    let mut term = DMatrix::<f64>::identity(n, n);
    let mut sum = term.clone();
    for j in 1..30 {
        term = &term * &a / j as f64;
        sum += &term;
    }
    for _ in 0..k {
        sum = &sum * &sum;
    }
    sum
}

/// The eigenvalues of `m` as sorted multipliers.
fn sorted(m: &DMatrix<f64>, dt: f64) -> Vec<Multiplier> {
    let mut v: Vec<Multiplier> = m.complex_eigenvalues().iter().map(|c| Multiplier::new(c.re, c.im, dt)).collect();
    v.sort_by(|a, b| b.abs.total_cmp(&a.abs).then(b.im.total_cmp(&a.im)));
    v
}

fn assert_same_nonzero(code: &[Multiplier], reference: &[Multiplier], tol: f64, what: &str) {
    // The code's map also carries the sample registers of a coordinate read with zero gain:
    // their multipliers are 0 (a defective block: the eigensolver returns about sqrt(eps)).
    let nz: Vec<&Multiplier> = code.iter().filter(|m| m.abs > 1e-6).collect();
    let rz: Vec<&Multiplier> = reference.iter().filter(|m| m.abs > 1e-6).collect();
    assert_eq!(nz.len(), rz.len(), "{what}: {code:?} vs {reference:?}");
    for r in &rz {
        let best = nz.iter().map(|c| (c.re - r.re).hypot(c.im - r.im)).fold(f64::INFINITY, f64::min);
        assert!(best <= tol, "{what}: reference {r:?} not among {nz:?} (closest {best:e})");
    }
}

/// The cart-pole's multipliers (equations plant through the code's linearization and ZOH)
/// against a closed-form computation written here: the linearization by hand, `e^{A dt}`
/// by Taylor series, and the delayed loop's companion matrix on
/// `(x, theta, x', theta', theta_{i-1}, theta_{i-2}, x_{i-1}, x_{i-2})`.
#[test]
fn cart_pole_multipliers_match_a_closed_form_zoh() {
    let (mc, m, l, g, b, c) = (0.5, 0.2, 0.3, 9.81, 0.1, 0.002);
    // M0 q'' = K q + D q' + B u at the origin, q = (x, theta).
    let m0 = SMatrix::<f64, 2, 2>::new(mc + m, m * l, m * l, m * l * l);
    let inv = m0.try_inverse().unwrap();
    let kq = inv * SMatrix::<f64, 2, 2>::new(0.0, 0.0, 0.0, m * g * l);
    let dq = inv * SMatrix::<f64, 2, 2>::new(-b, 0.0, 0.0, -c);
    let bq = inv * nalgebra::Vector2::new(1.0, 0.0);
    // Continuous A on (x, theta, x', theta') with the input as a fifth, constant state.
    let mut aug = DMatrix::<f64>::zeros(5, 5);
    aug[(0, 2)] = 1.0;
    aug[(1, 3)] = 1.0;
    for i in 0..2 {
        for j in 0..2 {
            aug[(2 + i, j)] = kq[(i, j)];
            aug[(2 + i, 2 + j)] = dq[(i, j)];
        }
        aug[(2 + i, 4)] = bq[i];
    }
    let eq = plant::<4>(&cart_pole_spec(false));
    for (dt, kp, kd, kx_d) in [(0.01, 40.0, 4.0, 2.0), (0.02, 25.0, 3.0, -1.0), (0.005, 10.0, 1.0, 0.5)] {
        let e = expm_taylor(&(&aug * dt));
        // The law on theta (primary) and x (secondary): u = -kp th1 - kd (th1 - th2)/dt + kx_d (x1 - x2)/dt.
        let mut mm = DMatrix::<f64>::zeros(8, 8);
        let mut law = [0.0; 8];
        law[4] = -kp - kd / dt;
        law[5] = kd / dt;
        law[6] = kx_d / dt;
        law[7] = -kx_d / dt;
        for i in 0..4 {
            for j in 0..4 {
                mm[(i, j)] = e[(i, j)];
            }
            for (j, lj) in law.iter().enumerate() {
                mm[(i, j)] += e[(i, 4)] * lj;
            }
        }
        mm[(4, 1)] = 1.0; // theta_{i} becomes theta_{(i+1)-1}
        mm[(5, 4)] = 1.0;
        mm[(6, 0)] = 1.0;
        mm[(7, 6)] = 1.0;
        let reference = sorted(&mm, dt);
        // Equations plant states (x, x', theta, theta'): primary theta = 2, secondary x = 0.
        let code = code_multipliers(&eq, 2, 0, &cfg_at(2, 0, kp, kd, kx_d, dt));
        assert_same_nonzero(&code, &reference, 1e-11, &format!("cart-pole dt {dt}"));
    }
}

/// The single pendulum `theta'' = a theta + b u` under `u_i = -P theta_{i-1} - D (theta_{i-1} -
/// theta_{i-2}) / dt`: with `ch = cosh(w dt)`, `sh = sinh(w dt)`, `w = sqrt(a)`, the ZOH map
/// is `Phi = [[ch, sh/w], [w sh, ch]]`, `Gamma = b [(ch - 1)/a, sh/w]`, in closed form.
fn pendulum_zoh(a: f64, bb: f64, dt: f64) -> (DMatrix<f64>, [f64; 2]) {
    let w = a.sqrt();
    let (ch, sh) = ((w * dt).cosh(), (w * dt).sinh());
    (DMatrix::from_row_slice(2, 2, &[ch, sh / w, w * sh, ch]), [bb * (ch - 1.0) / a, bb * sh / w])
}

#[test]
fn pendulum_multipliers_match_the_closed_form_zoh() {
    let spec = pendulum_spec(0.0);
    let eq = plant::<2>(&spec);
    let (m, l, g): (f64, f64, f64) = (0.3, 0.6, 9.81);
    let (a, bb) = (g / l, 1.0 / (m * l * l));
    for (dt, kp, kd) in [(0.01, 3.0, 0.3), (0.05, 2.5, 0.2), (0.1, 4.0, 0.5)] {
        let (phi, gamma) = pendulum_zoh(a, bb, dt);
        // State (theta, theta', theta_{i-1}, theta_{i-2}).
        let mut mm = DMatrix::<f64>::zeros(4, 4);
        let law = [0.0, 0.0, -kp - kd / dt, kd / dt];
        for i in 0..2 {
            for j in 0..2 {
                mm[(i, j)] = phi[(i, j)];
            }
            for (j, lj) in law.iter().enumerate() {
                mm[(i, j)] += gamma[i] * lj;
            }
        }
        mm[(2, 0)] = 1.0;
        mm[(3, 2)] = 1.0;
        let code = code_multipliers(&eq, 0, 1, &cfg1(kp, kd, dt));
        assert_same_nonzero(&code, &sorted(&mm, dt), 1e-11, &format!("pendulum dt {dt}"));
    }
}

/// The stability boundary of the inverted pendulum under delayed (r = 1) sampled P and PD
/// control, against the analytic boundary by D-subdivision (Stépán, "Vibrations of machines
/// subjected to digital force control", Int. J. Solids Struct. 38, 2001; Insperger & Stépán,
/// *Semi-Discretization for Time-Delay Systems*, Springer 2011, the digitally controlled
/// inverted pendulum; Kollár, Stépán & Turi, EJDE Conf. 10, 2003, pp. 163-185, the same
/// sampled PD loop). With the pulse transfer `G(z) = k (z + 1) / (z^2 - 2 ch z + 1)`,
/// `k = b (ch - 1) / a`, of the ZOH pendulum and the delayed law `C(z) = (P z + (D/dt)(z - 1)) /
/// z^2`, the characteristic polynomial is
/// `p(z) = z^2 (z^2 - 2 ch z + 1) + k P (z^2 + z) + k (D/dt) (z^2 - 1)`:
/// - `z = 1`: `P = a / b` (the static boundary: the control must beat gravity);
/// - `z = -1` is never a root (`p(-1) = 2 + 2 ch`): no flip boundary;
/// - `z = e^{i phi}`, `0 < phi < pi`: `p = 0` is linear in `(P, D)`, the D-curve.
///
/// The code's multipliers (equations plant, its dual-number linearization, Pade ZOH,
/// companion map) must put a multiplier on the unit circle at `e^{i phi}` exactly on the
/// analytic curve, 1 on the static line, and change stability across the boundary.
#[test]
fn pendulum_stability_boundary_matches_the_analytic_d_curves() {
    let eq = plant::<2>(&pendulum_spec(0.0));
    let (m, l, g): (f64, f64, f64) = (0.3, 0.6, 9.81);
    let (a, bb) = (g / l, 1.0 / (m * l * l));
    let dt = 0.05;
    let w = a.sqrt();
    let ch = (w * dt).cosh();
    let k = bb * (ch - 1.0) / a;
    let radius = |p: f64, d: f64| -> f64 {
        code_multipliers(&eq, 0, 1, &cfg1(p, d, dt)).iter().fold(0.0f64, |r, m| r.max(m.abs))
    };
    // The D-curve: k P w1 + k (D/dt) w2 = -z^2 (z^2 - 2 ch z + 1) at z = e^{i phi}.
    let curve = |phi: f64| -> (f64, f64) {
        let z = nalgebra::Complex::new(phi.cos(), phi.sin());
        let rhs = -(z * z * (z * z - z * 2.0 * ch + 1.0));
        let w1 = z * z + z;
        let w2 = z * z - 1.0;
        // [Re w1, Re w2; Im w1, Im w2] [kP, kD/dt] = [Re rhs, Im rhs]
        let det = w1.re * w2.im - w2.re * w1.im;
        let x = (rhs.re * w2.im - w2.re * rhs.im) / det;
        let y = (w1.re * rhs.im - rhs.re * w1.im) / det;
        (x / k, y / k * dt)
    };
    let p_static = a / bb;
    let mut on_curve = 0;
    for i in 1..40 {
        let phi = std::f64::consts::PI * i as f64 / 40.0;
        let (p, d) = curve(phi);
        if !(p.is_finite() && d.is_finite()) {
            continue;
        }
        let ms = code_multipliers(&eq, 0, 1, &cfg1(p, d, dt));
        let best = ms.iter().map(|m| (m.re - phi.cos()).hypot(m.im - phi.sin())).fold(f64::INFINITY, f64::min);
        assert!(best < 1e-9, "phi {phi}: (P, D) = ({p}, {d}): no multiplier at e^(i phi) (closest {best:e}) in {ms:?}");
        on_curve += 1;
    }
    assert!(on_curve > 30);
    // The static line: a multiplier 1 at P = a/b for any D.
    for d in [0.0, 0.1, 0.3] {
        let ms = code_multipliers(&eq, 0, 1, &cfg1(p_static, d, dt));
        let best = ms.iter().map(|m| (m.re - 1.0).hypot(m.im)).fold(f64::INFINITY, f64::min);
        assert!(best < 1e-9, "D {d}: closest to 1 is {best:e}");
    }
    // Crossing: the stable region is bounded by the static line and the D-curve. Find a
    // stable point from the analytic boundary and check that the code agrees on both sides.
    // For P slightly above a/b, the D range of stability from the curve's D at its P.
    let d_mid = 0.5 * curve(0.3 * std::f64::consts::PI).1.abs().min(1.0);
    let p_in = p_static * 1.05;
    let r_in = radius(p_in, d_mid);
    let r_out = radius(p_static * 0.95, d_mid);
    assert!(r_out > 1.0, "P below a/b must be unstable: radius {r_out}");
    // P alone (D = 0) cannot stabilize the delayed sampled pendulum: the D-curve at D = 0
    // is crossed for every P above a/b.
    for f in [1.01, 1.5, 3.0] {
        assert!(radius(p_static * f, 0.0) > 1.0, "P-only control at {f} a/b");
    }
    // Inside the region: stable where the analytic criterion says so. The analytic
    // criterion: all roots of p inside the unit circle, decided here by the argument
    // principle on the closed-form polynomial (winding number of p(e^{i t}) is 4).
    let winding = |p: f64, d: f64| -> i64 {
        let n = 20000;
        let mut total = 0.0;
        let val = |t: f64| {
            let z = nalgebra::Complex::new(t.cos(), t.sin());
            z * z * (z * z - z * 2.0 * ch + 1.0) + (z * z + z) * (k * p) + (z * z - 1.0) * (k * d / dt)
        };
        let mut prev = val(0.0).arg();
        for j in 1..=n {
            let cur = val(2.0 * std::f64::consts::PI * j as f64 / n as f64).arg();
            let mut dphi = cur - prev;
            if dphi > std::f64::consts::PI {
                dphi -= 2.0 * std::f64::consts::PI;
            }
            if dphi < -std::f64::consts::PI {
                dphi += 2.0 * std::f64::consts::PI;
            }
            total += dphi;
            prev = cur;
        }
        (total / (2.0 * std::f64::consts::PI)).round() as i64
    };
    let mut agree = 0;
    for pi in 0..12 {
        for di in 0..12 {
            let p = p_static * (0.8 + 0.1 * pi as f64);
            let d = 0.02 + 0.03 * di as f64;
            let stable_ref = winding(p, d) == 4;
            let r = radius(p, d);
            if (r - 1.0).abs() < 1e-6 {
                continue; // on the boundary itself
            }
            assert_eq!(r < 1.0, stable_ref, "P = {p}, D = {d}: radius {r}");
            agree += 1;
        }
    }
    assert!(agree > 100);
    let _ = r_in;
}

fn model_err(spec: &EquationsSpec) -> EquationsError {
    match EquationsModel::new(spec) {
        Ok(_) => panic!("accepted {spec:?}"),
        Err(e) => e,
    }
}

/// Every refusal names the key, and the column where there is one.
#[test]
fn bad_equations_are_named_errors() {
    let base = cart_pole_spec(false);
    let with_mass = |mass: Vec<Vec<String>>, forces: Vec<String>| EquationsSpec {
        form: Form::Mass { mass, forces },
        ..base.clone()
    };
    let good_mass = vec![s(&["M + m", "m*l*cos(theta)"]), s(&["m*l*cos(theta)", "m*l^2"])];
    let good_forces = s(&["u + m*l*theta_dot^2*sin(theta) - b*x_dot", "m*g*l*sin(theta) - c*theta_dot"]);
    let cases: Vec<(EquationsSpec, &str, &str)> = vec![
        (
            with_mass(good_mass.clone(), s(&["u + m*l*theta_dot^2*sin(thetta)", "0"])),
            "plant.forces[0]",
            "column 25: unknown name `thetta`",
        ),
        (with_mass(good_mass.clone(), s(&["u +", "0"])), "plant.forces[0]", "column 4"),
        (with_mass(vec![s(&["M + m", "m*l*cos(theta)"])], good_forces.clone()), "plant.mass", "has 1 rows"),
        (
            with_mass(vec![s(&["M + m"]), s(&["m*l*cos(theta)", "m*l^2"])], good_forces.clone()),
            "plant.mass[0]",
            "square",
        ),
        (
            with_mass(vec![s(&["M + m", "m*l*cos(theta)"]), s(&["m*l*sin(theta)", "m*l^2"])], good_forces.clone()),
            "plant.mass[1][0]",
            "not symmetric",
        ),
        (
            with_mass(
                vec![s(&["M + m", "m*l*cos(theta)"]), s(&["m*l*cos(theta)", "m*l^2*x_dot"])],
                good_forces.clone(),
            ),
            "plant.mass[1][1]",
            "column 7: the mass matrix may depend on the coordinates only, not on `x_dot`",
        ),
        (
            with_mass(vec![s(&["m", "m*cos(theta)"]), s(&["m*cos(theta)", "m"])], good_forces.clone()),
            "plant.mass",
            "singular or not positive definite",
        ),
        (
            with_mass(
                vec![s(&["m", "m*cos(theta)*(1 - 1e-12)"]), s(&["m*cos(theta)*(1 - 1e-12)", "m"])],
                good_forces.clone(),
            ),
            "plant.mass",
            "nearly singular",
        ),
        (with_mass(good_mass.clone(), s(&["u"])), "plant.forces", "has 1 entries for 2 coordinates"),
        (with_mass(good_mass.clone(), s(&["u", "m*g*l*cos(theta)"])), "plant.forces[1]", "not zero"),
        (with_mass(good_mass.clone(), s(&["u", "sqrt(theta)"])), "plant.forces[1]", "not finite"),
        (with_mass(good_mass.clone(), s(&["u", "log(theta)"])), "plant.forces[1]", "not finite"),
        (
            EquationsSpec {
                form: Form::Lagrangian {
                    lagrangian: "-0.5*m*x_dot^2 + theta_dot^2".into(),
                    generalized_forces: s(&["u", "0"]),
                },
                ..base.clone()
            },
            "plant.lagrangian",
            "not positive definite",
        ),
        (
            EquationsSpec {
                form: Form::Lagrangian {
                    lagrangian: "x_dot^4 + theta_dot^2".into(),
                    generalized_forces: s(&["u", "0"]),
                },
                ..base.clone()
            },
            "plant.lagrangian",
            "quadratic in the velocities",
        ),
        (
            EquationsSpec {
                form: Form::Lagrangian { lagrangian: "x_dot^2 + theta_dot^2".into(), generalized_forces: s(&["u"]) },
                ..base.clone()
            },
            "plant.generalized_forces",
            "has 1 entries",
        ),
        (
            EquationsSpec { coordinates: s(&["a", "b", "c", "d", "e"]), ..base.clone() },
            "plant.coordinates",
            "at most 4 are supported",
        ),
        (EquationsSpec { coordinates: s(&["x", "sin"]), ..base.clone() }, "plant.coordinates[1]", "reserved"),
        (EquationsSpec { coordinates: s(&["x", "x"]), ..base.clone() }, "plant.coordinates", "occurs twice"),
        (
            EquationsSpec { parameters: vec![("theta".into(), 1.0)], ..base.clone() },
            "plant.parameters.theta",
            "also a coordinate",
        ),
        (EquationsSpec { parameters: vec![("m".into(), f64::NAN)], ..base.clone() }, "plant.parameters.m", "finite"),
        (EquationsSpec { equilibrium: Some(vec![0.0]), ..base.clone() }, "plant.equilibrium", "has 1 values"),
    ];
    for (spec, key, what) in cases {
        let e = model_err(&spec);
        assert_eq!(e.key, key, "{e}");
        assert!(e.message.contains(what), "{key}: `{}` does not say `{what}`", e.message);
    }
}

/// A named equilibrium: the hanging pendulum (`theta = pi`) is an equilibrium of forces that
/// are not zero at the origin's upright position... and the upright one of a pendulum
/// measured from hanging is refused at the origin until named.
#[test]
fn equilibrium_shifts_the_states() {
    // theta measured from hanging: m l^2 theta'' = -m g l sin(theta) + u; upright is pi.
    let spec = EquationsSpec {
        coordinates: s(&["theta"]),
        parameters: vec![("m".into(), 0.3), ("l".into(), 0.6), ("g".into(), 9.81)],
        form: Form::Mass { mass: vec![s(&["m*l^2"])], forces: s(&["-m*g*l*sin(theta) + u + 0.1*cos(theta) - 0.1"]) },
        equilibrium: None,
    };
    let e = model_err(&EquationsSpec {
        form: Form::Mass { mass: vec![s(&["m*l^2"])], forces: s(&["-m*g*l*cos(theta) + u"]) },
        ..spec.clone()
    });
    assert!(e.message.contains("plant.equilibrium"), "{e}");
    let up = plant::<2>(&EquationsSpec {
        form: Form::Mass { mass: vec![s(&["m*l^2"])], forces: s(&["-m*g*l*sin(theta) + u"]) },
        equilibrium: Some(vec![std::f64::consts::PI]),
        ..spec.clone()
    });
    let upright = plant::<2>(&pendulum_spec(0.0));
    assert_rhs_close(&up, &upright, 1e-14, "shifted");
    let _ = Dual::<1>::cst(0.0);
}

/// The right-hand side evaluates over truncated power series (the equation-driven SSM's
/// scalar) to the same coefficients as the built-in Furuta plant.
#[test]
fn power_series_rhs_equals_the_builtin() {
    use sim::taylor::{Tps, TpsTable};
    let t = TpsTable::get(4, 5).unwrap();
    let x: [Tps; 4] = core::array::from_fn(|i| Tps::var(t, i, 0.1 * i as f64));
    let u = Tps::constant(t, 0.3);
    let a = Furuta::paper().rhs(&x, u);
    let b = plant::<4>(&furuta_spec(false)).rhs(&x, u);
    for i in 0..4 {
        let scale = a[i].coefficients().iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let err = a[i].coefficients().iter().zip(b[i].coefficients()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(err <= 1e-11 * scale, "component {i}: {err:e} of {scale:e}");
    }
}

/// The Jacobian from the compiled symbolic derivatives equals the dual-number one to
/// rounding, and its `f` is the right-hand side's to the bit (mass and Lagrangian forms).
#[test]
fn symbolic_jacobian_equals_the_dual_number_one() {
    fn check<const N: usize>(p: &EquationsPlant<N>, what: &str) {
        assert!(p.model().jac_tape().is_some(), "{what}: no Jacobian tape");
        for (k, x) in states::<N>(20).into_iter().enumerate() {
            let u = 0.7 * k as f64 - 5.0;
            let (f, jac) = p.exact_jacobian(&x, u);
            let (fd, jd) = sim::plant::linearize::dual_jacobian(p, &x, u);
            let rhs = p.rhs(&x, u);
            assert_eq!(f.map(f64::to_bits), rhs.map(f64::to_bits), "{what}: f at {x:?}");
            let scale = jd.iter().flatten().fold(1.0f64, |m, v| m.max(v.abs()));
            for i in 0..N {
                assert!((f[i] - fd[i]).abs() <= 1e-13 * (1.0 + fd[i].abs()), "{what}: f[{i}]");
                for j in 0..N {
                    let e = (jac[i][j] - jd[i][j]).abs();
                    assert!(e <= 1e-12 * scale, "{what}: J[{i}][{j}] {} vs {} at {x:?}", jac[i][j], jd[i][j]);
                }
            }
        }
    }
    for lagrangian in [false, true] {
        check(&plant::<4>(&furuta_spec(lagrangian)), "furuta");
        check(&plant::<4>(&cart_pole_spec(lagrangian)), "cart-pole");
    }
    check(&plant::<2>(&pendulum_spec(0.01)), "pendulum");
}

/// Three and four coupled coordinates whose mass matrix needs row exchanges in places (a
/// small first diagonal entry beside large couplings, still positive definite): the
/// unrolled solve of the right-hand side equals the general LU on slices bit for bit, the
/// dual numbers' values equal the `f64` evaluation, and the Jacobian's `f` is the rhs's.
#[test]
fn unrolled_solves_equal_the_general_lu_for_every_size() {
    fn spec(n: usize) -> EquationsSpec {
        let q: Vec<String> = (0..n).map(|i| format!("q{i}")).collect();
        let mass = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| match (i, j) {
                        (0, 0) => "0.2 + 0.1*cos(q0)^2".to_string(),
                        (i, j) if i == j => format!("{}", 10 * i),
                        (i, j) => format!("0.9*cos({} - {})", q[i.min(j)], q[i.max(j)]),
                    })
                    .collect()
            })
            .collect();
        let forces = (0..n).map(|i| format!("u - 0.1*{0}_dot + sin({0}) - {0}_dot^2*sin({0})", q[i])).collect();
        EquationsSpec { coordinates: q, parameters: vec![], form: Form::Mass { mass, forces }, equilibrium: None }
    }
    fn check<const N: usize>() {
        let n = N / 2;
        let p = plant::<N>(&spec(n));
        let mut swaps = 0;
        for (k, x) in states::<N>(100).into_iter().enumerate() {
            let u = 0.3 * k as f64 - 10.0;
            let rhs = p.rhs(&x, u);
            // The reference: the tape's outputs into the general LU on slices.
            let mut inputs = vec![0.0; 2 * n + 1];
            for i in 0..n {
                inputs[i] = x[2 * i];
                inputs[n + i] = x[2 * i + 1];
            }
            inputs[2 * n] = u;
            let outs = p.model().tape().eval_f64(&inputs);
            let nm = n * (n + 1) / 2;
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    a[i * n + j] = outs[upper_index(n, i.min(j), i.max(j))];
                }
            }
            if (1..n).any(|i| a[i * n].abs() > a[0].abs()) {
                swaps += 1;
            }
            let mut b = outs[nm..].to_vec();
            lu_solve(&mut a, &mut b, n);
            for i in 0..n {
                assert_eq!(rhs[2 * i + 1].to_bits(), b[i].to_bits(), "n = {n}, x = {x:?}: q''_{i}");
                assert_eq!(rhs[2 * i].to_bits(), x[2 * i + 1].to_bits());
            }
            let xd: [Dual<1>; N] = core::array::from_fn(|i| Dual::cst(x[i]));
            let vd = p.rhs(&xd, Dual::var(u, 0));
            assert_eq!(vd.map(|d| d.v.to_bits()), rhs.map(f64::to_bits), "n = {n}: dual values");
            let (f, jac) = p.exact_jacobian(&x, u);
            let jo = p.model().jac_tape().unwrap().eval_f64(&inputs);
            assert_eq!(
                jo[..outs.len()].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                outs.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "n = {n}: the Jacobian tape's values {jo:?} vs {outs:?}"
            );
            assert_eq!(f.map(f64::to_bits), rhs.map(f64::to_bits), "n = {n}: the Jacobian's f");
            let (_, jd) = sim::plant::linearize::dual_jacobian(&p, &x, u);
            let scale = jd.iter().flatten().fold(1.0f64, |m, v| m.max(v.abs()));
            for i in 0..N {
                for j in 0..N {
                    assert!((jac[i][j] - jd[i][j]).abs() <= 1e-12 * scale, "n = {n}: J[{i}][{j}] at {x:?}");
                }
            }
        }
        assert!(swaps > 0, "n = {n}: no state needed a row exchange");
    }
    check::<6>();
    check::<8>();
}

/// Every bundled equation scene's plant compiled with and without the fused product chains
/// (`(a*b)*k1 + k2`, `c - (a*b)*d`, `c - (a*k)*b` as one instruction) has the same
/// right-hand side bit for bit in `f64`, dual numbers and power series, and the same
/// Jacobian, at random states and at states with NaN, infinities and signed zeros.
#[test]
fn fused_chains_keep_every_bundled_scene_bit_for_bit() {
    use sim::expr::internals::WITHOUT_CHAIN_FUSION;
    let (scenes, shorter) = compare_bundled_scenes(&WITHOUT_CHAIN_FUSION);
    assert!(scenes >= 4, "{scenes} bundled equation scenes");
    assert!(shorter >= 1, "the chain fusion shortened no bundled scene's tapes");
}

/// Every bundled equation scene's plant evaluated by native code and by the interpreter
/// has the same right-hand side and Jacobian bit for bit, at random states and at states
/// with NaN, infinities and signed zeros; on x86-64 the tapes do run as native code.
#[test]
fn native_code_keeps_every_bundled_scene_bit_for_bit() {
    use sim::closed_loop::{AnyPlant, build_plant};
    use sim::expr::internals::WITHOUT_NATIVE;
    let (scenes, _) = compare_bundled_scenes(&WITHOUT_NATIVE);
    assert!(scenes >= 4, "{scenes} bundled equation scenes");
    let scene = sim::scene::Scene::load("furuta-equations", &[]).unwrap();
    let AnyPlant::Equations2(p) = build_plant(&scene).unwrap() else { panic!("furuta-equations: not 2 coordinates") };
    let native = [p.model().tape().is_native(), p.model().jac_tape().is_some_and(Tape::is_native)];
    assert_eq!(native, [cfg!(target_arch = "x86_64"); 2], "value and Jacobian tapes native");
    let plain = sim::expr::interpreted(|| build_plant(&scene));
    let AnyPlant::Equations2(plain) = plain.unwrap() else { panic!("furuta-equations: not 2 coordinates") };
    assert!(!plain.model().tape().is_native(), "`interpreted` turns native code off");
    assert!(
        build_plant(&scene).is_ok_and(
            |p| matches!(p, AnyPlant::Equations2(p) if p.model().tape().is_native() == cfg!(target_arch = "x86_64"))
        ),
        "and back on after it"
    );
}

/// Compares every bundled equation scene's plant built as usual with the one built while
/// `switch` is set (a compiler option off): right-hand sides in `f64`, dual numbers and
/// power series, and Jacobians, bit for bit. Returns the number of scenes and of those
/// whose tapes the option made shorter.
fn compare_bundled_scenes(switch: &'static std::thread::LocalKey<std::cell::Cell<bool>>) -> (usize, usize) {
    use sim::closed_loop::{AnyPlant, build_plant};
    use sim::taylor::{Tps, TpsTable};
    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }
    fn check<const N: usize>(a: &EquationsPlant<N>, b: &EquationsPlant<N>, what: &str) {
        let special = [0.0, -0.0, 0.3, -2.5, f64::INFINITY, f64::NEG_INFINITY, f64::NAN, 1e300];
        let mut xs = states::<N>(20);
        for k in 0..special.len() {
            xs.push(core::array::from_fn(|i| special[(k + 3 * i) % special.len()]));
        }
        let t = TpsTable::get(N, 3).unwrap();
        for (k, x) in xs.iter().enumerate() {
            let u = [0.7 * k as f64 - 5.0, -0.0, f64::NAN][k % 3];
            let (fa, fb) = (a.rhs(x, u), b.rhs(x, u));
            assert!(fa.iter().zip(&fb).all(|(p, q)| same(*p, *q)), "{what}: rhs at {x:?}: {fa:?} vs {fb:?}");
            let (ja, jb) = (a.exact_jacobian(x, u), b.exact_jacobian(x, u));
            let flat =
                |j: &([f64; N], [[f64; N]; N])| j.0.iter().chain(j.1.iter().flatten()).copied().collect::<Vec<_>>();
            assert!(flat(&ja).iter().zip(&flat(&jb)).all(|(p, q)| same(*p, *q)), "{what}: Jacobian at {x:?}");
            let (da, db) = (linearize::dual_jacobian(a, x, u), linearize::dual_jacobian(b, x, u));
            assert!(flat(&da).iter().zip(&flat(&db)).all(|(p, q)| same(*p, *q)), "{what}: dual numbers at {x:?}");
            let xt: [Tps; N] = core::array::from_fn(|i| Tps::var(t, i, x[i]));
            let ut = Tps::constant(t, u);
            for (p, q) in a.rhs(&xt, ut).iter().zip(&b.rhs(&xt, ut)) {
                let same_tps = p.coefficients().iter().zip(q.coefficients()).all(|(p, q)| same(*p, *q));
                assert!(same_tps, "{what}: power series at {x:?}");
            }
        }
    }
    let mut shorter = 0;
    let mut scenes = 0;
    for (name, text) in sim::scene::BUNDLED {
        if !text.contains("kind = \"equations\"") {
            continue;
        }
        scenes += 1;
        let scene = sim::scene::Scene::load(name, &[]).unwrap();
        let fused = build_plant(&scene).unwrap();
        switch.with(|c| c.set(true));
        let plain = build_plant(&scene);
        switch.with(|c| c.set(false));
        let plain = plain.unwrap();
        let lens = |p: &EquationsModel| p.tape().len() + p.jac_tape().map_or(0, Tape::len);
        match (&fused, &plain) {
            (AnyPlant::Equations1(a), AnyPlant::Equations1(b)) => {
                shorter += usize::from(lens(a.model()) < lens(b.model()));
                check(a, b, name)
            }
            (AnyPlant::Equations2(a), AnyPlant::Equations2(b)) => {
                shorter += usize::from(lens(a.model()) < lens(b.model()));
                check(a, b, name)
            }
            (AnyPlant::Equations3(a), AnyPlant::Equations3(b)) => {
                shorter += usize::from(lens(a.model()) < lens(b.model()));
                check(a, b, name)
            }
            (AnyPlant::Equations4(a), AnyPlant::Equations4(b)) => {
                shorter += usize::from(lens(a.model()) < lens(b.model()));
                check(a, b, name)
            }
            _ => panic!("{name}: not an equations plant"),
        }
    }
    (scenes, shorter)
}
