//! Sweeps that outgrow one machine: a grid of closed-loop runs (a basin map: bounded vs
//! escape of the full system) or of exact linear stability points (a stability chart over
//! KP, KD and dt), described by one TOML spec, cut into deterministic shards that separate
//! processes (a Slurm array task, a Kubernetes Indexed Job pod, a local core) compute, and
//! merged back into the result of the single-process run, bit for bit.
//!
//! - [`Sweep::parse`]: the spec (`kind`, `scene`, `[[axes]]`, `record`, `[basin]`), validated
//!   with errors naming the key; the scene is resolved and embedded, so a shard file says
//!   everything its cells depend on ([`Sweep::canonical`], hashed by [`Sweep::hash`]).
//! - The grid: cell `k` is row-major over the axes in spec order (first axis slowest).
//!   Shard `I/N` owns the cells `k` with `k mod N = I` (interleaved, so the cheap escaping
//!   cells and the expensive bounded ones spread over the shards).
//! - [`run_shard`]: every cell of a shard on the rayon pool, collected in cell order. A cell
//!   depends only on its values (its noise seed, if any, on its index and the scene's seed),
//!   never on the shard or the thread.
//! - [`shard`]: the self-describing shard file and [`shard::merge`], which checks that every
//!   cell is present exactly once and from the same spec.
//!
//! Reuses the study's computations: basin cells are [`crate::full_system::outcome_of`] of
//! [`sim::closed_loop::simulate`] runs from the scene (mode-shaped starts by
//! [`crate::parametric::mode_start_in`]); chart cells are [`sim::stability::scene_point`],
//! the arithmetic of [`sim::stability::scene_chart`]'s grid points.

pub mod shard;

use std::path::Path;

use serde::{Deserialize, Serialize};
use sim::chart::{Axis, Crossing};
use sim::closed_loop::simulate;
use sim::scene::Scene;
use sim::scene::axis::SceneAxis;

use crate::Error;
use crate::full_system::{ESCAPE_THETA, outcome_of};
use crate::parametric::mode_start_in;

/// Format version of the canonical spec, shard files and merged results.
pub const FORMAT_VERSION: u32 = 1;

/// Most cells a sweep may have (checked before anything is allocated).
pub const MAX_CELLS: u64 = 100_000_000;

/// Most shards a sweep may be cut into.
pub const MAX_SHARDS: u32 = 1_000_000;

/// What a sweep computes per cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// Full closed-loop runs: bounded or escaping, escape time, max |theta|.
    Basin,
    /// Exact linear stability: spectral radius and the kind of the dominant multiplier.
    Chart,
}

impl Kind {
    /// The spec's name of the kind.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Basin => "basin",
            Kind::Chart => "chart",
        }
    }
}

/// A grid axis: what it sets in each cell's run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AxisName {
    /// Sampling period, ms (`controller.dt_ms`).
    DtMs,
    /// Proportional gain, V/rad.
    Kp,
    /// Derivative gain, V s/rad.
    Kd,
    /// Initial theta, rad (the plant displaced, pre-history at rest).
    Theta0,
    /// Theta amplitude (rad) of the slow mode of the cell's linearized loop in the start.
    SlowAmp,
    /// Theta amplitude (rad) of the fast mode.
    FastAmp,
    /// Phase (rad) of the slow mode.
    SlowPhase,
    /// Phase (rad) of the fast mode.
    FastPhase,
    /// Quantization step of theta, rad per count (`effects.quantization.h_adc`).
    HAdc,
    /// Seed of the sensor noise (`effects.noise.seed`), a non-negative integer.
    Seed,
    /// Any gain or plant parameter of the scene by its name (`gains.theta.p`, `x.d`,
    /// `plant.parameters.m`; [`sim::scene::axis::SceneAxis`]), checked against the scene
    /// when the spec is loaded.
    Scene(String),
}

