//! The tests of `chaos_study::flag_pipeline_fit`.

use chaos_study::flag_pipeline::PipelineRow;
use chaos_study::flag_pipeline_fit::*;
use chaos_study::study_results::FlagResults;

/// The flag's noise level over the sd, as the diagnosis rows carry it.
const FN: f64 = chaos_study::calibration::FLAG_SAMPLING.noise_rel;

/// The bundled results of the flag study.
fn res() -> FlagResults {
    FlagResults::bundled().unwrap()
}

/// A quasi-periodic signal (two incommensurate frequencies: a 2-torus, whose delay
/// embeddings need 4 dimensions to be one-to-one in general): projected on its first two
/// singular directions most nearest neighbours are false, on four none (ratio 10).
#[test]
fn projection_fnn_finds_the_torus_dimension() {
    let x: Vec<f64> =
        (0..4000).map(|i| (0.21 * i as f64).sin() + 0.6 * (0.21 * 0.5f64.sqrt() * 5.1 * i as f64).cos()).collect();
    let rows = projection_fnn(&x, 8, 2, 30, &[1, 2, 4, 6], 10.0, 400).unwrap();
    println!("{rows:?}");
    assert_eq!(rows.iter().map(|r| r.dim).collect::<Vec<_>>(), vec![1, 2, 4, 6]);
    assert!(rows[0].fnn > 0.5 && rows[1].fnn > 0.2, "{rows:?}");
    assert_eq!(rows[2].fnn, 0.0, "{rows:?}");
    assert_eq!(rows[3].fnn, 0.0, "{rows:?}");
    assert!(
        (rows[0].singular_rel - 1.0).abs() < 1e-12 && rows.windows(2).all(|w| w[1].singular_rel <= w[0].singular_rel),
        "{rows:?}"
    );
    assert!(projection_fnn(&x, 8, 2, 30, &[8], 10.0, 400).is_err());
    assert!(projection_fnn(&x[..50], 8, 2, 30, &[2], 10.0, 400).is_err());
}

/// The dimension rule on the same torus: `p = 2 d + 1` for each `d` until the projection has
/// no false neighbours (ratio 2); a sine (a circle) needs 2.
#[test]
fn fnn_dimension_rule() {
    let x: Vec<f64> =
        (0..4000).map(|i| (0.21 * i as f64).sin() + 0.6 * (0.21 * 0.5f64.sqrt() * 5.1 * i as f64).cos()).collect();
    let (d, rows) = fnn_dimension(&x, 2, 30, 2.0, 0.005, 6, 400).unwrap();
    println!("{rows:?}");
    assert_eq!(rows.len(), d.unwrap());
    assert!((3..=4).contains(&d.unwrap()), "{rows:?}");
    assert!(rows.last().unwrap().fnn <= 0.005 && rows[..rows.len() - 1].iter().all(|r| r.fnn > 0.005), "{rows:?}");
    let s: Vec<f64> = (0..3000).map(|i| (0.13 * i as f64).sin()).collect();
    let (d, _) = fnn_dimension(&s, 3, 50, 2.0, 0.005, 4, 300).unwrap();
    assert_eq!(d, Some(2));
    let (none, rows) = fnn_dimension(&x, 2, 30, 2.0, 0.005, 1, 400).unwrap();
    assert!(none.is_none() && rows.len() == 1);
}

