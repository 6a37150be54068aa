use sim::plant::furuta::*;
use sim::plant::{Plant, PlantError};

/// The equations exactly as written in MODEL.md, with no rearrangement.
fn model_md(p: &FurutaParams, x: &[f64; 4], u: f64) -> [f64; 4] {
    let [th, wt, _, wp] = *x;
    let (s, c) = (th.sin(), th.cos());
    let mrl = p.m * p.r * p.l;
    let delta = p.jp * (p.ja + p.jp * s * s) - mrl * mrl * c * c;
    let m = p.n * u - p.k * wp;
    let a = m - 2.0 * p.jp * s * c * wt * wp - p.b2 * wp - mrl * s * wt * wt;
    let b = p.jp * s * c * wp * wp - p.b1 * wt + p.m * p.g * p.l * s;
    [wt, ((p.ja + p.jp * s * s) * b + mrl * c * a) / delta, wp, (p.jp * a + mrl * c * b) / delta]
}

#[test]
// 1.5707 is a state near (not at) pi/2 on purpose.
#[allow(clippy::approx_constant)]
fn rhs_matches_model_md() {
    let f = Furuta::paper();
    for (x, u) in [
        ([0.0, 0.0, 0.0, 0.0], 0.0),
        ([0.3, -1.2, 4.0, 2.5], 1.7),
        ([-2.9, 3.0, -1.0, -7.0], -12.0),
        ([1.5707, 0.1, 0.0, 30.0], 24.0),
    ] {
        let got = f.rhs(&x, u);
        let want = model_md(f.params(), &x, u);
        for i in 0..4 {
            // The reference loses about a digit to cancellation in Delta.
            let tol = 1e-12 * want[i].abs().max(1.0);
            assert!((got[i] - want[i]).abs() <= tol, "x={x:?} i={i}: {} vs {}", got[i], want[i]);
        }
    }
}

