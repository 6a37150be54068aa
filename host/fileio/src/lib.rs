//! The one output writer of the tool.
//!
//! Every file a command writes goes through [`AtomicFile`] (or [`write_atomic`]):
//! - the bytes go to a file created with `O_EXCL` under an unpredictable name in the target's
//!   folder, never through a symbolic link, and the target itself must be absent or a regular
//!   file (a symbolic link, a directory, a device, a FIFO or a socket there is an error naming
//!   it, so `--out /dev/null` can never replace a device node);
//! - a target that is one of the command's own inputs (same path or same file) is an error;
//! - while an [`Outputs`] transaction covers the target (a command's `--out` folder or file),
//!   committed files are only staged: [`Outputs::commit`] renames all of them into place under
//!   an advisory lock on each output folder, restoring the previous files if a rename fails, so
//!   a command's outputs appear all together or not at all, and concurrent runs into one folder
//!   each leave a consistent set (the last commit wins whole);
//! - dropping an [`Outputs`] without committing (an error path) removes everything staged, and
//!   so does SIGINT, SIGTERM or SIGHUP once [`install_signal_cleanup`] has run (the handler
//!   waits for a commit in progress, so a signal never leaves half a set).
//!
//! SIGKILL cannot be caught: it leaves the hidden staging folder `.ssmctl-stage-<pid>-*` (or a
//! temporary file `.<name>.ssmctl-tmp-<pid>-*`) next to the outputs, never a partial file under
//! a final name; the next run that writes into that folder removes the leftovers of processes
//! that no longer exist.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing))]

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};

pub mod store;

/// Prefix of the staging folders a transaction creates inside each output folder.
const STAGE_PREFIX: &str = ".ssmctl-stage-";
/// Infix of the temporary file of a write outside any transaction.
const TMP_INFIX: &str = ".ssmctl-tmp-";

/// Why an output could not be written; every variant names the path.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("refusing to write {}: it is a symbolic link; remove it or choose another output path", path.display())]
    Symlink { path: PathBuf },
    #[error("refusing to write {}: it is a {kind}, not a regular file; choose another output path", path.display())]
    NotRegular { path: PathBuf, kind: &'static str },
    #[error(
        "refusing to write {}: it is this command's input ({what} {}); choose another output path",
        path.display(),
        input.display()
    )]
    IsInput { path: PathBuf, what: String, input: PathBuf },
    #[error("{}: not a file name", path.display())]
    NoFileName { path: PathBuf },
    #[error("{action} {}: {}", path.display(), words(source))]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: io::Error,
    },
}

impl From<OutputError> for io::Error {
    fn from(e: OutputError) -> Self {
        let kind = match &e {
            OutputError::Io { source, .. } => source.kind(),
            OutputError::NoFileName { .. } => io::ErrorKind::InvalidInput,
            _ => io::ErrorKind::AlreadyExists,
        };
        io::Error::new(kind, e)
    }
}

/// An I/O error in words: without `(os error N)` and without the ` at path P` the `tempfile`
/// crate appends (P is an internal temporary name; the error names the output instead).
pub fn words(e: &io::Error) -> String {
    let mut s = e.to_string();
    if let Some(i) = s.find(" at path ") {
        s.truncate(i);
    }
    while let Some(i) = s.find(" (os error ") {
        let Some(j) = s.get(i..).and_then(|t| t.find(')')) else { break };
        s.replace_range(i..i + j + 1, "");
    }
    s
}

fn io_err<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(io::Error) -> OutputError + 'a {
    move |source| OutputError::Io { action, path: path.to_path_buf(), source }
}

/// `p` made absolute and normalized: the longest existing prefix canonicalized (links in the
/// folders resolved), the rest appended with `.` dropped and `..` applied lexically.
fn resolve(p: &Path) -> PathBuf {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    let comps: Vec<Component<'_>> = abs.components().collect();
    for split in (0..=comps.len()).rev() {
        let (head, tail) = comps.split_at(split);
        let head: PathBuf = head.iter().collect();
        if let Ok(mut base) = head.canonicalize() {
            for c in tail {
                match c {
                    Component::CurDir => {}
                    Component::ParentDir => {
                        base.pop();
                    }
                    other => base.push(other.as_os_str()),
                }
            }
            return base;
        }
    }
    abs
}

