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

#[cfg(test)]
mod tests {
    use super::*;

    const D: NameDefaults = NameDefaults {
        ridge: 3e-9,
        dim: 4,
        embed: 9,
        shift: 1,
        map_order: 4,
        multistep_stride: 4,
        multistep_iterations: 10,
    };

    #[test]
    fn names_parse_with_defaults() {
        let (m, seed, _) = parse_name("RBF 250 r=1e-8 d=6 p=13 ms h=4 stride 8 it 4 seed 2", 4, &D).unwrap();
        let Model::Embedded(c) = m else { panic!() };
        assert_eq!((c.fit.dim, c.fit.embed, c.fit.shift, c.step, seed), (6, 13, 1, 4, 2));
        assert_eq!(c.multistep, Some(MultiStep { horizon: 4, stride: 8, iterations: 4 }));
        let (m, _, _) = parse_name("RBF 200 r=3e-9 d=4 p=9 denoised 5 ms h=8", 4, &D).unwrap();
        let Model::Embedded(c) = m else { panic!() };
        assert_eq!((c.denoise_inputs, c.multistep.unwrap().iterations), (2, 10));
        let (m, _, _) = parse_name("poly 4 d=5 p=11", 4, &D).unwrap();
        let Model::Embedded(c) = m else { panic!() };
        assert_eq!((c.fit.dynamics, c.fit.dyn_order), (ssm::Dynamics::Map, 4));
        let (m, _, noisy) = parse_name("state RBF 200 r=3e-9 noise", 4, &D).unwrap();
        assert!(noisy && matches!(m, Model::Coords(StateFit { coords: Coords::State, centers: 200, .. })));
        let (m, _, _) = parse_name("delay 9 x 1 poly 4", 4, &D).unwrap();
        assert!(matches!(m, Model::Coords(StateFit { coords: Coords::Delay { embed: 9, shift: 1 }, centers: 0, .. })));
        for (bad, want) in [
            ("RBX 200", "expected `RBF C`"),
            ("RBF 200 q=3", "q=3"),
            ("RBF 200 denoised 4", "odd"),
            ("state RBF 200 seed 1", "seed 1"),
            ("RBF 200 noise", "noise"),
            ("delay 9 x 1 poly 4 noise", "noise"),
            ("delay 9 x 1 poly 4 seed 1", "seed 1"),
            ("state RBF 200 noise seed", "`seed` needs"),
            ("state RBF 200 noise seed -1", "seed -1 is not a count"),
            ("state RBF 200 noise seed 1.5", "seed 1.5 is not a count"),
            ("state RBF 200 noise seed x", "`x` is not a number"),
        ] {
            let e = parse_name(bad, 4, &D).unwrap_err();
            assert!(e.contains(bad) && e.contains(want), "{e}");
        }
    }

