//! The report's cache: each expensive section (or chain of sections that hand values to each
//! other) is a [`Unit`] stored in a content-addressed [`Store`] under a key made of everything
//! it depends on: the fingerprints of the workspace crates and of the `ssmctl` source files it
//! runs (computed by `build.rs`), the toolchain, `--quick`, and the bytes of the files it reads.
//! A section computes into a scratch folder of the store; its HTML, contents entries, summary
//! keys and files are then stored and replayed into the report, so a reused section gives the
//! same page and files as a computed one. A change to one section's source file recomputes
//! only the units that list it; a change to a library crate recomputes the units that use it.

use super::Report;
use fileio::store::{Entry, Key, KeyBuilder, Store};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::error::Error;
use std::path::{Path, PathBuf};

mod fingerprints {
    include!(concat!(env!("OUT_DIR"), "/fingerprints.rs"));
}

/// Workspace crates and the workspace crates they depend on (checked against the manifests
/// by a test), so a unit names only the crates it calls.
pub const CRATE_DEPS: &[(&str, &[&str])] = &[
    ("shared", &[]),
    ("controller", &["shared"]),
    ("infile", &[]),
    ("fileio", &[]),
    ("sim", &["controller", "shared", "infile"]),
    ("ssm", &["shared", "infile"]),
    ("chaos", &[]),
    ("furuta", &["sim", "ssm", "chaos", "shared", "infile"]),
    ("chaos_study", &["sim", "ssm", "chaos"]),
];

/// One cached piece of the report.
pub struct Unit {
    /// Its name (also the store entry's prefix and the timings' row).
    pub name: &'static str,
    /// The workspace crates it calls (their dependencies are added).
    pub crates: &'static [&'static str],
    /// Its source files under `ssmctl/src/report/` (every other `ssmctl` file counts for every
    /// unit).
    pub files: &'static [&'static str],
    /// The files and folders it reads, by name.
    pub inputs: Vec<(&'static str, PathBuf)>,
    /// The summary keys of earlier sections it reads (their values are part of the key and
    /// are given to it; it must not change them).
    pub reads: &'static [&'static str],
    /// Whether it measures speed: then the processor model and the number of cores are part of
    /// the key, so its timings are never replayed on another machine.
    pub timed: bool,
}

/// The processor model (`model name` of `/proc/cpuinfo`, where there is one) and the number
/// of cores this process may use.
fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("model name")).map(str::to_string))
        .unwrap_or_default();
    let cores = std::thread::available_parallelism().map_or(0, usize::from);
    format!("{model}; {cores} cores")
}

/// The start of a key for a unit outside the report (a study's candidate): `label`, the
/// toolchain and the fingerprints of `crates` with their workspace dependencies.
pub fn code_key(label: &str, crates: &[&str]) -> Result<KeyBuilder, Box<dyn Error>> {
    let mut k = KeyBuilder::new(label).part("toolchain", &fingerprints::TOOLCHAIN.to_le_bytes());
    for c in closure(crates)? {
        let h = crate_hash(c).ok_or_else(|| format!("cache: no fingerprint of crate `{c}`"))?;
        k = k.part(c, &h.to_le_bytes());
    }
    Ok(k)
}

/// The HTML, contents entries and summary keys of a section, as stored.
#[derive(Serialize, Deserialize)]
struct PartMeta {
    body: String,
    toc: Vec<(String, String, bool)>,
    summary: Map<String, Value>,
}

/// The report's store and the options that are part of every key.
pub struct SectionCache {
    store: Store,
    quick: bool,
}

/// Whether a unit was reused or computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Reused,
    Computed,
}

fn crate_hash(name: &str) -> Option<u64> {
    fingerprints::CRATES.iter().find(|(n, _)| *n == name).map(|(_, h)| *h)
}

/// The unit's crates with their workspace dependencies, sorted.
pub fn closure(crates: &[&str]) -> Result<Vec<&'static str>, String> {
    let mut out: Vec<&'static str> = Vec::new();
    let mut todo: Vec<&str> = crates.to_vec();
    while let Some(c) = todo.pop() {
        let (name, deps) =
            CRATE_DEPS.iter().find(|(n, _)| *n == c).ok_or_else(|| format!("report cache: unknown crate `{c}`"))?;
        if !out.contains(name) {
            out.push(name);
            todo.extend(deps.iter());
        }
    }
    out.sort_unstable();
    Ok(out)
}