/// The map class on the true state reproduces its committed diagnosis row: the quartic map
/// on x1..x4 of the known system (noise-free, the flag's data amount) is chaotic with close
/// to the exact exponent, and its statistics equal the committed row's.
#[test]
fn state_model_reproduces_its_committed_row() {
    let fit = StateFit {
        coords: Coords::State,
        centers: 0,
        order: 4,
        ridge: 3e-9,
        multistep: None,
        noise_rel: 0.0,
        noise_seed: 0,
    };
    let (k, r) = state_model_check(
        &chaos_study::flag_pipeline::CHOSEN,
        &chaos_study::flag_pipeline::FLAG_LAYOUT,
        1,
        &fit,
        4000.0,
    )
    .unwrap();
    let committed = res().known.diagnosis_rows().into_iter().find(|(_, _, c)| c.candidate == "state poly 4").unwrap().2;
    for (a, b, tol) in [
        (r.benettin, committed.benettin, 5e-4),
        (r.rosenstein, committed.rosenstein, 5e-4),
        (r.corr_dim, committed.corr_dim, 5e-3),
        (r.js, committed.js, 5e-5),
    ] {
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!((a - b).abs() <= tol, "{r:?} vs {committed:?}");
    }
    assert!(r.failed.is_none() && r.benettin_exact_ok && (k.exact - 0.940).abs() < 0.02, "{r:?}");
    let bad = StateFit { coords: Coords::Delay { embed: 0, shift: 1 }, ..fit };
    assert!(
        state_model_check(
            &chaos_study::flag_pipeline::CHOSEN,
            &chaos_study::flag_pipeline::FLAG_LAYOUT,
            1,
            &bad,
            100.0
        )
        .unwrap_err()
        .to_string()
        .contains("delay")
    );
}

/// What the committed diagnosis says: with the flag's settings on noise-free data no
/// candidate comes within 10 % of the exact exponent; on the true state every noise-free
/// fit does; with SSM dimension 6 (the dimension rule's choice) four of the five
/// RBF sizes at the flag's noise and data amount do, two of five at three times the data,
/// none of three on noise-free data (the noise regularizes the small singular directions);
/// denoised inputs none of five; on the flag no d = 5 or 6 row meets a target.
#[test]
fn diagnosis_counts() {
    let res = res();
    let rows = res.known.diagnosis_rows();
    let within = |what: &str, noise: Option<f64>, scale: usize| {
        let sel: Vec<_> =
            rows.iter().filter(|(w, n, r)| *w == what && noise.is_none_or(|x| *n == x) && r.scale == scale).collect();
        (sel.iter().filter(|(_, _, r)| r.benettin_exact_ok).count(), sel.len())
    };
    assert_eq!(within("(a) noise-free", None, 1), (0, 6));
    assert_eq!(within("(c) true state", Some(0.0), 1), (4, 4));
    assert_eq!(within("(b) d = 6", Some(FN), 1), (4, 5));
    assert_eq!(within("(b) d = 6", Some(FN), 3), (2, 5));
    assert_eq!(within("(b) d = 6", Some(0.0), 1), (0, 3));
    assert_eq!(within("(b) d = 5", None, 1), (1, 6));
    assert_eq!(within("denoised inputs", None, 1), (0, 5));
    assert_eq!(within("ridge", None, 1), (0, 9));
    assert_eq!(within("multistep", None, 1), (1, 2));
    // The multistep scan at d = 6 (Benettin within 10 %, also JS <= 0.01, rows): at 1x and the
    // flag's noise multistep meets Benettin as often as one-step, never JS; the one-step RBF
    // 250 loses its chaos on some seeds where multistep keeps it; at 3x the data the refined
    // RBF 250 is not chaotic while the one-step one is; noise-free neither.
    assert_eq!(d6_scan_counts(&rows, true, 1, FN), (4, 0, 13));
    assert_eq!(d6_scan_counts(&rows, false, 1, FN), (4, 0, 9));
    assert_eq!(d6_scan_counts(&rows, true, 3, FN), (0, 0, 1));
    assert_eq!(d6_scan_counts(&rows, false, 3, FN), (2, 0, 5));
    assert_eq!(d6_scan_counts(&rows, true, 1, 0.0), (0, 0, 2));
    assert_eq!(d6_scan_counts(&rows, false, 1, 0.0), (0, 0, 3));
    // On the flag, SSM dimension 5 and 6 meet none of the four targets.
    let flag = res.held_out.fit_rows();
    assert_eq!(flag.len(), 9);
    assert!(flag.iter().all(|r| r.passes == [false; 4]), "{flag:?}");
}

