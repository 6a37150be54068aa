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

pub mod axis;
pub(crate) mod bundled;

pub use bundled::{BUNDLED, bundled_names};

use crate::plant::equations::{EquationsModel, EquationsSpec, Form};
use serde::{Deserialize, Serialize};
use shared::{ControllerConfig, Gain, Gains, QuantMode, Quantization};
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
    /// `kind = "equations"`: the generalized coordinates (velocities are `<name>_dot`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coordinates: Option<Vec<String>>,
    /// `kind = "equations"`: named constants the expressions use.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameters: Option<toml::Table>,
    /// `kind = "equations"`: the mass matrix `M(q)`, one row of expressions per coordinate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<Vec<Vec<String>>>,
    /// `kind = "equations"`: the forces `f(q, q', u)` of `M(q) q'' = f`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forces: Option<Vec<String>>,
    /// `kind = "equations"`: a Lagrangian `L(q, q')` instead of `mass` and `forces`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lagrangian: Option<String>,
    /// `kind = "equations"`: the generalized forces `Q(q, q', u)` beside the Lagrangian.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generalized_forces: Option<Vec<String>>,
    /// `kind = "equations"`: the equilibrium to stabilize (coordinates); default the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub equilibrium: Option<Vec<f64>>,
}

impl PlantSpec {
    /// The equations of a `kind = "equations"` plant (keys checked for presence and
    /// consistency; the expressions are checked by [`EquationsModel::new`]). `None` for a
    /// built-in plant, which must not carry the equation keys.
    pub fn equations(&self, scene: &str) -> Result<Option<EquationsSpec>, SceneError> {
        let given: Vec<&str> = [
            ("coordinates", self.coordinates.is_some()),
            ("parameters", self.parameters.is_some()),
            ("mass", self.mass.is_some()),
            ("forces", self.forces.is_some()),
            ("lagrangian", self.lagrangian.is_some()),
            ("generalized_forces", self.generalized_forces.is_some()),
            ("equilibrium", self.equilibrium.is_some()),
        ]
        .into_iter()
        .filter(|(_, g)| *g)
        .map(|(k, _)| k)
        .collect();
        if self.kind != PlantKind::Equations {
            return match given.first() {
                Some(k) => Err(SceneError::key(
                    scene,
                    format!("plant.{k}"),
                    "only a plant of kind = \"equations\" takes equations (built-in plants take `params`)",
                )),
                None => Ok(None),
            };
        }
        if let Some(k) = self.params.keys().next() {
            return Err(SceneError::key(
                scene,
                format!("plant.params.{k}"),
                "an equations plant takes its constants in `plant.parameters`",
            ));
        }
        let Some(coordinates) = self.coordinates.clone() else {
            return Err(SceneError::key(
                scene,
                "plant.coordinates",
                "missing: an equations plant names its coordinates",
            ));
        };
        let mut parameters = Vec::new();
        for (name, v) in self.parameters.iter().flatten() {
            let x = match v {
                toml::Value::Float(x) => *x,
                toml::Value::Integer(i) => *i as f64,
                other => {
                    return Err(SceneError::key(
                        scene,
                        format!("plant.parameters.{name}"),
                        format!("must be a number, got a {}", other.type_str()),
                    ));
                }
            };
            parameters.push((name.clone(), x));
        }
        let mass_form = self.mass.is_some() || self.forces.is_some();
        let lagrange_form = self.lagrangian.is_some() || self.generalized_forces.is_some();
        let form = match (mass_form, lagrange_form) {
            (true, true) => {
                return Err(SceneError::key(
                    scene,
                    "plant.lagrangian",
                    "give either `mass` and `forces` or `lagrangian` and `generalized_forces`, not both",
                ));
            }
            (false, false) => {
                return Err(SceneError::key(
                    scene,
                    "plant.mass",
                    "missing: give `mass` and `forces`, or `lagrangian` and `generalized_forces`",
                ));
            }
            (true, false) => match (&self.mass, &self.forces) {
                (Some(mass), Some(forces)) => Form::Mass { mass: mass.clone(), forces: forces.clone() },
                (None, _) => {
                    return Err(SceneError::key(scene, "plant.mass", "missing: `forces` needs the mass matrix"));
                }
                (_, None) => return Err(SceneError::key(scene, "plant.forces", "missing: `mass` needs the forces")),
            },
            (false, true) => match (&self.lagrangian, &self.generalized_forces) {
                (Some(l), Some(q)) => Form::Lagrangian { lagrangian: l.clone(), generalized_forces: q.clone() },
                (None, _) => {
                    return Err(SceneError::key(scene, "plant.lagrangian", "missing: `generalized_forces` needs it"));
                }
                (_, None) => {
                    return Err(SceneError::key(
                        scene,
                        "plant.generalized_forces",
                        "missing: a Lagrangian needs its generalized forces (one per coordinate; \"0\" where none)",
                    ));
                }
            },
        };
        Ok(Some(EquationsSpec { coordinates, parameters, form, equilibrium: self.equilibrium.clone() }))
    }

