//! `ssmctl study SPEC.toml --data-dir DIR --out DIR`: the command-line side of
//! [`chaos_study::flag_study`]. Runs the spec on the data, writes its results files (the ones
//! [`chaos_study::study_results`] reads) and `study.json`: the spec's text, the CRC-64 of every
//! data file read and the code version, so that a result names what made it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use chaos_study::flag_study::{FlagStudySpec, run};
use chaos_study::known_system_study::{KnownSystemSpec, SeriesData, UnitRow, series_data, series_keys};
use chaos_study::selection_study::{
    Prepared, SelectionResults, SelectionSpec, evaluate, finish, load_series, prepare, prepare_series,
    result_from_json, result_json,
};
use chaos_study::study_results::{EXPERIMENT, HELD_OUT, SEARCH, VALIDATION, to_json};
use furuta::sweep::Shard;
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
    /// Selection specs: how many candidates this run computed (the others came from the
    /// cache or, in a merge, from the shard files).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub computed: Option<usize>,
    pub wall_seconds: f64,
    /// The file this record was written to (`None`: a shard's run, which writes none).
    #[serde(skip)]
    pub record_file: Option<String>,
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
    study_with(spec_path, data_dir, out, &SelectionRun { limit, quiet, ..Default::default() }, false)
}

/// [`study`] with a cache and a shard (selection specs): with `run.shard`, only that shard's
/// candidates are computed, into `out/selection-shard-I-of-N.json`; with `merge`, the shard
/// files in `out` are merged into the results (each candidate once, all of one spec and data).
pub fn study_with(
    spec_path: &Path,
    data_dir: &Path,
    out: &Path,
    opts: &SelectionRun,
    merge: bool,
) -> Result<StudyRecord, BoxError> {
    let t0 = Instant::now();
    let text = infile::read_text(spec_path, infile::MAX_SPEC_BYTES)
        .map_err(|e| format!("{}: cannot read the study spec: {e}", spec_path.display()))?;
    let origin = spec_path.display().to_string();
    match chaos_study::selection_study::spec_kind(&origin, &text)?.as_deref() {
        None => {}
        Some(chaos_study::known_system_study::KIND) => {
            let spec = KnownSystemSpec::parse(&origin, &text)?;
            return known_system_study(spec_path, &text, &spec, out, opts, merge, t0);
        }
        Some(_) => {
            let spec = SelectionSpec::parse(&origin, &text)?;
            return selection_study(spec_path, &text, &spec, data_dir, out, opts, merge, t0);
        }
    }
    // The flag study has no per-candidate cache; a shard or a merge is an error.
    if opts.shard.is_some() || merge {
        return Err(format!(
            "{origin}: --shard (or a Slurm/Kubernetes shard index) and --merge apply to selection specs (kind = \"selection\"); this is a flag study"
        )
        .into());
    }
    let (limit, quiet) = (opts.limit, opts.quiet);
    let spec = FlagStudySpec::parse(&origin, &text)?;
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
        computed: None,
        wall_seconds: t0.elapsed().as_secs_f64(),
        record_file: Some(STUDY_FILE.into()),
    };
    let p = out.join(STUDY_FILE);
    write_atomic(&p, (serde_json::to_string_pretty(&record)? + "\n").as_bytes())
        .map_err(|e| format!("{}: {e}", p.display()))?;
    Ok(record)
}

/// How a selection study runs: the first `limit` candidates only, a cache of per-candidate
/// results (`None`: every candidate computed, nothing kept), one shard of the candidates.
#[derive(Clone, Debug, Default)]
pub struct SelectionRun {
    pub limit: Option<usize>,
    pub cache: Option<PathBuf>,
    pub shard: Option<furuta::sweep::Shard>,
    pub quiet: bool,
}

/// The store's unit name of one candidate's result.
const CANDIDATE_UNIT: &str = "selection-candidate";

/// The store's unit name of a spec's simulated runs.
const RUNS_UNIT: &str = "selection-runs";

