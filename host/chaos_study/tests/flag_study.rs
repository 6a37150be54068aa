//! The tests of `chaos_study::flag_study`.

use chaos_study::flag_study::*;
use chaos_study::study_results::ModelRow;
use std::path::Path;

const SPEC: &str = r#"
name = "t"
[data]
folder = "inverted_flag_chaotic"
file = "traj_{run}.csv"
[runs]
training = [9, 7]
test = 8
validation = [3]
experiment = [0, 1]
[statistics]
step = 4
gp_embed = 6
long_runs = 5
benettin_transient = 5000
benettin_steps = 50000
region_factor = 1.5
data_noise_seed = 7
model_noise_seed = 1
[models]
fit = []
multistep = []
centres = ["RBF 200 r=3e-9 d=4 p=9"]
dimension = ["RBF 200 r=3e-9 d=4 p=9"]
[ensemble]
members = 1
"#;

#[test]
fn spec_parses_and_names_bad_keys() {
    let s = FlagStudySpec::parse("t.toml", SPEC).unwrap();
    assert_eq!(s.all_runs(), vec![0, 1, 3, 7, 8, 9]);
    assert!(s.run_path(Path::new("d"), 3).ends_with("inverted_flag_chaotic/traj_3.csv"));
    let e = FlagStudySpec::parse("t.toml", &SPEC.replace("members = 1", "members = 1\nsize = 2")).unwrap_err();
    assert!(e.to_string().contains("t.toml") && e.to_string().contains("size"), "{e}");
    let e = FlagStudySpec::parse("t.toml", &SPEC.replace("test = 8", "test = 9")).unwrap_err();
    assert!(e.to_string().contains("training"), "{e}");
    let e =
        FlagStudySpec::parse("t.toml", &SPEC.replace("d=4 p=9\"]\n[ensemble]", "d=4 p=7\"]\n[ensemble]")).unwrap_err();
    assert!(e.to_string().contains("models.dimension"), "{e}");
    let e = FlagStudySpec::parse("t.toml", &SPEC.replace("centres = [\"RBF", "centres = [\"RBX")).unwrap_err();
    assert!(e.to_string().contains("RBX"), "{e}");
    let e = FlagStudySpec::parse("t.toml", &SPEC.replace("step = 4", "step = 2")).unwrap_err();
    assert!(e.to_string().contains("statistics.step"), "{e}");
}

#[test]
fn the_bundled_spec_lists_the_bundled_results() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
    let spec = FlagStudySpec::parse("flag.toml", &std::fs::read_to_string(dir.join("flag.toml")).unwrap()).unwrap();
    let res = chaos_study::study_results::FlagResults::bundled().unwrap();
    let names = |rows: &[ModelRow]| rows.iter().map(|r| r.candidate.clone()).collect::<Vec<_>>();
    assert_eq!(spec.models.fit, names(&res.held_out.fit));
    assert_eq!(spec.models.multistep, names(&res.held_out.multistep));
    assert_eq!(spec.models.centres, names(&res.held_out.centres));
    let dims: Vec<String> = res.held_out.dimension.iter().map(|d| d.candidate.clone()).collect();
    assert_eq!(spec.models.dimension, dims);
    assert_eq!(spec.runs.validation, res.validation.runs.iter().map(|v| v.run).collect::<Vec<_>>());
    assert_eq!(spec.ensemble.members, res.validation.ensemble.members);
    let limited = spec.limited(3);
    assert_eq!(limited.models.centres.len(), 3);
    assert!(limited.models.dimension.iter().all(|d| limited.models.centres.contains(d)));
}