    /// The compiled, checked equations of a `kind = "equations"` plant.
    pub fn equations_model(&self, scene: &str) -> Result<Option<EquationsModel>, SceneError> {
        match self.equations(scene)? {
            None => Ok(None),
            Some(spec) => EquationsModel::new(&spec).map(Some).map_err(|e| SceneError::key(scene, e.key, e.message)),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlantKind {
    /// The Furuta (rotary inverted) pendulum of the paper.
    Furuta,
    /// A planar inverted pendulum on a motor-driven cart.
    Cart,
    /// A plant written as equations in the scene (`coordinates`, `parameters`, `mass` and
    /// `forces` or `lagrangian` and `generalized_forces`).
    Equations,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// Shorthand: P gain on the first coordinate (the primary angle), V/rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kp: Option<f64>,
    /// Shorthand: D gain on the first coordinate, V s/rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kd: Option<f64>,
    /// Shorthand: derivative gain on the second coordinate (the secondary angle), V s/rad,
    /// with the opposite sign: its `d` is `-kphi_d`.
    #[serde(default)]
    pub kphi_d: f64,
    /// Per-coordinate gains by coordinate name, `{ theta = { p = -45.0, d = -7.0 } }`:
    /// `u = -sum_i [p_i q_i + d_i dq_i/dt]` on the delayed samples. Coordinates without an
    /// entry are not measured. Instead of `kp`, `kd`, `kphi_d`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gains: Option<std::collections::BTreeMap<String, GainSpec>>,
    /// Sampling period, ms.
    pub dt_ms: f64,
    /// Feedback delay r in samples.
    #[serde(default = "one")]
    pub delay: u32,
}

/// The gains of one measured coordinate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainSpec {
    /// Proportional gain, V per unit of the coordinate.
    #[serde(default)]
    pub p: f64,
    /// Derivative gain, V s per unit of the coordinate.
    #[serde(default)]
    pub d: f64,
    /// Encoder resolution of this coordinate (units per count) when the scene quantizes;
    /// default `effects.quantization.h_adc`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub h_adc: Option<f64>,
}

/// One measured coordinate of a scene's controller.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// The coordinate's name (`theta`, `x`, ...).
    pub name: String,
    /// Its index in the plant state.
    pub index: u8,
    pub p: f64,
    pub d: f64,
    /// Its encoder resolution (0 when the scene does not quantize).
    pub h_adc: f64,
    /// The scene key the resolution came from.
    pub h_key: &'static str,
}

fn one() -> u32 {
    1
}

/// Initial condition at t = 0 and the samples the controller saw before it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Plant state at t = 0 (its length must match the plant); default: all zero. A scene
    /// file may give it by name, `state = { theta = 0.05 }` (unnamed entries 0).
    #[serde(default)]
    pub state: Vec<f64>,
    /// The r + 1 samples before t = 0, oldest first, one value per measured coordinate (in
    /// coordinate order); default: the plant at rest at the initial coordinates.
    #[serde(default)]
    pub history: Option<Vec<Vec<f64>>>,
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
    #[error("scene {scene}: axis `{axis}`: {message}")]
    Axis { scene: String, axis: String, message: String },
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

    /// Proportional gain on the primary angle, V/rad (the first measured coordinate's `p`
    /// when the scene gives `gains`).
    pub fn kp(mut self, kp: f64) -> Self {
        match self.first_gain() {
            Some(g) => g.p = kp,
            None => self.scene.controller.kp = Some(kp),
        }
        self
    }

