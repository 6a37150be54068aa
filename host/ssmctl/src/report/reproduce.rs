//! `ssmctl reproduce`: runs every capability on the bundled scenes and writes the report.
//! Each capability adds its own section; this module orchestrates them and writes the first
//! ones (scenes, stability, chart, accuracy-time-sim), each from its summary values alone.

use crate::bench;
use crate::plot::{self, Series};
use crate::report::cache::{Outcome, SectionCache, Unit};
use crate::report::prose::Prose;
use crate::report::{Report, esc, par_map};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use sim::closed_loop;
use sim::scene::{BUNDLED, Scene, SceneBuilder, Task};
use sim::stability;
use std::error::Error;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Runs the whole report into `out`, on the current rayon pool (`ssmctl reproduce --jobs N`
/// sizes the global one). The sections' wall times, the pool size and the peak resident
/// memory go into a last, timing-only section and `summary.json` key `timings`.
///
/// Each section (the model chain as one) is a cached unit ([`SectionCache`]) in `cache_dir`
/// (`None`: a temporary cache, nothing reused or kept): a unit whose code, options and input
/// files are unchanged is replayed, with the same page, summary keys and files.
///
/// Sweeps inside the sections run on the pool. Besides, two chains of sections that share
/// nothing run concurrently (`rayon::join`), each into its own [`Report::part`], appended in
/// the fixed order: the parametric-model chain (parametric, portraits, fullsystem,
/// predictions, bifsensitivity, then the global-bifurcation sections equation and basin) and the chaos chain (device, chaos, chaos-scale, chaos-verdict). Sections
/// that measure speed (accuracy-time-sim, the fit bench of fit-sloshing, chaos-cost) run
/// alone, so nothing else competes for the cores while they time. The large regressions
/// share a memory budget ([`REGRESSION_MEMORY_MB`]).
pub fn run(
    out: &Path,
    data_dir: &Path,
    quick: bool,
    quiet: bool,
    cache_dir: Option<&Path>,
) -> Result<(), Box<dyn Error>> {
    let t0 = Instant::now();
    fixed_mmap_threshold(MMAP_THRESHOLD_BYTES);
    ssm::ridge::set_memory_budget(REGRESSION_MEMORY_MB << 20);
    let cache = SectionCache::open(cache_dir, quick)?;
    let mut rep = Report::new(out)?;
    crate::output::create_dir(&out.join("fig"))?;
    rep.summary.insert("quick".into(), Value::Bool(quick));
    let mut t = Timings::default();
    let sim_unit =
        |name, timed| Unit { name, crates: &["sim"], files: &["reproduce.rs"], inputs: Vec::new(), reads: &[], timed };
    t.unit(&cache, &mut rep, sim_unit("scenes", false), |rep| scenes_section(rep, quick, quiet))?;
    t.unit(&cache, &mut rep, sim_unit("stability", false), stability_section)?;
    t.unit(&cache, &mut rep, sim_unit("chart", false), |rep| chart_section(rep, quick))?;
    let own = Unit {
        name: "own-plant",
        crates: &["sim", "furuta"],
        files: &["own_plant.rs"],
        inputs: Vec::new(),
        reads: &[],
        timed: false,
    };
    t.unit(&cache, &mut rep, own, |rep| crate::report::own_plant::section(rep, quick))?;
    t.unit(&cache, &mut rep, sim_unit("accuracy-time-sim", true), |rep| bench_section(rep, quick, quiet))?;
    let sloshing = Unit {
        name: "fit-sloshing",
        crates: &["ssm"],
        files: &["sloshing.rs"],
        inputs: vec![("sloshing data", data_dir.join("sloshing"))],
        reads: &[],
        timed: true,
    };
    t.unit(&cache, &mut rep, sloshing, |rep| crate::report::sloshing::sloshing_section(rep, data_dir, quick))?;
    let blob = Unit {
        name: "furuta-blob",
        crates: &["sim", "ssm"],
        files: &["sloshing.rs"],
        inputs: Vec::new(),
        reads: &[],
        timed: false,
    };
    t.unit(&cache, &mut rep, blob, |rep| crate::report::sloshing::furuta_blob(rep, quick))?;
    let pil_record = Path::new(crate::report::chaos::PIL_RECORD_DIR);
    let chaos_inputs = || {
        vec![
            ("PIL recordings", pil_record.to_path_buf()),
            ("flag data", data_dir.join("inverted_flag_chaotic")),
            ("flag study results", chaos_study::study_results::default_dir()),
        ]
    };
    let auto = Unit {
        name: "fit-auto",
        crates: &["furuta"],
        files: &["auto_table.rs"],
        inputs: vec![
            ("sloshing data", data_dir.join("sloshing")),
            ("Duffing data", furuta::auto_sets::duffing_dir()),
            ("auto results", furuta::auto_sets::grid_file().with_file_name("")),
        ],
        reads: &[],
        timed: false,
    };
    t.unit(&cache, &mut rep, auto, |rep| crate::report::auto_table::section(rep, data_dir, quick))?;
    let (model_chain, chaos_chain) = rayon::join(
        || {
            let mut part = rep.part();
            let mut t = Timings::default();
            // The model sections hand their models to each other: one unit.
            let models = Unit {
                name: "models",
                crates: &["furuta"],
                files: &["normal_form.rs", "bifurcations.rs", "global.rs", "tasks.rs"],
                inputs: Vec::new(),
                reads: &[],
                timed: false,
            };
            let r = cache.run(&mut part, models, |rep| {
                let (parametric, runs) = t.time("parametric", || crate::report::normal_form::section(rep, quick))?;
                let bif = t.time("portraits", || crate::report::bifurcations::portraits_section(rep, &parametric))?;
                let switch = t.time("fullsystem", || {
                    crate::report::bifurcations::fullsystem_section(rep, &parametric, &bif, quick)
                })?;
                let shared = t.time("predictions", || crate::report::bifurcations::predictions_section(rep, &runs))?;
                if !quick {
                    t.time("bifsensitivity", || {
                        crate::report::bifurcations::sensitivity_section(rep, &parametric, &bif, switch, &runs)
                    })?;
                }
                t.time("global", || {
                    crate::report::global::global_sections(rep, &parametric, &shared, &runs, &bif, quick)
                })
            });
            if let Ok(Outcome::Reused) = r {
                t.reused.push("models");
            }
            sendable(r.map(|_| ())).map(|()| (part, t))
        },
        || {
            let mut part = rep.part();
            let mut t = Timings::default();
            let r = (|| -> Result<(), Box<dyn Error>> {
                let rep = &mut part;
                let device = Unit {
                    name: "device",
                    crates: &["shared"],
                    files: &["sloshing.rs"],
                    inputs: vec![
                        ("device table", PathBuf::from("qemu/target/device-table.json")),
                        ("PIL summary", PathBuf::from("qemu/target/pil/summary.json")),
                        ("PIL model", PathBuf::from("qemu/target/pil/model.bin")),
                    ],
                    reads: &[],
                    timed: false,
                };
                t.unit(&cache, rep, device, |rep| {
                    crate::report::sloshing::device_section(rep, Path::new("qemu/target/device-table.json"))
                })?;
                let chaos = |name| Unit {
                    name,
                    crates: &["chaos_study"],
                    files: &["chaos.rs"],
                    inputs: chaos_inputs(),
                    reads: &[],
                    timed: false,
                };
                t.unit(&cache, rep, chaos("chaos"), |rep| crate::report::chaos::section(rep, data_dir, quick))?;
                t.unit(&cache, rep, chaos("chaos-scale"), |rep| {
                    crate::report::chaos::scale_section(rep, data_dir, quick)
                })?;
                let verdict = Unit {
                    name: "chaos-verdict",
                    crates: &["chaos_study"],
                    files: &["verdict.rs", "chaos.rs"],
                    inputs: chaos_inputs(),
                    reads: &["chaos"],
                    timed: false,
                };
                t.unit(&cache, rep, verdict, |rep| crate::report::verdict::microchaos_verdict_section(rep, quick))?;
                Ok(())
            })();
            sendable(r).map(|()| (part, t))
        },
    );
    for chain in [model_chain, chaos_chain] {
        let (part, times) = chain.map_err(|e| e as Box<dyn Error>)?;
        rep.append(part)?;
        t.sections.extend(times.sections);
        t.reused.extend(times.reused);
    }
    if !quick {
        let cost = Unit {
            name: "chaos-cost",
            crates: &["chaos_study"],
            files: &["chaos.rs"],
            inputs: chaos_inputs(),
            reads: &[],
            timed: true,
        };
        t.unit(&cache, &mut rep, cost, |rep| crate::report::chaos::cost_section(rep, data_dir))?;
    }
    cache.finish()?;
    timings_section(&mut rep, &t, t0.elapsed().as_secs_f64())?;
    rep.finish("ssmctl reproduce: delayed, sampled, quantized PD control of the Furuta pendulum")?;
    Ok(())
}

/// The working memory (MB) the report's regressions may hold at the same time
/// ([`ssm::ridge::set_memory_budget`]): the largest ones (the chaos study's RBF models, the
/// parametric fits) then take turns instead of adding up on several threads. Only the
/// schedule changes, not a result.
pub const REGRESSION_MEMORY_MB: usize = 320;

/// Allocations from this size (bytes) up get pages of their own from the system, which go
/// back to it when they are freed (see `fixed_mmap_threshold`).
pub const MMAP_THRESHOLD_BYTES: usize = 1 << 20;

/// Gives every allocation of at least `bytes` its own mapping (glibc's `M_MMAP_THRESHOLD`),
/// so freed matrices and series leave the resident memory. glibc otherwise raises that
/// threshold to the size of each large block freed (up to 32 MB), after which blocks of up to
/// that size come from the heaps of its arenas (one per thread), where freed memory stays
/// resident: in the quick report this kept much memory resident that the program no longer
/// held. Only where memory comes from changes, never a result. A no-op off glibc.
fn fixed_mmap_threshold(bytes: usize) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        let bytes = libc::c_int::try_from(bytes).unwrap_or(libc::c_int::MAX);
        // SAFETY: mallopt only sets an allocator parameter; M_MMAP_THRESHOLD takes any
        // non-negative size up to HEAP_MAX/2 and returns 0 (keeping the old value) otherwise.
        let _ = unsafe { libc::mallopt(libc::M_MMAP_THRESHOLD, bytes) };
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        let _ = bytes;
    }
}

