//! The `ssmctl` command line: argument parsing and output formatting only; the work is in
//! the library modules.

use crate::bench;
use crate::report::reproduce;
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use sim::closed_loop;
use sim::scene::{BUNDLED, Scene};
use sim::stability;
use std::io::Write as _;
use std::path::PathBuf;

/// Prints a line to stdout; a closed pipe (e.g. `| head`) ends output quietly, other write
/// errors are returned.
macro_rules! outln {
    ($($arg:tt)*) => {{
        let mut o = std::io::stdout().lock();
        match writeln!(o, $($arg)*) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
            r => r?,
        }
    }};
}

#[derive(Parser)]
#[command(
    name = "ssmctl",
    version,
    about = "Simulate, analyse and reduce a mechanical system under delayed, sampled, quantized PD control"
)]
pub struct Cli {
    /// No progress bars.
    #[arg(long, global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    pub cmd: Cmd,
}

#[derive(Args, Clone)]
pub struct SceneArgs {
    /// A bundled scene name (see `ssmctl scenes`) or a scene TOML file.
    #[arg(long)]
    pub scene: String,
    /// Override any scene field: `--set path.to.field=value` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<String>,
}

impl SceneArgs {
    fn load(&self) -> Result<Scene, sim::scene::SceneError> {
        Scene::load(&self.scene, &self.set)
    }
}

