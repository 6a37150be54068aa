//! The closed-loop simulator: the plant integrated period by period under the held input,
//! sampled at each period start, fed through exactly the controller code the device runs
//! (`controller::pd::FloatPd`, `controller::quant::IntPd` or `LiteralPd`).
//!
//! Owns composing the effects a scene names (and only those): quantization picks the integer
//! path, noise creates the seeded generator, saturation and integral action go into the
//! controller configuration. Must not implement control law arithmetic itself.

use crate::ode::{Integrator, Method, OdeError, OdeStats};
use crate::plant::equations::MAX_COORDINATES;
use crate::plant::{Cart, CartParams, EquationsPlant, Furuta, FurutaParams, Plant, PlantError};
use crate::scene::{MethodKind, PlantKind, Scene, SceneError};
use controller::{FloatPd, IntPd, LiteralPd, adc};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use shared::{ControllerConfig, QuantMode};
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

/// History capacity of the controllers the simulator instantiates (delay r <= 6): the
/// project's one capacity, the firmware's too.
pub const HISTORY: usize = controller::HISTORY;

/// Anything that can go wrong building or running a scene.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("scene {scene}: plant: {source}")]
    Plant { scene: String, source: PlantError },
    #[error("scene {scene}: controller configuration: {message}")]
    Controller { scene: String, message: String },
    #[error("scene {scene}: integrator: {source}")]
    Ode { scene: String, source: OdeError },
    #[error("scene {scene}: sensor at t = {t} s: {message}")]
    Sensor { scene: String, t: f64, message: String },
    #[error("scene {scene}: `initial.state` has {got} values, the {plant} plant has {need} states")]
    StateLength { scene: String, plant: &'static str, got: usize, need: usize },
    #[error("writing {path}: {source}")]
    Io { path: String, source: std::io::Error },
}

/// Integer-path values of one sample: encoder counts in, DAC code out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Codes {
    /// Counts of the first and second measured coordinates (0 when absent).
    pub q_theta: i32,
    pub q_phi: i32,
    pub code: i32,
    /// Counts of the third and further measured coordinates (0 when absent).
    pub q_rest: [i32; shared::MAX_GAINS - 2],
    /// Number of measured coordinates.
    pub measured: u8,
}

impl Codes {
    /// The counts of every measured coordinate, in gain order.
    pub fn counts(&self) -> impl Iterator<Item = i32> + '_ {
        [self.q_theta, self.q_phi].into_iter().chain(self.q_rest).take(usize::from(self.measured))
    }
}

/// A simulated closed-loop run, one row per sample t_i = i*dt (i = 0..=periods, or until the
/// run stopped). Row i holds the state at t_i and the input u_i held on [t_i, t_i + dt).
#[derive(Clone, Debug, Serialize)]
pub struct Trajectory {
    pub scene: String,
    pub state_names: Vec<&'static str>,
    pub dt: f64,
    pub t: Vec<f64>,
    /// Row-major states, `state_names.len()` values a row.
    pub states: Vec<f64>,
    pub u: Vec<f64>,
    /// Present only when the scene quantizes in counts mode.
    pub codes: Option<Vec<Codes>>,
    /// Samples at which the controller output was clipped by saturation.
    pub saturated_samples: u64,
    /// The rows of those samples, in order (`saturated_samples` of them): what a prefix of
    /// the run needs to count its own.
    pub saturated_rows: Vec<usize>,
    /// Why the run ended early (escape threshold crossed), if it did.
    pub stopped: Option<String>,
    pub integrator: String,
    pub ode_stats: OdeStats,
    pub wall_seconds: f64,
}

impl Trajectory {
    pub fn n_states(&self) -> usize {
        self.state_names.len()
    }
    pub fn rows(&self) -> usize {
        self.t.len()
    }
    /// State component `k` at row `i`.
    pub fn state(&self, i: usize, k: usize) -> f64 {
        self.states[i * self.n_states() + k]
    }
    /// The primary angle (theta) along the run.
    pub fn primary(&self) -> Vec<f64> {
        (0..self.rows()).map(|i| self.state(i, 0)).collect()
    }

