//! The shard file (one per shard, self-describing: format, version, spec hash, the canonical
//! spec, shard `I/N`, the cells with index and values) and the merge of a folder of them.
//!
//! [`merge`] refuses, naming the file or cell: another format or version, a file whose spec
//! does not hash to its stated hash, shards of two specs or of two shard counts, a shard
//! missing or present twice, a cell missing, present twice, in the wrong shard or with
//! values other than its grid point's. Its result does not depend on the shard count: the
//! merge of N shards is the single-process run, bit for bit.

use serde::{Deserialize, Serialize};

use super::{Cell, Shard, Sweep, hash_value};
use crate::Error;

/// `format` of a shard file.
pub const SHARD_FORMAT: &str = "ssm-sweep-shard";
/// `format` of a merged result.
pub const RESULT_FORMAT: &str = "ssm-sweep-result";

/// One shard's output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardFile {
    pub format: String,
    pub version: u32,
    pub spec_hash: String,
    pub shard: Shard,
    pub cells_total: u64,
    pub spec: Sweep,
    pub cells: Vec<Cell>,
    /// Wall time of the shard's cells (s) and the pool size: for cost per cell; not merged.
    pub wall_seconds: f64,
    pub threads: usize,
}

impl ShardFile {
    /// The file name of shard `I/N`: `shard-000I-of-000N.json` (sorts in shard order).
    pub fn file_name(shard: Shard) -> String {
        format!("shard-{:06}-of-{:06}.json", shard.index, shard.count)
    }

    /// A computed shard.
    pub fn new(
        sweep: &Sweep,
        shard: Shard,
        cells: Vec<Cell>,
        wall_seconds: f64,
        threads: usize,
    ) -> Result<Self, Error> {
        Ok(ShardFile {
            format: SHARD_FORMAT.into(),
            version: super::FORMAT_VERSION,
            spec_hash: sweep.hash()?,
            shard,
            cells_total: sweep.cells(),
            spec: sweep.clone(),
            cells,
            wall_seconds,
            threads,
        })
    }

    /// Parses a shard file's JSON (`label` names it in errors) and checks its format,
    /// version and that its spec hashes to its stated hash.
    pub fn parse(label: &str, text: &str) -> Result<Self, Error> {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| Error::Sweep(format!("{label}: not a shard file (JSON: {e})")))?;
        match (v.get("format").and_then(|f| f.as_str()), v.get("version").and_then(|f| f.as_u64())) {
            (Some(SHARD_FORMAT), Some(ver)) if ver == u64::from(super::FORMAT_VERSION) => {}
            (Some(SHARD_FORMAT), ver) => {
                let ver = ver.map_or_else(|| "missing (or not a whole number)".to_string(), |v| v.to_string());
                return Err(Error::Sweep(format!(
                    "{label}: shard file version {ver}; this build reads version {}",
                    super::FORMAT_VERSION
                )));
            }
            (f, _) => {
                let f = f.map_or_else(|| "missing (or not a string)".to_string(), |f| format!("`{f}`"));
                return Err(Error::Sweep(format!("{label}: format {f} is not `{SHARD_FORMAT}`")));
            }
        }
        let f: ShardFile = serde_path_to_error::deserialize(v)
            .map_err(|e| Error::Sweep(format!("{label}: `{}`: {}", e.path(), e.inner())))?;
        let h = hash_value(&f.spec.canonical()?);
        if h != f.spec_hash {
            return Err(Error::Sweep(format!(
                "{label}: its spec hashes to {h}, the file says {} (edited by hand?)",
                f.spec_hash
            )));
        }
        // The spec is data too: rebuilt from its parts and its grid recomputed.
        f.spec.check_embedded(label)?;
        Shard::new(f.shard.index.into(), f.shard.count.into()).map_err(|e| Error::Sweep(format!("{label}: {e}")))?;
        if f.cells_total != f.spec.cells() {
            return Err(Error::Sweep(format!(
                "{label}: cells_total {} but its spec has {} cells",
                f.cells_total,
                f.spec.cells()
            )));
        }
        Ok(f)
    }

    /// Whether this file is the complete output of `shard` of `sweep` (a re-run can skip it).
    pub fn completes(&self, sweep: &Sweep, hash: &str, shard: Shard) -> bool {
        self.spec_hash == hash && self.shard == shard && check_cells(sweep, shard, &self.cells, "").is_ok()
    }
}

