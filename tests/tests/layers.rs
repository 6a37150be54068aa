//! The crate graph is the architecture: each crate may depend only on the workspace crates
//! below it (ARCHITECTURE.md, "Architecture invariant" lines), and only the app depends on
//! the command-line and drawing crates. Read from `cargo metadata`, so a new arrow in a
//! manifest fails here with its name.

use serde_json::Value;
use std::collections::BTreeMap;
use std::process::Command;

/// Normal (non-dev) workspace dependencies each crate may have.
const ALLOWED: &[(&str, &[&str])] = &[
    ("shared", &[]),
    // The one bounded reader of input files, below every crate that reads files.
    ("infile", &[]),
    ("controller", &["shared"]),
    ("chaos", &[]),
    // The one output writer and the one bounded reader, under every crate that writes or reads files.
    ("fileio", &[]),
    ("infile", &[]),
    ("sim", &["controller", "shared", "infile"]),
    ("ssm", &["shared", "infile"]),
    ("furuta", &["sim", "ssm", "chaos", "shared", "controller", "infile"]),
    ("chaos_study", &["sim", "ssm", "chaos"]),
    ("ssmctl", &["sim", "ssm", "chaos", "furuta", "chaos_study", "shared", "controller", "infile", "fileio"]),
    // The Python module `ssm_ctl` (host/python): an app layer beside ssmctl, on the learner
    // and the simulator.
    ("python", &["ssm", "sim", "shared", "infile", "fileio"]),
    // Research and profiling programs (host/lab): on top of everything, used by nothing.
    ("lab", &["sim", "ssm", "chaos", "furuta", "chaos_study", "ssmctl", "fileio"]),
    ("tests", &["controller", "shared"]),
    // The fuzz targets' bodies (tests/fuzz-targets): above the app, whose parser they drive.
    ("fuzz-targets", &["sim", "ssm", "furuta", "chaos_study", "controller", "shared", "ssmctl", "infile", "fileio"]),
];

/// External crates only the app may depend on.
const APP_ONLY: &[&str] = &["clap", "indicatif", "plotters", "dejavu"];

/// External crates only the Python module may depend on (the bindings).
const PYTHON_ONLY: &[&str] = &["pyo3", "numpy"];

fn metadata() -> Value {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let out = Command::new(env!("CARGO"))
        .current_dir(&root)
        .args(["metadata", "--no-deps", "--format-version", "1", "--offline"])
        .output()
        .expect("cargo metadata runs");
    assert!(out.status.success(), "cargo metadata: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON")
}

/// `package -> [(dependency, kind)]` for the workspace members.
fn deps() -> BTreeMap<String, Vec<(String, Option<String>)>> {
    let m = metadata();
    let mut out = BTreeMap::new();
    for p in m["packages"].as_array().unwrap() {
        let name = p["name"].as_str().unwrap().to_string();
        let d = p["dependencies"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| (d["name"].as_str().unwrap().to_string(), d["kind"].as_str().map(String::from)))
            .collect();
        out.insert(name, d);
    }
    out
}

#[test]
fn crates_depend_only_downward() {
    let deps = deps();
    let members: Vec<&str> = ALLOWED.iter().map(|(n, _)| *n).collect();
    for (name, allowed) in ALLOWED {
        let Some(d) = deps.get(*name) else { panic!("workspace member {name} not found by cargo metadata") };
        for (dep, kind) in d {
            if kind.is_none() && members.contains(&dep.as_str()) {
                assert!(
                    allowed.contains(&dep.as_str()),
                    "{name} depends on {dep}: not an allowed arrow (allowed: {allowed:?})"
                );
            }
        }
    }
    // Every workspace member is listed above (a new crate states its place).
    for name in deps.keys() {
        assert!(
            members.contains(&name.as_str()) || name == "firmware",
            "workspace member {name} has no place in ALLOWED"
        );
    }
}

#[test]
fn only_the_app_draws_and_parses_command_lines() {
    for (name, d) in deps() {
        if name == "ssmctl" {
            continue;
        }
        for (dep, kind) in d {
            if kind.is_none() {
                assert!(!APP_ONLY.contains(&dep.as_str()), "{name} depends on {dep}, which only ssmctl may use");
            }
        }
    }
}

#[test]
fn only_the_python_module_binds_python() {
    for (name, d) in deps() {
        if name == "python" {
            continue;
        }
        for (dep, _) in d {
            assert!(
                !PYTHON_ONLY.contains(&dep.as_str()),
                "{name} depends on {dep}, which only the Python module (host/python) may use"
            );
        }
    }
}

/// The `.rs` files under `dir`, recursively, leaving out every file and folder `skip` names.
fn rs_files(dir: &std::path::Path, skip: &dyn Fn(&std::path::Path) -> bool) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if skip(&p) {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out
}