    /// Writes `t, <states>, u[, q_theta, q_phi, code[, q_2, q_3]]` as CSV to `w` (the
    /// counts of the third and fourth measured coordinates when the controller reads them;
    /// the application decides where: `ssmctl` writes a temporary file and renames it when
    /// complete).
    pub fn write_csv_to(&self, w: &mut impl Write) -> std::io::Result<()> {
        let mut header = String::from("t");
        for n in &self.state_names {
            header.push(',');
            header.push_str(n);
        }
        header.push_str(",u");
        let extra =
            self.codes.as_ref().and_then(|c| c.first()).map_or(0, |c| usize::from(c.measured).saturating_sub(2));
        if self.codes.is_some() {
            header.push_str(",q_theta,q_phi,code");
            for k in 0..extra {
                header.push_str(&format!(",q_{}", k + 2));
            }
        }
        writeln!(w, "{header}")?;
        let n = self.n_states();
        for i in 0..self.rows() {
            write!(w, "{}", self.t[i])?;
            for k in 0..n {
                write!(w, ",{}", self.states[i * n + k])?;
            }
            write!(w, ",{}", self.u[i])?;
            if let Some(c) = &self.codes {
                write!(w, ",{},{},{}", c[i].q_theta, c[i].q_phi, c[i].code)?;
                for q in c[i].q_rest.iter().take(extra) {
                    write!(w, ",{q}")?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    }
}

/// The integration method a scene asks for.
pub fn method_of(scene: &Scene) -> Method {
    let i = &scene.integrator;
    match i.method {
        MethodKind::Rodas => Method::Rodas { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) },
        MethodKind::RodasFixed => Method::RodasFixed { steps: i.steps.unwrap_or(1) },
        MethodKind::Rk4 => Method::Rk4 { steps: i.steps.unwrap_or(1) },
        MethodKind::Exprb => Method::Exprb { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) },
        MethodKind::ExprbFixed => Method::ExprbFixed { steps: i.steps.unwrap_or(1) },
        MethodKind::ExprbSplit => Method::ExprbSplit { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) },
        MethodKind::ExprbLean => Method::ExprbLean { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) },
        MethodKind::ExprbFiltered => {
            Method::ExprbFiltered { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) }
        }
        MethodKind::Exprb54 => Method::Exprb54 { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) },
        MethodKind::Exprb54Filtered => {
            Method::Exprb54Filtered { rtol: i.rtol.unwrap_or(1e-10), atol: i.atol.unwrap_or(1e-12) }
        }
    }
}

/// Plant parameters from the scene's `[plant.params]` overrides on top of the defaults.
fn params<T: serde::de::DeserializeOwned>(scene: &Scene) -> Result<T, SimError> {
    serde_path_to_error::deserialize(toml::Value::Table(scene.plant.params.clone())).map_err(|e| {
        SimError::Scene(SceneError::Key {
            scene: scene.name.clone(),
            path: format!("plant.params.{}", e.path()),
            message: e.inner().to_string(),
        })
    })
}

/// A plant built from a scene, one variant per kind (an equations plant per coordinate
/// count: its state count is a type parameter). [`with_plant!`](crate::with_plant) runs
/// code generic over [`Plant`] on any of them.
#[derive(Debug)]
pub enum AnyPlant {
    Furuta(Furuta),
    Cart(Cart),
    Equations1(EquationsPlant<2>),
    Equations2(EquationsPlant<4>),
    Equations3(EquationsPlant<6>),
    Equations4(EquationsPlant<8>),
}

/// `with_plant!(plant, p => body)`: evaluates `body` with `p` bound to the concrete plant
/// inside an [`AnyPlant`] (by value or by reference, as `plant` is given).
#[macro_export]
macro_rules! with_plant {
    ($plant:expr, $p:ident => $body:expr) => {
        match $plant {
            $crate::closed_loop::AnyPlant::Furuta($p) => $body,
            $crate::closed_loop::AnyPlant::Cart($p) => $body,
            $crate::closed_loop::AnyPlant::Equations1($p) => $body,
            $crate::closed_loop::AnyPlant::Equations2($p) => $body,
            $crate::closed_loop::AnyPlant::Equations3($p) => $body,
            $crate::closed_loop::AnyPlant::Equations4($p) => $body,
        }
    };
}