impl AxisName {
    const ALL: [(&'static str, AxisName); 10] = [
        ("dt_ms", AxisName::DtMs),
        ("kp", AxisName::Kp),
        ("kd", AxisName::Kd),
        ("theta0", AxisName::Theta0),
        ("slow_amp", AxisName::SlowAmp),
        ("fast_amp", AxisName::FastAmp),
        ("slow_phase", AxisName::SlowPhase),
        ("fast_phase", AxisName::FastPhase),
        ("h_adc", AxisName::HAdc),
        ("seed", AxisName::Seed),
    ];

    /// The spec's name of the axis.
    pub fn as_str(&self) -> &str {
        match self {
            AxisName::Scene(n) => n,
            a => Self::ALL.iter().find(|(_, b)| b == a).map_or("?", |(s, _)| s),
        }
    }

    /// A built-in axis by name, else a scene quantity for a dotted name (resolved against
    /// the scene by [`Sweep::parse`]).
    fn parse(s: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .find(|(n, _)| *n == s)
            .map(|(_, a)| a.clone())
            .or_else(|| (s.contains('.') || s == "kphi_d").then(|| AxisName::Scene(s.into())))
    }

    fn allowed(&self, kind: Kind) -> bool {
        match kind {
            Kind::Basin => true,
            Kind::Chart => matches!(self, AxisName::DtMs | AxisName::Kp | AxisName::Kd | AxisName::Scene(_)),
        }
    }

    fn names(kind: Kind) -> Vec<&'static str> {
        Self::ALL.iter().filter(|(_, a)| a.allowed(kind)).map(|(n, _)| *n).collect()
    }

    /// The scene quantity this axis sets, for the gain and parameter axes (`kp`, `kd` and
    /// the named ones).
    pub fn scene_axis(&self, scene: &Scene) -> Option<Result<SceneAxis, sim::scene::SceneError>> {
        match self {
            AxisName::Kp | AxisName::Kd | AxisName::Scene(_) => Some(SceneAxis::parse(scene, self.as_str())),
            _ => None,
        }
    }
}

impl Serialize for AxisName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for AxisName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        AxisName::parse(&s).ok_or_else(|| serde::de::Error::custom(format!("unknown axis `{s}`")))
    }
}

/// What a cell records.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Record {
    /// Basin: whether |theta| stayed below the escape threshold for the whole run.
    Bounded,
    /// Basin: time (s) of the first sample beyond the threshold (absent when bounded).
    EscapeT,
    /// Basin: max |theta| over the run (up to the escape).
    MaxTheta,
    /// Chart: spectral radius of the non-structural multipliers.
    Radius,
    /// Chart: `stable`, or how the largest multiplier sits: `static`, `dynamic`, `flip`.
    Kind,
}

impl Record {
    fn for_kind(kind: Kind) -> &'static [Record] {
        match kind {
            Kind::Basin => &[Record::Bounded, Record::EscapeT, Record::MaxTheta],
            Kind::Chart => &[Record::Radius, Record::Kind],
        }
    }

    /// The spec's (and the CSV header's) name.
    pub fn as_str(self) -> &'static str {
        match self {
            Record::Bounded => "bounded",
            Record::EscapeT => "escape_t",
            Record::MaxTheta => "max_theta",
            Record::Radius => "radius",
            Record::Kind => "kind",
        }
    }
}

/// One axis as written in the spec: a range `lo`, `hi`, `n` (n points evenly, both ends
/// included) or a list of `values`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lo: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hi: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
}

/// `[basin]`: the runs of a basin map. Unset fields come from the scene (`run.periods`,
/// `run.escape_theta`, else [`ESCAPE_THETA`]); the mode amplitudes and phases are the
/// values used where they are not axes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BasinSpec {
    #[serde(default)]
    pub periods: Option<u64>,
    #[serde(default)]
    pub escape_theta: Option<f64>,
    #[serde(default)]
    pub slow_amp: Option<f64>,
    #[serde(default)]
    pub fast_amp: Option<f64>,
    #[serde(default)]
    pub slow_phase: Option<f64>,
    #[serde(default)]
    pub fast_phase: Option<f64>,
}

/// The spec file as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecFile {
    /// Names the result files; a safe file name.
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub kind: Kind,
    /// A bundled scene name or a scene file (relative to the spec's folder).
    pub scene: String,
    /// `--set`-style overrides of the scene (`"run.periods=500"`).
    #[serde(default)]
    pub set: Vec<String>,
    pub axes: Vec<AxisSpec>,
    /// What each cell records (default: everything the kind records).
    #[serde(default)]
    pub record: Option<Vec<Record>>,
    /// The shard count for schedulers that give only an index (Kubernetes'
    /// `JOB_COMPLETION_INDEX`); not part of the spec hash.
    #[serde(default)]
    pub shards: Option<u32>,
    #[serde(default)]
    pub basin: Option<BasinSpec>,
}

