//! A content-addressed store of computed results (the report's sections, expensive runs).
//!
//! An entry is a folder `<unit>-<key>` under the store's folder, where `key` is a [`Key`]: a
//! CRC-64 of everything the result depends on (the inputs' bytes, the code's fingerprint, the
//! options), built with [`KeyBuilder`]. An entry holds the files the computation wrote (under
//! `files/`) and an opaque `meta` file (the caller's description of the result). It is filled
//! in a private scratch folder and renamed into place whole, so a reader sees a complete entry
//! or none; two runs that compute the same entry at once both succeed and one copy is kept.
//! Entries are never modified after they appear. Scratch folders of killed processes are
//! removed by the next run that opens the store. CRC-64 detects changed inputs; it does not
//! resist crafted collisions (the store is a cache, not a security boundary).

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use crate::{OutputError, STAGE_PREFIX, clean_stale, create_dir, io_err, sync_folder, write_atomic};

const CRC: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

/// Folder depth up to which [`KeyBuilder::tree`] descends (a deeper tree is an error, so a
/// link loop cannot recurse without end).
pub const MAX_TREE_DEPTH: usize = 16;

/// The file in the store folder that lists the entries the last run used ([`Store::finish_run`]).
pub const LAST_RUN: &str = "last-run.json";

/// A fingerprint of a result's inputs: 16 hexadecimal digits.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Key(String);

impl Key {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Builds a [`Key`] from named parts; every part is length-prefixed, so moving bytes from one
/// part to the next changes the key. A clone extends the same prefix.
#[derive(Clone)]
pub struct KeyBuilder {
    d: crc::Digest<'static, u64>,
}

impl KeyBuilder {
    pub fn new(label: &str) -> Self {
        let mut b = Self { d: CRC.digest() };
        b.add(label.as_bytes());
        b
    }

    fn add(&mut self, bytes: &[u8]) {
        self.d.update(&(bytes.len() as u64).to_le_bytes());
        self.d.update(bytes);
    }

    /// A named value.
    pub fn part(mut self, name: &str, bytes: &[u8]) -> Self {
        self.add(name.as_bytes());
        self.add(bytes);
        self
    }

    /// A file's contents under `name`; an absent file counts as absent (so its appearance
    /// changes the key). A folder, device or FIFO at `path` is an error naming it.
    pub fn file(mut self, name: &str, path: &Path) -> Result<Self, OutputError> {
        self.add(name.as_bytes());
        match std::fs::metadata(path) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => self.add(b"\0absent"),
            Err(e) => return Err(io_err("reading the cache input", path)(e)),
            Ok(m) if m.is_file() => self.contents(path)?,
            Ok(m) => {
                return Err(OutputError::NotRegular { path: path.to_path_buf(), kind: crate::kind_of(&m.file_type()) });
            }
        }
        Ok(self)
    }

    /// Every regular file under `dir` (relative names and contents, in name order) under
    /// `name`; an absent folder counts as absent. Hidden entries (names starting with `.`)
    /// are skipped: they are the writer's staging folders and temporary files.
    pub fn tree(mut self, name: &str, dir: &Path) -> Result<Self, OutputError> {
        self.add(name.as_bytes());
        match std::fs::metadata(dir) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => {
                self.add(b"\0absent");
                Ok(self)
            }
            Err(e) => Err(io_err("reading the cache input", dir)(e)),
            Ok(m) if m.is_dir() => {
                let mut files = Vec::new();
                list_files(dir, Path::new(""), 0, &mut files)?;
                for rel in files {
                    self.add(rel.to_string_lossy().as_bytes());
                    self.contents(&dir.join(&rel))?;
                }
                Ok(self)
            }
            Ok(m) if m.is_file() => {
                self.contents(dir)?;
                Ok(self)
            }
            Ok(m) => Err(OutputError::NotRegular { path: dir.to_path_buf(), kind: crate::kind_of(&m.file_type()) }),
        }
    }

    fn contents(&mut self, path: &Path) -> Result<(), OutputError> {
        let mut f = File::open(path).map_err(io_err("reading the cache input", path))?;
        let len = f.metadata().map_err(io_err("reading the cache input", path))?.len();
        self.d.update(&len.to_le_bytes());
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let n = f.read(&mut buf).map_err(io_err("reading the cache input", path))?;
            if n == 0 {
                break;
            }
            self.d.update(buf.get(..n).unwrap_or_default());
        }
        Ok(())
    }

    pub fn finish(self) -> Key {
        Key(format!("{:016x}", self.d.finalize()))
    }
}

