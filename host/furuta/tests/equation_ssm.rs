//! The tests of `furuta::equation_ssm`.

use furuta::Error;
use furuta::equation_ssm::*;
use sim::scene::Scene;
use ssm::interp::Interp;
use ssm::portrait::PointKind;

/// Linear rates are `ln|mu|/dt` of the exact ZOH multipliers; the invariance error on the
/// sphere of radius 0.05 rad falls with the order; no small divisor at 31 ms.
#[test]
fn furuta_equation_ssm_rates_and_invariance() {
    let e = furuta_equation_ssm(31.0, 5).unwrap();
    for i in 0..2 {
        let (got, want) = (e.polar.amp[i][0], e.exact_rates[i]);
        assert!((got - want).abs() < 1e-9 * want.abs().max(1.0), "mode {i}: {got} vs {want}");
    }
    assert_eq!(e.invariance.len(), 4);
    for pair in e.invariance.chunks(2) {
        let (e3, e5) = (pair[0].abs, pair[1].abs);
        eprintln!("invariance at r = {}: order 3 {e3:.3e}, order 5 {e5:.3e}", pair[0].radius);
        assert!(e5 < e3 / 3.0, "{e3} {e5}");
    }
    eprintln!("{}", e.table.to_text());
    assert!(e.extra_resonances.is_empty(), "{:?}", e.extra_resonances);
    assert!(e.min_divisor > RESONANCE_TOL);
    // Mode 1 slow (~0.44 Hz), mode 2 fast (~8.3 Hz).
    assert!(e.polar.eigenvalues[0].1 < e.polar.eigenvalues[1].1);
}

/// The equation-driven model's global bifurcations by the data-driven model's portrait
/// scans, on five order-7 nodes (0.5 ms apart, spline): the saddle connection of the
/// fast-mode saddle cycle comes before the subcritical torus Hopf, both inside
/// 30.5-32.5 ms. The values are printed and pinned against regressions (amplitudes
/// normalized by `Amplitude::Observable`; with `Amplitude::Spectral` all three came later;
/// the report sets them beside the full system's).
#[test]
fn furuta_equation_bifurcations_order7() {
    let model = EquationModel::furuta(&[30.5, 31.0, 31.5, 32.0, 32.5], 7).unwrap();
    // Interpolation error at the middle of a 0.5 ms interval.
    let direct = furuta_equation_polar(31.25, 7).unwrap();
    let nf = model.normal_form_at(31.25, Interp::Spline).unwrap();
    let rel = nf
        .amp
        .iter()
        .flatten()
        .zip(direct.amp.iter().flatten())
        .map(|(x, y)| (x - y).abs() / y.abs())
        .fold(0.0f64, f64::max);
    eprintln!("spline interpolation at 31.25 ms: max rel. error {rel:.2e}");
    assert!(rel < 1e-3, "{rel}");
    let b = equation_bifurcations(&model, Interp::Spline).unwrap();
    eprintln!("{:?}\n{:?}\nsmall-start switch {:?}", b.heteroclinic, b.hopf, b.small_start_switch);
    let het = b.heteroclinic.expect("saddle connection found");
    let hopf = b.hopf.expect("torus Hopf found");
    assert!(het.dt.is_finite() && hopf.dt.is_finite());
    assert!(30.5 < het.dt && het.dt < hopf.dt && hopf.dt < 32.5, "{} {}", het.dt, hopf.dt);
    assert_eq!(het.saddle, PointKind::LimitCycle { mode: 2 });
    assert_eq!(het.fate_below, ssm::portrait::FateClass::ConvergesTo(PointKind::Torus2));
    assert!(hopf.complex_pair && hopf.loses_stability, "{hopf:?}");
    assert!((hopf.dt - 31.7416).abs() < 0.005, "{}", hopf.dt);
    assert!((31.43..=31.48).contains(&het.dt), "{}", het.dt);
    let sw = b.small_start_switch.expect("small-start switch found");
    assert!((0.5 * (sw.0 + sw.1) - 31.4535).abs() < 0.005, "{sw:?}");
    // The switch is the connection (within the scans' tolerances), before the torus Hopf.
    assert!((het.dt - 0.5 * (sw.0 + sw.1)).abs() < 0.005 && sw.1 < hopf.dt, "{} {sw:?} {}", het.dt, hopf.dt);
    // The 2-torus at 30.8 ms: rho is theta's first harmonic, so it compares with the
    // full system's torus (`full_system::torus_full`, 8000 periods, last 80 s; the reference
    // values below) within 0.2 % / 0.6 % (the `Spectral` normalization missed by far more).
    let t = b.torus_30p8.expect("torus at 30.8 ms").rho;
    eprintln!("torus at 30.8 ms: {t:?}");
    assert!((t[0] / 0.09467 - 1.0).abs() < 2e-3 && (t[1] / 0.03045 - 1.0).abs() < 6e-3, "{t:?}");
}

