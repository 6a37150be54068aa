//! The tests of `chaos_study::selection_study`.

use chaos_study::flag_study::FlagStudySpec;
use chaos_study::selection_study::*;
use std::path::Path;

const SPEC: &str = r#"
kind = "selection"
name = "t"
[data]
training = ["a.csv"]
test = "b.csv"
[statistics]
gp_embed = 6
long_runs = 5
benettin_transient = 5000
benettin_steps = 50000
region_factor = 1.5
[models]
candidates = ["RBF 200 r=3e-9 d=4 p=9", "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2"]
"#;

#[test]
fn spec_parses_and_names_bad_keys() {
    let s = SelectionSpec::parse("t.toml", SPEC).unwrap();
    assert_eq!(spec_kind("t.toml", SPEC).unwrap().as_deref(), Some(KIND));
    assert_eq!(s.candidates().unwrap().len(), 2);
    let bad = |from: &str, to: &str, want: &str| {
        let e = SelectionSpec::parse("t.toml", &SPEC.replace(from, to)).unwrap_err().to_string();
        assert!(e.contains("t.toml") && e.contains(want), "{e}");
    };
    bad("region_factor = 1.5", "region_factor = 1.5\nextra = 1", "extra");
    bad("kind = \"selection\"", "kind = \"sweep\"", "kind");
    bad("test = \"b.csv\"", "test = \"a.csv\"", "data.test");
    bad("\"RBF 200", "\"RBX 200", "RBX");
    bad("gp_embed = 6", "gp_embed = 0", "gp_embed");
    bad("[models]\n", "[models]\ndim = 0\n", "models.dim");
    assert!(spec_kind("f.toml", "name = \"flag\"").unwrap().is_none());
}

#[test]
fn dimension_and_budget_of_the_default_search() {
    assert_eq!(with_dim("RBF 200 r=3e-9 d=4 p=9 centres random@3", 6), "RBF 200 r=3e-9 d=6 p=13 centres random@3");
    let s = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 5, Some(3)).unwrap();
    assert_eq!(s.models.candidates.len(), 5);
    let c = s.candidates().unwrap();
    assert!(c.iter().all(|c| c.fit.dim == 3 && c.fit.embed == 7), "{c:?}");
    let e = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 0, None).unwrap_err();
    assert!(e.to_string().contains("budget"), "{e}");
    let e = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 10_000, None).unwrap_err();
    assert!(e.to_string().contains("budget"), "{e}");
}

/// The bundled specs parse; the full flag search is the flag study's centre-set list.
#[test]
fn bundled_selection_specs_parse() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap();
    let search = SelectionSpec::parse("flag-search.toml", &read("flag-search.toml")).unwrap();
    let flag = FlagStudySpec::parse("flag.toml", &read("flag.toml")).unwrap();
    assert_eq!(search.models.candidates, flag.models.centres);
    assert_eq!(search.statistics.benettin_steps, flag.statistics.benettin_steps);
    let furuta = SelectionSpec::parse("furuta-chaos.toml", &read("furuta-chaos.toml")).unwrap();
    assert_eq!(furuta.data.simulated.as_ref().unwrap().theta0.len(), 3);
    assert!(furuta.models.candidates.is_empty() && furuta.models.standard.is_some());
    let e = SelectionSpec::parse(
        "f.toml",
        &read("furuta-chaos.toml").replace("theta0 = [0.02, 0.035, 0.05]", "theta0 = [0.02]"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("data.simulated.theta0"), "{e}");
    let e =
        SelectionSpec::parse("f.toml", &read("furuta-chaos.toml").replace("steps = [1]", "steps = [0]")).unwrap_err();
    assert!(e.to_string().contains("models.standard.steps"), "{e}");
}

/// The Furuta spec's machinery on short runs: simulated runs (the last held out), the
/// standard candidates at the rule's dimension, each measured, one picked.
#[test]
fn simulated_runs_and_standard_candidates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
    let mut spec =
        SelectionSpec::parse("furuta-chaos.toml", &std::fs::read_to_string(dir.join("furuta-chaos.toml")).unwrap())
            .unwrap();
    spec.data.simulated.as_mut().unwrap().periods = 3000;
    spec.models.standard.as_mut().unwrap().centers = 60;
    spec.statistics.benettin_transient = 200;
    spec.statistics.benettin_steps = 2000;
    spec.statistics.long_runs = 1;
    let p = prepare(&spec, Path::new("unused")).unwrap();
    assert_eq!(p.train.len(), 2);
    assert!(p.held_out && p.test.name == "furuta-quant-dt25 #2", "{}", p.test.name);
    let names: Vec<&str> = p.candidates.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["RBF 60 /1", "poly 4 /1"]);
    assert_eq!(p.data.len(), 1);
    let rows: Vec<serde_json::Value> =
        (0..p.candidates.len()).map(|i| result_json(&evaluate(&p, i).unwrap()).unwrap()).collect();
    let r = finish(&spec, &p, rows.clone()).unwrap();
    assert_eq!(r.candidates, rows);
    assert_eq!(r.training, ["furuta-quant-dt25 #0", "furuta-quant-dt25 #1"]);
    assert!(r.selection.name.is_some() || r.selection.why.contains("failed"), "{:?}", r.selection);
    let e = finish(&spec, &p, rows[..1].to_vec()).unwrap_err();
    assert!(e.to_string().contains("1 results for 2 candidates"), "{e}");
}
