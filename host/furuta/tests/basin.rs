//! The tests of `furuta::basin`.

use furuta::Error;
use furuta::basin::*;
use furuta::full_system::{ESCAPE_THETA, start_from_rho};
use furuta::sweep::Sweep;
use sim::chart::Axis;
use sim::scene::MethodKind;
use ssm::normal_form::Normalization;
use ssm::normal_form::PolarNormalForm;
use ssm::portrait::{PointKind, PortraitOptions};

/// `rho_i' = rho_i (a + b r^2)`, `r^2 = rho_1^2 + rho_2^2`: for `a < 0 < b` the origin
/// attracts every start inside the circle `r = sqrt(-a/b)` (an invariant circle of
/// saddles' stable manifolds' role: the exact separatrix) and every start outside it
/// grows without bound.
fn radial(a: f64, b: f64) -> PolarNormalForm {
    let pexps = ssm::poly::exponents(2, 0, 1);
    let amp = vec![vec![a, b, b], vec![a, b, b]];
    let phase = vec![vec![std::f64::consts::TAU * 0.44, 0.0, 0.0], vec![std::f64::consts::TAU * 8.4, 0.0, 0.0]];
    PolarNormalForm {
        modes: 2,
        order: 3,
        eigenvalues: vec![(a, phase[0][0]), (a, phase[1][0])],
        pexps,
        amp,
        phase,
        normalization: Normalization::UnitEigenvectors,
        extra_resonances: Vec::new(),
        min_divisor: 1.0,
        map_dt: None,
    }
}

/// The known answer: bounded exactly inside `r = 1` (`a = -1, b = 1`); within a horizon
/// `T`, a start at `r0 > 1` on the ray of angle `phi` leaves the box `[0, 2]^2` (at
/// `r1 = 2 / max(cos phi, sin phi)`, rays are invariant) after
/// `T(r0) = (ln((u1 - 1)/u1) - ln((u0 - 1)/u0)) / 2`, `u = r^2`.
#[test]
fn model_basin_of_a_radial_system_is_the_unit_disc() {
    let nf = radial(-1.0, 1.0);
    let opts = PortraitOptions { rho_max: [2.0, 2.0], ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() };
    let v: Vec<f64> = (0..15).map(|k| 0.05 + 0.1 * k as f64).collect();
    let horizon = 0.5;
    let mb = model_basin(&nf, PointKind::Equilibrium, &v, &v, horizon, 200.0, &opts).unwrap();
    let (mut checked, mut checked_h) = (0, 0);
    for (i, &x) in v.iter().enumerate() {
        for (j, &y) in v.iter().enumerate() {
            let r = x.hypot(y);
            let k = i * v.len() + j;
            if (r - 1.0).abs() > 0.01 {
                assert_eq!(
                    mb.asymptotic[k],
                    if r < 1.0 { ModelFate::Principal } else { ModelFate::LeavesBox },
                    "({x}, {y}) r = {r}"
                );
                checked += 1;
            }
            // Within the horizon.
            let t_exit = if r > 1.0 {
                let (u0, u1) = (r * r, (2.0 / (x.max(y) / r)).powi(2));
                0.5 * (((u1 - 1.0) / u1).ln() - ((u0 - 1.0) / u0).ln())
            } else {
                f64::INFINITY
            };
            if (t_exit - horizon).abs() > 0.02 {
                assert_eq!(
                    mb.horizon[k],
                    if t_exit < horizon { ModelFate::LeavesBox } else { ModelFate::Principal },
                    "({x}, {y}) exit at {t_exit}"
                );
                checked_h += 1;
            }
        }
    }
    // Most cells are away from the boundaries, and both verdicts occur within the horizon.
    assert!(checked >= 215 && checked_h >= 200, "{checked} {checked_h}");
    assert!(mb.horizon.contains(&ModelFate::LeavesBox) && mb.horizon.iter().zip(&mb.asymptotic).any(|(h, a)| h != a));
    // Against a "full system" that is the exact disc: no disagreement off the circle.
    let exact: Vec<bool> = v.iter().flat_map(|&x| v.iter().map(move |&y| x.hypot(y) < 1.0)).collect();
    let a = agreement(&mb.asymptotic, &exact).unwrap();
    assert_eq!(a.cells, 225);
    assert!(a.disagreement <= 2.0 / 225.0, "{a:?}");
    // A smaller disc (a = -0.81: r = 0.9) disagrees exactly on the ring 0.9 < r < 1.
    let small = model_basin(&radial(-0.81, 1.0), PointKind::Equilibrium, &v, &v, horizon, 200.0, &opts).unwrap();
    let ring = exact
        .iter()
        .zip(v.iter().flat_map(|&x| v.iter().map(move |&y| x.hypot(y))))
        .filter(|(_, r)| *r > 0.9 && *r < 1.0)
        .count();
    let a = agreement(&small.asymptotic, &exact).unwrap();
    assert_eq!((a.model_escaped_full_bounded, a.model_bounded_full_escaped), (ring, 0), "{a:?}");
}

