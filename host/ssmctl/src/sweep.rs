//! `ssmctl sweep` and `ssmctl sweep-merge`: the command-line side of [`furuta::sweep`].
//! Which shard to compute (`--shard I/N`, else a Slurm array task, else a Kubernetes Indexed
//! Job completion index, else the whole grid), the shard file written atomically (a re-run
//! of a complete shard is skipped), and the merge of a folder of shard files into
//! `NAME.json`, `NAME.csv` and the figure `NAME.png`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use furuta::sweep::shard::{ShardFile, SweepResult, merge};
use furuta::sweep::{AxisName, Kind, Shard, Sweep, run_shard};
use serde::Serialize;

use crate::output::write_atomic;

type BoxError = Box<dyn std::error::Error>;

/// Where the shard came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ShardSource {
    Flag,
    Slurm,
    Kubernetes,
    Whole,
}

/// The shard to compute: `flag` (`--shard I/N`) wins; else `SLURM_ARRAY_TASK_ID` with
/// `SLURM_ARRAY_TASK_COUNT` (less `SLURM_ARRAY_TASK_MIN` when the array does not start at
/// 0; a step other than 1 is refused); else `JOB_COMPLETION_INDEX` with the count from
/// `shards` (`--shards`, else the spec's `shards`); else the whole grid. `env` reads a
/// variable (the process environment, or a map in tests).
pub fn pick_shard(
    flag: Option<&str>,
    shards: Option<u32>,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<(Shard, ShardSource), BoxError> {
    if let Some(s) = flag {
        return Ok((Shard::parse(s)?, ShardSource::Flag));
    }
    let num = |name: &str| -> Result<Option<u64>, BoxError> {
        match env(name) {
            None => Ok(None),
            Some(v) => {
                v.trim().parse::<u64>().map(Some).map_err(|_| format!("{name}={v}: not a non-negative integer").into())
            }
        }
    };
    if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
        let count = num("SLURM_ARRAY_TASK_COUNT")?.ok_or(
            "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not (submit with sbatch --array=0-(N-1))",
        )?;
        let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        if let Some(step) = num("SLURM_ARRAY_TASK_STEP")? {
            if step != 1 {
                return Err(format!(
                    "SLURM_ARRAY_TASK_STEP={step}: the array must be contiguous (sbatch --array=0-{})",
                    count.saturating_sub(1)
                )
                .into());
            }
        }
        let i =
            id.checked_sub(min).ok_or_else(|| format!("SLURM_ARRAY_TASK_ID={id} below SLURM_ARRAY_TASK_MIN={min}"))?;
        let shard =
            Shard::new(i, count).map_err(|e| format!("Slurm array task {id} (min {min}, count {count}): {e}"))?;
        return Ok((shard, ShardSource::Slurm));
    }
    if let Some(i) = num("JOB_COMPLETION_INDEX")? {
        let n = shards.ok_or_else(|| format!("JOB_COMPLETION_INDEX={i} is set but no shard count: pass --shards N (the Job's completions) or set `shards` in the spec"))?;
        let shard = Shard::new(i, n.into()).map_err(|e| format!("Kubernetes JOB_COMPLETION_INDEX={i}: {e}"))?;
        return Ok((shard, ShardSource::Kubernetes));
    }
    Ok((Shard::WHOLE, ShardSource::Whole))
}

/// Reads and validates a spec file.
pub fn load_spec(path: &Path) -> Result<Sweep, BoxError> {
    let text = infile::read_text(path, infile::MAX_SPEC_BYTES)
        .map_err(|e| format!("cannot read sweep spec {}: {e}", path.display()))?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Ok(Sweep::parse(&path.display().to_string(), &text, dir)?)
}

/// What `ssmctl sweep` did.
#[derive(Debug, Serialize)]
pub struct SweepRun {
    pub file: PathBuf,
    pub shard: Shard,
    pub source: ShardSource,
    pub spec_hash: String,
    pub cells: usize,
    pub cells_total: u64,
    /// `false` when a complete file of this shard and spec was already there.
    pub computed: bool,
    pub wall_seconds: f64,
    pub threads: usize,
}

