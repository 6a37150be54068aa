//! The flag pipeline on a known chaotic system as a spec (`kind = "known-system"`): the
//! system, the flag's sampling (lengths, map step, lag, noise), the estimator settings, the
//! candidate search at each training-data scale (`check`) and the diagnosis variants, each a
//! list of candidate names ([`parse_name`]). `ssmctl study` runs it and writes
//! [`crate::study_results::KNOWN_SYSTEM`].
//!
//! Every row is one unit ([`KnownSystemSpec::units`]): its series (scale, noise, seed;
//! [`series_data`]) and its candidate. The units are independent, so a cache stores each and a
//! shard computes some; [`finish`] puts the rows in the spec's order.

use serde::{Deserialize, Serialize};
use ssm::TimeSeries;
use ssm::multistep::MultiStep;

use crate::Error;
use crate::flag_pipeline::{FlagLayout, KnownStats, KnownSystem, known_stats_with};
use crate::flag_pipeline_fit::{Coords, StateFit, state_model_row, variant};
use crate::model_selection::{Candidate, DataStats, EvalSettings, data_stats, evaluate_candidate};
use crate::study_results::{CheckRow, DiagRow, KnownData, KnownSystemResults};
use chaos::Context;

/// The value of `kind` that marks a known-system spec.
pub const KIND: &str = "known-system";

/// What a candidate name leaves out ([`parse_name`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NameDefaults {
    pub ridge: f64,
    pub dim: usize,
    pub embed: usize,
    pub shift: usize,
    /// Order of the polynomial map of `state` and `delay` candidates.
    pub map_order: u32,
    /// Window stride and Levenberg-Marquardt steps per stage of `ms h=H`.
    pub multistep_stride: usize,
    pub multistep_iterations: usize,
}

/// The flag's candidate search at each training-data scale: RBF maps (centres, ridge) and the
/// polynomial map of the default map order with ridge `poly_ridge`, at the default dimension,
/// embedding and shift and the layout's map step. An RBF map whose regression would exceed
/// `max_matrix_entries` (training rows times centres plus the linear terms) is left out at
/// that scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    pub scales: Vec<usize>,
    pub rbf: Vec<(usize, f64)>,
    pub poly_ridge: f64,
    pub max_matrix_entries: usize,
}

/// Diagnosis rows: a group name, the training-data scale, the noise over the series sd
/// (default: the layout's) and candidate names. For `state` candidates the noise is put on
/// the state they are fitted on; the observed series keep the layout's noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosisSpec {
    pub group: String,
    pub scale: usize,
    #[serde(default)]
    pub noise_rel: Option<f64>,
    pub candidates: Vec<String>,
}

/// A known-system spec.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownSystemSpec {
    pub kind: String,
    pub name: String,
    pub system: KnownSystem,
    pub layout: FlagLayout,
    /// Length of the exact exponent's Benettin run, s.
    pub benettin_time: f64,
    pub statistics: EvalSettings,
    pub names: NameDefaults,
    /// The flag's candidate search; a spec of diagnosis rows alone leaves it out.
    #[serde(default)]
    pub check: Option<CheckSpec>,
    #[serde(default)]
    pub diagnosis: Vec<DiagnosisSpec>,
    /// The stem of the results files, so that two specs can write to one folder: `STEM.json`,
    /// `STEM.study.json` and shards `STEM-shard-I-of-N.json` ([`Self::files`]). Default: the
    /// names of [`ResultFiles::default`].
    #[serde(default)]
    pub results: Option<String>,
}

/// The files a known-system spec writes: the results, the study record and the shards' prefix.
#[derive(Clone, Debug, PartialEq)]
pub struct ResultFiles {
    pub results: String,
    pub record: String,
    pub shard_prefix: String,
}

impl Default for ResultFiles {
    /// `known_system.json`, `study.json`, `known-system-shard-`.
    fn default() -> Self {
        Self {
            results: crate::study_results::KNOWN_SYSTEM.into(),
            record: "study.json".into(),
            shard_prefix: "known-system-shard-".into(),
        }
    }
}

/// The series a row is measured on: training-data scale, noise over the sd, realization.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SeriesKey {
    pub scale: usize,
    pub noise_rel: f64,
    pub seed: u64,
}

/// How a row's model is fitted.
#[derive(Clone, Debug, Serialize)]
pub enum Model {
    /// On the SSM of the delay-embedded observed series, as the flag's candidates.
    Embedded(Candidate),
    /// On the true state or the whole delay vector.
    Coords(StateFit),
}

