//! The tests of `furuta::full_system`.

use furuta::Error;
use furuta::full_system::*;
use furuta::parametric::{exact_modes, mode_start};
use sim::closed_loop::{Trajectory, simulate};
use sim::scene::SceneBuilder;

/// Known facts (MODEL.md): small starts stay bounded at 31.2 ms and escape within tens of
/// seconds at 31.6 ms; at 31.38 ms neither the pure fast-mode start of 1e-3 rad nor the plain
/// 0.05 rad start escapes within 3000 periods (the fast-mode start's escape seen with exprb
/// at rtol 1e-9 was an integration error: see
/// `near_saddle_verdict_agrees_with_a_tight_reference`).
#[test]
fn switch_scan_brackets_the_switch() {
    let (x, h) = mode_start(31.38, None, Some((1e-3, 0.0))).unwrap();
    let ics: Vec<Start> = vec![([0.05, 0.0, 0.0, 0.0], None), (x, Some(h))];
    let s = switch_scan(&[31.2, 31.38, 31.6], &ics, 3000, ESCAPE_THETA).unwrap();
    eprintln!("{}cost {:.2} s for {} runs", s.to_text(), s.wall_seconds, s.runs);
    assert!(s.outcomes[0].iter().all(Outcome::bounded));
    assert!(s.outcomes[0].iter().all(|o| o.max_theta < 0.3), "{:?}", s.outcomes[0]);
    assert_eq!(s.bracket(), Some((31.38, 31.6)));
    assert_eq!(s.all_escape_from(), Some(31.6));
    assert!(s.monotone());
    assert!(s.outcomes[1].iter().all(Outcome::bounded), "{:?}", s.outcomes[1]);
    for o in &s.outcomes[2] {
        let t = o.escape_t.unwrap();
        assert!((10.0..100.0).contains(&t), "escape at {t}");
    }
    assert!(switch_scan(&[31.4, 31.3], &ics, 10, 1.0).is_err());
    assert!(switch_scan(&[31.4], &[], 10, 1.0).is_err());
}

/// The scene's integrator near the saddle connection: the pure fast-mode start of 1e-3 rad at
/// 31.38 ms follows the saddle cycles for minutes, where an integration error decides the
/// verdict. Against RODAS4 at rtol 1e-12 over 3,000 periods: the same verdict (bounded), the
/// same largest |theta| within 1e-3 rad, theta within 0.05 rad at every sample (the
/// near-saddle motion amplifies the difference; both printed). exprb at rtol 1e-9 / atol
/// 1e-11 escapes here.
#[test]
fn near_saddle_verdict_agrees_with_a_tight_reference() {
    use sim::scene::{IntegratorSpec, MethodKind};
    let (x, h) = mode_start(31.38, None, Some((1e-3, 0.0))).unwrap();
    let periods = 3000;
    let scene_run = run(31.38, &(x, Some(h.clone())), periods, ESCAPE_THETA).unwrap();
    let reference = SceneBuilder::load("furuta-dt30.5")
        .unwrap()
        .dt_ms(31.38)
        .periods(periods)
        .initial_state(&x)
        .escape_theta(ESCAPE_THETA)
        .history(Some(&h))
        .integrator(IntegratorSpec { method: MethodKind::Rodas, rtol: Some(1e-12), atol: Some(1e-14), steps: None })
        .build()
        .unwrap();
    let reference = simulate(&reference, None).unwrap();
    assert!(scene_run.integrator.contains("lean"), "{}", scene_run.integrator);
    assert!(
        scene_run.stopped.is_none() && reference.stopped.is_none(),
        "{:?} {:?}",
        scene_run.stopped,
        reference.stopped
    );
    let theta = |t: &Trajectory| t.states.chunks(t.state_names.len()).map(|r| r[0]).collect::<Vec<f64>>();
    let (a, b) = (theta(&scene_run), theta(&reference));
    assert_eq!(a.len(), b.len());
    let max = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!((max(&a) - max(&b)).abs() < 1e-3 && max(&b) > 0.1, "{} vs {}", max(&a), max(&b));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    eprintln!("largest |theta|: scene {:.4}, RODAS4 {:.4}; max theta difference {diff:.1e}", max(&a), max(&b));
    assert!(diff < 0.05, "max theta difference {diff:e}");
}