/// The spec's prepared series and statistics; simulated runs come from the cache `cache`
/// when it has them (keyed by the code that simulates them, the runs' definition and a
/// scene file's bytes) and are stored there when computed.
fn prepare_cached(
    spec: &SelectionSpec,
    data_dir: &Path,
    data: &[DataFile],
    cache: Option<&Path>,
) -> Result<Prepared, BoxError> {
    let (Some(sim), Some(dir)) = (&spec.data.simulated, cache) else { return Ok(prepare(spec, data_dir)?) };
    let store = fileio::store::Store::open(dir)?;
    let mut k = crate::report::cache::code_key(RUNS_UNIT, &["chaos_study"])?
        .part("simulated", serde_json::to_string(sim)?.as_bytes());
    for (i, d) in data.iter().enumerate() {
        k = k.part(&format!("scene file {i}"), d.crc64.as_bytes());
    }
    let key = k.finish();
    type Runs = (Vec<ssm::TimeSeries>, ssm::TimeSeries, bool);
    let cached: Option<Runs> =
        store.get(RUNS_UNIT, &key).and_then(|e| e.meta().ok()).and_then(|m| serde_json::from_slice(&m).ok());
    let (train, test, held_out) = match cached {
        Some(r) => r,
        None => {
            let r: Runs = load_series(spec, data_dir)?;
            let bytes = serde_json::to_vec(&r)?;
            store
                .put(RUNS_UNIT, &key, |_| Ok::<_, std::convert::Infallible>(bytes))
                .map_err(|e| format!("cache {}: {e}", store.dir().display()))?;
            r
        }
    };
    Ok(prepare_series(spec, train, test, held_out)?)
}

/// The data files of a selection spec under `data_dir`, checked to exist, with their CRC-64:
/// the training files, then the test file.
fn selection_data(spec: &SelectionSpec, data_dir: &Path) -> Result<Vec<DataFile>, BoxError> {
    if let Some(sim) = &spec.data.simulated {
        // A bundled scene is part of the code (`sim`'s fingerprint); a scene file is data.
        let p = Path::new(&sim.scene);
        return if p.is_file() { Ok(vec![fingerprint(p)?]) } else { Ok(Vec::new()) };
    }
    let mut files = spec.training_paths(data_dir);
    files.extend(spec.test_path(data_dir));
    files
        .iter()
        .map(|p| {
            if !p.is_file() {
                return Err(format!(
                    "{}: data file of the spec not found (--data-dir {})",
                    p.display(),
                    data_dir.display()
                )
                .into());
            }
            fingerprint(p)
        })
        .collect()
}

/// The key of candidate `c`'s result: the code of the crates that compute it, the
/// toolchain, the estimator settings, the candidate (fit options, step, refits), the column,
/// the simulated runs and the data files' bytes (in their roles).
fn candidate_key(
    spec: &SelectionSpec,
    c: &chaos_study::model_selection::Candidate,
    data: &[DataFile],
) -> Result<fileio::store::Key, BoxError> {
    let mut k = crate::report::cache::code_key(CANDIDATE_UNIT, &["chaos_study"])?
        .part("statistics", serde_json::to_string(&spec.statistics)?.as_bytes())
        .part("column", spec.data.column.as_deref().unwrap_or("").as_bytes())
        .part("test held out", &[u8::from(spec.data.test.is_some())])
        .part("simulated", serde_json::to_string(&spec.data.simulated)?.as_bytes())
        .part("candidate", serde_json::to_string(c)?.as_bytes());
    for (i, d) in data.iter().enumerate() {
        k = k.part(&format!("data {i}"), d.crc64.as_bytes()).part(&format!("bytes {i}"), &d.bytes.to_le_bytes());
    }
    Ok(k.finish())
}

/// The candidate results of a run: (index, result) in the spec's order, and how many were
/// computed (the others came from the cache).
#[derive(Clone, Debug)]
pub struct Rows {
    pub rows: Vec<(usize, serde_json::Value)>,
    pub computed: usize,
}

/// The units `mine` of a shard (all without one) in `run.shard`.
fn shard_units(n: usize, run: &SelectionRun) -> Vec<usize> {
    (0..n).filter(|i| run.shard.is_none_or(|s| (*i as u64) % u64::from(s.count) == u64::from(s.index))).collect()
}