/// One row of the results: `group` is `None` for the check rows.
#[derive(Clone, Debug, Serialize)]
pub struct Unit {
    pub group: Option<String>,
    pub name: String,
    pub scale: usize,
    /// The row's noise value (the state's for `state` candidates).
    pub noise_rel: f64,
    pub series: SeriesKey,
    pub model: Model,
}

/// A row's measured values (rounded as the results carry them: exponents 3 decimals, D2 2,
/// JS 4; a failed row has none) and why it failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitRow {
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
    pub failed: Option<String>,
}

/// A candidate name: `[state | delay P x S] (RBF C | poly O) [/K] [r=R] [d=D p=P] [s=S]
/// [centres CHOICE] [denoised W] [ms h=H [stride S it I]] [seed N] [noise]`. `/K` is the map
/// step (default the layout's), `denoised W` fits the map again on inputs smoothed by a
/// moving average of W (odd) samples, `noise` marks a `state` candidate fitted on the noisy
/// state (its noise is the row's). `seed N` measures an embedded candidate on realization N
/// of the series, and fits a `state ... noise` candidate on realization N of the state's
/// noise (0: the name without it); `delay` and noise-free `state` candidates take no seed.
/// What is left out comes from `defaults`.
pub fn parse_name(name: &str, step: usize, d: &NameDefaults) -> Result<(Model, u64, bool), String> {
    let bad = |why: String| format!("candidate `{name}`: {why}");
    let toks: Vec<&str> = name.split_whitespace().collect();
    let mut i = 0;
    let next = |i: &mut usize| -> Option<&str> {
        let t = toks.get(*i).copied();
        *i += 1;
        t
    };
    let num = |t: Option<&str>, key: &str| -> Result<f64, String> {
        let what = if key.is_empty() { "a number".to_string() } else { format!("{key}NUMBER") };
        let t = t.ok_or_else(|| bad(format!("{what} missing at the end")))?;
        t.strip_prefix(key).unwrap_or(t).parse::<f64>().map_err(|_| bad(format!("`{t}` is not {what}")))
    };
    let int = |v: f64, what: &str| -> Result<usize, String> {
        if v >= 0.0 && v.fract() == 0.0 && v <= 1e9 {
            Ok(v as usize)
        } else {
            Err(bad(format!("{what} {v} is not a count")))
        }
    };
    let mut coords = None;
    match toks.first().copied() {
        Some("state") => {
            coords = Some(Coords::State);
            i = 1;
        }
        Some("delay") => {
            i = 1;
            let embed = int(num(next(&mut i), "")?, "delay window")?;
            if next(&mut i) != Some("x") {
                return Err(bad("expected `delay P x S`".into()));
            }
            let shift = int(num(next(&mut i), "")?, "delay shift")?;
            coords = Some(Coords::Delay { embed, shift });
        }
        _ => {}
    }
    let (centers, order) = match next(&mut i) {
        Some("RBF") => (int(num(next(&mut i), "")?, "centres")?, d.map_order),
        Some("poly") => (0, int(num(next(&mut i), "")?, "map order")? as u32),
        t => return Err(bad(format!("expected `RBF C` or `poly O`, got `{}`", t.unwrap_or("")))),
    };
    if centers == 0 && order == 0 {
        return Err(bad("`RBF 0` or `poly 0`".into()));
    }
    let (mut step, mut ridge, mut dim, mut embed, mut shift) = (step, d.ridge, d.dim, d.embed, d.shift);
    let (mut centres, mut ms, mut denoise, mut seed, mut noise) =
        (ssm::dynamics::CentreChoice::Farthest, None, 0, 0u64, false);
    while let Some(t) = next(&mut i) {
        if let Some(k) = t.strip_prefix('/') {
            step = int(num(Some(k), "")?, "map step")?;
        } else if t.starts_with("r=") {
            ridge = num(Some(t), "r=")?;
        } else if t.starts_with("d=") {
            dim = int(num(Some(t), "d=")?, "dimension")?;
        } else if t.starts_with("p=") {
            embed = int(num(Some(t), "p=")?, "embedding")?;
        } else if t.starts_with("s=") {
            shift = int(num(Some(t), "s=")?, "shift")?;
        } else {
            match t {
                "centres" => {
                    let c = next(&mut i).ok_or_else(|| bad("centre choice missing".into()))?;
                    centres = ssm::dynamics::CentreChoice::parse(c).map_err(|e| bad(e.to_string()))?;
                }
                "denoised" => {
                    let w = int(num(next(&mut i), "")?, "denoising window")?;
                    if w < 3 || w.is_multiple_of(2) {
                        return Err(bad(format!("denoised {w}: the window must be odd and >= 3")));
                    }
                    denoise = (w - 1) / 2;
                }
                "ms" => {
                    let horizon = int(num(next(&mut i), "h=")?, "horizon")?;
                    let (mut stride, mut iterations) = (d.multistep_stride, d.multistep_iterations);
                    if toks.get(i) == Some(&"stride") {
                        i += 1;
                        stride = int(num(next(&mut i), "")?, "stride")?;
                        if next(&mut i) != Some("it") {
                            return Err(bad("expected `stride S it I`".into()));
                        }
                        iterations = int(num(next(&mut i), "")?, "iterations")?;
                    }
                    ms = Some(MultiStep { horizon, stride, iterations });
                }
                "seed" => {
                    let n = next(&mut i).ok_or_else(|| bad("`seed` needs a realization number N".into()))?;
                    seed = int(num(Some(n), "")?, "seed")? as u64;
                }
                "noise" => noise = true,
                _ => return Err(bad(format!("unknown token `{t}`"))),
            }
        }
    }
    if step == 0 {
        return Err(bad("map step 0".into()));
    }
    let model = match coords {
        Some(coords) => {
            if denoise > 0 || centres != ssm::dynamics::CentreChoice::Farthest {
                return Err(bad("`state` and `delay` candidates take no centres or denoised".into()));
            }
            if seed != 0 && !(noise && coords == Coords::State) {
                return Err(bad(format!(
                    "`seed {seed}`: only `state ... noise` candidates (the noise's realization) and embedded ones take a seed"
                )));
            }
            if noise && coords != Coords::State {
                return Err(bad("`noise` marks `state` candidates only".into()));
            }
            Model::Coords(StateFit { coords, centers, order, ridge, multistep: ms, noise_rel: 0.0, noise_seed: seed })
        }
        None => {
            if noise {
                return Err(bad("`noise` marks `state` candidates only".into()));
            }
            let mut c = variant(step, centers, ridge, dim, embed, shift, ms, denoise);
            c.fit.dyn_order = order;
            c.name = name.to_string();
            c.centres = centres;
            c.fit.validate().map_err(|e| bad(e.to_string()))?;
            Model::Embedded(c)
        }
    };
    Ok((model, seed, noise))
}