/// The closed-form Jacobian against the dual-number one at random states (a fixed-seed
/// LCG), from the upright to tumbling: the same values to rounding.
#[test]
fn closed_form_jacobian_matches_dual_numbers() {
    let plant = Furuta::paper();
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut uniform = |lo: f64, hi: f64| {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut worst = 0.0f64;
    for k in 0..500 {
        // The first states near the upright, where the controller keeps the pendulum.
        let r = if k < 100 { 0.05 } else { 1.0 };
        let x = [uniform(-3.2, 3.2) * r, uniform(-20.0, 20.0) * r, uniform(-10.0, 10.0), uniform(-40.0, 40.0) * r];
        let u = uniform(-24.0, 24.0);
        let (f, jac) = plant.rhs_and_jacobian(&x, u);
        let (fd, jd) = sim::plant::jacobian(&plant, &x, u);
        for i in 0..4 {
            let scale = jd[i].iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
            for j in 0..4 {
                let e = (jac[i][j] - jd[i][j]).abs() / scale;
                worst = worst.max(e);
                assert!(e <= 1e-12, "x={x:?} u={u}: d f{i}/d x{j} = {:e}, dual {:e}", jac[i][j], jd[i][j]);
            }
            assert!((f[i] - fd[i]).abs() <= 1e-14 * fd[i].abs().max(1.0), "x={x:?}: f{i} {} vs {}", f[i], fd[i]);
        }
    }
    eprintln!("closed-form vs dual Jacobian: worst relative difference {worst:e}");
}

#[test]
fn energy_rate_equals_power_balance() {
    // dE/dt = N*u*w_phi - K*w_phi^2 - b1*w_theta^2 - b2*w_phi^2 along the flow.
    let f = Furuta::paper();
    let p = *f.params();
    let x = [0.4, -0.7, 0.2, 1.3];
    let u = 2.0;
    let dx = f.rhs(&x, u);
    let eps = 1e-6;
    let xp: [f64; 4] = core::array::from_fn(|i| x[i] + eps * dx[i]);
    let xm: [f64; 4] = core::array::from_fn(|i| x[i] - eps * dx[i]);
    let de = (f.energy(&xp) - f.energy(&xm)) / (2.0 * eps);
    let power = p.n * u * x[3] - p.k * x[3] * x[3] - p.b1 * x[1] * x[1] - p.b2 * x[3] * x[3];
    assert!((de - power).abs() < 1e-7 * power.abs().max(1.0), "{de} vs {power}");
}

#[test]
fn paper_delta_min() {
    let f = Furuta::paper();
    let p = f.params();
    let want = p.jp * p.ja - (p.m * p.r * p.l).powi(2);
    assert!((f.delta(0.0) - want).abs() < 1e-20, "{} vs {want}", f.delta(0.0));
    // MODEL.md: Delta(0) = 4.25e-7.
    assert!((f.delta(0.0) - 4.25e-7).abs() < 0.01e-7, "{}", f.delta(0.0));
    // The general formula at theta = 1.
    let (s, c) = 1.0f64.sin_cos();
    let d1 = p.jp * (p.ja + p.jp * s * s) - (p.m * p.r * p.l * c).powi(2);
    assert!((f.delta(1.0) - d1).abs() < 1e-12 * d1);
    assert!(f.delta(1.0) > f.delta(0.0));
}

#[test]
fn validation_names_the_field() {
    let base = FurutaParams::default();
    let cases: [(FurutaParams, PlantError); 6] = [
        (FurutaParams { jp: f64::NAN, ..base }, PlantError::NotFinite { field: "jp", value: f64::NAN }),
        (FurutaParams { k: f64::INFINITY, ..base }, PlantError::NotFinite { field: "k", value: f64::INFINITY }),
        (FurutaParams { m: 0.0, ..base }, PlantError::NotPositive { field: "m", value: 0.0 }),
        (FurutaParams { n: -1.0, ..base }, PlantError::NotPositive { field: "n", value: -1.0 }),
        (FurutaParams { b2: -0.1, ..base }, PlantError::Negative { field: "b2", value: -0.1 }),
        (FurutaParams { b1: -1e-9, ..base }, PlantError::Negative { field: "b1", value: -1e-9 }),
    ];
    for (p, want) in cases {
        let got = Furuta::new(p).unwrap_err();
        match (&got, &want) {
            (PlantError::NotFinite { field: a, .. }, PlantError::NotFinite { field: b, .. }) => {
                assert_eq!(a, b)
            }
            _ => assert_eq!(got, want),
        }
        let field = match want {
            PlantError::NotFinite { field, .. }
            | PlantError::NotPositive { field, .. }
            | PlantError::Negative { field, .. } => field,
            _ => unreachable!(),
        };
        assert!(got.to_string().contains(&format!("`{field}`")), "{got}");
    }
    // Zero damping and zero back-EMF are allowed.
    assert!(Furuta::new(FurutaParams { b1: 0.0, b2: 0.0, k: 0.0, ..base }).is_ok());
}

#[test]
fn singular_and_near_singular_mass_matrix_rejected() {
    let base = FurutaParams::default();
    let mrl = base.m * base.r * base.l;
    // Delta(0) exactly zero or negative: ja = mrl^2/jp, or smaller.
    for ja in [mrl * mrl / base.jp * 0.999, mrl * mrl / base.jp * 0.5] {
        match Furuta::new(FurutaParams { ja, ..base }) {
            Err(PlantError::SingularMassMatrix { delta_min, .. }) => assert!(delta_min <= 0.0),
            other => panic!("ja={ja}: {other:?}"),
        }
    }
    // Positive but tiny: 1e-11 relative.
    let ja = mrl * mrl / base.jp * (1.0 + 1e-11);
    match Furuta::new(FurutaParams { ja, ..base }) {
        Err(PlantError::NearSingularMassMatrix { delta_min, threshold, .. }) => {
            assert!(delta_min > 0.0 && delta_min < threshold, "{delta_min} {threshold}");
            assert!(delta_min.is_finite());
        }
        other => panic!("{other:?}"),
    }
    // Comfortably positive: accepted, and the rhs is finite at the worst angle.
    let ja = mrl * mrl / base.jp * (1.0 + 1e-6);
    let f = Furuta::new(FurutaParams { ja, ..base }).unwrap();
    assert!(f.rhs(&[0.0, 1.0, 0.0, 1.0], 1.0).iter().all(|v| v.is_finite()));
}

#[test]
fn params_serde_defaults_and_unknown_fields() {
    let p: FurutaParams = serde_json::from_str(r#"{"m": 0.2}"#).unwrap();
    assert_eq!(p, FurutaParams { m: 0.2, ..FurutaParams::default() });
    let e = serde_json::from_str::<FurutaParams>(r#"{"mass": 0.2}"#).unwrap_err();
    assert!(e.to_string().contains("mass"), "{e}");
}
