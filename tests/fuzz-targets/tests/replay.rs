//! Stable replay of the fuzz corpora (docs/decisions/0004): every file of `tests/fuzz/seeds/<target>`
//! (inputs built from the bundled scenes, data and blobs and the bad cases),
//! `tests/fuzz/regressions/<target>` (what the fuzzers found, kept after the fix) and, when
//! present, a local `tests/fuzz/corpus/<target>` (what a libFuzzer run grew) goes through the
//! same target body the libFuzzer harness calls. No nightly toolchain needed; a few seconds.

use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).filter(|p| p.is_file()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

/// Runs every file of `kind` for every target; returns (files run, failures as
/// "target/file: message").
fn replay(kind: &str) -> (usize, Vec<String>) {
    let mut n = 0;
    let mut failures = Vec::new();
    for (name, body) in fuzz_targets::TARGETS {
        for f in files(&fuzz_dir().join(kind).join(name)) {
            let data = std::fs::read(&f).unwrap();
            n += 1;
            if let Err(p) = std::panic::catch_unwind(|| body(&data)) {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                failures.push(format!("{name}/{}: {msg}", f.file_name().unwrap().to_string_lossy()));
            }
        }
    }
    (n, failures)
}

#[test]
fn every_target_has_seeds_and_they_pass() {
    for (name, _) in fuzz_targets::TARGETS {
        let n = files(&fuzz_dir().join("seeds").join(name)).len();
        assert!(n >= 5, "target {name}: {n} seed files in tests/fuzz/seeds/{name}");
        assert!(
            fuzz_dir().join("fuzz_targets").join(format!("{name}.rs")).is_file(),
            "target {name} has no libFuzzer harness"
        );
    }
    let (n, failures) = replay("seeds");
    assert!(failures.is_empty(), "{} of {n} seed files fail:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn regression_files_pass() {
    let (n, failures) = replay("regressions");
    assert!(failures.is_empty(), "{} of {n} regression files fail:\n{}", failures.len(), failures.join("\n"));
}

/// A corpus grown by a local libFuzzer run (not committed; can be large): `cargo test -p
/// fuzz-targets -- --ignored` after `cargo xtask fuzz`.
#[test]
#[ignore = "replays the local libFuzzer corpus (tests/fuzz/corpus), absent in CI"]
fn a_local_corpus_passes() {
    let (n, failures) = replay("corpus");
    assert!(failures.is_empty(), "{} of {n} corpus files fail:\n{}", failures.len(), failures.join("\n"));
}