impl KnownSystemSpec {
    /// The spec in TOML `text` (from `origin`, for the messages); unknown or missing keys and
    /// bad values are errors naming the key.
    pub fn parse(origin: &str, text: &str) -> Result<Self, Error> {
        let bad = |why: String| Error::BadInput { what: "study spec", why: format!("{origin}: {why}") };
        let de = toml::Deserializer::parse(text).map_err(|e| bad(e.to_string()))?;
        let spec: Self = serde_path_to_error::deserialize(de)
            .map_err(|e| bad(format!("at `{}`: {}", e.path(), e.inner().message())))?;
        spec.units().map_err(bad)?;
        Ok(spec)
    }

    /// The spec with every candidate list cut to its first `n`.
    pub fn limited(&self, n: usize) -> Self {
        let mut s = self.clone();
        if let Some(c) = &mut s.check {
            c.rbf.truncate(n);
        }
        for g in &mut s.diagnosis {
            g.candidates.truncate(n);
        }
        s
    }

    /// The series of the held-out statistics the rows are judged against: scale 1, the
    /// layout's noise, realization 0.
    pub fn reference_series(&self) -> SeriesKey {
        SeriesKey { scale: 1, noise_rel: self.layout.noise_rel, seed: 0 }
    }

    fn check_values(&self) -> Result<(), String> {
        if self.kind != KIND {
            return Err(format!("kind = `{}`: expected `{KIND}`", self.kind));
        }
        let l = &self.layout;
        if l.step == 0 || l.lag == 0 || l.test < 2 || l.train.contains(&0) {
            return Err(format!("layout: need step, lag >= 1 and series of >= 2 samples (got {l:?})"));
        }
        if !(l.noise_rel.is_finite() && l.noise_rel >= 0.0) {
            return Err(format!("layout.noise_rel = {}: needs a finite value >= 0", l.noise_rel));
        }
        if !(self.benettin_time.is_finite() && self.benettin_time > 0.0) {
            return Err(format!("benettin_time = {}: needs a positive time (s)", self.benettin_time));
        }
        self.statistics.check()?;
        if let Some(check) = &self.check {
            if check.scales.contains(&0) {
                return Err(format!("check.scales = {:?}: every scale must be >= 1", check.scales));
            }
            if let Some(&(c, r)) = check.rbf.iter().find(|(c, r)| *c == 0 || !(r.is_finite() && *r > 0.0)) {
                return Err(format!("check.rbf: ({c}, {r}): needs centres >= 1 and a ridge > 0"));
            }
            if !(check.poly_ridge.is_finite() && check.poly_ridge > 0.0) {
                return Err(format!("check.poly_ridge = {}: needs a value > 0", check.poly_ridge));
            }
        }
        if let Some(stem) = &self.results {
            let ok = !stem.is_empty()
                && stem.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
                && stem != "study";
            if !ok {
                return Err(format!(
                    "results = `{stem}`: needs a file stem of letters, digits, `_` and `-` (not `study`)"
                ));
            }
        }
        for (k, g) in self.diagnosis.iter().enumerate() {
            if g.scale == 0 {
                return Err(format!("diagnosis[{k}] (`{}`).scale = 0: needs >= 1", g.group));
            }
            if let Some(n) = g.noise_rel.filter(|n| !(n.is_finite() && *n >= 0.0)) {
                return Err(format!("diagnosis[{k}] (`{}`).noise_rel = {n}: needs a finite value >= 0", g.group));
            }
        }
        Ok(())
    }