/// An error that can cross threads (a task's on the rayon pool).
type SendError = Box<dyn Error + Send + Sync>;

/// A section's result made sendable across threads (the error keeps its message).
fn sendable<T>(r: Result<T, Box<dyn Error>>) -> Result<T, SendError> {
    r.map_err(|e| e.to_string().into())
}

/// Wall time of each section and the process's peak resident memory while it ran, in the
/// order they were recorded.
#[derive(Default)]
struct Timings {
    sections: Vec<(&'static str, f64, Option<f64>)>,
    /// The units replayed from the cache.
    reused: Vec<&'static str>,
}

impl Timings {
    /// Runs `f` and records its wall time and the peak resident memory (MB) while it ran
    /// under `name` (see [`RssWatch`]).
    fn time<T, E>(&mut self, name: &'static str, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        let t0 = Instant::now();
        let watch = RssWatch::start();
        let r = crate::report::tasks::task(name, f);
        self.sections.push((name, t0.elapsed().as_secs_f64(), watch.finish()));
        r
    }

    /// Runs a cached unit ([`SectionCache::run`]) under its name.
    fn unit(
        &mut self,
        cache: &SectionCache,
        rep: &mut Report,
        unit: Unit,
        f: impl FnOnce(&mut Report) -> Result<(), Box<dyn Error>>,
    ) -> Result<(), Box<dyn Error>> {
        let name = unit.name;
        if self.time(name, || cache.run(rep, unit, f))? == Outcome::Reused {
            self.reused.push(name);
        }
        Ok(())
    }
}

/// Interval between two samples of the resident memory (ms) for the per-section peaks.
pub const RSS_SAMPLE_MS: u64 = 10;

/// The peak resident memory of the process while one section runs: one background thread
/// samples `VmRSS` every [`RSS_SAMPLE_MS`] and raises the maximum of every open watch; each
/// watch also samples at its start and end. A section that runs beside another (the two
/// chains of [`run`]) sees the whole process, the other's memory included; peaks shorter than
/// a sample interval can be missed (the process's `VmHWM` in the timings does not).
struct RssWatch {
    /// Peak in kB (0: not measured).
    peak: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

/// The open watches, and whether the sampling thread runs.
static WATCHES: std::sync::Mutex<(Vec<std::sync::Weak<std::sync::atomic::AtomicU64>>, bool)> =
    std::sync::Mutex::new((Vec::new(), false));

impl RssWatch {
    fn start() -> Self {
        use std::sync::atomic::{AtomicU64, Ordering};
        let peak = std::sync::Arc::new(AtomicU64::new(rss_kb().unwrap_or(0)));
        let mut w = WATCHES.lock().unwrap_or_else(|e| e.into_inner());
        w.0.push(std::sync::Arc::downgrade(&peak));
        if !w.1 && rss_kb().is_some() {
            // The sampler stops when no watch is open (and is restarted by the next one).
            let spawned = std::thread::Builder::new().name("rss-sampler".into()).spawn(|| {
                loop {
                    std::thread::sleep(std::time::Duration::from_millis(RSS_SAMPLE_MS));
                    let kb = rss_kb().unwrap_or(0);
                    let mut w = WATCHES.lock().unwrap_or_else(|e| e.into_inner());
                    w.0.retain(|p| p.upgrade().map(|p| p.fetch_max(kb, Ordering::Relaxed)).is_some());
                    if w.0.is_empty() {
                        w.1 = false;
                        return;
                    }
                }
            });
            w.1 = spawned.is_ok();
        }
        RssWatch { peak }
    }

