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
    ("controller", &["shared"]),
    ("chaos", &[]),
    ("sim", &["controller", "shared"]),
    ("ssm", &["shared"]),
    ("furuta", &["sim", "ssm", "chaos", "shared", "controller"]),
    ("ssmctl", &["sim", "ssm", "chaos", "furuta", "shared", "controller"]),
    ("tests", &["controller", "shared"]),
];

/// External crates only the app may depend on.
const APP_ONLY: &[&str] = &["clap", "indicatif", "plotters", "dejavu"];

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
                assert!(allowed.contains(&dep.as_str()), "{name} depends on {dep}: not an allowed arrow (allowed: {allowed:?})");
            }
        }
    }
    // Every workspace member is listed above (a new crate states its place).
    for name in deps.keys() {
        assert!(members.contains(&name.as_str()) || name == "firmware", "workspace member {name} has no place in ALLOWED");
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