/// Checks that `cells` are exactly the cells of `shard`, in order, with their grid values.
fn check_cells(sweep: &Sweep, shard: Shard, cells: &[Cell], label: &str) -> Result<(), Error> {
    let mut expect = sweep.shard_cells(shard);
    for c in cells {
        let Some(k) = expect.next() else {
            return Err(Error::Sweep(format!("{label}: cell {} is not in shard {shard} (or appears twice)", c.index)));
        };
        if c.index != k {
            if c.index < k {
                return Err(Error::Sweep(format!("{label}: cell {} duplicated or out of order", c.index)));
            }
            if c.index % u64::from(shard.count) != u64::from(shard.index) || c.index >= sweep.cells() {
                return Err(Error::Sweep(format!("{label}: cell {} does not belong to shard {shard}", c.index)));
            }
            return Err(Error::Sweep(format!("{label}: cell {k} {} is missing", sweep.describe(&sweep.values(k)))));
        }
        check_record(sweep, c, label)?;
        let v = sweep.values(k);
        if v.len() != c.values.len() || v.iter().zip(&c.values).any(|(a, b)| a.to_bits() != b.to_bits()) {
            return Err(Error::Sweep(format!(
                "{label}: cell {k} has values {:?}, its grid point is {}",
                c.values,
                sweep.describe(&v)
            )));
        }
    }
    if let Some(k) = expect.next() {
        return Err(Error::Sweep(format!("{label}: cell {k} {} is missing", sweep.describe(&sweep.values(k)))));
    }
    Ok(())
}

/// Checks that cell `c` holds exactly what `sweep` records (a chart cell in a basin sweep,
/// or a field the spec does not record, is refused).
fn check_record(sweep: &Sweep, c: &Cell, label: &str) -> Result<(), Error> {
    use super::Record;
    let has = |r: Record| sweep.record.contains(&r);
    let fields = [
        (Record::Bounded, c.bounded.is_some()),
        (Record::MaxTheta, c.max_theta.is_some()),
        (Record::Radius, c.radius.is_some()),
        (Record::Kind, c.kind.is_some()),
    ];
    for (r, present) in fields {
        if present != has(r) {
            let why = if present {
                "holds `{r}`, which this {kind} sweep does not record"
            } else {
                "lacks `{r}`, which this {kind} sweep records"
            };
            let why = why.replace("{r}", r.as_str()).replace("{kind}", sweep.kind.as_str());
            return Err(Error::Sweep(format!("{label}: cell {} {why}", c.index)));
        }
    }
    if c.escape_t.is_some() && (!has(Record::EscapeT) || c.bounded == Some(true)) {
        return Err(Error::Sweep(format!(
            "{label}: cell {} holds `escape_t`, which this sweep does not record for it",
            c.index
        )));
    }
    Ok(())
}

/// The merged sweep: the spec and every cell in index order. Independent of the shard count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepResult {
    pub format: String,
    pub version: u32,
    pub spec_hash: String,
    pub spec: Sweep,
    pub cells: Vec<Cell>,
}

/// What the merge read, besides the result: for cost per cell.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MergeStats {
    pub shards: u32,
    /// Sum over shards of wall time x pool size (core-seconds).
    pub core_seconds: f64,
    /// Sum over shards of the wall time.
    pub wall_seconds: f64,
}

