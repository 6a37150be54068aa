//! Scalar time series: loading `(t, observable)` CSV files and validating sampling; several
//! observables per trajectory (CSV columns, SSMLearn `.mat` files, time windows) in [`multi`].
//!
//! A file has one header line naming the columns (a first line of numbers is an error, not
//! a lost sample), then one `t,x` pair per line (extra whitespace allowed, blank lines
//! rejected). Validation is strict: every value finite, time strictly increasing and
//! uniformly sampled (each step within a relative tolerance [`SAMPLING_RTOL`] of the
//! typical (median) step, so a missing or repeated sample is reported at the row where the
//! step changes), signal not constant. Nothing is silently dropped. Files larger than
//! [`crate::limits::MAX_DATA_FILE_BYTES`] are refused before they are read.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

pub mod multi;

pub use multi::{MultiSeries, check_same_observables, load_csv_observables, load_mat, mat_trajectories};

use std::path::Path;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Relative tolerance on each sampling step with respect to the typical (median) step.
/// (1e-4: CSV time stamps are printed rounded, e.g. to 1e-7 s on a 1/30 s grid = 3e-6 relative;
/// a dropped or repeated sample is a 100 % deviation.)
pub const SAMPLING_RTOL: f64 = 1e-4;

/// Smallest accepted magnitude (largest |x|) of a signal: below it the squares the learner
/// forms (norms, SVDs, regressions) reach the subnormal range and lose their digits.
pub const MIN_MAGNITUDE: f64 = 1e-100;
/// Largest accepted magnitude of a signal: above it the squares overflow.
pub const MAX_MAGNITUDE: f64 = 1e100;

/// A uniformly sampled scalar observable.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeSeries {
    /// Name used in error messages and reports (the file stem for loaded files).
    pub name: String,
    /// Sample times in seconds, strictly increasing and uniform.
    pub t: Vec<f64>,
    /// Observable values, same length as `t`.
    pub x: Vec<f64>,
}

/// Errors from loading or validating a time series. Rows are 1-based data rows (the header
/// is not counted); lines are 1-based file lines (the header is line 1).
#[derive(Debug, Error)]
pub enum DataError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: empty file, expected a header line `t,x`")]
    NoHeader { file: String },
    #[error(
        "{file}: line 1 `{line}` holds numbers, not column names: the file needs a header line (e.g. `t,x`) before the data"
    )]
    NumericHeader { file: String, line: String },
    #[error("{file}: line {line}: expected {expected} comma-separated columns (as the header), found {found}")]
    Columns { file: String, line: usize, expected: usize, found: usize },
    #[error(
        "{file}: {found} columns ({available}); name the observable column (`--column NAME`), the first is the time"
    )]
    ManyColumns { file: String, found: usize, available: String },
    #[error("{file}: no column `{column}` in the header (columns: {available}); the first column is the time")]
    UnknownColumn { file: String, column: String, available: String },
    #[error("{file}: line {line}: cannot parse {column} value {text:?} as a number")]
    Parse { file: String, line: usize, column: String, text: String },
    #[error("{name}: row {row}: {column} is not finite ({value})")]
    NonFinite { name: String, row: usize, column: String, value: f64 },
    #[error("{name}: t and x have different lengths ({nt} vs {nx})")]
    LengthMismatch { name: String, nt: usize, nx: usize },
    #[error("{name}: row {row}: time does not increase (t = {t_prev} then {t})")]
    NonIncreasing { name: String, row: usize, t_prev: f64, t: f64 },
    #[error(
        "{name}: row {row}: uneven sampling, the step to this row {step} differs from the typical (median) step {typical} by more than {rtol} relative"
    )]
    UnevenSampling { name: String, row: usize, step: f64, typical: f64, rtol: f64 },
    #[error("{name}: {have} samples, need at least {need} ({why})")]
    TooShort { name: String, have: usize, need: usize, why: String },
    #[error("{name}: the signal is constant (x = {value} everywhere)")]
    Constant { name: String, value: f64 },
    #[error(
        "{name}: the largest |x| is {max_abs:e}, outside [{MIN_MAGNITUDE:e}, {MAX_MAGNITUDE:e}]: squares and products of such values under- or overflow double precision (the fit would lose its digits); rescale the data"
    )]
    Magnitude { name: String, max_abs: f64 },
    #[error("{name}: observable {observable} is constant ({value} everywhere)")]
    ConstantObservable { name: String, observable: String, value: f64 },
    #[error("{name}: no observables (a trajectory needs at least one besides the time)")]
    NoObservables { name: String },
    #[error(
        "{name}: observables [{got}] differ from those of {first} [{expected}]; every trajectory needs the same observables"
    )]
    ObservableMismatch { name: String, got: String, first: String, expected: String },
    #[error("{name}: time window [{from}, {to}]: {why} (the data span t = {t_first} .. {t_last} s)")]
    Window { name: String, from: String, to: String, t_first: f64, t_last: f64, why: String },
    #[error("{name}: no observable `{observable}` (observables: {available})")]
    UnknownObservable { name: String, observable: String, available: String },
    #[error(
        "{name}: sampling step {step:e} s cannot be resolved on the time axis near t = {t:e} s (a step must be a normal number and at least {ULPS_PER_STEP} times the spacing of f64 times there)"
    )]
    TinyStep { name: String, step: f64, t: f64 },
    #[error(transparent)]
    Mat(#[from] crate::mat::MatError),
    #[error("{file}: {var}: {why}")]
    MatLayout { file: String, var: String, why: String },
}

