//! `ssmctl study SPEC.toml --data-dir DIR --out DIR`: the command-line side of
//! [`chaos_study::flag_study`]. Runs the spec on the data, writes its results files (the ones
//! [`chaos_study::study_results`] reads) and `study.json`: the spec's text, the CRC-64 of every
//! data file read and the code version, so that a result names what made it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use chaos_study::flag_study::{FlagStudySpec, run};
use chaos_study::study_results::{EXPERIMENT, HELD_OUT, VALIDATION, to_json};
use serde::Serialize;

use crate::output::write_atomic;

type BoxError = Box<dyn std::error::Error>;

/// The fingerprint of the data files (as the xtask's run cache).
const FINGERPRINT: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

/// The provenance file of a study's results.
pub const STUDY_FILE: &str = "study.json";

/// One data file the study read.
#[derive(Clone, Debug, Serialize)]
pub struct DataFile {
    pub path: PathBuf,
    pub bytes: u64,
    /// CRC-64/ECMA-182 of the file, hex.
    pub crc64: String,
}

/// `study.json`: what the results were made from.
#[derive(Clone, Debug, Serialize)]
pub struct StudyRecord {
    pub spec_file: PathBuf,
    pub spec: String,
    /// Each candidate list cut to this many (`--candidates`), or the whole spec.
    pub candidates_limit: Option<usize>,
    pub data: Vec<DataFile>,
    /// The ssmctl version and, when run from a git checkout, its commit.
    pub code_version: String,
    pub git_commit: Option<String>,
    pub files: Vec<String>,
    pub wall_seconds: f64,
}

/// The commit of the checkout the command runs in (`None` outside one).
fn git_commit() -> Option<String> {
    let out = std::process::Command::new("git").args(["rev-parse", "HEAD"]).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn fingerprint(path: &Path) -> Result<DataFile, BoxError> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(DataFile {
        path: path.to_path_buf(),
        bytes: bytes.len() as u64,
        crc64: format!("{:016x}", FINGERPRINT.checksum(&bytes)),
    })
}

/// Runs the study `spec_path` on `data_dir`, each candidate list cut to `limit` when given,
/// and writes the results to `out`; returns the record written to `out/study.json`.
pub fn study(
    spec_path: &Path,
    data_dir: &Path,
    out: &Path,
    limit: Option<usize>,
    quiet: bool,
) -> Result<StudyRecord, BoxError> {
    let t0 = Instant::now();
    let text = std::fs::read_to_string(spec_path).map_err(|e| format!("{}: {e}", spec_path.display()))?;
    let spec = FlagStudySpec::parse(&spec_path.display().to_string(), &text)?;
    let spec = limit.map_or(spec.clone(), |n| spec.limited(n));
    let mut data = Vec::new();
    for k in spec.all_runs() {
        let p = spec.run_path(data_dir, k);
        if !p.is_file() {
            return Err(format!(
                "{}: run {k} of the spec's data not found (--data-dir {}, data.folder `{}`, data.file `{}`)",
                p.display(),
                data_dir.display(),
                spec.data.folder,
                spec.data.file
            )
            .into());
        }
        data.push(fingerprint(&p)?);
    }
    let say = |s: &str| {
        if !quiet {
            eprintln!("[{:7.1} s] {s}", t0.elapsed().as_secs_f64());
        }
    };
    let r = run(&spec, data_dir, &say)?;
    crate::output::create_dir(out)?;
    let files = [
        (HELD_OUT, to_json(&r.held_out)?),
        (EXPERIMENT, to_json(&r.experiment)?),
        (VALIDATION, to_json(&r.validation)?),
    ];
    for (name, json) in &files {
        let p = out.join(name);
        write_atomic(&p, json.as_bytes()).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let record = StudyRecord {
        spec_file: spec_path.to_path_buf(),
        spec: text,
        candidates_limit: limit,
        data,
        code_version: env!("CARGO_PKG_VERSION").to_string(),
        git_commit: git_commit(),
        files: files.iter().map(|(n, _)| n.to_string()).collect(),
        wall_seconds: t0.elapsed().as_secs_f64(),
    };
    let p = out.join(STUDY_FILE);
    write_atomic(&p, (serde_json::to_string_pretty(&record)? + "\n").as_bytes())
        .map_err(|e| format!("{}: {e}", p.display()))?;
    Ok(record)
}