/// Top-level modules of one crate and the crate's own top-level modules each one uses
/// (`crate::m` anywhere in its files, `super::m` in a top-level file), comments skipped.
fn module_graph(src: &std::path::Path) -> BTreeMap<String, std::collections::BTreeSet<String>> {
    fn used(text: &str, prefix: &str, out: &mut std::collections::BTreeSet<String>) {
        for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
            let mut rest = line;
            while let Some(i) = rest.find(prefix) {
                rest = &rest[i + prefix.len()..];
                let name: String =
                    rest.chars().take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '_').collect();
                if !name.is_empty() {
                    out.insert(name);
                }
            }
        }
    }
    // Test modules may reach any module: their imports are not the architecture.
    let all = rs_files(src, &|p| p.ends_with("tests.rs"));
    let mut graph: BTreeMap<String, std::collections::BTreeSet<String>> = BTreeMap::new();
    for p in &all {
        let rel = p.strip_prefix(src).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_string_lossy().trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(p).unwrap();
        let entry = graph.entry(top.clone()).or_default();
        used(&text, "crate::", entry);
        if rel.components().count() == 1 {
            used(&text, "super::", entry);
        }
        entry.remove(&top);
    }
    let names: Vec<String> = graph.keys().cloned().collect();
    for deps in graph.values_mut() {
        deps.retain(|d| names.contains(d));
    }
    graph
}

/// A module that reaches itself through the imports of others, if any.
fn cycle(graph: &BTreeMap<String, std::collections::BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        g: &BTreeMap<String, std::collections::BTreeSet<String>>,
        m: &str,
        path: &mut Vec<String>,
        done: &mut std::collections::BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == m) {
            return Some(path[i..].iter().cloned().chain([m.to_string()]).collect());
        }
        if done.contains(m) {
            return None;
        }
        path.push(m.to_string());
        for d in g.get(m).into_iter().flatten() {
            if let Some(c) = visit(g, d, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(m.to_string());
        None
    }
    let mut done = std::collections::BTreeSet::new();
    graph.keys().find_map(|m| visit(graph, m, &mut Vec::new(), &mut done))
}

/// No import circles between the top-level modules of a crate (the crate root and its
/// error module, which gather every module, excepted).
#[test]
fn no_module_import_circles() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    for krate in ["host/sim", "host/ssm", "host/chaos", "host/furuta", "host/ssmctl", "controller", "shared"] {
        let mut g = module_graph(&root.join(krate).join("src"));
        for gather in ["lib", "main", "error"] {
            g.remove(gather);
        }
        for deps in g.values_mut() {
            deps.remove("error");
        }
        assert_eq!(cycle(&g), None, "{krate}: import circle");
    }
    // The check sees a circle when there is one.
    let mut g: BTreeMap<String, std::collections::BTreeSet<String>> = BTreeMap::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    g.entry("c".into()).or_default().insert("a".into());
    assert_eq!(cycle(&g), Some(vec!["a".into(), "b".into(), "c".into(), "a".into()]));
}

/// Calls that would write a file behind the one output writer's back (`fileio`): no
/// symlink/device checks, no staging, no transaction.
const RAW_WRITES: [&str; 6] =
    ["fs::write(", " File::create(", "(File::create(", "fs::File::create(", "OpenOptions::new(", "fs::copy("];

/// The non-test part of a source file: the text before its first `#[cfg(test)]`.
fn non_test_part(text: &str) -> &str {
    text.split("#[cfg(test)]").next().unwrap_or(text)
}

/// Every file the command line and the Python module write goes through `fileio`.
#[test]
fn apps_write_only_through_the_one_writer() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let mut offenders = Vec::new();
    for krate in ["host/ssmctl/src", "host/python/src"] {
        for p in rs_files(&root.join(krate), &|p| p.ends_with("tests.rs")) {
            let text = std::fs::read_to_string(&p).unwrap();
            for (n, line) in non_test_part(&text).lines().enumerate() {
                if !line.trim_start().starts_with("//") && RAW_WRITES.iter().any(|w| line.contains(w)) {
                    offenders.push(format!("{}:{}: {}", p.display(), n + 1, line.trim()));
                }
            }
        }
    }
    assert!(offenders.is_empty(), "writes outside fileio:\n{}", offenders.join("\n"));
    // The scan sees a raw write when there is one, and not in a test module.
    assert!(RAW_WRITES.iter().any(|w| non_test_part("let _ = std::fs::write(p, b);").contains(w)));
    assert!(!RAW_WRITES.iter().any(|w| non_test_part("#[cfg(test)]\nfn t() { std::fs::write(p, b); }").contains(w)));
}

