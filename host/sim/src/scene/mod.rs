//! Scenes: what to simulate, as TOML. A scene names the plant and its parameters, the
//! controller (gains, sampling period, delay), the initial state with its pre-history, how
//! long to run, the integrator, and the list of effects to simulate. Only the effects a scene
//! names are simulated: no `[effects.quantization]` means the exact float controller, no
//! `[effects.noise]` means no random numbers are drawn, `tasks = ["stability"]` runs no
//! simulation.
//!
//! Owns parsing, `--set path=value` overrides and validation with key paths in errors. Must
//! not run anything.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

mod bundled;

pub use bundled::{BUNDLED, bundled_names};

use serde::{Deserialize, Serialize};
use shared::{ControllerConfig, QuantMode, Quantization};
use std::path::Path;

/// A fully parsed and validated scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Scene name (file stem or bundled name).
    pub name: String,
    /// One line saying what the scene shows.
    #[serde(default)]
    pub description: String,
    pub plant: PlantSpec,
    pub controller: ControllerSpec,
    #[serde(default)]
    pub initial: InitialSpec,
    pub run: RunSpec,
    #[serde(default)]
    pub integrator: IntegratorSpec,
    #[serde(default)]
    pub effects: Effects,
}

/// Which plant, and overrides of its default (paper) parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantSpec {
    pub kind: PlantKind,
    /// Parameter overrides, checked against the plant's own parameter type when the scene is
    /// built (unknown names are errors there, with the path `plant.params.NAME`).
    #[serde(default)]
    pub params: toml::Table,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlantKind {
    /// The Furuta (rotary inverted) pendulum of the paper.
    Furuta,
    /// A planar inverted pendulum on a motor-driven cart.
    Cart,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// V/rad.
    pub kp: f64,
    /// V s/rad.
    pub kd: f64,
    /// V s/rad, derivative gain on the secondary angle.
    #[serde(default)]
    pub kphi_d: f64,
    /// Sampling period, ms.
    pub dt_ms: f64,
    /// Feedback delay r in samples.
    #[serde(default = "one")]
    pub delay: u32,
}

fn one() -> u32 {
    1
}

/// Initial condition at t = 0 and the samples the controller saw before it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Plant state at t = 0 (its length must match the plant); default: all zero.
    #[serde(default)]
    pub state: Vec<f64>,
    /// The r + 1 samples (primary, secondary) before t = 0, oldest first; default: the plant
    /// at rest at the initial angles.
    #[serde(default)]
    pub history: Option<Vec<[f64; 2]>>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Task {
    /// Closed-loop simulation.
    Simulate,
    /// Exact multipliers of the linearized sampled-data loop.
    Stability,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Number of sampling periods to simulate.
    pub periods: u64,
    /// What to compute; default: simulate and stability.
    #[serde(default = "default_tasks")]
    pub tasks: Vec<Task>,
    /// Stop the run when |primary angle| exceeds this many radians (an escape), if set.
    #[serde(default)]
    pub escape_theta: Option<f64>,
}