/// The resolved path of a file that is about to be written: its folder canonicalized, its own
/// name kept (a link there must not be followed).
fn resolve_target(target: &Path) -> Result<PathBuf, OutputError> {
    let name = target.file_name().ok_or_else(|| OutputError::NoFileName { path: target.to_path_buf() })?;
    let parent = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Ok(resolve(parent).join(name))
}

/// The kind of a non-regular file, in words.
fn kind_of(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_block_device() {
            return "block device";
        }
        if ft.is_char_device() {
            return "character device";
        }
        if ft.is_fifo() {
            return "FIFO";
        }
        if ft.is_socket() {
            return "socket";
        }
    }
    if ft.is_dir() { "directory" } else { "special file" }
}

/// The target must be absent or a regular file (not followed if it is a link).
fn check_target_kind(shown: &Path, resolved: &Path) -> Result<(), OutputError> {
    match std::fs::symlink_metadata(resolved) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(OutputError::Io { action: "inspecting", path: shown.to_path_buf(), source: e }),
        Ok(m) if m.file_type().is_symlink() => Err(OutputError::Symlink { path: shown.to_path_buf() }),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => Err(OutputError::NotRegular { path: shown.to_path_buf(), kind: kind_of(&m.file_type()) }),
    }
}

/// A command's input: its label, the path as given, the resolved path and, where it exists, its
/// device and inode (hard links and other spellings name the same file).
#[derive(Clone, Debug)]
struct Input {
    what: String,
    shown: PathBuf,
    resolved: PathBuf,
    id: Option<(u64, u64)>,
}

fn file_id(p: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = p;
        None
    }
}

impl Input {
    fn new(what: &str, p: &Path) -> Self {
        Self { what: what.to_string(), shown: p.to_path_buf(), resolved: resolve(p), id: file_id(p) }
    }

    fn check(&self, shown: &Path, resolved: &Path) -> Result<(), OutputError> {
        let same_id = match (self.id, file_id(resolved)) {
            (Some(a), Some(b)) => a == b,
            _ => false,
        };
        if same_id || self.resolved == resolved {
            return Err(OutputError::IsInput {
                path: shown.to_path_buf(),
                what: self.what.clone(),
                input: self.shown.clone(),
            });
        }
        Ok(())
    }
}

/// Refuses to write `output` when it is one of `inputs` (`export --out` equal to `--model`,
/// `fit --save` onto a data file, ...): the input would be destroyed by its own command.
pub fn check_not_input(output: &Path, inputs: &[(&str, &Path)]) -> Result<(), OutputError> {
    let resolved = resolve_target(output)?;
    for (what, p) in inputs {
        Input::new(what, p).check(output, &resolved)?;
    }
    Ok(())
}

/// One staged file of a transaction.
#[derive(Debug)]
struct Staged {
    shown: PathBuf,
    target: PathBuf,
    tmp: PathBuf,
}

/// An open transaction: where it writes, what it must not overwrite, what it has staged.
#[derive(Debug)]
struct Txn {
    id: u64,
    /// The thread that opened it: among transactions covering a file, the writing thread's own
    /// is preferred (tests open several at once; a command opens one and writes from any thread).
    thread: std::thread::ThreadId,
    roots: Vec<PathBuf>,
    inputs: Vec<Input>,
    /// One staging folder per output folder (keyed by the resolved output folder).
    stages: BTreeMap<PathBuf, PathBuf>,
    staged: Vec<Staged>,
}

impl Txn {
    fn covers(&self, target: &Path) -> Option<usize> {
        self.roots.iter().filter(|r| target.starts_with(r)).map(|r| r.components().count()).max()
    }

