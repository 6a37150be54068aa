//! A verdict on the Furuta microchaos (docs/decisions/0002): is the quantized loop at the
//! paper's settings (`furuta-quant-dt25`, 25 ms) chaotic, at which scales, or a torus shaken
//! by quantization (and, in the recordings, by sensor noise)?
//!
//! Two kinds of evidence:
//! - **The system itself** (simulated, noise-free): the period map is piecewise smooth,
//!   `s_{i+1} = F(s_i, Q(s_i))` with the encoder/DAC quantizer `Q`. `Q' = 0` almost
//!   everywhere, so the map's tangent is the open-loop flow's `d phi/dx` alone: infinitesimal
//!   separations grow at the *open-loop* (uncontrolled, upright pendulum) rate, whatever the
//!   controller does ([`PeriodMapExponents::quantized_tangent`]); the feedback acts only on
//!   separations that change a count. That number says nothing about the attractor. The
//!   tangent of the *unquantized* closed loop along the quantized orbit
//!   ([`PeriodMapExponents::smooth_tangent`]) is the smooth part's own stretching at the
//!   attractor. Twin runs started `1e-9 .. 1e-3` apart ([`twin_divergence`]) resolve the
//!   separation rate by scale (finite-size Lyapunov exponents): below one encoder step the
//!   open-loop rate, at the attractor's scale whatever the loop does with count flips.
//! - **Time series** (theta sampled every 25 ms), the tests that can tell chaos from
//!   noise-driven diffusion on a torus ([`series_tests`]): the 0-1 test (coarsened to the
//!   autocorrelation's first zero), data FSLE over scales (plateau = chaos, `lambda ~ delta^-2`
//!   = diffusion), IAAFT surrogates with the nonlinear prediction error and time-reversal
//!   asymmetry (rank p-values).
//!
//! Stated choices: series of `periods` samples after the 20 s transient
//! ([`crate::microchaos::simulate_scene`]); embedding dimension 6, lag = first zero of the
//! autocorrelation, Theiler window = dominant period (as [`chaos::Context`]);
//! separation of twin runs in `(theta, dt * theta', dt * phi')` (rad): the arm angle `phi` is
//! left out, it is a neutral direction of the loop (the law reads only its differences).

use chaos::{FsleRow, FsleSeriesParams, Statistic, SurrogateParams, SurrogateResult, ZeroOneParams, ZeroOneResult};
use nalgebra::DMatrix;
use serde::Serialize;
use sim::closed_loop::{AnyPlant, Trajectory, build_plant, simulate};
use sim::plant::{Dual, Plant};
use sim::scene::{Scene, SceneBuilder};
use ssm::TimeSeries;

use crate::Error;
use chaos::Context;

/// Encoder step of the quantized scenes (2000 counts per revolution), rad.
pub const H_ADC: f64 = std::f64::consts::PI / 1000.0;

/// The bundled scenes the verdict compares: the quantized loop, its smooth twin (no
/// quantization) and its noisy twin.
pub const SCENES: [&str; 3] = ["furuta-quant-dt25", "furuta-dt25", "furuta-quant-dt25-noise"];

/// Settings of [`microchaos_verdict`] (lengths and counts; the methods are fixed).
#[derive(Clone, Debug, Serialize)]
pub struct VerdictOptions {
    /// Periods of each simulated series (20 s of transient are dropped).
    pub periods: usize,
    /// Initial theta of the simulated series.
    pub theta0: f64,
    /// Periods of the orbit along which the period-map tangents are multiplied (after 20 s).
    pub tangent_periods: usize,
    /// Twin runs: start points on the attractor, periods followed, initial separations.
    pub twin_starts: usize,
    pub twin_periods: usize,
    pub twin_deltas: Vec<f64>,
    /// IAAFT surrogates per test (p >= 1 / (n + 1)).
    pub surrogates: usize,
    /// Random frequencies of the 0-1 test.
    pub zero_one_c: usize,
}