fn default_tasks() -> Vec<Task> {
    vec![Task::Simulate, Task::Stability]
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodKind {
    /// Adaptive L-stable Rosenbrock (RODAS4), error-controlled by rtol/atol.
    Rodas,
    /// The same scheme with a fixed number of steps per period.
    RodasFixed,
    /// Classical explicit RK4 with a fixed number of steps per period (baseline).
    Rk4,
    /// Adaptive exponential Rosenbrock (exprb43), error-controlled by rtol/atol; integrates
    /// the stiff transient after each input jump exactly.
    Exprb,
    /// The same scheme with a fixed number of steps per period.
    ExprbFixed,
    /// Adaptive exprb43 with the fast mode split off the `phi`-functions (closed form for
    /// the dominant eigenvalue, short Taylor sums for the rest): the steps of `exprb` at a
    /// fraction of the cost per step; error-controlled by rtol/atol.
    ExprbSplit,
    /// exprb-split made lean (closed-form Jacobian, warm-started eigenpair, Taylor sums cut
    /// at the tolerance, the period's first step learnt): fewer flops per step and fewer
    /// steps per period; error-controlled by rtol/atol.
    ExprbLean,
    /// exprb-lean with the fast-mode component of the error estimate weighted down in steps
    /// much shorter than the fast time constant (early in the transient after each input
    /// jump): about half the steps of exprb-lean for the same error on the smooth Furuta
    /// loops; error-controlled by rtol/atol.
    ExprbFiltered,
    /// Adaptive exprb54s4 (order 5, embedded order 4; Luan & Ostermann 2014) on exprb-lean's
    /// machinery: opt-in, for measuring a higher-order method against exprb-filtered; no
    /// bundled scene or report section uses it. Error-controlled by rtol/atol.
    Exprb54,
    /// exprb54 with exprb-filtered's weighting of the error estimate's fast-mode component.
    Exprb54Filtered,
}

impl MethodKind {
    /// The scene file's name of the method (`integrator.method`, e.g. `"exprb-lean"`).
    pub fn key(self) -> &'static str {
        match self {
            MethodKind::Rodas => "rodas",
            MethodKind::RodasFixed => "rodas-fixed",
            MethodKind::Rk4 => "rk4",
            MethodKind::Exprb => "exprb",
            MethodKind::ExprbFixed => "exprb-fixed",
            MethodKind::ExprbSplit => "exprb-split",
            MethodKind::ExprbLean => "exprb-lean",
            MethodKind::ExprbFiltered => "exprb-filtered",
            MethodKind::Exprb54 => "exprb54",
            MethodKind::Exprb54Filtered => "exprb54-filtered",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    #[serde(default = "default_method")]
    pub method: MethodKind,
    /// Relative tolerance (rodas, exprb).
    #[serde(default)]
    pub rtol: Option<f64>,
    /// Absolute tolerance (rodas, exprb).
    #[serde(default)]
    pub atol: Option<f64>,
    /// Steps per sampling period (rodas-fixed, exprb-fixed, rk4).
    #[serde(default)]
    pub steps: Option<u32>,
}

fn default_method() -> MethodKind {
    MethodKind::Rodas
}

impl Default for IntegratorSpec {
    fn default() -> Self {
        Self { method: MethodKind::Rodas, rtol: Some(1e-10), atol: Some(1e-12), steps: None }
    }
}

/// The effects a scene asks for; an absent table is an effect not simulated.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    #[serde(default)]
    pub quantization: Option<QuantSpec>,
    #[serde(default)]
    pub saturation: Option<SaturationSpec>,
    #[serde(default)]
    pub noise: Option<NoiseSpec>,
    #[serde(default)]
    pub integral: Option<IntegralSpec>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuantSpec {
    /// `counts` (encoder counts in, DAC code out: what a device does) or `literal` (the
    /// paper's formula read literally, one step h = h_adc).
    pub mode: QuantModeSpec,
    /// rad per count of the primary angle.
    pub h_adc: f64,
    /// rad per count of the secondary angle; default: h_adc.
    #[serde(default)]
    pub h_adc_phi: Option<f64>,
    /// V per DAC code; default: h_adc * 1 V/rad (only meaningful for `counts`).
    #[serde(default)]
    pub h_dac: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum QuantModeSpec {
    Counts,
    Literal,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SaturationSpec {
    /// |u| <= u_max, V.
    pub u_max: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Seed of the ChaCha8 generator: the same seed gives the same run, bit for bit.
    pub seed: u64,
    /// Standard deviation of Gaussian noise added to the sampled primary angle, rad.
    pub sigma_theta: f64,
    /// The same for the secondary angle, rad.
    #[serde(default)]
    pub sigma_phi: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegralSpec {
    /// Integral gain, V/(rad s).
    pub ki: f64,
}

/// A scene that could not be read or is invalid; the message names the key path.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read scene file {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("scene {scene}: TOML syntax: {message}")]
    Syntax { scene: String, message: String },
    #[error("scene {scene}: `{path}`: {message}")]
    Key { scene: String, path: String, message: String },
    #[error("unknown scene `{0}`: not a bundled scene name (see `ssmctl scenes`) nor a readable .toml file")]
    Unknown(String),
    #[error("override `{0}`: expected PATH=VALUE, e.g. controller.dt_ms=31.2")]
    BadOverride(String),
}

impl SceneError {
    fn key(scene: &str, path: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Key { scene: scene.into(), path: path.into(), message: message.into() }
    }
}

/// Typed edits of a parsed scene, for code that derives runs from a scene (parametric
/// sweeps, full-system checks, benches). The `--set PATH=VALUE` strings are the command
/// line's; programs set fields here. Each setter replaces one field; [`SceneBuilder::build`]
/// validates the result exactly as a parsed scene file is validated.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    scene: Scene,
    /// A setter that needed a table the scene does not have (its key path).
    missing: Option<&'static str>,
}

impl SceneBuilder {
    /// Starts from a bundled scene (or a scene file) without overrides.
    pub fn load(name_or_file: &str) -> Result<Self, SceneError> {
        Ok(Scene::load(name_or_file, &[])?.builder())
    }

    /// Sampling period, ms (the scene file's unit).
    pub fn dt_ms(mut self, dt_ms: f64) -> Self {
        self.scene.controller.dt_ms = dt_ms;
        self
    }

    /// Proportional gain on the primary angle, V/rad.
    pub fn kp(mut self, kp: f64) -> Self {
        self.scene.controller.kp = kp;
        self
    }

    /// Derivative gain on the primary angle, V s/rad.
    pub fn kd(mut self, kd: f64) -> Self {
        self.scene.controller.kd = kd;
        self
    }

    /// Number of sampling periods to simulate.
    pub fn periods(mut self, periods: u64) -> Self {
        self.scene.run.periods = periods;
        self
    }

    /// Plant state at t = 0.
    pub fn initial_state(mut self, state: &[f64]) -> Self {
        self.scene.initial.state = state.to_vec();
        self
    }

    /// The `delay + 1` samples `[primary, secondary]` before t = 0, oldest first (`None`: the
    /// plant at rest at the initial angles).
    pub fn history(mut self, history: Option<&[[f64; 2]]>) -> Self {
        self.scene.initial.history = history.map(<[[f64; 2]]>::to_vec);
        self
    }

    /// Stop the run when |primary angle| exceeds this many radians.
    pub fn escape_theta(mut self, escape_theta: f64) -> Self {
        self.scene.run.escape_theta = Some(escape_theta);
        self
    }

    /// The integrator.
    pub fn integrator(mut self, integrator: IntegratorSpec) -> Self {
        self.scene.integrator = integrator;
        self
    }

    /// What the run computes.
    pub fn tasks(mut self, tasks: &[Task]) -> Self {
        self.scene.run.tasks = tasks.to_vec();
        self
    }

    /// Seed of the sensor noise; an error at [`SceneBuilder::build`] if the scene has none.
    pub fn noise_seed(mut self, seed: u64) -> Self {
        match &mut self.scene.effects.noise {
            Some(n) => n.seed = seed,
            None => self.missing = Some("effects.noise.seed"),
        }
        self
    }

    /// Quantization step of the primary angle, rad per count (`effects.quantization.h_adc`);
    /// an error at [`SceneBuilder::build`] if the scene has no quantization.
    pub fn quant_step(mut self, h_adc: f64) -> Self {
        match &mut self.scene.effects.quantization {
            Some(q) => q.h_adc = h_adc,
            None => self.missing = Some("effects.quantization.h_adc"),
        }
        self
    }

    /// The validated scene.
    pub fn build(self) -> Result<Scene, SceneError> {
        if let Some(path) = self.missing {
            return Err(SceneError::key(
                &self.scene.name,
                path,
                "the scene has no such table to set (it does not simulate this effect)",
            ));
        }
        self.scene.validate()?;
        Ok(self.scene)
    }
}

impl Scene {
    /// Loads a bundled scene by name, or a TOML file by path, applies `overrides`
    /// (`path.to.key=value`, value parsed as TOML, else taken as a string) and validates.
    pub fn load(name_or_file: &str, overrides: &[String]) -> Result<Self, SceneError> {
        let (label, text) = if let Some(text) = bundled::get(name_or_file) {
            (name_or_file.to_string(), text.to_string())
        } else if name_or_file.ends_with(".toml") || Path::new(name_or_file).is_file() {
            let text = infile::read_text(Path::new(name_or_file), infile::MAX_SCENE_BYTES)
                .map_err(|source| SceneError::Io { path: name_or_file.into(), source })?;
            (name_or_file.to_string(), text)
        } else {
            return Err(SceneError::Unknown(name_or_file.into()));
        };
        Self::parse(&label, &text, overrides)
    }

    /// Parses scene TOML text (`label` names it in errors).
    pub fn parse(label: &str, text: &str, overrides: &[String]) -> Result<Self, SceneError> {
        infile::check_nesting(text, infile::MAX_NESTING)
            .map_err(|message| SceneError::Syntax { scene: label.into(), message })?;
        let mut table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| SceneError::Syntax { scene: label.into(), message: e.message().into() })?;
        for o in overrides {
            apply_override(label, &mut table, o)?;
        }
        let scene: Scene = serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| SceneError::key(label, e.path().to_string(), e.inner().to_string()))?;
        scene.validate()?;
        Ok(scene)
    }

    /// Checks values the types cannot: finiteness, signs, lengths.
    pub fn validate(&self) -> Result<(), SceneError> {
        let s = self.name.as_str();
        let finite = |path: &str, v: f64| {
            if v.is_finite() { Ok(()) } else { Err(SceneError::key(s, path, format!("must be finite, got {v}"))) }
        };
        let positive = |path: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(SceneError::key(s, path, format!("must be finite and > 0, got {v}")))
            }
        };
        check_name(&self.name)?;
        let c = &self.controller;
        if let Some(q) = &self.effects.quantization {
            if q.mode == QuantModeSpec::Literal && q.h_dac.is_some() {
                return Err(SceneError::key(
                    s,
                    "effects.quantization.h_dac",
                    "the literal reading uses one step h = h_adc for ADC and DAC; remove h_dac",
                ));
            }
        }
        // A subnormal sampling period (in seconds) means nothing and breaks the time axis.
        let dt = self.dt();
        if dt.is_finite() && dt > 0.0 && !dt.is_normal() {
            return Err(SceneError::key(
                s,
                "controller.dt_ms",
                format!("{:e} ms is too small a sampling period ({dt:e} s is subnormal)", c.dt_ms),
            ));
        }
        // The controller configuration: the one validation every boundary uses (scene,
        // decoded blob, export), with the controller's message under the scene's key path.
        controller::validate_config::<{ controller::HISTORY }>(&self.controller_config())
            .map_err(|e| self.config_error(&e))?;
        if self.run.periods > MAX_PERIODS {
            return Err(SceneError::key(
                s,
                "run.periods",
                format!("{} exceeds the limit of {MAX_PERIODS} periods (the run is held in memory)", self.run.periods),
            ));
        }
        for (i, v) in self.initial.state.iter().enumerate() {
            finite(&format!("initial.state[{i}]"), *v)?;
        }
        if let Some(h) = &self.initial.history {
            let need = c.delay as usize + 1;
            if h.len() != need {
                return Err(SceneError::key(
                    s,
                    "initial.history",
                    format!("needs delay + 1 = {need} samples [primary, secondary], oldest first; got {}", h.len()),
                ));
            }
            for (i, pair) in h.iter().enumerate() {
                finite(&format!("initial.history[{i}][0]"), pair[0])?;
                finite(&format!("initial.history[{i}][1]"), pair[1])?;
            }
        }
        if self.run.periods == 0 && self.run.tasks.contains(&Task::Simulate) {
            return Err(SceneError::key(s, "run.periods", "must be >= 1 when the scene simulates"));
        }
        if let Some(e) = self.run.escape_theta {
            positive("run.escape_theta", e)?;
        }
        if self.run.tasks.is_empty() {
            return Err(SceneError::key(s, "run.tasks", "lists nothing to do"));
        }
        let i = &self.integrator;
        match i.method {
            MethodKind::Rodas
            | MethodKind::Exprb
            | MethodKind::ExprbSplit
            | MethodKind::ExprbLean
            | MethodKind::ExprbFiltered
            | MethodKind::Exprb54
            | MethodKind::Exprb54Filtered => {
                if i.steps.is_some() {
                    return Err(SceneError::key(s, "integrator.steps", "not used by adaptive methods (set rtol/atol)"));
                }
                for (key, v, (lo, hi)) in [
                    ("integrator.rtol", i.rtol.unwrap_or(1e-10), RTOL_RANGE),
                    ("integrator.atol", i.atol.unwrap_or(1e-12), ATOL_RANGE),
                ] {
                    positive(key, v)?;
                    if !(lo..=hi).contains(&v) {
                        return Err(SceneError::key(
                            s,
                            key,
                            format!(
                                "{v} is outside {lo:e} ..= {hi:e}: a tolerance the integrator cannot meet in bounded work, or one that means nothing"
                            ),
                        ));
                    }
                }
            }
            MethodKind::RodasFixed | MethodKind::Rk4 | MethodKind::ExprbFixed => {
                if i.rtol.is_some() || i.atol.is_some() {
                    return Err(SceneError::key(
                        s,
                        "integrator.rtol",
                        "fixed-step methods take `steps`, not tolerances",
                    ));
                }
                match i.steps {
                    Some(n) if n >= 1 => {
                        if u64::from(n) > MAX_STEPS_PER_PERIOD {
                            return Err(SceneError::key(
                                s,
                                "integrator.steps",
                                format!("{n} exceeds the limit of {MAX_STEPS_PER_PERIOD} steps per period"),
                            ));
                        }
                        // The step must be resolvable on the time axis at the run's end.
                        let dt = self.dt();
                        let t_end = dt * self.run.periods.max(1) as f64;
                        let h = dt / f64::from(n);
                        let spacing = f64::EPSILON * t_end;
                        if !(h > 16.0 * spacing) {
                            return Err(SceneError::key(
                                s,
                                "integrator.steps",
                                format!(
                                    "{n} steps per period make the step {h:e} s, below the time axis's resolution near t = {t_end:e} s ({spacing:e} s): the steps would not advance the time"
                                ),
                            ));
                        }
                    }
                    _ => return Err(SceneError::key(s, "integrator.steps", "fixed-step methods need steps >= 1")),
                }
            }
        }
        if let Some(n) = &self.effects.noise {
            if !(n.sigma_theta.is_finite() && n.sigma_theta >= 0.0) {
                return Err(SceneError::key(s, "effects.noise.sigma_theta", "must be finite and >= 0"));
            }
            if !(n.sigma_phi.is_finite() && n.sigma_phi >= 0.0) {
                return Err(SceneError::key(s, "effects.noise.sigma_phi", "must be finite and >= 0"));
            }
        }
        Ok(())
    }

    /// A controller configuration error under the key it is about. A fixed-point gain (or
    /// `u_max` in DAC codes) that is out of range only because of a quantization step (the
    /// same value is representable with the paper's steps of pi/1000) is the step's error,
    /// not the gain's.
    fn config_error(&self, e: &controller::ConfigError) -> SceneError {
        use controller::Field;
        let s = self.name.as_str();
        if let (
            controller::ConfigError::OutOfRange(f @ (Field::Kp | Field::Kd | Field::KphiD | Field::Ki | Field::UMax)),
            Some(q),
        ) = (e, &self.effects.quantization)
        {
            let cfg = self.controller_config();
            let paper = 1e-3 * std::f64::consts::PI;
            let reference = ControllerConfig {
                quant: cfg.quant.map(|q| Quantization { h_adc: paper, h_adc_phi: paper, h_dac: paper, ..q }),
                ..cfg
            };
            if controller::validate_config::<{ controller::HISTORY }>(&reference).is_ok() {
                let step = match (f, q.h_adc_phi.is_some()) {
                    (Field::KphiD, true) => "effects.quantization.h_adc_phi",
                    _ => "effects.quantization.h_adc",
                };
                let dac = if q.h_dac.is_some() { " (or effects.quantization.h_dac)" } else { "" };
                return SceneError::key(
                    s,
                    step,
                    format!(
                        "with this step{dac}, `{}` is not representable in the integer controller (in DAC codes per encoder count, or DAC codes, it is out of range or rounds to zero), though it is with the paper's steps: {e}",
                        f.name()
                    ),
                );
            }
        }
        SceneError::key(s, self.config_key(e), e.to_string())
    }

    /// The scene key path of the field a controller configuration error is about.
    fn config_key(&self, e: &controller::ConfigError) -> &'static str {
        use controller::Field;
        let q = self.effects.quantization.as_ref();
        match e.field() {
            Some(Field::Kp) => "controller.kp",
            Some(Field::Kd) => "controller.kd",
            Some(Field::KphiD) => "controller.kphi_d",
            Some(Field::Ki) => "effects.integral.ki",
            Some(Field::Dt) => "controller.dt_ms",
            Some(Field::UMax) => "effects.saturation.u_max",
            Some(Field::HAdc) => "effects.quantization.h_adc",
            // Defaults come from h_adc: name the key the value came from.
            Some(Field::HAdcPhi) if q.is_some_and(|q| q.h_adc_phi.is_some()) => "effects.quantization.h_adc_phi",
            Some(Field::HDac) if q.is_some_and(|q| q.h_dac.is_some()) => "effects.quantization.h_dac",
            Some(Field::HAdcPhi | Field::HDac) => "effects.quantization.h_adc",
            None => match e {
                controller::ConfigError::DelayTooLong { .. } => "controller.delay",
                _ => "effects.quantization",
            },
        }
    }

    /// Sampling period in seconds (the one place the scene's millisecond field is converted).
    pub fn dt(&self) -> f64 {
        crate::units::ms_to_s(self.controller.dt_ms)
    }

    /// Typed edits of this scene (see [`SceneBuilder`]).
    pub fn builder(self) -> SceneBuilder {
        SceneBuilder { scene: self, missing: None }
    }

    /// The controller configuration this scene runs (what a device would be flashed with).
    pub fn controller_config(&self) -> ControllerConfig {
        let c = &self.controller;
        ControllerConfig {
            kp: c.kp,
            kd: c.kd,
            kphi_d: c.kphi_d,
            ki: self.effects.integral.as_ref().map_or(0.0, |i| i.ki),
            dt: self.dt(),
            delay: c.delay,
            u_max: self.effects.saturation.as_ref().map(|s| s.u_max),
            quant: self.effects.quantization.as_ref().map(|q| Quantization {
                mode: match q.mode {
                    QuantModeSpec::Counts => QuantMode::Counts,
                    QuantModeSpec::Literal => QuantMode::Literal,
                },
                h_adc: q.h_adc,
                h_adc_phi: q.h_adc_phi.unwrap_or(q.h_adc),
                h_dac: q.h_dac.unwrap_or(q.h_adc),
            }),
        }
    }

    /// Names of the effects this scene simulates, for metadata and reports.
    pub fn effect_names(&self) -> Vec<String> {
        let e = &self.effects;
        let mut v = vec![format!("sampling/zoh dt={} ms, delay r={}", self.controller.dt_ms, self.controller.delay)];
        if let Some(q) = &e.quantization {
            v.push(format!(
                "quantization ({})",
                match q.mode {
                    QuantModeSpec::Counts => "counts",
                    QuantModeSpec::Literal => "literal",
                }
            ));
        }
        if let Some(s) = &e.saturation {
            v.push(format!("saturation |u| <= {} V", s.u_max));
        }
        if let Some(n) = &e.noise {
            v.push(format!("sensor noise seed={} sigma_theta={} sigma_phi={}", n.seed, n.sigma_theta, n.sigma_phi));
        }
        if let Some(i) = &e.integral {
            v.push(format!("integral action ki={}", i.ki));
        }
        v
    }

    pub fn wants(&self, t: Task) -> bool {
        self.run.tasks.contains(&t)
    }
}