/// The values of units `mine` (keys `keys`, in the same order), each read from `store` under
/// `unit` when it holds one that `valid` accepts, else computed by `compute` (on the rayon
/// pool) and stored: (index, value) in the given order, and how many were computed.
fn cached_units(
    store: Option<&fileio::store::Store>,
    unit: &str,
    mine: &[usize],
    keys: &[fileio::store::Key],
    valid: &(dyn Fn(&serde_json::Value) -> bool + Sync),
    compute: &(dyn Fn(usize) -> Result<serde_json::Value, BoxError> + Sync),
) -> Result<Rows, BoxError> {
    use rayon::prelude::*;
    let rows: Vec<Result<(usize, serde_json::Value, bool), String>> = mine
        .par_iter()
        .zip(keys)
        .map(|(&i, key)| {
            if let Some(e) = store.and_then(|s| s.get(unit, key)) {
                // An entry that does not read back is computed again.
                let v = e.meta().ok().and_then(|m| serde_json::from_slice::<serde_json::Value>(&m).ok());
                if let Some(v) = v.filter(|v| valid(v)) {
                    return Ok((i, v, false));
                }
            }
            let v = compute(i).map_err(|e| e.to_string())?;
            if let Some(store) = store {
                let bytes = serde_json::to_vec(&v).map_err(|e| e.to_string())?;
                store
                    .put(unit, key, |_| Ok::<_, std::convert::Infallible>(bytes))
                    .map_err(|e| format!("cache {}: {e}", store.dir().display()))?;
            }
            Ok((i, v, true))
        })
        .collect();
    if let Some(s) = store {
        s.finish_run()?;
    }
    let rows: Vec<(usize, serde_json::Value, bool)> = rows.into_iter().collect::<Result<_, _>>()?;
    let computed = rows.iter().filter(|r| r.2).count();
    Ok(Rows { rows: rows.into_iter().map(|(i, v, _)| (i, v)).collect(), computed })
}

/// The candidate results of a selection spec: the candidates of `shard` (all without one),
/// each from the cache or computed, as (index, result) in the spec's order.
pub fn selection_rows(
    spec: &SelectionSpec,
    p: &Prepared,
    data: &[DataFile],
    run: &SelectionRun,
    say: &dyn Fn(&str),
) -> Result<Rows, BoxError> {
    let store = run.cache.as_deref().map(fileio::store::Store::open).transpose()?;
    let mine = shard_units(p.candidates.len(), run);
    let keys: Vec<fileio::store::Key> =
        mine.iter().map(|&i| candidate_key(spec, &p.candidates[i], data)).collect::<Result<_, _>>()?;
    let cached = store.as_ref().map_or(0, |s| keys.iter().filter(|k| s.get(CANDIDATE_UNIT, k).is_some()).count());
    say(&format!("{} candidates, {cached} in the cache", mine.len()));
    cached_units(store.as_ref(), CANDIDATE_UNIT, &mine, &keys, &|v| result_from_json(v).is_ok(), &|i| {
        Ok(result_json(&evaluate(p, i)?)?)
    })
}

/// Runs the selection spec on `data_dir` and selects (every candidate; `run.shard` is not
/// used): the results file, the data files read and how many candidates were computed.
pub fn run_selection(
    spec: &SelectionSpec,
    data_dir: &Path,
    run: &SelectionRun,
    say: &dyn Fn(&str),
) -> Result<(SelectionResults, Vec<DataFile>, usize), BoxError> {
    let spec = run.limit.map_or(spec.clone(), |n| spec.limited(n));
    let data = selection_data(&spec, data_dir)?;
    let p = prepare_cached(&spec, data_dir, &data, run.cache.as_deref())?;
    for (ds, ctx) in &p.data {
        say(&format!(
            "test series {}: {} samples at map step {}, lag {}, Theiler {}",
            p.test.name, ds.len, ds.step, ctx.lag, ctx.theiler
        ));
    }
    let whole = SelectionRun { shard: None, ..run.clone() };
    let rows = selection_rows(&spec, &p, &data, &whole, say)?;
    let r = finish(&spec, &p, rows.rows.into_iter().map(|(_, v)| v).collect())?;
    Ok((r, data, rows.computed))
}