#[derive(Subcommand)]
pub enum Cmd {
    /// List the bundled scenes.
    Scenes {
        #[arg(long)]
        json: bool,
    },
    /// Simulate a scene's closed loop; writes `DIR/<scene>.csv` and `DIR/<scene>.json`.
    Simulate {
        #[command(flatten)]
        scene: SceneArgs,
        #[arg(long)]
        out: PathBuf,
    },
    /// Exact closed-loop multipliers of the linearized sampled-data loop.
    Stability {
        #[command(flatten)]
        scene: SceneArgs,
        /// Print JSON `{"multipliers": [...]}` sorted by modulus, largest first.
        #[arg(long)]
        json: bool,
    },
    /// Stability chart over two gains or plant parameters (default KP, KD) for several
    /// sampling periods, as a PNG.
    StabilityChart {
        #[command(flatten)]
        scene: SceneArgs,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// Sampling periods in ms, comma separated.
        #[arg(long, value_delimiter = ',', default_value = "20,25,30.8")]
        dt_ms: Vec<f64>,
        /// The two axes, comma separated: gains `COORD.p`, `COORD.d` of measured coordinates
        /// (`theta.p`, `x.d`; the shorthand `kp`, `kd`, `kphi_d`) or plant parameters
        /// (`plant.parameters.m` of a plant written as equations, `plant.params.b1` of a
        /// built-in one).
        #[arg(long, value_delimiter = ',', default_value = "kp,kd")]
        axes: Vec<String>,
        /// Range and points of the first axis, `min:max:n` (default for `kp`: 0:40:161).
        #[arg(long = "x-range", visible_alias = "kp", value_name = "MIN:MAX:N", allow_hyphen_values = true)]
        x_range: Option<String>,
        /// Range and points of the second axis, `min:max:n` (default for `kd`: 0:8:161).
        #[arg(long = "y-range", visible_alias = "kd", value_name = "MIN:MAX:N", allow_hyphen_values = true)]
        y_range: Option<String>,
    },
    /// Run everything on the bundled scenes; writes DIR/index.html and DIR/summary.json.
    Reproduce {
        #[arg(long)]
        out: PathBuf,
        /// Shorter runs and timing windows (smoke test).
        #[arg(long)]
        quick: bool,
        /// Folder of the measured reference data sets (sections skip, saying so, when absent).
        #[arg(long, default_value = "../shared/data")]
        data_dir: PathBuf,
        /// Threads of the pool the sweeps run on (default: RAYON_NUM_THREADS, else one per
        /// core). The results do not depend on it.
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
        jobs: Option<u16>,
        /// Folder of the section cache (default: `.ssmctl-cache` beside the `--out` folder).
        /// A section whose code, options and input files are unchanged is replayed from it.
        #[arg(long, conflicts_with = "no_cache")]
        cache: Option<PathBuf>,
        /// Compute every section; read and keep nothing in the cache.
        #[arg(long)]
        no_cache: bool,
    },
    /// Manage the report's section cache.
    Cache {
        #[command(subcommand)]
        what: CacheCmd,
    },
    /// Run a sweep spec (basin map, stability chart) or one shard of it; writes
    /// DIR/shard-I-of-N.json. The shard: --shard, else the Slurm array task
    /// (SLURM_ARRAY_TASK_ID/COUNT/MIN), else Kubernetes' JOB_COMPLETION_INDEX with --shards
    /// or the spec's `shards`, else the whole grid. A complete shard file of the same spec
    /// is kept (re-runs are idempotent).
    Sweep {
        /// The sweep spec (TOML).
        spec: PathBuf,
        /// Folder of the shard files (created if needed).
        #[arg(long)]
        out: PathBuf,
        /// Compute shard I of N (0-based), e.g. `3/8`.
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        /// The shard count for JOB_COMPLETION_INDEX (default: the spec's `shards`).
        #[arg(long)]
        shards: Option<u32>,
        /// Threads of the pool (default: RAYON_NUM_THREADS, else one per core). The results
        /// do not depend on it.
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
        jobs: Option<u16>,
        /// Recompute even if a complete shard file is there; replace one of another spec.
        #[arg(long)]
        force: bool,
    },
    /// Run a study spec (`studies/flag.toml`) on measured data: writes its results files
    /// (the report reads them from studies/results/flag) and OUT/study.json (the spec, the
    /// data files' CRC-64 and the code version).
    Study {
        /// The study spec (TOML).
        spec: PathBuf,
        /// Folder of the measured data sets (the spec's `data.folder` is under it).
        #[arg(long, default_value = "../shared/data")]
        data_dir: PathBuf,
        /// Folder of the results files (created if needed).
        #[arg(long)]
        out: PathBuf,
        /// Budget: only the first N candidates of each of the spec's lists (a quick, partial run).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        candidates: Option<u32>,
        /// Threads of the pool (default: RAYON_NUM_THREADS, else one per core). The results
        /// do not depend on it.
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
        jobs: Option<u16>,
        /// Selection specs: folder of the per-candidate cache (default: `.ssmctl-cache` beside
        /// the --out folder); a candidate whose code, settings and data are unchanged is read
        /// from it, not computed.
        #[arg(long, conflicts_with = "no_cache")]
        cache: Option<PathBuf>,
        /// Selection specs: compute every candidate; read and keep nothing in the cache.
        #[arg(long)]
        no_cache: bool,
        /// Selection specs: compute shard I of N of the candidates (0-based, candidate k in
        /// shard k mod N) into OUT/selection-shard-I-of-N.json. Without it, the Slurm array
        /// task (SLURM_ARRAY_TASK_ID/COUNT/MIN) or Kubernetes' JOB_COMPLETION_INDEX with
        /// --shards, as `ssmctl sweep`.
        #[arg(long, value_name = "I/N", conflicts_with = "merge")]
        shard: Option<String>,
        /// The shard count for JOB_COMPLETION_INDEX.
        #[arg(long)]
        shards: Option<u32>,
        /// Selection specs: merge the shard files in --out into the results (the same as one
        /// unsharded run).
        #[arg(long)]
        merge: bool,
    },
    /// Merge a folder of sweep shard files: checks every cell is there once, from one spec;
    /// writes `OUT/<name>.json`, `OUT/<name>.csv` and the figure `OUT/<name>.png`.
    SweepMerge {
        /// Folder of shard-*.json files.
        dir: PathBuf,
        /// Output folder (created if needed).
        #[arg(long)]
        out: PathBuf,
    },
    /// Fit an SSM reduced model to time series of one or several observables (CSV files of
    /// t and observables, or SSMLearn .mat files with a cell array xData of {t, X} rows).
    Fit(Box<FitArgs>),
    /// The equation-driven SSM of the scene's sampled-data loop (no quantization or
    /// saturation), for any plant and gain vector: Taylor expansion of the one-period map,
    /// SSM tangent to the leading complex multiplier pairs (at most two), polar amplitude
    /// equations in the data-driven model's conventions, invariance error by order.
    SsmEquations {
        #[command(flatten)]
        scene: SceneArgs,
        /// Order of the expansion, the manifold and the reduced map (3..=9).
        #[arg(long, default_value_t = 7)]
        order: u32,
        #[arg(long)]
        json: bool,
    },
    /// Backbone curves (instantaneous damping ratio and frequency against amplitude) of a
    /// saved model with polynomial dynamics; writes DIR/backbone.json and DIR/backbone.png.
    Backbone {
        /// Fitted model JSON written by `ssmctl fit --save`.
        #[arg(long)]
        model: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Observable (1-based, in the order the model was fitted with).
        #[arg(long, default_value_t = 1)]
        observable: usize,
        /// Largest amplitude of the curve, in the observable's units.
        #[arg(long)]
        amplitude: f64,
    },
    /// Forced response curve of a saved model with polynomial dynamics: harmonic forcing
    /// added to its normal form, the forcing amplitude calibrated from one measured
    /// steady state; all branches with their stability. Writes DIR/frc.json and DIR/frc.png.
    Frc {
        /// Fitted model JSON written by `ssmctl fit --save`.
        #[arg(long)]
        model: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Forcing frequencies A:B or A:B:N in rad/s (0 < A < B; N points, default 400).
        #[arg(long, value_name = "A:B[:N]")]
        freq_range: String,
        /// A measured steady state: forcing frequency (rad/s) and amplitude (max |observable|
        /// over a period, in the observable's units).
        #[arg(long, value_name = "FREQ,AMP")]
        calibrate: String,
        /// Observable (1-based, in the order the model was fitted with).
        #[arg(long, default_value_t = 1)]
        observable: usize,
        /// Forced mode (1-based, by increasing frequency) of a model with several modes.
        #[arg(long, default_value_t = 1)]
        mode: usize,
        /// Largest amplitude the model is trusted at (default: where the reduced coordinates
        /// leave the training data's range).
        #[arg(long)]
        amplitude_max: Option<f64>,
        /// Print the curve as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Convert a fitted RBF model (JSON from `fit --save`) to the device blob.
    Export {
        /// Fitted model JSON written by `ssmctl fit --save`.
        #[arg(long)]
        model: PathBuf,
        /// Output blob.
        #[arg(long)]
        out: PathBuf,
        /// Scene whose controller configuration the blob carries (default: the paper's gains
        /// at the model's sampling period).
        #[arg(long)]
        scene: Option<String>,
    },
    /// Print a device blob's header and shapes.
    Inspect {
        blob: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Chaotic statistics of scalar series vs SSM models: correlation dimension, SSM
    /// dimension, Lyapunov exponents, PDF divergences.
    Chaos {
        /// Training CSV files, comma separated (the longest is the reference data).
        #[arg(long, value_delimiter = ',', required = true)]
        data: Vec<PathBuf>,
        /// The observable's column in wider CSV files (the first column is the time).
        #[arg(long)]
        column: Option<String>,
        /// Embedding dimension of the estimators.
        #[arg(long, default_value_t = 6)]
        gp_embed: usize,
        /// SSM dimension (default: smallest even integer above the correlation dimension).
        #[arg(long)]
        ssm_dim: Option<usize>,
        /// RBF centres.
        #[arg(long, default_value_t = 500)]
        centers: usize,
        /// Polynomial map order.
        #[arg(long, default_value_t = 4)]
        poly_order: u32,
        /// SSM delay-embedding shift in samples (default: the embedding window spans a quarter
        /// of the dominant period).
        #[arg(long)]
        shift: Option<usize>,
        /// Relative ridge parameter of the SSM regressions.
        #[arg(long, default_value_t = 1e-8)]
        ridge: f64,
        /// Held-out CSV file: the models are fitted on --data only; the data statistics, the
        /// model runs' start and the model selection use this series (default: the longest
        /// --data series, then nothing is held out).
        #[arg(long)]
        test: Option<PathBuf>,
        /// Candidates of the model selection: the first N of the report's search (the flag
        /// study's centre-set candidates in studies/flag.toml: RBF maps over 4 samples, SSM
        /// dimension 4 or --ssm-dim), run as `ssmctl study` runs a selection spec. Each
        /// candidate is a fit, a 55,000-step Benettin run and a long run; studies/README.md
        /// gives the default's cost.
        #[arg(long, default_value_t = DEFAULT_CHAOS_BUDGET, value_parser = clap::value_parser!(u32).range(1..))]
        budget: u32,
        /// Folder of the per-candidate cache (as `ssmctl study`'s); default: no cache.
        #[arg(long)]
        cache: Option<PathBuf>,
        #[arg(long)]
        json: bool,
    },
    /// Benchmarks.
    Bench {
        #[command(subcommand)]
        what: BenchCmd,
    },
    /// Processor-in-the-loop: the scene's plant simulated here, the integer controller and
    /// the predictor on the Cortex-M4F under QEMU over UART0; writes DIR/pil.csv,
    /// DIR/summary.json and the recorded data set DIR/theta.csv (`t_s,theta_meas_rad`: the
    /// measured angle, noise then encoder quantization) and DIR/record.csv (t, true theta and
    /// phi, measured theta, code, prediction). `cargo xtask pil` builds the firmware, fits a
    /// model and runs this; `cargo xtask pil-record` records several runs.
    Pil {
        #[command(flatten)]
        scene: SceneArgs,
        /// Device model blob (its controller configuration must equal the scene's).
        #[arg(long)]
        model: PathBuf,
        /// Fit a 4D RBF model of the scene first and write it to --model.
        #[arg(long)]
        fit_model: bool,
        #[arg(long, default_value_t = 2000)]
        periods: u64,
        #[arg(long)]
        out: PathBuf,
        /// The firmware's PIL binary (where the xtask copies each board's images after building
        /// them in one target dir).
        #[arg(long, default_value = "qemu/target/images/mps2-an386/pil")]
        elf: PathBuf,
        /// QEMU machine: mps2-an386, or netduinoplus2 (STM32F405) for the `stm32f407` build
        /// (qemu/target/images/stm32f407/pil).
        #[arg(long, default_value = "mps2-an386", value_parser = crate::pil::Machine::parse)]
        machine: crate::pil::Machine,
        /// Per-reply timeout, seconds.
        #[arg(long, default_value_t = 5.0)]
        timeout: f64,
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args)]
pub struct FitArgs {
    /// Training files, comma separated: CSV, or .mat (every trajectory of --mat-var).
    #[arg(long, value_delimiter = ',', required_unless_present = "mat")]
    pub data: Vec<PathBuf>,
    /// Test files, comma separated (CSV or .mat).
    #[arg(long, value_delimiter = ',')]
    pub test: Vec<PathBuf>,
    /// A MATLAB .mat file (v5-v7; SSMLearn's layout: a cell array with one row {t, X} per
    /// trajectory, X one row per observable) split into training and test trajectories by
    /// --test-rows.
    #[arg(long)]
    pub mat: Option<PathBuf>,
    /// The cell-array variable of .mat files.
    #[arg(long, default_value = "xData")]
    pub mat_var: String,
    /// Rows of --mat (1-based, comma separated) held out for testing (SSMLearn's indTest).
    #[arg(long, value_delimiter = ',')]
    pub test_rows: Vec<usize>,
    /// The observable's column in wider CSV files (e.g. `theta` of `ssmctl simulate`'s
    /// output; the first column is the time). Without it files must have two columns.
    #[arg(long, conflicts_with = "observables")]
    pub column: Option<String>,
    /// Several observables, comma separated: CSV column names, or rows of X in .mat files
    /// (1, 2, ...); `all` for every column / row. Every observable is delay-embedded with
    /// --embed copies (SSMLearn's OverEmbedding = embed - 1); NMTE is over all of them.
    #[arg(long, value_delimiter = ',')]
    pub observables: Option<Vec<String>>,
    /// Start of the time window in s (SSMLearn's sliceTrajectories), to cut initial
    /// transients: one value for every trajectory, or one per trajectory (training, then
    /// test; an empty entry leaves it uncut).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub from: Vec<String>,
    /// End of the time window in s (as --from).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub to: Vec<String>,
    /// SSM dimension d (with --auto: fixes the dimension instead of choosing it from the
    /// singular values).
    #[arg(long, required_unless_present = "auto")]
    pub dim: Option<usize>,
    /// Delay-embedding dimension p (> 2d).
    #[arg(long, required_unless_present = "auto")]
    pub embed: Option<usize>,
    /// Delay between embedding components, in samples.
    #[arg(long, default_value_t = 1)]
    pub shift: usize,
    /// Polynomial order of the manifold parametrization.
    #[arg(long, default_value_t = 3)]
    pub order: u32,
    /// Polynomial order of the reduced dynamics (flow, map).
    #[arg(long, default_value_t = 5)]
    pub dyn_order: u32,
    /// flow | map | rbf | rbf:KERNEL (KERNEL: linear = rbf, cubic, thin-plate, gaussian:EPS;
    /// the device exports the linear kernel only)
    #[arg(long, default_value = "map")]
    pub dynamics: String,
    /// Number of RBF centres.
    #[arg(long, default_value_t = 100)]
    pub centers: usize,
    /// Ridge alpha (relative to the largest squared singular value), or `cv`.
    #[arg(long, default_value = "0")]
    pub ridge: String,
    /// Fit the linear part of flow/map dynamics to the points within this fraction of the
    /// largest |eta| only (then the higher orders to all): exact rates near the fixed
    /// point when the data also reach large amplitudes. E.g. 0.01. Needs clean data near
    /// the fixed point: noise-dominated small amplitudes make it worse (see bench fit).
    #[arg(long)]
    pub linear_anchor: Option<f64>,
    /// With --linear-anchor: pick the small pairs by their envelope and fit the linear part
    /// jointly with the higher orders (unbiased by them; see ssm::FitOptions::anchor_joint).
    #[arg(long, requires = "linear_anchor")]
    pub anchor_joint: bool,
    /// Choose the settings from the data (ssm::auto): the SSM dimension from the singular
    /// values of the delay-embedded data, then the transient cut, embedding size and shift,
    /// manifold and dynamics orders, ridge and joint linear anchor (or none) by
    /// cross-validation (leave one trajectory out; blocks in time of a single trajectory),
    /// scored by held-out NMTE and the spread of the linear part across folds. Prints the
    /// choice, the runner-up and why; --intervals is on unless --no-intervals.
    #[arg(long, conflicts_with_all = ["embed", "shift", "order", "dyn_order", "ridge", "linear_anchor", "from"])]
    pub auto: bool,
    /// Most settings --auto scores (each costs one fit per fold).
    #[arg(long, default_value_t = 40, requires = "auto")]
    pub budget: usize,
    /// Bootstrap 95 % intervals of the eigenvalues (real and imaginary parts, damping ratio)
    /// and of the backbone curves (bands in backbone.json and backbone.png): over
    /// trajectories (4 or more), segments of them (2 or 3), or the residuals of a lone one.
    #[arg(long)]
    pub intervals: bool,
    /// No intervals with --auto.
    #[arg(long, conflicts_with = "intervals")]
    pub no_intervals: bool,
    /// Bootstrap replicates of --intervals.
    #[arg(long, default_value_t = 200)]
    pub replicates: usize,
    /// Seed of the bootstrap resampling.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Add the extended normal form in polar coordinates (polynomial flow or map dynamics).
    #[arg(long)]
    pub normal_form: bool,
    /// Save the fitted model as JSON (input of `export`).
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Backbone curves of the normal form (polynomial dynamics): instantaneous damping ratio
    /// and frequency against the amplitude of an observable through the manifold; written
    /// to DIR/backbone.json and DIR/backbone.png and added to the summary.
    #[arg(long, value_name = "DIR")]
    pub backbone: Option<PathBuf>,
    /// The backbone's observable (a name of --observables; default the first).
    #[arg(long, requires = "backbone")]
    pub backbone_observable: Option<String>,
    /// The backbone's largest amplitude (default: the largest |observable| in the training
    /// data).
    #[arg(long, requires = "backbone")]
    pub backbone_amplitude: Option<f64>,
    /// Forced response curve of the fitted normal form (as `ssmctl frc`), for the first
    /// observable (or --backbone-observable): written to DIR/frc.json and DIR/frc.png; needs
    /// --frc-range and --frc-calibrate.
    #[arg(long, value_name = "DIR", requires_all = ["frc_range", "frc_calibrate"])]
    pub frc: Option<PathBuf>,
    /// Forcing frequencies A:B or A:B:N in rad/s for --frc.
    #[arg(long, value_name = "A:B[:N]", requires = "frc")]
    pub frc_range: Option<String>,
    /// The measured steady state for --frc: forcing frequency (rad/s) and amplitude.
    #[arg(long, value_name = "FREQ,AMP", requires = "frc")]
    pub frc_calibrate: Option<String>,
}

/// `--from`/`--to` entries: numbers, empty for no bound.
fn parse_bounds(v: &[String], flag: &str) -> Result<Vec<Option<f64>>, String> {
    v.iter()
        .map(|s| match s.trim() {
            "" => Ok(None),
            t => t.parse::<f64>().map(Some).map_err(|_| format!("{flag} `{s}`: expected a time in seconds")),
        })
        .collect()
}

#[derive(Subcommand)]
pub enum CacheCmd {
    /// Removes the entries the last `reproduce` with this cache did not use (with `--all`:
    /// every entry) and scratch folders of processes that no longer run; prints what it
    /// removed.
    Gc {
        /// The cache folder.
        dir: PathBuf,
        #[arg(long)]
        all: bool,
    },
}

#[derive(Subcommand)]
pub enum BenchCmd {
    /// Periods simulated per second vs max theta error against a tight reference.
    Simulate {
        #[arg(long)]
        json: bool,
        #[arg(long, default_value_t = 200)]
        periods: u64,
        #[arg(long)]
        quick: bool,
    },
    /// Fit time vs test error on the sloshing data (train decay_0, decay_1; test decay_2),
    /// one setting varied at a time; ratios against the recommended fit in the same run.
    Fit {
        #[arg(long)]
        json: bool,
        /// Folder holding `sloshing/decay_{0,1,2}.csv`.
        #[arg(long, default_value = "../shared/data")]
        data_dir: PathBuf,
        #[arg(long)]
        quick: bool,
    },
}

/// Runs `f` with a spinner showing the progress messages `f` reports (none when `quiet`).
fn with_spinner<T>(quiet: bool, msg: &str, f: impl FnOnce(&mut dyn FnMut(&str)) -> T) -> T {
    let pb = spinner(quiet, None, msg);
    let mut report = |m: &str| {
        if let Some(pb) = &pb {
            pb.set_message(m.to_string());
            pb.tick();
        }
    };
    let out = f(&mut report);
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    out
}

fn spinner(quiet: bool, len: Option<u64>, msg: &str) -> Option<ProgressBar> {
    if quiet {
        return None;
    }
    let pb = match len {
        Some(n) => ProgressBar::new(n).with_style(
            ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        ),
        None => ProgressBar::new_spinner(),
    };
    pb.set_message(msg.to_string());
    Some(pb)
}

/// Parses `min:max:n`.
pub fn parse_range(s: &str, what: &str) -> Result<(f64, f64, usize), String> {
    let parts: Vec<&str> = s.split(':').collect();
    let bad = || format!("--{what} `{s}`: expected min:max:n with min < max and n >= 2");
    if parts.len() != 3 {
        return Err(bad());
    }
    let lo: f64 = parts[0].trim().parse().map_err(|_| bad())?;
    let hi: f64 = parts[1].trim().parse().map_err(|_| bad())?;
    let n: usize = parts[2].trim().parse().map_err(|_| bad())?;
    if !(lo.is_finite() && hi.is_finite() && lo < hi && n >= 2) {
        return Err(bad());
    }
    Ok((lo, hi, n))
}

/// The scene quantities of `stability-chart --axes`: `None` for the classic (KP, KD) chart
/// of a scene with the shorthand gains, else the two named axes (errors name `--axes` and
/// list the scene's gains and parameters).
pub fn chart_axes(
    scene: &Scene,
    axes: &[String],
) -> Result<Option<(sim::scene::axis::SceneAxis, sim::scene::axis::SceneAxis)>, String> {
    let [x, y] = axes else {
        return Err(format!("--axes: give two axes, e.g. `--axes theta.p,theta.d`; got {}", axes.len()));
    };
    if (x.as_str(), y.as_str()) == ("kp", "kd") && scene.controller.gains.is_none() {
        return Ok(None);
    }
    let axis = |name: &str| sim::scene::axis::SceneAxis::parse(scene, name).map_err(|e| format!("--axes: {e}"));
    Ok(Some((axis(x)?, axis(y)?)))
}

/// The two axes of `stability-chart --axes` with their ranges: `--x-range`/`--y-range`
/// (aliases `--kp`/`--kd`), by default 0:40:161 for `kp` and 0:8:161 for `kd`; any other
/// axis needs its range given.
pub fn chart_ranges<'a>(
    axes: &'a [String],
    x_range: Option<&str>,
    y_range: Option<&str>,
) -> Result<[(&'a str, (f64, f64, usize)); 2], String> {
    let [x, y] = axes else {
        return Err(format!("--axes: give two axes, e.g. `--axes theta.p,theta.d`; got {}", axes.len()));
    };
    if x == y {
        return Err(format!("--axes: `{x}` given twice"));
    }
    let range = |name: &str, given: Option<&str>, flag: &str| -> Result<(f64, f64, usize), String> {
        match (given, name) {
            (Some(r), _) => parse_range(r, flag),
            (None, "kp") => parse_range("0:40:161", flag),
            (None, "kd") => parse_range("0:8:161", flag),
            (None, _) => Err(format!("--{flag}: give the range of axis `{name}` as min:max:n (it has no default)")),
        }
    };
    Ok([(x.as_str(), range(x, x_range, "x-range/--kp")?), (y.as_str(), range(y, y_range, "y-range/--kd")?)])
}

/// Parses a command line (`args[0]` is the program name) without exiting: clap's error
/// carries the usage message and its exit code (2; 0 for `--help`/`--version`).
pub fn try_parse(args: &[String]) -> Result<Cli, clap::Error> {
    Cli::try_parse_from(args)
}

/// The checks of a parsed command line that read no input file, run by [`run`] before any
/// work: numeric options against their ranges and the stated size limits (`--periods`,
/// `--timeout`, grid ranges, fit and chaos options through the libraries' own validation),
/// and bundled scenes with their `--set` overrides (scene files are read by the command).
/// The seam the `cli_options` fuzz target drives.
pub fn check_options(cli: &Cli) -> Result<(), Box<dyn std::error::Error>> {
    let bundled = |a: &SceneArgs| -> Result<(), Box<dyn std::error::Error>> {
        if sim::scene::BUNDLED.iter().any(|(n, _)| *n == a.scene) {
            a.load()?;
        }
        Ok(())
    };
    let one_based = |v: usize, flag: &str| -> Result<(), Box<dyn std::error::Error>> {
        if v == 0 { Err(format!("{flag} is 1-based").into()) } else { Ok(()) }
    };
    match &cli.cmd {
        Cmd::Simulate { scene, .. } | Cmd::Stability { scene, .. } | Cmd::SsmEquations { scene, .. } => bundled(scene)?,
        Cmd::StabilityChart { scene, dt_ms, axes, x_range, y_range, .. } => {
            // The axis names first (against a bundled scene), then their ranges.
            if sim::scene::BUNDLED.iter().any(|(n, _)| *n == scene.scene) {
                let s = scene.load()?;
                chart_axes(&s, axes)?;
            }
            let [(x, xr), (y, yr)] = chart_ranges(axes, x_range.as_deref(), y_range.as_deref())?;
            sim::chart::Axis::from(xr).check(x).map_err(|e| format!("--x-range/--kp: {e}"))?;
            sim::chart::Axis::from(yr).check(y).map_err(|e| format!("--y-range/--kd: {e}"))?;
            if let Some(dt) = dt_ms.iter().find(|dt| !(dt.is_finite() && **dt > 0.0)) {
                return Err(format!("--dt-ms {dt}: a sampling period must be finite and > 0 ms").into());
            }
            if dt_ms.len() > sim::chart::MAX_PANELS {
                return Err(format!(
                    "--dt-ms: {} sampling periods; a chart has at most {} panels",
                    dt_ms.len(),
                    sim::chart::MAX_PANELS
                )
                .into());
            }
        }
        Cmd::Fit(a) => {
            parse_bounds(&a.from, "--from")?;
            parse_bounds(&a.to, "--to")?;
            let dynamics = crate::fit_command::parse_dynamics(&a.dynamics, a.centers)?;
            if a.auto {
                if let Some(d) = a.dim {
                    if d == 0 || d > ssm::limits::MAX_DIM {
                        return Err(format!("--dim {d}: expected 1..={}", ssm::limits::MAX_DIM).into());
                    }
                }
                if a.budget == 0 {
                    return Err("--budget must be >= 1 setting".into());
                }
                if !matches!(dynamics, ssm::Dynamics::Flow | ssm::Dynamics::Map) {
                    return Err(format!("--auto fits polynomial flows or maps, not --dynamics {}", a.dynamics).into());
                }
            }
            if (a.intervals || a.auto) && !a.no_intervals && a.replicates < 20 {
                return Err(format!("--replicates {}: the bootstrap needs at least 20", a.replicates).into());
            }
            let (dim, embed) = (a.dim.unwrap_or(2), a.embed.unwrap_or(5));
            let opts = ssm::FitOptions {
                dim,
                embed,
                shift: a.shift,
                manifold_order: a.order,
                dyn_order: a.dyn_order,
                dynamics,
                ridge: crate::fit_command::parse_ridge(&a.ridge)?,
                linear_anchor: a.linear_anchor,
                anchor_joint: a.anchor_joint,
            };
            // Ranges and size limits here; the embedding's count against the observables
            // (Takens) where the data are known, after their own errors: checked with the
            // fewest observables the embedding needs (the fit checks again with the data's).
            if !a.auto {
                opts.validate_for((2 * dim.min(ssm::limits::MAX_DIM) + 1).div_ceil(embed.max(1)))?;
            }
            if let Some(r) = &a.frc_range {
                crate::fit_command::parse_freq_range(r)?;
            }
            if let Some(c) = &a.frc_calibrate {
                crate::fit_command::parse_calibration(c)?;
            }
        }
        Cmd::Backbone { observable, .. } => one_based(*observable, "--observable")?,
        Cmd::Frc { freq_range, calibrate, observable, mode, .. } => {
            crate::fit_command::parse_freq_range(freq_range)?;
            crate::fit_command::parse_calibration(calibrate)?;
            one_based(*observable, "--observable")?;
            one_based(*mode, "--mode")?;
        }
        Cmd::Chaos { gp_embed, ssm_dim, centers, poly_order, shift, ridge, .. } => {
            chaos_study::microchaos::ChaosOptions {
                gp_embed: *gp_embed,
                ssm_dim: *ssm_dim,
                centers: *centers,
                poly_order: *poly_order,
                shift: *shift,
                ridge: *ridge,
                ..Default::default()
            }
            .validate()?;
        }
        Cmd::Pil { scene, periods, timeout, .. } => {
            if *periods == 0 {
                return Err("--periods must be >= 1 (a PIL run of 0 periods compares nothing)".into());
            }
            if *periods > sim::scene::MAX_PERIODS {
                return Err(
                    format!("--periods {periods} exceeds the limit of {} periods", sim::scene::MAX_PERIODS).into()
                );
            }
            crate::pil::reply_timeout(*timeout)?;
            bundled(scene)?;
        }
        Cmd::Bench { what: BenchCmd::Simulate { periods, .. } } => {
            bench::problem(*periods)?;
        }
        Cmd::Scenes { .. }
        | Cmd::Cache { .. }
        | Cmd::Reproduce { .. }
        | Cmd::Sweep { .. }
        | Cmd::Study { .. }
        | Cmd::SweepMerge { .. }
        | Cmd::Export { .. }
        | Cmd::Inspect { .. }
        | Cmd::Bench { .. } => {}
    }
    Ok(())
}

/// Candidates `ssmctl chaos` measures by default (`--budget`): the first of the report's
/// search.
pub const DEFAULT_CHAOS_BUDGET: u32 = 12;

/// Where a command writes (output folders and files) and what it reads that must never be
/// overwritten: the one place each command's outputs are declared, for its [`Outputs`]
/// transaction.
///
/// [`Outputs`]: crate::output::Outputs
pub fn output_plan(cmd: &Cmd) -> (Vec<PathBuf>, Vec<(&'static str, PathBuf)>) {
    let scene_file = |s: &SceneArgs| {
        let p = PathBuf::from(&s.scene);
        if p.is_file() { vec![("--scene", p)] } else { Vec::new() }
    };
    match cmd {
        Cmd::Simulate { scene, out } | Cmd::StabilityChart { scene, out, .. } => (vec![out.clone()], scene_file(scene)),
        Cmd::Reproduce { out, .. } => (vec![out.clone()], Vec::new()),
        Cmd::Sweep { spec, out, .. } => (vec![out.clone()], vec![("the sweep spec", spec.clone())]),
        Cmd::Study { spec, out, .. } => (vec![out.clone()], vec![("the study spec", spec.clone())]),
        Cmd::SweepMerge { dir, out } => {
            let mut shards: Vec<(&'static str, PathBuf)> = std::fs::read_dir(dir)
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .map(|p| ("a shard file", p))
                .collect();
            shards.sort();
            (vec![out.clone()], shards)
        }
        Cmd::Fit(a) => {
            let roots = a.save.iter().chain(a.backbone.iter()).chain(a.frc.iter()).cloned().collect();
            let inputs = a
                .data
                .iter()
                .map(|p| ("--data", p.clone()))
                .chain(a.test.iter().map(|p| ("--test", p.clone())))
                .chain(a.mat.iter().map(|p| ("--mat", p.clone())))
                .collect();
            (roots, inputs)
        }
        Cmd::Backbone { model, out, .. } | Cmd::Frc { model, out, .. } => {
            (vec![out.clone()], vec![("--model", model.clone())])
        }
        Cmd::Export { model, out, scene } => {
            let mut inputs = vec![("--model", model.clone())];
            if let Some(s) = scene.as_ref().map(PathBuf::from).filter(|p| p.is_file()) {
                inputs.push(("--scene", s));
            }
            (vec![out.clone()], inputs)
        }
        Cmd::Pil { scene, model, fit_model, out, elf, .. } => {
            let mut roots = vec![out.clone()];
            let mut inputs = scene_file(scene);
            inputs.push(("--elf", elf.clone()));
            // A fitted model is committed by itself before the run reads it (see `Cmd::Pil`).
            if *fit_model {
                roots.push(model.clone());
            } else {
                inputs.push(("--model", model.clone()));
            }
            (roots, inputs)
        }
        Cmd::Scenes { .. }
        | Cmd::Cache { .. }
        | Cmd::Stability { .. }
        | Cmd::SsmEquations { .. }
        | Cmd::Inspect { .. }
        | Cmd::Chaos { .. }
        | Cmd::Bench { .. } => (Vec::new(), Vec::new()),
    }
}

/// The report cache's default folder: `.ssmctl-cache` in the folder that holds `out`.
fn default_cache_dir(out: &std::path::Path) -> Result<PathBuf, String> {
    let abs = std::path::absolute(out).map_err(|e| format!("--out {}: {e}", out.display()))?;
    abs.parent()
        .map(|p| p.join(".ssmctl-cache"))
        .ok_or_else(|| format!("--out {}: no parent folder for the cache; give --cache DIR", out.display()))
}

/// Runs the CLI; the error is printed by `main`. The command's files are staged in one
/// [`Outputs`](crate::output::Outputs) transaction and appear only when it succeeds.
pub fn run(cli: Cli) -> Result<(), Box<dyn std::error::Error>> {
    check_options(&cli)?;
    let (roots, inputs) = output_plan(&cli.cmd);
    let roots: Vec<&std::path::Path> = roots.iter().map(PathBuf::as_path).collect();
    let inputs: Vec<(&str, &std::path::Path)> = inputs.iter().map(|(w, p)| (*w, p.as_path())).collect();
    let tx = crate::output::Outputs::begin(&roots, &inputs);
    for r in &roots {
        // An output folder (or a link to one) is fine; anything else must be writable as a file.
        // Checked first and the folder looked at after a refusal: another shard of the same
        // sweep may create the folder between the two looks.
        if let Err(e) = tx.check(r) {
            if !std::fs::metadata(r).is_ok_and(|m| m.is_dir()) {
                return Err(e.into());
            }
        }
    }
    run_command(cli)?;
    // Lets a test deliver a signal while a finished command's files are staged.
    if let Some(ms) = std::env::var("SSMCTL_HOLD_BEFORE_COMMIT_MS").ok().and_then(|v| v.parse::<u64>().ok()) {
        eprintln!("holding the staged outputs for {ms} ms");
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    tx.commit()?;
    Ok(())
}

fn run_command(cli: Cli) -> Result<(), Box<dyn std::error::Error>> {
    let quiet = cli.quiet;
    match cli.cmd {
        Cmd::Scenes { json } => {
            let mut list = Vec::new();
            for (name, text) in BUNDLED {
                let s = Scene::parse(name, text, &[])?;
                list.push(serde_json::json!({"name": name, "description": s.description, "effects": s.effect_names()}));
                if !json {
                    outln!("{name:<22} {}", s.description);
                }
            }
            if json {
                outln!("{}", serde_json::to_string_pretty(&list)?);
            }
        }
        Cmd::Simulate { scene, out } => {
            let s = scene.load()?;
            if !s.wants(sim::scene::Task::Simulate) {
                return Err(format!(
                    "scene {} asks only for {:?} (run.tasks); it runs no simulation",
                    s.name, s.run.tasks
                )
                .into());
            }
            let pb = spinner(quiet, Some(s.run.periods), &s.name);
            let report = |i: u64| {
                if let Some(pb) = &pb {
                    pb.set_position(i);
                }
            };
            let tr = closed_loop::simulate(&s, Some(&report))?;
            if let Some(pb) = pb {
                pb.finish_and_clear();
            }
            let csv =
                crate::output::write_scene_outputs(&s, &tr, &out).map_err(|e| -> Box<dyn std::error::Error> { e })?;
            eprintln!(
                "{}: {} periods in {:.3} s ({}){}; wrote {}",
                s.name,
                tr.rows() - 1,
                tr.wall_seconds,
                tr.integrator,
                tr.stopped.as_deref().map(|r| format!(", stopped: {r}")).unwrap_or_default(),
                csv.display()
            );
        }
        Cmd::Stability { scene, json } => {
            let s = scene.load()?;
            let m = stability::scene_multipliers(&s)?;
            if json {
                outln!("{}", serde_json::to_string(&serde_json::json!({ "multipliers": m }))?);
            } else {
                outln!("{:>12} {:>12} {:>10} {:>10} {:>12}", "re", "im", "|mu|", "f [Hz]", "rate [1/s]");
                for x in &m {
                    outln!("{:>12.6} {:>12.6} {:>10.6} {:>10.4} {:>12.5}", x.re, x.im, x.abs, x.freq_hz, x.rate);
                }
            }
        }
        Cmd::StabilityChart { scene, out, dt_ms, axes, x_range, y_range } => {
            let s = scene.load()?;
            let named = chart_axes(&s, &axes)?;
            let [(_, xr), (_, yr)] = chart_ranges(&axes, x_range.as_deref(), y_range.as_deref())?;
            let summary = match named {
                None => crate::draw::chart::chart_for_scene(&s, &out, &dt_ms, xr, yr)?,
                Some((xa, ya)) => crate::draw::chart::chart_for_scene_axes(&s, &out, &dt_ms, (&xa, xr), (&ya, yr))?,
            };
            outln!("{}", serde_json::to_string_pretty(&summary)?);
        }
        Cmd::Reproduce { out, quick, data_dir, jobs, cache, no_cache } => {
            if let Some(n) = jobs {
                rayon::ThreadPoolBuilder::new().num_threads(n.into()).build_global()?;
            }
            let cache = if no_cache { None } else { Some(cache.map_or_else(|| default_cache_dir(&out), Ok)?) };
            reproduce::run(&out, &data_dir, quick, quiet, cache.as_deref())?;
            eprintln!("wrote {}", out.join("index.html").display());
        }
        Cmd::Cache { what: CacheCmd::Gc { dir, all } } => {
            if !dir.is_dir() {
                return Err(format!("cache gc: {} is not a folder", dir.display()).into());
            }
            let r = fileio::store::Store::open(&dir)?.gc(all)?;
            outln!(
                "{}: removed {} entries ({:.1} MB){}, kept {}",
                dir.display(),
                r.removed,
                r.removed_bytes as f64 / 1e6,
                if all { "" } else { " not used by the last reproduce" },
                r.kept
            );
        }
        Cmd::Sweep { spec, out, shard, shards, jobs, force } => {
            if let Some(n) = jobs {
                rayon::ThreadPoolBuilder::new().num_threads(n.into()).build_global()?;
            }
            let r = crate::sweep::run(&spec, &out, shard.as_deref(), shards, force)?;
            let what = if r.computed {
                format!("{} cells in {:.3} s on {} threads", r.cells, r.wall_seconds, r.threads)
            } else {
                "already complete, kept".into()
            };
            eprintln!(
                "shard {} ({:?}) of {} cells, spec hash {}: {what}; {}",
                r.shard,
                r.source,
                r.cells_total,
                r.spec_hash,
                r.file.display()
            );
        }
        Cmd::Study { spec, data_dir, out, candidates, jobs, cache, no_cache, shard, shards, merge } => {
            if let Some(n) = jobs {
                rayon::ThreadPoolBuilder::new().num_threads(n.into()).build_global()?;
            }
            let (shard, source) = crate::sweep::pick_shard(shard.as_deref(), shards, &|k| std::env::var(k).ok())?;
            let shard = (source != crate::sweep::ShardSource::Whole).then_some(shard);
            let cache = if no_cache { None } else { Some(cache.map_or_else(|| default_cache_dir(&out), Ok)?) };
            let opts = crate::study::SelectionRun { limit: candidates.map(|n| n as usize), cache, shard, quiet };
            let r = crate::study::study_with(&spec, &data_dir, &out, &opts, merge)?;
            let written = r.files.iter().chain(&r.record_file).map(String::as_str).collect::<Vec<_>>().join(", ");
            eprintln!(
                "study {} on {} data files in {:.1} s: wrote {written} under {}",
                spec.display(),
                r.data.len(),
                r.wall_seconds,
                out.display()
            );
        }
        Cmd::SweepMerge { dir, out } => {
            let m = crate::sweep::merge_dir(&dir, &out)?;
            outln!("{}", serde_json::to_string_pretty(&m)?);
        }
        Cmd::Fit(a) => {
            // `--save` onto an input is refused before the fit by `run` (see `output_plan`).
            let a = *a;
            let frc_observable = a.backbone_observable.clone();
            let r = crate::fit_command::run_fit(&crate::fit_command::FitRequest {
                data: a.data,
                test: a.test,
                mat: a.mat,
                mat_var: a.mat_var,
                test_rows: a.test_rows,
                observables: a.observables,
                from: parse_bounds(&a.from, "--from")?,
                to: parse_bounds(&a.to, "--to")?,
                backbone: a.backbone.map(|out| crate::fit_command::BackboneRequest {
                    out: Some(out),
                    observable: a.backbone_observable,
                    amplitude: a.backbone_amplitude,
                }),
                dim: a.dim.unwrap_or(0),
                embed: a.embed.unwrap_or(0),
                shift: a.shift,
                order: a.order,
                dyn_order: a.dyn_order,
                dynamics: a.dynamics,
                centers: a.centers,
                ridge: a.ridge,
                column: a.column,
                linear_anchor: a.linear_anchor,
                anchor_joint: a.anchor_joint,
                normal_form: a.normal_form,
                auto: a.auto.then_some(crate::fit_command::AutoRequest { budget: a.budget, dim: a.dim }),
                intervals: ((a.intervals || a.auto) && !a.no_intervals)
                    .then_some(crate::fit_command::IntervalRequest { replicates: a.replicates, seed: a.seed }),
            })?;
            if let Some(path) = &a.save {
                crate::output::write_atomic(path, r.model.to_json()?.as_bytes())?;
            }
            if let (Some(dir), Some(range), Some(calibrate)) = (&a.frc, &a.frc_range, &a.frc_calibrate) {
                let (lo, hi, n) = crate::fit_command::parse_freq_range(range)?;
                let cal = crate::fit_command::parse_calibration(calibrate)?;
                let names = &r.summary.observables;
                let index = match &frc_observable {
                    Some(o) => names
                        .iter()
                        .position(|n| n == o)
                        .ok_or_else(|| format!("--backbone-observable {o}: observables are {}", names.join(", ")))?,
                    None => 0,
                };
                let name = names.get(index).cloned().unwrap_or_else(|| (index + 1).to_string());
                let frc = ssm::frc::frc(&r.model, &ssm::frc::FrcOptions::new(index), cal, lo, hi, n)?;
                crate::fit_command::write_frc(dir, &r.model, &frc, &name)?;
                eprintln!("wrote {} and {}", dir.join("frc.json").display(), dir.join("frc.png").display());
            }
            if a.json {
                outln!("{}", serde_json::to_string_pretty(&r.summary)?);
            } else {
                outln!("{}", crate::fit_command::text_summary(&r.summary));
            }
        }
        Cmd::Backbone { model, out, observable, amplitude } => {
            for f in ["backbone.json", "backbone.png"] {
                crate::output::check_not_input(&out.join(f), &[("--model", model.as_path())])?;
            }
            let text = infile::read_text(&model, infile::MAX_MODEL_BYTES)
                .map_err(|e| format!("--model {}: cannot read: {e}", model.display()))?;
            let m = ssm::SsmModel::from_json(&text).map_err(|e| format!("{}: {e}", model.display()))?;
            let index = observable.checked_sub(1).ok_or("--observable is 1-based")?;
            let curves = ssm::backbone::backbone(&m, &ssm::backbone::BackboneOptions::new(index, amplitude))?;
            let name = observable.to_string();
            let json = crate::fit_command::backbone_json(&curves, &name, &[]);
            crate::fit_command::write_backbone(&out, &curves, &json, &name, &[])?;
            eprintln!("wrote {} and {}", out.join("backbone.json").display(), out.join("backbone.png").display());
        }
        Cmd::Frc { model, out, freq_range, calibrate, observable, mode, amplitude_max, json } => {
            crate::output::check_not_input(&out.join("frc.json"), &[("--model", model.as_path())])?;
            let text = infile::read_text(&model, infile::MAX_MODEL_BYTES)
                .map_err(|e| format!("--model {}: cannot read: {e}", model.display()))?;
            let m = ssm::SsmModel::from_json(&text).map_err(|e| format!("{}: {e}", model.display()))?;
            let (lo, hi, n) = crate::fit_command::parse_freq_range(&freq_range)?;
            let cal = crate::fit_command::parse_calibration(&calibrate)?;
            let index = observable.checked_sub(1).ok_or("--observable is 1-based")?;
            let mode = mode.checked_sub(1).ok_or("--mode is 1-based")?;
            let opts = ssm::frc::FrcOptions { mode, amplitude_max, ..ssm::frc::FrcOptions::new(index) };
            let frc = ssm::frc::frc(&m, &opts, cal, lo, hi, n)?;
            let name = observable.to_string();
            crate::fit_command::write_frc(&out, &m, &frc, &name)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&crate::fit_command::frc_json(&frc, &name)?)?);
            } else {
                outln!("{}", crate::fit_command::frc_text(&frc).trim_end());
            }
            eprintln!("wrote {} and {}", out.join("frc.json").display(), out.join("frc.png").display());
        }
        Cmd::Export { model, out, scene } => {
            // `--out` onto `--model` or the scene file is refused by `run` (see `output_plan`).
            let text = infile::read_text(&model, infile::MAX_MODEL_BYTES)
                .map_err(|e| format!("--model {}: cannot read: {e}", model.display()))?;
            let m = ssm::SsmModel::from_json(&text).map_err(|e| format!("{}: {e}", model.display()))?;
            let cfg = match scene {
                Some(s) => {
                    let sc = Scene::load(&s, &[])?;
                    // The device predicts one sample ahead per controller period.
                    ssm::device::check_loop_dt(m.dt, sc.dt())
                        .map_err(|e| format!("{} for scene {}: {e}", model.display(), sc.name))?;
                    sc.controller_config()
                }
                None => shared::ControllerConfig::paper(m.dt),
            };
            controller::validate_config::<{ controller::HISTORY }>(&cfg)?;
            let owned = ssm::device::to_device_model(&m, cfg)?;
            let blob = ssm::device::encode(&owned)?;
            // What is written must be what `inspect` and the device accept: decode it again
            // with the host decoder and validate its configuration before writing.
            crate::fit_command::inspect(&blob)
                .map_err(|e| format!("{}: the exported blob would be refused: {e}", model.display()))?;
            crate::output::write_atomic(&out, &blob)?;
            eprintln!(
                "wrote {} ({} bytes): p={} d={} K={} lift order {}",
                out.display(),
                blob.len(),
                owned.p,
                owned.d,
                owned.k,
                owned.lift_order
            );
        }
        Cmd::Inspect { blob, json } => {
            let bytes = infile::read_bytes(&blob, infile::MAX_BLOB_BYTES)
                .map_err(|e| format!("{}: cannot read: {e}", blob.display()))?;
            let v = crate::fit_command::inspect(&bytes).map_err(|e| format!("{}: {e}", blob.display()))?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                for (k, x) in v.as_object().into_iter().flatten() {
                    outln!("{k:<18} {x}");
                }
            }
        }
        Cmd::Chaos {
            data,
            column,
            gp_embed,
            ssm_dim,
            centers,
            poly_order,
            shift,
            ridge,
            test,
            budget,
            cache,
            json,
        } => {
            let train =
                data.iter().map(|p| ssm::load_csv_column(p, column.as_deref())).collect::<Result<Vec<_>, _>>()?;
            let held_out = test.as_ref().map(|p| ssm::load_csv_column(p, column.as_deref())).transpose()?;
            let o = chaos_study::microchaos::ChaosOptions {
                gp_embed,
                ssm_dim,
                centers,
                poly_order,
                shift,
                ridge,
                ..Default::default()
            };
            let r = chaos_study::microchaos::analyse_held_out(&train, held_out.as_ref(), &o)?;
            let reference = match &held_out {
                Some(t) => t,
                None => train.iter().max_by_key(|s| s.x.len()).ok_or("no training series")?,
            };
            // The model selection: a default selection spec from the arguments, run as
            // `ssmctl study` runs one (the report's search, cut to --budget, at --ssm-dim when
            // given).
            let name = |p: &PathBuf| p.display().to_string();
            let spec = chaos_study::selection_study::SelectionSpec::default_search(
                data.iter().map(name).collect(),
                test.as_ref().map(name),
                column.clone(),
                budget as usize,
                ssm_dim,
            )?;
            let spec = chaos_study::selection_study::SelectionSpec {
                statistics: chaos_study::model_selection::EvalSettings { gp_embed, ..spec.statistics },
                ..spec
            };
            let run = crate::study::SelectionRun { cache, quiet: true, ..Default::default() };
            let (sel_results, _, _) = crate::study::run_selection(&spec, std::path::Path::new(""), &run, &|_| {})?;
            let results: Vec<chaos_study::model_selection::CandidateResult> = sel_results
                .candidates
                .iter()
                .map(chaos_study::selection_study::result_from_json)
                .collect::<Result<_, _>>()?;
            let sel = sel_results.selection.clone();
            if json {
                let mut v = serde_json::to_value(&r)?;
                if let Some(m) = v.as_object_mut() {
                    m.insert("candidates".into(), serde_json::Value::Array(sel_results.candidates.clone()));
                    m.insert("selection".into(), serde_json::to_value(&sel)?);
                    m.insert("held_out".into(), serde_json::Value::Bool(held_out.is_some()));
                }
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.4}"));
                outln!(
                    "correlation dimension {:.3} +- {:.3} -> SSM dimension {}",
                    r.corr_dim,
                    r.corr_dim_err,
                    r.ssm_dim
                );
                outln!(
                    "largest Lyapunov exponent [1/s]: data {:.4}, RBF model {}, polynomial model {}",
                    r.lle_data,
                    opt(r.lle_model_rbf),
                    opt(r.lle_model_poly)
                );
                outln!(
                    "Benettin exponent of the reduced maps [1/s]: RBF {}, polynomial {}",
                    opt(r.lle_model_rbf_benettin),
                    opt(r.lle_model_poly_benettin)
                );
                outln!(
                    "PDF Jensen-Shannon divergence [bits]: RBF {}, polynomial {}",
                    opt(r.pdf_divergence_rbf),
                    opt(r.pdf_divergence_poly)
                );
                outln!(
                    "residual-kicked models: LLE RBF {}, polynomial {}; JS RBF {}, polynomial {}",
                    opt(r.lle_model_rbf_kicked),
                    opt(r.lle_model_poly_kicked),
                    opt(r.pdf_divergence_rbf_kicked),
                    opt(r.pdf_divergence_poly_kicked)
                );
                for n in &r.notes {
                    outln!("note: {n}");
                }
                outln!(
                    "model selection on {} ({}):",
                    reference.name,
                    if held_out.is_some() { "held out" } else { "a training series: nothing held out" }
                );
                for c in &results {
                    outln!("  {}", chaos_study::model_selection::describe(c));
                }
                outln!("picked: {}", sel.name.as_deref().unwrap_or("none"));
                outln!("why: {}", sel.why);
                for w in &sel.warnings {
                    outln!("warning: {w}");
                }
            }
        }
        Cmd::Pil { scene, model, fit_model, periods, out, elf, machine, timeout, json } => {
            // Options were checked first (`check_options`), then anything that runs or writes.
            let reply_timeout = crate::pil::reply_timeout(timeout)?;
            if fit_model {
                crate::output::check_not_input(
                    &model,
                    &[("--scene", std::path::Path::new(&scene.scene)), ("--elf", elf.as_path())],
                )?;
                let blob = crate::pil::fit_model(&scene.load()?)?;
                // Its own transaction (the deepest root wins), committed now: the run reads it.
                let inputs = [("--scene", std::path::Path::new(&scene.scene)), ("--elf", elf.as_path())];
                let tx = crate::output::Outputs::begin(&[model.as_path()], &inputs);
                crate::output::write_atomic(&model, &blob)?;
                tx.commit()?;
                eprintln!("pil: fitted model written to {} ({} bytes)", model.display(), blob.len());
            }
            let opts = crate::pil::PilOptions {
                scene: scene.scene.clone(),
                overrides: scene.set.clone(),
                model,
                periods,
                out,
                elf,
                machine,
                reply_timeout,
            };
            let s = crate::pil::run(&opts)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                outln!(
                    "pil: {} periods, codes identical: {} (to the host-only simulation: {}, max state diff {:.1e}), predictions compared: {} (bit-identical: {}, max rel diff {:.3e}), {} saturated, {:.0} round trips/s on the link, {:.0} periods/s overall{}",
                    s.periods,
                    if s.codes_identical { "yes" } else { "NO" },
                    if s.host_sim_codes_identical { "yes" } else { "NO" },
                    s.host_sim_max_state_diff,
                    s.predictions_compared,
                    if s.predictions_bit_identical { "yes" } else { "no" },
                    s.max_pred_rel_diff,
                    s.saturated_samples,
                    s.round_trips_per_s,
                    s.periods_per_s,
                    s.stopped.as_ref().map_or(String::new(), |r| format!(", stopped: {r}"))
                );
            }
        }
        Cmd::Bench { what: BenchCmd::Fit { json, data_dir, quick } } => {
            let dir = data_dir.join("sloshing");
            let series: Vec<ssm::TimeSeries> =
                (0..3).map(|i| ssm::load_csv(dir.join(format!("decay_{i}.csv")))).collect::<Result<_, _>>()?;
            let (rows, _) = with_spinner(quiet, "bench fit", |p| bench::bench_fit(&series[..2], &series[2], quick, p))?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                outln!(
                    "{:<36} {:>9} {:>10} {:>10} {:>10}  stopped",
                    "setting",
                    "fit ms",
                    "x baseline",
                    "NMTE",
                    "DTW-NMTE"
                );
                for r in &rows {
                    outln!(
                        "{:<36} {:>9.3} {:>10.2} {:>10.4} {:>10.4}  {}",
                        r.setting,
                        r.fit_ms,
                        r.ratio_vs_baseline,
                        r.nmte_test,
                        r.dtw_nmte_test,
                        r.stopped.as_deref().unwrap_or("-")
                    );
                }
            }
        }
        Cmd::SsmEquations { scene, order, json } => {
            let s = scene.load()?;
            let e = crate::equations_command::compute(&s, order)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&crate::equations_command::to_json(&e))?);
            } else {
                outln!("{}", crate::equations_command::to_text(&e));
            }
        }
        Cmd::Bench { what: BenchCmd::Simulate { json, periods, quick } } => {
            let (rows, baseline) = with_spinner(quiet, "bench", |p| bench::bench_simulate(periods, quick, p))?;
            let forms = with_spinner(quiet, "bench", |p| bench::bench_plant_forms(periods, quick, p))?;
            if json {
                outln!(
                    "{}",
                    serde_json::to_string_pretty(&serde_json::json!({ "integrators": rows, "plant_forms": forms }))?
                );
            } else {
                outln!("baseline: {baseline}");
                outln!(
                    "{:<34} {:>14} {:>12} {:>10} {:>12}",
                    "method",
                    "periods/s",
                    "max err rad",
                    "x baseline",
                    "steps/period"
                );
                for r in &rows {
                    outln!(
                        "{:<34} {:>14.0} {:>12.2e} {:>10.2} {:>12.1}",
                        r.method,
                        r.periods_per_s,
                        r.max_err_rad,
                        r.ratio_vs_baseline,
                        r.steps_per_period
                    );
                }
                outln!();
                outln!(
                    "plant forms (the same scene: the built-in Furuta, furuta-equations, and furuta-equations \
                     with its tapes interpreted instead of run as native code); {}",
                    forms.counters
                );
                let load = |l: Option<f64>| l.map_or("-".to_string(), |v| format!("{v:.2}"));
                outln!(
                    "CPU ratios: median of {} interleaved rounds; load average {} before, {} after",
                    forms.rows.first().map_or(0, |r| r.rounds),
                    load(forms.load_average[0]),
                    load(forms.load_average[1])
                );
                outln!(
                    "{:<11} {:<26} {:>12} {:>10} {:>12} {:>10} {:>9} {:>10} {:>6}",
                    "plant",
                    "integrator",
                    "cpu us/per",
                    "x built-in",
                    "max err rad",
                    "rhs/per",
                    "ns/rhs",
                    "instr/rhs",
                    "tape"
                );
                for r in &forms.rows {
                    outln!(
                        "{:<11} {:<26} {:>12.2} {:>10.2} {:>12.2e} {:>10.1} {:>9.1} {:>10} {:>6}",
                        r.plant,
                        r.integrator,
                        1e6 * r.cpu_s_per_period,
                        r.cpu_ratio_vs_builtin,
                        r.max_err_rad,
                        r.rhs_per_period,
                        r.ns_per_rhs,
                        r.instructions_per_rhs.map_or("-".into(), |n| format!("{n:.0}")),
                        r.tape_instructions.map_or("-".into(), |n| n.to_string())
                    );
                }
            }
        }
    }
    Ok(())
}