/// Builds the plant a scene names, validating its parameters.
pub fn build_plant(scene: &Scene) -> Result<AnyPlant, SimError> {
    let plant_err = |source| SimError::Plant { scene: scene.name.clone(), source };
    Ok(match scene.plant.kind {
        PlantKind::Furuta => AnyPlant::Furuta(Furuta::new(params::<FurutaParams>(scene)?).map_err(plant_err)?),
        PlantKind::Cart => AnyPlant::Cart(Cart::new(params::<CartParams>(scene)?).map_err(plant_err)?),
        PlantKind::Equations => {
            let Some(model) = scene.plant.equations_model(&scene.name)? else {
                return Err(SimError::Scene(SceneError::Key {
                    scene: scene.name.clone(),
                    path: "plant.kind".into(),
                    message: "an equations plant without equations".into(),
                }));
            };
            let model = Arc::new(model);
            let n = model.coordinates();
            let plant = match n {
                1 => EquationsPlant::new(model).map(AnyPlant::Equations1),
                2 => EquationsPlant::new(model).map(AnyPlant::Equations2),
                3 => EquationsPlant::new(model).map(AnyPlant::Equations3),
                _ => EquationsPlant::new(model).map(AnyPlant::Equations4),
            };
            plant.ok_or_else(|| {
                SimError::Scene(SceneError::Key {
                    scene: scene.name.clone(),
                    path: "plant.coordinates".into(),
                    message: format!("{n} coordinates: at most {MAX_COORDINATES} are supported"),
                })
            })?
        }
    })
}

/// Runs a scene's closed-loop simulation.
pub fn simulate(scene: &Scene, progress: Option<&dyn Fn(u64)>) -> Result<Trajectory, SimError> {
    crate::with_plant!(build_plant(scene)?, p => simulate_with(&p, scene, progress))
}

/// The law the scene's effects select.
enum Law {
    Float(FloatPd<f64, HISTORY>),
    Counts { pd: IntPd<HISTORY>, h: Vec<f64> },
    Literal(LiteralPd<HISTORY>),
}

impl Law {
    fn new(cfg: &ControllerConfig, scene: &str) -> Result<Self, SimError> {
        let err = |e: controller::ConfigError| SimError::Controller { scene: scene.into(), message: e.to_string() };
        Ok(match cfg.quant {
            None => Law::Float(FloatPd::try_new(cfg).map_err(err)?),
            Some(q) => match q.mode {
                QuantMode::Counts => Law::Counts {
                    pd: IntPd::try_new(cfg).map_err(err)?,
                    h: cfg.gains.iter().map(|g| g.h_adc).collect(),
                },
                QuantMode::Literal => Law::Literal(LiteralPd::try_new(cfg).map_err(err)?),
            },
        })
    }
}

/// Names a measured coordinate in messages: the shorthand's two angles as before.
fn coordinate_name(i: usize) -> String {
    match i {
        0 => "primary angle".into(),
        1 => "secondary angle".into(),
        _ => format!("measured coordinate {i}"),
    }
}

/// The state indices the controller measures, each checked against the plant's `n` states.
pub fn measured_indices(cfg: &ControllerConfig, n: usize, scene: &str) -> Result<Vec<usize>, SimError> {
    cfg.gains
        .iter()
        .map(|g| {
            let i = usize::from(g.index);
            if i < n {
                Ok(i)
            } else {
                Err(SimError::Controller {
                    scene: scene.into(),
                    message: format!("a gain measures state index {i}, the plant has {n} states"),
                })
            }
        })
        .collect()
}