/// A validated grid axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridAxis {
    pub name: AxisName,
    /// The grid values (a range's points are `lo + (hi - lo) j / (n - 1)`,
    /// [`sim::chart::Axis::at`]).
    pub values: Vec<f64>,
    /// The range, when the axis was given as one.
    pub range: Option<Axis>,
}

/// The resolved basin settings (every field set).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinSettings {
    pub periods: u64,
    pub escape_theta: f64,
    pub slow_amp: Option<f64>,
    pub fast_amp: Option<f64>,
    pub slow_phase: f64,
    pub fast_phase: f64,
}

/// Everything a cell's result depends on, in the form shard files embed and the spec hash
/// covers: the kind, the resolved scene, the axes with their values, what is recorded and
/// the basin settings. The shard count is not part of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    pub format: String,
    pub version: u32,
    pub name: String,
    pub description: String,
    pub kind: Kind,
    pub scene: Scene,
    pub axes: Vec<GridAxis>,
    pub record: Vec<Record>,
    pub basin: Option<BasinSettings>,
    /// The spec's shard count (not hashed; see [`SpecFile::shards`]).
    #[serde(skip)]
    pub shards: Option<u32>,
}

fn bad(what: impl Into<String>, why: impl Into<String>) -> Error {
    Error::Sweep(format!("{}: {}", what.into(), why.into()))
}

impl Sweep {
    /// Parses and validates a spec; `label` names it in errors, `base_dir` resolves a
    /// relative scene file.
    pub fn parse(label: &str, text: &str, base_dir: &Path) -> Result<Self, Error> {
        infile::check_nesting(text, infile::MAX_NESTING).map_err(|e| bad(format!("spec {label}"), e))?;
        let value: toml::Value = text
            .parse::<toml::Table>()
            .map(toml::Value::Table)
            .map_err(|e| bad(format!("spec {label}"), format!("TOML syntax: {}", e.message())))?;
        let spec: SpecFile = serde_path_to_error::deserialize(value)
            .map_err(|e| bad(format!("spec {label}: `{}`", e.path()), e.inner().to_string()))?;
        Self::from_spec(label, spec, base_dir)
    }

    /// Validates a parsed spec.
    pub fn from_spec(label: &str, spec: SpecFile, base_dir: &Path) -> Result<Self, Error> {
        let key = |k: &str| format!("spec {label}: `{k}`");
        sim::scene::check_name(&spec.name).map_err(|e| bad(key("name"), e.to_string()))?;
        let scene_ref = if sim::scene::bundled_names().any(|n| n == spec.scene) || Path::new(&spec.scene).is_absolute()
        {
            spec.scene.clone()
        } else {
            let p = base_dir.join(&spec.scene);
            if p.is_file() { p.to_string_lossy().into_owned() } else { spec.scene.clone() }
        };
        let scene = Scene::load(&scene_ref, &spec.set).map_err(|e| bad(key("scene"), e.to_string()))?;
        Self::from_parts(label, spec, scene)
    }

