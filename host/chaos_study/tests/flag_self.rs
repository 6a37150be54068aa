//! The tests of `chaos_study::flag_self`.

use chaos_study::flag_pipeline::{PipelineRow, rows_against};
use chaos_study::flag_pipeline_fit::variant;
use chaos_study::flag_self::*;
use chaos_study::model_selection::{Candidate, EvalSettings, data_stats};
use chaos_study::study_results::{FlagResults, ModelRow, RunStats};
use ssm::{Dynamics, TimeSeries};

/// The bundled results of the flag study.
fn res() -> FlagResults {
    FlagResults::bundled().unwrap()
}

fn flag_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/inverted_flag_chaotic")
}

fn close(a: Option<f64>, b: Option<f64>, tol: f64) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() <= tol + 1e-12,
        (None, None) => true,
        _ => false,
    }
}

/// Pieces of a run: the whole run, and the first and last held-out-length pieces when it is
/// longer; a run no longer than the piece is one row.
#[test]
fn pieces_of_a_run() {
    assert_eq!(pieces(3, 2247, 1973), vec![(3, 0, 2247), (3, 0, 1973), (3, 274, 1973)]);
    assert_eq!(pieces(1, 908, 1973), vec![(1, 0, 908)]);
    assert_eq!(pieces(8, 1973, 1973), vec![(8, 0, 1973)]);
    assert_eq!(pieces(5, 100, 0), vec![(5, 0, 100)]);
}

/// Mean, sd and placement on a known answer: values 1..=5 have mean 3 and sd sqrt(2.5);
/// 3 sits at the 50th percentile (tie counting half) with z = 0, 6 above all with
/// z = 3 / sqrt(2.5).
#[test]
fn placement_known_answer() {
    let v = [1.0, 2.0, 3.0, 4.0, 5.0];
    let (m, sd) = mean_sd(&v).unwrap();
    assert!((m - 3.0).abs() < 1e-15 && (sd - 2.5f64.sqrt()).abs() < 1e-15);
    assert_eq!(placement(3.0, &v), Some((0.5, 0.0)));
    let (p, z) = placement(6.0, &v).unwrap();
    assert!(p == 1.0 && (z - 3.0 / 2.5f64.sqrt()).abs() < 1e-12);
    assert_eq!(placement(1.0, &[1.0]), None);
    assert_eq!(placement(1.0, &[2.0, 2.0]), None);
}

/// The committed rows: the whole runs' D2 are the committed D2 of every run (the same
/// estimator, the test run's settings); the counts of whole runs and of test-length pieces
/// meeting each one-run target, which runs meet each, and the Rosenstein exponents of the two
/// overlapping pieces of one run.
#[test]
fn flag_self_counts() {
    let res = res();
    let data = res.held_out.data.tuple();
    let rows = res.experiment.rows.clone();
    assert_eq!(rows.len(), 15);
    let whole: Vec<&SelfRow> = rows.iter().filter(|r| is_whole(r, &rows)).collect();
    let part: Vec<&SelfRow> = rows.iter().filter(|r| !is_whole(r, &rows)).collect();
    assert_eq!(whole.iter().map(|r| r.run).collect::<Vec<_>>(), vec![0, 1, 2, 3, 4, 5, 6, 7, 9]);
    assert!(part.iter().all(|r| r.len == res.held_out.test_len) && part.len() == 6);
    for r in &whole {
        assert_eq!(r.corr_dim, res.held_out.corr_dim_of_run(r.run), "traj_{}", r.run);
    }
    assert_eq!(self_counts(&whole, data), (9, 2, 1, 8, 0));
    assert_eq!(self_counts(&part, data), (6, 2, 1, 6, 0));
    let all: Vec<&SelfRow> = rows.iter().collect();
    assert_eq!(self_counts(&all, data), (15, 4, 2, 14, 0));
    let meets = |i: usize| {
        whole.iter().filter(|r| self_passes(r.rosenstein, r.corr_dim, r.js, data)[i]).map(|r| r.run).collect::<Vec<_>>()
    };
    assert_eq!((meets(0), meets(1), meets(2)), (vec![1, 3], vec![2], vec![0, 1, 3, 4, 5, 6, 7, 9]));
    let t3: Vec<f64> = part.iter().filter(|r| r.run == 3).filter_map(|r| r.rosenstein).collect();
    assert_eq!(t3, vec![0.162, 0.326]);
}