impl VerdictOptions {
    /// The report's quick settings (a few seconds of CPU).
    pub fn quick() -> Self {
        Self {
            periods: 6000,
            theta0: 0.02,
            tangent_periods: 800,
            twin_starts: 6,
            twin_periods: 320,
            twin_deltas: vec![1e-9, 1e-6, 1e-3],
            surrogates: 19,
            zero_one_c: 100,
        }
    }
    /// The full report's settings.
    pub fn full() -> Self {
        Self {
            periods: 20000,
            tangent_periods: 6000,
            twin_starts: 16,
            twin_periods: 600,
            twin_deltas: vec![1e-9, 1e-7, 1e-5, 1e-3],
            surrogates: 39,
            ..Self::quick()
        }
    }
    fn validate(&self) -> Result<(), Error> {
        let bad = |what: &'static str, why: String| Err(Error::BadOption { what, why });
        if self.periods < 2000 {
            return bad(
                "periods",
                format!("{} < 2000 (the series tests need about 1000 samples after the transient)", self.periods),
            );
        }
        if self.tangent_periods < 100 {
            return bad("tangent_periods", format!("{} < 100", self.tangent_periods));
        }
        if self.twin_starts == 0 || self.twin_periods < 10 {
            return bad(
                "twin_starts / twin_periods",
                format!("{} starts of {} periods (need >= 1 and >= 10)", self.twin_starts, self.twin_periods),
            );
        }
        if let Some(d) = self.twin_deltas.iter().find(|d| !(d.is_finite() && **d > 0.0 && **d < 1e-2)) {
            return bad("twin_deltas", format!("{d} is not in (0, 1e-2) rad"));
        }
        if self.twin_deltas.is_empty() || self.surrogates == 0 || self.zero_one_c == 0 {
            return bad("twin_deltas / surrogates / zero_one_c", "must not be empty or zero".into());
        }
        Ok(())
    }
}

/// The time-series tests of one series.
#[derive(Clone, Debug, Serialize)]
pub struct SeriesTests {
    pub name: String,
    pub samples: usize,
    /// Delay lag and Theiler window (samples), embedding dimension.
    pub lag: usize,
    pub theiler: usize,
    pub embed: usize,
    /// Standard deviation of the series (rad): the FSLE scales are given relative to it too.
    pub std: f64,
    pub zero_one: ZeroOneResult,
    /// Data FSLE (1/s) over scales (rad, in the embedding).
    pub fsle: Vec<FsleRow>,
    pub fsle_pairs: usize,
    /// Slope of ln lambda against ln delta over the FSLE rows with >= 30 pairs: ~0 plateau
    /// (chaos), ~-2 diffusion.
    pub fsle_slope: Option<f64>,
    pub surrogate_prediction: SurrogateResult,
    pub surrogate_time_reversal: SurrogateResult,
}