/// The comparison table matches rows by monomial: an order-5 normal form as the "data"
/// side of the order-7 table agrees on every row up to degree 5 (the parametrization is
/// order by order; the two expansions differ only by their RK4 meshes) and has no
/// degree-7 rows.
#[test]
fn coefficient_comparison_matches_rows() {
    let rows = coefficient_comparison(&[31.2], 7, |dt| furuta_equation_polar(dt, 5)).unwrap();
    assert_eq!(rows.len(), 20);
    for r in &rows {
        assert_eq!(r.dt_ms, 31.2);
        if r.degree <= 5 {
            let d = r.rel_diff.unwrap();
            assert!(d.abs() < 1e-6, "{r:?}");
        } else {
            assert_eq!(r.degree, 7);
            assert!(r.data.is_none() && r.rel_diff.is_none(), "{r:?}");
        }
    }
    assert_eq!(rows.iter().filter(|r| r.degree == 3).count(), 4);
}

/// The Furuta written as equations (`furuta-equations`) has the built-in plant's
/// equation-driven SSM: every polar coefficient to 1e-8 relative (cubic and quintic).
#[test]
fn furuta_as_equations_has_the_builtin_ssm() {
    let load = |name: &str| Scene::load(name, &[]).unwrap();
    let a = equation_ssm(&load("furuta-dt30.8"), 5).unwrap();
    let b = equation_ssm(&load("furuta-equations"), 5).unwrap();
    assert_eq!(a.table.rows.len(), b.table.rows.len());
    let mut worst = 0.0f64;
    for (x, y) in a.table.rows.iter().zip(&b.table.rows) {
        assert_eq!((x.mode, &x.monomial), (y.mode, &y.monomial));
        worst = worst.max((x.value - y.value).abs() / x.value.abs());
    }
    eprintln!("furuta-equations vs built-in: {} rows, max relative difference {worst:.2e}", a.table.rows.len());
    assert!(worst < 1e-8, "{worst}");
    assert_eq!(a.table.rows.iter().filter(|r| r.rho_exps.iter().sum::<u32>() == 3).count(), 4);
}

/// Plants written as equations with any gain vector: the linear rates and frequencies of
/// the table are the exact multipliers' (`ln|mu|/dt`, to 1e-9), the invariance error
/// falls with the order.
#[test]
fn equation_scenes_have_an_ssm() {
    // (scene, master pairs): the Duffing chain's two modes; the pendulum and the cart-pole
    // have one dominant pair (the cart's slow oscillation).
    for (name, pairs) in [("duffing-chain", 2), ("cartpole-pd", 1), ("pendulum-pd", 1)] {
        let o: &[String] = &[];
        let scene = Scene::load(name, o).unwrap();
        let e = equation_ssm(&scene, 5).unwrap();
        eprintln!("{name}: rates {:?} freqs {:?} Hz\n{}", e.exact_rates, e.exact_freqs_hz, e.table.to_text());
        assert_eq!(e.polar.modes, pairs, "{name}");
        assert_eq!(e.exact_rates.len(), pairs);
        for i in 0..pairs {
            let (got, want) = (e.polar.amp[i][0], e.exact_rates[i]);
            assert!((got - want).abs() < 1e-9 * want.abs().max(1.0), "{name} mode {i}: {got} vs {want}");
            let f = e.polar.eigenvalues[i].1 / std::f64::consts::TAU;
            assert!((f - e.exact_freqs_hz[i]).abs() < 1e-9 * f, "{name} mode {i}: {f} vs {}", e.exact_freqs_hz[i]);
        }
        // On the smaller sphere (the larger one, 0.05 in x1, is past the Duffing
        // chain's hardening springs' convergence radius: k3 x^3 is 1.25 k1 x there).
        for pair in e.invariance.chunks(2) {
            eprintln!("{name}: invariance at r = {}: {:.3e} -> {:.3e}", pair[0].radius, pair[0].abs, pair[1].abs);
        }
        let small = &e.invariance[..2];
        assert!(small[1].abs < small[0].abs, "{name}: {small:?}");
    }
    // A stiffer cart D gain overdamps the cart mode: the dominant multiplier is real.
    let stiff = ["controller.gains.x.d=-15.0".to_string()];
    let err = equation_ssm(&Scene::load("cartpole-pd", &stiff).unwrap(), 5).unwrap_err().to_string();
    assert!(err.contains("cartpole-pd") && err.contains("is real"), "{err}");
}

#[test]
fn order_out_of_range_is_refused() {
    assert!(matches!(furuta_equation_ssm(31.0, 2), Err(Error::BadOption { what: "order", .. })));
    assert!(matches!(furuta_equation_ssm(31.0, 10), Err(Error::BadOption { what: "order", .. })));
    assert!(matches!(EquationModel::furuta(&[31.0], 7), Err(Error::BadOption { what: "nodes_ms", .. })));
    assert!(matches!(EquationModel::furuta(&[31.0, 30.5], 7), Err(Error::BadOption { what: "nodes_ms", .. })));
}