/// The best committed model row placed among the whole runs: the runs' mean and sd of each
/// statistic and the row's percentile and z-score in each.
#[test]
fn best_row_among_the_runs() {
    let res = res();
    let rows = res.experiment.rows.clone();
    let whole: Vec<&SelfRow> = rows.iter().filter(|r| is_whole(r, &rows)).collect();
    let col = |f: &dyn Fn(&SelfRow) -> Option<f64>| whole.iter().filter_map(|r| f(r)).collect::<Vec<f64>>();
    let (ros, d2, js) = (col(&|r| r.rosenstein), col(&|r| r.corr_dim), col(&|r| r.js));
    assert_eq!((ros.len(), d2.len(), js.len()), (9, 8, 9));
    let best = res
        .held_out
        .centre_rows()
        .into_iter()
        .find(|r| r.candidate == "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3")
        .unwrap();
    let (pr, zr) = placement(best.rosenstein.unwrap(), &ros).unwrap();
    let (pd, zd) = placement(best.corr_dim.unwrap(), &d2).unwrap();
    let (pj, zj) = placement(best.js.unwrap(), &js).unwrap();
    let (mr, sr) = mean_sd(&ros).unwrap();
    let (md, sd) = mean_sd(&d2).unwrap();
    let (mj, sj) = mean_sd(&js).unwrap();
    println!("{mr} {sr} {pr} {zr}; {md} {sd} {pd} {zd}; {mj} {sj} {pj} {zj}");
    assert!((mr - 0.3452).abs() < 5e-5 && (sr - 0.1121).abs() < 5e-5, "{mr} {sr}");
    assert!((md - 3.5188).abs() < 5e-5 && (sd - 0.6795).abs() < 5e-5, "{md} {sd}");
    assert!((mj - 0.005211).abs() < 5e-7 && (sj - 0.005402).abs() < 5e-7, "{mj} {sj}");
    assert!((pr - 3.0 / 9.0).abs() < 1e-12 && (zr + 0.484).abs() < 0.005, "{pr} {zr}");
    assert!((pd - 1.0 / 8.0).abs() < 1e-12 && (zd + 0.896).abs() < 0.005, "{pd} {zd}");
    assert!((pj - 8.0 / 9.0).abs() < 1e-12 && (zj - 0.701).abs() < 0.005, "{pj} {zj}");
}

/// Every committed flag row's name gives its candidate back: every name parses, the best row is
/// the candidate the live re-run test builds by hand, a multistep name carries its
/// refinement; a bad name is an error naming it.
#[test]
fn candidate_names_parse() {
    let cands: Vec<Candidate> =
        res().held_out.centres.iter().map(|r| candidate_from_name(&r.candidate).unwrap()).collect();
    assert_eq!(cands.len(), 237);
    let c = candidate_from_name("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3").unwrap();
    let hand = variant(4, 250, 5e-9, 4, 9, 1, None, 0);
    assert_eq!(
        (c.fit, c.step, c.centres, c.multistep.is_none()),
        (hand.fit, 4, ssm::dynamics::CentreChoice::KMeansPP { seed: 3 }, true)
    );
    let ms = candidate_from_name("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=4 stride 8 it 4").unwrap();
    let m = ms.multistep.unwrap();
    assert_eq!((m.horizon, m.stride, m.iterations, ms.fit.ridge), (4, 8, 4, ssm::Ridge::Fixed(1e-8)));
    assert_eq!(ms.fit.dynamics, Dynamics::Rbf { centers: 300 });
    for bad in [
        "poly 4 d=4",
        "RBF x r=1 d=4 p=9",
        "RBF 200 r=3e-9 d=4",
        "RBF 200 r=3e-9 d=4 p=9 centres",
        "RBF 200 r=3e-9 d=4 p=9 ms h=4",
        "RBF 200 r=3e-9 d=4 p=9 foo",
    ] {
        let e = candidate_from_name(bad).unwrap_err().to_string();
        assert!(e.contains("flag row name") && e.contains(bad), "{e}");
    }
}