/// The tests of [`SeriesTests`] on series `x` with the estimator settings `ctx` (sampling
/// step, lag, Theiler window, embedding; the same for every series compared).
pub fn series_tests(name: &str, x: &[f64], ctx: &Context, o: &VerdictOptions) -> Result<SeriesTests, Error> {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let std = (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n).sqrt();
    let zero_one =
        chaos::zero_one_test(x, &ZeroOneParams { n_c: o.zero_one_c, stride: ctx.lag, ..Default::default() })?;
    let pts = chaos::delay_embed(x, ctx.embed, ctx.lag)?;
    // Scales from a tenth of the standard deviation (times sqrt(m): distances in the
    // embedding) up by sqrt(2) to about the attractor's size.
    let unit = std * (ctx.embed as f64).sqrt();
    let delta = chaos::thresholds(0.1 * unit, 2f64.sqrt(), 9)?;
    let fp = FsleSeriesParams {
        theiler: ctx.theiler,
        max_refs: 1000,
        horizon: (10 * ctx.theiler).min(x.len() / 4),
        dt: ctx.dt,
    };
    let (fsle, fsle_pairs) = chaos::fsle_series(&pts, &delta, &fp)?;
    let fsle_slope = chaos::scaling_slope(&fsle, 30).ok();
    let sp = SurrogateParams { surrogates: o.surrogates, max_len: 4096, max_iter: 100, seed: 1, ..Default::default() };
    let pe = Statistic::PredictionError {
        m: ctx.embed,
        tau: ctx.lag,
        horizon: ctx.lag,
        neighbours: 5,
        theiler: ctx.theiler,
        refs: 500,
    };
    let mut tests = chaos::surrogate_tests(x, &[pe, Statistic::TimeReversal { lag: ctx.lag }], &sp)?.into_iter();
    let (Some(surrogate_prediction), Some(surrogate_time_reversal)) = (tests.next(), tests.next()) else {
        return Err(Error::BadInput { what: "surrogate test", why: "fewer results than statistics".into() });
    };
    Ok(SeriesTests {
        name: name.into(),
        samples: x.len(),
        lag: ctx.lag,
        theiler: ctx.theiler,
        embed: ctx.embed,
        std,
        zero_one,
        fsle,
        fsle_pairs,
        fsle_slope,
        surrogate_prediction,
        surrogate_time_reversal,
    })
}

/// One period of the plant's flow under held input `u` by classical RK4 in dual numbers:
/// the end state and the Jacobians `d x(dt) / d x(0)` (row-major 4 x 4) and `d x(dt) / d u`.
/// `steps` RK4 steps (the exact derivative of the RK4 map).
pub fn flow_jacobian<P: Plant<4>>(
    p: &P,
    x: &[f64; 4],
    u: f64,
    dt: f64,
    steps: usize,
) -> ([f64; 4], [[f64; 4]; 4], [f64; 4]) {
    type D = Dual<5>;
    let mut s: [D; 4] = std::array::from_fn(|i| D::var(x[i], i));
    let ud = D::var(u, 4);
    let h = dt / steps as f64;
    let add = |a: &[D; 4], k: &[D; 4], c: f64| -> [D; 4] { std::array::from_fn(|i| a[i] + k[i] * c) };
    for _ in 0..steps {
        let k1 = p.rhs(&s, ud);
        let k2 = p.rhs(&add(&s, &k1, h / 2.0), ud);
        let k3 = p.rhs(&add(&s, &k2, h / 2.0), ud);
        let k4 = p.rhs(&add(&s, &k3, h), ud);
        s = std::array::from_fn(|i| s[i] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0));
    }
    let end = std::array::from_fn(|i| s[i].v);
    let jx = std::array::from_fn(|i| std::array::from_fn(|j| s[i].d[j]));
    let ju = std::array::from_fn(|i| s[i].d[4]);
    (end, jx, ju)
}

/// RK4 steps per period for [`flow_jacobian`] of a linearization with `||A||_1 = a_norm`
/// over a period `dt`: `h ||A||_1 <= 0.5` at the equilibrium (the fast motor mode sets the
/// step), at least 10.
pub fn rk4_steps(a_norm: f64, dt: f64) -> usize {
    ((dt * a_norm / 0.5).ceil() as usize).max(10)
}

/// Exponents of the quantized loop's period map along its own orbit (1/s).
#[derive(Clone, Debug, Serialize)]
pub struct PeriodMapExponents {
    /// `ln rho(Phi) / dt` of the open-loop ZOH map at the upright equilibrium.
    pub open_loop_rate: f64,
    /// Largest exponent of the quantized map's own tangent (`Q' = 0`: the product of the
    /// open-loop flow Jacobians along the orbit).
    pub quantized_tangent: f64,
    /// `ln rho(M) / dt` of the linearized unquantized closed loop at the equilibrium.
    pub linear_closed_loop_rate: f64,
    /// Leading exponents (QR) of the unquantized closed loop's tangent along the quantized
    /// orbit (the structural multiplier 1 of the arm angle contributes a 0).
    pub smooth_tangent: Vec<f64>,
    /// Periods multiplied (the first quarter aligns the frames and is not averaged); RK4
    /// steps per period of the flow Jacobian.
    pub periods: usize,
    pub rk4_steps: usize,
}