/// The prefix of a selection study's shard files.
const SHARD_PREFIX: &str = "selection-shard-";

/// The results file of a selection study.
pub const SELECTION_FILE: &str = "selection.json";

/// One shard's candidate results: the spec and data they are of, and (index, result) rows.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct SelectionShard {
    pub format: String,
    /// CRC-64 of the spec (as run) and of the data files.
    pub spec_hash: String,
    pub shard: Shard,
    pub candidates: usize,
    pub rows: Vec<(usize, serde_json::Value)>,
}

const SHARD_FORMAT: &str = "ssmctl selection shard v1";

fn selection_hash(spec: &SelectionSpec, data: &[DataFile]) -> Result<String, BoxError> {
    let mut bytes = serde_json::to_vec(spec)?;
    for d in data {
        bytes.extend_from_slice(d.crc64.as_bytes());
    }
    Ok(format!("{:016x}", FINGERPRINT.checksum(&bytes)))
}

/// The shard files in `out` merged: every candidate of `n` once, all of spec hash `hash`.
fn merge_shards(out: &Path, prefix: &str, hash: &str, n: usize) -> Result<Vec<serde_json::Value>, BoxError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(out)
        .map_err(|e| format!("{}: cannot list the shard files: {e}", out.display()))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().and_then(|f| f.to_str()).is_some_and(|f| f.starts_with(prefix)))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(format!("{}: no {prefix}*.json files to merge", out.display()).into());
    }
    let mut slots: Vec<Option<serde_json::Value>> = vec![None; n];
    for f in &files {
        let text = infile::read_text(f, infile::MAX_DATA_BYTES).map_err(|e| format!("{}: {e}", f.display()))?;
        let s: SelectionShard = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", f.display()))?;
        if s.format != SHARD_FORMAT {
            return Err(format!("{}: format `{}`, expected `{SHARD_FORMAT}`", f.display(), s.format).into());
        }
        if s.spec_hash != hash || s.candidates != n {
            return Err(format!(
                "{}: a shard of another spec or data (hash {}, {} candidates; this run: {hash}, {n})",
                f.display(),
                s.spec_hash,
                s.candidates
            )
            .into());
        }
        for (i, v) in s.rows {
            let slot = slots.get_mut(i).ok_or_else(|| format!("{}: candidate {i} of {n}", f.display()))?;
            if slot.replace(v).is_some() {
                return Err(format!("{}: candidate {i} is in more than one shard file", f.display()).into());
            }
        }
    }
    let missing: Vec<usize> = slots.iter().enumerate().filter(|(_, v)| v.is_none()).map(|(i, _)| i).collect();
    if !missing.is_empty() {
        return Err(format!("{}: candidates {missing:?} are in no shard file", out.display()).into());
    }
    Ok(slots.into_iter().flatten().collect())
}

/// The progress printer of a study run (silent with `--quiet`), after refusing `--merge` with
/// `--shard`.
fn progress(opts: &SelectionRun, merge: bool, t0: Instant) -> Result<impl Fn(&str) + Sync, BoxError> {
    if merge && opts.shard.is_some() {
        return Err("--merge and --shard: merge the shard files in a run of its own".into());
    }
    let quiet = opts.quiet;
    Ok(move |s: &str| {
        if !quiet {
            eprintln!("[{:7.1} s] {s}", t0.elapsed().as_secs_f64());
        }
    })
}