impl Unit {
    /// The key of this unit: code fingerprints, options, inputs and the summary values it reads.
    pub fn key(&self, quick: bool, given: &Map<String, Value>) -> Result<Key, Box<dyn Error>> {
        let mut k = KeyBuilder::new(self.name)
            .part("toolchain", &fingerprints::TOOLCHAIN.to_le_bytes())
            .part("quick", &[u8::from(quick)]);
        for c in closure(self.crates)? {
            let h = crate_hash(c).ok_or_else(|| format!("report cache: no fingerprint of crate `{c}`"))?;
            k = k.part(c, &h.to_le_bytes());
        }
        for f in self.files {
            let rel = format!("report/{f}");
            if !fingerprints::FILES.iter().any(|(n, _)| *n == rel) {
                return Err(
                    format!("report cache: unit `{}` names `{rel}`, which is not a source file", self.name).into()
                );
            }
        }
        // Every ssmctl file outside report/ counts, and of report/ the unit's own and the shared
        // ones (the page, the cache, the text templates' filters).
        for (n, h) in fingerprints::FILES {
            let own = n
                .strip_prefix("report/")
                .is_none_or(|f| ["mod.rs", "cache.rs", "prose.rs"].contains(&f) || self.files.contains(&f));
            if own {
                k = k.part(n, &h.to_le_bytes());
            }
        }
        for (name, path) in &self.inputs {
            k = k.tree(name, path)?;
        }
        for (name, v) in given {
            k = k.part(&format!("summary {name}"), &serde_json::to_vec(v)?);
        }
        if self.timed {
            k = k.part("machine", machine().as_bytes());
        }
        Ok(k.finish())
    }
}

impl SectionCache {
    /// The cache in `dir`, or with `dir = None` a temporary one that is removed when this is
    /// dropped (`--no-cache`: every unit computed, nothing kept).
    pub fn open(dir: Option<&Path>, quick: bool) -> Result<Self, Box<dyn Error>> {
        let store = match dir {
            Some(d) => Store::open(d)?,
            None => Store::temporary()?,
        };
        Ok(Self { store, quick })
    }

    pub fn dir(&self) -> &Path {
        self.store.dir()
    }

    /// Runs `unit` into `rep`: replays the stored result when its key matches, else computes
    /// it with `f` (into a part writing under a scratch folder), stores it and replays it.
    pub fn run(
        &self,
        rep: &mut Report,
        unit: Unit,
        f: impl FnOnce(&mut Report) -> Result<(), Box<dyn Error>>,
    ) -> Result<Outcome, Box<dyn Error>> {
        let given: Map<String, Value> =
            unit.reads.iter().filter_map(|k| rep.summary.get(*k).map(|v| (k.to_string(), v.clone()))).collect();
        let key = unit.key(self.quick, &given)?;
        let (entry, outcome) = match self.store.get(unit.name, &key) {
            Some(e) => (e, Outcome::Reused),
            None => {
                let e = self
                    .store
                    .put(unit.name, &key, |dir| -> Result<Vec<u8>, String> {
                        // The report folder's `fig/` exists before any section runs.
                        crate::output::create_dir(&dir.join("fig")).map_err(|e| e.to_string())?;
                        let mut part = rep.part_in(dir);
                        part.summary.extend(given.clone());
                        f(&mut part).map_err(|e| e.to_string())?;
                        let (body, toc, mut summary) = part.into_parts();
                        for (k, v) in &given {
                            if summary.remove(k).as_ref() != Some(v) {
                                return Err(format!("section `{}` changed the summary key `{k}` it reads", unit.name));
                            }
                        }
                        serde_json::to_vec(&PartMeta { body, toc, summary }).map_err(|e| e.to_string())
                    })
                    .map_err(|e| e.to_string())?;
                (e, Outcome::Computed)
            }
        };
        replay(&entry, rep).map_err(|e| format!("report cache: entry {}: {e}", unit.name))?;
        Ok(outcome)
    }

    /// Records the entries this run used (kept by `ssmctl cache gc`).
    pub fn finish(&self) -> Result<(), Box<dyn Error>> {
        Ok(self.store.finish_run()?)
    }
}

/// Copies a stored unit's files into the report folder (through the command's transaction)
/// and appends its HTML, contents entries and summary keys.
fn replay(entry: &Entry, rep: &mut Report) -> Result<(), Box<dyn Error>> {
    let meta: PartMeta = serde_json::from_slice(&entry.meta()?)?;
    let from = entry.files_dir();
    for rel in entry.files()? {
        let dest = rep.dir().join(&rel);
        if let Some(parent) = dest.parent() {
            crate::output::create_dir(parent)?;
        }
        let bytes = infile::read_bytes(&from.join(&rel), infile::MAX_REPORT_INPUT_BYTES)?;
        crate::output::write_atomic(&dest, &bytes)?;
    }
    let mut part = rep.part();
    part.set_parts(meta.body, meta.toc, meta.summary);
    rep.append(part)?;
    Ok(())
}