/// Runs the closed loop on a given plant.
pub fn simulate_with<P: Plant<N>, const N: usize>(
    plant: &P,
    scene: &Scene,
    progress: Option<&dyn Fn(u64)>,
) -> Result<Trajectory, SimError> {
    let start = Instant::now();
    let name = scene.name.as_str();
    let cfg = scene.controller_config();
    let dt = cfg.dt;
    let mut x = [0.0; N];
    if !scene.initial.state.is_empty() {
        if scene.initial.state.len() != N {
            return Err(SimError::StateLength {
                scene: name.into(),
                plant: plant.name(),
                got: scene.initial.state.len(),
                need: N,
            });
        }
        x.copy_from_slice(&scene.initial.state);
    }
    // The measured coordinates' state indices, in gain order.
    let idx = measured_indices(&cfg, N, name)?;
    let n = idx.len();
    let sample = |x: &[f64; N]| -> Vec<f64> { idx.iter().map(|&i| x[i]).collect() };
    let history: Vec<f64> = match &scene.initial.history {
        Some(h) => h.iter().flatten().copied().collect(),
        None => sample(&x).repeat(cfg.delay as usize + 1),
    };
    let mut law = Law::new(&cfg, name)?;
    let sensor_err = |t: f64, e: String| SimError::Sensor { scene: name.into(), t, message: e };
    let prime_err = |e: controller::InputError| SimError::Controller {
        scene: name.into(),
        message: format!("initial.history: {e}"),
    };
    let counts = |q: &[f64], h: &[f64], t: f64, what: &str| -> Result<Vec<i32>, SimError> {
        q.iter()
            .zip(h)
            .enumerate()
            .map(|(k, (&v, &hk))| {
                adc(v, hk).map_err(|e| sensor_err(t, format!("{what}{} {v}: {e}", coordinate_name(k))))
            })
            .collect()
    };
    match &mut law {
        Law::Float(pd) => pd.prime(&history).map_err(prime_err)?,
        Law::Literal(pd) => pd.prime(&history).map_err(prime_err)?,
        Law::Counts { pd, h } => {
            let mut q = Vec::with_capacity(history.len());
            for s in history.chunks(n.max(1)) {
                q.extend(counts(s, h, 0.0, "pre-history ")?);
            }
            pd.prime(&q).map_err(prime_err)?;
        }
    }
    // Only a scene that names noise gets a generator: a noiseless run draws no random numbers.
    // sigma_theta applies to the first measured coordinate, sigma_phi to the second.
    let mut noise = match &scene.effects.noise {
        Some(ns) => {
            let normal = |sigma: f64| {
                Normal::new(0.0, sigma)
                    .map_err(|e| SimError::Controller { scene: name.into(), message: format!("noise: {e}") })
            };
            Some((ChaCha8Rng::seed_from_u64(ns.seed), normal(ns.sigma_theta)?, normal(ns.sigma_phi)?))
        }
        None => None,
    };
    let mut ode =
        Integrator::<N>::new(method_of(scene)).map_err(|source| SimError::Ode { scene: name.into(), source })?;
    let periods = scene.run.periods as usize;
    let mut traj = Trajectory {
        scene: name.into(),
        state_names: plant.state_names().to_vec(),
        dt,
        t: Vec::with_capacity(periods + 1),
        states: Vec::with_capacity((periods + 1) * N),
        u: Vec::with_capacity(periods + 1),
        codes: matches!(law, Law::Counts { .. }).then(|| Vec::with_capacity(periods + 1)),
        saturated_samples: 0,
        saturated_rows: Vec::new(),
        stopped: None,
        integrator: ode.describe(),
        ode_stats: OdeStats::default(),
        wall_seconds: 0.0,
    };
    let mut q = vec![0.0; n];
    let escape = scene.run.escape_theta;
    for i in 0..=periods {
        let t = i as f64 * dt;
        for (qk, &i) in q.iter_mut().zip(&idx) {
            *qk = x[i];
        }
        if let Some((rng, ny, nz)) = &mut noise {
            if let Some(v) = q.get_mut(0) {
                *v += ny.sample(rng);
            }
            if let Some(v) = q.get_mut(1) {
                *v += nz.sample(rng);
            }
        }
        let (u, saturated) = match &mut law {
            Law::Float(pd) => {
                let o = pd.step(&q).map_err(|e| sensor_err(t, e.to_string()))?;
                (o.u, o.saturated)
            }
            Law::Literal(pd) => {
                let o = pd.step(&q).map_err(|e| sensor_err(t, e.to_string()))?;
                (o.u, o.saturated)
            }
            Law::Counts { pd, h } => {
                let c = counts(&q, h, t, "")?;
                let o = pd.step(&c).map_err(|e| sensor_err(t, e.to_string()))?;
                if let Some(codes) = &mut traj.codes {
                    let at = |k: usize| c.get(k).copied().unwrap_or(0);
                    codes.push(Codes {
                        q_theta: at(0),
                        q_phi: at(1),
                        code: o.code,
                        q_rest: core::array::from_fn(|k| at(k + 2)),
                        measured: c.len() as u8,
                    });
                }
                (pd.volts(o.code), o.saturated)
            }
        };
        if saturated {
            traj.saturated_samples += 1;
            traj.saturated_rows.push(i);
        }
        traj.t.push(t);
        traj.states.extend_from_slice(&x);
        traj.u.push(u);
        if let Some(limit) = escape {
            if x[P::PRIMARY].abs() > limit {
                traj.stopped = Some(format!("|primary angle| exceeded {limit} rad at t = {t:.4} s"));
                break;
            }
        }
        if i == periods {
            break;
        }
        ode.advance(plant, &mut x, u, dt).map_err(|source| SimError::Ode { scene: name.into(), source })?;
        if let Some(report) = progress {
            if i % 256 == 0 {
                report(i as u64);
            }
        }
    }
    traj.ode_stats = ode.stats();
    traj.wall_seconds = start.elapsed().as_secs_f64();
    Ok(traj)
}

