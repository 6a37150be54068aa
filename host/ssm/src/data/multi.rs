//! Several observables per trajectory ([`MultiSeries`]): CSV files with more than one
//! observable column, SSMLearn `.mat` trajectories (see [`crate::mat`]), time windows
//! (SSMLearn's `sliceTrajectories`) and the check that every trajectory of a set has the
//! same observables.
//!
//! Validation is that of [`TimeSeries`] applied to the shared time and to every observable:
//! finite values, strictly increasing uniform time, no constant observable, magnitudes in
//! range.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{DataError, MAX_MAGNITUDE, MIN_MAGNITUDE, TimeSeries, check_time};
use crate::mat::{MatFile, MatValue};

/// A uniformly sampled trajectory of `q >= 1` observables.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MultiSeries {
    /// Name used in error messages and reports.
    pub name: String,
    /// Sample times in seconds, strictly increasing and uniform.
    pub t: Vec<f64>,
    /// Names of the observables (CSV header entries, or `1..=q` for the rows of a `.mat` X).
    pub observables: Vec<String>,
    /// Samples, row-major `t.len() x q`: `x[n * q + i]` is observable `i` at `t[n]`.
    pub x: Vec<f64>,
}

impl From<&TimeSeries> for MultiSeries {
    /// The one-observable trajectory of a scalar series (observable named `x`); not
    /// validated again.
    fn from(ts: &TimeSeries) -> Self {
        MultiSeries { name: ts.name.clone(), t: ts.t.clone(), observables: vec!["x".into()], x: ts.x.clone() }
    }
}