/// Multistep refinement on the flag (committed rows): no row meets more than one target; the
/// Benettin target only RBF 300 at d = 4, JS only RBF 200 at d = 4 with horizon 4; D2 and
/// Rosenstein stay well below the data's (the committed maxima are the known answer).
#[test]
fn flag_multistep_rows_meet_at_most_one_target() {
    let res = res();
    let rows = res.held_out.multistep_rows();
    assert_eq!(rows.len(), res.held_out.multistep.len());
    assert!(rows.iter().all(|r| r.passes.iter().filter(|&&p| p).count() <= 1), "{rows:?}");
    let meets = |i: usize| rows.iter().filter(|r| r.passes[i]).map(|r| r.candidate.as_str()).collect::<Vec<_>>();
    assert_eq!(meets(0), vec!["RBF 300 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4"]);
    assert!(meets(1).is_empty() && meets(2).is_empty());
    assert_eq!(meets(3), vec!["RBF 200 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4"]);
    let max = |f: &dyn Fn(&PipelineRow) -> Option<f64>| rows.iter().filter_map(f).fold(f64::MIN, f64::max);
    assert!((max(&|r| r.corr_dim) - 2.14).abs() < 1e-12 && (max(&|r| r.rosenstein) - 0.241).abs() < 1e-12);
    assert_eq!(rows.iter().filter(|r| r.failed.is_some()).count(), 1);
}

/// Seeded RBF centre sets on the flag (committed rows): many rows meet the Benettin or the
/// JS target and some meet both (the farthest-point rows meet none, see
/// `flag_multistep_rows_meet_at_most_one_target`), but only the one-step RBF 200 r=3e-9
/// meets D2, and no row meets Benettin, D2 and JS together: the Benettin rows' D2 stays
/// several error bars low. The counts and the best row are the committed rows' known answer.
#[test]
fn flag_centre_rows_meet_benettin_and_js_but_not_d2() {
    let res = res();
    let rows = res.held_out.centre_rows();
    assert_eq!(rows.len(), res.held_out.centres.len());
    assert_eq!(target_counts(&rows), (237, 38, 30, 1, 105, 20, 0));
    let names = |i: usize| rows.iter().filter(|r| r.passes[i]).map(|r| r.candidate.as_str()).collect::<Vec<_>>();
    assert_eq!(names(2), vec!["RBF 200 r=3e-9 d=4 p=9"]);
    let best = rows
        .iter()
        .filter(|r| r.passes[0] && r.passes[3])
        .max_by(|a, b| a.corr_dim.unwrap_or(0.0).total_cmp(&b.corr_dim.unwrap_or(0.0)))
        .unwrap();
    assert_eq!(best.candidate, "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3");
    assert_eq!((best.benettin, best.corr_dim, best.js), (Some(0.346), Some(2.91), Some(0.0090)));
    // Multistep with seeded centres: two rows meet Benettin and JS, both with a low D2.
    let ms: Vec<_> = rows
        .iter()
        .filter(|r| r.passes[0] && r.passes[3] && r.candidate.contains(" ms "))
        .map(|r| r.corr_dim)
        .collect();
    assert_eq!(ms, vec![Some(2.28), Some(1.56)]);
    // Every candidate name is unique and every dimension row names a row.
    assert!(rows.iter().enumerate().all(|(i, r)| rows[..i].iter().all(|q| q.candidate != r.candidate)));
    assert!(
        res.held_out.dimension.iter().all(|d| rows.iter().any(|r| r.candidate == d.candidate)),
        "unknown dimension row"
    );
}