/// The pick rule on known rows: the row meeting most targets wins; among equals the smaller
/// score; a failed row never.
#[test]
fn pick_rule() {
    let data = RunStats { rosenstein: 0.3, corr_dim: 3.0, corr_dim_err: 0.2 };
    let row = |n: &str, b: f64, r: f64, d: f64, j: f64, failed: &str| ModelRow {
        candidate: n.into(),
        benettin: Some(b),
        rosenstein: Some(r),
        corr_dim: Some(d),
        js: Some(j),
        failed: (!failed.is_empty()).then(|| failed.into()),
    };
    let rows = [
        row("a", 0.31, 0.2, 2.0, 0.02, ""),      // Benettin only: 1
        row("b", 0.31, 0.305, 2.0, 0.005, ""),   // B, R, JS: 3
        row("c", 0.30, 0.30, 3.0, 0.001, "esc"), // failed
        row("d", 0.32, 0.31, 2.0, 0.009, ""),    // B, R, JS: 3, larger score
    ];
    let r = rows_against(&rows, &data);
    assert_eq!(r.iter().map(|r| r.passes.iter().filter(|&&p| p).count()).collect::<Vec<_>>(), vec![1, 3, 0, 3]);
    assert!(row_score(&r[1]) < row_score(&r[3]) && row_score(&r[2]).is_infinite());
    // b: each target's error over its tolerance, summed, plus the unmet targets' penalty.
    assert!((row_score(&r[1]) - (1.0 / 3.0 + 1.0 / 3.0 + 5.0 + 0.5)).abs() < 1e-9);
    assert_eq!(pick(&r), Some(1));
    assert_eq!(pick(&r[2..3]), None);
}

/// A live re-run of the experiment-as-model rows and of every run's own statistics on the flag (skipped when the data
/// are absent): every committed number to its printed precision.
#[test]
fn flag_self_reproduces() {
    let dir = flag_dir();
    if !dir.join("traj_8.csv").is_file() {
        eprintln!("SKIPPED (needs ../shared/data): inverted-flag data not found under {}", dir.display());
        return;
    }
    let load = |k: usize| ssm::load_csv(dir.join(format!("traj_{k}.csv"))).unwrap();
    let runs: Vec<(usize, TimeSeries)> = [0, 1, 2, 3, 4, 5, 6, 7, 9].into_iter().map(|k| (k, load(k))).collect();
    let s = EvalSettings::default();
    let (ds, rows) = experiment_as_model(&[load(9), load(7)], &load(8), &runs, &s).unwrap();
    let res = res();
    let data = res.held_out.data;
    assert_eq!(ds.len, res.held_out.test_len);
    assert!(
        (ds.lle - data.rosenstein).abs() <= 5e-4
            && (ds.corr_dim - data.corr_dim).abs() <= 5e-3
            && (ds.corr_dim_err - data.corr_dim_err).abs() <= 5e-3,
        "{ds:?}"
    );
    let committed = &res.experiment.rows;
    assert_eq!(rows.len(), committed.len());
    for (a, b) in rows.iter().zip(committed) {
        assert_eq!((a.run, a.start, a.len), (b.run, b.start, b.len));
        assert!(
            close(a.rosenstein, b.rosenstein, 5e-4)
                && close(a.corr_dim, b.corr_dim, 5e-3)
                && close(a.corr_dim_err, b.corr_dim_err, 5e-3)
                && close(a.js, b.js, 5e-5),
            "{a:?} vs {b:?}"
        );
    }
    for o in &res.experiment.runs_own {
        let (k, lag, theiler, lle, d2, d2_err) = (o.run, o.lag, o.theiler, o.rosenstein, o.corr_dim, o.corr_dim_err);
        let (d, _) = data_stats(&load(k), STEP, &s).unwrap();
        assert_eq!((d.lag, d.theiler), (lag, theiler), "traj_{k}");
        assert!(
            (d.lle - lle).abs() <= 5e-4 && (d.corr_dim - d2).abs() <= 5e-3 && (d.corr_dim_err - d2_err).abs() <= 5e-3,
            "traj_{k}: {d:?}"
        );
    }
    assert!(data_stats(&load(1), STEP, &s).is_err());
}