    /// Derivative gain on the primary angle, V s/rad (the first measured coordinate's `d`
    /// when the scene gives `gains`).
    pub fn kd(mut self, kd: f64) -> Self {
        match self.first_gain() {
            Some(g) => g.d = kd,
            None => self.scene.controller.kd = Some(kd),
        }
        self
    }

    /// The gains of the first measured coordinate (in coordinate order) of a scene with
    /// `gains`.
    fn first_gain(&mut self) -> Option<&mut GainSpec> {
        let first = self.scene.measured().ok()?.into_iter().next()?.name;
        self.scene.controller.gains.as_mut()?.get_mut(&first)
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
        self.scene.initial.history = history.map(|h| h.iter().map(|s| s.to_vec()).collect());
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
        resolve_named_state(label, &mut table)?;
        let scene: Scene = serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| SceneError::key(label, e.path().to_string(), e.inner().to_string()))?;
        scene.validate_as(label)?;
        Ok(scene)
    }

    /// Checks values the types cannot: finiteness, signs, lengths.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.validate_as(&self.name)
    }

    /// [`Scene::validate`], with the plant's equations reported under `label` (the scene
    /// file's path when loaded from a file).
    fn validate_as(&self, label: &str) -> Result<(), SceneError> {
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
        self.plant.equations_model(label)?;
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
        let measured = self.measured()?;
        if measured.len() > shared::MAX_GAINS {
            return Err(SceneError::key(
                s,
                "controller.gains",
                format!("measures {} coordinates; the controller takes at most {}", measured.len(), shared::MAX_GAINS),
            ));
        }
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
            let n = self.measured()?.len();
            if h.len() != need {
                return Err(SceneError::key(
                    s,
                    "initial.history",
                    format!(
                        "needs delay + 1 = {need} samples (one value per measured coordinate each), oldest first; got {}",
                        h.len()
                    ),
                ));
            }
            for (i, sample) in h.iter().enumerate() {
                if sample.len() != n {
                    return Err(SceneError::key(
                        s,
                        format!("initial.history[{i}]"),
                        format!("has {} values for {n} measured coordinates", sample.len()),
                    ));
                }
                for (k, v) in sample.iter().enumerate() {
                    finite(&format!("initial.history[{i}][{k}]"), *v)?;
                }
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
            controller::ConfigError::OutOfRange(f @ (Field::P(_) | Field::D(_) | Field::Ki | Field::UMax)),
            Some(q),
        ) = (e, &self.effects.quantization)
        {
            let paper = 1e-3 * std::f64::consts::PI;
            let mut reference = self.controller_config();
            for g in reference.gains.as_mut_slice() {
                g.h_adc = paper;
            }
            reference.quant = reference.quant.map(|q| Quantization { h_dac: paper, ..q });
            if controller::validate_config::<{ controller::HISTORY }>(&reference).is_ok() {
                // The step of the coordinate the gain acts on (the DAC step for ki and u_max).
                let step = match f {
                    Field::P(i) | Field::D(i) => self.config_key(&controller::ConfigError::NonFinite(Field::HAdc(*i))),
                    _ => "effects.quantization.h_adc".to_string(),
                };
                let dac = if q.h_dac.is_some() { " (or effects.quantization.h_dac)" } else { "" };
                return SceneError::key(
                    s,
                    &step,
                    format!(
                        "with this step{dac}, the gain {} is not representable in the integer controller (in DAC codes per encoder count, or DAC codes, it is out of range or rounds to zero), though it is with the paper's steps: {e}",
                        self.config_key(e)
                    ),
                );
            }
        }
        SceneError::key(s, self.config_key(e), e.to_string())
    }

    /// The scene key path of the field a controller configuration error is about.
    fn config_key(&self, e: &controller::ConfigError) -> String {
        use controller::Field;
        let q = self.effects.quantization.as_ref();
        let measured = self.measured().unwrap_or_default();
        let gains = self.controller.gains.is_some();
        let name = |i: u8| measured.get(usize::from(i)).map_or_else(|| format!("#{i}"), |m| m.name.clone());
        match e.field() {
            Some(Field::P(i)) if gains => format!("controller.gains.{}.p", name(i)),
            Some(Field::D(i)) if gains => format!("controller.gains.{}.d", name(i)),
            Some(Field::P(_)) => "controller.kp".into(),
            Some(Field::D(0)) => "controller.kd".into(),
            Some(Field::D(_)) => "controller.kphi_d".into(),
            Some(Field::HAdc(i)) => {
                measured.get(usize::from(i)).map_or("effects.quantization.h_adc".to_string(), |m| match m.h_key {
                    "gain" => format!("controller.gains.{}.h_adc", m.name),
                    k => k.to_string(),
                })
            }
            Some(Field::Ki) => "effects.integral.ki".into(),
            Some(Field::Dt) => "controller.dt_ms".into(),
            Some(Field::UMax) => "effects.saturation.u_max".into(),
            // Defaults come from h_adc: name the key the value came from.
            Some(Field::HDac) if q.is_some_and(|q| q.h_dac.is_some()) => "effects.quantization.h_dac".into(),
            Some(Field::HDac) => "effects.quantization.h_adc".into(),
            None => match e {
                controller::ConfigError::DelayTooLong { .. } => "controller.delay".into(),
                controller::ConfigError::NoGains
                | controller::ConfigError::DuplicateIndex { .. }
                | controller::ConfigError::GainSum => if gains { "controller.gains" } else { "controller.kp" }.into(),
                _ => "effects.quantization".into(),
            },
        }
    }

    /// The names of the plant's generalized coordinates, in state order (state index `2 i`).
    pub fn coordinate_names(&self) -> Vec<String> {
        match self.plant.kind {
            PlantKind::Furuta => vec!["theta".into(), "phi".into()],
            PlantKind::Cart => vec!["theta".into(), "x".into()],
            PlantKind::Equations => self.plant.coordinates.clone().unwrap_or_default(),
        }
    }

    /// The measured coordinates, in coordinate order, with their gains: from `gains`, or
    /// from the shorthand `kp`, `kd` (first coordinate) and `kphi_d` (second coordinate,
    /// `d = -kphi_d`), which for the built-in plants is exactly `Gains::shorthand`.
    pub fn measured(&self) -> Result<Vec<Measured>, SceneError> {
        let s = self.name.as_str();
        let c = &self.controller;
        let coords = self.coordinate_names();
        let q = self.effects.quantization.as_ref();
        let mut out = Vec::new();
        match &c.gains {
            Some(gains) => {
                for (key, what) in [("kp", c.kp.is_some()), ("kd", c.kd.is_some()), ("kphi_d", c.kphi_d != 0.0)] {
                    if what {
                        return Err(SceneError::key(
                            s,
                            format!("controller.{key}"),
                            "give either `gains` or the shorthand kp, kd, kphi_d, not both",
                        ));
                    }
                }
                if let Some(name) = gains.keys().find(|k| !coords.contains(k)) {
                    return Err(SceneError::key(
                        s,
                        format!("controller.gains.{name}"),
                        format!("not a coordinate of the plant (coordinates: {})", coords.join(", ")),
                    ));
                }
                if q.is_some_and(|q| q.h_adc_phi.is_some()) {
                    return Err(SceneError::key(
                        s,
                        "effects.quantization.h_adc_phi",
                        "with `gains`, give each coordinate's resolution as `controller.gains.NAME.h_adc`",
                    ));
                }
                for (i, name) in coords.iter().enumerate() {
                    if let Some(g) = gains.get(name) {
                        let (h_adc, h_key) = match (g.h_adc, q) {
                            (Some(h), _) => (h, "gain"),
                            (None, Some(q)) => (q.h_adc, "effects.quantization.h_adc"),
                            (None, None) => (0.0, "effects.quantization.h_adc"),
                        };
                        out.push(Measured { name: name.clone(), index: (2 * i) as u8, p: g.p, d: g.d, h_adc, h_key });
                    }
                }
                if out.is_empty() {
                    return Err(SceneError::key(s, "controller.gains", "names no coordinate: nothing is measured"));
                }
            }
            None => {
                let Some(kp) = c.kp else {
                    return Err(SceneError::key(s, "controller.kp", "missing: give kp and kd, or `gains`"));
                };
                let Some(kd) = c.kd else {
                    return Err(SceneError::key(s, "controller.kd", "missing: give kp and kd, or `gains`"));
                };
                let h0 = q.map_or(0.0, |q| q.h_adc);
                let first = coords.first().cloned().unwrap_or_default();
                out.push(Measured {
                    name: first,
                    index: 0,
                    p: kp,
                    d: kd,
                    h_adc: h0,
                    h_key: "effects.quantization.h_adc",
                });
                match coords.get(1) {
                    Some(second) => {
                        let (h1, key) = match q.and_then(|q| q.h_adc_phi) {
                            Some(h) => (h, "effects.quantization.h_adc_phi"),
                            None => (h0, "effects.quantization.h_adc"),
                        };
                        out.push(Measured {
                            name: second.clone(),
                            index: 2,
                            p: 0.0,
                            d: -c.kphi_d,
                            h_adc: h1,
                            h_key: key,
                        });
                    }
                    None if c.kphi_d != 0.0 => {
                        return Err(SceneError::key(s, "controller.kphi_d", "the plant has a single coordinate"));
                    }
                    None => {}
                }
            }
        }
        Ok(out)
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
    /// A scene whose gains do not resolve ([`Scene::measured`], which validation reports)
    /// gets an empty gain vector, which the controller refuses.
    pub fn controller_config(&self) -> ControllerConfig {
        let c = &self.controller;
        let mut gains = Gains::new();
        for m in self.measured().unwrap_or_default() {
            if gains.push(Gain { index: m.index, p: m.p, d: m.d, h_adc: m.h_adc }).is_err() {
                break;
            }
        }
        ControllerConfig {
            gains,
            ki: self.effects.integral.as_ref().map_or(0.0, |i| i.ki),
            dt: self.dt(),
            delay: c.delay,
            u_max: self.effects.saturation.as_ref().map(|s| s.u_max),
            quant: self.effects.quantization.as_ref().map(|q| Quantization {
                mode: match q.mode {
                    QuantModeSpec::Counts => QuantMode::Counts,
                    QuantModeSpec::Literal => QuantMode::Literal,
                },
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

/// `[initial] state = { theta = 0.05 }`: a state given by name becomes the array of the
/// plant's state order (unnamed entries 0), so that no ordering needs to be remembered.
/// Names are the plant's state names: for an equations plant each coordinate and its
/// `<coord>_dot`; for the built-in plants their CSV columns.
fn resolve_named_state(label: &str, table: &mut toml::Table) -> Result<(), SceneError> {
    let Some(toml::Value::Table(named)) = table.get("initial").and_then(|i| i.get("state")).cloned() else {
        return Ok(());
    };
    let plant = table.get("plant");
    let kind = plant.and_then(|p| p.get("kind")).and_then(toml::Value::as_str);
    let names: Vec<String> = match kind {
        Some("furuta") => ["theta", "w_theta", "phi", "w_phi"].map(String::from).to_vec(),
        Some("cart") => ["theta", "w_theta", "x", "v"].map(String::from).to_vec(),
        Some("equations") => {
            let coords = plant.and_then(|p| p.get("coordinates")).and_then(toml::Value::as_array);
            let Some(coords) = coords else {
                return Err(SceneError::key(label, "initial.state", "named states need `plant.coordinates`"));
            };
            coords.iter().filter_map(toml::Value::as_str).flat_map(|c| [c.to_string(), format!("{c}_dot")]).collect()
        }
        _ => return Err(SceneError::key(label, "initial.state", "named states need a known `plant.kind`")),
    };
    let mut state = vec![toml::Value::Float(0.0); names.len()];
    for (name, v) in &named {
        let key = format!("initial.state.{name}");
        let Some(i) = names.iter().position(|n| n == name) else {
            return Err(SceneError::key(
                label,
                key,
                format!("not a state of this plant (states: {})", names.join(", ")),
            ));
        };
        let x = match v {
            toml::Value::Float(x) => *x,
            toml::Value::Integer(k) => *k as f64,
            other => return Err(SceneError::key(label, key, format!("must be a number, got a {}", other.type_str()))),
        };
        if let Some(slot) = state.get_mut(i) {
            *slot = toml::Value::Float(x);
        }
    }
    if let Some(toml::Value::Table(init)) = table.get_mut("initial") {
        init.insert("state".into(), toml::Value::Array(state));
    }
    Ok(())
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