/// The stable 2-torus at 30.8 ms from theta0 = 0.05: bounded, the fast frequency within 1 %
/// of the exact linear one, the slow one shifted up by the amplitude (both printed),
/// amplitude about a tenth of a radian and consistent with the mode
/// amplitudes (max |theta| of two tones <= rho_1 + rho_2, reached on a long tail).
#[test]
fn torus_at_30_8_ms() {
    let tf = torus_full(30.8, &([0.05, 0.0, 0.0, 0.0], None), 8000, 80.0).unwrap();
    eprintln!("{tf:?}");
    let lin = tf.linear_freqs_hz;
    assert!(((tf.freqs_hz[1] - lin[1]) / lin[1]).abs() < 0.01, "{tf:?}");
    let shift = (tf.freqs_hz[0] - lin[0]) / lin[0];
    assert!((0.08..0.20).contains(&shift), "slow shift {shift}");
    assert!((0.08..0.2).contains(&tf.amplitude_theta), "{tf:?}");
    let sum = tf.rho[0] + tf.rho[1];
    assert!(tf.amplitude_theta < 1.05 * sum && tf.amplitude_theta > 0.9 * sum, "{tf:?}");
    assert!(tf.rho[0] > 2.0 * tf.rho[1], "slow component dominates: {:?}", tf.rho);
}

/// Domain of attraction at 31.6 ms (paper fig. 5): a start near the 2-torus stays, one
/// inside it (small slow amplitude) and one outside it escape.
#[test]
fn fates_at_31_6_ms() {
    let inside = fate_from(31.6, [0.08, 0.03], [0.0, 0.0], 6000).unwrap();
    let low = fate_from(31.6, [0.02, 0.03], [0.0, 0.0], 6000).unwrap();
    let high = fate_from(31.6, [0.14, 0.055], [0.0, 0.0], 6000).unwrap();
    eprintln!("inside {:?} {:?}; low {:?}; high {:?}", inside.bounded, inside.freqs_hz, low.escape_t, high.escape_t);
    assert!(inside.bounded && inside.escape_t.is_none());
    assert!(!low.bounded && !high.bounded);
    assert!((15.0..40.0).contains(&low.escape_t.unwrap()), "{:?}", low.escape_t);
    assert!(high.escape_t.unwrap() < 10.0, "{:?}", high.escape_t);
    // The first window reads the requested amplitudes (linear start, 1.25 s in).
    let r = inside.amps[0].1;
    assert!((r[0] - 0.08).abs() < 0.1 * 0.08 && (r[1] - 0.03).abs() < 0.15 * 0.03, "{r:?}");
    // Bounded run: the amplitudes stay near the torus.
    let tail = &inside.amps[inside.amps.len() / 2..];
    assert!(tail.iter().all(|a| (0.05..0.13).contains(&a.1[0]) && a.1[1] < 0.06), "amplitudes left the torus");
    assert!(fate_from(31.6, [0.0, 0.0], [0.0, 0.0], 10).is_err());
}