impl MultiSeries {
    /// Builds and validates a trajectory (see [`MultiSeries::validate`]).
    pub fn new(name: impl Into<String>, t: Vec<f64>, observables: Vec<String>, x: Vec<f64>) -> Result<Self, DataError> {
        let ms = MultiSeries { name: name.into(), t, observables, x };
        ms.validate()?;
        Ok(ms)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Number of observables q.
    pub fn dim(&self) -> usize {
        self.observables.len()
    }

    /// Mean sampling step; `None` with fewer than 2 samples.
    pub fn dt(&self) -> Option<f64> {
        let n = self.t.len();
        match (self.t.first(), self.t.last()) {
            (Some(first), Some(last)) if n >= 2 => Some((last - first) / (n - 1) as f64),
            _ => None,
        }
    }

    /// Observable `i` as a scalar series (named `name/observable`).
    pub fn observable(&self, i: usize) -> Option<TimeSeries> {
        let q = self.dim();
        self.observables.get(i).map(|obs| TimeSeries {
            name: format!("{}/{}", self.name, obs),
            t: self.t.clone(),
            x: self.x.iter().skip(i).step_by(q).copied().collect(),
        })
    }

    /// Checks shapes, finiteness, strictly increasing uniform time and that no observable
    /// is constant; needs at least 2 samples and 1 observable.
    pub fn validate(&self) -> Result<(), DataError> {
        let name = &self.name;
        let q = self.dim();
        if q == 0 {
            return Err(DataError::NoObservables { name: name.clone() });
        }
        if self.x.len() != self.t.len() * q {
            return Err(DataError::LengthMismatch { name: name.clone(), nt: self.t.len(), nx: self.x.len() / q });
        }
        if self.t.len() < 2 {
            return Err(DataError::TooShort {
                name: name.clone(),
                have: self.t.len(),
                need: 2,
                why: "a sampling step".into(),
            });
        }
        for (n, (&t, row)) in self.t.iter().zip(self.x.chunks_exact(q)).enumerate() {
            if !t.is_finite() {
                return Err(DataError::NonFinite { name: name.clone(), row: n + 1, column: "t".into(), value: t });
            }
            for (&v, obs) in row.iter().zip(&self.observables) {
                if !v.is_finite() {
                    return Err(DataError::NonFinite { name: name.clone(), row: n + 1, column: obs.clone(), value: v });
                }
            }
        }
        check_time(name, &self.t)?;
        for (i, (obs, &x0)) in self.observables.iter().zip(&self.x).enumerate() {
            if self.x.iter().skip(i).step_by(q).all(|&v| v == x0) {
                return Err(DataError::ConstantObservable { name: name.clone(), observable: obs.clone(), value: x0 });
            }
            // The bound of a single series, per observable: beyond it the SVD and the
            // regressions square values into overflow (an SVD that does not converge).
            let max_abs = self.x.iter().skip(i).step_by(q).fold(0.0f64, |m, v| m.max(v.abs()));
            if !(MIN_MAGNITUDE..=MAX_MAGNITUDE).contains(&max_abs) {
                return Err(DataError::Magnitude { name: format!("{name}: observable {obs}"), max_abs });
            }
        }
        Ok(())
    }

    /// The samples with `from <= t <= to` (either bound optional), as SSMLearn's
    /// `sliceTrajectories` cuts initial transients. A window that misses the data, or
    /// bounds that are not finite or not ordered, is an error naming the trajectory, the
    /// window and the data's time span; a window keeping fewer than 2 samples is
    /// [`DataError::TooShort`].
    pub fn window(&self, from: Option<f64>, to: Option<f64>) -> Result<Self, DataError> {
        let (first, last) = (self.t.first().copied().unwrap_or(f64::NAN), self.t.last().copied().unwrap_or(f64::NAN));
        let bad = |why: &str| DataError::Window {
            name: self.name.clone(),
            from: from.map_or("start".into(), |v| v.to_string()),
            to: to.map_or("end".into(), |v| v.to_string()),
            t_first: first,
            t_last: last,
            why: why.into(),
        };
        if from.is_some_and(|v| !v.is_finite()) || to.is_some_and(|v| !v.is_finite()) {
            return Err(bad("the bounds must be finite"));
        }
        if let (Some(a), Some(b)) = (from, to)
            && a >= b
        {
            return Err(bad("--from must be below --to"));
        }
        if from.is_some_and(|a| a > last) || to.is_some_and(|b| b < first) {
            return Err(bad("the window lies outside the data"));
        }
        let start = from.map_or(0, |a| self.t.partition_point(|&t| t < a));
        let end = to.map_or(self.t.len(), |b| self.t.partition_point(|&t| t <= b));
        let q = self.dim();
        let label = format!(
            "{}[t in {}..{}]",
            self.name,
            from.map_or(String::new(), |v| v.to_string()),
            to.map_or(String::new(), |v| v.to_string())
        );
        let end = end.max(start);
        let t = self.t.get(start..end).unwrap_or_default().to_vec();
        let x = self.x.get(start * q..end * q).unwrap_or_default().to_vec();
        MultiSeries::new(label, t, self.observables.clone(), x)
    }
}

impl MultiSeries {
    /// The observables named `names`, in that order (a copy); an unknown name is an error
    /// listing the available ones.
    pub fn select(&self, names: &[String]) -> Result<Self, DataError> {
        let q = self.dim();
        let idx: Vec<usize> = names
            .iter()
            .map(|n| {
                self.observables.iter().position(|o| o == n).ok_or_else(|| DataError::UnknownObservable {
                    name: self.name.clone(),
                    observable: n.clone(),
                    available: self.observables.join(", "),
                })
            })
            .collect::<Result<_, _>>()?;
        let x = self
            .x
            .chunks_exact(q.max(1))
            .flat_map(|row| idx.iter().filter_map(move |&i| row.get(i).copied()))
            .collect();
        MultiSeries::new(self.name.clone(), self.t.clone(), names.to_vec(), x)
    }
}

/// Errors unless every trajectory has the observables of the first (count, and names when
/// `names` is true); the error names the first trajectory that differs.
pub fn check_same_observables(set: &[MultiSeries], names: bool) -> Result<(), DataError> {
    let Some(first) = set.first() else { return Ok(()) };
    for s in set.iter().skip(1) {
        if s.dim() != first.dim() || (names && s.observables != first.observables) {
            return Err(DataError::ObservableMismatch {
                name: s.name.clone(),
                got: s.observables.join(", "),
                first: first.name.clone(),
                expected: first.observables.join(", "),
            });
        }
    }
    Ok(())
}

/// Loads a CSV file whose first column is the time and whose other columns are observables:
/// `columns` names the observable columns to keep (in that order), `None` keeps them all.
/// The trajectory is named after the file stem.
pub fn load_csv_observables(path: impl AsRef<Path>, columns: Option<&[String]>) -> Result<MultiSeries, DataError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let text = crate::limits::read_text_limited(path, crate::limits::MAX_DATA_FILE_BYTES)
        .map_err(|source| DataError::Io { file: file.clone(), source })?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| file.clone());
    parse_csv_observables(&file, name, &text, columns)
}