/// Every `tests/*.rs` file of a workspace crate is compiled: it is a test target's root or a
/// `mod` of one. With `autotests = false` a file outside both would silently never build or run.
#[test]
fn every_integration_test_file_is_built() {
    let m = metadata();
    let mut orphans = Vec::new();
    for p in m["packages"].as_array().unwrap() {
        let manifest = std::path::Path::new(p["manifest_path"].as_str().unwrap());
        let dir = manifest.parent().unwrap().join("tests");
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        let roots: Vec<std::path::PathBuf> = p["targets"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|t| t["kind"].as_array().unwrap().iter().any(|k| k == "test"))
            .map(|t| std::path::PathBuf::from(t["src_path"].as_str().unwrap()))
            .collect();
        let root_text: String = roots.iter().filter_map(|r| std::fs::read_to_string(r).ok()).collect();
        for e in entries {
            let path = e.unwrap().path();
            if path.extension().is_none_or(|x| x != "rs") || roots.contains(&path) {
                continue;
            }
            let stem = path.file_stem().unwrap().to_str().unwrap();
            if !root_text.contains(&format!("mod {stem};")) {
                orphans.push(path.display().to_string());
            }
        }
    }
    assert!(
        orphans.is_empty(),
        "test files that no test target builds (add `mod NAME;` to tests/integration.rs): {orphans:?}"
    );
}

/// The lines of `text` that declare a test (`#[test]`, a `proptest!` block, a `#[cfg(test)]`
/// item), comments skipped: in a library built with `test = false` they would silently never
/// build or run.
fn test_lines(text: &str) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .filter(|(_, l)| ["#[test]", "proptest!", "#[cfg(test)]"].iter().any(|m| l.contains(m)))
        .map(|(n, l)| (n + 1, l.trim().to_string()))
        .collect()
}

/// The `.rs` files of the library whose root is `lib`, by folder: every file under the root's
/// folder except those of the package's other targets (`src/main.rs`, `src/bin/`, a binary's own
/// folder such as `src/xtask/`).
fn library_files(lib: &std::path::Path, other_roots: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
    let dir = lib.parent().unwrap();
    let skip_dirs: Vec<&std::path::Path> =
        other_roots.iter().filter_map(|r| r.parent()).filter(|d| *d != dir && d.starts_with(dir)).collect();
    rs_files(dir, &|p| skip_dirs.iter().any(|s| p.starts_with(s)) || other_roots.iter().any(|r| r == p))
}

/// The `.rs` files of the binary whose root is `bin`: the root, and the folder of its own modules
/// (`src/NAME/` beside `src/NAME.rs`, or the folder of a `main.rs` that is not the library's).
fn binary_files(bin: &std::path::Path, lib_dir: Option<&std::path::Path>) -> Vec<std::path::PathBuf> {
    let own = if bin.file_name().is_some_and(|n| n == "main.rs") {
        bin.parent().filter(|d| Some(*d) != lib_dir).map(std::path::Path::to_path_buf)
    } else {
        Some(bin.with_extension(""))
    };
    let mut files = vec![bin.to_path_buf()];
    if let Some(d) = own.filter(|d| d.is_dir()) {
        files.extend(rs_files(&d, &|p| p == bin));
    }
    files
}

/// A library or binary with `test = false` (its unit tests live in its integration-test binary,
/// so it is compiled once) has no test left under its sources.
#[test]
fn libraries_without_unit_tests_have_no_tests_in_their_sources() {
    let m = metadata();
    let mut found = Vec::new();
    let (mut libs, mut bins) = (0, 0);
    for p in m["packages"].as_array().unwrap() {
        let targets = p["targets"].as_array().unwrap();
        let roots: Vec<std::path::PathBuf> =
            targets.iter().map(|t| std::path::PathBuf::from(t["src_path"].as_str().unwrap())).collect();
        let is = |t: &Value, kinds: &[&str]| t["kind"].as_array().unwrap().iter().any(|k| kinds.iter().any(|x| k == x));
        let lib_dir = targets
            .iter()
            .zip(&roots)
            .find(|(t, _)| is(t, &["lib", "rlib", "cdylib"]))
            .and_then(|(_, r)| r.parent().map(std::path::Path::to_path_buf));
        for (t, root) in targets.iter().zip(&roots) {
            if t["test"].as_bool() != Some(false) {
                continue;
            }
            let files = if is(t, &["lib", "rlib", "cdylib"]) {
                libs += 1;
                let others: Vec<std::path::PathBuf> = roots.iter().filter(|r| *r != root).cloned().collect();
                library_files(root, &others)
            } else if is(t, &["bin"]) {
                bins += 1;
                binary_files(root, lib_dir.as_deref())
            } else {
                continue;
            };
            for f in files {
                for (n, line) in test_lines(&std::fs::read_to_string(&f).unwrap()) {
                    found.push(format!("{}:{n}: {line}", f.display()));
                }
            }
        }
    }
    assert!(libs > 0, "no library with `test = false` found: the scan would check nothing");
    assert!(bins > 0, "no binary with `test = false` found: the scan would check nothing");
    assert!(
        found.is_empty(),
        "tests in libraries or binaries built with `test = false` never run (move them to tests/integration.rs):\n{}",
        found.join("\n")
    );
    // The scan sees each kind of test, and not one in a comment.
    assert_eq!(test_lines("#[test]\nfn t() {}\nproptest! {}\n#[cfg(test)]\nmod tests;").len(), 3);
    assert!(test_lines("// #[test] in a comment").is_empty());
}
