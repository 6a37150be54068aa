//! Scene quantities a stability chart or a sweep varies, by name: one gain of one measured
//! coordinate (`theta.p`, `gains.x.d`; `kp`, `kd`, `kphi_d` are the Furuta shorthand) or one
//! plant parameter (`plant.parameters.m` of a plant written as equations, `plant.params.b1`
//! of a built-in one). Names are checked against the scene; an unknown one is an error that
//! lists what the scene has.

use super::{GainSpec, PlantKind, Scene, SceneError};
use crate::plant::{cart::CartParams, furuta::FurutaParams};
use shared::ControllerConfig;

/// One scene quantity a grid axis sets.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneAxis {
    /// The P (`derivative == false`) or D gain of the measured coordinate `coord`, entry
    /// `slot` of the gain vector. `negate`: the axis value is the gain's negative (the
    /// shorthand `kphi_d`, whose D gain is `-kphi_d`).
    Gain { name: String, coord: String, slot: usize, derivative: bool, negate: bool },
    /// A plant parameter; `table` is `parameters` (equations plant) or `params` (built-in).
    Parameter { name: String, table: &'static str, key: String },
}

impl SceneAxis {
    /// The axis `name` of `scene`: `kp`, `kd`, `kphi_d`, `COORD.p`, `COORD.d` (optionally
    /// prefixed `gains.` or `controller.gains.`), `plant.parameters.NAME` or
    /// `plant.params.NAME`. An unknown name, a coordinate the controller does not measure or
    /// a parameter the plant does not have is an error listing the scene's axes.
    pub fn parse(scene: &Scene, name: &str) -> Result<Self, SceneError> {
        let err = |why: String| SceneError::Axis {
            scene: scene.name.clone(),
            axis: name.into(),
            message: format!("{why}; this scene's axes are {}", Self::names(scene).join(", ")),
        };
        let measured = scene.measured()?;
        let gain = |coord: &str, derivative: bool, negate: bool| -> Result<Self, SceneError> {
            let slot = measured.iter().position(|m| m.name == coord).ok_or_else(|| {
                err(if scene.coordinate_names().iter().any(|c| c == coord) {
                    format!("coordinate `{coord}` is not measured (it has no gains in the scene)")
                } else {
                    format!("`{coord}` is not a coordinate of the plant")
                })
            })?;
            Ok(Self::Gain { name: name.into(), coord: coord.into(), slot, derivative, negate })
        };
        match name {
            "kp" | "kd" => {
                let first = measured.first().map(|m| m.name.clone()).unwrap_or_default();
                return gain(&first, name == "kd", false);
            }
            "kphi_d" => {
                let second = scene.coordinate_names().get(1).cloned();
                return match second {
                    Some(c) if measured.get(1).is_some_and(|m| m.name == c) => gain(&c, true, true),
                    _ => Err(err("`kphi_d` is the D gain of a measured second coordinate".into())),
                };
            }
            _ => {}
        }
        if let Some(p) = name.strip_prefix("plant.parameters.").or_else(|| name.strip_prefix("plant.params.")) {
            let table = if name.starts_with("plant.parameters.") { "parameters" } else { "params" };
            let want = if scene.plant.kind == PlantKind::Equations { "parameters" } else { "params" };
            if table != want {
                return Err(err(format!("a {} plant takes its parameters as `plant.{want}.NAME`", kind_name(scene))));
            }
            if !Self::parameter_names(scene).iter().any(|n| n == p) {
                return Err(err(format!("`{p}` is not a parameter of the plant")));
            }
            return Ok(Self::Parameter { name: name.into(), table, key: p.into() });
        }
        let rest = name.strip_prefix("controller.gains.").or_else(|| name.strip_prefix("gains.")).unwrap_or(name);
        match rest.rsplit_once('.') {
            Some((coord, "p")) => gain(coord, false, false),
            Some((coord, "d")) => gain(coord, true, false),
            _ => Err(err(format!("unknown axis `{name}`"))),
        }
    }

    /// The names [`parse`](Self::parse) accepts for `scene`: each measured coordinate's
    /// `.p` and `.d`, the shorthand where it applies, each plant parameter.
    pub fn names(scene: &Scene) -> Vec<String> {
        let measured = scene.measured().unwrap_or_default();
        let mut v: Vec<String> =
            measured.iter().flat_map(|m| [format!("{}.p", m.name), format!("{}.d", m.name)]).collect();
        if !measured.is_empty() {
            v.extend(["kp".into(), "kd".into()]);
        }
        if scene.coordinate_names().get(1).is_some_and(|c| measured.get(1).is_some_and(|m| &m.name == c)) {
            v.push("kphi_d".into());
        }
        let table = if scene.plant.kind == PlantKind::Equations { "parameters" } else { "params" };
        v.extend(Self::parameter_names(scene).into_iter().map(|p| format!("plant.{table}.{p}")));
        v
    }

    /// The plant's parameter names: the scene's `plant.parameters`, or the fields of the
    /// built-in plant's parameter type.
    fn parameter_names(scene: &Scene) -> Vec<String> {
        let table = match scene.plant.kind {
            PlantKind::Equations => scene.plant.parameters.clone().unwrap_or_default(),
            PlantKind::Furuta => toml::Table::try_from(FurutaParams::default()).unwrap_or_default(),
            PlantKind::Cart => toml::Table::try_from(CartParams::default()).unwrap_or_default(),
        };
        table.keys().cloned().collect()
    }

