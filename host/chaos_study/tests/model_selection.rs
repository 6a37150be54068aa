//! The tests of `chaos_study::model_selection`.

use chaos::Targets;
use chaos_study::Error;
use chaos_study::model_selection::*;
use ssm::{Dynamics, Ridge};
use ssm::{FitOptions, SsmModel, TimeSeries, fit};

fn henon_series(name: &str, transient: usize, n: usize) -> TimeSeries {
    let o = chaos::reference::Henon::default().orbit(n, transient);
    TimeSeries::new(name, (0..n).map(|k| k as f64).collect(), o.iter().map(|s| s[0]).collect()).unwrap()
}

fn henon_candidate(name: &str, dynamics: Dynamics, order: u32) -> Candidate {
    Candidate {
        name: name.into(),
        step: 1,
        fit: FitOptions {
            dim: 2,
            embed: 5,
            shift: 1,
            manifold_order: 3,
            dyn_order: order,
            dynamics,
            ridge: Ridge::Fixed(1e-10),
            linear_anchor: None,
            anchor_joint: false,
        },
        smooth: 0,
        multistep: None,
        denoise_inputs: 0,
        centres: Default::default(),
    }
}

/// Known answer: an SSM model fitted to Henon x-data (delay embedding p = 5, d = 2) must
/// itself be chaotic with Henon's exponent 0.419 per iteration; a linear map (order 1)
/// cannot be and is not picked.
#[test]
fn henon_model_is_chaotic_with_the_known_exponent_and_is_selected() {
    let train = [henon_series("h1", 100, 3000), henon_series("h2", 5000, 3000)];
    let test = henon_series("h3", 10_000, 3000);
    let cands = [
        henon_candidate("linear map", Dynamics::Map, 1),
        henon_candidate("rbf 400", Dynamics::Rbf { centers: 400 }, 1),
        henon_candidate("quartic map", Dynamics::Map, 4),
    ];
    let s = EvalSettings { benettin_transient: 1000, benettin_steps: 20_000, ..Default::default() };
    let (res, sel) = evaluate_and_select(&train, &test, &cands, &s, &Targets::default()).unwrap();
    // The held-out data: Henon's D2 1.21 and exponent 0.419 through the same estimators.
    let data = &res[0].data;
    assert!((data.corr_dim - 1.21).abs() < 0.05 && (data.lle - 0.419).abs() < 0.03, "{data:?}");
    // The RBF map is chaotic with Henon's exponent within 10 %; the linear map decays and
    // the quartic map in these coordinates settles on a periodic orbit (rows printed).
    for r in &res {
        eprintln!("{}", describe(r));
    }
    let rbf = &res[1];
    let b = rbf.benettin.unwrap();
    assert!(rbf.failed.is_none() && (b - 0.419).abs() < 0.042, "{}", describe(rbf));
    assert!(rbf.js.unwrap() < 0.01 && (rbf.rosenstein.unwrap() - 0.419).abs() < 0.07, "{}", describe(rbf));
    assert!(
        res[0].benettin.unwrap() < 0.0 && res[2].benettin.unwrap() < 0.0,
        "{} / {}",
        describe(&res[0]),
        describe(&res[2])
    );
    assert_eq!(sel.index, Some(1), "{sel:?}");
    assert!(sel.why.contains("Benettin within 10 %") && sel.warnings.is_empty(), "{sel:?}");
}