/// The closed-loop law row `g` (`u_i = g . s_i` on the augmented state of
/// [`sim::linear::AugmentedLayout`]) read back from the linear closed-loop map and the ZOH
/// it was built from: rows `0..n` of the map are `[Phi 0] + Gamma g^T`.
pub fn law_row(m: &DMatrix<f64>, phi: &DMatrix<f64>, gamma: &nalgebra::DVector<f64>) -> Result<Vec<f64>, Error> {
    let n = phi.nrows();
    let (r, gr) = gamma
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .ok_or(Error::BadInput { what: "ZOH", why: "empty input column".into() })?;
    if gr == 0.0 {
        return Err(Error::BadInput { what: "ZOH", why: "the input does not reach the plant".into() });
    }
    Ok((0..m.ncols()).map(|j| (m[(r, j)] - if j < n { phi[(r, j)] } else { 0.0 }) / gr).collect())
}

/// [`PeriodMapExponents`] of a quantized scene along `traj` (rows `skip..skip + periods`).
pub fn period_map_exponents(
    scene: &Scene,
    traj: &Trajectory,
    skip: usize,
    periods: usize,
) -> Result<PeriodMapExponents, Error> {
    let AnyPlant::Furuta(plant) = build_plant(scene)? else {
        return Err(Error::BadInput {
            what: "scene",
            why: format!("{}: the period-map exponents are for the Furuta plant", scene.name),
        });
    };
    if traj.rows() < skip + periods + 1 {
        return Err(Error::BadInput {
            what: "trajectory",
            why: format!("{} rows < {} needed", traj.rows(), skip + periods + 1),
        });
    }
    let cfg = scene.controller_config();
    let dt = cfg.dt;
    let (a, b) = sim::plant::linearize(&plant);
    let lp = sim::linear::LinearPlant::new(
        &a,
        &b,
        <sim::plant::Furuta as Plant<4>>::PRIMARY,
        <sim::plant::Furuta as Plant<4>>::SECONDARY,
    )?;
    let zoh = lp.discretize(dt)?;
    let cl = zoh.closed_loop(&cfg)?;
    let g = law_row(&cl.matrix, &zoh.phi, &zoh.gamma)?;
    let rho = |m: &DMatrix<f64>| -> Result<f64, Error> {
        Ok(sim::linear::eigenvalues(m)?.iter().map(|c| c.norm()).fold(0.0, f64::max))
    };
    let open_loop_rate = rho(&zoh.phi)?.ln() / dt;
    let linear_closed_loop_rate = rho(&cl.matrix)?.ln() / dt;
    let a_norm = (0..4).map(|j| (0..4).map(|i| a[(i, j)].abs()).sum::<f64>()).fold(0.0, f64::max);
    let steps = rk4_steps(a_norm, dt);
    let n = 4;
    let dim = cl.matrix.nrows();
    let k = 3.min(dim);
    // Tangent frames: one vector for the Q' = 0 map (plant block only), k for the smooth one.
    let mut v = nalgebra::DVector::<f64>::from_fn(n, |i, _| 1.0 + 0.1 * i as f64);
    v /= v.norm();
    let mut q = DMatrix::<f64>::from_fn(dim, k, |i, j| if i == j { 1.0 } else { 0.01 * ((i * 7 + j * 3) % 5) as f64 });
    q = q.qr().q();
    let mut log_v = 0.0;
    let mut logs = vec![0.0; k];
    let mut m = cl.matrix.clone();
    // The first quarter aligns the frames and is not averaged: the closed loop's map is far
    // from normal (the derivative gain puts kd/dt ~ 200 V/rad into it), and its transient
    // growth would bias a short average.
    let transient = periods / 4;
    for row in skip..skip + periods {
        let keep = row >= skip + transient;
        let x: [f64; 4] = std::array::from_fn(|i| traj.state(row, i));
        let (_, jx, ju) = flow_jacobian(&plant, &x, traj.u[row], dt, steps);
        let phi = DMatrix::<f64>::from_fn(n, n, |i, j| jx[i][j]);
        // Q' = 0: only the plant's own flow acts on the separation.
        v = &phi * &v;
        let nv = v.norm();
        if !(nv.is_finite() && nv > 0.0) {
            return Err(chaos::ChaosError::Collapsed { step: row - skip }.into());
        }
        if keep {
            log_v += nv.ln();
        }
        v /= nv;
        // The smooth closed loop: rows 0..n are [Phi 0] + Gamma g^T, the shift registers as in the linear map.
        for i in 0..n {
            for j in 0..dim {
                m[(i, j)] = (if j < n { phi[(i, j)] } else { 0.0 }) + ju[i] * g[j];
            }
        }
        let w = &m * &q;
        let qr = w.qr();
        let r = qr.r();
        for (j, l) in logs.iter_mut().enumerate() {
            let d = r[(j, j)].abs();
            if !(d.is_finite() && d > 0.0) {
                return Err(chaos::ChaosError::Collapsed { step: row - skip }.into());
            }
            if keep {
                *l += d.ln();
            }
        }
        q = qr.q();
    }
    let t = (periods - transient) as f64 * dt;
    Ok(PeriodMapExponents {
        open_loop_rate,
        quantized_tangent: log_v / t,
        linear_closed_loop_rate,
        smooth_tangent: logs.iter().map(|l| l / t).collect(),
        periods,
        rk4_steps: steps,
    })
}