/// Two attractors: `rho_1' = rho_1 (-1 + 2.5 rho_1^2 - rho_1^4)` (an unstable cycle at
/// `rho_1 = sqrt(1/2)`, a stable one at `sqrt(2)`), `rho_2' = -rho_2`: starts below
/// `sqrt(1/2)` in `rho_1` reach the equilibrium (the principal attractor here), starts
/// above it the stable cycle (another attractor: not bounded in the full system's sense).
#[test]
fn model_basin_tells_the_principal_attractor_from_another() {
    let pexps = ssm::poly::exponents(2, 0, 2);
    let a1: Vec<f64> = pexps
        .iter()
        .map(|e| match (e[0], e[1]) {
            (0, 0) => -1.0,
            (1, 0) => 2.5,
            (2, 0) => -1.0,
            _ => 0.0,
        })
        .collect();
    let a2: Vec<f64> = pexps.iter().map(|e| if e[0] + e[1] == 0 { -1.0 } else { 0.0 }).collect();
    let zero = vec![0.0; pexps.len()];
    let nf = PolarNormalForm {
        modes: 2,
        order: 5,
        eigenvalues: vec![(-1.0, 1.0), (-1.0, 50.0)],
        pexps,
        amp: vec![a1, a2],
        phase: vec![zero.clone(), zero],
        ..radial(-1.0, 1.0)
    };
    let opts = PortraitOptions {
        rho_max: [2.0, 2.0],
        ray_samples: 0,
        flow_grid: 0,
        converge_tol: 1e-5,
        manifold_eps: 1e-4,
        ..PortraitOptions::default()
    };
    let v: Vec<f64> = (0..14).map(|k| 0.05 + 0.1 * k as f64).collect();
    let mb = model_basin(&nf, PointKind::Equilibrium, &v, &v, 1.0, 200.0, &opts).unwrap();
    for (i, &x) in v.iter().enumerate() {
        for (j, &y) in v.iter().enumerate() {
            let want = if x < 0.5f64.sqrt() { ModelFate::Principal } else { ModelFate::OtherAttractor };
            assert_eq!(mb.asymptotic[i * v.len() + j], want, "({x}, {y})");
            assert_eq!(mb.horizon[i * v.len() + j], want);
        }
    }
    assert_eq!(ModelFate::OtherAttractor.bounded(), Some(false));
    assert_eq!(ModelFate::Undecided.bounded(), None);
}