/// Metadata written beside a trajectory CSV.
#[derive(Debug, Serialize)]
pub struct Metadata<'a> {
    pub scene: &'a str,
    pub description: &'a str,
    pub plant: PlantKind,
    pub plant_params: &'a toml::Table,
    pub controller: ControllerConfig,
    pub effects: Vec<String>,
    pub integrator: &'a str,
    pub tolerance: Option<[f64; 2]>,
    pub steps_per_period: Option<u32>,
    pub periods_simulated: usize,
    pub stopped: Option<&'a str>,
    pub saturated_samples: u64,
    pub ode_stats: OdeStats,
    pub wall_seconds: f64,
    pub csv: &'a str,
}

/// The file names a scene's run is written to: `<scene>.csv` (the trajectory) and
/// `<scene>.json` (the metadata). Scene names are restricted to safe file names
/// ([`crate::scene::check_name`]), so these never leave the output folder.
pub fn output_names(scene: &Scene) -> (String, String) {
    (format!("{}.csv", scene.name), format!("{}.json", scene.name))
}

/// The metadata JSON written beside the trajectory CSV `csv_name`.
pub fn metadata_json(scene: &Scene, traj: &Trajectory, csv_name: &str) -> Result<String, serde_json::Error> {
    let i = &scene.integrator;
    let meta = Metadata {
        scene: &scene.name,
        description: &scene.description,
        plant: scene.plant.kind,
        plant_params: &scene.plant.params,
        controller: scene.controller_config(),
        effects: scene.effect_names(),
        integrator: &traj.integrator,
        tolerance: matches!(
            i.method,
            MethodKind::Rodas
                | MethodKind::Exprb
                | MethodKind::ExprbSplit
                | MethodKind::ExprbLean
                | MethodKind::ExprbFiltered
                | MethodKind::Exprb54
                | MethodKind::Exprb54Filtered
        )
        .then(|| [i.rtol.unwrap_or(1e-10), i.atol.unwrap_or(1e-12)]),
        steps_per_period: i.steps,
        periods_simulated: traj.rows().saturating_sub(1),
        stopped: traj.stopped.as_deref(),
        saturated_samples: traj.saturated_samples,
        ode_stats: traj.ode_stats,
        wall_seconds: traj.wall_seconds,
        csv: csv_name,
    };
    serde_json::to_string_pretty(&meta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A three-mass chain with an encoder on every mass, each of its own resolution.
    const CHAIN3: &str = r#"
name = "chain3-quant"
description = "Three-mass Duffing chain, PD on the first mass, D on the others, three encoders"

[plant]
kind = "equations"
coordinates = ["x1", "x2", "x3"]
parameters = { m = 1.0, k = 100.0, k3 = 1.0e4, c = 0.05 }
mass = [["m", "0", "0"], ["0", "m", "0"], ["0", "0", "m"]]
forces = ["-k*x1 - k3*x1^3 - k*(x1 - x2) - c*x1_dot + u",
          "-k*(x2 - x1) - k*(x2 - x3) - c*x2_dot",
          "-k*(x3 - x2) - c*x3_dot"]

[controller]
gains = { x1 = { p = 5.0, d = 1.0, h_adc = 1.0e-5 }, x2 = { d = 0.5, h_adc = 2.0e-5 }, x3 = { d = 0.25, h_adc = 5.0e-5 } }
dt_ms = 5.0
delay = 1

[initial]
state = { x1 = 0.02, x2 = -0.01, x3 = 0.005 }

[run]
periods = 2000

[effects.quantization]
mode = "counts"
h_adc = 1.0e-5
h_dac = 1.0e-4

[integrator]
method = "rodas"
rtol = 1e-10
atol = 1e-12
"#;

    /// Quantized runs read every measured coordinate through its own encoder: with three,
    /// the recorded counts are `floor(q_j / h_j)` of the state, each DAC code is the integer
    /// controller's output on the recorded counts (a fresh `controller::IntPd` replayed, bit
    /// for bit) and within one DAC step of the float law on the same counts, the held input
    /// is the code times the DAC step, and the CSV has a column per measured coordinate.
    #[test]
    fn quantized_run_with_three_encoders_is_the_integer_controller() {
        let dir = std::env::temp_dir().join(format!("sim-chain3-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("chain3-quant.toml");
        std::fs::write(&path, CHAIN3).unwrap();
        let s = Scene::load(path.to_str().unwrap(), &[]).unwrap();
        let tr = simulate(&s, None).unwrap();
        let cfg = s.controller_config();
        assert_eq!(cfg.gains.len(), 3);
        let codes = tr.codes.as_ref().unwrap();
        assert_eq!(codes.len(), tr.rows());
        let h: Vec<f64> = cfg.gains.iter().map(|g| g.h_adc).collect();
        assert_eq!(h, [1.0e-5, 2.0e-5, 5.0e-5]);
        let idx: Vec<usize> = cfg.gains.iter().map(|g| usize::from(g.index)).collect();
        let mut pd = controller::IntPd::<HISTORY>::try_new(&cfg).unwrap();
        let first: Vec<i32> = codes[0].counts().collect();
        pd.prime(&[first.clone(), first].concat()).unwrap();
        let h_dac = cfg.quant.unwrap().h_dac;
        let mut worst = 0.0f64;
        for (i, c) in codes.iter().enumerate() {
            let q: Vec<i32> = c.counts().collect();
            assert_eq!(q.len(), 3);
            for (j, &k) in idx.iter().enumerate() {
                assert_eq!(q[j], (tr.state(i, k) / h[j]).floor() as i32, "row {i} coordinate {j}");
            }
            let o = pd.step(&q).unwrap();
            assert_eq!(o.code, c.code, "row {i}");
            assert_eq!(tr.u[i], pd.volts(c.code), "row {i}");
            if i >= 2 {
                let (q1, q2): (Vec<i32>, Vec<i32>) = (codes[i - 1].counts().collect(), codes[i - 2].counts().collect());
                let u: f64 = -cfg
                    .gains
                    .iter()
                    .enumerate()
                    .map(|(j, g)| {
                        let (a, b) = (f64::from(q1[j]) * h[j], f64::from(q2[j]) * h[j]);
                        g.p * a + g.d * (a - b) / cfg.dt
                    })
                    .sum::<f64>();
                worst = worst.max((f64::from(c.code) * h_dac - u).abs() / h_dac);
            }
        }
        eprintln!("three encoders: {} rows, integer law vs float law on the counts: {worst:.3} DAC steps", tr.rows());
        assert!(worst <= 1.0, "{worst}");
        assert!(codes.iter().any(|c| c.q_rest[0] != 0), "the third encoder never moved");
        let mut csv = Vec::new();
        tr.write_csv_to(&mut csv).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        assert!(csv.starts_with("t,x1,x1_dot,x2,x2_dot,x3,x3_dot,u,q_theta,q_phi,code,q_2\n"), "{}", &csv[..80]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn scene(name: &str, o: &[&str]) -> Scene {
        Scene::load(name, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
    }

    /// Long quantized runs stay finite and repeat bit for bit.
    #[test]
    fn quantized_1e5_periods_finite_and_bitwise_reproducible() {
        let mut s = scene("furuta-quant-dt25", &["run.periods=100000"]);
        s.integrator =
            crate::scene::IntegratorSpec { method: MethodKind::RodasFixed, rtol: None, atol: None, steps: Some(8) };
        let a = simulate(&s, None).unwrap();
        let b = simulate(&s, None).unwrap();
        assert_eq!(a.rows(), 100_001);
        assert!(a.states.iter().all(|v| v.is_finite()));
        assert!(a.states.iter().zip(&b.states).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert_eq!(a.codes, b.codes);
        // Bounded: the quantized loop stays within the neighbourhood (no escape).
        assert!(a.primary().iter().all(|t| t.abs() < 0.5));
        // The held voltage is exactly the DAC step times the integer code.
        let c = a.codes.as_ref().unwrap();
        assert!(a.u.iter().zip(c).all(|(u, c)| *u == 4.8828125e-3 * f64::from(c.code)));
    }

    /// Both readings of the quantizer (integer counts/DAC codes, and the paper's formula read
    /// literally) give long bounded irregular motion at the paper's gains, dt = 25 ms: twin
    /// runs started 1e-9 rad apart separate to the attractor's size (sensitive dependence),
    /// and the motion neither settles nor escapes.
    #[test]
    fn both_quantizer_readings_give_bounded_chaotic_runs() {
        for name in ["furuta-quant-dt25", "furuta-literal-dt25"] {
            let a = simulate(&scene(name, &["run.periods=3000"]), None).unwrap();
            let b = simulate(&scene(name, &["run.periods=3000", "initial.state=[0.020000001,0,0,0]"]), None).unwrap();
            assert!(a.stopped.is_none() && b.stopped.is_none(), "{name}: {:?} {:?}", a.stopped, b.stopped);
            let (xa, xb) = (a.primary(), b.primary());
            let amp = xa.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let sep_at = xa.iter().zip(&xb).position(|(p, q)| (p - q).abs() > 0.1 * amp);
            // Irregular, not settled: the spread of the last third stays at the attractor's size.
            let tail = &xa[2000..];
            let mean = tail.iter().sum::<f64>() / tail.len() as f64;
            let sd = (tail.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / tail.len() as f64).sqrt();
            println!("{name}: max |theta| {amp:.4}, tail sd {sd:.4}, twins separate at sample {sep_at:?}");
            assert!(amp < 0.5, "{name}: escaped the neighbourhood ({amp})");
            assert!(sd > 0.1 * amp, "{name}: settled (sd {sd}, amplitude {amp})");
            let k = sep_at.unwrap_or(usize::MAX);
            assert!(k < 2000, "{name}: twins 1e-9 apart did not separate within 50 s");
        }
    }

    #[test]
    fn effects_are_simulated_only_when_named() {
        let plain = simulate(&scene("furuta-dt25", &["run.periods=40"]), None).unwrap();
        assert!(plain.codes.is_none(), "unquantized scene touched the integer path");
        assert_eq!(plain.saturated_samples, 0);
        let noisy = |seed: &str| {
            simulate(&scene("furuta-noise-pid", &["run.periods=200", &format!("effects.noise.seed={seed}")]), None)
                .unwrap()
        };
        let (a, b, c) = (noisy("1"), noisy("1"), noisy("2"));
        assert_eq!(a.states, b.states, "same seed, same run");
        assert_ne!(a.states, c.states, "another seed, another run");
        // Noise off: the run equals the noiseless scene exactly.
        let quiet = simulate(
            &scene(
                "furuta-noise-pid",
                &["run.periods=200", "effects.noise.sigma_theta=0", "effects.noise.sigma_phi=0"],
            ),
            None,
        )
        .unwrap();
        let mut s = scene("furuta-noise-pid", &["run.periods=200"]);
        s.effects.noise = None;
        let none = simulate(&s, None).unwrap();
        assert_eq!(quiet.states, none.states);
    }

    #[test]
    fn saturation_scene_escapes_to_the_tilted_rotating_state_and_clips() {
        let tr = simulate(&scene("furuta-saturation", &[]), None).unwrap();
        assert!(tr.saturated_samples > 0);
        // The clipped rows, in order: exactly those whose held input sits at the limit.
        assert_eq!(tr.saturated_rows.len() as u64, tr.saturated_samples);
        assert!(tr.saturated_rows.windows(2).all(|w| w[0] < w[1]) && tr.saturated_rows.iter().all(|&r| r < tr.rows()));
        assert!(tr.saturated_rows.iter().all(|&r| tr.u[r].abs() == 24.0));
        let late = &tr.primary()[tr.rows() - 200..];
        let mean = late.iter().sum::<f64>() / late.len() as f64;
        let spread = late.iter().fold(0.0_f64, |m, t| m.max((t - mean).abs()));
        // theta settles tilted and steady, away from upright and short of hanging down
        // (MODEL.md: saturation creates an attracting tilted rotating state).
        assert!(mean.abs() > 0.3 && mean.abs() < 2.5 && spread < 0.05, "late theta {mean} +- {spread}");
        assert!(tr.u.iter().all(|u| u.abs() <= 24.0));
    }

    #[test]
    fn bad_initial_state_length_is_an_error() {
        let e = simulate(&scene("furuta-dt25", &["initial.state=[0.1, 0.0]"]), None).unwrap_err().to_string();
        assert!(e.contains("initial.state") && e.contains('4'), "{e}");
    }
}