    /// The peak in MB (2^20 bytes); `None` where `VmRSS` cannot be read.
    fn finish(self) -> Option<f64> {
        use std::sync::atomic::Ordering;
        let now = rss_kb()?;
        let kb = self.peak.fetch_max(now, Ordering::Relaxed).max(now);
        Some(kb as f64 / 1024.0)
    }
}

/// The process's current resident set size in kB (`VmRSS` of `/proc/self/status`) on Linux,
/// `None` elsewhere or when it cannot be read.
fn rss_kb() -> Option<u64> {
    status_kb("VmRSS:")
}

/// A `kB` field of `/proc/self/status` (Linux only).
fn status_kb(key: &str) -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        let line = status.lines().find(|l| l.starts_with(key))?;
        line.split_whitespace().nth(1)?.parse().ok()
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = key;
        None
    }
}

/// The process's peak resident set size in MB (2^20 bytes): `VmHWM` of `/proc/self/status`
/// on Linux, `None` elsewhere or when it cannot be read.
pub fn peak_rss_mb() -> Option<f64> {
    status_kb("VmHWM:").map(|kb| kb as f64 / 1024.0)
}

/// The last section: where the time went (table and bar figure), the pool size and the peak
/// memory; `summary.json` key `timings`. Wall-clock only: `cargo xtask compare-report` skips
/// the key, the figure and the section's text.
fn timings_section(rep: &mut Report, t: &Timings, total_seconds: f64) -> Result<(), Box<dyn Error>> {
    let jobs = rayon::current_num_threads();
    let peak = peak_rss_mb();
    rep.timings_section(
        "timings",
        "Where the time goes",
        &format!(
        "Wall time of each section of this run, the size of the thread pool the sweeps ran on (<code>--jobs N</code>, \
         else <code>RAYON_NUM_THREADS</code>, else one thread per core) and the process's peak resident memory \
         (<code>VmHWM</code>). Per section: the largest resident memory of the process while the section ran \
         (<code>VmRSS</code> sampled every {RSS_SAMPLE_MS} ms and at the section's start and end). Sections that run concurrently \
         overlap, so their times can add up to more than the total and a section's peak includes the memory of the \
         sections running beside it; with <code>--jobs 1</code> the two chains run one after the other and each peak is \
         the section's own. \
         These numbers change from run to run; the report's results do not depend on the pool size."
        ),
    );
    rep.para(&format!(
        "Total {total_seconds:.1} s on {jobs} thread{}; peak resident memory {}.",
        if jobs == 1 { "" } else { "s" },
        peak.map_or("not measured (no /proc/self/status)".to_string(), |m| format!("{m:.0} MB")),
    ));
    let rows: Vec<Vec<String>> = t
        .sections
        .iter()
        .map(|(name, s, m)| {
            vec![
                name.to_string(),
                format!("{s:.2}"),
                format!("{:.1} %", 100.0 * s / total_seconds.max(1e-9)),
                m.map_or("-".into(), |m| format!("{m:.0}")),
                if t.reused.contains(name) { "reused from the cache".into() } else { "computed".into() },
            ]
        })
        .collect();
    rep.table(&["section", "wall [s]", "of total", "peak memory while running [MB]", ""], &rows);
    // `cargo xtask reproduce` runs the device table and the processor-in-the-loop steps
    // before this report and names their timings file in SSMCTL_XTASK_STEPS.
    let steps: Vec<Value> = match std::env::var_os("SSMCTL_XTASK_STEPS") {
        Some(path) => {
            let text = infile::read_text(Path::new(&path), infile::MAX_REPORT_INPUT_BYTES)
                .map_err(|e| format!("SSMCTL_XTASK_STEPS {}: cannot read: {e}", path.to_string_lossy()))?;
            let v: Value = serde_json::from_str(&text)
                .map_err(|e| format!("SSMCTL_XTASK_STEPS {}: {e}", path.to_string_lossy()))?;
            v["steps"]
                .as_array()
                .cloned()
                .ok_or_else(|| format!("SSMCTL_XTASK_STEPS {}: no `steps` array", path.to_string_lossy()))?
        }
        None => Vec::new(),
    };
    if !steps.is_empty() {
        rep.para("Before this report, <code>cargo xtask reproduce</code> ran these steps (a reused step matched the stored run's fingerprint of firmware image, host binary, scene, model and periods):");
        let rows: Vec<Vec<String>> = steps
            .iter()
            .map(|st| {
                vec![
                    st["name"].as_str().unwrap_or("?").to_string(),
                    format!("{:.2}", st["seconds"].as_f64().unwrap_or(f64::NAN)),
                    if st["cached"] == Value::Bool(true) { "reused".into() } else { "run".into() },
                ]
            })
            .collect();
        rep.table(&["xtask step", "wall [s]", ""], &rows);
    }
    let cached: Vec<Value> =
        steps.iter().filter(|st| st["cached"] == Value::Bool(true)).map(|st| st["name"].clone()).collect();
    let fig = "fig/timings.png";
    let bars: Vec<(String, f64)> = t.sections.iter().map(|(n, s, _)| (n.to_string(), *s)).collect();
    let height = 80 + 26 * bars.len() as u32;
    plot::bars(
        &rep.dir().join(fig),
        &format!("wall time per section ({jobs} threads)"),
        "wall [s]",
        &bars,
        RGBColor(20, 60, 160),
        (760, height),
    )?;
    rep.figure(fig, "Wall time per section of this run");
    rep.end_timings();
    rep.summary.insert(
        "timings".into(),
        json!({
            "total_seconds": total_seconds,
            "jobs": jobs,
            "cached": cached,
            "xtask_steps": steps,
            "sections": t.sections.iter().map(|(n, s, m)| json!({"name": n, "seconds": s, "peak_rss_mb": m, "reused": t.reused.contains(n)})).collect::<Vec<_>>(),
            "peak_rss_mb": peak,
            "rss_sample_ms": RSS_SAMPLE_MS,
        }),
    );
    Ok(())
}

