//! Coverage of the bootstrap intervals of `ssm::auto::intervals`: on decays of a damped
//! Duffing oscillator `x'' + 2 zeta w x' + w^2 x + k x^3 = 0` with known linear eigenvalue
//! `-zeta w + i w sqrt(1 - zeta^2)`, observed through `x` with Gaussian measurement noise at
//! three levels, the 95 % intervals of the real and imaginary parts and of the damping ratio
//! contain the exact values in at least 90 % of 102 seeded repetitions (the observed coverage
//! and mean widths are printed), for two decays (segment bootstrap) and for a lone decay
//! (residual bootstrap). And on the bundled Duffing data (clean, three trajectories).

use ssm::auto::{IntervalOptions, Setting, intervals};
use ssm::testing::XorShift64;
use ssm::{Dynamics, FitOptions, MultiSeries, Ridge};

const W: f64 = std::f64::consts::TAU;
const ZETA: f64 = 0.02;
const K: f64 = 1.0;

/// `x` sampled every `dt` for `t_end` from `x(0) = x0`, `x'(0) = 0` (RK4, 20 substeps),
/// plus noise of standard deviation `sigma`.
fn decay(name: &str, x0: f64, dt: f64, t_end: f64, sigma: f64, rng: &mut XorShift64) -> MultiSeries {
    let n = (t_end / dt).round() as usize + 1;
    let f = |s: [f64; 2]| [s[1], -2.0 * ZETA * W * s[1] - W * W * s[0] - K * s[0].powi(3)];
    let mut s = [x0, 0.0];
    let h = dt / 20.0;
    let (mut t, mut x) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        t.push(k as f64 * dt);
        x.push(s[0] + sigma * rng.gauss());
        for _ in 0..20 {
            let add = |a: [f64; 2], b: [f64; 2], c: f64| [a[0] + c * b[0], a[1] + c * b[1]];
            let k1 = f(s);
            let k2 = f(add(s, k1, h / 2.0));
            let k3 = f(add(s, k2, h / 2.0));
            let k4 = f(add(s, k3, h));
            s = [0, 1].map(|i| s[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
    }
    MultiSeries::new(name, t, vec!["x".into()], x).unwrap()
}

fn setting() -> Setting {
    Setting {
        cut: 0.0,
        options: FitOptions {
            dim: 2,
            embed: 5,
            shift: 2,
            manifold_order: 3,
            dyn_order: 3,
            dynamics: Dynamics::Map,
            ridge: Ridge::Fixed(0.0),
            linear_anchor: None,
            anchor_joint: false,
        },
    }
}

#[test]
fn intervals_cover_the_exact_damping_in_90_percent_of_repetitions() {
    let exact = (-ZETA * W, W * (1.0 - ZETA * ZETA).sqrt(), ZETA);
    let levels = [0.002, 0.005, 0.01];
    let reps_per_level = 34;
    let (mut hits, mut total) = ([0usize; 3], 0usize);
    let mut width = [0.0f64; 3];
    for (li, &sigma) in levels.iter().enumerate() {
        let (mut h, mut wsum) = ([0usize; 3], [0.0; 3]);
        for rep in 0..reps_per_level {
            let mut rng = XorShift64::new(1000 * (li as u64 + 1) + rep as u64);
            let train = [decay("a", 1.0, 0.05, 12.0, sigma, &mut rng), decay("b", 0.7, 0.05, 12.0, sigma, &mut rng)];
            let o = IntervalOptions { replicates: 100, seed: rep as u64 + 7, ..Default::default() };
            let iv = intervals(&train, &setting(), &o).unwrap();
            let e = &iv.eigenvalues[0];
            for (k, (i, v)) in [(e.re, exact.0), (e.im, exact.1), (e.damping_ratio, exact.2)].iter().enumerate() {
                if i.contains(*v) {
                    h[k] += 1;
                    hits[k] += 1;
                }
                wsum[k] += i.width();
                width[k] += i.width();
            }
            total += 1;
        }
        let n = reps_per_level as f64;
        eprintln!(
            "noise {sigma}: coverage re {:.2}, im {:.2}, zeta {:.2}; mean widths re {:.2e}, im {:.2e}, zeta {:.2e}",
            h[0] as f64 / n,
            h[1] as f64 / n,
            h[2] as f64 / n,
            wsum[0] / n,
            wsum[1] / n,
            wsum[2] / n
        );
    }
    let n = total as f64;
    eprintln!(
        "all {total}: coverage re {:.3}, im {:.3}, zeta {:.3}; mean widths re {:.2e} ({:.1} % of |re|), zeta {:.2e}",
        hits[0] as f64 / n,
        hits[1] as f64 / n,
        hits[2] as f64 / n,
        width[0] / n,
        100.0 * width[0] / n / exact.0.abs(),
        width[2] / n
    );
    assert!(total >= 100);
    for (k, what) in ["re", "im", "damping ratio"].iter().enumerate() {
        assert!(hits[k] as f64 >= 0.9 * n, "{what}: coverage {} of {total}", hits[k]);
    }
}

/// The bundled Duffing data (clean decays, three trajectories, `x` alone): the fit is
/// nearly exact and so is the interval. The bootstrap measures the spread of the estimate
/// over resampled data, not the bias of the truncated polynomial model: on data without
/// noise that bias (below 1e-6 relative here) can exceed the spread, so the exact value
/// must lie within 1e-6 |lambda| of the interval, not inside it.
#[test]
fn intervals_of_the_bundled_duffing_data_contain_the_exact_eigenvalue() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    let train: Vec<MultiSeries> = (1..=3)
        .map(|i| ssm::load_csv_observables(format!("{dir}/duffing_{i}.csv"), Some(&["x".to_string()])).unwrap())
        .collect();
    let mut s = setting();
    s.options.dyn_order = 5;
    s.options.shift = 1;
    let iv = intervals(&train, &s, &IntervalOptions::default()).unwrap();
    let e = &iv.eigenvalues[0];
    eprintln!("{}: {e:?}", iv.method);
    let off = |i: &ssm::auto::Interval, v: f64| (i.lo - v).max(v - i.hi).max(0.0);
    assert!(off(&e.re, -ZETA * W) < 1e-6 * W, "{e:?}");
    assert!(off(&e.im, W * (1.0 - ZETA * ZETA).sqrt()) < 1e-6 * W, "{e:?}");
    assert!(off(&e.damping_ratio, ZETA) < 1e-6, "{e:?}");
    assert!(e.re.width() < 1e-4 * ZETA * W, "{e:?}");
}

/// A lone noisy decay (one trajectory: the residual bootstrap): the 95 % intervals of the
/// real and imaginary parts and of the damping ratio contain the exact values in at least
/// 90 % of 102 seeded repetitions over three noise levels (coverage and widths printed).
#[test]
fn residual_intervals_of_a_lone_decay_cover_the_exact_damping() {
    let exact = (-ZETA * W, W * (1.0 - ZETA * ZETA).sqrt(), ZETA);
    let levels = [0.002, 0.005, 0.01];
    let reps_per_level = 34;
    let (mut hits, mut width, mut total) = ([0usize; 3], [0.0f64; 3], 0usize);
    for (li, &sigma) in levels.iter().enumerate() {
        let (mut h, mut wsum) = ([0usize; 3], [0.0; 3]);
        for rep in 0..reps_per_level {
            let mut rng = XorShift64::new(mix(5000 * (li as u64 + 1) + rep as u64));
            let train = [decay("lone", 1.0, 0.05, 12.0, sigma, &mut rng)];
            let o = IntervalOptions { replicates: 100, seed: rep as u64 + 7, ..Default::default() };
            let iv = intervals(&train, &setting(), &o).unwrap();
            assert!(iv.method.starts_with("residuals"), "{}", iv.method);
            let e = &iv.eigenvalues[0];
            for (k, (i, v)) in [(e.re, exact.0), (e.im, exact.1), (e.damping_ratio, exact.2)].iter().enumerate() {
                if i.contains(*v) {
                    h[k] += 1;
                    hits[k] += 1;
                }
                wsum[k] += i.width();
                width[k] += i.width();
            }
            total += 1;
        }
        let n = reps_per_level as f64;
        eprintln!(
            "lone decay, noise {sigma}: coverage re {:.2}, im {:.2}, zeta {:.2}; mean widths re {:.2e}, im {:.2e}, zeta {:.2e}",
            h[0] as f64 / n,
            h[1] as f64 / n,
            h[2] as f64 / n,
            wsum[0] / n,
            wsum[1] / n,
            wsum[2] / n
        );
    }
    let n = total as f64;
    eprintln!(
        "lone decay, all {total}: coverage re {:.3}, im {:.3}, zeta {:.3}; mean widths re {:.2e} ({:.1} % of |re|), zeta {:.2e}",
        hits[0] as f64 / n,
        hits[1] as f64 / n,
        hits[2] as f64 / n,
        width[0] / n,
        100.0 * width[0] / n / exact.0.abs(),
        width[2] / n
    );
    assert!(total >= 100);
    for (k, what) in ["re", "im", "damping ratio"].iter().enumerate() {
        assert!(hits[k] as f64 >= 0.9 * n, "{what}: coverage {} of {total}", hits[k]);
    }
}

/// The residual bootstrap refuses a block of no samples and a lone trajectory too short
/// for an interval, by name.
#[test]
fn residual_bootstrap_errors_are_named() {
    let mut rng = XorShift64::new(mix(3));
    let train = [decay("lone", 1.0, 0.05, 12.0, 0.005, &mut rng)];
    let o = IntervalOptions { residual_block: Some(0), ..Default::default() };
    let e = intervals(&train, &setting(), &o).unwrap_err().to_string();
    assert!(e.contains("residual_block"), "{e}");
    let short = MultiSeries { t: train[0].t[..100].to_vec(), x: train[0].x[..100].to_vec(), ..train[0].clone() };
    let e = intervals(&[short], &setting(), &IntervalOptions::default()).unwrap_err();
    assert!(matches!(e, ssm::auto::AutoError::TooLittleData { .. }), "{e}");
    assert!(e.to_string().contains("lone"), "{e}");
}

/// A well-spread xorshift state from a small seed (splitmix64's finalizer): small seeds
/// would start the generator with tiny states, whose first draws are outliers of the
/// Gaussian noise.
fn mix(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