/// Scale-resolved divergence of twin runs of a scene.
#[derive(Clone, Debug, Serialize)]
pub struct TwinStudy {
    /// Initial separations (rad of theta) and the FSLE (1/s) over scales from all of them.
    pub deltas0: Vec<f64>,
    pub fsle: Vec<FsleRow>,
    /// Per initial separation: mean time (s) until the twins first differ by one encoder
    /// step `h`, and the fraction of twins that got there.
    pub time_to_h: Vec<(f64, Option<f64>, f64)>,
    /// Largest separation reached, as a fraction of the runs' theta range (saturation).
    pub theta_range: f64,
    pub starts: usize,
    pub periods: usize,
}

/// Twin runs of `scene` restarted from `starts` points on `traj` (row, state and the
/// controller's pre-history), unperturbed and with theta moved by each of `deltas0`, followed
/// for `periods`; FSLE over thresholds from the smallest initial separation up to 0.2 rad.
pub fn twin_divergence(
    scene: &Scene,
    traj: &Trajectory,
    skip: usize,
    starts: usize,
    periods: usize,
    deltas0: &[f64],
) -> Result<TwinStudy, Error> {
    let dt = traj.dt;
    let rows = traj.rows();
    if rows < skip + 3 {
        return Err(Error::BadInput {
            what: "trajectory",
            why: format!("{rows} rows, the twins start after row {skip}"),
        });
    }
    let starts_at: Vec<usize> = (0..starts).map(|k| skip + 2 + k * (rows - skip - 3) / starts.max(1)).collect();
    let tasks: Vec<(usize, Option<f64>)> = starts_at
        .iter()
        .flat_map(|&r| std::iter::once((r, None)).chain(deltas0.iter().map(move |&d| (r, Some(d)))))
        .collect();
    let runs = crate::par_map(&tasks, |&(r, d)| -> Result<Vec<[f64; 3]>, Error> {
        let mut x: Vec<f64> = (0..4).map(|i| traj.state(r, i)).collect();
        x[0] += d.unwrap_or(0.0);
        let hist = [[traj.state(r - 2, 0), traj.state(r - 2, 2)], [traj.state(r - 1, 0), traj.state(r - 1, 2)]];
        let s = scene.clone().builder().periods(periods as u64).initial_state(&x).history(Some(&hist)).build()?;
        let t = simulate(&s, None)?;
        Ok((0..t.rows()).map(|i| [t.state(i, 0), dt * t.state(i, 1), dt * t.state(i, 3)]).collect())
    })?;
    let per = deltas0.len() + 1;
    let mut seps = Vec::new();
    let mut time_to_h = vec![(0.0, 0.0, 0usize); deltas0.len()];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for chunk in runs.chunks(per) {
        let base = &chunk[0];
        base.iter().for_each(|p| {
            lo = lo.min(p[0]);
            hi = hi.max(p[0]);
        });
        for (k, twin) in chunk[1..].iter().enumerate() {
            let d: Vec<f64> = base
                .iter()
                .zip(twin)
                .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
                .collect();
            if let Some(i) = d.iter().position(|&v| v >= H_ADC) {
                time_to_h[k].0 += i as f64 * dt;
                time_to_h[k].1 += 1.0;
            }
            time_to_h[k].2 += 1;
            seps.push(d);
        }
    }
    let d_min = deltas0.iter().copied().fold(f64::INFINITY, f64::min);
    // Thresholds from 2 x the smallest start by factors of sqrt(10) up to 2e-3 rad (below one
    // encoder step), then by sqrt(2) up to 0.2 rad (the attractor's scales).
    let mut delta = vec![2.0 * d_min];
    while let Some(&last) = delta.last() {
        let next = if last < 2e-3 * (1.0 - 1e-9) { (last * 10f64.sqrt()).min(2e-3) } else { last * 2f64.sqrt() };
        if next > 0.2 {
            break;
        }
        delta.push(next);
    }
    let fsle = chaos::fsle_from_separations(&seps, dt, &delta)?;
    Ok(TwinStudy {
        deltas0: deltas0.to_vec(),
        fsle,
        time_to_h: deltas0
            .iter()
            .zip(&time_to_h)
            .map(|(&d, &(t, c, n))| (d, (c > 0.0).then(|| t / c), c / n.max(1) as f64))
            .collect(),
        theta_range: hi - lo,
        starts,
        periods,
    })
}