/// Computes one shard of `spec` into `out` (created if needed). An existing complete file
/// of the same shard and spec is kept (idempotent re-runs); one of another spec is an
/// error unless `force`.
pub fn run(
    spec: &Path,
    out: &Path,
    shard: Option<&str>,
    shards: Option<u32>,
    force: bool,
) -> Result<SweepRun, BoxError> {
    let sweep = load_spec(spec)?;
    let (shard, source) = pick_shard(shard, shards.or(sweep.shards), &|k| std::env::var(k).ok())?;
    let hash = sweep.hash()?;
    crate::output::create_dir(out).map_err(|e| e.to_string())?;
    let file = out.join(ShardFile::file_name(shard));
    let threads = rayon::current_num_threads();
    if file.exists() && !force {
        let label = file.display().to_string();
        let text =
            infile::read_text(&file, infile::MAX_SHARD_BYTES).map_err(|e| format!("cannot read {label}: {e}"))?;
        match ShardFile::parse(&label, &text) {
            Ok(f) if f.completes(&sweep, &hash, shard) => {
                return Ok(SweepRun {
                    file,
                    shard,
                    source,
                    spec_hash: hash,
                    cells: f.cells.len(),
                    cells_total: sweep.cells(),
                    computed: false,
                    wall_seconds: f.wall_seconds,
                    threads: f.threads,
                });
            }
            Ok(f) if f.spec_hash != hash => {
                return Err(format!("{label} holds shard {} of spec `{}` (hash {}), not of this spec `{}` (hash {hash}): use another --out folder, or --force to replace it", f.shard, f.spec.name, f.spec_hash, sweep.name).into());
            }
            // Incomplete or unreadable: recompute it.
            _ => {}
        }
    }
    let t0 = Instant::now();
    let cells = run_shard(&sweep, shard)?;
    let wall_seconds = t0.elapsed().as_secs_f64();
    let n = cells.len();
    let f = ShardFile::new(&sweep, shard, cells, wall_seconds, threads)?;
    write_atomic(&file, serde_json::to_string(&f)?.as_bytes())?;
    Ok(SweepRun {
        file,
        shard,
        source,
        spec_hash: hash,
        cells: n,
        cells_total: sweep.cells(),
        computed: true,
        wall_seconds,
        threads,
    })
}

/// What `ssmctl sweep-merge` wrote.
#[derive(Debug, Serialize)]
pub struct MergeSummary {
    pub json: PathBuf,
    pub csv: PathBuf,
    pub png: Option<PathBuf>,
    pub spec: String,
    pub spec_hash: String,
    pub shards: u32,
    pub cells: usize,
    /// Bounded (basin) or stable (chart) cells, when recorded.
    pub good_cells: Option<usize>,
    /// Core-seconds of the shards per cell (their wall time x pool size / cells).
    pub core_seconds_per_cell: f64,
    /// Why no figure was drawn, if none was.
    pub figure_note: Option<String>,
}

/// Merges every `shard-*.json` of `dir` into `out` (a folder, created if needed).
pub fn merge_dir(dir: &Path, out: &Path) -> Result<MergeSummary, BoxError> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot read shard folder {}: {}", dir.display(), infile::describe(&e)))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("shard-") && n.ends_with(".json"))
        })
        .collect();
    names.sort();
    if names.is_empty() {
        return Err(format!("no shard files (shard-*.json) in {}", dir.display()).into());
    }
    let mut files = Vec::with_capacity(names.len());
    for p in &names {
        let label = p.display().to_string();
        let text = infile::read_text(p, infile::MAX_SHARD_BYTES).map_err(|e| format!("cannot read {label}: {e}"))?;
        files.push((label.clone(), ShardFile::parse(&label, &text)?));
    }
    let (result, stats) = merge(files)?;
    crate::output::create_dir(out).map_err(|e| e.to_string())?;
    let name = &result.spec.name;
    let json = out.join(format!("{name}.json"));
    let csv = out.join(format!("{name}.csv"));
    write_atomic(&json, serde_json::to_string(&result)?.as_bytes())?;
    write_atomic(&csv, result.to_csv().as_bytes())?;
    let png = out.join(format!("{name}.png"));
    let (png, figure_note) = match figure(&result, &png)? {
        None => (Some(png), None),
        Some(note) => (None, Some(note)),
    };
    let (cells, good_cells) = result.counts();
    Ok(MergeSummary {
        json,
        csv,
        png,
        spec: name.clone(),
        spec_hash: result.spec_hash.clone(),
        shards: stats.shards,
        cells,
        good_cells,
        core_seconds_per_cell: stats.core_seconds / cells.max(1) as f64,
        figure_note,
    })
}