/// Near the 3-torus at 31.5 ms: the 150 s transient has the slow and fast peaks plus
/// sidebands; their spacing is the frequency of the slow amplitude's own oscillation
/// (both printed), two independent readings of the third frequency.
#[test]
fn transient_near_three_torus_shows_third_frequency() {
    let (x, h) = start_from_rho(31.5, [0.02, 0.035], [0.0, 0.0]).unwrap();
    let a = transient_analysis(31.5, &(x, Some(h)), 150.0).unwrap();
    eprintln!("{a:?}");
    assert!(a.peaks.len() >= 3, "{:?}", a.peaks);
    let (s, e) = (a.sideband_spacing_hz.unwrap(), a.envelope_freq_hz.unwrap());
    assert!((s - e).abs() < 0.02 * e, "sideband {s} vs envelope {e}");
    assert!((0.01..0.05).contains(&e), "{e}");
    let lin = exact_modes(31.5).unwrap().freqs_hz;
    assert!(
        ((a.fast.freq_hz - lin[1]) / lin[1]).abs() < 0.03 && ((a.slow.freq_hz - lin[0]) / lin[0]).abs() < 0.2,
        "{a:?}"
    );
}

/// `mode_start` on the fast mode alone: theta's envelope grows at the exact fast rate
/// (`ln|mu|/dt`, +0.27 1/s) and its first sample is the requested amplitude times
/// cos(phase); the mixed start's theta is the sum of the two single-mode starts (linear).
#[test]
fn mode_start_excites_the_fast_mode() {
    let dt_ms = 31.0;
    let e = exact_modes(dt_ms).unwrap();
    let (x, h) = mode_start(dt_ms, None, Some((1e-4, 0.4))).unwrap();
    assert!((x[0] - 1e-4 * 0.4f64.cos()).abs() < 1e-12, "{x:?}");
    let tr = run(dt_ms, &(x, Some(h)), 640, ESCAPE_THETA).unwrap();
    let th = tr.primary();
    let per = 32; // ~1 s chunks, 8 fast periods each
    let peaks: Vec<f64> = th.chunks(per).take(20).map(|c| c.iter().fold(0.0f64, |m, v| m.max(v.abs()))).collect();
    let rate = (peaks[18] / peaks[2]).ln() / (16.0 * per as f64 * tr.dt);
    eprintln!("fast envelope rate {rate:+.5} vs exact {:+.5}", e.rates[1]);
    assert!(((rate - e.rates[1]) / e.rates[1]).abs() < 0.05, "{rate} vs {}", e.rates[1]);
    let (s, hs) = mode_start(dt_ms, Some((2e-3, 1.0)), None).unwrap();
    let (f, hf) = mode_start(dt_ms, None, Some((1e-3, -0.5))).unwrap();
    let (m, hm) = mode_start(dt_ms, Some((2e-3, 1.0)), Some((1e-3, -0.5))).unwrap();
    for k in 0..4 {
        assert!((m[k] - s[k] - f[k]).abs() < 1e-12 * (1.0 + m[k].abs()), "{k}");
    }
    for ((a, b), c) in hs.iter().zip(&hf).zip(&hm) {
        assert!((c[0] - a[0] - b[0]).abs() < 1e-14 && (c[1] - a[1] - b[1]).abs() < 1e-14);
    }
    assert!(mode_start(dt_ms, None, None).is_err());
    assert!(mode_start(dt_ms, Some((-1e-3, 0.0)), None).is_err());
}