/// The values the conclusion quotes besides the rates, exponents and test results of
/// [`Verdict`] (the report writes the conclusion's sentences over them).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Conclusion {
    /// One encoder step `h` (rad): the scale below which the twins see the open-loop flow.
    pub encoder_step: f64,
    /// The first twin FSLE threshold at or above one encoder step with a rate (rad): where one
    /// count flip takes the separation from about `h / 2`; `None` when no band has a rate.
    pub separation_after_flip: Option<f64>,
    /// The span of the noise-free quantized series the 0-1 test's displacements cover, s.
    pub zero_one_span_s: f64,
}

/// Everything [`microchaos_verdict`] measured, and what it concludes.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// What the conclusion quotes beyond the fields below.
    pub conclusion: Conclusion,
    /// Deterministic chaos in the strict sense: the noise-free quantized loop's twins separate
    /// exponentially from 1e-9 rad up to a count flip at a rate (`rate_below_step`) that
    /// agrees with the period map's own tangent exponent within 30 %.
    pub chaotic: bool,
    /// Mean twin FSLE (1/s) over the bands below `h / 100` (before any count flip is near).
    pub rate_below_step: Option<f64>,
    /// The attractor's scales (rad): from 5 encoder steps to 0.3 x the theta range.
    pub attractor_scales: (f64, f64),
    /// Twin FSLE over the attractor's scales: mean rate (1/s) and the slope of ln lambda
    /// against ln delta (0: exponential separation; -2: diffusion).
    pub attractor_rate: Option<f64>,
    pub attractor_slope: Option<f64>,
    /// Exponential separation at the attractor's scale: a positive twin FSLE whose slope over
    /// those scales is above -0.5, and a 0-1 test K above 0.5.
    pub chaotic_at_attractor_scale: bool,
    pub period_map: PeriodMapExponents,
    /// Twin runs of the noise-free quantized loop, and of the noisy one (both twins get the
    /// same noise sequence: the random dynamical system's separation).
    pub twins: TwinStudy,
    pub twins_noisy: TwinStudy,
    /// Series tests: the noise-free quantized loop, the smooth (unquantized) loop at the same
    /// dt, the noisy quantized loop (simulated), and the PIL recording when given.
    pub series: Vec<SeriesTests>,
    /// Where the noisy series comes from.
    pub noisy_source: String,
    pub options: VerdictOptions,
}