/// Why D2 stays low: the Kaplan-Yorke dimension of every chaotic model (Benettin above 10 %
/// of the data's exponent) is below the data's D2; D2 over five pieces of one long run moves
/// by more than a unit; the data's D2 is the same after moving averages and with its noise
/// added again (not noise-inflated), and over the flag's runs its sd is several times the
/// one-run error bar.
#[test]
fn flag_dimension_diagnosis() {
    let res = res();
    let h = &res.held_out;
    let data = h.data;
    let rows = h.centre_rows();
    let chaotic = |name: &str| {
        rows.iter()
            .any(|r| r.candidate == name && r.failed.is_none() && r.benettin.is_some_and(|b| b > 0.1 * data.rosenstein))
    };
    let ky: Vec<f64> = h.dimension.iter().filter(|d| chaotic(&d.candidate)).filter_map(|d| d.kaplan_yorke).collect();
    assert_eq!(ky.len(), 106);
    let (lo, hi) = (ky.iter().copied().fold(f64::MAX, f64::min), ky.iter().copied().fold(f64::MIN, f64::max));
    assert_eq!((lo, hi), (1.49, 2.69));
    assert!(hi < data.corr_dim - 3.0 * data.corr_dim_err);
    let spread = h
        .dimension
        .iter()
        .filter(|d| d.corr_dim_pieces.iter().all(Option::is_some))
        .map(|d| {
            let v: Vec<f64> = d.corr_dim_pieces.iter().flatten().copied().collect();
            v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
        })
        .fold(f64::MIN, f64::max);
    assert!((spread - 2.33).abs() < 1e-9, "{spread}");
    // Within 0.01 (the printed precision) of the raw data's D2.
    let near = |v: f64| (v - data.corr_dim).abs() <= 0.01 + 1e-12;
    let sm = h.corr_dim_smoothed;
    assert!(near(sm.smoothed_3) && near(sm.smoothed_5) && near(sm.noise_added), "{sm:?}");
    let runs: Vec<f64> = h.corr_dim_runs.iter().filter_map(|r| r.corr_dim).collect();
    assert_eq!(runs.len(), 9);
    assert_eq!(h.corr_dim_of_run(8), Some(data.corr_dim));
    let mean = runs.iter().sum::<f64>() / 9.0;
    let sd = (runs.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / 8.0).sqrt();
    assert!((mean - 3.501).abs() < 1e-3 && (sd - 0.638).abs() < 1e-3, "{mean} {sd}");
    assert!(sd > 3.5 * data.corr_dim_err);
}

/// A live re-run of the best seeded centre-set row on the flag (skipped when the
/// data are absent): RBF 250 r=5e-9, k-means++ centres with seed 3, fitted on traj_9 +
/// traj_7 and measured on traj_8 at step 4, gives the committed numbers to their printed
/// precision (about 10 s).
#[test]
fn flag_centre_row_reproduces() {
    use chaos_study::model_selection::{EvalSettings, data_stats, evaluate_candidate};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/inverted_flag_chaotic");
    if !dir.join("traj_8.csv").is_file() {
        eprintln!("SKIPPED (needs ../shared/data): inverted-flag data not found under {}", dir.display());
        return;
    }
    let load = |k: usize| ssm::load_csv(dir.join(format!("traj_{k}.csv"))).unwrap();
    let (train, test) = ([load(9), load(7)], load(8));
    let s = EvalSettings::default();
    let data = data_stats(&test, 4, &s).unwrap();
    let c = chaos_study::model_selection::Candidate {
        centres: ssm::dynamics::CentreChoice::KMeansPP { seed: 3 },
        ..variant(4, 250, 5e-9, 4, 9, 1, None, 0)
    };
    let r = evaluate_candidate(&train, &test, &c, &data, &s).unwrap();
    let res = res();
    let row = res.held_out.centres.iter().find(|r| r.candidate == "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3").unwrap();
    let close = |a: Option<f64>, b: Option<f64>, tol: f64| matches!((a, b), (Some(a), Some(b)) if (a - b).abs() <= tol);
    assert!(r.failed.is_none(), "{r:?}");
    assert!(
        close(r.benettin, row.benettin, 5e-4 + 1e-12) && close(r.rosenstein, row.rosenstein, 5e-4 + 1e-12),
        "{r:?}"
    );
    assert!(close(r.corr_dim, row.corr_dim, 5e-3 + 1e-12) && close(r.js, row.js, 5e-5 + 1e-12), "{r:?}");
}