/// Draws the result's figure to `png`; `Some(reason)` when this result has none.
fn figure(r: &SweepResult, png: &Path) -> Result<Option<String>, BoxError> {
    match r.spec.kind {
        Kind::Chart => chart_figure(r, png),
        Kind::Basin => crate::draw::basin::draw_basin(png, r).map_err(Into::into),
    }
}

/// The stability chart of a chart sweep (one panel per dt), with the D-curves computed at
/// merge time: [`crate::draw::chart::draw_chart`].
fn chart_figure(r: &SweepResult, png: &Path) -> Result<Option<String>, BoxError> {
    let s = &r.spec;
    if r.cells.iter().any(|c| c.radius.is_none() || c.kind.is_none()) {
        return Ok(Some("the chart figure needs `radius` and `kind` recorded".into()));
    }
    // The plane: kp (x) and kd (y), else the two gain or parameter axes given as ranges, the
    // later one in the spec (the faster-varying) across.
    let plane: Vec<(usize, sim::scene::axis::SceneAxis)> =
        s.scene_axes()?.into_iter().filter(|(i, _)| s.axes[*i].range.is_some()).collect();
    let classic = s.axis(AxisName::Kp).zip(s.axis(AxisName::Kd));
    let (ikp, ikd, named) = match (classic, plane.as_slice()) {
        (Some((ikp, ikd)), _) if plane.len() == 2 => (ikp, ikd, None),
        (_, [(iy, ya), (ix, xa)]) => (*ix, *iy, Some((xa.clone(), ya.clone()))),
        _ => return Ok(Some("the chart figure needs two gain or parameter axes as ranges, and no third one".into())),
    };
    let (Some(kp), Some(kd)) = (s.axes[ikp].range, s.axes[ikd].range) else {
        return Ok(Some("the chart figure needs its two axes as ranges".into()));
    };
    if s.axes.iter().enumerate().any(|(i, a)| i != ikp && i != ikd && a.name != AxisName::DtMs) {
        return Ok(Some("the chart figure draws two gain or parameter axes and dt_ms only".into()));
    }
    let idt = s.axis(AxisName::DtMs);
    let dts: Vec<f64> = idt.map_or_else(|| vec![s.scene.controller.dt_ms], |i| s.axes[i].values.clone());
    if dts.len() > sim::chart::MAX_PANELS {
        return Ok(Some(format!(
            "{} dt_ms values: a chart figure has at most {} panels (the cells are in the JSON and CSV)",
            dts.len(),
            sim::chart::MAX_PANELS
        )));
    }
    let mut panels = Vec::with_capacity(dts.len());
    for (d, &dt_ms) in dts.iter().enumerate() {
        let mut points = Vec::with_capacity(kp.n * kd.n);
        for i in 0..kd.n {
            for j in 0..kp.n {
                let mut pos = vec![0; s.axes.len()];
                pos[ikp] = j;
                pos[ikd] = i;
                if let Some(idt) = idt {
                    pos[idt] = d;
                }
                let c = &r.cells[s.index_of(&pos) as usize];
                points.push((c.radius.unwrap_or(f64::NAN), c.kind.and_then(|k| k.crossing())));
            }
        }
        panels.push(match &named {
            None => sim::stability::scene_panel(&s.scene, dt_ms, kp, kd, &points)?,
            Some((xa, ya)) => sim::stability::scene_panel_axes(&s.scene, dt_ms, (xa, kp), (ya, kd), &points)?,
        });
    }
    let (names, base_point) = match &named {
        None => (None, None),
        Some((xa, ya)) => {
            (Some([xa.name().to_string(), ya.name().to_string()]), Some((xa.value(&s.scene)?, ya.value(&s.scene)?)))
        }
    };
    let chart = sim::chart::Chart { kp, kd, base: s.scene.controller_config(), panels, names, base_point };
    crate::draw::chart::draw_chart(png, &chart)?;
    Ok(None)
}
