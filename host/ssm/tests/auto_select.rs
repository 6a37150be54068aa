//! `ssm::auto`: settings chosen by cross-validation against an exhaustive grid over the same
//! options (the 1.2x test), determinism across thread counts, and named errors on bad input.
//! The full default grid is the example `auto_grid` (slow); here smaller grids.

use ssm::auto::{AutoError, AutoGrid, AutoOptions, exhaustive, select};
use ssm::{DataError, MultiSeries, load_csv_observables};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
/// Exact linear eigenvalue of the Duffing data (`tests/data/make_mat.py`: w = 2 pi, zeta = 0.02).
const W: f64 = std::f64::consts::TAU;
const ZETA: f64 = 0.02;

fn duffing_x() -> Vec<MultiSeries> {
    (1..=3)
        .map(|i| load_csv_observables(format!("{DATA}/duffing_{i}.csv"), Some(&["x".to_string()])).unwrap())
        .collect()
}

fn sloshing() -> Option<Vec<MultiSeries>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sloshing");
    if !dir.is_dir() {
        eprintln!("skipped: {} not found (the shared data folder is absent)", dir.display());
        return None;
    }
    Some((0..3).map(|i| load_csv_observables(dir.join(format!("decay_{i}.csv")), None).unwrap()).collect())
}

/// A grid of two values per knob (128 settings): small enough for the exhaustive search in
/// the suite.
fn small_grid() -> AutoGrid {
    AutoGrid {
        cuts: vec![0.0, 0.1],
        embed_extra: vec![0, 2],
        shifts: vec![1, 2],
        manifold_orders: vec![3, 1],
        dyn_orders: vec![5, 3],
        ridges: vec![0.0, 1e-6],
        anchors: vec![None, Some(0.2)],
    }
}

fn eig_error(train: &[MultiSeries], s: &ssm::auto::Setting) -> f64 {
    let m = ssm::fit_multi(&ssm::auto::cut(train, s.cut), &s.options).unwrap();
    let exact = (-ZETA * W, W * (1.0 - ZETA * ZETA).sqrt());
    m.eigenvalues_ct()
        .iter()
        .map(|e| (e.0 - exact.0).hypot(e.1.abs() - exact.1) / exact.1.hypot(exact.0))
        .fold(0.0, f64::max)
}

/// Auto's held-out NMTE within 1.2x of the best of the exhaustive grid over the same options,
/// and (Duffing, exact eigenvalue known) its eigenvalue error within 1.2x of the grid
/// winner's, on the Duffing CSVs and the sloshing decays.
#[test]
fn auto_is_within_1_2x_of_the_exhaustive_grid() {
    let mut sets = vec![("duffing", duffing_x())];
    if let Some(s) = sloshing() {
        sets.push(("sloshing", s));
    }
    for (name, train) in sets {
        let o = AutoOptions { grid: small_grid(), budget: 40, ..Default::default() };
        let auto = select(&train, &o).unwrap();
        let (all, at) = exhaustive(&train, &o).unwrap();
        let grid_best = &all[at];
        let min_nmte = all.iter().map(|s| s.nmte).fold(f64::INFINITY, f64::min);
        eprintln!(
            "{name}: auto {} (score {:.5}, NMTE {:.5}, {} settings) | grid winner {} (score {:.5}, NMTE {:.5}) | grid min NMTE {:.5} of {} settings",
            auto.best.setting.describe(),
            auto.best.score,
            auto.best.nmte,
            auto.evaluated,
            grid_best.setting.describe(),
            grid_best.score,
            grid_best.nmte,
            min_nmte,
            all.len()
        );
        assert!(auto.evaluated <= 40);
        assert!(auto.best.score <= 1.2 * grid_best.score, "{name}: score {} vs {}", auto.best.score, grid_best.score);
        assert!(auto.best.nmte <= 1.2 * min_nmte, "{name}: NMTE {} vs grid best {}", auto.best.nmte, min_nmte);
        if name == "duffing" {
            let (ea, eg) = (eig_error(&train, &auto.best.setting), eig_error(&train, &grid_best.setting));
            eprintln!("{name}: eigenvalue error auto {ea:.3e}, grid winner {eg:.3e}");
            assert!(ea <= 1.2 * eg.max(1e-4), "{name}: eigenvalue error {ea} vs grid winner {eg}");
        }
    }
}

