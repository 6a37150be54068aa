//! The tests of `chaos_study::known_system_study`.

use chaos_study::flag_pipeline::FlagLayout;
use chaos_study::flag_pipeline_fit::{Coords, StateFit, state_model_row};
use chaos_study::known_system_study::*;
use chaos_study::model_selection::EvalSettings;
use ssm::multistep::MultiStep;

const D: NameDefaults = NameDefaults {
    ridge: 3e-9,
    dim: 4,
    embed: 9,
    shift: 1,
    map_order: 4,
    multistep_stride: 4,
    multistep_iterations: 10,
};

#[test]
fn names_parse_with_defaults() {
    let (m, seed, _) = parse_name("RBF 250 r=1e-8 d=6 p=13 ms h=4 stride 8 it 4 seed 2", 4, &D).unwrap();
    let Model::Embedded(c) = m else { panic!() };
    assert_eq!((c.fit.dim, c.fit.embed, c.fit.shift, c.step, seed), (6, 13, 1, 4, 2));
    assert_eq!(c.multistep, Some(MultiStep { horizon: 4, stride: 8, iterations: 4 }));
    let (m, _, _) = parse_name("RBF 200 r=3e-9 d=4 p=9 denoised 5 ms h=8", 4, &D).unwrap();
    let Model::Embedded(c) = m else { panic!() };
    assert_eq!((c.denoise_inputs, c.multistep.unwrap().iterations), (2, 10));
    let (m, _, _) = parse_name("poly 4 d=5 p=11", 4, &D).unwrap();
    let Model::Embedded(c) = m else { panic!() };
    assert_eq!((c.fit.dynamics, c.fit.dyn_order), (ssm::Dynamics::Map, 4));
    let (m, _, noisy) = parse_name("state RBF 200 r=3e-9 noise", 4, &D).unwrap();
    assert!(noisy && matches!(m, Model::Coords(StateFit { coords: Coords::State, centers: 200, .. })));
    let (m, _, _) = parse_name("delay 9 x 1 poly 4", 4, &D).unwrap();
    assert!(matches!(m, Model::Coords(StateFit { coords: Coords::Delay { embed: 9, shift: 1 }, centers: 0, .. })));
    for (bad, want) in [
        ("RBX 200", "expected `RBF C`"),
        ("RBF 200 q=3", "q=3"),
        ("RBF 200 denoised 4", "odd"),
        ("state RBF 200 seed 1", "seed 1"),
        ("RBF 200 noise", "noise"),
        ("delay 9 x 1 poly 4 noise", "noise"),
        ("delay 9 x 1 poly 4 seed 1", "seed 1"),
        ("state RBF 200 noise seed", "`seed` needs"),
        ("state RBF 200 noise seed -1", "seed -1 is not a count"),
        ("state RBF 200 noise seed 1.5", "seed 1.5 is not a count"),
        ("state RBF 200 noise seed x", "`x` is not a number"),
    ] {
        let e = parse_name(bad, 4, &D).unwrap_err();
        assert!(e.contains(bad) && e.contains(want), "{e}");
    }
}

/// `seed N` on a `state ... noise` candidate picks the noise's realization: seed 0 is the
/// name without a seed, model for model and series for series; seed 1 is another noise on
/// the same state.
#[test]
fn state_noise_seed_picks_the_realization() {
    let (m, seed, noisy) = parse_name("state RBF 200 r=3e-9 noise seed 3", 4, &D).unwrap();
    let Model::Coords(f) = m else { panic!() };
    assert_eq!((f.noise_seed, seed, noisy), (3, 3, true));
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies/flag-noise-realizations.toml"),
    )
    .unwrap();
    let head = &text[..text.find("[[diagnosis]]").unwrap()];
    let names = ["state poly 2 r=1e-8 noise", "state poly 2 r=1e-8 noise seed 0", "state poly 2 r=1e-8 noise seed 1"];
    let list = names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
    let t = format!("{head}[[diagnosis]]\ngroup = \"g\"\nscale = 1\ncandidates = [{list}]\n");
    let s = KnownSystemSpec::parse("s.toml", &t).unwrap();
    assert!(s.check.is_none());
    let units = s.units().unwrap();
    let fit = |u: &Unit| match &u.model {
        Model::Coords(f) => *f,
        m => panic!("{m:?}"),
    };
    let (f0, f00, f1) = (fit(&units[0]), fit(&units[1]), fit(&units[2]));
    assert_eq!((f0.noise_seed, f00.noise_seed, f1.noise_seed), (0, 0, 1));
    assert_eq!(serde_json::to_string(&f0).unwrap(), serde_json::to_string(&f00).unwrap());
    // Every row is judged on the layout's observed series, realization 0.
    assert!(units.iter().all(|u| u.series == s.reference_series()), "{units:?}");
    // Short estimator runs: the fits and their rows, not the study's values.
    let small = KnownSystemSpec {
        benettin_time: 100.0,
        statistics: EvalSettings { benettin_transient: 100, benettin_steps: 1000, long_runs: 1, ..s.statistics },
        ..s.clone()
    };
    let data = series_data(&small, small.reference_series()).unwrap();
    let row = |f: &StateFit| {
        let layout = FlagLayout { noise_rel: small.layout.noise_rel, ..small.layout };
        state_model_row(&small.system, &layout, 1, f, &data.stats, &data.series, &small.statistics).unwrap()
    };
    let (r0, r00, r1) = (row(&f0), row(&f00), row(&f1));
    let values = |r: &chaos_study::flag_pipeline::PipelineRow| (r.benettin, r.rosenstein, r.corr_dim, r.js);
    assert_eq!(format!("{:?}", values(&r0)), format!("{:?}", values(&r00)));
    assert_ne!(format!("{:?}", values(&r0)), format!("{:?}", values(&r1)));
    let e: Vec<UnitRow> = units.iter().map(|u| evaluate(&small, u, &data).unwrap()).collect();
    assert_eq!(e[0], e[1]);
    assert_ne!(e[0], e[2]);
}