/// A centre choice refits the RBF map on the reduced training coordinates with those
/// centres (options unchanged, the centres those of `choose_centres`); on Henon data
/// the seeded model is chaotic with the known exponent 0.419 too. A centre choice with
/// polynomial dynamics is refused.
#[test]
fn seeded_centres_refit_the_map() {
    use ssm::dynamics::CentreChoice;
    let train = [henon_series("h1", 100, 3000), henon_series("h2", 5000, 3000)];
    let test = henon_series("h3", 10_000, 3000);
    let s = EvalSettings { benettin_transient: 1000, benettin_steps: 20_000, ..Default::default() };
    let data = data_stats(&test, 1, &s).unwrap();
    let choice = CentreChoice::KMeansPP { seed: 1 };
    let c = Candidate { centres: choice, ..henon_candidate("rbf 200 kmeans++", Dynamics::Rbf { centers: 200 }, 1) };
    let (r, m) = evaluate_candidate_fitted(&train, &test, &c, &data, &s).unwrap();
    let m = m.unwrap();
    assert_eq!(m.options, c.fit);
    let (ys, dts) = ssm::fit::embed_training(&phase_subsamples(&train, 1).unwrap(), &c.fit).unwrap();
    let etas: Vec<faer::Mat<f64>> = ys.iter().map(|y| m.manifold.reduce_points(y.as_ref())).collect();
    let trajs: Vec<_> =
        etas.iter().zip(&dts).map(|(e, &dt)| ssm::dynamics::EtaTrajectory { eta: e.as_ref(), dt }).collect();
    let ssm::ReducedDynamics::Rbf(rbf) = &m.dynamics else { panic!("not an RBF map") };
    let ssm::ReducedDynamics::Rbf(again) =
        ssm::ReducedDynamics::fit_rbf_centres(&trajs, c.fit.dynamics, c.fit.ridge, choice).unwrap()
    else {
        panic!()
    };
    assert_eq!(rbf.centers, again.centers);
    let ssm::ReducedDynamics::Rbf(plain) = ssm::ReducedDynamics::fit(&trajs, c.fit.dynamics, 1, c.fit.ridge).unwrap()
    else {
        panic!()
    };
    assert_ne!(rbf.centers, plain.centers);
    assert!(r.notes.iter().any(|n| n == "centres kmeans++@1"), "{:?}", r.notes);
    let b = r.benettin.unwrap();
    assert!(r.failed.is_none() && (b - 0.419).abs() < 0.042, "{}", describe(&r));
    let poly = Candidate { centres: choice, ..henon_candidate("map", Dynamics::Map, 3) };
    assert!(matches!(
        evaluate_candidate(&train, &test, &poly, &data, &s),
        Err(Error::BadOption { what: "centres", .. })
    ));
}

/// The rollout loss is zero for the exact map of the data (up to rounding), grows with
/// the horizon for a map with a slightly wrong rotation (error after k steps about
/// k x 0.01 rad of a unit circle), and is `None` on too short a series.
#[test]
fn rollout_error_known_answers() {
    let rot =
        |w: f64, n: usize| -> Vec<f64> { (0..n).flat_map(|k| [(w * k as f64).cos(), (w * k as f64).sin()]).collect() };
    let data = rot(0.3, 400);
    let fitted = |w: f64| {
        let d = rot(w, 400);
        let mm = faer::Mat::from_fn(400, 2, |i, j| d[2 * i + j]);
        ssm::ReducedDynamics::fit(
            &[ssm::dynamics::EtaTrajectory { eta: mm.as_ref(), dt: 0.1 }],
            Dynamics::Map,
            1,
            Ridge::Fixed(0.0),
        )
        .unwrap()
    };
    let exact = rollout_error(&fitted(0.3), &data, 2, 10, 50).unwrap();
    assert!(exact < 1e-9, "{exact}");
    let (e1, e10) = (
        rollout_error(&fitted(0.31), &data, 2, 1, 50).unwrap(),
        rollout_error(&fitted(0.31), &data, 2, 10, 50).unwrap(),
    );
    // RMS over k = 1..=10 of 2 sin(0.005 k) ~ 0.01 sqrt(385 / 10) = 0.062.
    assert!((e1 - 0.01).abs() < 1e-4 && (e10 - 0.0620).abs() < 1e-3, "{e1} {e10}");
    assert!(rollout_error(&fitted(0.3), &data[..20], 2, 10, 50).is_none());
}