/// The `summary.json` key `microchaos_verdict`: the conclusion and the test values.
#[derive(Clone, Debug, Serialize)]
pub struct MicrochaosVerdictSummary {
    pub conclusion: Conclusion,
    pub chaotic: bool,
    pub chaotic_at_attractor_scale: bool,
    pub rate_below_step: Option<f64>,
    pub attractor_scales: (f64, f64),
    pub attractor_rate: Option<f64>,
    pub attractor_slope: Option<f64>,
    /// Per series: 0-1 test K, data FSLE slope, surrogate p-values.
    pub series: Vec<SeriesSummary>,
    pub period_map: PeriodMapExponents,
    /// Twin FSLE tables (noise-free; noisy with common noise).
    pub fsle_twins: Vec<FsleRow>,
    pub fsle_twins_noisy: Vec<FsleRow>,
    pub noisy_source: String,
}

/// One series' test values in [`MicrochaosVerdictSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct SeriesSummary {
    pub name: String,
    pub zero_one_k: f64,
    pub fsle_slope: Option<f64>,
    pub fsle: Vec<FsleRow>,
    pub surrogate_p_prediction: f64,
    pub surrogate_p_time_reversal: f64,
}

impl From<&Verdict> for MicrochaosVerdictSummary {
    fn from(v: &Verdict) -> Self {
        Self {
            conclusion: v.conclusion,
            chaotic: v.chaotic,
            chaotic_at_attractor_scale: v.chaotic_at_attractor_scale,
            rate_below_step: v.rate_below_step,
            attractor_scales: v.attractor_scales,
            attractor_rate: v.attractor_rate,
            attractor_slope: v.attractor_slope,
            series: v
                .series
                .iter()
                .map(|s| SeriesSummary {
                    name: s.name.clone(),
                    zero_one_k: s.zero_one.k,
                    fsle_slope: s.fsle_slope,
                    fsle: s.fsle.clone(),
                    surrogate_p_prediction: s.surrogate_prediction.p_value,
                    surrogate_p_time_reversal: s.surrogate_time_reversal.p_value,
                })
                .collect(),
            period_map: v.period_map.clone(),
            fsle_twins: v.twins.fsle.clone(),
            fsle_twins_noisy: v.twins_noisy.fsle.clone(),
            noisy_source: v.noisy_source.clone(),
        }
    }
}

/// Mean twin FSLE over the bands inside `[lo, hi]` (lower and upper thresholds) with a value
/// and at least 3 pairs, and the slope of ln lambda against ln delta over them.
pub fn band_rate(rows: &[FsleRow], lo: f64, hi: f64) -> (Option<f64>, Option<f64>) {
    let inside: Vec<&FsleRow> = rows
        .windows(2)
        .filter(|w| w[0].delta >= lo * (1.0 - 1e-9) && w[1].delta <= hi * (1.0 + 1e-9))
        .map(|w| &w[0])
        .filter(|r| r.pairs >= 3 && r.lambda.is_some())
        .collect();
    let lam: Vec<f64> = inside.iter().filter_map(|r| r.lambda).collect();
    let mean = (!lam.is_empty()).then(|| lam.iter().sum::<f64>() / lam.len() as f64);
    let owned: Vec<FsleRow> = inside.into_iter().copied().collect();
    (mean, chaos::scaling_slope(&owned, 3).ok())
}