/// A spec without [check] and without diagnosis candidates has nothing to compute; a bad
/// `results` stem is named.
#[test]
fn empty_specs_and_bad_result_stems_are_errors() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies/flag-noise-realizations.toml"),
    )
    .unwrap();
    let spec = KnownSystemSpec::parse("n.toml", &text).unwrap();
    assert_eq!(spec.units().unwrap().len(), 24);
    let files = spec.files();
    assert_eq!(
        (files.results.as_str(), files.record.as_str()),
        ("noise_realizations.json", "noise_realizations.study.json")
    );
    assert_ne!(files, ResultFiles::default());
    let empty = text[..text.find("[[diagnosis]]").unwrap()].to_string();
    let e = KnownSystemSpec::parse("n.toml", &empty).unwrap_err().to_string();
    assert!(e.contains("n.toml") && e.contains("nothing to compute"), "{e}");
    for stem in ["\"\"", "\"../x\"", "\"study\""] {
        let t = text.replace("results = \"noise_realizations\"", &format!("results = {stem}"));
        let e = KnownSystemSpec::parse("n.toml", &t).unwrap_err().to_string();
        assert!(e.contains("n.toml") && e.contains("results ="), "{e}");
    }
}

/// The committed noise-realization rows are the bundled spec's, written by it, and their
/// realization 0 is the committed known-system file's noisy-state rows, value for value.
#[test]
fn noise_realizations_extend_the_known_system_rows() {
    use chaos_study::study_results::{KnownSystemResults, default_dir, read};
    let studies = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
    let text = std::fs::read_to_string(studies.join("flag-noise-realizations.toml")).unwrap();
    let spec = KnownSystemSpec::parse("flag-noise-realizations.toml", &text).unwrap();
    let files = spec.files();
    assert_eq!(files.results, chaos_study::study_results::NOISE_REALIZATIONS);
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(default_dir().join(&files.record)).unwrap()).unwrap();
    assert_eq!(record["spec"].as_str(), Some(text.as_str()), "{} is not this spec's run", files.record);
    let noisy: KnownSystemResults = read(&default_dir().join(&files.results)).unwrap();
    let known = chaos_study::study_results::FlagResults::bundled().unwrap().known;
    assert_eq!(noisy.data, known.data);
    let names: Vec<&str> = noisy.diagnosis.iter().map(|r| r.candidate.as_str()).collect();
    let want: Vec<String> = spec.units().unwrap().into_iter().map(|u| u.name).collect();
    assert_eq!(names, want);
    let mut matched = 0;
    for r in &noisy.diagnosis {
        let Some(base) = r.candidate.strip_suffix(" seed 0") else { continue };
        let k = known.diagnosis.iter().find(|k| k.candidate == base).unwrap_or_else(|| panic!("{base}"));
        assert_eq!(chaos_study::study_results::DiagRow { candidate: base.to_string(), ..r.clone() }, *k);
        matched += 1;
    }
    assert_eq!(matched, 3);
}

/// The bundled spec's rows are the committed file's, in its order (names, scales, noise).
#[test]
fn bundled_spec_lists_the_committed_rows() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
    let text = std::fs::read_to_string(dir.join("flag-known-system.toml")).unwrap();
    let spec = KnownSystemSpec::parse("flag-known-system.toml", &text).unwrap();
    let units = spec.units().unwrap();
    let known = chaos_study::study_results::FlagResults::bundled().unwrap().known;
    let check: Vec<(String, usize)> =
        units.iter().filter(|u| u.group.is_none()).map(|u| (u.name.clone(), u.scale)).collect();
    let want: Vec<(String, usize)> = known.pipeline_check.iter().map(|r| (r.candidate.clone(), r.scale)).collect();
    assert_eq!(check, want);
    let diag: Vec<(String, String, usize, f64)> = units
        .iter()
        .filter_map(|u| u.group.as_ref().map(|g| (g.clone(), u.name.clone(), u.scale, u.noise_rel)))
        .collect();
    let want: Vec<(String, String, usize, f64)> =
        known.diagnosis.iter().map(|r| (r.group.clone(), r.candidate.clone(), r.scale, r.noise_rel)).collect();
    assert_eq!(diag, want);
    let bad = |from: &str, to: &str, key: &str| {
        let e = KnownSystemSpec::parse("k.toml", &text.replace(from, to)).unwrap_err().to_string();
        assert!(e.contains("k.toml") && e.contains(key), "{e}");
    };
    bad("poly_ridge = 1e-8", "poly_ridge = 1e-8\nextra = 1", "extra");
    bad("scales = [1, 3, 10]", "scales = [0]", "check.scales");
    bad("\"state poly 4 noise\"", "\"state poly 4\"", "noise");
    bad("gp_embed = 6", "gp_embed = 0", "gp_embed");
}
