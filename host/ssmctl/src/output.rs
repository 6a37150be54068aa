//! Writing data files: every writer of a data set, blob or model goes through
//! [`AtomicFile`] (or [`write_atomic`]): the bytes go to a temporary file in the target's
//! folder, which is renamed over the target only when complete, so a failed or interrupted
//! run leaves no partial file (a `theta.csv` that `fit` would accept). A target that is one
//! of the command's own inputs is an error ([`check_not_input`]), before anything is
//! written.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// An error naming the file.
fn with_path(path: &Path, what: &str, e: io::Error) -> io::Error {
    io::Error::new(e.kind(), format!("{what} {}: {e}", path.display()))
}

/// A file being written: a temporary sibling of the target until [`AtomicFile::commit`]
/// renames it; dropped without a commit, the temporary file is removed and the target is
/// left as it was.
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    w: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target` (its folder must exist).
    pub fn create(target: &Path) -> io::Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let name = target.file_name().ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, format!("{}: not a file name", target.display()))
        })?;
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".tmp-{}-{n}", std::process::id()));
        let tmp = target.with_file_name(tmp_name);
        let f = File::create(&tmp).map_err(|e| with_path(target, "creating a temporary file for", e))?;
        Ok(Self { target: target.to_path_buf(), tmp, w: Some(BufWriter::new(f)) })
    }

    /// The file this will become.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes, syncs and renames the temporary file over the target.
    pub fn commit(mut self) -> io::Result<()> {
        let target = self.target.clone();
        let w = self.w.take().ok_or_else(|| io::Error::other("already committed"))?;
        let f = w.into_inner().map_err(|e| with_path(&target, "writing", e.into_error()))?;
        f.sync_all().map_err(|e| with_path(&target, "writing", e))?;
        drop(f);
        std::fs::rename(&self.tmp, &target).map_err(|e| with_path(&target, "renaming the temporary file to", e))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.w {
            Some(w) => w.write(buf).map_err(|e| with_path(&self.target, "writing", e)),
            None => Err(io::Error::other("write after commit")),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match &mut self.w {
            Some(w) => w.flush().map_err(|e| with_path(&self.target, "writing", e)),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.w.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` through an [`AtomicFile`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// Where `p` points, as far as it can be resolved: the canonical path if it exists, else
/// the canonical folder joined with the file name.
fn resolve(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Some(parent.canonicalize().ok()?.join(p.file_name()?))
}

/// True when `a` and `b` name the same file (same resolved path, or on Unix the same
/// device and inode: hard links).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    matches!((resolve(a), resolve(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses to write `output` when it is one of `inputs` (`export --out` equal to `--model`,
/// `fit --save` onto a data file, ...): the input would be destroyed by its own command.
pub fn check_not_input(output: &Path, inputs: &[(&str, &Path)]) -> Result<(), String> {
    for (what, input) in inputs {
        if same_file(output, input) {
            return Err(format!(
                "refusing to write {}: it is this command's input ({what} {}); choose another output path",
                output.display(),
                input.display()
            ));
        }
    }
    Ok(())
}

/// Writes a scene's run: `DIR/<scene>.csv` and `DIR/<scene>.json` (see
/// [`sim::closed_loop::output_names`]), each through an [`AtomicFile`]; returns the CSV path.
pub fn write_scene_outputs(
    scene: &sim::scene::Scene,
    traj: &sim::closed_loop::Trajectory,
    dir: &Path,
    inputs: &[(&str, &Path)],
) -> Result<PathBuf, Box<dyn std::error::Error + Send + Sync>> {
    let (csv_name, json_name) = sim::closed_loop::output_names(scene);
    let (csv, json) = (dir.join(&csv_name), dir.join(&json_name));
    check_not_input(&csv, inputs)?;
    check_not_input(&json, inputs)?;
    std::fs::create_dir_all(dir).map_err(|e| with_path(dir, "creating", e))?;
    let mut f = AtomicFile::create(&csv)?;
    traj.write_csv_to(&mut f)?;
    let text = sim::closed_loop::metadata_json(scene, traj, &csv_name)?;
    f.commit()?;
    write_atomic(&json, text.as_bytes())?;
    Ok(csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("ssmctl-output-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    /// A file appears only complete: a writer dropped before its commit (a failed run)
    /// leaves neither a partial target nor its temporary file, and an existing target is
    /// kept as it was.
    #[test]
    fn atomic_file_appears_only_when_committed() {
        let d = dir("atomic");
        let target = d.join("theta.csv");
        {
            let mut f = AtomicFile::create(&target).unwrap();
            writeln!(f, "t_s,theta_meas_rad\n0,1").unwrap();
            assert!(!target.exists(), "visible before the commit");
        }
        assert_eq!(names(&d), Vec::<String>::new());
        write_atomic(&target, b"old\n").unwrap();
        {
            let mut f = AtomicFile::create(&target).unwrap();
            f.write_all(b"partial").unwrap();
        }
        assert_eq!(std::fs::read(&target).unwrap(), b"old\n");
        let mut f = AtomicFile::create(&target).unwrap();
        f.write_all(b"new\n").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new\n");
        assert_eq!(names(&d), ["theta.csv"]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn an_input_is_not_an_output() {
        let d = dir("inputs");
        let model = d.join("m.json");
        std::fs::write(&model, "{}").unwrap();
        let e = check_not_input(&model, &[("--model", &model)]).unwrap_err();
        assert!(e.contains("--model") && e.contains("m.json"), "{e}");
        // Another spelling of the same file.
        let other = d.join(".").join("m.json");
        assert!(check_not_input(&other, &[("--model", &model)]).is_err());
        #[cfg(unix)]
        {
            let link = d.join("link.json");
            std::fs::hard_link(&model, &link).unwrap();
            assert!(check_not_input(&link, &[("--model", &model)]).is_err());
        }
        // A new file, or another existing one, is fine.
        assert!(check_not_input(&d.join("blob.bin"), &[("--model", &model)]).is_ok());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