/// The pick on the first validation run (committed rows, its own settings): the counts of rows
/// meeting each target there, the picked row's statistics there and on the test run, and the
/// test run's own pick read on the validation run.
#[test]
fn validation_pick_on_traj3() {
    use chaos_study::flag_pipeline_fit::target_counts;
    let res = res();
    let centres = &res.held_out.centres;
    let v3 = res.validation.primary().unwrap();
    assert_eq!(v3.run, 3);
    let val = v3.pipeline_rows();
    assert_eq!(val.len(), centres.len());
    assert!(val.iter().zip(centres).all(|(v, c)| v.candidate == c.candidate));
    assert_eq!(target_counts(&val), (237, 45, 27, 19, 92, 17, 1));
    assert_eq!(val.iter().filter(|r| r.passes[1]).count(), 7);
    assert_eq!(val.iter().filter(|r| r.passes[0] && r.passes[2] && r.passes[3]).count(), 1);
    let (v, t) = validation_pick(&res).unwrap().unwrap();
    assert_eq!(v.candidate, "RBF 250 r=1e-8 d=4 p=9 centres kmeans++@11");
    assert_eq!(v.passes, [true, false, true, true]);
    assert_eq!((v.benettin, v.rosenstein, v.corr_dim, v.js), (Some(0.300), Some(0.213), Some(1.96), Some(0.0067)));
    assert_eq!((t.benettin, t.rosenstein, t.corr_dim, t.js), (Some(0.287), Some(0.155), Some(1.64), Some(0.0070)));
    assert_eq!(t.passes, [false, false, false, true]);
    let test = res.held_out.centre_rows();
    let tp = &test[pick(&test).unwrap()];
    assert_eq!(tp.candidate, "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3");
    let best = val.iter().find(|r| r.candidate == "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3").unwrap();
    assert_eq!((best.rosenstein, best.corr_dim), (Some(0.167), Some(1.66)));
    // The second validation run picks another row; its statistics there and on the test run.
    let v0run = res.validation.run(0).unwrap();
    let own = |k: usize| res.experiment.own(k).unwrap().stats();
    assert_eq!((own(0), own(3)), (v0run.data, v3.data));
    let val0 = v0run.pipeline_rows();
    assert!(val0.iter().zip(centres).all(|(v, c)| v.candidate == c.candidate) && val0.len() == 237);
    assert_eq!(target_counts(&val0), (237, 38, 32, 3, 44, 16, 0));
    let (v0, t0) = validation_pick_on(v0run, &res.held_out).unwrap();
    assert_eq!(v0.candidate, "RBF 200 r=3e-9 d=4 p=9 centres random@8");
    assert_eq!(
        (v0.benettin, v0.rosenstein, v0.corr_dim, v0.js, v0.passes),
        (Some(0.495), Some(0.387), Some(2.94), Some(0.0081), [true, false, false, true])
    );
    assert_eq!(
        (t0.benettin, t0.rosenstein, t0.corr_dim, t0.js, t0.passes),
        (Some(0.495), Some(0.244), Some(2.95), Some(0.0064), [false, false, false, true])
    );
    // The same model's Rosenstein exponent on its own series started from the first validation run.
    let r3 = val.iter().find(|r| r.candidate == v0.candidate).unwrap().rosenstein;
    assert_eq!(r3, Some(0.163));
    // The ensemble's members: the best-ranked rows, the pick first.
    let m = ensemble_members(v3, 5);
    assert_eq!(m[0], v.candidate);
    assert_eq!(m.len(), 5);
}