/// The starts of a grid from one `ModeBasis` per dt (`start_from_rho_in`, as `map_basin`
/// takes them) equal, bit for bit, those of the per-start computation as it was before the
/// basis (eigenvectors of the requested modes computed for every start, written out here),
/// with one mode left out, both modes, and both phases; bad amplitudes are refused alike.
#[test]
fn starts_from_one_mode_basis_equal_the_per_start_ones() {
    use nalgebra::{Complex, DVector};
    fn per_start(dt_ms: f64, slow: Option<(f64, f64)>, fast: Option<(f64, f64)>) -> ([f64; 4], Vec<[f64; 2]>) {
        let scene = SceneBuilder::load("furuta-dt30.5").unwrap().dt_ms(dt_ms).build().unwrap();
        let map = sim::stability::linear_plant(&scene).unwrap().closed_loop(&scene.controller_config()).unwrap();
        let lay = map.layout;
        let mut pairs = sim::stability::dominant_pairs(&scene).unwrap();
        pairs.truncate(2);
        pairs.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        let n = map.matrix.nrows();
        let mut total = DVector::<f64>::zeros(n);
        for (pair, m) in pairs.iter().zip([slow, fast]) {
            let Some((theta_amp, phase)) = m else { continue };
            let v = furuta::parametric::eigenvector_near(&map.matrix, Complex::new(pair.re, pair.im)).unwrap();
            let th = v[0];
            let scale = Complex::from_polar(theta_amp / th.norm(), phase - th.arg());
            for k in 0..n {
                total[k] += (v[k] * scale).re;
            }
        }
        let state = [total[0], total[1], total[2], total[3]];
        let history = (0..=lay.delay).rev().map(|k| [total[lay.y_start + k], total[lay.z_start + k]]).collect();
        (state, history)
    }
    let bits =
        |s: &([f64; 4], Vec<[f64; 2]>)| s.0.iter().chain(s.1.iter().flatten()).map(|v| v.to_bits()).collect::<Vec<_>>();
    for dt_ms in [31.3, 31.6] {
        let basis = furuta::parametric::ModeBasis::at(dt_ms).unwrap();
        for (rho, phases) in [
            ([0.005, 0.0], [0.0, 0.0]),
            ([0.0, 0.12], [0.0, 0.3]),
            ([0.1, 0.03], [0.0, 0.0]),
            ([0.25, 0.004], [1.0, -2.0]),
        ] {
            let m = |k: usize| (rho[k] > 0.0).then_some((rho[k], phases[k]));
            let want = per_start(dt_ms, m(0), m(1));
            let got = start_from_rho_in(&basis, rho, phases).unwrap();
            assert_eq!(bits(&got), bits(&want), "dt {dt_ms} rho {rho:?}");
            assert_eq!(bits(&start_from_rho(dt_ms, rho, phases).unwrap()), bits(&want), "dt {dt_ms} rho {rho:?}");
        }
        for rho in [[0.0, 0.0], [-0.1, 0.1], [f64::NAN, 0.1]] {
            assert!(
                matches!(start_from_rho_in(&basis, rho, [0.0, 0.0]), Err(Error::BadInput { what: "rho", .. })),
                "{rho:?}"
            );
        }
        assert!(matches!(
            start_from_rho_in(&basis, [0.1, 0.0], [f64::NAN, 0.0]),
            Err(Error::BadOption { what: "mode_start", .. })
        ));
    }
}

/// The switch scan runs every (dt, start) on the rayon pool: a 1-thread and a 2-thread pool
/// give the same outcomes, bit for bit, in the same order; so does the per-dt variant.
#[test]
fn switch_scan_is_bit_identical_on_one_and_two_threads() {
    let ics: Vec<Start> =
        vec![([0.05, 0.0, 0.0, 0.0], None), ([0.01, 0.0, 0.0, 0.0], None), ([0.3, 0.0, 0.0, 0.0], None)];
    let dts = [31.2, 31.6, 33.0];
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let a = switch_scan(&dts, &ics, 400, 0.2).unwrap();
            let b =
                switch_scan_per_dt(&dts, |dt| default_ics(dt).map(|v| v.into_iter().take(3).collect()), 300).unwrap();
            (a, b)
        })
    };
    let ((a1, b1), (a2, b2)) = (on(1), on(2));
    let bits = |s: &SwitchScan| -> Vec<(Option<u64>, u64)> {
        s.outcomes.iter().flatten().map(|o| (o.escape_t.map(f64::to_bits), o.max_theta.to_bits())).collect()
    };
    assert_eq!(bits(&a1), bits(&a2));
    assert_eq!(bits(&b1), bits(&b2));
    assert_eq!((a1.runs, b1.runs), (9, 9));
    // The 0.3 rad start escapes past 0.2 rad, the small ones do not: both kinds covered.
    assert!(a1.outcomes[0][2].escape_t.is_some() && a1.outcomes[0][1].bounded(), "{}", a1.to_text());
    assert!(switch_scan_per_dt(&[31.4, 31.3], default_ics, 10).is_err());
}