/// Largest `run.periods` of a scene: a run is held in memory (about 60 bytes a period).
pub const MAX_PERIODS: u64 = 10_000_000;

/// Largest length of a scene name.
pub const MAX_NAME_LEN: usize = 100;

/// Scene names become file names (`simulate` writes `DIR/<name>.csv`): only ASCII letters,
/// digits, `-`, `_` and `.` are allowed, not starting with `.` (no `..`, no separators, no
/// absolute paths, no hidden files), at most [`MAX_NAME_LEN`] characters.
pub fn check_name(name: &str) -> Result<(), SceneError> {
    let ok_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    let why = if name.is_empty() {
        Some("is empty".to_string())
    } else if name.len() > MAX_NAME_LEN {
        Some(format!("is {} characters long, the limit is {MAX_NAME_LEN}", name.len()))
    } else if name.starts_with('.') {
        Some("starts with `.`".to_string())
    } else if let Some(c) = name.chars().find(|c| !ok_char(*c)) {
        Some(format!("contains {c:?}"))
    } else {
        None
    };
    match why {
        None => Ok(()),
        Some(why) => Err(SceneError::key(
            &name.chars().take(MAX_NAME_LEN).collect::<String>(),
            "name",
            format!(
                "{why}: a scene name becomes a file name and may hold only ASCII letters, digits, `-`, `_` and `.` (not first)"
            ),
        )),
    }
}