/// The torus-loss rule on synthetic two-tone series at the exact linear frequencies of
/// 31.4 ms, 8,000 samples: constant amplitudes are an attracting torus (means to 1 %,
/// spreads below the floor); a slow amplitude growing as `0.08 e^{0.004 t}` is lost
/// (spreads 0.044 / 0.062 rad over the middle / last third, less the window's
/// smoothing); a decaying oscillation of it is not; an escaped run is lost unmeasured.
#[test]
fn torus_step_rule_on_synthetic_series() {
    let dt_ms = 31.4;
    let h = dt_ms * 1e-3;
    let f = furuta::parametric::exact_modes(dt_ms).unwrap().freqs_hz;
    let series = |a1: &dyn Fn(f64) -> f64| -> Vec<f64> {
        (0..8000)
            .map(|k| {
                let t = k as f64 * h;
                a1(t) * (std::f64::consts::TAU * f[0] * t).cos() + 0.03 * (std::f64::consts::TAU * f[1] * t + 0.3).cos()
            })
            .collect()
    };
    let steady = torus_step(dt_ms, &series(&|_| 0.1), h, None).unwrap();
    eprintln!("{steady:?}");
    let rho = steady.rho.unwrap();
    assert!(!steady.lost && (rho[0] / 0.1 - 1.0).abs() < 0.01 && (rho[1] / 0.03 - 1.0).abs() < 0.01, "{steady:?}");
    assert!(steady.spread_last.unwrap() < TORUS_SPREAD_MIN);
    let growing = torus_step(dt_ms, &series(&|t| 0.08 * (0.004 * t).exp()), h, None).unwrap();
    eprintln!("{growing:?}");
    let (sm, sl) = (growing.spread_mid.unwrap(), growing.spread_last.unwrap());
    assert!(growing.lost && (0.035..0.045).contains(&sm) && (0.05..0.063).contains(&sl), "{growing:?}");
    // rho_1 = 0.08 e^{0.004 t} rises monotonically: the spreads' ratio is e^{0.004 T/3}.
    let g = growing.growth_rate.unwrap();
    assert!((g / 0.004 - 1.0).abs() < 0.02, "{g}");
    // Its halves measure the same rate: the noise floor is a small part of it.
    let gn = growing.rate_noise.unwrap();
    assert!(gn < 0.05 * g, "noise {gn} vs rate {g}");
    let decaying = torus_step(
        dt_ms,
        &series(&|t| 0.1 + 0.03 * (-0.01 * t).exp() * (0.05 * std::f64::consts::TAU * t).sin()),
        h,
        None,
    )
    .unwrap();
    eprintln!("{decaying:?}");
    assert!(
        !decaying.lost
            && decaying.spread_last.unwrap() < decaying.spread_mid.unwrap()
            && decaying.spread_last.unwrap() > TORUS_SPREAD_MIN,
        "{decaying:?}"
    );
    // An oscillation of 20 s decaying at 0.01/s: each third's spread is set by its first
    // swing, within a quarter period of the same phase.
    let d = decaying.growth_rate.unwrap();
    assert!((-0.012..-0.008).contains(&d), "{d}");
    assert_eq!(steady.growth_rate.map(f64::is_finite), Some(true));
    assert_eq!(steady.rate_noise.map(f64::is_finite), Some(true));
    // A growth that speeds up (0.002/s in the first half of the measured span, samples
    // 2666..5333, 0.006/s in the second): the halves disagree by 0.004/s, the floor is
    // half that.
    let t_half = 5333.0 * h;
    let kinked = torus_step(
        dt_ms,
        &series(&|t| 0.08 * if t < t_half { (0.002 * t).exp() } else { (0.002 * t_half + 0.006 * (t - t_half)).exp() }),
        h,
        None,
    )
    .unwrap();
    eprintln!("{kinked:?}");
    let kn = kinked.rate_noise.unwrap();
    assert!((kn / 0.002 - 1.0).abs() < 0.1, "{kn}");
    let escaped = torus_step(dt_ms, &[0.1; 10], h, Some(12.5)).unwrap();
    assert!(
        escaped.lost
            && escaped.rho.is_none()
            && escaped.escape_t == Some(12.5)
            && escaped.growth_rate.is_none()
            && escaped.rate_noise.is_none()
    );
    assert!(matches!(torus_step(dt_ms, &[f64::NAN; 3000], h, None), Err(Error::BadInput { what: "theta", .. })));
    assert!(matches!(torus_step(dt_ms, &[0.0; 30], h, None), Err(Error::BadInput { what: "periods", .. })));
}