/// Runs every test (see the module doc). `pil` is the noisy processor-in-the-loop recording
/// (plant theta) when available; otherwise only the simulated noisy scene is tested, which
/// the result says.
pub fn microchaos_verdict(pil: Option<&TimeSeries>, o: &VerdictOptions) -> Result<Verdict, Error> {
    o.validate()?;
    let built: Vec<Scene> = SCENES
        .iter()
        .map(|name| {
            Ok(SceneBuilder::load(name)?.periods(o.periods as u64).initial_state(&[o.theta0, 0.0, 0.0, 0.0]).build()?)
        })
        .collect::<Result<_, Error>>()?;
    let sims = crate::par_map(&built, crate::microchaos::simulate_shared)?;
    let quant_traj = &sims[0];
    let dt = quant_traj.dt;
    let skip = (20.0 / dt) as usize;
    if skip + 1000 >= quant_traj.rows() {
        return Err(Error::BadOption {
            what: "periods",
            why: format!("{} periods leave fewer than 1000 after the 20 s transient", o.periods),
        });
    }
    let mut named: Vec<(String, Vec<f64>)> = SCENES
        .iter()
        .zip(&sims)
        .map(|(n, t)| (format!("{n} (simulated theta)"), t.primary()[skip..].to_vec()))
        .collect();
    let noisy_source = match pil {
        Some(ts) => {
            named.push((format!("PIL recording: {}", ts.name), ts.x.clone()));
            format!("the PIL recording {} and the simulated noisy scene", ts.name)
        }
        None => "no PIL recording: the simulated scene furuta-quant-dt25-noise (same noise settings) stands in for it"
            .into(),
    };
    // One set of estimator settings, from the noise-free quantized series, for every series.
    let ctx = Context::from_series(&named[0].1, dt, 6)?;
    let series: Vec<SeriesTests> = crate::par_map(&named, |(n, x)| series_tests(n, x, &ctx, o))?;
    let tangent_periods = o.tangent_periods.min(quant_traj.rows() - skip - 1);
    let period_map = period_map_exponents(&built[0], quant_traj, skip, tangent_periods)?;
    let twin_sets = [(0usize, &built[0]), (2, &built[2])];
    let mut tw = crate::par_map(&twin_sets, |&(k, s)| {
        twin_divergence(s, &sims[k], skip, o.twin_starts, o.twin_periods, &o.twin_deltas)
    })?
    .into_iter();
    let (Some(twins), Some(twins_noisy)) = (tw.next(), tw.next()) else {
        return Err(Error::BadInput { what: "twin runs", why: "fewer studies than scenes".into() });
    };
    let (rate_below_step, _) = band_rate(&twins.fsle, 0.0, H_ADC / 100.0);
    let chaotic = rate_below_step.is_some_and(|r| {
        r > 0.0 && (r - period_map.quantized_tangent).abs() <= 0.3 * period_map.quantized_tangent.abs()
    });
    let attractor_scales = (5.0 * H_ADC, 0.3 * twins.theta_range);
    let (attractor_rate, attractor_slope) = band_rate(&twins.fsle, attractor_scales.0, attractor_scales.1);
    let q = &series[0];
    let chaotic_at_attractor_scale =
        attractor_rate.is_some_and(|r| r > 0.0) && attractor_slope.is_some_and(|s| s > -0.5) && q.zero_one.k > 0.5;
    let conclusion = Conclusion {
        encoder_step: H_ADC,
        separation_after_flip: twins.fsle.iter().find(|r| r.delta >= H_ADC && r.lambda.is_some()).map(|r| r.delta),
        zero_one_span_s: (q.zero_one.n_cut * q.zero_one.stride) as f64 * dt,
    };
    Ok(Verdict {
        conclusion,
        chaotic,
        rate_below_step,
        attractor_scales,
        attractor_rate,
        attractor_slope,
        chaotic_at_attractor_scale,
        period_map,
        twins,
        twins_noisy,
        series,
        noisy_source,
        options: o.clone(),
    })
}