/// Regular files under `base/rel`, relative to `base`, sorted; hidden names skipped.
fn list_files(base: &Path, rel: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), OutputError> {
    let dir = base.join(rel);
    if depth > MAX_TREE_DEPTH {
        return Err(OutputError::Io {
            action: "reading the cache input",
            path: dir,
            source: io::Error::other(format!("folders nested deeper than {MAX_TREE_DEPTH} levels (a link loop?)")),
        });
    }
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .map_err(io_err("reading the cache input", &dir))?
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .filter(|n| !n.to_string_lossy().starts_with('.'))
        .collect();
    names.sort();
    for n in names {
        let r = rel.join(&n);
        let p = base.join(&r);
        let m = std::fs::metadata(&p).map_err(io_err("reading the cache input", &p))?;
        if m.is_dir() {
            list_files(base, &r, depth + 1, out)?;
        } else if m.is_file() {
            out.push(r);
        } else {
            return Err(OutputError::NotRegular { path: p, kind: crate::kind_of(&m.file_type()) });
        }
    }
    Ok(())
}

/// A complete entry of a [`Store`].
#[derive(Debug, Clone)]
pub struct Entry {
    dir: PathBuf,
}

impl Entry {
    /// The folder holding the entry's files.
    pub fn files_dir(&self) -> PathBuf {
        self.dir.join("files")
    }

    /// The caller's description stored with the entry.
    pub fn meta(&self) -> Result<Vec<u8>, OutputError> {
        let p = self.dir.join("meta");
        std::fs::read(&p).map_err(io_err("reading the cache entry", &p))
    }

    /// The entry's files, relative to [`Entry::files_dir`], in name order.
    pub fn files(&self) -> Result<Vec<PathBuf>, OutputError> {
        let mut out = Vec::new();
        let d = self.files_dir();
        if d.is_dir() {
            list_files(&d, Path::new(""), 0, &mut out)?;
        }
        Ok(out)
    }
}

/// Why [`Store::put`] failed: the computation's own error, or the store's.
#[derive(Debug)]
pub enum PutError<E> {
    Compute(E),
    Store(OutputError),
}

impl<E: std::fmt::Display> std::fmt::Display for PutError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Compute(e) => e.fmt(f),
            Self::Store(e) => write!(f, "cache: {e}"),
        }
    }
}

impl<E: std::fmt::Debug + std::fmt::Display> std::error::Error for PutError<E> {}

/// What [`Store::gc`] removed and kept.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct GcReport {
    pub removed: usize,
    pub removed_bytes: u64,
    pub kept: usize,
}

/// A folder of entries; see the module documentation.
#[derive(Debug)]
pub struct Store {
    dir: PathBuf,
    used: std::sync::Mutex<BTreeSet<String>>,
    /// For [`Store::temporary`]: the folder, removed when the store is dropped.
    _temporary: Option<tempfile::TempDir>,
}