    /// `seed N` on a `state ... noise` candidate picks the noise's realization: seed 0 is the
    /// name without a seed, model for model and series for series; seed 1 is another noise on
    /// the same state.
    #[test]
    fn state_noise_seed_picks_the_realization() {
        let (m, seed, noisy) = parse_name("state RBF 200 r=3e-9 noise seed 3", 4, &D).unwrap();
        let Model::Coords(f) = m else { panic!() };
        assert_eq!((f.noise_seed, seed, noisy), (3, 3, true));
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies/flag-noise-realizations.toml"),
        )
        .unwrap();
        let head = &text[..text.find("[[diagnosis]]").unwrap()];
        let names =
            ["state poly 2 r=1e-8 noise", "state poly 2 r=1e-8 noise seed 0", "state poly 2 r=1e-8 noise seed 1"];
        let list = names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
        let t = format!("{head}[[diagnosis]]\ngroup = \"g\"\nscale = 1\ncandidates = [{list}]\n");
        let s = KnownSystemSpec::parse("s.toml", &t).unwrap();
        assert!(s.check.is_none());
        let units = s.units().unwrap();
        let fit = |u: &Unit| match &u.model {
            Model::Coords(f) => *f,
            m => panic!("{m:?}"),
        };
        let (f0, f00, f1) = (fit(&units[0]), fit(&units[1]), fit(&units[2]));
        assert_eq!((f0.noise_seed, f00.noise_seed, f1.noise_seed), (0, 0, 1));
        assert_eq!(serde_json::to_string(&f0).unwrap(), serde_json::to_string(&f00).unwrap());
        // Every row is judged on the layout's observed series, realization 0.
        assert!(units.iter().all(|u| u.series == s.reference_series()), "{units:?}");
        // Short estimator runs: the fits and their rows, not the study's values.
        let small = KnownSystemSpec {
            benettin_time: 100.0,
            statistics: EvalSettings { benettin_transient: 100, benettin_steps: 1000, long_runs: 1, ..s.statistics },
            ..s.clone()
        };
        let data = series_data(&small, small.reference_series()).unwrap();
        let row = |f: &StateFit| {
            let layout = FlagLayout { noise_rel: small.layout.noise_rel, ..small.layout };
            state_model_row(&small.system, &layout, 1, f, &data.stats, &data.series, &small.statistics).unwrap()
        };
        let (r0, r00, r1) = (row(&f0), row(&f00), row(&f1));
        let values = |r: &crate::flag_pipeline::PipelineRow| (r.benettin, r.rosenstein, r.corr_dim, r.js);
        assert_eq!(format!("{:?}", values(&r0)), format!("{:?}", values(&r00)));
        assert_ne!(format!("{:?}", values(&r0)), format!("{:?}", values(&r1)));
        let e: Vec<UnitRow> = units.iter().map(|u| evaluate(&small, u, &data).unwrap()).collect();
        assert_eq!(e[0], e[1]);
        assert_ne!(e[0], e[2]);
    }

    /// A spec without [check] and without diagnosis candidates has nothing to compute; a bad
    /// `results` stem is named.
    #[test]
    fn empty_specs_and_bad_result_stems_are_errors() {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies/flag-noise-realizations.toml"),
        )
        .unwrap();
        let spec = KnownSystemSpec::parse("n.toml", &text).unwrap();
        assert_eq!(spec.units().unwrap().len(), 24);
        let files = spec.files();
        assert_eq!(
            (files.results.as_str(), files.record.as_str()),
            ("noise_realizations.json", "noise_realizations.study.json")
        );
        assert_ne!(files, ResultFiles::default());
        let empty = text[..text.find("[[diagnosis]]").unwrap()].to_string();
        let e = KnownSystemSpec::parse("n.toml", &empty).unwrap_err().to_string();
        assert!(e.contains("n.toml") && e.contains("nothing to compute"), "{e}");
        for stem in ["\"\"", "\"../x\"", "\"study\""] {
            let t = text.replace("results = \"noise_realizations\"", &format!("results = {stem}"));
            let e = KnownSystemSpec::parse("n.toml", &t).unwrap_err().to_string();
            assert!(e.contains("n.toml") && e.contains("results ="), "{e}");
        }
    }

    /// The committed noise-realization rows are the bundled spec's, written by it, and their
    /// realization 0 is the committed known-system file's noisy-state rows, value for value.
    #[test]
    fn noise_realizations_extend_the_known_system_rows() {
        use crate::study_results::{KnownSystemResults, default_dir, read};
        let studies = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
        let text = std::fs::read_to_string(studies.join("flag-noise-realizations.toml")).unwrap();
        let spec = KnownSystemSpec::parse("flag-noise-realizations.toml", &text).unwrap();
        let files = spec.files();
        assert_eq!(files.results, crate::study_results::NOISE_REALIZATIONS);
        let record: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(default_dir().join(&files.record)).unwrap()).unwrap();
        assert_eq!(record["spec"].as_str(), Some(text.as_str()), "{} is not this spec's run", files.record);
        let noisy: KnownSystemResults = read(&default_dir().join(&files.results)).unwrap();
        let known = crate::study_results::FlagResults::bundled().unwrap().known;
        assert_eq!(noisy.data, known.data);
        let names: Vec<&str> = noisy.diagnosis.iter().map(|r| r.candidate.as_str()).collect();
        let want: Vec<String> = spec.units().unwrap().into_iter().map(|u| u.name).collect();
        assert_eq!(names, want);
        let mut matched = 0;
        for r in &noisy.diagnosis {
            let Some(base) = r.candidate.strip_suffix(" seed 0") else { continue };
            let k = known.diagnosis.iter().find(|k| k.candidate == base).unwrap_or_else(|| panic!("{base}"));
            assert_eq!(crate::study_results::DiagRow { candidate: base.to_string(), ..r.clone() }, *k);
            matched += 1;
        }
        assert_eq!(matched, 3);
    }

    /// The bundled spec's rows are the committed file's, in its order (names, scales, noise).
    #[test]
    fn bundled_spec_lists_the_committed_rows() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies");
        let text = std::fs::read_to_string(dir.join("flag-known-system.toml")).unwrap();
        let spec = KnownSystemSpec::parse("flag-known-system.toml", &text).unwrap();
        let units = spec.units().unwrap();
        let known = crate::study_results::FlagResults::bundled().unwrap().known;
        let check: Vec<(String, usize)> =
            units.iter().filter(|u| u.group.is_none()).map(|u| (u.name.clone(), u.scale)).collect();
        let want: Vec<(String, usize)> = known.pipeline_check.iter().map(|r| (r.candidate.clone(), r.scale)).collect();
        assert_eq!(check, want);
        let diag: Vec<(String, String, usize, f64)> = units
            .iter()
            .filter_map(|u| u.group.as_ref().map(|g| (g.clone(), u.name.clone(), u.scale, u.noise_rel)))
            .collect();
        let want: Vec<(String, String, usize, f64)> =
            known.diagnosis.iter().map(|r| (r.group.clone(), r.candidate.clone(), r.scale, r.noise_rel)).collect();
        assert_eq!(diag, want);
        let bad = |from: &str, to: &str, key: &str| {
            let e = KnownSystemSpec::parse("k.toml", &text.replace(from, to)).unwrap_err().to_string();
            assert!(e.contains("k.toml") && e.contains(key), "{e}");
        };
        bad("poly_ridge = 1e-8", "poly_ridge = 1e-8\nextra = 1", "extra");
        bad("scales = [1, 3, 10]", "scales = [0]", "check.scales");
        bad("\"state poly 4 noise\"", "\"state poly 4\"", "noise");
        bad("gp_embed = 6", "gp_embed = 0", "gp_embed");
    }
}