/// The onset is the zero of the growth rate, linear in dt between the last decaying and
/// the first growing step; none when the first step grows or the first non-decaying one
/// escaped. A rate within its noise floor neither grows nor decays.
#[test]
fn growth_onset_interpolates_the_rate_zero() {
    let step = |dt_ms: f64, g: Option<f64>, lost: bool| TorusStep {
        dt_ms,
        escape_t: None,
        rho: None,
        spread_mid: None,
        spread_last: None,
        growth_rate: g,
        rate_noise: None,
        lost,
    };
    let noisy = |dt_ms: f64, g: f64, noise: f64| TorusStep { rate_noise: Some(noise), ..step(dt_ms, Some(g), false) };
    // Without a floor a rate of 1e-9 is growth; with a floor of 1e-5 it decides nothing,
    // and the zero is interpolated between its neighbours (31.65 + 0.1 * 3/7).
    let tiny = |s: TorusStep| {
        TorusContinuation::from_steps(
            [0.1, 0.03],
            100,
            vec![step(31.6, Some(-5e-4), false), step(31.65, Some(-3e-4), false), s, step(31.75, Some(4e-4), false)],
        )
    };
    assert!(
        (tiny(step(31.7, Some(1e-9), false)).growth_onset.unwrap() - (31.65 + 0.05 * 3e-4 / (3e-4 + 1e-9))).abs()
            < 1e-12
    );
    assert!((tiny(noisy(31.7, 1e-9, 1e-5)).growth_onset.unwrap() - (31.65 + 0.1 * 3.0 / 7.0)).abs() < 1e-12);
    // So does a decay within its floor; a decay beyond it counts.
    assert!((tiny(noisy(31.7, -2e-4, 3e-4)).growth_onset.unwrap() - (31.65 + 0.1 * 3.0 / 7.0)).abs() < 1e-12);
    assert!((tiny(noisy(31.7, -2e-4, 1e-4)).growth_onset.unwrap() - (31.7 + 0.05 * 2.0 / 6.0)).abs() < 1e-12);
    // A growth within its floor is not the onset; the next step's is.
    let c = TorusContinuation::from_steps(
        [0.1, 0.03],
        100,
        vec![step(31.6, Some(-3e-4), false), noisy(31.7, 2e-4, 5e-4), noisy(31.8, 6e-4, 1e-4)],
    );
    assert!((c.growth_onset.unwrap() - (31.6 + 0.2 * 3.0 / 9.0)).abs() < 1e-12, "{:?}", c.growth_onset);
    // Nothing decays beyond its floor before the growth: no onset.
    let c = TorusContinuation::from_steps([0.1, 0.03], 100, vec![noisy(31.6, -1e-4, 2e-4), noisy(31.7, 6e-4, 1e-4)]);
    assert_eq!(c.growth_onset, None);
    let c = TorusContinuation::from_steps(
        [0.1, 0.03],
        100,
        vec![
            step(31.6, Some(-3e-4), false),
            step(31.7, Some(-1e-4), false),
            step(31.75, Some(3e-4), false),
            step(31.8, Some(1e-3), true),
        ],
    );
    assert_eq!(c.lost_between, Some((31.75, 31.8)));
    let on = c.growth_onset.unwrap();
    assert!((on - 31.7125).abs() < 1e-12, "{on}");
    let first = TorusContinuation::from_steps(
        [0.1, 0.03],
        100,
        vec![step(31.6, Some(1e-4), false), step(31.7, Some(2e-4), true)],
    );
    assert_eq!(first.growth_onset, None);
    let escaped =
        TorusContinuation::from_steps([0.1, 0.03], 100, vec![step(31.6, Some(-1e-4), false), step(31.7, None, true)]);
    assert_eq!((escaped.growth_onset, escaped.lost_between), (None, Some((31.6, 31.7))));
}

/// The full system's continuation on the report's quick grid (8,000 periods, 0.1 ms): the
/// torus attracts up to 31.8 ms and is lost at 31.9 ms, as on the fitted map
/// (`map_torus_continuation_loses_the_torus_on_the_grid`), and the growth rate turns
/// positive between 31.7 and 31.8 ms (the onset is printed). With the pre-history off by
/// one the torus was lost a step early.
#[test]
fn torus_continuation_loses_the_torus_where_the_map_does() {
    let dts: Vec<f64> = (0..=5).map(|k| ((31.4 + 0.1 * k as f64) * 1e4).round() / 1e4).collect();
    let c = torus_continuation(&dts, [0.097, 0.0277], 8000).unwrap();
    for s in &c.steps {
        eprintln!("{} {:?} {:?} {:?} {}", s.dt_ms, s.spread_mid, s.spread_last, s.growth_rate, s.lost);
    }
    assert_eq!(c.lost_between, Some((31.8, 31.9)));
    let on = c.growth_onset.unwrap();
    eprintln!("growth onset {on} ms");
    assert!((31.7..31.8).contains(&on), "{on}");
    assert!(c.steps[..3].iter().all(|s| s.growth_rate.is_some_and(|g| g < 0.0)), "{:?}", c.steps);
}

