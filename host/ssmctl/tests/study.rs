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

/// The bundled known-system spec cut small (short estimator runs, a 60-centre RBF map and a
/// polynomial map at scale 1, one delay-embedding and one state diagnosis row), in `dir`.
fn small_known_system(dir: &Path) -> PathBuf {
    let full = std::fs::read_to_string(root().join("studies/flag-known-system.toml")).unwrap();
    let head = &full[..full.find("[statistics]").unwrap()];
    let text = format!(
        "{}{}",
        head.replace("benettin_time = 4000.0", "benettin_time = 100.0"),
        r#"[statistics]
gp_embed = 6
long_runs = 1
benettin_transient = 200
benettin_steps = 2000
region_factor = 1.5

[names]
ridge = 1e-8
dim = 4
embed = 9
shift = 1
map_order = 3
multistep_stride = 4
multistep_iterations = 10

[check]
scales = [1]
rbf = [[60, 1e-8]]
poly_ridge = 1e-8
max_matrix_entries = 100000000

[[diagnosis]]
group = "small"
scale = 1
candidates = ["RBF 40 d=4 p=9"]

[[diagnosis]]
group = "state"
scale = 1
noise_rel = 0.0
candidates = ["state poly 3"]
"#
    );
    let spec = dir.join("known.toml");
    std::fs::write(&spec, text).unwrap();
    spec
}

/// A small known-system spec runs; its file reads back as the report reads it; a second run
/// computes nothing and writes the same file; two shards merged write it byte for byte; a
/// bad key is an error naming it.
#[test]
fn known_system_spec_runs_cached_and_sharded() {
    use chaos_study::study_results::{KNOWN_SYSTEM, KnownSystemResults};
    use ssmctl::study::{SelectionRun, study_with};
    let dir = std::env::temp_dir().join(format!("ssmctl-known-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_known_system(&dir);
    let opts = SelectionRun { cache: Some(dir.join("cache")), quiet: true, ..Default::default() };
    let whole = dir.join("whole");
    let rec = study_with(&spec, &dir, &whole, &opts, false).unwrap();
    assert_eq!((rec.computed, rec.files.as_slice()), (Some(4), &[KNOWN_SYSTEM.to_string()][..]), "{rec:?}");
    let first = std::fs::read(whole.join(KNOWN_SYSTEM)).unwrap();
    let r: KnownSystemResults = read(&whole.join(KNOWN_SYSTEM)).unwrap();
    let names: Vec<&str> = r.pipeline_check.iter().map(|c| c.candidate.as_str()).collect();
    assert_eq!(names, ["RBF 60 /4 r=1e-8", "poly 3 /4"]);
    let diag: Vec<(&str, &str, f64)> =
        r.diagnosis.iter().map(|d| (d.group.as_str(), d.candidate.as_str(), d.noise_rel)).collect();
    assert_eq!(diag, [("small", "RBF 40 d=4 p=9", 0.0032057590668853656), ("state", "state poly 3", 0.0)]);
    assert!(r.data.exact > 0.5 && r.data.corr_dim > 1.0, "{:?}", r.data);
    assert_eq!(r.check_rows().len(), 2);

    let again = dir.join("again");
    assert_eq!(study_with(&spec, &dir, &again, &opts, false).unwrap().computed, Some(0));
    assert_eq!(std::fs::read(again.join(KNOWN_SYSTEM)).unwrap(), first);

    let sharded = dir.join("sharded");
    for i in 0..2 {
        let o =
            SelectionRun { shard: Some(furuta::sweep::Shard::new(i, 2).unwrap()), quiet: true, ..Default::default() };
        assert_eq!(study_with(&spec, &dir, &sharded, &o, false).unwrap().computed, Some(2));
    }
    study_with(&spec, &dir, &sharded, &SelectionRun { quiet: true, ..Default::default() }, true).unwrap();
    assert_eq!(std::fs::read(sharded.join(KNOWN_SYSTEM)).unwrap(), first);

    let text = std::fs::read_to_string(&spec).unwrap();
    std::fs::write(&spec, text.replace("poly_ridge = 1e-8", "poly_ridge = 1e-8\nridges = 2")).unwrap();
    let e = study_with(&spec, &dir, &dir.join("bad"), &opts, false).unwrap_err().to_string();
    assert!(e.contains("known.toml") && e.contains("ridges"), "{e}");
    std::fs::write(&spec, text.replace("\"state poly 3\"", "\"state poly 3 seed 2\"")).unwrap();
    let e = study_with(&spec, &dir, &dir.join("bad"), &opts, false).unwrap_err().to_string();
    assert!(e.contains("diagnosis[1]") && e.contains("seed"), "{e}");

    // Named result files: two specs write to one folder without touching each other's files.
    let named = text.replace("name = \"flag-known-system\"", "name = \"small\"\nresults = \"small_rows\"");
    assert_ne!(named, text);
    std::fs::write(
        &spec,
        named
            .replace("\"state poly 3\"", "\"state poly 3 noise seed 1\"")
            .replace("noise_rel = 0.0\ncandidates = [\"state", "candidates = [\"state"),
    )
    .unwrap();
    let rec = study_with(&spec, &dir, &whole, &opts, false).unwrap();
    assert_eq!(
        (rec.files.as_slice(), rec.record_file.as_deref()),
        (&["small_rows.json".to_string()][..], Some("small_rows.study.json"))
    );
    assert_eq!(std::fs::read(whole.join(KNOWN_SYSTEM)).unwrap(), first);
    let r: KnownSystemResults = read(&whole.join("small_rows.json")).unwrap();
    assert_eq!(r.diagnosis[1].candidate, "state poly 3 noise seed 1");
    assert!(r.diagnosis[1].noise_rel > 0.0 && whole.join("small_rows.study.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A search spec (the search grammar's names) on the Lorenz data writes the search table the
/// report reads, one row per candidate in the spec's order; a bad name is an error naming it.
#[test]
fn search_spec_writes_the_search_table() {
    use chaos_study::study_results::{SEARCH, SearchResults};
    use ssmctl::study::{SelectionRun, study_with};
    let dir = std::env::temp_dir().join(format!("ssmctl-search-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let selection = std::fs::read_to_string(lorenz_selection(&dir)).unwrap();
    let head = &selection[..selection.find("[models]").unwrap()];
    let names = ["k=1 d=3 p=7 s=1 m=3 c=40 r=1e-8", "k=2 d=3 p=7 s=1 m=3 polynomial map order 3 r=1e-8 smooth=3"];
    let spec = dir.join("search.toml");
    let text = format!(
        "{}[models]\ncandidates = [{}]\n",
        head.replace("kind = \"selection\"", "kind = \"search\""),
        names.map(|n| format!("\"{n}\"")).join(", ")
    );
    std::fs::write(&spec, &text).unwrap();
    let out = dir.join("out");
    let opts = SelectionRun { quiet: true, ..Default::default() };
    let rec = study_with(&spec, &dir, &out, &opts, false).unwrap();
    assert_eq!(rec.files, [SEARCH]);
    let r: SearchResults = read(&out.join(SEARCH)).unwrap();
    let got: Vec<&str> = r.rows.iter().map(|r| r.candidate.as_str()).collect();
    assert_eq!(got, names);
    assert!(r.rows.iter().all(|r| r.data_rosenstein > 0.0 && r.cells()[0] == r.candidate), "{r:?}");
    std::fs::write(&spec, text.replace("smooth=3", "smooth=4")).unwrap();
    let e = study_with(&spec, &dir, &out, &opts, false).unwrap_err().to_string();
    assert!(e.contains("search.toml") && e.contains("smooth=4") && e.contains("odd"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