    /// Validates a spec whose scene is already resolved (`spec.scene` and `spec.set` are not
    /// read again): the grid, what is recorded and the basin settings.
    fn from_parts(label: &str, spec: SpecFile, scene: Scene) -> Result<Self, Error> {
        let key = |k: &str| format!("spec {label}: `{k}`");
        sim::scene::check_name(&spec.name).map_err(|e| bad(key("name"), e.to_string()))?;
        if spec.axes.is_empty() {
            return Err(bad(key("axes"), "no axes: give at least one [[axes]] table"));
        }
        let mut axes: Vec<GridAxis> = Vec::new();
        let mut cells: u64 = 1;
        for (i, a) in spec.axes.iter().enumerate() {
            let k = key(&format!("axes[{i}]"));
            let known = || {
                format!(
                    "{} and the scene's gains and parameters: {}",
                    AxisName::names(spec.kind).join(", "),
                    SceneAxis::names(&scene).join(", ")
                )
            };
            let name = AxisName::parse(&a.name).ok_or_else(|| {
                bad(&k, format!("unknown axis `{}` (a {} sweep knows {})", a.name, spec.kind.as_str(), known()))
            })?;
            if !name.allowed(spec.kind) {
                return Err(bad(
                    &k,
                    format!(
                        "axis `{}` does not apply to a {} sweep (it knows {})",
                        a.name,
                        spec.kind.as_str(),
                        known()
                    ),
                ));
            }
            if axes.iter().any(|g| g.name == name) {
                return Err(bad(&k, format!("axis `{}` given twice", a.name)));
            }
            // A gain or parameter axis names a quantity of this scene, once.
            if let Some(q) = name.scene_axis(&scene) {
                let q = q.map_err(|e| bad(&k, e.to_string()))?;
                for g in &axes {
                    if let Some(Ok(other)) = g.name.scene_axis(&scene) {
                        if other.same_quantity(&q) {
                            return Err(bad(
                                &k,
                                format!("axis `{}` sets the same quantity as axis `{}`", a.name, g.name.as_str()),
                            ));
                        }
                    }
                }
            }
            let k = format!("{k} ({})", a.name);
            let (values, range) = match (&a.values, a.lo, a.hi, a.n) {
                (Some(v), None, None, None) => {
                    if v.is_empty() {
                        return Err(bad(&k, "empty range: `values` is empty"));
                    }
                    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                        return Err(bad(&k, format!("value {x} is not finite")));
                    }
                    let mut seen = std::collections::HashSet::with_capacity(v.len());
                    if let Some(x) = v.iter().find(|x| !seen.insert(x.to_bits())) {
                        return Err(bad(&k, format!("value {x} given twice")));
                    }
                    (v.clone(), None)
                }
                (None, Some(lo), Some(hi), Some(n)) => {
                    if !(lo.is_finite() && hi.is_finite()) {
                        return Err(bad(&k, format!("bounds {lo} .. {hi} must be finite")));
                    }
                    if n == 0 || lo > hi || (lo == hi && n > 1) || (lo < hi && n < 2) {
                        return Err(bad(
                            &k,
                            format!(
                                "empty range: lo = {lo}, hi = {hi}, n = {n} (need lo < hi and n >= 2, or lo = hi and n = 1)"
                            ),
                        ));
                    }
                    // The grid's size is checked before its values are allocated.
                    if cells.checked_mul(n as u64).is_none_or(|c| c > MAX_CELLS) {
                        return Err(bad(
                            &k,
                            format!("n = {n}: the grid would have more than {MAX_CELLS} cells (the limit)"),
                        ));
                    }
                    if lo == hi {
                        (vec![lo], None)
                    } else {
                        let r = Axis { lo, hi, n };
                        ((0..n).map(|j| r.at(j)).collect(), Some(r))
                    }
                }
                _ => return Err(bad(&k, "give either `values = [...]` or all of `lo`, `hi`, `n`")),
            };
            let sign = match name {
                AxisName::SlowAmp | AxisName::FastAmp => {
                    values.iter().find(|x| **x < 0.0).map(|x| format!("amplitude {x} is negative"))
                }
                AxisName::DtMs | AxisName::HAdc => {
                    values.iter().find(|x| **x <= 0.0).map(|x| format!("{x} must be positive"))
                }
                _ => None,
            };
            if let Some(why) = sign {
                return Err(bad(&k, why));
            }
            if name == AxisName::Seed {
                if let Some(x) =
                    values.iter().find(|x| !(x.fract() == 0.0 && **x >= 0.0 && **x < 9.007_199_254_740_992e15))
                {
                    return Err(bad(&k, format!("seed {x} is not a non-negative integer below 2^53")));
                }
            }
            cells = cells.saturating_mul(values.len() as u64);
            if cells > MAX_CELLS {
                return Err(bad(key("axes"), format!("more than {MAX_CELLS} cells (the limit)")));
            }
            axes.push(GridAxis { name, values, range });
        }
        let record = match spec.record {
            None => Record::for_kind(spec.kind).to_vec(),
            Some(r) => {
                if r.is_empty() {
                    return Err(bad(key("record"), "records nothing"));
                }
                for (j, x) in r.iter().enumerate() {
                    if !Record::for_kind(spec.kind).contains(x) {
                        let names: Vec<&str> = Record::for_kind(spec.kind).iter().map(|r| r.as_str()).collect();
                        return Err(bad(
                            key("record"),
                            format!(
                                "`{}` is not recorded by a {} sweep (it records {})",
                                x.as_str(),
                                spec.kind.as_str(),
                                names.join(", ")
                            ),
                        ));
                    }
                    if r[..j].contains(x) {
                        return Err(bad(key("record"), format!("`{}` given twice", x.as_str())));
                    }
                }
                r
            }
        };
        if let Some(n) = spec.shards {
            if n == 0 || n > MAX_SHARDS {
                return Err(bad(key("shards"), format!("{n} shards; need 1 ..= {MAX_SHARDS}")));
            }
        }
        let has = |a: AxisName| axes.iter().any(|g| g.name == a);
        let plane = axes.iter().filter(|g| g.range.is_some() && g.name.scene_axis(&scene).is_some()).count();
        let basin = match spec.kind {
            Kind::Chart => {
                if spec.basin.is_some() {
                    return Err(bad(key("basin"), "a chart sweep runs no simulation"));
                }
                // One figure panel per sampling period, as `stability-chart --dt-ms`.
                if let Some((i, g)) = axes.iter().enumerate().find(|(_, g)| g.name == AxisName::DtMs) {
                    if g.values.len() > sim::chart::MAX_PANELS {
                        return Err(bad(
                            key(&format!("axes[{i}]")),
                            format!(
                                "`dt_ms` has {} values: a chart has one panel per sampling period, at most {}",
                                g.values.len(),
                                sim::chart::MAX_PANELS
                            ),
                        ));
                    }
                }
                let missing = [AxisName::Kp, AxisName::Kd]
                    .into_iter()
                    .find(|a| !axes.iter().any(|g| g.name == *a && g.range.is_some()));
                if let (Some(a), true) = (missing, plane < 2) {
                    return Err(bad(
                        key("axes"),
                        format!(
                            "a chart sweep needs `{}` as a range (lo, hi, n >= 2), or two gain or parameter axes as ranges",
                            a.as_str()
                        ),
                    ));
                }
                None
            }
            Kind::Basin => {
                let b = spec.basin.unwrap_or_default();
                let periods = b.periods.unwrap_or(scene.run.periods);
                if periods == 0 || periods > sim::scene::MAX_PERIODS {
                    return Err(bad(
                        key("basin.periods"),
                        format!("{periods}; need 1 ..= {}", sim::scene::MAX_PERIODS),
                    ));
                }
                let escape_theta = b.escape_theta.or(scene.run.escape_theta).unwrap_or(ESCAPE_THETA);
                if !(escape_theta.is_finite() && escape_theta > 0.0) {
                    return Err(bad(key("basin.escape_theta"), format!("{escape_theta} must be positive and finite")));
                }
                for (n, v) in [
                    ("slow_amp", b.slow_amp),
                    ("fast_amp", b.fast_amp),
                    ("slow_phase", b.slow_phase),
                    ("fast_phase", b.fast_phase),
                ] {
                    if let Some(v) = v {
                        if !v.is_finite() || (n.ends_with("amp") && v < 0.0) {
                            return Err(bad(
                                key(&format!("basin.{n}")),
                                format!("{v} must be finite{}", if n.ends_with("amp") { " and >= 0" } else { "" }),
                            ));
                        }
                        if AxisName::parse(n).is_some_and(has) {
                            return Err(bad(
                                key(&format!("basin.{n}")),
                                format!("`{n}` is also an axis; give it in one place"),
                            ));
                        }
                    }
                }
                let modes =
                    has(AxisName::SlowAmp) || has(AxisName::FastAmp) || b.slow_amp.is_some() || b.fast_amp.is_some();
                let phases = has(AxisName::SlowPhase) || has(AxisName::FastPhase);
                if phases && !modes {
                    return Err(bad(
                        key("axes"),
                        "a phase axis needs a mode start: a `slow_amp` / `fast_amp` axis or [basin] value",
                    ));
                }
                if modes && has(AxisName::Theta0) {
                    return Err(bad(key("axes"), "`theta0` and mode amplitudes both set the start; use one"));
                }
                if has(AxisName::HAdc) && scene.effects.quantization.is_none() {
                    return Err(bad(
                        key("axes"),
                        format!("axis `h_adc` needs a scene with [effects.quantization]; {} has none", scene.name),
                    ));
                }
                if has(AxisName::Seed) && scene.effects.noise.is_none() {
                    return Err(bad(
                        key("axes"),
                        format!("axis `seed` needs a scene with [effects.noise]; {} has none", scene.name),
                    ));
                }
                Some(BasinSettings {
                    periods,
                    escape_theta,
                    slow_amp: b.slow_amp,
                    fast_amp: b.fast_amp,
                    slow_phase: b.slow_phase.unwrap_or(0.0),
                    fast_phase: b.fast_phase.unwrap_or(0.0),
                })
            }
        };
        Ok(Sweep {
            format: "ssm-sweep-spec".into(),
            version: FORMAT_VERSION,
            name: spec.name,
            description: spec.description,
            kind: spec.kind,
            scene,
            axes,
            record,
            basin,
            shards: spec.shards,
        })
    }

    /// Checks a sweep read from a file (a shard's embedded spec) as the spec it claims to be:
    /// the spec is rebuilt from its own parts (name, kind, scene, the axes as written, what
    /// is recorded, the basin settings), its grid recomputed, and the result must be this
    /// sweep exactly. A file edited by hand (grid values off their range, a name with a
    /// path in it, a record the kind does not make) is refused, naming what differs.
    pub fn check_embedded(&self, label: &str) -> Result<(), Error> {
        let key = |k: &str| format!("{label}: spec `{k}`");
        if self.format != "ssm-sweep-spec" || self.version != FORMAT_VERSION {
            return Err(bad(
                key("format"),
                format!("{} version {}; expected ssm-sweep-spec version {FORMAT_VERSION}", self.format, self.version),
            ));
        }
        self.scene.validate().map_err(|e| bad(key("scene"), e.to_string()))?;
        let is_axis = |a: AxisName| self.axes.iter().any(|g| g.name == a);
        let axes = self
            .axes
            .iter()
            .map(|g| match g.range {
                Some(r) => AxisSpec {
                    name: g.name.as_str().into(),
                    lo: Some(r.lo),
                    hi: Some(r.hi),
                    n: Some(r.n),
                    values: None,
                },
                None => AxisSpec {
                    name: g.name.as_str().into(),
                    lo: None,
                    hi: None,
                    n: None,
                    values: Some(g.values.clone()),
                },
            })
            .collect();
        let basin = self.basin.as_ref().map(|b| BasinSpec {
            periods: Some(b.periods),
            escape_theta: Some(b.escape_theta),
            slow_amp: b.slow_amp,
            fast_amp: b.fast_amp,
            slow_phase: (!is_axis(AxisName::SlowPhase)).then_some(b.slow_phase),
            fast_phase: (!is_axis(AxisName::FastPhase)).then_some(b.fast_phase),
        });
        let spec = SpecFile {
            name: self.name.clone(),
            description: self.description.clone(),
            kind: self.kind,
            scene: self.scene.name.clone(),
            set: Vec::new(),
            axes,
            record: Some(self.record.clone()),
            shards: None,
            basin: (self.kind == Kind::Basin).then(|| basin.unwrap_or_default()),
        };
        if self.kind == Kind::Chart && self.basin.is_some() {
            return Err(bad(key("basin"), "a chart sweep has no basin settings"));
        }
        if self.kind == Kind::Basin && self.basin.is_none() {
            return Err(bad(key("basin"), "a basin sweep without its basin settings"));
        }
        let rebuilt = Self::from_parts(label, spec, self.scene.clone())?;
        for (i, (a, b)) in self.axes.iter().zip(&rebuilt.axes).enumerate() {
            if a.values.len() != b.values.len()
                || a.values.iter().zip(&b.values).any(|(x, y)| x.to_bits() != y.to_bits())
            {
                return Err(bad(
                    key(&format!("axes[{i}]")),
                    format!(
                        "axis `{}` lists {} values that are not the grid of its range (edited by hand?)",
                        a.name.as_str(),
                        a.values.len()
                    ),
                ));
            }
        }
        if rebuilt.canonical()? != self.canonical()? {
            return Err(bad(key("basin"), "settings that the spec does not resolve to (edited by hand?)"));
        }
        Ok(())
    }

    /// The canonical JSON of the sweep (what the hash covers and shard files embed).
    pub fn canonical(&self) -> Result<serde_json::Value, Error> {
        serde_json::to_value(self).map_err(|e| Error::Sweep(format!("canonical spec: {e}")))
    }

    /// The spec hash: 64-bit FNV-1a of the canonical JSON text, 16 hex digits. It identifies
    /// a spec among the shards of one output folder (not a cryptographic digest).
    pub fn hash(&self) -> Result<String, Error> {
        Ok(hash_value(&self.canonical()?))
    }

    /// Number of cells.
    pub fn cells(&self) -> u64 {
        self.axes.iter().map(|a| a.values.len() as u64).product()
    }

    /// The grid position of cell `k` (one index per axis).
    pub fn position(&self, mut k: u64) -> Vec<usize> {
        let mut pos = vec![0; self.axes.len()];
        for (p, a) in pos.iter_mut().zip(&self.axes).rev() {
            let n = a.values.len() as u64;
            *p = (k % n) as usize;
            k /= n;
        }
        pos
    }

    /// The cell index of a grid position.
    pub fn index_of(&self, pos: &[usize]) -> u64 {
        pos.iter().zip(&self.axes).fold(0, |k, (&p, a)| k * a.values.len() as u64 + p as u64)
    }

    /// The axis values of cell `k`.
    pub fn values(&self, k: u64) -> Vec<f64> {
        self.position(k).iter().zip(&self.axes).map(|(&p, a)| a.values[p]).collect()
    }

    /// The position of an axis among the axes.
    pub fn axis(&self, name: AxisName) -> Option<usize> {
        self.axes.iter().position(|a| a.name == name)
    }

    /// The gain and parameter axes (`kp`, `kd`, the named ones), with their positions
    /// among the axes, in spec order.
    pub fn scene_axes(&self) -> Result<Vec<(usize, SceneAxis)>, Error> {
        let mut v = Vec::new();
        for (i, g) in self.axes.iter().enumerate() {
            if let Some(q) = g.name.scene_axis(&self.scene) {
                v.push((i, q.map_err(|e| bad(format!("axis `{}`", g.name.as_str()), e.to_string()))?));
            }
        }
        Ok(v)
    }

    /// The cells of shard `shard` (`k mod N = I`), in order.
    pub fn shard_cells(&self, shard: Shard) -> impl Iterator<Item = u64> {
        (u64::from(shard.index)..self.cells()).step_by(shard.count as usize)
    }

    /// Computes cell `k`.
    pub fn compute(&self, k: u64) -> Result<Cell, Error> {
        let values = self.values(k);
        let get = |a: AxisName| self.axis(a).map(|i| values[i]);
        let ce = |e: Error| Error::Sweep(format!("cell {k} {}: {e}", self.describe(&values)));
        // The named gains and parameters first: the typed setters below then edit that scene.
        let mut scene = self.scene.clone();
        for (a, &v) in self.axes.iter().zip(&values) {
            if let AxisName::Scene(_) = a.name {
                if let Some(q) = a.name.scene_axis(&scene) {
                    scene = q.and_then(|q| q.apply(&scene, v)).map_err(|e| ce(e.into()))?;
                }
            }
        }
        let mut b = scene.builder();
        if let Some(v) = get(AxisName::DtMs) {
            b = b.dt_ms(v);
        }
        if let Some(v) = get(AxisName::Kp) {
            b = b.kp(v);
        }
        if let Some(v) = get(AxisName::Kd) {
            b = b.kd(v);
        }
        let mut cell = Cell { index: k, values: values.clone(), ..Cell::default() };
        let want = |r: Record| self.record.contains(&r);
        match (&self.basin, self.kind) {
            (Some(bs), Kind::Basin) => {
                if let Some(v) = get(AxisName::HAdc) {
                    b = b.quant_step(v);
                }
                if let Some(noise) = &self.scene.effects.noise {
                    // The cell's seed: the axis value, else a mix of the scene's seed and the
                    // cell index (never the shard or the thread).
                    let seed = get(AxisName::Seed).map_or_else(|| splitmix64(noise.seed ^ splitmix64(k)), |s| s as u64);
                    b = b.noise_seed(seed);
                }
                b = b.periods(bs.periods).escape_theta(bs.escape_theta);
                let slow = get(AxisName::SlowAmp).or(bs.slow_amp);
                let fast = get(AxisName::FastAmp).or(bs.fast_amp);
                if slow.is_some() || fast.is_some() {
                    let (sa, fa) = (slow.unwrap_or(0.0), fast.unwrap_or(0.0));
                    if !(sa.is_finite() && fa.is_finite() && sa >= 0.0 && fa >= 0.0) {
                        return Err(ce(Error::BadInput {
                            what: "mode amplitudes",
                            why: format!("need finite non-negative amplitudes, got ({sa}, {fa})"),
                        }));
                    }
                    if sa == 0.0 && fa == 0.0 {
                        // Neither mode excited: the loop at rest at the equilibrium.
                        b = b.initial_state(&[0.0; 4]).history(None);
                    } else {
                        let sp = get(AxisName::SlowPhase).unwrap_or(bs.slow_phase);
                        let fp = get(AxisName::FastPhase).unwrap_or(bs.fast_phase);
                        let at = b.clone().build().map_err(|e| ce(e.into()))?;
                        let (x, h) = mode_start_in(&at, (sa > 0.0).then_some((sa, sp)), (fa > 0.0).then_some((fa, fp)))
                            .map_err(ce)?;
                        b = b.initial_state(&x).history(Some(&h));
                    }
                } else if let Some(t0) = get(AxisName::Theta0) {
                    // Both plants have 4 states, the primary angle first.
                    let x = [t0, 0.0, 0.0, 0.0];
                    b = b.initial_state(&x).history(None);
                }
                let scene = b.build().map_err(|e| ce(e.into()))?;
                let tr = simulate(&scene, None).map_err(|e| ce(e.into()))?;
                let o = outcome_of(&tr);
                cell.bounded = want(Record::Bounded).then_some(o.bounded());
                cell.escape_t = if want(Record::EscapeT) { o.escape_t } else { None };
                cell.max_theta = want(Record::MaxTheta).then_some(o.max_theta);
            }
            _ => {
                let scene = b.build().map_err(|e| ce(e.into()))?;
                let (radius, kind) = sim::stability::scene_point(&scene).map_err(|e| ce(e.into()))?;
                cell.radius = want(Record::Radius).then_some(radius);
                cell.kind = want(Record::Kind).then_some(PointKind::from(kind));
            }
        }
        Ok(cell)
    }

    /// `(dt_ms = 31, theta0 = 0.05)`.
    pub fn describe(&self, values: &[f64]) -> String {
        let parts: Vec<String> =
            self.axes.iter().zip(values).map(|(a, v)| format!("{} = {v}", a.name.as_str())).collect();
        format!("({})", parts.join(", "))
    }
}