/// A sampling step must span at least this many f64 spacings of the largest time, so the
/// rounding of the times is far below the uniformity tolerance.
pub const ULPS_PER_STEP: f64 = 1024.0;

/// Time strictly increasing and uniformly sampled (finite values and >= 2 samples checked
/// before). The typical step is the median: one missing or repeated sample changes the mean
/// of all steps (and every step would differ from it), not the median, so the error names
/// the row where the step changes.
pub(crate) fn check_time(name: &str, t: &[f64]) -> Result<(), DataError> {
    let pairs = || t.iter().zip(t.iter().skip(1));
    for (i, (&t_prev, &t_next)) in pairs().enumerate() {
        if t_next <= t_prev {
            return Err(DataError::NonIncreasing { name: name.to_string(), row: i + 2, t_prev, t: t_next });
        }
    }
    let mut steps: Vec<f64> = pairs().map(|(a, b)| b - a).collect();
    steps.sort_by(f64::total_cmp);
    let Some(&typical) = steps.get(steps.len() / 2) else {
        return Ok(()); // fewer than 2 samples: checked by the callers
    };
    let t_max = t.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !typical.is_normal() || typical < ULPS_PER_STEP * f64::EPSILON * t_max {
        return Err(DataError::TinyStep { name: name.to_string(), step: typical, t: t_max });
    }
    for (i, (&t_prev, &t_next)) in pairs().enumerate() {
        let step = t_next - t_prev;
        if (step - typical).abs() > SAMPLING_RTOL * typical {
            return Err(DataError::UnevenSampling {
                name: name.to_string(),
                row: i + 2,
                step,
                typical,
                rtol: SAMPLING_RTOL,
            });
        }
    }
    Ok(())
}

