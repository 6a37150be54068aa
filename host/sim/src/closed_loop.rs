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
/// code generic over [`Plant`] on any of them. Cloning is cheap (an equations plant shares
/// its compiled model), so one built plant can serve a [`Stepper`] and [`simulate_plant`].
#[derive(Clone, Debug)]
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

/// A scene's plant with its integrator, the state passed as a slice: for a caller that drives
/// the loop itself (the PIL host). Its methods are not generic, so the integrator's code is
/// compiled in `sim` (at `sim`'s optimization level), not in the calling crate.
#[derive(Debug)]
pub struct Stepper(StepperKind);

#[derive(Debug)]
enum StepperKind {
    Furuta(Furuta, Integrator<4>),
    Cart(Cart, Integrator<4>),
    Equations1(EquationsPlant<2>, Integrator<2>),
    Equations2(EquationsPlant<4>, Integrator<4>),
    Equations3(EquationsPlant<6>, Integrator<6>),
    Equations4(EquationsPlant<8>, Integrator<8>),
}

impl Stepper {
    /// The plant `scene` names ([`build_plant`]) and an integrator of its method ([`method_of`]).
    pub fn new(scene: &Scene) -> Result<Self, SimError> {
        Self::with_plant(scene, build_plant(scene)?)
    }

    /// An already built `plant` (the one `scene` names) and an integrator of the scene's
    /// method: for a caller that also needs the plant itself, so it is built once.
    pub fn with_plant(scene: &Scene, plant: AnyPlant) -> Result<Self, SimError> {
        fn ode<const N: usize>(scene: &Scene) -> Result<Integrator<N>, SimError> {
            Integrator::new(method_of(scene)).map_err(|source| SimError::Ode { scene: scene.name.clone(), source })
        }
        Ok(Self(match plant {
            AnyPlant::Furuta(p) => StepperKind::Furuta(p, ode(scene)?),
            AnyPlant::Cart(p) => StepperKind::Cart(p, ode(scene)?),
            AnyPlant::Equations1(p) => StepperKind::Equations1(p, ode(scene)?),
            AnyPlant::Equations2(p) => StepperKind::Equations2(p, ode(scene)?),
            AnyPlant::Equations3(p) => StepperKind::Equations3(p, ode(scene)?),
            AnyPlant::Equations4(p) => StepperKind::Equations4(p, ode(scene)?),
        }))
    }

    /// The plant's state count.
    pub fn states(&self) -> usize {
        // Read off each variant's integrator type, so the counts are stated only there.
        fn n<const N: usize>(_: &Integrator<N>) -> usize {
            N
        }
        match &self.0 {
            StepperKind::Furuta(_, ode) => n(ode),
            StepperKind::Cart(_, ode) => n(ode),
            StepperKind::Equations1(_, ode) => n(ode),
            StepperKind::Equations2(_, ode) => n(ode),
            StepperKind::Equations3(_, ode) => n(ode),
            StepperKind::Equations4(_, ode) => n(ode),
        }
    }

    /// [`Integrator::advance`]: `x` (of [`Stepper::states`] values) by exactly `h` seconds
    /// under the held input `u`. A state of another length is an error, `x` untouched.
    pub fn advance(&mut self, x: &mut [f64], u: f64, h: f64) -> Result<(), OdeError> {
        fn go<P: Plant<N>, const N: usize>(
            p: &P,
            ode: &mut Integrator<N>,
            x: &mut [f64],
            u: f64,
            h: f64,
        ) -> Result<(), OdeError> {
            let len = x.len();
            let x: &mut [f64; N] = x.try_into().map_err(|_| {
                OdeError::BadArgument(format!("a state of {len} values for the {} plant of {N} states", p.name()))
            })?;
            ode.advance(p, x, u, h)
        }
        match &mut self.0 {
            StepperKind::Furuta(p, ode) => go(p, ode, x, u, h),
            StepperKind::Cart(p, ode) => go(p, ode, x, u, h),
            StepperKind::Equations1(p, ode) => go(p, ode, x, u, h),
            StepperKind::Equations2(p, ode) => go(p, ode, x, u, h),
            StepperKind::Equations3(p, ode) => go(p, ode, x, u, h),
            StepperKind::Equations4(p, ode) => go(p, ode, x, u, h),
        }
    }
}

/// Runs a scene's closed-loop simulation.
pub fn simulate(scene: &Scene, progress: Option<&dyn Fn(u64)>) -> Result<Trajectory, SimError> {
    simulate_plant(scene, &build_plant(scene)?, progress)
}

/// Runs a scene's closed-loop simulation on its already built `plant` ([`build_plant`] of
/// `scene`). Not generic, so a caller holding an [`AnyPlant`] gets the numerics `sim` compiles.
pub fn simulate_plant(scene: &Scene, plant: &AnyPlant, progress: Option<&dyn Fn(u64)>) -> Result<Trajectory, SimError> {
    crate::with_plant!(plant, p => simulate_with(p, scene, progress))
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