/// Writes shard `shard` of a study's `n` units (`rows`, of spec hash `hash`) to
/// `out/PREFIX-I-of-N.json`; returns the file's name.
fn write_shard(
    out: &Path,
    prefix: &str,
    hash: String,
    shard: Shard,
    n: usize,
    rows: Vec<(usize, serde_json::Value)>,
) -> Result<String, BoxError> {
    let s = SelectionShard { format: SHARD_FORMAT.into(), spec_hash: hash, shard, candidates: n, rows };
    let name = format!("{prefix}{}-of-{}.json", shard.index, shard.count);
    let path = out.join(&name);
    write_atomic(&path, (serde_json::to_string_pretty(&s)? + "\n").as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(name)
}

/// The record of a study run, written to `out/RECORD` (`record_file`, [`STUDY_FILE`] but for
/// known-system specs that name their files) unless the run is one shard.
#[allow(clippy::too_many_arguments)]
fn record(
    spec_path: &Path,
    text: &str,
    opts: &SelectionRun,
    out: &Path,
    record_file: &str,
    data: Vec<DataFile>,
    file: String,
    computed: usize,
    t0: Instant,
) -> Result<StudyRecord, BoxError> {
    let record = StudyRecord {
        spec_file: spec_path.to_path_buf(),
        spec: text.to_string(),
        candidates_limit: opts.limit,
        data,
        code_version: env!("CARGO_PKG_VERSION").to_string(),
        git_commit: git_commit(),
        files: vec![file],
        computed: Some(computed),
        wall_seconds: t0.elapsed().as_secs_f64(),
        record_file: opts.shard.is_none().then(|| record_file.to_string()),
    };
    if opts.shard.is_none() {
        let p = out.join(record_file);
        write_atomic(&p, (serde_json::to_string_pretty(&record)? + "\n").as_bytes())
            .map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(record)
}

#[allow(clippy::too_many_arguments)]
fn selection_study(
    spec_path: &Path,
    text: &str,
    spec: &SelectionSpec,
    data_dir: &Path,
    out: &Path,
    opts: &SelectionRun,
    merge: bool,
    t0: Instant,
) -> Result<StudyRecord, BoxError> {
    let say = progress(opts, merge, t0)?;
    let spec = opts.limit.map_or(spec.clone(), |n| spec.limited(n));
    let data = selection_data(&spec, data_dir)?;
    let hash = selection_hash(&spec, &data)?;
    let p = prepare_cached(&spec, data_dir, &data, opts.cache.as_deref())?;
    let n = p.candidates.len();
    crate::output::create_dir(out)?;
    let mut computed = 0;
    let file = match (opts.shard, merge) {
        (Some(shard), _) => {
            let rows = selection_rows(&spec, &p, &data, opts, &say)?;
            computed = rows.computed;
            write_shard(out, SHARD_PREFIX, hash, shard, n, rows.rows)?
        }
        (None, merge) => {
            let rows = if merge {
                merge_shards(out, SHARD_PREFIX, &hash, n)?
            } else {
                let rows = selection_rows(&spec, &p, &data, opts, &say)?;
                computed = rows.computed;
                rows.rows.into_iter().map(|(_, v)| v).collect()
            };
            let r = finish(&spec, &p, rows)?;
            say(&format!("picked: {}", r.selection.name.as_deref().unwrap_or("none")));
            // A search spec's result is the search table; a selection spec's, the pick.
            let (name, json) = if spec.kind == chaos_study::selection_study::SEARCH_KIND {
                let rows = r
                    .candidates
                    .iter()
                    .map(|v| result_from_json(v).map(|c| chaos_study::selection_study::search_row(&c)))
                    .collect::<Result<_, _>>()?;
                let produced_by = format!("ssmctl study {} --data-dir {}", spec_path.display(), data_dir.display());
                (SEARCH, to_json(&chaos_study::study_results::SearchResults { produced_by, rows })?)
            } else {
                (SELECTION_FILE, serde_json::to_string_pretty(&r)? + "\n")
            };
            let path = out.join(name);
            write_atomic(&path, json.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))?;
            name.to_string()
        }
    };
    record(spec_path, text, opts, out, STUDY_FILE, data, file, computed, t0)
}

/// The store's unit name of one known-system row.
const KNOWN_UNIT: &str = "known-system-row";

/// A known-system spec (`kind = "known-system"`): every row of the check and the diagnosis a
/// unit of the cache and of a shard; the series a computed row needs are simulated and
/// measured once per run. Writes `known_system.json` (or a shard file) and `study.json`, or
/// the files the spec's `results` names ([`KnownSystemSpec::files`]).
fn known_system_study(
    spec_path: &Path,
    text: &str,
    spec: &KnownSystemSpec,
    out: &Path,
    opts: &SelectionRun,
    merge: bool,
    t0: Instant,
) -> Result<StudyRecord, BoxError> {
    let say = progress(opts, merge, t0)?;
    let origin = spec_path.display().to_string();
    let spec = opts.limit.map_or(spec.clone(), |n| spec.limited(n));
    let units = spec.units().map_err(|why| format!("{origin}: {why}"))?;
    let n = units.len();
    let files = spec.files();
    let hash = format!("{:016x}", FINGERPRINT.checksum(&serde_json::to_vec(&spec)?));
    let store = opts.cache.as_deref().map(fileio::store::Store::open).transpose()?;
    // A row's key: the code that computes it, the system, its sampling, the settings, the row.
    let base = crate::report::cache::code_key(KNOWN_UNIT, &["chaos_study"])?
        .part("system", serde_json::to_string(&spec.system)?.as_bytes())
        .part("layout", serde_json::to_string(&spec.layout)?.as_bytes())
        .part("benettin time", &spec.benettin_time.to_le_bytes())
        .part("statistics", serde_json::to_string(&spec.statistics)?.as_bytes());
    let key = |u: &chaos_study::known_system_study::Unit| -> Result<fileio::store::Key, BoxError> {
        Ok(base.clone().part("row", serde_json::to_string(u)?.as_bytes()).finish())
    };
    let mine = if merge { Vec::new() } else { shard_units(n, opts) };
    let keys: Vec<fileio::store::Key> = mine.iter().map(|&i| key(&units[i])).collect::<Result<_, _>>()?;
    let valid = |v: &serde_json::Value| serde_json::from_value::<UnitRow>(v.clone()).is_ok();
    let missing: Vec<usize> = mine
        .iter()
        .zip(&keys)
        .filter(|(_, k)| store.as_ref().and_then(|s| s.get(KNOWN_UNIT, k)).is_none())
        .map(|(&i, _)| i)
        .collect();
    // The series the computed rows need, and the reference series of the results.
    let mut needed = series_keys(missing.iter().map(|&i| &units[i]));
    if opts.shard.is_none() && !needed.contains(&spec.reference_series()) {
        needed.push(spec.reference_series());
    }
    say(&format!(
        "{} rows, {} in the cache; simulating {} series",
        mine.len(),
        mine.len() - missing.len(),
        needed.len()
    ));
    use rayon::prelude::*;
    let series: Vec<SeriesData> = needed
        .par_iter()
        .map(|&k| series_data(&spec, k).map_err(|e| e.to_string()))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    let compute = |i: usize| -> Result<serde_json::Value, BoxError> {
        let u = &units[i];
        let s = series.iter().find(|s| s.key == u.series).ok_or_else(|| format!("{}: series not prepared", u.name))?;
        let row = chaos_study::known_system_study::evaluate(&spec, u, s)?;
        say(&format!("{} (scale {}): {row:?}", u.name, u.scale));
        Ok(serde_json::to_value(row)?)
    };
    let rows = cached_units(store.as_ref(), KNOWN_UNIT, &mine, &keys, &valid, &compute)?;
    crate::output::create_dir(out)?;
    let file = if let Some(shard) = opts.shard {
        write_shard(out, &files.shard_prefix, hash, shard, n, rows.rows)?
    } else {
        let values = if merge {
            merge_shards(out, &files.shard_prefix, &hash, n)?
        } else {
            rows.rows.into_iter().map(|(_, v)| v).collect()
        };
        let rows: Vec<UnitRow> = values
            .into_iter()
            .map(serde_json::from_value)
            .collect::<Result<_, _>>()
            .map_err(|e| format!("row: {e}"))?;
        let reference =
            series.iter().find(|s| s.key == spec.reference_series()).ok_or("the reference series was not simulated")?;
        // The command without its output folder, so that a rerun elsewhere writes the same bytes.
        let produced_by = format!("ssmctl study {}", spec_path.display());
        let r = chaos_study::known_system_study::finish(&produced_by, &reference.stats, &units, rows)?;
        let path = out.join(&files.results);
        write_atomic(&path, to_json(&r)?.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))?;
        files.results.clone()
    };
    record(spec_path, text, opts, out, &files.record, Vec::new(), file, rows.computed, t0)
}