/// The ensemble of the best validation-ranked models on the test run (committed test rows):
/// the members' mean and sd of Benettin, Rosenstein and D2, their JS, and the pooled density's
/// JS at most every member's.
#[test]
fn ensemble_statistics() {
    let res = res();
    let test = res.held_out.centre_rows();
    let ens = res.validation.ensemble;
    let rows: Vec<_> = ensemble_members(res.validation.primary().unwrap(), ens.members)
        .iter()
        .map(|n| test.iter().find(|r| r.candidate == *n).unwrap().clone())
        .collect();
    let col = |f: &dyn Fn(&PipelineRow) -> Option<f64>| {
        mean_sd(&rows.iter().filter_map(|r| f(r)).collect::<Vec<_>>()).unwrap()
    };
    let (b, r, d) = (col(&|r| r.benettin), col(&|r| r.rosenstein), col(&|r| r.corr_dim));
    println!("{b:?} {r:?} {d:?}");
    assert!((b.0 - 0.3282).abs() < 5e-5 && (b.1 - 0.0471).abs() < 5e-5, "{b:?}");
    assert!((r.0 - 0.1982).abs() < 5e-5 && (r.1 - 0.0320).abs() < 5e-5, "{r:?}");
    assert!((d.0 - 2.136).abs() < 5e-4 && (d.1 - 0.574).abs() < 5e-4, "{d:?}");
    let js: Vec<f64> = rows.iter().filter_map(|r| r.js).collect();
    assert_eq!(js, vec![0.0070, 0.0050, 0.0037, 0.0079, 0.0051]);
    assert!(js.iter().all(|&j| ens.js_pooled <= j));
}

/// Live re-runs (skipped without the data): the validation pick on the first validation run
/// gives its committed row, and the ensemble its pooled JS.
#[test]
fn validation_pick_and_ensemble_reproduce() {
    let dir = flag_dir();
    if !dir.join("traj_8.csv").is_file() {
        eprintln!("SKIPPED (needs ../shared/data): inverted-flag data not found under {}", dir.display());
        return;
    }
    let load = |k: usize| ssm::load_csv(dir.join(format!("traj_{k}.csv"))).unwrap();
    let train = [load(9), load(7)];
    let s = EvalSettings::default();
    let res = res();
    let v3 = res.validation.primary().unwrap();
    let val = load(v3.run);
    let data = data_stats(&val, STEP, &s).unwrap();
    assert!(
        (data.0.lle - v3.data.rosenstein).abs() <= 5e-4
            && (data.0.corr_dim - v3.data.corr_dim).abs() <= 5e-3
            && (data.0.corr_dim_err - v3.data.corr_dim_err).abs() <= 5e-3,
        "{:?}",
        data.0
    );
    let (v, _) = validation_pick(&res).unwrap().unwrap();
    let r = chaos_study::model_selection::evaluate_candidate(
        &train,
        &val,
        &candidate_from_name(&v.candidate).unwrap(),
        &data,
        &s,
    )
    .unwrap();
    assert!(r.failed.is_none(), "{r:?}");
    assert!(
        close(r.benettin, v.benettin, 5e-4)
            && close(r.rosenstein, v.rosenstein, 5e-4)
            && close(r.corr_dim, v.corr_dim, 5e-3)
            && close(r.js, v.js, 5e-5),
        "{r:?} vs {v:?}"
    );
    let ens = res.validation.ensemble;
    let names = ensemble_members(v3, ens.members);
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let e = ensemble(&train, &load(8), &names, &s).unwrap();
    assert!(e.failed.is_empty(), "{e:?}");
    assert!(close(e.js_pooled, Some(ens.js_pooled), 5e-5), "{e:?}");
    let test = res.held_out.centre_rows();
    for (n, j) in e.members.iter().zip(&e.js_members) {
        assert!(close(*j, test.iter().find(|r| &r.candidate == n).unwrap().js, 5e-5), "{n}: {j:?}");
    }
    let bad = ensemble(&train, &load(8), &["RBF 200 r=3e-9 d=5 p=11"], &s).unwrap_err().to_string();
    assert!(bad.contains("d = 4"), "{bad}");
}