    /// Every row of the results, the check's first (by scale, then candidate), then the
    /// diagnosis's in the spec's order.
    pub fn units(&self) -> Result<Vec<Unit>, String> {
        self.check_values()?;
        let d = &self.names;
        let step = self.layout.step;
        let mut out = Vec::new();
        let (scales, rbf, poly_ridge, max_entries) = match &self.check {
            Some(c) => (c.scales.as_slice(), c.rbf.as_slice(), c.poly_ridge, c.max_matrix_entries),
            None => (&[][..], &[][..], 0.0, 0),
        };
        for &scale in scales {
            let series = SeriesKey { scale, noise_rel: self.layout.noise_rel, seed: 0 };
            let rows = scale * (self.layout.train[0] + self.layout.train[1]);
            for &(c, r) in rbf {
                if rows.saturating_mul(c + 1 + d.dim) > max_entries {
                    continue;
                }
                let mut cand = variant(step, c, r, d.dim, d.embed, d.shift, None, 0);
                cand.name = format!("RBF {c} /{step} r={r:e}");
                out.push(Unit {
                    group: None,
                    name: cand.name.clone(),
                    scale,
                    noise_rel: self.layout.noise_rel,
                    series,
                    model: Model::Embedded(cand),
                });
            }
            let mut poly = variant(step, 0, poly_ridge, d.dim, d.embed, d.shift, None, 0);
            poly.fit.dyn_order = d.map_order;
            poly.name = format!("poly {} /{step}", d.map_order);
            out.push(Unit {
                group: None,
                name: poly.name.clone(),
                scale,
                noise_rel: self.layout.noise_rel,
                series,
                model: Model::Embedded(poly),
            });
        }
        for (k, g) in self.diagnosis.iter().enumerate() {
            let noise = g.noise_rel.unwrap_or(self.layout.noise_rel);
            for name in &g.candidates {
                let (model, seed, noisy) =
                    parse_name(name, step, d).map_err(|e| format!("diagnosis[{k}] (`{}`): {e}", g.group))?;
                let (model, series) = match model {
                    Model::Coords(mut f) => {
                        if f.coords == Coords::State {
                            if noisy != (noise > 0.0) {
                                return Err(format!(
                                    "diagnosis[{k}] (`{}`): `{name}`: `noise` in the name and noise_rel = {noise} disagree",
                                    g.group
                                ));
                            }
                            f.noise_rel = noise;
                        }
                        // The state and delay fits are judged on the layout's observed series.
                        (Model::Coords(f), SeriesKey { scale: g.scale, noise_rel: self.layout.noise_rel, seed: 0 })
                    }
                    m => (m, SeriesKey { scale: g.scale, noise_rel: noise, seed }),
                };
                out.push(Unit {
                    group: Some(g.group.clone()),
                    name: name.clone(),
                    scale: g.scale,
                    noise_rel: noise,
                    series,
                    model,
                });
            }
        }
        if out.is_empty() {
            return Err("nothing to compute: no [check] scales and no [[diagnosis]] candidates".into());
        }
        Ok(out)
    }

    /// The files the spec's run writes ([`Self::results`]).
    pub fn files(&self) -> ResultFiles {
        match &self.results {
            None => ResultFiles::default(),
            Some(stem) => ResultFiles {
                results: format!("{stem}.json"),
                record: format!("{stem}.study.json"),
                shard_prefix: format!("{stem}-shard-"),
            },
        }
    }
}