/// A run continued from [`end_start`] at the same dt is the uninterrupted run: 300 + 300
/// periods from a mixed mode start at 31.4 ms against one run of 600, theta within 1e-7 rad
/// at every sample. With the pre-history shifted by one sample (the last row counted twice,
/// as the torus continuation did before) the continued run is far off: the delayed samples
/// then belong to the wrong instants, a kick of the fast mode. Both errors are printed.
#[test]
fn end_start_continues_a_run() {
    let dt = 31.4;
    let (x, h) = start_from_rho(dt, [0.097, 0.0277], [0.0, 0.0]).unwrap();
    let whole = run(dt, &(x, Some(h.clone())), 600, ESCAPE_THETA).unwrap().primary();
    let first = run(dt, &(x, Some(h)), 300, ESCAPE_THETA).unwrap();
    let delay = SceneBuilder::load("furuta-dt30.5").unwrap().dt_ms(dt).build().unwrap().controller.delay as usize;
    let start = end_start(&first, delay).unwrap();
    assert_eq!(start.1.as_ref().map(Vec::len), Some(delay + 1));
    let second = run(dt, &start, 300, ESCAPE_THETA).unwrap().primary();
    let err = second.iter().zip(&whole[300..]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    eprintln!("continued vs whole: max |theta error| {err:.2e} rad");
    assert!(err < 1e-7, "{err}");
    // The off-by-one pre-history: rows 300 - delay ..= 300.
    let rows = first.rows();
    let shifted: Vec<[f64; 2]> = (rows - 1 - delay..rows).map(|i| [first.state(i, 0), first.state(i, 2)]).collect();
    let off = run(dt, &(start.0, Some(shifted)), 300, ESCAPE_THETA).unwrap().primary();
    let err_off = off.iter().zip(&whole[300..]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    eprintln!("shifted pre-history: max |theta error| {err_off:.2e} rad");
    assert!(err_off > 1e-4, "{err_off}");
    // Too short a run is refused, naming the trajectory.
    let short = run(dt, &start, 1, ESCAPE_THETA).unwrap();
    assert!(matches!(end_start(&short, delay), Err(Error::BadInput { what: "trajectory", .. })));
}

/// [`run`] on the scene parsed once per process equals the old path (the bundled scene parsed
/// for every run) bit for bit, and [`run_with`] with the scene's own integrator equals [`run`].
#[test]
fn run_on_the_cached_scene_equals_a_freshly_parsed_scene_bit_for_bit() {
    let (x, h) = mode_start(31.5, Some((0.05, 0.0)), Some((0.02, 0.0))).unwrap();
    let start: Start = (x, Some(h.clone()));
    let fresh = SceneBuilder::load("furuta-dt30.5")
        .unwrap()
        .dt_ms(31.5)
        .periods(300)
        .initial_state(&x)
        .escape_theta(ESCAPE_THETA)
        .history(Some(&h))
        .build()
        .unwrap();
    let old = simulate(&fresh, None).unwrap();
    let new = run(31.5, &start, 300, ESCAPE_THETA).unwrap();
    let spec = fresh.integrator.clone();
    let with = run_with(Some(&spec), 31.5, &start, 300, ESCAPE_THETA).unwrap();
    let bits = |t: &Trajectory| t.states.iter().chain(&t.u).map(|v| v.to_bits()).collect::<Vec<u64>>();
    assert_eq!(old.rows(), 301);
    assert_eq!(bits(&old), bits(&new));
    assert_eq!(bits(&old), bits(&with));
    assert_eq!((old.ode_stats, &old.integrator), (new.ode_stats, &new.integrator));
}
