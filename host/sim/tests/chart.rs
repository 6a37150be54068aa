//! Tests of the stability chart on the Furuta linearization of MODEL.md.

use crate::linear::furuta_ab;
use nalgebra::Complex;
use shared::ControllerConfig;
use sim::chart::internals::*;
use sim::chart::*;
use sim::linear::{LinearPlant, Zoh};

fn plant() -> LinearPlant {
    let (a, b) = furuta_ab();
    LinearPlant::new(&a, &b, 0, 2).unwrap()
}

fn summary_of(chart: &Chart, dt: f64) -> &PanelSummary {
    &chart.panels.iter().find(|p| p.dt_s == dt).unwrap().summary
}

#[test]
fn stable_region_shrinks_with_the_period_and_excludes_the_paper_point() {
    let base = ControllerConfig::paper(0.025);
    let kp = Axis { lo: 0.0, hi: 40.0, n: 81 };
    let kd = Axis { lo: 0.0, hi: 8.0, n: 81 };
    let chart = compute_chart(&plant(), &base, &[0.020, 0.025, 0.0308], kp, kd).unwrap();
    for p in &chart.panels {
        println!("{:?}", p.summary);
    }
    let (s20, s25, s308) = (summary_of(&chart, 0.020), summary_of(&chart, 0.025), summary_of(&chart, 0.0308));
    // The paper's point is just outside the stable region at 25 ms (MODEL.md: one pair
    // just outside the unit circle) and further out at 30.8 ms.
    assert!(s25.base_radius > 1.0 && s25.base_radius < 1.02, "{s25:?}");
    assert!(s308.base_radius > s25.base_radius, "{s308:?}");
    // A stable region exists at 20 and 25 ms and shrinks as the period grows.
    assert!(s20.stable_points > 0 && s25.stable_points > 0, "{s20:?} {s25:?}");
    assert!(s20.stable_points > s25.stable_points && s25.stable_points > s308.stable_points);
    // Stability is lost only dynamically here: this plant has no static boundary (see
    // `furuta_has_no_static_boundary`), and flips happen away from the stable region.
    for s in [s20, s25, s308] {
        assert!(s.edge_dynamic > 0 && s.edge_static == 0 && s.edge_flip == 0, "{s:?}");
    }
    // Stable gains near the paper's point at 25 ms: KD below 5.45 at KP = 15.5.
    let (_, kd_hi) = s25.kd_range.unwrap();
    assert!(kd_hi < 6.0, "{s25:?}");
}

