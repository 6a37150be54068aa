//! One compile per crate and profile in `cargo xtask test`: the builds that select part of the
//! workspace resolve every shared dependency's features as `cargo test --workspace` does, so
//! cargo reuses that build's artifacts instead of compiling faer, nalgebra, gemm, serde, ssm
//! ... again with other features (a feature set is part of each artifact's hash).
//!
//! - the PIL and Slurm steps' `cargo build --profile test --workspace --bin ssmctl`: the same
//!   packages without dev-dependencies, so no dev-dependency may turn on a feature of the
//!   build graph (proptest's default `fork` did, through tempfile, rustix, `bitflags/std`);
//! - maturin's build of the Python module (`host/python` alone): its manifest requests the
//!   features the rest of the workspace turns on.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// `name version -> {features}` of every package `cargo tree ARGS` lists (a package built
/// both for the host and the target may appear with two feature sets).
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let out = Command::new(env!("CARGO"))
        .current_dir(&root)
        .args(["tree", "--offline", "--prefix", "none", "-f", "{p}|{f}"])
        .args(args)
        .output()
        .expect("cargo tree runs");
    assert!(out.status.success(), "cargo tree {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    // One line per package; cargo tree separates the trees of several roots with blank lines.
    for line in String::from_utf8(out.stdout).unwrap().lines().filter(|l| !l.trim().is_empty()) {
        let (package, feats) = line.split_once('|').unwrap_or_else(|| panic!("unexpected line {line:?}"));
        let key = package.split_whitespace().take(2).collect::<Vec<_>>().join(" ");
        let feats = feats.trim_end_matches(" (*)").trim().to_string();
        map.entry(key).or_default().insert(feats);
    }
    map
}

/// Packages of `part` whose features differ from those in `whole`.
fn differing(part: &BTreeMap<String, BTreeSet<String>>, whole: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    part.iter()
        .filter_map(|(k, f)| {
            let w = whole.get(k)?;
            (!f.is_subset(w)).then(|| format!("{k}: {f:?} here, {w:?} in `cargo test --workspace`"))
        })
        .collect()
}

#[test]
fn dev_dependencies_turn_on_no_feature_of_the_build_graph() {
    let with_dev = features(&["--workspace", "-e", "normal,build,dev"]);
    let without = features(&["--workspace", "-e", "normal,build"]);
    assert!(without.keys().any(|k| k.starts_with("faer ")), "{without:?}");
    let d = differing(&without, &with_dev);
    assert!(d.is_empty(), "a dev-dependency changes features of the ssmctl build:\n{}", d.join("\n"));
}

#[test]
fn the_python_module_resolves_the_workspace_features() {
    let with_dev = features(&["--workspace", "-e", "normal,build,dev"]);
    let python = features(&["-p", "python", "-e", "normal,build"]);
    assert!(
        python.keys().any(|k| k.starts_with("ssm ")) && python.keys().any(|k| k.starts_with("pyo3 ")),
        "{python:?}"
    );
    let d = differing(&python, &with_dev);
    assert!(
        d.is_empty(),
        "maturin's build of host/python alone would recompile these (request the features in host/python/Cargo.toml):\n{}",
        d.join("\n")
    );
}

/// Names of the packages only the compiler runs (proc macros, and what only build scripts and
/// proc macros use) in `cargo test --workspace`.
fn compile_time_packages() -> BTreeSet<String> {
    let name = |k: &String| k.split_whitespace().next().unwrap_or_default().to_string();
    let all: BTreeSet<String> = features(&["--workspace", "-e", "normal,build,dev"]).keys().map(name).collect();
    let run: BTreeSet<String> = features(&["--workspace", "-e", "normal,dev,no-proc-macro"]).keys().map(name).collect();
    all.difference(&run).cloned().collect()
}

/// The packages `[profile.dev.package]` of the root manifest builds at opt-level 0.
fn unoptimized_in_manifest() -> BTreeSet<String> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    let mut inside = false;
    let mut names = BTreeSet::new();
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == "[profile.dev.package]";
            continue;
        }
        if let (true, Some((name, value))) = (inside, line.split_once('=')) {
            if value.replace(' ', "") == "{opt-level=0}" {
                names.insert(name.trim().trim_matches('"').to_string());
            }
        }
    }
    names
}

/// `package."*"` optimizes every dependency, and it takes precedence over `build-override`, so
/// the packages that only run at compile time are named to build unoptimized: all of them, and
/// none that the tests or `ssmctl` run.
#[test]
fn compile_time_packages_are_built_unoptimized_and_only_they() {
    let compile_time = compile_time_packages();
    assert!(compile_time.contains("syn") && compile_time.contains("serde_derive"), "{compile_time:?}");
    assert!(!compile_time.contains("faer") && !compile_time.contains("serde"), "{compile_time:?}");
    let listed = unoptimized_in_manifest();
    let missing: Vec<_> = compile_time.difference(&listed).collect();
    let extra: Vec<_> = listed.difference(&compile_time).collect();
    assert!(
        missing.is_empty(),
        "add to [profile.dev.package] of Cargo.toml as `NAME = {{ opt-level = 0 }}`: {missing:?}"
    );
    assert!(
        extra.is_empty(),
        "[profile.dev.package] of Cargo.toml unoptimizes packages that run in the tests: {extra:?}"
    );
}