/// Applies `a.b.c=value` to the table, creating intermediate tables as needed.
/// Relative tolerances an adaptive integrator accepts: tighter than 1e-14 cannot be met in
/// f64 in bounded work, looser than 0.1 means nothing.
pub const RTOL_RANGE: (f64, f64) = (1e-14, 0.1);
/// Absolute tolerances an adaptive integrator accepts (the states are O(1) rad, rad/s).
pub const ATOL_RANGE: (f64, f64) = (1e-20, 1.0);
/// Most steps per sampling period of a fixed-step integrator.
pub const MAX_STEPS_PER_PERIOD: u64 = 1_000_000;

/// Deepest dotted key of a `--set` override (the scene's own keys are at most 3 deep).
pub const MAX_KEY_DEPTH: usize = 8;

fn apply_override(label: &str, table: &mut toml::Table, o: &str) -> Result<(), SceneError> {
    let (path, raw) = o.split_once('=').ok_or_else(|| SceneError::BadOverride(o.into()))?;
    let path = path.trim();
    if path.is_empty() || path.split('.').any(str::is_empty) {
        return Err(SceneError::BadOverride(o.into()));
    }
    let keys: Vec<&str> = path.split('.').collect();
    if keys.len() > MAX_KEY_DEPTH {
        return Err(SceneError::key(
            label,
            path,
            format!("{} dotted keys; a scene key has at most {MAX_KEY_DEPTH}", keys.len()),
        ));
    }
    infile::check_nesting(raw, infile::MAX_NESTING)
        .map_err(|e| SceneError::key(label, path, format!("value: {}", e.trim_start_matches("line 1: "))))?;
    let value = parse_value(raw.trim());
    let (last, parents) = keys.split_last().ok_or_else(|| SceneError::BadOverride(o.into()))?;
    let mut cur = table;
    let mut walked = String::new();
    for k in parents {
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(k);
        let entry = cur.entry((*k).to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = match entry {
            toml::Value::Table(t) => t,
            other => {
                return Err(SceneError::key(
                    label,
                    walked,
                    format!("cannot set `{path}`: this key is a {}, not a table", other.type_str()),
                ));
            }
        };
    }
    cur.insert((*last).to_string(), value);
    Ok(())
}

/// A TOML value if `raw` parses as one (number, bool, array, quoted string), else a string.
fn parse_value(raw: &str) -> toml::Value {
    let doc = format!("v = {raw}");
    match doc.parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(raw.into())),
        Err(_) => toml::Value::String(raw.into()),
    }
}

#[cfg(test)]
mod tests;