/// Merges the shard files `(label, file)` (each already [`ShardFile::parse`]d).
pub fn merge(files: Vec<(String, ShardFile)>) -> Result<(SweepResult, MergeStats), Error> {
    let Some((first_label, first)) = files.first() else {
        return Err(Error::Sweep("no shard files to merge".into()));
    };
    let (hash, count) = (first.spec_hash.clone(), first.shard.count);
    for (label, f) in &files {
        if f.spec_hash != hash {
            return Err(Error::Sweep(format!(
                "shards of two specs: {first_label} is spec `{}` (hash {hash}), {label} is spec `{}` (hash {}); merge one spec's shards per folder",
                first.spec.name, f.spec.name, f.spec_hash
            )));
        }
        if f.shard.count != count {
            return Err(Error::Sweep(format!(
                "shards of two shard counts: {first_label} is shard {}, {label} is shard {}; merge one run's shards",
                first.shard, f.shard
            )));
        }
    }
    let mut by_index: Vec<Option<usize>> = vec![None; count as usize];
    for (i, (label, f)) in files.iter().enumerate() {
        let slot = &mut by_index[f.shard.index as usize];
        if let Some(j) = *slot {
            return Err(Error::Sweep(format!("shard {} appears twice: {} and {label}", f.shard, files[j].0)));
        }
        *slot = Some(i);
    }
    let missing: Vec<String> =
        by_index.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| format!("{i}/{count}")).collect();
    if !missing.is_empty() {
        let shown = missing.iter().take(10).cloned().collect::<Vec<_>>().join(", ");
        let more = if missing.len() > 10 { format!(" and {} more", missing.len() - 10) } else { String::new() };
        return Err(Error::Sweep(format!(
            "missing shard{} {shown}{more} of spec `{}` (hash {hash})",
            if missing.len() > 1 { "s" } else { "" },
            first.spec.name
        )));
    }
    let sweep = first.spec.clone();
    for (label, f) in &files {
        check_cells(&sweep, f.shard, &f.cells, label)?;
    }
    let total = sweep.cells();
    let mut stats = MergeStats { shards: count, core_seconds: 0.0, wall_seconds: 0.0 };
    for (_, f) in &files {
        stats.core_seconds += f.wall_seconds * f.threads as f64;
        stats.wall_seconds += f.wall_seconds;
    }
    // Interleave: cell k is the (k / N)-th cell of shard k mod N.
    let mut order: Vec<std::vec::IntoIter<Cell>> = vec![Vec::new().into_iter(); count as usize];
    for (_, f) in files {
        let i = f.shard.index as usize;
        order[i] = f.cells.into_iter();
    }
    let mut cells = Vec::with_capacity(usize::try_from(total).unwrap_or(0));
    for k in 0..total {
        let c = order[(k % u64::from(count)) as usize]
            .next()
            .ok_or_else(|| Error::Sweep(format!("cell {k} is missing")))?;
        cells.push(c);
    }
    Ok((
        SweepResult {
            format: RESULT_FORMAT.into(),
            version: super::FORMAT_VERSION,
            spec_hash: hash,
            spec: sweep,
            cells,
        },
        stats,
    ))
}

impl SweepResult {
    /// The result as CSV: the axis names, then what the spec records, one row per cell in
    /// index order (f64 in Rust's shortest round-trip form; `escape_t` empty when bounded).
    pub fn to_csv(&self) -> String {
        let s = &self.spec;
        let mut out: Vec<String> = vec!["index".into()];
        out.extend(s.axes.iter().map(|a| a.name.as_str().to_string()));
        out.extend(s.record.iter().map(|r| r.as_str().to_string()));
        let mut text = out.join(",") + "\n";
        for c in &self.cells {
            let mut row: Vec<String> = vec![c.index.to_string()];
            row.extend(c.values.iter().map(|v| v.to_string()));
            for r in &s.record {
                row.push(match r {
                    super::Record::Bounded => c.bounded.map(|b| b.to_string()).unwrap_or_default(),
                    super::Record::EscapeT => c.escape_t.map(|v| v.to_string()).unwrap_or_default(),
                    super::Record::MaxTheta => c.max_theta.map(|v| v.to_string()).unwrap_or_default(),
                    super::Record::Radius => c.radius.map(|v| v.to_string()).unwrap_or_default(),
                    super::Record::Kind => c.kind.map(|k| k.as_str().to_string()).unwrap_or_default(),
                });
            }
            text.push_str(&row.join(","));
            text.push('\n');
        }
        text
    }

    /// Counts for a summary line: (cells, bounded or stable cells) when recorded.
    pub fn counts(&self) -> (usize, Option<usize>) {
        let n = self.cells.len();
        let good = match self.spec.kind {
            super::Kind::Basin => self
                .spec
                .record
                .contains(&super::Record::Bounded)
                .then(|| self.cells.iter().filter(|c| c.bounded == Some(true)).count()),
            super::Kind::Chart => self
                .spec
                .record
                .contains(&super::Record::Radius)
                .then(|| self.cells.iter().filter(|c| c.radius.is_some_and(|r| r < 1.0)).count()),
        };
        (n, good)
    }
}