    fn discard(&mut self) {
        for s in self.staged.drain(..) {
            let _ = std::fs::remove_file(&s.tmp);
        }
        for (_, stage) in std::mem::take(&mut self.stages) {
            let _ = std::fs::remove_dir_all(&stage);
        }
    }
}

#[derive(Debug, Default)]
struct Registry {
    next_id: u64,
    txns: Vec<Txn>,
    /// Temporary files of writes outside any transaction, removed on a signal.
    loose: Vec<PathBuf>,
}

fn registry() -> MutexGuard<'static, Registry> {
    static REG: OnceLock<Mutex<Registry>> = OnceLock::new();
    // A panic while holding the lock leaves plain data behind: keep using it.
    REG.get_or_init(Default::default).lock().unwrap_or_else(|p| p.into_inner())
}

/// Is process `pid` gone (so its leftovers may be removed)?
fn process_gone(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else { return false };
        // SAFETY: kill with signal 0 only checks for the process; no signal is sent.
        let r = unsafe { libc::kill(pid, 0) };
        r != 0 && io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        false
    }
}

/// Removes staging folders and temporary files in `dir` left by processes that no longer exist
/// (SIGKILL, power loss).
fn clean_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let pid_str = if let Some(rest) = name.strip_prefix(STAGE_PREFIX) {
            rest.split('-').next()
        } else if let Some((_, rest)) = name.split_once(TMP_INFIX) {
            rest.split('-').next()
        } else {
            continue;
        };
        let Some(pid) = pid_str.and_then(|s| s.parse::<u32>().ok()) else { continue };
        if pid == std::process::id() || !process_gone(pid) {
            continue;
        }
        let p = e.path();
        match e.file_type() {
            Ok(t) if t.is_dir() => {
                let _ = std::fs::remove_dir_all(&p);
            }
            Ok(t) if t.is_file() => {
                let _ = std::fs::remove_file(&p);
            }
            _ => {}
        }
    }
}

/// A new file created with `O_EXCL` (never through a link), readable like a normal output.
fn create_new(path: &Path) -> io::Result<File> {
    let mut o = OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.mode(0o644);
    }
    o.open(path)
}

/// A command's outputs as one transaction: files written under its roots while it is open
/// are staged and appear together at [`Outputs::commit`]; dropped without a commit, nothing
/// staged remains.
#[derive(Debug)]
pub struct Outputs {
    id: u64,
    committed: bool,
}

impl Outputs {
    /// Opens a transaction over `roots` (output folders or single output files, existing or
    /// not) that refuses to overwrite any of `inputs`.
    pub fn begin(roots: &[&Path], inputs: &[(&str, &Path)]) -> Self {
        let mut reg = registry();
        reg.next_id += 1;
        let id = reg.next_id;
        let roots = roots.iter().map(|r| resolve(r)).collect();
        let inputs = inputs.iter().map(|(w, p)| Input::new(w, p)).collect();
        reg.txns.push(Txn {
            id,
            thread: std::thread::current().id(),
            roots,
            inputs,
            stages: BTreeMap::new(),
            staged: Vec::new(),
        });
        Self { id, committed: false }
    }

    /// Checks that `target` may be written by this transaction (not a link, not a special
    /// file, not an input), before any work is done.
    pub fn check(&self, target: &Path) -> Result<(), OutputError> {
        let resolved = resolve_target(target)?;
        check_target_kind(target, &resolved)?;
        let reg = registry();
        if let Some(t) = reg.txns.iter().find(|t| t.id == self.id) {
            for i in &t.inputs {
                i.check(target, &resolved)?;
            }
        }
        Ok(())
    }

    /// The files staged so far (their final paths, as given).
    pub fn staged(&self) -> Vec<PathBuf> {
        let reg = registry();
        reg.txns
            .iter()
            .find(|t| t.id == self.id)
            .map(|t| t.staged.iter().map(|s| s.shown.clone()).collect())
            .unwrap_or_default()
    }