/// FNV-1a, 64 bits, of the JSON text of `v`, as 16 hex digits.
pub fn hash_value(v: &serde_json::Value) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in v.to_string().bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// SplitMix64's output function: decorrelates neighbouring cell indices as seeds.
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A chart point's classification.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointKind {
    Stable,
    Static,
    Dynamic,
    Flip,
}

impl From<Option<Crossing>> for PointKind {
    fn from(c: Option<Crossing>) -> Self {
        match c {
            None => PointKind::Stable,
            Some(Crossing::Static) => PointKind::Static,
            Some(Crossing::Dynamic) => PointKind::Dynamic,
            Some(Crossing::Flip) => PointKind::Flip,
        }
    }
}

impl PointKind {
    /// Back to the chart's crossing (`None` = stable).
    pub fn crossing(self) -> Option<Crossing> {
        match self {
            PointKind::Stable => None,
            PointKind::Static => Some(Crossing::Static),
            PointKind::Dynamic => Some(Crossing::Dynamic),
            PointKind::Flip => Some(Crossing::Flip),
        }
    }

    /// The spec's (and CSV's) name.
    pub fn as_str(self) -> &'static str {
        match self {
            PointKind::Stable => "stable",
            PointKind::Static => "static",
            PointKind::Dynamic => "dynamic",
            PointKind::Flip => "flip",
        }
    }
}

