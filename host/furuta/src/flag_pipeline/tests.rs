use super::*;

/// The tangent of every system is the derivative of its right-hand side (central
/// differences, step 1e-6, at a generic state).
#[test]
fn tangent_is_the_derivative_of_the_rhs() {
    for sys in [KnownSystem::Lorenz96 { n: 4, f: 18.0 }, KnownSystem::Lorenz96 { n: 5, f: 8.0 }, KnownSystem::CoupledLorenz { c: 1.5 }, KnownSystem::LorenzX { rho: 28.0 }, KnownSystem::Rossler { a: 0.2, b: 0.2, c: 5.7 }] {
        let n = sys.dim();
        let x: Vec<f64> = (0..n).map(|i| 1.3 + 0.7 * (i as f64 * 1.9).sin()).collect();
        let v: Vec<f64> = (0..n).map(|i| 0.4 - 0.3 * (i as f64 * 0.8).cos()).collect();
        let (mut o, mut w) = (vec![0.0; n], vec![0.0; n]);
        sys.rhs(&x, &v, &mut o, &mut w);
        let h = 1e-6;
        let f = |s: f64| {
            let y: Vec<f64> = x.iter().zip(&v).map(|(a, b)| a + s * b).collect();
            let (mut o, mut w) = (vec![0.0; n], vec![0.0; n]);
            sys.rhs(&y, &v, &mut o, &mut w);
            o
        };
        let (p, m) = (f(h), f(-h));
        for i in 0..n {
            let fd = (p[i] - m[i]) / (2.0 * h);
            assert!((fd - w[i]).abs() < 1e-6 * (1.0 + w[i].abs()), "{} component {i}: {fd} vs {}", sys.name(), w[i]);
        }
    }
}

/// The integrator and Benettin on the Lorenz system: the published largest exponent 0.906 1/s.
#[test]
fn lorenz_exponent_is_the_published_one() {
    let (l, e) = KnownSystem::LorenzX { rho: 28.0 }.exponent(0.01, 2_000, 200_000).unwrap();
    assert!((l - 0.906).abs() < 0.02 && e < 0.02, "{l} ± {e}");
}

/// The chosen system sampled like the flag (known answers, measured): lag 11 and Theiler
/// window 39 at map step 4 (the flag: 11, 38), D2 3.04 ± 0.16 (in [2.9, 3.5], the flag's
/// 3.13-3.36 within the bars), Rosenstein 0.337 1/s (the flag: 0.332), exact exponent
/// 0.990 ± 0.015 1/s, 0.63 nats per lag. The exact exponent does not depend on the
/// renormalization step: at a 4 times longer step (the map step) it agrees within 3 %.
#[test]
fn chosen_system_sampled_like_the_flag() {
    let (k, series) = known_stats(&CHOSEN, &FLAG_LAYOUT, 1, 4000.0).unwrap();
    assert_eq!(series.iter().map(|s| s.x.len()).collect::<Vec<_>>(), vec![12_922, 12_631, 7_890]);
    assert_eq!((k.lag, k.theiler), (11, 39), "{k:?}");
    assert!((2.9..=3.5).contains(&k.corr_dim) && (k.corr_dim - 3.04).abs() < 0.05 && k.corr_dim_err < 0.25, "{k:?}");
    assert!((k.exact - 0.990).abs() < 0.03 && k.exact_err < 0.03, "{k:?}");
    assert!((0.55..=0.70).contains(&k.per_lag), "{k:?}");
    assert!((k.rosenstein - 0.337).abs() < 0.02, "{k:?}");
    assert!((k.step_dt - 4.0 * k.dt).abs() < 1e-12, "{k:?}");
    let (l4, e4) = CHOSEN.exponent(4.0 * k.dt, 2_000, 70_000).unwrap();
    assert!((l4 - k.exact).abs() < 0.03 * k.exact && e4 < 0.03, "{l4} ± {e4} vs {}", k.exact);
}

/// The flag-like series: consecutive pieces of one orbit with white noise of the given level
/// relative to each piece's sd (the noise measured against the noise-free orbit: within 5 %).
#[test]
fn flag_like_series_lengths_and_noise() {
    let sys = KnownSystem::Lorenz96 { n: 5, f: 8.0 };
    let clean = sys.flag_like_series(0.01, &[3000, 2000], 0.0).unwrap();
    let noisy = sys.flag_like_series(0.01, &[3000, 2000], 0.02).unwrap();
    for (c, y) in clean.iter().zip(&noisy) {
        assert_eq!(c.x.len(), y.x.len());
        assert!((c.t[1] - 0.01).abs() < 1e-15);
        let e: Vec<f64> = c.x.iter().zip(&y.x).map(|(a, b)| b - a).collect();
        let rel = sd(&e) / sd(&c.x);
        assert!((rel - 0.02).abs() < 0.001, "{rel}");
    }
    // The pieces do not repeat each other.
    assert!((clean[0].x[0] - clean[1].x[0]).abs() > 1e-6);
}

/// Bad options are errors naming what is wrong.
#[test]
fn bad_options_are_errors() {
    let sys = KnownSystem::LorenzX { rho: 28.0 };
    assert!(sys.flag_like_series(0.0, &[100], 0.0).is_err());
    assert!(sys.flag_like_series(0.01, &[1], 0.0).is_err());
    assert!(sys.flag_like_series(0.01, &[100], -1.0).is_err());
    assert!(sys.step_for_lag(0, 11).is_err());
    assert!(known_stats(&sys, &FLAG_LAYOUT, 0, 100.0).unwrap_err().to_string().contains("scale"));
    assert!(known_stats(&sys, &FLAG_LAYOUT, 1, f64::NAN).unwrap_err().to_string().contains("benettin_time"));
}

/// Flag-like candidates: the flag search's options at the map step, RBF rows then the
/// polynomial map.
#[test]
fn flag_like_candidates_have_the_flag_options() {
    let c = flag_like_candidates(4, &FLAG_LIKE_RBF);
    assert_eq!(c.len(), FLAG_LIKE_RBF.len() + 1);
    assert!(c.iter().all(|c| c.step == 4 && c.fit.dim == 4 && c.fit.embed == 9 && c.fit.shift == 1 && c.fit.manifold_order == 3));
    assert_eq!(c[0].fit.dynamics, ssm::Dynamics::Rbf { centers: 200 });
    assert_eq!(c.last().unwrap().fit.dynamics, ssm::Dynamics::Map);
}
