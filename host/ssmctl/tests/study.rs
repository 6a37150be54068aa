//! `ssmctl study` recomputes the bundled results: a spec cut to one centre-set candidate,
//! one validation run and two experiment runs is run on the flag data, and every value it
//! writes equals the bundled `studies/results/flag` value to the precision the files carry
//! (one unit of the last decimal). Needs `../shared/data`; without it the test says so
//! loudly on stderr and checks only the spec's errors.

use std::path::{Path, PathBuf};

use chaos_study::study_results::{
    EXPERIMENT, ExperimentResults, FlagResults, HELD_OUT, HeldOutResults, VALIDATION, ValidationResults, read,
};

const CANDIDATE: &str = "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn small_spec() -> String {
    let full = std::fs::read_to_string(root().join("studies/flag.toml")).unwrap();
    let models = full.find("[models]").unwrap();
    let ensemble = full.find("[ensemble]").unwrap();
    let head = full[..models]
        .replace("validation = [3, 0]", "validation = [3]")
        .replace("experiment = [0, 1, 2, 3, 4, 5, 6, 7, 9]", "experiment = [0, 1]");
    format!(
        "{head}[models]\nfit = []\nmultistep = []\ncentres = [\"{CANDIDATE}\"]\ndimension = [\"{CANDIDATE}\"]\n\n{}",
        full[ensemble..].replace("members = 5", "members = 1")
    )
}

/// `a` equals `b` to `decimals` decimals (one unit of the last one).
fn close(a: Option<f64>, b: Option<f64>, decimals: i32) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() <= 10f64.powi(-decimals) + 1e-12,
        (None, None) => true,
        _ => false,
    }
}

