//! The tests of `chaos_study::study_results`.

use chaos_study::study_results::*;
use std::path::PathBuf;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("furuta-study-results-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn bundled_results_load_and_agree() {
    let r = FlagResults::bundled().unwrap();
    assert_eq!(r.validation.primary().unwrap().run, 3);
    assert_eq!(r.validation.run(0).unwrap().rows.len(), r.held_out.centres.len());
}

#[test]
fn errors_name_the_file_and_the_key() {
    let p = tmp("stats.json", r#"{"rosenstein": 0.3, "corr_dim": "x", "corr_dim_err": 0.1}"#);
    let e = read::<RunStats>(&p).unwrap_err().to_string();
    assert!(e.contains("stats.json") && e.contains("corr_dim"), "{e}");
    let p = tmp("extra.json", r#"{"rosenstein": 0.3, "corr_dim": 1.0, "corr_dim_err": 0.1, "lag": 3}"#);
    let e = read::<RunStats>(&p).unwrap_err().to_string();
    assert!(e.contains("extra.json") && e.contains("lag"), "{e}");
    let e = read::<RunStats>(&p.with_file_name("absent.json")).unwrap_err().to_string();
    assert!(e.contains("absent.json") && e.contains("ssmctl study"), "{e}");
}

#[test]
fn rows_round_trip_bit_for_bit() {
    let row = ModelRow {
        candidate: "RBF 200 r=3e-9 d=4 p=9".into(),
        benettin: Some(0.497),
        rosenstein: Some(-0.000),
        corr_dim: None,
        js: Some(0.0041),
        failed: None,
    };
    let p = tmp("row.json", &to_json(&row).unwrap());
    assert_eq!(read::<ModelRow>(&p).unwrap(), row);
}