/// One series of the study, measured: the system's statistics, the series (training, then
/// held-out) and the held-out series' statistics at the map step.
pub struct SeriesData {
    pub key: SeriesKey,
    pub stats: KnownStats,
    pub series: Vec<TimeSeries>,
    pub data: (DataStats, Context),
}

/// The series `key` of the spec's system, sampled as its layout.
pub fn series_data(spec: &KnownSystemSpec, key: SeriesKey) -> Result<SeriesData, Error> {
    let layout = FlagLayout { noise_rel: key.noise_rel, ..spec.layout };
    let (stats, series) =
        known_stats_with(&spec.system, &layout, key.scale, spec.benettin_time, key.seed, &spec.statistics)?;
    let data = data_stats(&series[2], layout.step, &spec.statistics)?;
    Ok(SeriesData { key, stats, series, data })
}

/// The distinct series of `units`, in their first order.
pub fn series_keys<'a>(units: impl IntoIterator<Item = &'a Unit>) -> Vec<SeriesKey> {
    let mut out: Vec<SeriesKey> = Vec::new();
    for u in units {
        if !out.contains(&u.series) {
            out.push(u.series);
        }
    }
    out
}

fn round(v: Option<f64>, decimals: i32) -> Option<f64> {
    let f = 10f64.powi(decimals);
    v.map(|v| (v * f).round() / f)
}

/// Measures `unit` on its series `s`.
pub fn evaluate(spec: &KnownSystemSpec, unit: &Unit, s: &SeriesData) -> Result<UnitRow, Error> {
    if s.key != unit.series {
        return Err(Error::BadInput {
            what: "known-system row",
            why: format!("{}: measured on series {:?}, needs {:?}", unit.name, s.key, unit.series),
        });
    }
    let (b, r, d2, js, failed) = match &unit.model {
        Model::Embedded(c) => {
            let res = evaluate_candidate(&s.series[..2], &s.series[2], c, &s.data, &spec.statistics)?;
            (res.benettin, res.rosenstein, res.corr_dim, res.js, res.failed)
        }
        Model::Coords(f) => {
            let layout = FlagLayout { noise_rel: unit.series.noise_rel, ..spec.layout };
            let row = state_model_row(&spec.system, &layout, unit.scale, f, &s.stats, &s.series, &spec.statistics)?;
            (row.benettin, row.rosenstein, row.corr_dim, row.js, row.failed)
        }
    };
    // The reason up to its first colon, as the results carry it.
    let failed = failed.map(|f| f.split(':').next().unwrap_or(&f).to_string());
    let ok = failed.is_none();
    let keep = |v: Option<f64>, dec: i32| if ok { round(v, dec) } else { None };
    Ok(UnitRow { benettin: keep(b, 3), rosenstein: keep(r, 3), corr_dim: keep(d2, 2), js: keep(js, 4), failed })
}

/// The results file from the reference series' statistics and every unit's row (in the
/// order of [`KnownSystemSpec::units`]).
pub fn finish(
    produced_by: &str,
    reference: &KnownStats,
    units: &[Unit],
    rows: Vec<UnitRow>,
) -> Result<KnownSystemResults, Error> {
    if rows.len() != units.len() {
        return Err(Error::BadInput {
            what: "known-system rows",
            why: format!("{} rows for {} candidates", rows.len(), units.len()),
        });
    }
    let mut check = Vec::new();
    let mut diagnosis = Vec::new();
    for (u, r) in units.iter().zip(rows) {
        match &u.group {
            None => check.push(CheckRow {
                candidate: u.name.clone(),
                scale: u.scale,
                benettin: r.benettin,
                rosenstein: r.rosenstein,
                corr_dim: r.corr_dim,
                js: r.js,
                failed: r.failed,
            }),
            Some(g) => diagnosis.push(DiagRow {
                group: g.clone(),
                candidate: u.name.clone(),
                scale: u.scale,
                noise_rel: u.noise_rel,
                benettin: r.benettin,
                rosenstein: r.rosenstein,
                corr_dim: r.corr_dim,
                js: r.js,
                failed: r.failed,
            }),
        }
    }
    Ok(KnownSystemResults {
        produced_by: produced_by.to_string(),
        data: KnownData {
            rosenstein: reference.rosenstein,
            corr_dim: reference.corr_dim,
            corr_dim_err: reference.corr_dim_err,
            exact: reference.exact,
        },
        pipeline_check: check,
        diagnosis,
    })
}