/// Parses CSV text (see [`load_csv_observables`]); `file` is used in error messages.
pub fn parse_csv_observables(
    file: &str,
    name: String,
    text: &str,
    columns: Option<&[String]>,
) -> Result<MultiSeries, DataError> {
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = match lines.next() {
        Some((_, h)) if !h.trim().is_empty() => h.split(',').map(str::trim).collect(),
        _ => return Err(DataError::NoHeader { file: file.to_string() }),
    };
    let available = || header.get(1..).unwrap_or_default().join(", ");
    let picked: Vec<usize> = match columns {
        None => (1..header.len()).collect(),
        Some(cs) => cs
            .iter()
            .map(|c| {
                header.iter().position(|h| h == c).filter(|&i| i > 0).ok_or_else(|| DataError::UnknownColumn {
                    file: file.to_string(),
                    column: c.clone(),
                    available: available(),
                })
            })
            .collect::<Result<_, _>>()?,
    };
    if picked.is_empty() {
        return Err(DataError::NoObservables { name: file.to_string() });
    }
    let observables: Vec<String> = picked.iter().filter_map(|&i| header.get(i)).map(|h| h.to_string()).collect();
    let (mut t, mut x) = (Vec::new(), Vec::new());
    for (i, line) in lines {
        let line_no = i + 1;
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        if cols.len() != header.len() || cols.iter().any(|c| c.is_empty()) {
            let found = if line.trim().is_empty() { 0 } else { cols.len() };
            return Err(DataError::Columns { file: file.to_string(), line: line_no, expected: header.len(), found });
        }
        // `cols` has one entry per header column (checked above), `picked` indexes the header.
        let parse = |k: usize, column: &str| {
            let text = cols.get(k).copied().unwrap_or_default();
            text.parse::<f64>().map_err(|_| DataError::Parse {
                file: file.to_string(),
                line: line_no,
                column: column.to_string(),
                text: text.to_string(),
            })
        };
        t.push(parse(0, "t")?);
        for (&k, obs) in picked.iter().zip(&observables) {
            x.push(parse(k, obs)?);
        }
    }
    MultiSeries::new(format!("{name} ({file})"), t, observables, x)
}

/// Loads the trajectories of an SSMLearn `.mat` file: variable `var` (SSMLearn's `xData`)
/// is an `N x 2` cell array with one row per trajectory, `{t, X}`: `t` a vector of times
/// (row or column), `X` one row per observable and one column per time. Observables are
/// named by their row of X, `1..=q`; trajectory `i` is named `FILE var{i,:}`. Every
/// trajectory must have the same number of observables. MATLAB writes this layout with
/// `save(FILE, 'xData', '-v7')`; scipy with `savemat(FILE, {'xData': cells})` where
/// `cells` is an object array of shape `(N, 2)`.
pub fn load_mat(path: impl AsRef<Path>, var: &str) -> Result<Vec<MultiSeries>, DataError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let value = MatFile::open(path)?.get(var)?;
    mat_trajectories(&file, var, &value)
}

/// The trajectories of an SSMLearn `xData` cell array already read (see [`load_mat`]).
pub fn mat_trajectories(file: &str, var: &str, value: &MatValue) -> Result<Vec<MultiSeries>, DataError> {
    let layout = |at: String, why: String| DataError::MatLayout { file: file.to_string(), var: at, why };
    let MatValue::Cell { dims, cells } = value else {
        return Err(layout(
            var.into(),
            "a double array; expected a cell array with one row {t, X} per trajectory".into(),
        ));
    };
    let [n, cols] = *dims;
    if cols != 2 || n == 0 {
        return Err(layout(
            var.into(),
            format!("a {n} x {cols} cell array; expected N x 2, one row {{t, X}} per trajectory"),
        ));
    }
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let at = |j: usize| format!("{var}{{{},{j}}}", i + 1);
        let (Some(t_cell), Some(x_cell)) = (cells.get(i), cells.get(n + i)) else {
            return Err(layout(at(1), format!("{} cells for a {n} x 2 cell array", cells.len())));
        };
        let (MatValue::Double { dims: td, data: t }, MatValue::Double { dims: xd, data: xs }) = (t_cell, x_cell) else {
            let j = if matches!(t_cell, MatValue::Cell { .. }) { 1 } else { 2 };
            return Err(layout(at(j), "a cell array; expected a double array".into()));
        };
        let [t_rows, t_cols] = *td;
        if t_rows.min(t_cols) != 1 {
            return Err(layout(at(1), format!("a {t_rows} x {t_cols} array; expected a vector of times")));
        }
        let len = t.len();
        let [q, nx] = *xd;
        if nx != len {
            let hint = if q == len {
                " (one column per observable: SSMLearn's layout has one ROW per observable, transpose X)"
            } else {
                ""
            };
            return Err(layout(at(2), format!("X is {q} x {nx} but t has {len} samples; expected q x {len}{hint}")));
        }
        // X column-major q x len: sample n, observable r is xs[n * q + r], already row-major
        // in the MultiSeries sense.
        let name = format!("{file} {var}{{{},:}}", i + 1);
        let observables = (1..=q).map(|r| r.to_string()).collect();
        out.push(MultiSeries::new(name, t.clone(), observables, xs.clone())?);
    }
    check_same_observables(&out, false)?;
    Ok(out)
}