fn bar(quiet: bool, len: u64, msg: &str) -> Option<ProgressBar> {
    (!quiet).then(|| {
        let pb = ProgressBar::new(len).with_style(
            ProgressStyle::with_template("{msg:<28} [{bar:30}] {pos}/{len}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        pb.set_message(msg.to_string());
        pb
    })
}

const SCENES_INTRO: &str = "Each scene runs the device's own controller code (float path, or the integer path when the \
    scene quantizes) against the plant integrated period by period. Trajectories are in <code>scenes/</code> as CSV with \
    JSON metadata. max |theta| is over the second half of the run.";
/// A scene's row (an item of the summary's `scenes`); the rate is the wall-clock one.
const SCENE_CELLS: [&str; 7] = [
    "{{ name }}",
    "{{ effects | join(\"; \") }}",
    "{{ periods }}",
    "{{ max_abs_theta_late | num }}",
    "{% if stopped is none %}-{% else %}{{ stopped }}{% endif %}",
    "{{ saturated_samples }}",
    "{{ (periods / ([wall_seconds, 1e-9] | max)) | fixed(0) }}",
];
const SCENE_CAPTION: &str = "{{ name }}: theta(t)";

/// The scenes section: each bundled scene simulated (`quick`: fewer periods), its trajectory
/// CSV, metadata and figure written, the summary key `scenes`; the page from the summary.
pub fn scenes_section(rep: &mut Report, quick: bool, quiet: bool) -> Result<(), Box<dyn Error>> {
    let pb = bar(quiet, BUNDLED.len() as u64, "simulating scenes");
    // Each scene (run, CSV outputs, figure) is a task on the rayon pool writing only its own
    // files; the values are collected in the bundled order.
    let dir = rep.dir().to_path_buf();
    let done = par_map(BUNDLED, |(name, _)| -> Result<Option<Value>, SendError> {
        let r = scene_task(&dir, name, quick);
        if let Some(pb) = &pb {
            pb.inc(1);
        }
        r
    })
    .map_err(|e| e as Box<dyn Error>)?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    rep.summary.insert("scenes".into(), Value::Array(done.into_iter().flatten().collect()));
    scenes_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the scenes section from the summary `s` (`scenes`).
pub fn scenes_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section("scenes", "Bundled scenes: closed-loop simulations", &p.html("scenes/intro", SCENES_INTRO, s)?);
    let list = s["scenes"].as_array().ok_or("report: summary lacks the list `scenes`")?;
    rep.table(
        &["scene", "effects", "periods", "max |theta| late [rad]", "stopped", "saturated samples", "periods/s"],
        &p.rows("scenes/row", &SCENE_CELLS, list)?,
    );
    for sc in list {
        let fig = sc["figure"].as_str().ok_or("report: scenes[].figure is not a string")?;
        rep.figure(fig, &p.text("scenes/caption", SCENE_CAPTION, sc)?);
    }
    Ok(())
}

/// One bundled scene of the scenes section: simulates it (300 periods when `quick`), writes
/// its outputs under `dir/scenes` and its figure; `None` for a scene that asks for no
/// simulation.
fn scene_task(dir: &Path, name: &str, quick: bool) -> Result<Option<Value>, SendError> {
    let mut b = SceneBuilder::load(name)?;
    if quick {
        b = b.periods(300);
    }
    let s = b.build()?;
    if !s.wants(Task::Simulate) {
        return Ok(None);
    }
    let tr = closed_loop::simulate(&s, None)?;
    crate::output::write_scene_outputs(&s, &tr, &dir.join("scenes"))?;
    let theta = tr.primary();
    let half = theta.len() / 2;
    let max_late = theta[half..].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let pts: Vec<(f64, f64)> = tr.t.iter().copied().zip(theta.iter().copied()).collect();
    let fig = format!("fig/{name}.png");
    plot::lines(
        &dir.join(&fig),
        &format!("{name}: theta(t)"),
        "t [s]",
        "theta [rad]",
        &[Series { name: "theta", points: &pts, color: RGBColor(20, 60, 160) }],
        (640, 300),
    )?;
    let periods = tr.rows() - 1;
    Ok(Some(json!({
        "name": name, "effects": s.effect_names(), "periods": periods, "max_abs_theta_late": max_late,
        "stopped": tr.stopped, "saturated_samples": tr.saturated_samples, "integrator": tr.integrator,
        "wall_seconds": tr.wall_seconds, "figure": fig,
    })))
}

const STABILITY_INTRO: &str = "Multipliers of the exact zero-order-hold discretization of the linearized loop with \
    delay r (augmented state of the current and delayed samples, matrix exponential). The structural multiplier 1 (a \
    shift of the arm angle) is removed. rate = ln|mu|/dt; the two dominant pairs are the linear coefficients a fitted \
    normal form must reproduce.";
/// A scene's first cells; then [`PAIR_CELLS`] per dominant pair (up to two).
const STABILITY_CELLS: [&str; 3] = [
    "{{ scene }}",
    "{{ dt_ms | plain }}",
    "{% if kp_kd is none %}gains{% else %}{{ kp_kd[0] | plain }} / {{ kp_kd[1] | plain }}{% endif %}",
];
const PAIR_CELLS: [&str; 3] = ["{{ m.abs | fixed(6) }}", "{{ m.freq_hz | fixed(3) }}", "{{ m.rate | signed(4) }}"];

fn stability_section(rep: &mut Report) -> Result<(), Box<dyn Error>> {
    let mut list = Vec::new();
    for (name, _) in BUNDLED {
        let s = Scene::load(name, &[])?;
        if !s.wants(Task::Stability) || s.effects.quantization.is_some() {
            continue;
        }
        let dom = stability::dominant_pairs(&s)?;
        let kp_kd = s.controller.kp.zip(s.controller.kd).map(|(p, d)| [p, d]);
        list.push(json!({"scene": name, "dt_ms": s.controller.dt_ms, "dominant": dom, "kp_kd": kp_kd}));
    }
    rep.summary.insert("stability".into(), Value::Array(list));
    stability_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the stability section from the summary `s` (`stability`).
pub fn stability_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section(
        "stability",
        "Exact linear stability of the sampled-data loop",
        &p.html("stability/intro", STABILITY_INTRO, s)?,
    );
    let list = s["stability"].as_array().ok_or("report: summary lacks the list `stability`")?;
    let mut rows = Vec::new();
    for item in list {
        let mut row = p.rows("stability/row", &STABILITY_CELLS, std::slice::from_ref(item))?.concat();
        let pairs: Vec<Value> = item["dominant"]
            .as_array()
            .ok_or("report: stability[].dominant is not a list")?
            .iter()
            .take(2)
            .map(|m| json!({ "m": m }))
            .collect();
        row.extend(p.rows("stability/pair", &PAIR_CELLS, &pairs)?.concat());
        rows.push(row);
    }
    rep.table(
        &["scene", "dt [ms]", "KP / KD", "|mu1|", "f1 [Hz]", "rate1 [1/s]", "|mu2|", "f2 [Hz]", "rate2 [1/s]"],
        &rows,
    );
    Ok(())
}

/// The scene of the stability chart and its sampling periods (ms).
const CHART_SCENE: &str = "furuta-dt25";
const CHART_DTS_MS: [f64; 3] = [20.0, 25.0, 30.8];

const CHART_INTRO: &str = "Like the paper's figure 2: the region where every non-structural multiplier lies inside \
    the unit circle, for several sampling periods, with the static (real multiplier through +1) and dynamic (complex \
    pair through the unit circle) boundaries. The cross marks the scene's gains ({{ page_chart.gains[0] | num }} V, {{ \
    page_chart.gains[1] | num }} V s).";
const CHART_CAPTION: &str = "Stability chart: stable regions and boundaries for dt = {{ page_chart.dts_ms | nums }} ms";

fn chart_section(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    let s = Scene::load(CHART_SCENE, &[])?;
    let theta = s.measured()?.into_iter().next().ok_or("furuta-dt25 measures no coordinate")?;
    let n = if quick { 61 } else { 201 };
    let fig = "fig/stability_chart.png";
    let summary =
        crate::draw::chart::chart_for_scene(&s, &rep.dir().join(fig), &CHART_DTS_MS, (0.0, 40.0, n), (0.0, 8.0, n))?;
    // The figure's path relative to the report (the section may be computed in a cache folder).
    let mut v = serde_json::to_value(&summary)?;
    v["png"] = json!(fig);
    rep.summary.insert("stability_chart".into(), v);
    rep.summary.insert(
        "page_chart".into(),
        json!({"scene": CHART_SCENE, "gains": [theta.p, theta.d], "dts_ms": CHART_DTS_MS}),
    );
    chart_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the chart section from the summary `s` (`stability_chart`, `page_chart`).
pub fn chart_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section("chart", "Stability chart in the (KP, KD) plane", &p.html("chart/intro", CHART_INTRO, s)?);
    let fig = s["stability_chart"]["png"].as_str().ok_or("report: stability_chart.png is not a string")?;
    rep.figure(fig, &p.text("chart/caption", CHART_CAPTION, s)?);
    Ok(())
}

const BENCH_INTRO: &str = "Sampling periods simulated per second (one core, fastest of repeated runs) against the max \
    theta error versus a tight reference (RODAS4 at rtol {{ page_bench.reference_rtol | e }}), on {{ page_bench.periods \
    }} periods of {{ page_bench.scene }} from theta0 = {{ page_bench.theta0 | plain }} rad. The baseline is classical \
    RK4 at its stable step, measured in the same run. For scale: {{ page_bench.elsewhere }}.";
/// A row of the table (an item of the summary's `bench_simulate`).
const BENCH_CELLS: [&str; 5] = [
    "{{ method }}",
    "{{ periods_per_s | fixed(0) }}",
    "{{ max_err_rad | sci(2) }}",
    "{{ ratio_vs_baseline | fixed(2) }}",
    "{{ steps_per_period | fixed(1) }}",
];
/// Speeds of other programs on the same problem, quoted from MODEL.md (not measured here).
const BENCH_ELSEWHERE: &str = "scipy LSODA reaches about 500 periods/s, a C RK4 5,000-9,000/s (MODEL.md)";

pub fn bench_section(rep: &mut Report, quick: bool, quiet: bool) -> Result<(), Box<dyn Error>> {
    let pb = (!quiet).then(ProgressBar::new_spinner);
    let (rows, baseline) = bench::bench_simulate(bench::PERIODS, quick, |m| {
        if let Some(pb) = &pb {
            pb.set_message(format!("bench: {m}"));
            pb.tick();
        }
    })?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    rep.summary.insert("bench_simulate".into(), serde_json::to_value(&rows)?);
    rep.summary.insert(
        "page_bench".into(),
        json!({"periods": bench::PERIODS, "scene": bench::SCENE, "theta0": bench::THETA0,
               "reference_rtol": bench::REFERENCE_RTOL, "baseline": baseline, "elsewhere": BENCH_ELSEWHERE}),
    );
    bench_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the accuracy-time section from the summary `s` (`bench_simulate`, `page_bench`).
pub fn bench_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    // Plain text escaped here: an HTML template would write the `/` of `periods/s` and of
    // the method labels as entities.
    rep.section(
        "accuracy-time-sim",
        "What accuracy costs in time: simulation",
        &esc(&p.text("accuracy-time-sim/intro", BENCH_INTRO, s)?),
    );
    rep.para(&esc(&p.text("accuracy-time-sim/baseline", "Baseline: {{ page_bench.baseline }}.", s)?));
    let rows = s["bench_simulate"].as_array().ok_or("report: summary lacks the list `bench_simulate`")?;
    rep.table(
        &["method", "periods/s", "max theta error [rad]", "x baseline", "steps/period"],
        &p.rows("accuracy-time-sim/row", &BENCH_CELLS, rows)?,
    );
    Ok(())
}