impl TimeSeries {
    /// Builds and validates a series (see [`TimeSeries::validate`]).
    pub fn new(name: impl Into<String>, t: Vec<f64>, x: Vec<f64>) -> Result<Self, DataError> {
        let ts = TimeSeries { name: name.into(), t, x };
        ts.validate()?;
        Ok(ts)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Mean sampling step `(t_last - t_first) / (n - 1)`; `None` with fewer than 2 samples.
    pub fn dt(&self) -> Option<f64> {
        let n = self.t.len();
        match (self.t.first(), self.t.last()) {
            (Some(first), Some(last)) if n >= 2 => Some((last - first) / (n - 1) as f64),
            _ => None,
        }
    }

    /// Checks lengths, finiteness, strictly increasing uniform time, and a non-constant
    /// signal. Needs at least 2 samples; embedding-specific lengths are checked by
    /// [`TimeSeries::require_len`].
    pub fn validate(&self) -> Result<(), DataError> {
        let name = &self.name;
        if self.t.len() != self.x.len() {
            return Err(DataError::LengthMismatch { name: name.clone(), nt: self.t.len(), nx: self.x.len() });
        }
        self.require_len(2, "a sampling step")?;
        for (i, (&t, &x)) in self.t.iter().zip(&self.x).enumerate() {
            for (column, value) in [("t", t), ("x", x)] {
                if !value.is_finite() {
                    return Err(DataError::NonFinite { name: name.clone(), row: i + 1, column: column.into(), value });
                }
            }
        }
        check_time(name, &self.t)?;
        let x0 = self.x.first().copied().unwrap_or_default();
        if self.x.iter().all(|&x| x == x0) {
            return Err(DataError::Constant { name: name.clone(), value: x0 });
        }
        let max_abs = self.x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(MIN_MAGNITUDE..=MAX_MAGNITUDE).contains(&max_abs) {
            return Err(DataError::Magnitude { name: name.clone(), max_abs });
        }
        Ok(())
    }

    /// Errors with [`DataError::TooShort`] unless there are at least `need` samples.
    pub fn require_len(&self, need: usize, why: &str) -> Result<(), DataError> {
        if self.t.len() < need {
            return Err(DataError::TooShort {
                name: self.name.clone(),
                have: self.t.len(),
                need,
                why: why.to_string(),
            });
        }
        Ok(())
    }

    /// The samples with `t >= t_from` (a copy, renamed with the cut), validated again.
    pub fn from_time(&self, t_from: f64) -> Result<Self, DataError> {
        let start = self.t.partition_point(|&t| t < t_from);
        TimeSeries::new(
            format!("{}[t>={t_from}]", self.name),
            self.t.get(start..).unwrap_or_default().to_vec(),
            self.x.get(start..).unwrap_or_default().to_vec(),
        )
    }
}

/// Loads a CSV file with a header line and two columns `t,x`, then validates it.
/// The series is named after the file stem.
pub fn load_csv(path: impl AsRef<Path>) -> Result<TimeSeries, DataError> {
    load_csv_column(path, None)
}

/// [`load_csv`] for a file of several columns (e.g. what `ssmctl simulate` writes): the first
/// column is the time, `column` names the observable by its header entry. With `None` the
/// file must have exactly two columns.
pub fn load_csv_column(path: impl AsRef<Path>, column: Option<&str>) -> Result<TimeSeries, DataError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let text = crate::limits::read_text_limited(path, crate::limits::MAX_DATA_FILE_BYTES)
        .map_err(|source| DataError::Io { file: file.clone(), source })?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| file.clone());
    parse_csv_column(&file, name, &text, column)
}

/// Parses two-column CSV text (see [`load_csv`]); `file` is used in error messages.
pub fn parse_csv(file: &str, name: String, text: &str) -> Result<TimeSeries, DataError> {
    parse_csv_column(file, name, text, None)
}

/// Parses CSV text (see [`load_csv_column`]); `file` is used in error messages. Every data
/// line must have as many columns as the header; every entry of the time column and of
/// the chosen column must parse (the other columns are not read).
pub fn parse_csv_column(file: &str, name: String, text: &str, column: Option<&str>) -> Result<TimeSeries, DataError> {
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = match lines.next() {
        Some((_, h)) if !h.trim().is_empty() => h.split(',').map(str::trim).collect(),
        _ => return Err(DataError::NoHeader { file: file.to_string() }),
    };
    if header.iter().all(|h| h.parse::<f64>().is_ok()) {
        let line = text.lines().next().unwrap_or_default();
        return Err(DataError::NumericHeader { file: file.to_string(), line: line.chars().take(80).collect() });
    }
    let (ncols, xcol) = match column {
        None => (2, 1),
        Some(c) => {
            let idx =
                header.iter().position(|h| *h == c).filter(|&i| i > 0).ok_or_else(|| DataError::UnknownColumn {
                    file: file.to_string(),
                    column: c.to_string(),
                    available: header.get(1..).unwrap_or_default().join(", "),
                })?;
            (header.len(), idx)
        }
    };
    if column.is_none() && header.len() > 2 {
        return Err(DataError::ManyColumns {
            file: file.to_string(),
            found: header.len(),
            available: header.join(", "),
        });
    }
    let mut t = Vec::new();
    let mut x = Vec::new();
    for (i, line) in lines {
        let line_no = i + 1;
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        let found = if line.trim().is_empty() { 0 } else { cols.len() };
        let columns = || DataError::Columns { file: file.to_string(), line: line_no, expected: ncols, found };
        if cols.len() != ncols || cols.iter().any(|c| c.is_empty()) {
            return Err(columns());
        }
        let (Some(&t_text), Some(&x_text)) = (cols.first(), cols.get(xcol)) else {
            return Err(columns());
        };
        for (col, text, out) in [("t", t_text, &mut t), ("x", x_text, &mut x)] {
            let v: f64 = text.parse().map_err(|_| DataError::Parse {
                file: file.to_string(),
                line: line_no,
                column: col.to_string(),
                text: text.to_string(),
            })?;
            out.push(v);
        }
    }
    TimeSeries::new(format!("{name} ({file})"), t, x)
}