    /// Moves every staged file into place, all or none; returns their final paths.
    pub fn commit(mut self) -> Result<Vec<PathBuf>, OutputError> {
        self.committed = true;
        let mut reg = registry();
        let Some(pos) = reg.txns.iter().position(|t| t.id == self.id) else { return Ok(Vec::new()) };
        let mut txn = reg.txns.remove(pos);
        let r = commit_txn(&mut txn);
        txn.discard();
        drop(reg);
        r
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        let mut reg = registry();
        if let Some(pos) = reg.txns.iter().position(|t| t.id == self.id) {
            let mut txn = reg.txns.remove(pos);
            txn.discard();
        }
    }
}

/// An exclusive advisory lock on a folder, released when dropped.
struct FolderLock(#[allow(dead_code)] File);

fn lock_folder(dir: &Path) -> Result<FolderLock, OutputError> {
    let f = File::open(dir).map_err(io_err("opening the output folder", dir))?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        loop {
            // SAFETY: flock on a descriptor we own; released when the file is closed.
            let r = unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX) };
            if r == 0 {
                break;
            }
            let e = io::Error::last_os_error();
            if e.kind() != io::ErrorKind::Interrupted {
                return Err(OutputError::Io {
                    action: "locking the output folder",
                    path: dir.to_path_buf(),
                    source: e,
                });
            }
        }
    }
    Ok(FolderLock(f))
}

fn sync_folder(dir: &Path) {
    // Durability of the renames; a folder that cannot be opened for sync is not an error here.
    if let Ok(f) = File::open(dir) {
        let _ = f.sync_all();
    }
}

fn commit_txn(txn: &mut Txn) -> Result<Vec<PathBuf>, OutputError> {
    // Lock every output folder, in a fixed order, for the whole set of renames.
    let mut folders: Vec<PathBuf> =
        txn.staged.iter().filter_map(|s| s.target.parent().map(Path::to_path_buf)).collect();
    folders.sort();
    folders.dedup();
    let mut locks = Vec::with_capacity(folders.len());
    for f in &folders {
        locks.push(lock_folder(f)?);
    }
    // Re-check under the lock: another process may have planted something since staging.
    for s in &txn.staged {
        check_target_kind(&s.shown, &s.target)?;
        for i in &txn.inputs {
            i.check(&s.shown, &s.target)?;
        }
    }
    // Keep the previous files (hard links in the staging folder) to restore on a failure.
    let mut backups: Vec<Option<PathBuf>> = Vec::with_capacity(txn.staged.len());
    for (k, s) in txn.staged.iter().enumerate() {
        let backup = match (std::fs::symlink_metadata(&s.target), s.target.parent().and_then(|p| txn.stages.get(p))) {
            (Ok(_), Some(stage)) => {
                let b = stage.join(format!(".previous-{k}"));
                std::fs::hard_link(&s.target, &b).ok().map(|_| b)
            }
            _ => None,
        };
        backups.push(backup);
    }
    for (k, s) in txn.staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(&s.tmp, &s.target) {
            for (done, backup) in txn.staged.iter().zip(&backups).take(k) {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, &done.target);
                    }
                    None => {
                        let _ = std::fs::remove_file(&done.target);
                    }
                }
            }
            return Err(OutputError::Io {
                action: "moving the finished file into place at",
                path: s.shown.clone(),
                source: e,
            });
        }
    }
    for f in &folders {
        sync_folder(f);
    }
    drop(locks);
    Ok(txn.staged.iter().map(|s| s.shown.clone()).collect())
}

/// Where an [`AtomicFile`]'s bytes go until it is committed.
#[derive(Debug)]
enum Dest {
    /// Staged in transaction `txn`: at commit the file joins the transaction's set.
    Staged { txn: u64 },
    /// A lone temporary file renamed over the target at commit.
    Loose,
}