/// The estimator bias on the flag's candidates (docs/decisions/0002): the one-step linear-kernel
/// models whose D2 lies within 0.5 of the data's and JS <= 0.005 have Rosenstein/Benettin
/// near one half, outside the range where the 10 % Benettin and 5 % Rosenstein targets
/// can hold together; if the estimator is biased on the data as on them, the data's
/// exponent is about twice the Rosenstein value (the calibration, `chaos_study::calibration`,
/// finds no such bias common to attractors like the flag's). The one-step rows inside the
/// joint range (thin-plate kernels, map steps 5 and 6) have small Benettin exponents, and
/// one errors-in-variables row a larger one with D2 and JS far from the data's.
#[test]
fn flag_search_ratios_and_the_joint_range() {
    let (lo, hi) = Targets::default().joint_ratio_range();
    assert!((lo - 0.95 / 1.1).abs() < 1e-12 && (hi - 1.05 / 0.9).abs() < 1e-12, "{lo} {hi}");
    let rows = flag_search_ratios(&chaos_study::study_results::FlagResults::bundled().unwrap().search);
    assert!(rows.len() >= 30, "{}", rows.len());
    assert!(rows.iter().filter(|r| r.candidate.starts_with("k=4 ")).all(|r| r.data_corr_dim == 3.36), "{rows:?}");
    let best = best_matching(&rows);
    assert_eq!(best.len(), 3, "{best:?}");
    for r in &best {
        assert!(
            r.ratio > 0.42 && r.ratio < 0.56 && r.implied_data_exponent > 0.59 && r.implied_data_exponent < 0.78,
            "{r:?}"
        );
        assert!(r.ratio < lo, "{r:?}");
    }
    let joint: Vec<&RatioRow> = rows.iter().filter(|r| r.ratio >= lo && r.ratio <= hi).collect();
    // The errors-in-variables row c=250 is the one joint row above 0.21; its D2 and JS are
    // far from the data's.
    for r in joint.iter().filter(|r| !r.multistep) {
        assert!(
            r.benettin < 0.21 || (r.candidate.contains("denoised inputs") && r.benettin < 0.28 && r.js > 0.01),
            "{r:?}"
        );
    }
}

/// The errors-in-variables refit on a known answer: a pure sinusoid with 20 samples per
/// period. A centred moving average of 5 samples scales it by
/// G = sin(5 pi / 20) / (5 sin(pi / 20)) = 0.9040 (in the interior), so the refitted map
/// takes a smoothed point to the raw next point, 1 / G = 1.106 times the smoothed next
/// point, where the ordinary fit (a rotation) takes it to the smoothed next point.
#[test]
fn denoised_input_refit_known_answer_on_a_sinusoid() {
    let th = 2.0 * std::f64::consts::PI / 20.0;
    let n = 2000;
    let ts = TimeSeries::new(
        "sin",
        (0..n).map(|k| k as f64 * 0.01).collect(),
        (0..n).map(|k| (th * k as f64).sin()).collect(),
    )
    .unwrap();
    let opts = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 1,
        dyn_order: 1,
        dynamics: Dynamics::Rbf { centers: 20 },
        ridge: Ridge::Fixed(1e-12),
        linear_anchor: None,
        anchor_joint: false,
    };
    let plain = fit(std::slice::from_ref(&ts), &opts).unwrap();
    let mut m = plain.clone();
    refit_denoised_inputs(&mut m, std::slice::from_ref(&ts), 1, 2).unwrap();
    let g = (5.0 * th / 2.0).sin() / (5.0 * (th / 2.0).sin());
    assert!((g - 0.9040).abs() < 1e-4, "{g}");
    let smooth = moving_average(&ts, 2).unwrap();
    let (ys, _) = ssm::fit::embed_training(std::slice::from_ref(&smooth), &opts).unwrap();
    let eta = m.manifold.reduce_points(ys[0].as_ref());
    let mut sc = ssm::dynamics::StepScratch::default();
    // RMS over interior points of |f(eta_i) - c eta_{i+1}| over the RMS radius.
    let mut err = |model: &SsmModel, c: f64| {
        let (mut e2, mut r2) = (0.0, 0.0);
        for i in 100..eta.nrows() - 100 {
            let mut e = vec![eta[(i, 0)], eta[(i, 1)]];
            model.dynamics.step(&mut e, model.dt, &mut sc);
            e2 += (e[0] - c * eta[(i + 1, 0)]).powi(2) + (e[1] - c * eta[(i + 1, 1)]).powi(2);
            r2 += eta[(i, 0)].powi(2) + eta[(i, 1)].powi(2);
        }
        (e2 / r2).sqrt()
    };
    // The refit interpolates its training pairs, so it hits the raw next point closely;
    // the plain fit misses the smoothed one by more (its training ring is 1 / G larger:
    // the kernel terms extrapolate inwards). Both errors are printed.
    let (refit, plain_err, refit_wrong) = (err(&m, 1.0 / g), err(&plain, 1.0), err(&m, 1.0));
    eprintln!("refit {refit}, plain {plain_err}");
    assert!(refit < 1e-4 && plain_err < 1e-2, "refit {refit}, plain {plain_err}");
    assert!((refit_wrong - (1.0 / g - 1.0)).abs() < 0.01, "{refit_wrong}");
}

