use super::Report;
use serde_json::{Map, Value};
use ssmctl::report::cache::*;
use std::path::{Path, PathBuf};

/// The dependency table above matches the crates' manifests.
#[test]
fn crate_deps_match_the_manifests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let names: Vec<&str> = CRATE_DEPS.iter().map(|(n, _)| *n).collect();
    for (name, deps) in CRATE_DEPS {
        let dir = if ["shared", "controller"].contains(name) { root.join(name) } else { root.join("host").join(name) };
        let text = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
        let manifest: toml::Table = toml::from_str(&text).unwrap();
        let mut found: Vec<&str> = manifest
            .get("dependencies")
            .and_then(|d| d.as_table())
            .map(|d| names.iter().copied().filter(|n| d.contains_key(*n)).collect())
            .unwrap_or_default();
        let mut want = deps.to_vec();
        found.sort_unstable();
        want.sort_unstable();
        assert_eq!(found, want, "{name}'s workspace dependencies");
    }
    assert_eq!(closure(&["furuta"]).unwrap(), ["chaos", "controller", "furuta", "infile", "shared", "sim", "ssm"]);
    assert!(closure(&["nope"]).is_err());
}

fn unit(name: &'static str, files: &'static [&'static str], inputs: Vec<(&'static str, PathBuf)>) -> Unit {
    Unit { name, crates: &["ssm"], files, inputs, reads: &[], timed: false }
}

/// A second run replays the first's page, summary and files without computing; a changed
/// input, `--quick` or source file changes the key.
#[test]
fn a_unit_is_computed_once_and_replayed() {
    let d = std::env::temp_dir().join(format!("ssmctl-report-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("data")).unwrap();
    std::fs::write(d.join("data/x.csv"), "1\n").unwrap();
    let cache = SectionCache::open(Some(&d.join("cache")), true).unwrap();
    let mut calls = 0;
    let mut render = |out: &str| {
        let mut rep = Report::new(&d.join(out)).unwrap();
        let o = cache
            .run(&mut rep, unit("demo", &["sloshing.rs"], vec![("data", d.join("data"))]), |r| {
                calls += 1;
                r.section("demo", "Demo", "intro");
                r.summary.insert("demo".into(), Value::from(1.5));
                ssmctl::output::create_dir(&r.dir().join("fig")).unwrap();
                ssmctl::output::write_atomic(&r.dir().join("fig/demo.png"), b"png").unwrap();
                r.figure("fig/demo.png", "a figure");
                Ok(())
            })
            .unwrap();
        rep.finish("t").unwrap();
        o
    };
    assert_eq!(render("a"), Outcome::Computed);
    assert_eq!(render("b"), Outcome::Reused);
    for f in ["index.html", "summary.json", "fig/demo.png"] {
        assert_eq!(std::fs::read(d.join("a").join(f)).unwrap(), std::fs::read(d.join("b").join(f)).unwrap(), "{f}");
    }
    std::fs::write(d.join("data/x.csv"), "2\n").unwrap();
    assert_eq!(render("c"), Outcome::Computed);
    assert_eq!(calls, 2);
    let none = Map::new();
    let k = |quick, files| unit("demo", files, vec![]).key(quick, &none).unwrap();
    assert_ne!(k(true, &["sloshing.rs"]), k(false, &["sloshing.rs"]));
    assert_ne!(k(true, &["sloshing.rs"]), k(true, &["chaos.rs"]));
    assert!(unit("demo", &["nope.rs"], vec![]).key(true, &none).is_err());
    let timed = Unit { timed: true, ..unit("demo", &["sloshing.rs"], vec![]) };
    assert_ne!(timed.key(true, &none).unwrap(), k(true, &["sloshing.rs"]));
    // A section reading an earlier section's summary key sees it, keyed by its value, and
    // the key stays the earlier section's.
    let reader = |rep: &mut Report| {
        let u =
            Unit { name: "reader", crates: &["ssm"], files: &[], inputs: Vec::new(), reads: &["demo"], timed: false };
        cache.run(rep, u, |r| {
            let seen = r.summary.get("demo").cloned().unwrap_or(Value::Null);
            r.summary.insert("reader".into(), seen);
            Ok(())
        })
    };
    let mut rep = Report::new(&d.join("r")).unwrap();
    rep.summary.insert("demo".into(), Value::from(2.5));
    assert_eq!(reader(&mut rep).unwrap(), Outcome::Computed);
    assert_eq!((rep.summary["reader"].clone(), rep.summary["demo"].clone()), (Value::from(2.5), Value::from(2.5)));
    let mut rep = Report::new(&d.join("r2")).unwrap();
    rep.summary.insert("demo".into(), Value::from(3.5));
    assert_eq!(reader(&mut rep).unwrap(), Outcome::Computed);
    assert_eq!(rep.summary["reader"], Value::from(3.5));
    // A failing section stores nothing and its error comes through.
    let mut rep = Report::new(&d.join("e")).unwrap();
    let e = cache.run(&mut rep, unit("fails", &[], vec![]), |_| Err("no data".into())).unwrap_err();
    assert!(e.to_string().contains("no data"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}