impl Store {
    /// Opens (creating it if needed) the store in `dir`, removing scratch folders left by
    /// processes that no longer exist.
    pub fn open(dir: &Path) -> Result<Self, OutputError> {
        if std::fs::symlink_metadata(dir).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(OutputError::Symlink { path: dir.to_path_buf() });
        }
        let resolved = crate::resolve(dir);
        if let Some(root) =
            crate::registry().txns.iter().find_map(|t| t.roots.iter().find(|r| resolved.starts_with(r)).cloned())
        {
            return Err(OutputError::Io {
                action: "opening the cache folder",
                path: dir.to_path_buf(),
                source: io::Error::other(format!(
                    "it lies inside this command's output {}; choose a cache folder outside it",
                    root.display()
                )),
            });
        }
        create_dir(dir)?;
        clean_stale(dir);
        Ok(Self { dir: dir.to_path_buf(), used: Default::default(), _temporary: None })
    }

    /// A store in a new private folder under the system's temporary folder, removed with the
    /// store (for runs that must not reuse or keep anything).
    pub fn temporary() -> Result<Self, OutputError> {
        let t = tempfile::Builder::new()
            .prefix("ssmctl-cache-")
            .tempdir()
            .map_err(io_err("creating a temporary cache folder in", &std::env::temp_dir()))?;
        Ok(Self { dir: t.path().to_path_buf(), used: Default::default(), _temporary: Some(t) })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn entry_dir(&self, unit: &str, key: &Key) -> PathBuf {
        self.dir.join(format!("{unit}-{key}"))
    }

    fn mark_used(&self, unit: &str, key: &Key) {
        self.used.lock().unwrap_or_else(|p| p.into_inner()).insert(format!("{unit}-{key}"));
    }

    /// The complete entry of `unit` under `key`, if there is one.
    pub fn get(&self, unit: &str, key: &Key) -> Option<Entry> {
        let dir = self.entry_dir(unit, key);
        let complete = std::fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir())
            && std::fs::symlink_metadata(dir.join("meta")).is_ok_and(|m| m.is_file());
        complete.then(|| {
            self.mark_used(unit, key);
            Entry { dir }
        })
    }

    /// Computes and stores the entry of `unit` under `key`: `fill` writes the entry's files
    /// into the folder it is given and returns the entry's description. Nothing is stored
    /// when `fill` fails. If another run stored the same entry meanwhile, that one is kept.
    pub fn put<E>(
        &self,
        unit: &str,
        key: &Key,
        fill: impl FnOnce(&Path) -> Result<Vec<u8>, E>,
    ) -> Result<Entry, PutError<E>> {
        let prefix = format!("{STAGE_PREFIX}{}-", std::process::id());
        let scratch = tempfile::Builder::new()
            .prefix(&prefix)
            .rand_bytes(8)
            .tempdir_in(&self.dir)
            .map_err(|e| PutError::Store(io_err("creating a scratch folder in", &self.dir)(e)))?;
        let files = scratch.path().join("files");
        create_dir(&files).map_err(PutError::Store)?;
        let meta = fill(&files).map_err(PutError::Compute)?;
        let meta_path = scratch.path().join("meta");
        crate::create_new(&meta_path)
            .and_then(|mut f| {
                use std::io::Write;
                f.write_all(&meta)?;
                f.sync_all()
            })
            .map_err(|e| PutError::Store(io_err("writing the cache entry", &meta_path)(e)))?;
        let dest = self.entry_dir(unit, key);
        let kept = scratch.keep();
        match std::fs::rename(&kept, &dest) {
            Ok(()) => sync_folder(&self.dir),
            Err(_) if self.get(unit, key).is_some() => {
                let _ = std::fs::remove_dir_all(&kept);
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&kept);
                return Err(PutError::Store(io_err("storing the cache entry", &dest)(e)));
            }
        }
        self.mark_used(unit, key);
        Ok(Entry { dir: dest })
    }

    /// Writes [`LAST_RUN`]: the entries this run read or stored, which [`Store::gc`] keeps.
    pub fn finish_run(&self) -> Result<(), OutputError> {
        let used: Vec<String> = self.used.lock().unwrap_or_else(|p| p.into_inner()).iter().cloned().collect();
        let mut text = String::from("[\n");
        for (i, u) in used.iter().enumerate() {
            let sep = if i + 1 < used.len() { "," } else { "" };
            text.push_str(&format!("  \"{u}\"{sep}\n"));
        }
        text.push_str("]\n");
        let p = self.dir.join(LAST_RUN);
        write_atomic(&p, text.as_bytes()).map_err(|e| io_err("writing", &p)(e))
    }

    /// Removes every entry the last run ([`LAST_RUN`]) did not use, or every entry with
    /// `all`, and scratch folders of processes that no longer exist. Without a record of the
    /// last run, nothing but scratch folders is removed unless `all`.
    pub fn gc(&self, all: bool) -> Result<GcReport, OutputError> {
        clean_stale(&self.dir);
        let keep: Option<BTreeSet<String>> = if all {
            Some(BTreeSet::new())
        } else {
            let p = self.dir.join(LAST_RUN);
            match std::fs::read_to_string(&p) {
                Ok(t) => Some(
                    t.lines()
                        .map(|l| l.trim().trim_end_matches(',').trim_matches('"').to_string())
                        .filter(|l| !l.is_empty() && l != "[" && l != "]")
                        .collect(),
                ),
                Err(e) if e.kind() == io::ErrorKind::NotFound => None,
                Err(e) => return Err(io_err("reading", &p)(e)),
            }
        };
        let mut report = GcReport::default();
        let entries = std::fs::read_dir(&self.dir).map_err(io_err("reading the cache folder", &self.dir))?;
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let is_entry = e.file_type().is_ok_and(|t| t.is_dir()) && !name.starts_with('.') && is_entry_name(&name);
            if !is_entry {
                continue;
            }
            match &keep {
                Some(k) if !k.contains(&name) => {
                    report.removed_bytes += tree_bytes(&e.path());
                    std::fs::remove_dir_all(e.path()).map_err(io_err("removing the cache entry", &e.path()))?;
                    report.removed += 1;
                }
                _ => report.kept += 1,
            }
        }
        if all {
            let _ = std::fs::remove_file(self.dir.join(LAST_RUN));
        }
        Ok(report)
    }
}