/// Every point of every D-curve has a multiplier on the unit circle of the right kind:
/// checks the affine-determinant construction against the eigenvalue route.
#[test]
fn d_curve_points_have_a_multiplier_on_the_unit_circle() {
    let p = plant();
    let base = ControllerConfig::paper(0.025);
    let kp = Axis { lo: 0.0, hi: 40.0, n: 2 };
    let kd = Axis { lo: 0.0, hi: 8.0, n: 2 };
    for dt in [0.02, 0.025, 0.0308] {
        let zoh = p.discretize(dt).unwrap();
        let curves = d_curves(&zoh, &base, kp, kd, &set_primary).unwrap();
        let mut kinds = [0usize; 3];
        for c in &curves {
            kinds[c.kind as usize] += 1;
            for (&(x, y), &f) in c.points.iter().zip(&c.freq_hz).step_by(7) {
                let cfg = ControllerConfig { dt, ..base }.with_primary(x, y);
                let dom = zoh.closed_loop(&cfg).unwrap().dominant_multipliers().unwrap();
                let target = match c.kind {
                    Crossing::Static => Complex::new(1.0, 0.0),
                    Crossing::Flip => Complex::new(-1.0, 0.0),
                    Crossing::Dynamic => Complex::new(0.0, 0.0),
                };
                let best = dom
                    .iter()
                    .map(|m| match c.kind {
                        Crossing::Dynamic if m.im.abs() > 1e-9 => (m.abs - 1.0).abs(),
                        Crossing::Dynamic => f64::INFINITY,
                        _ => (m.re - target.re).hypot(m.im),
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(best < 1e-7, "dt {dt} {:?} at ({x}, {y}): distance {best:e}", c.kind);
                // The curve's frequency is that of the multiplier on the circle.
                let on_circle = dom.iter().min_by(|a, b| (a.abs - 1.0).abs().total_cmp(&(b.abs - 1.0).abs())).unwrap();
                assert!((on_circle.freq_hz - f).abs() < 1e-6 * (1.0 + f), "{on_circle:?} vs {f} Hz");
            }
        }
        // Dynamic boundaries are present in the window at every period, static ones never.
        assert!(kinds[Crossing::Static as usize] == 0 && kinds[Crossing::Dynamic as usize] > 0, "{kinds:?}");
    }
}

/// Where the grid changes stability between two neighbours, a bisection along that edge
/// finds gains with a multiplier on the unit circle whose kind matches the classification.
/// Returns the number of boundary edges checked per kind (static, dynamic, flip).
fn check_grid_boundaries(p: &LinearPlant, base: &ControllerConfig, kp: Axis, kd: Axis) -> [usize; 3] {
    let dt = base.dt;
    let chart = compute_chart(p, base, &[dt], kp, kd).unwrap();
    let panel = &chart.panels[0];
    let zoh = p.discretize(dt).unwrap();
    let radius = |x: f64, y: f64| spectral_radius_of(&zoh, &base.with_primary(x, y));
    let mut checked = [0; 3];
    for i in 0..kd.n {
        for j in 0..kp.n - 1 {
            let (a, b) = (i * kp.n + j, i * kp.n + j + 1);
            let (sa, sb) = (panel.radius[a] < 1.0, panel.radius[b] < 1.0);
            if sa == sb {
                continue;
            }
            let kind = if sa { panel.unstable_kind[b] } else { panel.unstable_kind[a] }.unwrap();
            let y = kd.at(i);
            let (mut lo, mut hi) = (kp.at(j), kp.at(j + 1));
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if (radius(mid, y) < 1.0) == sa { lo = mid } else { hi = mid }
            }
            let cfg = base.with_primary(hi, y);
            let dom = zoh.closed_loop(&cfg).unwrap().dominant_multipliers().unwrap();
            let crossing = dom[0];
            assert!((crossing.abs - 1.0).abs() < 1e-9, "{crossing:?}");
            assert_eq!(kind_of(Complex::new(crossing.re, crossing.im)), kind, "at ({hi}, {y})");
            checked[kind as usize] += 1;
        }
    }
    checked
}

#[test]
fn grid_boundaries_are_crossings_of_the_classified_kind() {
    let kp = Axis { lo: 0.0, hi: 40.0, n: 41 };
    let kd = Axis { lo: 0.0, hi: 8.0, n: 41 };
    let checked = check_grid_boundaries(&plant(), &ControllerConfig::paper(0.025), kp, kd);
    assert!(checked[Crossing::Dynamic as usize] >= 10, "{checked:?}");
}

/// An inverted pendulum `theta'' = a theta - c w + b u` with a decoupled secondary
/// coordinate (`z' = 0`): under `u = -KP theta - ...` a real eigenvalue crosses 0 at
/// `KP = a / b` whatever KD and dt, so its chart has a static boundary there.
fn pendulum(a: f64, b: f64) -> LinearPlant {
    let am = nalgebra::Matrix3::new(0.0, 1.0, 0.0, a, -0.5, 0.0, 0.0, 0.0, 0.0);
    let bv = nalgebra::Vector3::new(0.0, b, 0.0);
    LinearPlant::new(&am, &bv, 0, 2).unwrap()
}

#[test]
fn static_boundary_of_a_pendulum_is_at_kp_a_over_b() {
    let p = pendulum(100.0, 10.0);
    let base = ControllerConfig::shorthand(15.0, 1.0, 0.0, 0.01);
    let kp = Axis { lo: 0.0, hi: 30.0, n: 61 };
    let kd = Axis { lo: 0.0, hi: 3.0, n: 61 };
    let zoh = p.discretize(0.01).unwrap();
    let curves = d_curves(&zoh, &base, kp, kd, &set_primary).unwrap();
    let statics: Vec<_> = curves.iter().filter(|c| c.kind == Crossing::Static).collect();
    assert_eq!(statics.len(), 1, "{curves:?}");
    for &(x, _) in &statics[0].points {
        assert!((x - 10.0).abs() < 1e-9, "static boundary at KP = {x}");
    }
    let checked = check_grid_boundaries(&p, &base, kp, kd);
    assert!(checked[Crossing::Static as usize] > 0 && checked[Crossing::Dynamic as usize] > 0, "{checked:?}");
}

/// For the Furuta plant a real multiplier +1 would be a steady state with constant arm
/// speed v: phi'' = 0 and theta'' = 0 force theta = 0 (Delta0 != 0) and N u = (K + b2) v,
/// with u = KphiD v, independent of KP and KD. So det(M - I) of the deflated map does not
/// depend on the gains and the static boundary is absent from the (KP, KD) plane (it is
/// the line N KphiD = K + b2 in KphiD).
#[test]
fn furuta_has_no_static_boundary() {
    let zoh = plant().discretize(0.025).unwrap();
    let base = ControllerConfig::paper(0.025);
    let (f0, fa, fb) = affine_det(&zoh, &base, Complex::new(1.0, 0.0), 40.0, 8.0, &set_primary, true).unwrap();
    assert!(f0.norm() > 0.0);
    assert!(fa.norm() * 40.0 < 1e-9 * f0.norm() && fb.norm() * 8.0 < 1e-9 * f0.norm(), "{f0} {fa} {fb}");
    // ... and it vanishes at N KphiD = K + b2.
    use crate::linear::furuta::{B2, K, NM};
    let at = {
        let (kp, kd, _) = base.as_shorthand().unwrap();
        ControllerConfig { gains: shared::Gains::shorthand(kp, kd, (K + B2) / NM, 0.0, 0.0), ..base }
    };
    let (g0, _, _) = affine_det(&zoh, &at, Complex::new(1.0, 0.0), 40.0, 8.0, &set_primary, true).unwrap();
    assert!(g0.norm() < 1e-9 * f0.norm(), "{g0} vs {f0}");
}

fn spectral_radius_of(zoh: &Zoh, cfg: &ControllerConfig) -> f64 {
    sim::linear::spectral_radius(&zoh.closed_loop(cfg).unwrap().dominant_multipliers().unwrap())
}

#[test]
fn bad_chart_inputs_are_named() {
    let p = plant();
    let base = ControllerConfig::paper(0.025);
    let ok = Axis { lo: 0.0, hi: 1.0, n: 3 };
    let e = compute_chart(&p, &base, &[0.02], Axis { lo: 1.0, hi: 1.0, n: 3 }, ok).unwrap_err();
    assert!(matches!(&e, ChartError::BadAxis { axis, .. } if axis == "KP"), "{e}");
    let e = compute_chart(&p, &base, &[0.02], ok, Axis { lo: 0.0, hi: 1.0, n: 1 }).unwrap_err();
    assert!(matches!(&e, ChartError::BadAxis { axis, .. } if axis == "KD"), "{e}");
    let e = compute_chart(&p, &base, &[], ok, ok).unwrap_err();
    assert!(matches!(e, ChartError::NoPeriods), "{e}");
    let e = compute_chart(&p, &base, &[0.02, -1.0], ok, ok).unwrap_err();
    assert!(matches!(e, ChartError::BadPeriod(-1.0)), "{e}");
}

#[test]
fn clipping_keeps_inside_pieces() {
    let kp = Axis { lo: 0.0, hi: 10.0, n: 2 };
    let kd = Axis { lo: 0.0, hi: 1.0, n: 2 };
    let line = [(-5.0, 0.5, 0.0), (5.0, 0.5, 1.0), (15.0, 0.5, 2.0), (15.0, 2.0, 3.0), (5.0, 0.25, 4.0)];
    let pieces = clip_polyline(&line, kp, kd);
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[0], vec![(0.0, 0.5, 0.5), (5.0, 0.5, 1.0), (10.0, 0.5, 1.5)]);
    assert_eq!(pieces[1].last(), Some(&(5.0, 0.25, 4.0)));
    // (15, 2) -> (5, 0.25) enters through KD = 1 at KP = 15 - 10/1.75.
    let entry = pieces[1][0];
    assert!((entry.0 - (15.0 - 10.0 / 1.75)).abs() < 1e-12 && (entry.1 - 1.0).abs() < 1e-12, "{entry:?}");
}

/// The chart's panels and grid rows run on the rayon pool: a 1-thread and a 2-thread pool
/// give the same chart, bit for bit (Debug prints every f64 exactly).
#[test]
fn chart_is_bit_identical_on_one_and_two_threads() {
    let base = ControllerConfig::paper(0.025);
    let kp = Axis { lo: 0.0, hi: 40.0, n: 23 };
    let kd = Axis { lo: 0.0, hi: 8.0, n: 17 };
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| compute_chart(&plant(), &base, &[0.020, 0.025, 0.0308], kp, kd).unwrap())
    };
    let (one, two) = (on(1), on(2));
    assert_eq!(format!("{one:?}"), format!("{two:?}"));
    assert!(one.panels.iter().all(|p| p.radius.len() == 23 * 17 && !p.curves.is_empty()));
}