/// A file being written: a temporary file until [`AtomicFile::commit`]; dropped without a
/// commit, the temporary file is removed and the target is left as it was.
pub struct AtomicFile {
    shown: PathBuf,
    target: PathBuf,
    tmp: PathBuf,
    dest: Dest,
    w: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target` (its folder must exist). Refuses a target that is a link, a
    /// directory, a device, a FIFO, a socket, or an input of a transaction covering it.
    pub fn create(target: &Path) -> io::Result<Self> {
        Ok(Self::try_create(target)?)
    }

    /// [`AtomicFile::create`] with the typed error.
    pub fn try_create(target: &Path) -> Result<Self, OutputError> {
        let resolved = resolve_target(target)?;
        check_target_kind(target, &resolved)?;
        let parent = resolved.parent().unwrap_or(Path::new("/")).to_path_buf();
        let name = resolved.file_name().ok_or_else(|| OutputError::NoFileName { path: target.to_path_buf() })?;
        let mut reg = registry();
        reg.next_id += 1;
        let serial = reg.next_id;
        let me = std::thread::current().id();
        let best =
            reg.txns.iter().enumerate().filter_map(|(i, t)| t.covers(&resolved).map(|d| (t.thread == me, d, i))).max();
        let (tmp, dest) = match best.and_then(|(_, _, i)| reg.txns.get_mut(i)) {
            Some(txn) => {
                for inp in &txn.inputs {
                    inp.check(target, &resolved)?;
                }
                let stage = match txn.stages.get(&parent) {
                    Some(s) => s.clone(),
                    None => {
                        clean_stale(&parent);
                        let prefix = format!("{STAGE_PREFIX}{}-", std::process::id());
                        let dir = tempfile::Builder::new()
                            .prefix(&prefix)
                            .rand_bytes(8)
                            .tempdir_in(&parent)
                            .map_err(io_err("creating a staging folder in", &parent))?
                            .keep();
                        txn.stages.insert(parent.clone(), dir.clone());
                        dir
                    }
                };
                let tmp = stage.join(format!("{serial}-{}", name.to_string_lossy()));
                (tmp, Dest::Staged { txn: txn.id })
            }
            None => {
                clean_stale(&parent);
                let prefix = format!(".{}{TMP_INFIX}{}-", name.to_string_lossy(), std::process::id());
                let named = tempfile::Builder::new()
                    .prefix(&prefix)
                    .rand_bytes(8)
                    .tempfile_in(&parent)
                    .map_err(io_err("creating a temporary file for", target))?;
                let (f, p) = named.keep().map_err(|e| OutputError::Io {
                    action: "creating a temporary file for",
                    path: target.to_path_buf(),
                    source: e.error,
                })?;
                reg.loose.push(p.clone());
                drop(reg);
                return Ok(Self {
                    shown: target.to_path_buf(),
                    target: resolved,
                    tmp: p,
                    dest: Dest::Loose,
                    w: Some(BufWriter::new(f)),
                });
            }
        };
        drop(reg);
        let f = create_new(&tmp).map_err(io_err("creating a staged file for", target))?;
        Ok(Self { shown: target.to_path_buf(), target: resolved, tmp, dest, w: Some(BufWriter::new(f)) })
    }

    /// The file this will become.
    pub fn target(&self) -> &Path {
        &self.shown
    }

    /// Flushes and syncs the bytes, then either renames the file over the target (no
    /// transaction covers it) or hands it to the covering transaction.
    pub fn commit(mut self) -> io::Result<()> {
        Ok(self.try_commit()?)
    }

    fn try_commit(&mut self) -> Result<(), OutputError> {
        let w = self.w.take().ok_or_else(|| OutputError::Io {
            action: "committing",
            path: self.shown.clone(),
            source: io::Error::other("already committed"),
        })?;
        let f = w.into_inner().map_err(|e| OutputError::Io {
            action: "writing",
            path: self.shown.clone(),
            source: e.into_error(),
        });
        let f = match f {
            Ok(f) => f,
            Err(e) => {
                self.abandon();
                return Err(e);
            }
        };
        if let Err(e) = f.sync_all() {
            self.abandon();
            return Err(OutputError::Io { action: "writing", path: self.shown.clone(), source: e });
        }
        drop(f);
        let mut reg = registry();
        match self.dest {
            Dest::Staged { txn } => match reg.txns.iter_mut().find(|t| t.id == txn) {
                Some(t) => {
                    // A second write of the same file in one transaction replaces the first.
                    if let Some(old) = t.staged.iter().position(|s| s.target == self.target) {
                        let s = t.staged.remove(old);
                        let _ = std::fs::remove_file(&s.tmp);
                    }
                    t.staged.push(Staged {
                        shown: self.shown.clone(),
                        target: self.target.clone(),
                        tmp: self.tmp.clone(),
                    });
                    Ok(())
                }
                None => {
                    drop(reg);
                    let _ = std::fs::remove_file(&self.tmp);
                    Err(OutputError::Io {
                        action: "committing",
                        path: self.shown.clone(),
                        source: io::Error::other("its output transaction has already ended"),
                    })
                }
            },
            Dest::Loose => {
                reg.loose.retain(|p| p != &self.tmp);
                let r = check_target_kind(&self.shown, &self.target).and_then(|()| {
                    std::fs::rename(&self.tmp, &self.target)
                        .map_err(io_err("moving the finished file into place at", &self.shown))
                });
                if r.is_err() {
                    let _ = std::fs::remove_file(&self.tmp);
                } else if let Some(p) = self.target.parent() {
                    sync_folder(p);
                }
                r
            }
        }
    }

    fn abandon(&mut self) {
        let _ = std::fs::remove_file(&self.tmp);
        if let Dest::Loose = self.dest {
            registry().loose.retain(|p| p != &self.tmp);
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.w {
            Some(w) => w
                .write(buf)
                .map_err(|e| OutputError::Io { action: "writing", path: self.shown.clone(), source: e }.into()),
            None => Err(io::Error::other(format!("{}: write after commit", self.shown.display()))),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match &mut self.w {
            Some(w) => {
                w.flush().map_err(|e| OutputError::Io { action: "writing", path: self.shown.clone(), source: e }.into())
            }
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.w.take().is_some() {
            self.abandon();
        }
    }
}

/// Writes `bytes` to `path` through an [`AtomicFile`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// Creates the output folder `dir` (and its parents); a file, device or other non-folder
/// there is an error naming it.
pub fn create_dir(dir: &Path) -> Result<(), OutputError> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => return Ok(()),
        Ok(m) => return Err(OutputError::NotRegular { path: dir.to_path_buf(), kind: not_a_folder(&m.file_type()) }),
        Err(_) => {}
    }
    std::fs::create_dir_all(dir).map_err(io_err("creating the output folder", dir))
}

fn not_a_folder(ft: &std::fs::FileType) -> &'static str {
    if ft.is_file() { "regular file where an output folder was asked for" } else { kind_of(ft) }
}

/// Opens a diagnostic log that must survive a failed run (QEMU's console output): not staged,
/// truncated if present, never through a link, never a device or any other non-regular file.
pub fn open_log(path: &Path) -> Result<File, OutputError> {
    let resolved = resolve_target(path)?;
    check_target_kind(path, &resolved)?;
    let mut o = OpenOptions::new();
    o.write(true).create(true).truncate(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW).mode(0o644);
    }
    o.open(&resolved).map_err(io_err("opening the log", path))
}

/// Removes everything staged by every open transaction and every lone temporary file.
fn discard_all(reg: &mut Registry) {
    for t in &mut reg.txns {
        t.discard();
    }
    for p in reg.loose.drain(..) {
        let _ = std::fs::remove_file(&p);
    }
}

/// Starts a thread that, on SIGINT, SIGTERM or SIGHUP, removes every staged and temporary
/// file (after a commit in progress has finished) and exits with 128 + the signal number.
/// Call once from a binary's `main`; later calls do nothing.
pub fn install_signal_cleanup() -> io::Result<()> {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
        std::thread::Builder::new().name("output-cleanup".into()).spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let mut reg = registry();
                discard_all(&mut reg);
                // Exit while holding the lock: no commit can start after the cleanup.
                std::process::exit(128 + sig);
            }
        })?;
    }
    let _ = INSTALLED.set(());
    Ok(())
}

#[cfg(test)]
mod tests;