fn result(
    name: &str,
    b: Option<f64>,
    r: Option<f64>,
    d2: Option<f64>,
    js: Option<f64>,
    failed: Option<&str>,
) -> CandidateResult {
    CandidateResult {
        name: name.into(),
        step: 1,
        options: henon_candidate(name, Dynamics::Map, 2).fit,
        data: DataStats {
            step: 1,
            dt: 1.0,
            lag: 1,
            theiler: 1,
            corr_dim: 3.0,
            corr_dim_err: 0.2,
            lle: 0.4,
            len: 100,
            noise_sd: 0.0,
        },
        benettin: b,
        benettin_err: b.map(|_| 0.01),
        benettin_2nd: None,
        rosenstein: r,
        rosenstein_noisy: None,
        rollout: None,
        corr_dim: d2,
        corr_dim_err: d2.map(|_| 0.1),
        js,
        excursion: Some(1.0),
        long_steps: 100,
        failed: failed.map(String::from),
        notes: Vec::new(),
        seconds: 0.0,
    }
}

/// Constructed case: the pick meets most targets; a failed candidate with perfect
/// numbers is never picked; ties go to the smaller normalized error; a non-chaotic pick
/// on chaotic data is warned about; all failed gives no pick.
#[test]
fn selection_by_targets_failures_ties_and_warnings() {
    let t = Targets::default();
    let res = vec![
        result("torus", Some(0.0), Some(0.39), Some(3.05), Some(0.005), None), // R, D2, JS: 3
        result("escaped", Some(0.4), Some(0.4), Some(3.0), Some(0.0), Some("escaped in the long run")),
        result("chaotic", Some(0.41), Some(0.39), Some(3.1), Some(0.008), None), // all 4
        result("chaotic, worse", Some(0.43), Some(0.395), Some(3.15), Some(0.009), None), // all 4, larger error
    ];
    assert_eq!(res[0].passes(&t), [false, true, true, true]);
    assert_eq!(res[1].passes(&t), [false; 4]);
    assert!(res[1].score(&t).is_infinite());
    let sel = select(&res, &t, 0.0);
    assert_eq!(sel.index, Some(2), "{sel:?}");
    assert!(sel.why.contains("meets 4 of 4") && sel.why.contains("1 of 4 candidates failed"), "{}", sel.why);
    assert!(sel.warnings.is_empty(), "{:?}", sel.warnings);
    // Without the chaotic ones the torus is picked, with a warning.
    let sel = select(&res[..2], &t, 0.0);
    assert_eq!(sel.index, Some(0));
    assert!(sel.warnings[0].contains("data look chaotic"), "{:?}", sel.warnings);
    // The reverse: non-chaotic data (exponent below the margin), chaotic pick.
    let mut calm = res[2].clone();
    calm.data.lle = -0.05;
    let sel = select(&[calm], &t, 0.0);
    assert!(sel.warnings[0].contains("do not look so"), "{:?}", sel.warnings);
    // Every candidate failed: no pick, said plainly.
    let sel = select(&res[1..2], &t, 0.0);
    assert_eq!(sel.index, None);
    assert!(sel.why.contains("all 1 candidates failed"), "{}", sel.why);
}