    /// The name the axis was given by.
    pub fn name(&self) -> &str {
        match self {
            Self::Gain { name, .. } | Self::Parameter { name, .. } => name,
        }
    }

    /// Whether two axes set the same quantity (`kp` and `theta.p` of a Furuta do).
    pub fn same_quantity(&self, other: &Self) -> bool {
        match (self, other) {
            (Self::Gain { slot: a, derivative: da, .. }, Self::Gain { slot: b, derivative: db, .. }) => {
                a == b && da == db
            }
            (Self::Parameter { key: a, .. }, Self::Parameter { key: b, .. }) => a == b,
            _ => false,
        }
    }

    /// Whether the axis is a controller gain (it changes the controller, not the plant).
    pub fn is_gain(&self) -> bool {
        matches!(self, Self::Gain { .. })
    }

    /// Sets a gain axis to `v` in `cfg` (a parameter axis leaves it unchanged).
    pub fn set_gain(&self, cfg: &mut ControllerConfig, v: f64) {
        if let Self::Gain { slot, derivative, negate, .. } = self {
            if let Some(g) = cfg.gains.get_mut(*slot) {
                let v = if *negate { -v } else { v };
                if *derivative {
                    g.d = v;
                } else {
                    g.p = v;
                }
            }
        }
    }

    /// The axis value of `scene` (a built-in plant's parameter not overridden: its default).
    pub fn value(&self, scene: &Scene) -> Result<f64, SceneError> {
        match self {
            Self::Gain { slot, derivative, negate, .. } => {
                let m = scene.measured()?;
                let g = m.get(*slot).map_or(0.0, |g| if *derivative { g.d } else { g.p });
                Ok(if *negate { -g } else { g })
            }
            Self::Parameter { key, .. } => {
                let defaults = match scene.plant.kind {
                    PlantKind::Equations => toml::Table::new(),
                    PlantKind::Furuta => toml::Table::try_from(FurutaParams::default()).unwrap_or_default(),
                    PlantKind::Cart => toml::Table::try_from(CartParams::default()).unwrap_or_default(),
                };
                let given = match scene.plant.kind {
                    PlantKind::Equations => scene.plant.parameters.as_ref(),
                    _ => Some(&scene.plant.params),
                };
                let v = given.and_then(|t| t.get(key)).or_else(|| defaults.get(key));
                Ok(match v {
                    Some(toml::Value::Float(x)) => *x,
                    Some(toml::Value::Integer(i)) => *i as f64,
                    _ => f64::NAN,
                })
            }
        }
    }

    /// `scene` with the axis set to `v`, validated as a scene file is. A gain the shorthand
    /// cannot express (a P gain on the second coordinate) turns the scene's shorthand into
    /// the equivalent per-coordinate `gains` first.
    pub fn apply(&self, scene: &Scene, v: f64) -> Result<Scene, SceneError> {
        let mut s = scene.clone();
        match self {
            Self::Parameter { table, key, .. } => {
                let t = if *table == "parameters" {
                    s.plant.parameters.get_or_insert_with(toml::Table::new)
                } else {
                    &mut s.plant.params
                };
                t.insert(key.clone(), toml::Value::Float(v));
            }
            Self::Gain { coord, slot, derivative, negate, .. } => {
                let v = if *negate { -v } else { v };
                let c = &mut s.controller;
                match (&mut c.gains, *slot, *derivative) {
                    (Some(g), _, _) => {
                        if let Some(g) = g.get_mut(coord) {
                            if *derivative {
                                g.d = v;
                            } else {
                                g.p = v;
                            }
                        }
                    }
                    (None, 0, false) => c.kp = Some(v),
                    (None, 0, true) => c.kd = Some(v),
                    (None, _, true) => c.kphi_d = -v,
                    (None, _, false) => {
                        to_gains(&mut s)?;
                        return self.apply(&s, if *negate { -v } else { v });
                    }
                }
            }
        }
        s.validate()?;
        Ok(s)
    }
}

fn kind_name(scene: &Scene) -> &'static str {
    match scene.plant.kind {
        PlantKind::Furuta => "built-in Furuta",
        PlantKind::Cart => "built-in cart",
        PlantKind::Equations => "equations",
    }
}

/// Replaces the shorthand `kp`, `kd`, `kphi_d` (and `h_adc_phi`) by the same gains per
/// coordinate.
fn to_gains(s: &mut Scene) -> Result<(), SceneError> {
    let quantized = s.effects.quantization.is_some();
    let gains = s
        .measured()?
        .into_iter()
        .map(|m| (m.name, GainSpec { p: m.p, d: m.d, h_adc: quantized.then_some(m.h_adc) }))
        .collect();
    let c = &mut s.controller;
    c.gains = Some(gains);
    c.kp = None;
    c.kd = None;
    c.kphi_d = 0.0;
    if let Some(q) = &mut s.effects.quantization {
        q.h_adc_phi = None;
    }
    Ok(())
}