/// One computed cell: its index, its axis values and what the spec records.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cell {
    pub index: u64,
    pub values: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounded: Option<bool>,
    /// Absent when bounded (or not recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub escape_t: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_theta: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<PointKind>,
}

/// Shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// The whole grid as one shard.
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// A checked shard: `count` in 1 ..= [`MAX_SHARDS`], `index` in 0..count.
    pub fn new(index: u64, count: u64) -> Result<Self, Error> {
        if count == 0 || count > u64::from(MAX_SHARDS) {
            return Err(Error::Sweep(format!("shard count {count}: need 1 ..= {MAX_SHARDS}")));
        }
        if index >= count {
            return Err(Error::Sweep(format!("shard index {index} outside 0..{count} (shards are numbered from 0)")));
        }
        Ok(Shard { index: index as u32, count: count as u32 })
    }

    /// Parses `I/N`.
    pub fn parse(s: &str) -> Result<Self, Error> {
        let bad = || Error::Sweep(format!("shard `{s}`: expected I/N with 0 <= I < N, e.g. 3/8"));
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let i: u64 = i.trim().parse().map_err(|_| bad())?;
        let n: u64 = n.trim().parse().map_err(|_| bad())?;
        Self::new(i, n)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Every cell of `shard` on the rayon pool, collected in cell order (the first error in
/// cell order).
pub fn run_shard(sweep: &Sweep, shard: Shard) -> Result<Vec<Cell>, Error> {
    let ks: Vec<u64> = sweep.shard_cells(shard).collect();
    crate::par_map(&ks, |&k| sweep.compute(k))
}