#[test]
fn study_recomputes_the_bundled_rows() {
    let data_dir = root().join("../shared/data");
    let dir = std::env::temp_dir().join(format!("ssmctl-study-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("small.toml");
    std::fs::write(&spec, small_spec()).unwrap();
    let out = dir.join("out");

    // A spec whose data are absent is an error naming the file.
    let e = ssmctl::study::study(&spec, &dir.join("nowhere"), &out, None, true).unwrap_err().to_string();
    assert!(e.contains("traj_") && e.contains("not found") && e.contains("--data-dir"), "{e}");

    if !data_dir.join("inverted_flag_chaotic/traj_8.csv").is_file() {
        eprintln!(
            "SKIPPED study_recomputes_the_bundled_rows (needs ../shared/data): no flag data under {}",
            data_dir.display()
        );
        return;
    }
    let rec = ssmctl::study::study(&spec, &data_dir, &out, None, true).unwrap();
    assert_eq!(rec.data.len(), 6);
    assert!(rec.data.iter().all(|d| d.crc64.len() == 16 && d.bytes > 0), "{:?}", rec.data);
    let bundled = FlagResults::bundled().unwrap();

    let h: HeldOutResults = read(&out.join(HELD_OUT)).unwrap();
    let b = &bundled.held_out;
    assert_eq!((h.test_run.as_str(), h.test_len, h.data), (b.test_run.as_str(), b.test_len, b.data));
    let (row, want) = (&h.centres[0], b.centres.iter().find(|r| r.candidate == CANDIDATE).unwrap());
    assert!(row.failed.is_none(), "{row:?}");
    assert!(
        close(row.benettin, want.benettin, 3)
            && close(row.rosenstein, want.rosenstein, 3)
            && close(row.corr_dim, want.corr_dim, 2)
            && close(row.js, want.js, 4),
        "{row:?} vs {want:?}"
    );
    let (dim, want) = (&h.dimension[0], b.dimension.iter().find(|d| d.candidate == CANDIDATE).unwrap());
    assert!(close(dim.kaplan_yorke, want.kaplan_yorke, 2), "{dim:?} vs {want:?}");
    assert!(
        dim.corr_dim_pieces.iter().zip(&want.corr_dim_pieces).all(|(a, b)| close(*a, *b, 2)),
        "{dim:?} vs {want:?}"
    );
    for r in &h.corr_dim_runs {
        assert!(close(r.corr_dim, b.corr_dim_of_run(r.run), 2), "run {}: {r:?}", r.run);
    }
    let (s, w) = (h.corr_dim_smoothed, b.corr_dim_smoothed);
    assert!(
        close(Some(s.smoothed_3), Some(w.smoothed_3), 2)
            && close(Some(s.smoothed_5), Some(w.smoothed_5), 2)
            && close(Some(s.noise_added), Some(w.noise_added), 2),
        "{s:?} vs {w:?}"
    );

    let e: ExperimentResults = read(&out.join(EXPERIMENT)).unwrap();
    assert_eq!(e.rows.len(), 2);
    for r in &e.rows {
        let w = bundled.experiment.rows.iter().find(|q| (q.run, q.start, q.len) == (r.run, r.start, r.len)).unwrap();
        assert!(
            close(r.rosenstein, w.rosenstein, 3)
                && close(r.corr_dim, w.corr_dim, 2)
                && close(r.corr_dim_err, w.corr_dim_err, 2)
                && close(r.js, w.js, 4),
            "{r:?} vs {w:?}"
        );
    }
    // Run 1 has no scaling range: left out of the own-settings rows, as in the bundled file.
    assert_eq!(e.runs_own.iter().map(|r| r.run).collect::<Vec<_>>(), vec![0, 8]);
    for r in &e.runs_own {
        let w = bundled.experiment.own(r.run).unwrap();
        assert_eq!((r.lag, r.theiler), (w.lag, w.theiler), "run {}", r.run);
        assert!(close(Some(r.rosenstein), Some(w.rosenstein), 3) && close(Some(r.corr_dim), Some(w.corr_dim), 2));
    }

    let v: ValidationResults = read(&out.join(VALIDATION)).unwrap();
    let (run, want) = (&v.runs[0], bundled.validation.run(3).unwrap());
    assert_eq!((run.run, run.data), (3, want.data));
    let (row, w) = (&run.rows[0], want.rows.iter().find(|r| r.candidate == CANDIDATE).unwrap());
    assert!(
        close(row.benettin, w.benettin, 3)
            && close(row.rosenstein, w.rosenstein, 3)
            && close(row.corr_dim, w.corr_dim, 2)
            && close(row.js, w.js, 4),
        "{row:?} vs {w:?}"
    );
    // One member: the pooled density is the member's own long run.
    assert_eq!(v.ensemble.members, 1);
    assert!(close(Some(v.ensemble.js_pooled), h.centres[0].js, 4), "{:?}", v.ensemble);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A selection spec on Lorenz data (x, sampled every 5 ms; two training runs and a test run
/// from other starts) with four small candidates and short estimator runs, in `dir`.
fn lorenz_selection(dir: &Path) -> PathBuf {
    let lorenz = chaos::reference::Lorenz::default();
    for (k, transient) in [(0, 2_000), (1, 9_000), (2, 17_000)] {
        let o = lorenz.orbit(6_000, 0.005, 1, transient);
        let mut csv = String::from("t_s,x\n");
        for (i, s) in o.iter().enumerate() {
            csv += &format!("{},{}\n", i as f64 * 0.005, s[0]);
        }
        std::fs::write(dir.join(format!("lorenz_{k}.csv")), csv).unwrap();
    }
    let spec = dir.join("lorenz.toml");
    std::fs::write(
        &spec,
        r#"kind = "selection"
name = "lorenz"
[data]
training = ["lorenz_0.csv", "lorenz_1.csv"]
test = "lorenz_2.csv"
[statistics]
gp_embed = 4
long_runs = 2
benettin_transient = 200
benettin_steps = 2000
region_factor = 1.5
[models]
candidates = [
    "RBF 40 r=1e-8 d=3 p=7",
    "RBF 60 r=1e-8 d=3 p=7 centres random@1",
    "RBF 40 r=1e-6 d=3 p=7 centres kmeans++@1",
    "RBF 60 r=1e-8 d=3 p=7 centres farthest@2",
]
"#,
    )
    .unwrap();
    spec
}

/// A selection spec run whole with a cache, again (nothing computed, the same file), and in
/// three shards merged (the same file, byte for byte); a merge with a shard missing or of
/// another spec is refused, naming what is wrong.
#[test]
fn selection_spec_shards_merge_and_cache() {
    use ssmctl::study::{SELECTION_FILE, SelectionRun, study_with};
    let dir = std::env::temp_dir().join(format!("ssmctl-selection-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let spec = lorenz_selection(&dir);
    let cache = dir.join("cache");
    let whole = dir.join("whole");
    let opts = SelectionRun { cache: Some(cache.clone()), quiet: true, ..Default::default() };
    let rec = study_with(&spec, &dir, &whole, &opts, false).unwrap();
    assert_eq!((rec.computed, rec.data.len()), (Some(4), 3), "{rec:?}");
    let first = std::fs::read(whole.join(SELECTION_FILE)).unwrap();
    let v: serde_json::Value = serde_json::from_slice(&first).unwrap();
    assert_eq!(v["candidates"].as_array().unwrap().len(), 4);
    assert!(v["held_out"].as_bool().unwrap() && v["test"].as_str().unwrap().starts_with("lorenz_2"), "{v}");
    assert!(v["candidates"][0].get("seconds").is_none());

    let again = dir.join("again");
    let rec = study_with(&spec, &dir, &again, &opts, false).unwrap();
    assert_eq!(rec.computed, Some(0));
    assert_eq!(std::fs::read(again.join(SELECTION_FILE)).unwrap(), first);

    // Three shards without the cache, then the merge.
    let sharded = dir.join("sharded");
    for i in 0..3 {
        let o =
            SelectionRun { shard: Some(furuta::sweep::Shard::new(i, 3).unwrap()), quiet: true, ..Default::default() };
        let rec = study_with(&spec, &dir, &sharded, &o, false).unwrap();
        assert_eq!(rec.computed, Some(if i == 0 { 2 } else { 1 }));
    }
    let shard1 = sharded.join("selection-shard-1-of-3.json");
    let shard1_text = std::fs::read(&shard1).unwrap();
    let merged = study_with(&spec, &dir, &sharded, &SelectionRun { quiet: true, ..Default::default() }, true).unwrap();
    assert_eq!(merged.computed, Some(0));
    assert_eq!(std::fs::read(sharded.join(SELECTION_FILE)).unwrap(), first);

    let merge = |d: &Path| {
        study_with(&spec, &dir, d, &SelectionRun { quiet: true, ..Default::default() }, true).unwrap_err().to_string()
    };
    std::fs::remove_file(&shard1).unwrap();
    let e = merge(&sharded);
    assert!(e.contains("candidates [1]") && e.contains("no shard file"), "{e}");
    // A shard of a spec cut to two candidates is of another spec.
    let o = SelectionRun {
        shard: Some(furuta::sweep::Shard::new(1, 3).unwrap()),
        limit: Some(2),
        quiet: true,
        ..Default::default()
    };
    study_with(&spec, &dir, &sharded, &o, false).unwrap();
    let e = merge(&sharded);
    assert!(e.contains("selection-shard-1-of-3.json") && e.contains("another spec"), "{e}");
    std::fs::write(&shard1, shard1_text).unwrap();
    assert!(merge(&dir.join("empty")).contains("no selection-shard-*.json files to merge"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `ssmctl chaos` on the flag's traj_9 alone (nothing held out) with its default search
/// picks a chaotic model: its own exponent positive and above twice its error, no warning.
/// Needs `../shared/data`; without it the test says so loudly.
#[test]
fn chaos_default_search_picks_a_chaotic_model_on_traj_9() {
    let traj = root().join("../shared/data/inverted_flag_chaotic/traj_9.csv");
    if !traj.is_file() {
        eprintln!(
            "SKIPPED chaos_default_search_picks_a_chaotic_model_on_traj_9 (needs ../shared/data): no {}",
            traj.display()
        );
        return;
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ssmctl"))
        .args(["chaos", "--data", traj.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cands = v["candidates"].as_array().unwrap();
    assert_eq!(cands.len(), ssmctl::cli::DEFAULT_CHAOS_BUDGET as usize);
    let sel = &v["selection"];
    let i = sel["index"].as_u64().unwrap() as usize;
    let (b, e) = (cands[i]["benettin"].as_f64().unwrap(), cands[i]["benettin_err"].as_f64().unwrap());
    assert!(b > 0.0 && b > 2.0 * e, "picked {}: Benettin {b} +- {e}", sel["name"]);
    assert!(sel["warnings"].as_array().unwrap().is_empty(), "{sel}");
}