/// `<unit>-<16 hex digits>`.
fn is_entry_name(name: &str) -> bool {
    name.rsplit_once('-')
        .is_some_and(|(u, k)| !u.is_empty() && k.len() == 16 && k.bytes().all(|b| b.is_ascii_hexdigit()))
}

fn tree_bytes(p: &Path) -> u64 {
    let mut total = 0;
    if let Ok(rd) = std::fs::read_dir(p) {
        for e in rd.flatten() {
            match e.file_type() {
                Ok(t) if t.is_dir() => total += tree_bytes(&e.path()),
                Ok(t) if t.is_file() => total += e.metadata().map_or(0, |m| m.len()),
                _ => {}
            }
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fileio-store-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn keys_follow_every_input() {
        let d = tmp("keys");
        std::fs::write(d.join("a.txt"), b"one").unwrap();
        std::fs::create_dir_all(d.join("t/sub")).unwrap();
        std::fs::write(d.join("t/sub/x"), b"x").unwrap();
        let key = || {
            KeyBuilder::new("unit")
                .part("quick", b"1")
                .file("a", &d.join("a.txt"))
                .unwrap()
                .tree("t", &d.join("t"))
                .unwrap()
                .finish()
        };
        let k0 = key();
        assert_eq!(k0, key());
        assert_eq!(k0.as_str().len(), 16);
        std::fs::write(d.join("a.txt"), b"two").unwrap();
        let k1 = key();
        assert_ne!(k0, k1);
        std::fs::write(d.join("t/sub/y"), b"").unwrap();
        let k2 = key();
        assert_ne!(k1, k2);
        // Hidden files (staging leftovers) do not count.
        std::fs::write(d.join("t/.tmp"), b"z").unwrap();
        assert_eq!(k2, key());
        // Absent differs from empty.
        let absent = KeyBuilder::new("u").file("f", &d.join("none")).unwrap().finish();
        std::fs::write(d.join("none"), b"").unwrap();
        assert_ne!(absent, KeyBuilder::new("u").file("f", &d.join("none")).unwrap().finish());
        // The split between parts counts.
        assert_ne!(KeyBuilder::new("u").part("ab", b"c").finish(), KeyBuilder::new("u").part("a", b"bc").finish());
        // A folder where a file is expected is named.
        let e = KeyBuilder::new("u").file("f", &d.join("t")).err().unwrap().to_string();
        assert!(e.contains("directory") && e.contains("/t"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn put_then_get_and_failed_fills_store_nothing() {
        let d = tmp("put");
        let s = Store::open(&d.join("cache")).unwrap();
        let k = KeyBuilder::new("u").part("x", b"1").finish();
        assert!(s.get("sec", &k).is_none());
        let r: Result<Entry, PutError<String>> = s.put("sec", &k, |_| Err("boom".to_string()));
        assert!(matches!(r, Err(PutError::Compute(ref e)) if e == "boom"));
        assert!(s.get("sec", &k).is_none());
        let e = s
            .put("sec", &k, |dir| {
                std::fs::create_dir_all(dir.join("fig")).unwrap();
                std::fs::write(dir.join("fig/a.png"), b"png").unwrap();
                Ok::<_, String>(b"meta".to_vec())
            })
            .unwrap();
        assert_eq!(e.meta().unwrap(), b"meta");
        assert_eq!(e.files().unwrap(), vec![PathBuf::from("fig/a.png")]);
        let again = s.get("sec", &k).unwrap();
        assert_eq!(std::fs::read(again.files_dir().join("fig/a.png")).unwrap(), b"png");
        // A second put of the same entry keeps one copy and leaves no scratch folder.
        s.put("sec", &k, |_| Ok::<_, String>(b"other".to_vec())).unwrap();
        assert_eq!(s.get("sec", &k).unwrap().meta().unwrap(), b"meta");
        let names: Vec<String> = std::fs::read_dir(s.dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec![format!("sec-{k}")], "{names:?}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn concurrent_puts_of_one_entry_all_succeed() {
        let d = tmp("race");
        let s = Store::open(&d).unwrap();
        let k = KeyBuilder::new("race").finish();
        std::thread::scope(|sc| {
            for i in 0..4u8 {
                let s = &s;
                let k = &k;
                sc.spawn(move || {
                    for _ in 0..10 {
                        let e = s
                            .put("u", k, |dir| {
                                std::fs::write(dir.join("f"), [i; 64]).unwrap();
                                Ok::<_, String>(vec![i])
                            })
                            .unwrap();
                        let m = e.meta().unwrap();
                        assert_eq!(std::fs::read(e.files_dir().join("f")).unwrap(), vec![m[0]; 64]);
                    }
                });
            }
        });
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn gc_keeps_what_the_last_run_used() {
        let d = tmp("gc");
        let s = Store::open(&d).unwrap();
        let ka = KeyBuilder::new("a").finish();
        let kb = KeyBuilder::new("b").finish();
        for k in [&ka, &kb] {
            s.put("u", k, |dir| {
                std::fs::write(dir.join("f"), b"12345").unwrap();
                Ok::<_, String>(Vec::new())
            })
            .unwrap();
        }
        // No record of a last run: nothing is removed.
        assert_eq!(s.gc(false).unwrap(), GcReport { removed: 0, removed_bytes: 0, kept: 2 });
        let next = Store::open(&d).unwrap();
        assert!(next.get("u", &ka).is_some());
        next.finish_run().unwrap();
        let r = next.gc(false).unwrap();
        assert_eq!((r.removed, r.kept), (1, 1));
        assert!(r.removed_bytes >= 5);
        assert!(next.get("u", &kb).is_none() && next.get("u", &ka).is_some());
        assert_eq!(next.gc(true).unwrap().removed, 1);
        assert!(next.get("u", &ka).is_none());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_store_inside_an_open_output_is_refused() {
        let d = tmp("inside");
        let out = d.join("out");
        let txn = crate::Outputs::begin(&[&out], &[]);
        let e = Store::open(&out.join("cache")).unwrap_err().to_string();
        assert!(e.contains("inside this command's output"), "{e}");
        assert!(Store::open(&d.join("cache")).is_ok());
        drop(txn);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_link_as_the_store_folder_is_refused() {
        let d = tmp("link");
        std::os::unix::fs::symlink("/tmp", d.join("c")).unwrap();
        let e = Store::open(&d.join("c")).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