/// The same data give the same choice on one thread and on several.
#[test]
fn selection_is_the_same_for_any_thread_count() {
    let train = duffing_x();
    let o = AutoOptions { grid: small_grid(), budget: 24, ..Default::default() };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let c = pool.install(|| select(&train, &o)).unwrap();
        serde_json::to_string(&c).unwrap()
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one, run(2));
}

/// The dimension of the Duffing and sloshing data is 2 (one oscillatory mode) by the
/// singular-value gap.
#[test]
fn dimension_from_the_singular_values() {
    let d = ssm::auto::choose_dim(&duffing_x(), 4).unwrap();
    assert_eq!(d.dim, 2, "{d:?}");
    if let Some(s) = sloshing() {
        let d = ssm::auto::choose_dim(&s, 4).unwrap();
        assert_eq!(d.dim, 2, "{d:?}");
    }
}

fn series(name: &str, x: Vec<f64>) -> MultiSeries {
    let t = (0..x.len()).map(|i| i as f64 * 0.02).collect();
    MultiSeries { name: name.into(), t, observables: vec!["x".into()], x }
}

/// Too little data for the folds, a single short trajectory, constant or NaN data: named
/// errors, never a fallback.
#[test]
fn bad_input_is_a_named_error() {
    let o = AutoOptions::default();
    let osc = |n: usize| (0..n).map(|i| (i as f64 * 0.3).sin() * (-0.01 * i as f64).exp()).collect::<Vec<_>>();
    // One short trajectory: too short for three blocks with the grid's largest embedding.
    let e = select(&[series("short", osc(120))], &o).unwrap_err();
    assert!(matches!(e, AutoError::TooLittleData { .. }), "{e}");
    assert!(e.to_string().contains("short block 1 of 3"), "{e}");
    // Two trajectories, one too short to be held out.
    let e = select(&[series("long", osc(2000)), series("tiny", osc(60))], &o).unwrap_err();
    assert!(e.to_string().contains("tiny"), "{e}");
    // A single trajectory cannot be split into one block.
    let e = select(&[series("one", osc(2000))], &AutoOptions { blocks: 1, ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("blocks"), "{e}");
    // Constant and NaN data.
    let e = select(&[series("flat", vec![1.5; 500])], &o).unwrap_err();
    assert!(matches!(e, AutoError::Data(DataError::ConstantObservable { .. } | DataError::Constant { .. })), "{e}");
    let mut x = osc(500);
    x[77] = f64::NAN;
    let e = select(&[series("holey", x)], &o).unwrap_err();
    assert!(matches!(e, AutoError::Data(DataError::NonFinite { .. })), "{e}");
    assert!(e.to_string().contains("holey"), "{e}");
    // Options.
    let e = select(&duffing_x(), &AutoOptions { budget: 0, ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("budget"), "{e}");
    let e = select(&duffing_x(), &AutoOptions { dynamics: ssm::Dynamics::Rbf { centers: 5 }, ..Default::default() })
        .unwrap_err();
    assert!(e.to_string().contains("dynamics"), "{e}");
    let e = select(
        &duffing_x(),
        &AutoOptions { grid: AutoGrid { cuts: vec![0.7], ..Default::default() }, ..Default::default() },
    )
    .unwrap_err();
    assert!(e.to_string().contains("grid.cuts"), "{e}");
    // The bootstrap of a single short trajectory.
    let s = ssm::auto::Setting {
        cut: 0.0,
        options: select(&duffing_x(), &AutoOptions { budget: 1, ..Default::default() }).unwrap().best.setting.options,
    };
    let e = ssm::auto::intervals(&[series("lone", osc(100))], &s, &Default::default()).unwrap_err();
    assert!(matches!(e, AutoError::TooLittleData { .. }), "{e}");
}