#[test]
fn bad_inputs_are_refused() {
    let nf = radial(-1.0, 1.0);
    let opts = PortraitOptions { rho_max: [2.0, 2.0], ..PortraitOptions::default() };
    assert!(matches!(
        model_basin(&nf, PointKind::Equilibrium, &[0.1], &[0.1], 0.0, 10.0, &opts),
        Err(Error::BadOption { .. })
    ));
    assert!(matches!(
        model_basin(&nf, PointKind::Equilibrium, &[0.1], &[0.1], 20.0, 10.0, &opts),
        Err(Error::BadOption { .. })
    ));
    assert!(matches!(
        model_basin(&nf, PointKind::Equilibrium, &[2.5], &[0.1], 1.0, 10.0, &opts),
        Err(Error::BadInput { .. })
    ));
    assert!(matches!(
        model_basin(&nf, PointKind::Equilibrium, &[], &[0.1], 1.0, 10.0, &opts),
        Err(Error::BadInput { .. })
    ));
    assert!(matches!(agreement(&[ModelFate::Principal], &[true, false]), Err(Error::Shape { .. })));
    assert!(matches!(torus_continuation(&[31.5, 31.4], [0.1, 0.03], 100), Err(Error::BadInput { what: "dts_ms", .. })));
    let mut o = BasinOptions::quick();
    o.dts_ms = vec![];
    assert!(matches!(full_basin(&o), Err(Error::BadInput { what: "dts_ms", .. })));
}

/// The report's grids run by the verdict method at the scene's tolerances; `method: None`
/// keeps the scene's integrator whole.
#[test]
fn report_grids_take_the_verdict_method() {
    let scene = furuta::full_system::base_scene().unwrap();
    for o in [BasinOptions::full(), BasinOptions::quick()] {
        let sw = Sweep::from_spec("basin", o.spec("basin"), std::path::Path::new(".")).unwrap();
        assert_eq!(sw.scene.integrator, furuta::full_system::verdict_integrator().unwrap());
        assert_eq!(sw.scene.integrator.method, MethodKind::ExprbFiltered);
        assert_eq!(
            (sw.scene.integrator.rtol, sw.scene.integrator.atol),
            (scene.integrator.rtol, scene.integrator.atol)
        );
    }
    let o = BasinOptions { method: None, ..BasinOptions::quick() };
    let sw = Sweep::from_spec("basin", o.spec("basin"), std::path::Path::new(".")).unwrap();
    assert_eq!(sw.scene.integrator, scene.integrator);
}

/// A 3 x 2 grid at one dt through the sweep machinery equals the runs of
/// `full_system::run` from the same mode starts (outcome by outcome), and the cell order
/// is rho_1-major.
#[test]
fn full_basin_cells_are_the_runs_from_mode_starts() {
    let o = BasinOptions {
        dts_ms: vec![31.5],
        rho1: Axis { lo: 0.02, hi: 0.14, n: 3 },
        rho2: Axis { lo: 0.01, hi: 0.05, n: 2 },
        phases: [0.3, 0.0],
        periods: 200,
        method: None,
    };
    let b = full_basin(&o).unwrap();
    let (r1, r2) = o.values();
    let bounded = b.bounded_at(0);
    assert_eq!(bounded.len(), 6);
    for (i, &x) in r1.iter().enumerate() {
        for (j, &y) in r2.iter().enumerate() {
            let (s, h) = start_from_rho(31.5, [x, y], o.phases).unwrap();
            let out = furuta::full_system::outcome_of(
                &furuta::full_system::run(31.5, &(s, Some(h)), 200, ESCAPE_THETA).unwrap(),
            );
            let c = b.cell(i, j, 0);
            assert_eq!(c.values, vec![x, y, 31.5]);
            assert_eq!(
                (c.bounded, c.escape_t, c.max_theta),
                (Some(out.bounded()), out.escape_t, Some(out.max_theta)),
                "({x}, {y})"
            );
            assert_eq!(bounded[i * 2 + j], out.bounded());
        }
    }
    // (0.14, 0.05) escapes within 200 periods at 31.5 ms; small starts do not.
    assert!(!bounded[5] && bounded[0], "{bounded:?}");
    assert!((b.escape_fraction(0) - bounded.iter().filter(|x| !**x).count() as f64 / 6.0).abs() == 0.0);
}
