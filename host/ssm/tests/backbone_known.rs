//! Backbone curves of a FITTED model against the analytic backbone of the system that made
//! the data.
//!
//! The system is a polar normal form, `rho' = (A + B rho^2) rho`, `theta' = W + C rho^2`,
//! i.e. `z' = z (A + i W + (B + i C) |z|^2)`, observed through `y_0 = Re z` and
//! `y_1 = Im z + 0.2 (Re z)^2`. Its backbone in observable 0 is analytic: amplitude `rho`,
//! frequency `W + C rho^2` (rad/s), damping ratio `zeta = -(A + B rho^2) / |(A + B rho^2) +
//! i (W + C rho^2)|` (the definition of `ssm::backbone`). The fit sees only samples.

use std::time::Instant;

use ssm::backbone::{BackboneOptions, backbone};
use ssm::{Dynamics, FitOptions, MultiSeries, Ridge, fit_multi};

const A: f64 = -0.1;
const W: f64 = std::f64::consts::TAU;
const B: f64 = -0.5;
const C: f64 = 1.0;

fn rhs(x: [f64; 2]) -> [f64; 2] {
    let r2 = x[0] * x[0] + x[1] * x[1];
    let (g, o) = (A + B * r2, W + C * r2);
    [g * x[0] - o * x[1], o * x[0] + g * x[1]]
}

/// Samples every `dt` for `t_end` s from `z0 = rho0 e^{i theta0}` (RK4, 20 steps per sample).
fn trajectory(name: &str, rho0: f64, theta0: f64, dt: f64, t_end: f64) -> MultiSeries {
    let n = (t_end / dt).round() as usize + 1;
    let mut x = [rho0 * theta0.cos(), rho0 * theta0.sin()];
    let (mut t, mut obs) = (Vec::with_capacity(n), Vec::with_capacity(2 * n));
    let h = dt / 20.0;
    for k in 0..n {
        t.push(k as f64 * dt);
        obs.extend([x[0], x[1] + 0.2 * x[0] * x[0]]);
        for _ in 0..20 {
            let add = |a: [f64; 2], b: [f64; 2], s: f64| [a[0] + s * b[0], a[1] + s * b[1]];
            let k1 = rhs(x);
            let k2 = rhs(add(x, k1, h / 2.0));
            let k3 = rhs(add(x, k2, h / 2.0));
            let k4 = rhs(add(x, k3, h));
            x = [0, 1].map(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
    }
    MultiSeries::new(name, t, vec!["re".into(), "im_plus".into()], obs).unwrap()
}

#[test]
fn fitted_backbone_matches_the_analytic_one() {
    let dt = 0.01;
    let train = [trajectory("a", 1.0, 0.0, dt, 20.0), trajectory("b", 0.9, 2.0, dt, 20.0)];
    for (dynamics, dyn_order) in [(Dynamics::Flow, 5), (Dynamics::Map, 5)] {
        let opts = FitOptions {
            dim: 2,
            embed: 3,
            shift: 1,
            manifold_order: 3,
            dyn_order,
            dynamics,
            ridge: Ridge::Fixed(0.0),
            linear_anchor: None,
            anchor_joint: false,
        };
        let t0 = Instant::now();
        let model = fit_multi(&train, &opts).unwrap();
        let fit_ms = t0.elapsed().as_secs_f64() * 1e3;
        let amp_max = 0.9;
        let t1 = Instant::now();
        let bb = backbone(&model, &BackboneOptions::new(0, amp_max)).unwrap();
        let bb_ms = t1.elapsed().as_secs_f64() * 1e3;
        assert_eq!(bb.len(), 1);
        let (mut e_freq, mut e_zeta, mut e_amp_rho): (f64, f64, f64) = (0.0, 0.0, 0.0);
        for p in &bb[0].points {
            let r = p.amplitude;
            let (g, o) = (A + B * r * r, W + C * r * r);
            e_freq = e_freq.max((p.freq_rad_s - o).abs() / o);
            e_zeta = e_zeta.max((p.damping_ratio + g / g.hypot(o)).abs());
            // The normal form's rho is the observable's amplitude at linear order only.
            e_amp_rho = e_amp_rho.max((p.amplitude - p.rho).abs());
        }
        let last = bb[0].points.last().unwrap();
        eprintln!(
            "{dynamics:?} order {dyn_order}: fit {fit_ms:.2} ms, backbone {bb_ms:.2} ms; up to amplitude {amp_max}: max relative frequency \
             error {e_freq:.2e}, max damping-ratio error {e_zeta:.2e} (zeta from {:.4} to {:.4}); |amplitude - rho| up to {e_amp_rho:.2e}",
            bb[0].points[0].damping_ratio, last.damping_ratio
        );
        assert!((last.amplitude - amp_max).abs() < 1e-9, "{last:?}");
        assert!(e_freq < 2e-3, "{dynamics:?}: frequency error {e_freq}");
        assert!(e_zeta < 1e-3, "{dynamics:?}: damping-ratio error {e_zeta}");
    }
}
