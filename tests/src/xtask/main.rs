//! Cross-target automation behind `cargo xtask` (alias in `.cargo/config.toml`).
//!
//! - `install`: the thumbv7em-none-eabihf target and `qemu-system-arm`, if missing.
//! - `qemu-test [--board mps2-an386|stm32f407]`: generate the model blob and expected
//!   outputs, build the firmware in `qemu/` with its own config for the board (default
//!   mps2-an386), run it under QEMU (hard timeout; the STM32F407 image in QEMU's
//!   `netduinoplus2`, an STM32F405), pass/fail by exit code.
//! - `firmware-size`: flash/RAM of the firmware for each board configuration.
//! - `device-table [--json]`: build the firmware's `device_table` binary, run it under QEMU
//!   with `-icount shift=7` and print instructions per call of the controllers and the
//!   predictor (K = 50 ... 1000 centres, each sqrt flavour) with the predictions' relative
//!   error against the host's f64 evaluation; `--json` prints (and writes to
//!   `qemu/target/device-table.json`) the table as JSON.
//! - `pil [--periods N] [--scene NAME]`: processor-in-the-loop. Builds the firmware (its
//!   `pil` binary), fits a 4D RBF model of the scene and runs `ssmctl pil` (plant on the host,
//!   integer controller + predictor on the device over UART0 of mps2-an386); output in
//!   `qemu/target/pil/`. The equation scenes run with the encoders and DAC of
//!   `PIL_EQUATION_SCENES` (they control exactly on their own).
//!   Passes when every period ran, the device's codes equal the host's and its predictions
//!   are bit-identical to the host's f32 predictor, and the whole run (counts, codes,
//!   states) equals the host-only simulation of the scene with the same noise seed.
//! - `pil-equations [--board mps2-an386|stm32f407]`: the PIL runs of the six equation scenes
//!   (one to four measured coordinates) that `test` makes (`pil_equations`); the STM32F407 image runs the models the mps2-an386
//!   runs fitted.
//! - `pil-record --out DIR [--runs N] [--periods P] [--scene NAME] [--seed S] [--fresh]`: records N
//!   PIL runs of a noisy quantized scene (default `furuta-quant-dt25-noise`, 3 runs of
//!   20,000 periods) as data sets `DIR/run{1..N}/theta.csv` (measured angle, format of the
//!   measured data sets) with `record.csv` and `summary.json`; run r uses noise seed
//!   `S + r - 1` and its own initial angle. One model, fitted once, serves all runs
//!   (`DIR/model.bin`); `DIR/runs.json` lists seeds, initial states and times. Run 1 fits
//!   the model, the others then run concurrently (one QEMU each). A run whose folder holds a
//!   complete run with the same fingerprint (firmware image, host binary, scene, overrides,
//!   model, periods: `cache.rs`) is reused and says so; `--fresh` redoes it.
//! - `python-test`: the Python module (`host/python`) built into a venv (`target/pyvenv`,
//!   made and given maturin, pytest and numpy when missing) and its pytest tests (`python.rs`).
//! - `test`: everything, as steps that start as soon as what they need is there (`test_all`):
//!   the installs (rustup, apt, the Python venv), `cargo fmt --check` (workspace, `qemu/`,
//!   `tests/fuzz/`) and the firmware builds (both boards, one after the other in one target
//!   dir, each board's images copied to `qemu/target/images/BOARD/`) run while cargo builds
//!   the host tests; then
//!   `cargo test --workspace` in `target/xtask-build/` with clippy, the API docs and the lab
//!   check inside the host build (the xtask as compiler wrapper, `wrap.rs`), the Python module
//!   and pytest, qemu-test on both
//!   machines side by side, device-table (counted as one on-target test, see
//!   `device_table::check`), a 2,000-period PIL run (one more), a 500-period PIL run of the
//!   STM32F407 image on `netduinoplus2` over USART1 (one more), 300-period PIL runs of the four
//!   plants written as equations on each machine (one more per machine) and `slurm-test`, all with the
//!   host build's test-profile `ssmctl`. Ends with the table of steps and wall times (also
//!   `target/xtask-test-steps.json`) and `on-target: N passed, M failed`.
//! - `reproduce --out DIR [--fresh] [...]`: install + device-table + a PIL run + the PIL
//!   recordings of the chaos study (both reused when unchanged, `--fresh` redoes them), then
//!   `ssmctl reproduce` with the remaining arguments (the report).
//! - `compare-report BASE NEW`: do two report directories of `ssmctl reproduce [--quick]
//!   --out DIR` (e.g. before and after a refactor) hold the same results? `summary.json` and
//!   `scenes/*.json` equal as JSON (numbers to 1e-12 relative, wall-clock timing keys
//!   skipped, paths inside the report equal after their `BASE`/`NEW` prefix), `index.html`
//!   equal with every number masked, every other file (figures, model blobs, scene CSVs)
//!   byte-identical, no file in only one tree. Prints each mismatch (file, JSON path) and
//!   `N numbers compared, M files byte-identical, K mismatches`; fails on any mismatch.
//!   Rules and the timing keys: `compare_report.rs`.
//! - `slurm-test`: a one-node Slurm on localhost (installed from Debian when missing) runs
//!   the bundled sweeps as `sbatch --array` jobs; their merge must equal the local
//!   single-process run bit for bit; the daemons are shut down on every path (`slurm.rs`).
//! - `fuzz [--seconds N] [TARGET ...]`: the libFuzzer targets of `tests/fuzz` (nightly +
//!   cargo-fuzz; says so when missing), N seconds each (`fuzz.rs`).
//! - `host-tests [--test-times]`: the host build and host tests of `test` alone; with
//!   `--test-times` the 20 slowest tests (`host_tests.rs`).
//! - `test-cpu [--top N] [--alone N] [--baseline FILE] [--json FILE] [--save-estimates] PACKAGE[:TEST][=EXE] ...`:
//!   the CPU of test binaries (a package's unit tests, or its integration test TEST), whole
//!   and the N longest tests of that run each alone, as Markdown for `docs/build-time.md`;
//!   `target/xtask-test-cpu.json` (or `--json FILE`); `--save-estimates` merges their wall times into
//!   `tests/host-test-seconds.json`; `=EXE` measures an executable built before (the binary
//!   before a change) as that target's (`test_cpu.rs`).
//! - `build-times [--steps FILE] [--save-estimates] [LABEL=TIMINGS.html ...]`: Markdown tables
//!   of the last `cargo xtask test` (steps, host test binaries) and of cargo `--timings`
//!   reports (unit-seconds by kind, side by side), for `docs/build-time.md`; with
//!   `--save-estimates` the binaries' seconds go to `tests/host-test-seconds.json`, the order
//!   a clean clone starts them in (`host_tests.rs`).

mod cache;
mod child;
mod compare_report;
mod device_table;
mod elf;
mod files;
mod fuzz;
mod host_tests;
mod python;
mod rng;
mod slurm;
mod steps;
mod test_cpu;
mod traces;
mod vectors;
mod wrap;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

const TARGET: &str = "thumbv7em-none-eabihf";
/// QEMU's own runner already has `timeout 120`; this outer limit also covers the build.
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);
const RAM_ORIGIN: u64 = 0x2000_0000;

/// The board an image is built for (the firmware's cargo feature) and the QEMU machine that
/// runs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Board {
    /// QEMU's `mps2-an386` (Cortex-M4F, 4 MiB code + 4 MiB data SSRAM, CMSDK UART): the default.
    Mps2An386,
    /// The STM32F407 image (`--features stm32f407`: flash 0x0800_0000 1 MiB, SRAM 0x2000_0000
    /// 128 KiB, USART1), the one flashed to a real board; QEMU runs it as `netduinoplus2`
    /// (STM32F405: the same flash and SRAM; QEMU maps 192 KiB of SRAM, the image uses 128).
    Stm32f407,
}

impl Board {
    fn parse(name: &str) -> Result<Self> {
        match name {
            "mps2-an386" => Ok(Self::Mps2An386),
            "stm32f407" => Ok(Self::Stm32f407),
            other => Err(format!("unknown board `{other}` (expected mps2-an386 or stm32f407)")),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Mps2An386 => "mps2-an386",
            Self::Stm32f407 => "stm32f407",
        }
    }

    /// QEMU's machine (and CPU) options for this board.
    fn machine(self) -> &'static [&'static str] {
        match self {
            Self::Mps2An386 => &["-cpu", "cortex-m4", "-machine", "mps2-an386"],
            Self::Stm32f407 => &["-machine", "netduinoplus2"],
        }
    }

    /// Flash and RAM capacity of the memory map the image is linked for.
    fn capacity(self) -> (u64, u64) {
        match self {
            Self::Mps2An386 => (4 << 20, 4 << 20),
            Self::Stm32f407 => (1 << 20, 128 << 10),
        }
    }

    /// `ssmctl pil --machine` for this board's PIL firmware.
    fn pil_machine(self) -> &'static str {
        match self {
            Self::Mps2An386 => "mps2-an386",
            Self::Stm32f407 => "netduinoplus2",
        }
    }

    /// Where this board's images are copied after their build: both boards build in
    /// `qemu/target`, whose `release/` names are the same for either feature set.
    fn image_dir(self) -> PathBuf {
        qemu_dir().join("target").join("images").join(self.name())
    }
}

/// The firmware's binaries: the on-target tests, the device table, the PIL loop.
const FIRMWARE_BINARIES: [&str; 3] = ["firmware", "device_table", "pil"];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ has a parent").to_path_buf()
}

fn qemu_dir() -> PathBuf {
    root().join("qemu")
}

type Result<T> = std::result::Result<T, String>;

fn main() -> ExitCode {
    let raw: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if wrap::is_wrapper_call(&raw) {
        return wrap::main(raw);
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("install") => install(),
        Some("qemu-test") => match (args.get(1).map(String::as_str), args.get(2)) {
            (None, _) => qemu_test(Board::Mps2An386).map(|_| ()),
            (Some("--board"), Some(b)) if args.len() == 3 => Board::parse(b).and_then(qemu_test).map(|_| ()),
            _ => Err("qemu-test: expected no option or `--board mps2-an386|stm32f407`".into()),
        },
        Some("firmware-size") => firmware_size(),
        Some("device-table") => match args.get(1).map(String::as_str) {
            None => device_table_cmd(false),
            Some("--json") => device_table_cmd(true),
            Some(other) => Err(format!("device-table: unknown option `{other}` (expected --json)")),
        },
        Some("test") => test_all(),
        Some("python-test") => python::python_test(),
        Some("reproduce") => reproduce(&args[1..]),
        // An explicit `pil` always runs (it is a test of the device); reproduce may reuse.
        Some("pil") => pil_args(&args[1..]).and_then(|(scene, periods)| pil(&scene, periods, true, Host::Test)).map(|_| ()),
        Some("pil-equations") => match (args.get(1).map(String::as_str), args.get(2)) {
            (None, _) => pil_equations(Board::Mps2An386),
            (Some("--board"), Some(b)) if args.len() == 3 => Board::parse(b).and_then(pil_equations),
            _ => Err("pil-equations: expected no option or `--board mps2-an386|stm32f407`".into()),
        },
        Some("pil-record") => record_args(&args[1..]).and_then(|r| pil_record(&r)).map(|_| ()),
        Some("compare-report") => compare_report::run(&args[1..]),
        Some("slurm-test") => slurm::slurm_test(None),
        Some("fuzz") => fuzz::fuzz(&args[1..]),
        Some("host-tests") => host_tests_only(&args[1..]),
        Some("test-cpu") => test_cpu::run(&args[1..], &root(), &root().join("target").join("xtask-test-cpu.json"), &estimates_path()),
        Some("build-times") => {
            host_tests::build_times(&args[1..], &steps_json_path(), &estimates_path(), &WORKSPACE_CRATES).map(|md| print!("{md}"))
        }
        _ => Err("usage: cargo xtask <install | qemu-test [--board mps2-an386|stm32f407] | firmware-size | device-table [--json] | python-test | pil [--periods N] [--scene NAME] | pil-equations [--board mps2-an386|stm32f407] | pil-record --out DIR [--runs N] [--periods P] [--scene NAME] [--seed S] [--fresh] | test | reproduce --out DIR [--fresh] | compare-report BASE NEW | slurm-test | fuzz [--seconds N] [TARGET ...] | host-tests [--test-times] | test-cpu [--top N] [--alone N] [--baseline FILE] [--json FILE] [--save-estimates] PACKAGE[:TEST][=EXE] ... | build-times [--steps FILE] [--save-estimates] [LABEL=TIMINGS.html ...]>".into()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A command without the environment of the outer `cargo run` that would leak into a nested
/// cargo (target dir, rustflags of the host build), tied to the xtask: its process dies with
/// the xtask, whatever kills it (`child.rs`).
fn cmd(program: impl AsRef<std::ffi::OsStr>) -> Command {
    let mut c = Command::new(program);
    child::tie(&mut c);
    for var in ["CARGO_TARGET_DIR", "RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_TARGET", "CARGO_MANIFEST_DIR"]
    {
        c.env_remove(var);
    }
    c
}

/// The target folder of the xtask's test-profile builds of the workspace (the host tests, the
/// PIL and Slurm `ssmctl`, the Python module): its own, because they compile the workspace's
/// crates through the xtask as compiler wrapper ([`host_build_env`]), which cargo hashes into
/// each of their artifacts; in `target/debug` a developer's plain `cargo test` and `cargo
/// xtask test` would compile every workspace crate again after each other.
fn build_dir() -> PathBuf {
    root().join("target").join("xtask-build")
}

/// cargo in the workspace's root, building in [`build_dir`] ([`host_build_env`]).
fn host_cargo() -> Result<Command> {
    let mut c = cmd("cargo");
    c.current_dir(root());
    host_build_env(&mut c)?;
    Ok(c)
}

/// What every cargo (or the Python module's build backend) that builds the workspace in the
/// test profile for the xtask is given: [`build_dir`] as its target folder and the xtask itself
/// as the workspace crates' compiler wrapper (`wrap.rs`), so that the host build (which also
/// asks the wrapper for the lints, the API docs and the lab check: [`wrapper_plan`]), the
/// test listing, the PIL and Slurm `ssmctl` and the Python module share one compile of each
/// crate. A wrapper the environment names is replaced (said once): the checks need this one.
fn host_build_env(c: &mut Command) -> Result<()> {
    let exe = std::env::current_exe().map_err(|e| format!("the xtask's own path, for the compiler wrapper: {e}"))?;
    if let Some(other) = std::env::var_os("RUSTC_WORKSPACE_WRAPPER").filter(|o| o.as_os_str() != exe.as_os_str()) {
        static SAID: std::sync::Once = std::sync::Once::new();
        SAID.call_once(|| {
            eprintln!(
                "xtask: RUSTC_WORKSPACE_WRAPPER={} is replaced by the xtask's own for its builds in {}",
                other.to_string_lossy(),
                build_dir().display()
            )
        });
    }
    c.env("CARGO_TARGET_DIR", build_dir()).env("RUSTC_WORKSPACE_WRAPPER", exe);
    for (key, value) in build_env(std::env::var_os("CI").as_deref(), |k| std::env::var_os(k).is_some()) {
        c.env(key, value);
    }
    Ok(())
}

/// The profile settings of the xtask's builds in [`build_dir`], each unless the environment
/// already says. Always no line tables for the workspace's crates (`debug = false` in the dev
/// and test profiles): nobody reads them there (a panic's message keeps its file:line, which
/// comes from the panic's location, not from debug info; a backtrace keeps the function
/// names), and they cost a sixth of a crate's compile. The dev profile too, so the Python
/// module's `--profile dev` build keeps the test profile's settings and reuses its crates.
/// Outside CI incremental compilation stays on, so a warm re-run after an edit recompiles only
/// what changed. A CI run (`CI` set and not `false` or `0`) builds its target dir once, so
/// incremental compilation's dep-graphs and query caches would never be read: it turns it off,
/// and without it the workspace's crates in 4 codegen units instead of 16 compile in less CPU
/// (fewer copies of inlined generic code; the dependencies keep 16, set in `Cargo.toml`, as
/// for them it saves nothing).
fn build_env(ci: Option<&std::ffi::OsStr>, is_set: impl Fn(&str) -> bool) -> Vec<(&'static str, &'static str)> {
    const ALWAYS: [(&str, &str); 2] = [("CARGO_PROFILE_DEV_DEBUG", "false"), ("CARGO_PROFILE_TEST_DEBUG", "false")];
    const CI: [(&str, &str); 3] = [
        ("CARGO_INCREMENTAL", "0"),
        ("CARGO_PROFILE_DEV_CODEGEN_UNITS", "4"),
        ("CARGO_PROFILE_TEST_CODEGEN_UNITS", "4"),
    ];
    let ci = ci.is_some_and(|v| !v.is_empty() && v != "false" && v != "0");
    let ci_only: &[(&str, &str)] = if ci { &CI } else { &[] };
    ALWAYS.iter().chain(ci_only).copied().filter(|(k, _)| !is_set(k)).collect()
}

fn run(c: &mut Command) -> Result<()> {
    let status = c.status().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    if status.success() { Ok(()) } else { Err(format!("{c:?} failed with {status}")) }
}

fn output(c: &mut Command) -> Option<String> {
    let o = c.output().ok()?;
    o.status.success().then(|| String::from_utf8_lossy(&o.stdout).into_owned())
}

fn install() -> Result<()> {
    rust_target()?;
    if output(cmd("qemu-system-arm").arg("--version")).is_some() {
        println!("install: qemu-system-arm present");
    } else {
        apt(&["update"], None)?;
        apt(&QEMU_APT_INSTALL, None)?;
    }
    Ok(())
}

fn rust_target() -> Result<()> {
    let installed = output(cmd("rustup").args(["target", "list", "--installed"])).unwrap_or_default();
    if installed.lines().any(|l| l.trim() == TARGET) {
        println!("install: target {TARGET} present");
        Ok(())
    } else {
        run(cmd("rustup").args(["target", "add", TARGET]))
    }
}

/// The apt-get arguments that install QEMU's Arm machines, without its recommends (GUI,
/// audio and video codecs, GPU drivers): the emulated Cortex-M boards need none of them.
const QEMU_APT_INSTALL: [&str; 4] = ["install", "-y", "--no-install-recommends", "qemu-system-arm"];

/// `apt-get ARGS` (through sudo unless root), its output into `log` when given.
fn apt(args: &[&str], log: Option<&Path>) -> Result<()> {
    let is_root = output(cmd("id").arg("-u")).is_some_and(|u| u.trim() == "0");
    let mut c = if is_root {
        cmd("apt-get")
    } else {
        let mut c = cmd("sudo");
        c.arg("apt-get");
        c
    };
    c.env("DEBIAN_FRONTEND", "noninteractive").args(args);
    match log {
        Some(log) => steps::run_logged(&mut c, log),
        None => run(&mut c),
    }
}

/// What `cargo xtask test` needs from rustup: the firmware's target, clippy, rustfmt.
fn rust_tools() -> Result<()> {
    rust_target()?;
    for (probe, component) in [("clippy", "clippy"), ("fmt", "rustfmt")] {
        if output(cmd("cargo").args([probe, "--version"])).is_none() {
            run(cmd("rustup").args(["component", "add", component]))?;
        }
    }
    Ok(())
}

/// What `cargo xtask test` needs from apt-get (QEMU; Slurm and munge), with one package
/// index update for both; apt's output goes to `log`.
fn apt_packages(log: &Path) -> Result<()> {
    let qemu = output(cmd("qemu-system-arm").arg("--version")).is_none();
    let slurm = slurm::missing();
    if !qemu && !slurm {
        println!("install: qemu-system-arm, slurm-wlm and munge present");
        return Ok(());
    }
    apt(&["update"], Some(log))?;
    if qemu {
        apt(&QEMU_APT_INSTALL, Some(log))?;
    }
    if slurm {
        apt(&slurm::APT_INSTALL, Some(log))?;
    }
    Ok(())
}

/// `cargo fmt --check` of the workspace and of the two folders with their own workspace
/// (`qemu/`, `tests/fuzz/`); the root `rustfmt.toml` applies to all three.
fn fmt_check(log_dir: &Path) -> Result<()> {
    for (dir, log) in [(root(), "fmt.log"), (qemu_dir(), "fmt-qemu.log"), (root().join("tests/fuzz"), "fmt-fuzz.log")] {
        steps::run_logged(cmd("cargo").current_dir(&dir).args(["fmt", "--all", "--check"]), &log_dir.join(log))
            .map_err(|e| {
                format!("formatting differs from rustfmt in {} (run `cargo fmt --all` there): {e}", dir.display())
            })?;
    }
    println!("fmt: the workspace, qemu/ and tests/fuzz/ are formatted");
    Ok(())
}

/// On-target results parsed from the firmware's `test NAME ... ok|FAILED` lines.
#[derive(Debug, Default)]
struct TargetResult {
    passed: u32,
    failed: u32,
}

/// Writes everything the firmware includes; returns the device table's f64 references.
fn write_target_data() -> Result<Vec<Vec<f64>>> {
    let v = vectors::generate()?;
    let dir = qemu_dir().join("target-data");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    // Only rewrite on change, so cargo does not rebuild the firmware needlessly.
    let write = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = dir.join(name);
        if std::fs::read(&path).ok().as_deref() != Some(bytes) {
            files::write_atomic(&path, bytes)?;
        }
        Ok(())
    };
    write("model.bin", &v.blob)?;
    write("vectors.rs", v.source.as_bytes())?;
    let t = traces::generate()?;
    write("traces.rs", t.source.as_bytes())?;
    println!(
        "qemu-test: model blob {} bytes (p={}, d={}, k={}, lift order {}), {} rolling + {} free-run expected outputs per sqrt flavour",
        v.blob.len(),
        vectors::P,
        vectors::D,
        vectors::K,
        vectors::ORDER,
        v.rolling_len,
        vectors::FREE_RUN
    );
    for (name, clamped, steps) in &t.summary {
        println!("qemu-test: IntPd golden trace {name}: {steps} steps, {clamped} clamped");
    }
    let dt = device_table::generate()?;
    for (k, blob) in &dt.blobs {
        write(&format!("dt_k{k}.bin"), blob)?;
    }
    write("device_table.rs", dt.source.as_bytes())?;
    Ok(dt.reference)
}

/// Builds the firmware's binaries for `board` and copies them to its
/// [`Board::image_dir`]; returns the test binary's path there (the others are beside it).
fn build_firmware(board: Board) -> Result<PathBuf> {
    build_firmware_with(board, None)
}

/// [`build_firmware`]; with `log`, as a step beside the host build: cargo's output into the
/// log, at a lower priority. Both boards share one target dir, so the dependencies compile
/// once and only the firmware crate twice; a lock keeps another thread's build from
/// replacing the images between this build and their copy.
fn build_firmware_with(board: Board, log: Option<&Path>) -> Result<PathBuf> {
    static BUILD: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_build = BUILD.lock().unwrap_or_else(|p| p.into_inner());
    let mut c = cmd("cargo");
    c.current_dir(qemu_dir()).args(["build", "--release"]);
    if board == Board::Stm32f407 {
        c.args(["--features", "stm32f407"]);
    }
    match log {
        Some(log) => {
            steps::lower_priority(&mut c);
            steps::run_logged(&mut c, log)?;
        }
        None => run(&mut c)?,
    }
    let built = qemu_dir().join("target").join(TARGET).join("release");
    let dir = board.image_dir();
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for name in FIRMWARE_BINARIES {
        let from = built.join(name);
        let bytes = std::fs::read(&from).map_err(|e| format!("{}: {e}", from.display()))?;
        let to = dir.join(name);
        // Replaced whole (a QEMU run may be reading the old one), and only when changed.
        if std::fs::read(&to).ok().as_deref() != Some(&bytes[..]) {
            files::write_atomic(&to, &bytes)?;
        }
    }
    Ok(dir.join("firmware"))
}

/// Runs `elf` under QEMU as `board`'s machine with `extra` arguments, output into `log`;
/// `None` on timeout. Returns the exit status and the output.
fn run_qemu(
    elf: &Path,
    board: Board,
    extra: &[&str],
    log: &str,
    timeout: Duration,
) -> Result<(Option<std::process::ExitStatus>, String)> {
    let start = Instant::now();
    let log = qemu_dir().join("target").join(log);
    if let Some(dir) = log.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let log_file = std::fs::File::create(&log).map_err(|e| format!("{}: {e}", log.display()))?;
    let mut child = child::Tied(
        cmd("qemu-system-arm")
            .args(board.machine())
            .arg("-nographic")
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(extra)
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(log_file.try_clone().map_err(|e| e.to_string())?)
            .stderr(log_file)
            .spawn()
            .map_err(|e| format!("cannot start qemu-system-arm (run `cargo xtask install`): {e}"))?,
    );
    // Any return from here kills and reaps QEMU (`Tied`); a timeout does it explicitly.
    let status = loop {
        if let Some(s) = child.0.try_wait().map_err(|e| e.to_string())? {
            break Some(s);
        }
        if start.elapsed() > timeout {
            drop(child);
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ok((status, std::fs::read_to_string(&log).unwrap_or_default()))
}

/// Builds the on-target test suite for `board` and runs it in QEMU's machine for it; the
/// verdict is QEMU's exit code (semihosting exit) and the `test ... ok|FAILED` lines.
fn qemu_test(board: Board) -> Result<TargetResult> {
    write_target_data()?;
    let elf = build_firmware(board)?;
    qemu_suite(board, &elf)
}

/// Runs the built on-target suite `elf` in `board`'s QEMU machine (see [`qemu_test`]).
fn qemu_suite(board: Board, elf: &Path) -> Result<TargetResult> {
    let start = Instant::now();
    let log = match board {
        Board::Mps2An386 => "qemu-test.log".to_string(),
        other => format!("qemu-test-{}.log", other.name()),
    };
    let (status, text) = run_qemu(elf, board, &[], &log, QEMU_TIMEOUT)?;
    print!("{text}");
    let mut r = TargetResult::default();
    for line in text.lines() {
        if line.starts_with("test ") && line.ends_with(" ... ok") {
            r.passed += 1;
        } else if line.starts_with("test ") && line.contains(" ... FAILED") {
            r.failed += 1;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    match status {
        None => Err(format!(
            "QEMU timed out after {}s ({} passed, {} failed so far)",
            QEMU_TIMEOUT.as_secs(),
            r.passed,
            r.failed
        )),
        Some(s) if s.success() && r.failed == 0 && r.passed > 0 => {
            println!("qemu-test: PASS on {} ({} passed, 0 failed, {secs:.1} s in QEMU)", board.name(), r.passed);
            Ok(r)
        }
        Some(s) => {
            Err(format!("qemu-test: FAIL on {} (exit {s}, {} passed, {} failed)", board.name(), r.passed, r.failed))
        }
    }
}

/// Builds and runs the device-table firmware under `-icount shift=7`, returns the table
/// and the binary's flash/RAM.
fn device_table_run() -> Result<(device_table::Table, elf::Sizes)> {
    let reference = write_target_data()?;
    let firmware = build_firmware(Board::Mps2An386)?;
    device_table_measure(&reference, &firmware)
}

/// [`device_table_run`] with the target data's `reference` written and the mps2-an386
/// firmware (`firmware`, the test binary beside `device_table`) built.
fn device_table_measure(reference: &[Vec<f64>], firmware: &Path) -> Result<(device_table::Table, elf::Sizes)> {
    let elf_path = firmware.with_file_name("device_table");
    let start = Instant::now();
    let (status, text) =
        run_qemu(&elf_path, Board::Mps2An386, &["-icount", "shift=7"], "device-table.log", QEMU_TIMEOUT)?;
    match status {
        None => return Err(format!("device-table: QEMU timed out after {}s", QEMU_TIMEOUT.as_secs())),
        Some(s) if !s.success() => return Err(format!("device-table: firmware exited with {s}:\n{text}")),
        Some(_) => {}
    }
    let parsed = device_table::parse(&text)?;
    let table = device_table::table(&parsed, reference)?;
    let bytes = std::fs::read(&elf_path).map_err(|e| format!("{}: {e}", elf_path.display()))?;
    let sizes = elf::sizes(&bytes, RAM_ORIGIN)?;
    eprintln!("device-table: {:.1} s in QEMU", start.elapsed().as_secs_f64());
    Ok((table, sizes))
}

fn device_table_json(t: &device_table::Table, s: &elf::Sizes) -> serde_json::Value {
    let r1 = |x: f64| (x * 10.0).round() / 10.0;
    serde_json::json!({
        "controller_step_instructions_int": r1(t.ctrl_int),
        // The integer step by number of measured coordinates (2: the Furuta's, the row above).
        "controller_step_instructions_int_by_coordinates": { "1": r1(t.ctrl_int_n1), "2": r1(t.ctrl_int), "3": r1(t.ctrl_int_n3), "4": r1(t.ctrl_int_n4) },
        // The same with the configuration opaque to the compiler (as decoded by the PIL firmware).
        "controller_step_instructions_int_runtime_config": { "1": r1(t.ctrl_int_rt[0]), "2": r1(t.ctrl_int_rt[1]), "3": r1(t.ctrl_int_rt[2]), "4": r1(t.ctrl_int_rt[3]) },
        // The bundled Furuta scenes' PD law (no integral action), run-time configuration.
        "controller_step_instructions_int_pd": r1(t.ctrl_int_rt_pd),
        "controller_step_instructions_float": r1(t.ctrl_f32),
        "controller_step_instructions_f64": r1(t.ctrl_f64),
        "predictor": t.predictor.iter().map(|r| serde_json::json!({
            "centers": r.centers,
            "sqrt": r.sqrt,
            "instructions": r1(r.instructions),
            "per_center": (r.per_center * 100.0).round() / 100.0,
            "rel_error": r.rel_error,
        })).collect::<Vec<_>>(),
        // The same kernel (generic scalar, library operation order) as f32 on the FPU and as
        // f64 in software; `vs_f32` = instructions over the f32 row's at the same K.
        "predictor_f32_vs_f64": t.scalar.iter().map(|r| {
            let f32_row = t.scalar.iter().find(|o| o.centers == r.centers && o.scalar == "f32");
            serde_json::json!({
                "centers": r.centers,
                "scalar": r.scalar,
                "instructions": r1(r.instructions),
                "per_center": (r.per_center * 100.0).round() / 100.0,
                "rel_error": r.rel_error,
                "vs_f32": f32_row.map(|o| (r.instructions / o.instructions * 100.0).round() / 100.0),
            })
        }).collect::<Vec<_>>(),
        "predictor_project_instructions": r1(t.project),
        "predictor_lift_instructions": r1(t.lift),
        "predictor_model": { "d": device_table::D, "p": device_table::P, "lift_order": device_table::ORDER, "horizon": device_table::HORIZON },
        "calibration_1000_nops": r1(t.calib_nops1000),
        "flash_bytes": s.flash,
        "ram_bytes": s.ram,
    })
}

fn print_table(t: &device_table::Table, s: &elf::Sizes) {
    println!(
        "device-table: instructions per call (QEMU -icount shift=7, SysTick; 1,000 nops measure {:.1})",
        t.calib_nops1000
    );
    println!("  IntPd step            {:8.1}  (2 coordinates, the Furuta's gains with ki = 0.5)", t.ctrl_int);
    println!("  IntPd step            {:8.1}  (1 coordinate)", t.ctrl_int_n1);
    println!("  IntPd step            {:8.1}  (3 coordinates)", t.ctrl_int_n3);
    println!("  IntPd step            {:8.1}  (4 coordinates)", t.ctrl_int_n4);
    println!(
        "  IntPd step, run-time configuration: {:.1} / {:.1} / {:.1} / {:.1}  (1 / 2 / 3 / 4 coordinates)",
        t.ctrl_int_rt[0], t.ctrl_int_rt[1], t.ctrl_int_rt[2], t.ctrl_int_rt[3]
    );
    println!("  IntPd step            {:8.1}  (PD on 2 coordinates, run-time configuration)", t.ctrl_int_rt_pd);
    println!("  FloatPd<f32> step     {:8.1}", t.ctrl_f32);
    println!("  FloatPd<f64> step     {:8.1}", t.ctrl_f64);
    println!("  predictor project     {:8.1}  (p = {}, d = {})", t.project, device_table::P, device_table::D);
    println!("  predictor lift        {:8.1}  (lift order {})", t.lift, device_table::ORDER);
    println!(
        "  predictor step (d = {}):   K  sqrt       instructions  per centre  rel_error (predict({}))",
        device_table::D,
        device_table::HORIZON
    );
    for r in &t.predictor {
        println!(
            "  {:>28} {:<10} {:>12.1} {:>11.2}  {:.2e}",
            r.centers, r.sqrt, r.instructions, r.per_center, r.rel_error
        );
    }
    println!(
        "  RBF step, generic kernel (d = {}, vsqrt.f32 / libm::sqrt): K  scalar  instructions  per centre  rel_error (predict({}))",
        device_table::D,
        device_table::HORIZON
    );
    for r in &t.scalar {
        println!(
            "  {:>45} {:<7} {:>12.1} {:>11.2}  {:.2e}",
            r.centers, r.scalar, r.instructions, r.per_center, r.rel_error
        );
    }
    println!("  device_table binary: flash {} B, static RAM {} B", s.flash, s.ram);
}

fn device_table_cmd(json: bool) -> Result<()> {
    let (t, s) = device_table_run()?;
    // Always leave the JSON where `ssmctl reproduce` reads it.
    let mut v = device_table_json(&t, &s);
    v["firmware_sizes"] = serde_json::Value::Array(firmware_sizes()?);
    let text = serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?;
    let path = qemu_dir().join("target").join("device-table.json");
    files::write_atomic(&path, text.as_bytes())?;
    if json {
        println!("{text}");
    } else {
        print_table(&t, &s);
    }
    Ok(())
}

/// The README's main job: the on-device table under QEMU, then `ssmctl reproduce` with the
/// remaining arguments (e.g. `--out out/report`).
fn reproduce(rest: &[String]) -> Result<()> {
    // `--fresh` redoes the processor-in-the-loop runs even when stored ones match; the other
    // arguments go to `ssmctl reproduce`.
    let fresh = rest.iter().any(|a| a == "--fresh");
    let rest: Vec<&String> = rest.iter().filter(|a| *a != "--fresh").collect();
    install()?;
    // The release `ssmctl` writes the report; the PIL steps run it too, so the workspace is
    // built once.
    let host = ssmctl_bin(Host::Release)?;
    let mut steps = Vec::new();
    let t = Instant::now();
    device_table_cmd(false)?;
    steps.push(serde_json::json!({"name": "device table (build + QEMU)", "seconds": t.elapsed().as_secs_f64(), "cached": false}));
    // A processor-in-the-loop run; its summary.json goes into the report.
    let t = Instant::now();
    let v = pil("furuta-quant-dt25", 2000, fresh, Host::Release)?;
    steps.push(serde_json::json!({"name": "PIL run (2,000 periods)", "seconds": t.elapsed().as_secs_f64(), "cached": v["cached"]}));
    // The chaos study's "experiment": three noisy PIL recordings (train on two, test on one).
    let t = Instant::now();
    let recorded = pil_record(&RecordArgs {
        out: qemu_dir().join("target").join("pil-record"),
        runs: 3,
        periods: 20_000,
        scene: PIL_SCENE.into(),
        seed: 1,
        fresh,
        host: Host::Release,
    })?;
    steps.push(serde_json::json!({"name": "PIL recordings (3 x 20,000 periods)", "seconds": t.elapsed().as_secs_f64(), "cached": recorded}));
    // Where the xtask's own time went, for the report's timings.
    let path = qemu_dir().join("target").join("xtask-steps.json");
    let text = serde_json::to_string_pretty(&serde_json::json!({ "steps": steps })).map_err(|e| e.to_string())?;
    files::write_atomic(&path, text.as_bytes())?;
    let mut c = cmd(host.to_str().ok_or("host binary path is not UTF-8")?);
    c.current_dir(root()).arg("reproduce").args(rest);
    c.env("SSMCTL_XTASK_STEPS", &path);
    run(&mut c)
}

/// The PIL scene of `cargo xtask test` / `pil`: quantized, with seeded sensor noise, so the
/// run checks noise and encoder counts against the host-only simulation too.
const PIL_SCENE: &str = "furuta-quant-dt25-noise";
/// Periods of the PIL run inside `cargo xtask test`.
const PIL_TEST_PERIODS: u64 = 2000;

fn pil_args(rest: &[String]) -> Result<(String, u64)> {
    let mut scene = PIL_SCENE.to_string();
    let mut periods = PIL_TEST_PERIODS;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("pil: {name} needs a value"));
        match a.as_str() {
            "--periods" => {
                let v = value("--periods")?;
                periods = v.parse().map_err(|e| format!("pil: --periods `{v}`: {e}"))?;
                if periods == 0 {
                    return Err("pil: --periods must be at least 1".into());
                }
            }
            "--scene" => scene = value("--scene")?,
            other => return Err(format!("pil: unknown option `{other}` (expected --periods N, --scene NAME)")),
        }
    }
    Ok((scene, periods))
}

/// The PIL firmware for `board`, built (and the target data it includes written) if needed.
fn pil_firmware(board: Board) -> Result<PathBuf> {
    if !qemu_dir().join("target-data/model.bin").exists() {
        write_target_data()?;
    }
    Ok(build_firmware(board)?.with_file_name("pil"))
}

/// Which build of the host's `ssmctl` a command runs.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Host {
    /// The test profile's, as the host tests built it (`cargo xtask test` and the PIL commands).
    Test,
    /// The release build, which `reproduce` runs for the report and so for its PIL steps too.
    Release,
}

/// The host's `ssmctl`, built if needed, once per xtask process; PIL runs call the binary
/// directly so several can run at once. In the test profile (which optimizes the host crates)
/// with `--workspace`, which resolves features as `cargo test --workspace` does
/// (dev-dependencies change no feature of the build graph: `tests/tests/build_sharing.rs`), so
/// after the host tests' build this is that build's binary and nothing is compiled again;
/// [`Host::Release`] is the release binary.
fn ssmctl_bin(host: Host) -> Result<PathBuf> {
    static BIN: [std::sync::OnceLock<PathBuf>; 2] = [const { std::sync::OnceLock::new() }; 2];
    let (slot, dir, build): (_, _, &[&str]) = match host {
        Host::Test => (&BIN[0], "debug", &["--profile", "test", "--workspace", "--exclude", "lab"]),
        Host::Release => (&BIN[1], "release", &["--release", "-p", "ssmctl"]),
    };
    if let Some(p) = slot.get() {
        return Ok(p.clone());
    }
    let (mut c, target) = match host {
        Host::Test => (host_cargo()?, build_dir()),
        Host::Release => {
            let mut c = cmd("cargo");
            c.current_dir(root());
            (c, root().join("target"))
        }
    };
    run(c.args(["build", "-q"]).args(build).args(["--bin", "ssmctl"]))?;
    Ok(slot.get_or_init(|| target.join(dir).join("ssmctl")).clone())
}

/// The two programs of a PIL run, built, and the fingerprint of their images (read and
/// hashed once per command, not once per run).
struct PilTools {
    elf: PathBuf,
    host: PathBuf,
    /// The board the firmware is built for (its QEMU machine runs it).
    board: Board,
    fingerprint: String,
}

fn pil_tools(board: Board, host: Host) -> Result<PilTools> {
    let (elf, host) = (pil_firmware(board)?, ssmctl_bin(host)?);
    let read = |p: &Path| std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()));
    let fingerprint = cache::key(&[&read(&elf)?, &read(&host)?, board.name().as_bytes()]);
    Ok(PilTools { elf, host, board, fingerprint })
}

/// What one `ssmctl pil` run is: scene, overrides, model (fitted by this run when `fit`),
/// periods, output folder.
struct PilRun<'a> {
    scene: &'a str,
    set: Vec<String>,
    model: PathBuf,
    fit: bool,
    periods: u64,
    out: PathBuf,
}

/// One `ssmctl pil` run with `tools`; returns the checked summary and whether it was reused. A run is reused when its output folder holds a complete run with the
/// same fingerprint of firmware image, host binary, scene, overrides, model and periods
/// (`fresh`: never reused).
fn ssmctl_pil(tools: &PilTools, r: &PilRun<'_>, fresh: bool) -> Result<(serde_json::Value, bool)> {
    let (elf, host) = (tools.elf.as_path(), tools.host.as_path());
    let model_bytes =
        if r.fit { Vec::new() } else { std::fs::read(&r.model).map_err(|e| format!("{}: {e}", r.model.display()))? };
    let periods_arg = r.periods.to_string();
    let set = r.set.join("\n");
    let key = cache::key(&[
        tools.fingerprint.as_bytes(),
        r.scene.as_bytes(),
        set.as_bytes(),
        periods_arg.as_bytes(),
        &[u8::from(r.fit)],
        &model_bytes,
    ]);
    let summary = |out: &Path| -> Result<serde_json::Value> {
        let path = out.join("summary.json");
        let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        pil_check(&v, r.periods)?;
        theta_csv_check(&out.join("theta.csv"), r.periods)?;
        Ok(v)
    };
    if !fresh
        && cache::hit(&r.out, &key)
        && r.model.is_file()
        && let Ok(v) = summary(&r.out)
    {
        return Ok((v, true));
    }
    cache::forget(&r.out);
    std::fs::create_dir_all(&r.out).map_err(|e| format!("{}: {e}", r.out.display()))?;
    let mut c = cmd(host.to_str().ok_or("host binary path is not UTF-8")?);
    c.current_dir(root()).args(["pil", "--scene", r.scene]);
    for o in &r.set {
        c.arg("--set").arg(o);
    }
    c.arg("--model").arg(&r.model);
    if r.fit {
        c.arg("--fit-model");
    }
    c.args(["--periods", &periods_arg]).arg("--out").arg(&r.out).arg("--elf").arg(elf);
    c.args(["--machine", tools.board.pil_machine()]);
    // Beside the test binaries on a loaded two-core machine the emulator can wait seconds for
    // the CPU: a longer wait per reply than the interactive default, a hung device still fails.
    c.args(["--timeout", PIL_REPLY_TIMEOUT_S]);
    run(&mut c)?;
    let v = summary(&r.out)?;
    cache::store(&r.out, &key)?;
    Ok((v, false))
}

/// Seconds the xtask's PIL runs wait for each reply of the device (`ssmctl pil --timeout`).
const PIL_REPLY_TIMEOUT_S: &str = "60";

/// The bundled plants written as equations, with the encoders, DAC and saturation a device
/// needs (`--set` overrides: the scenes themselves control exactly). Resolutions: pi/2000 rad
/// (a 4,000-count encoder) on the cart-pole's and the pendulum's angles, the paper's pi/1000
/// on the Furuta's, 0.1 mm on the cart, 1 um on the Duffing masses; the double pendulum's
/// stiffer D gains read 16-bit encoders (2 pi/65536 rad) and 10 um on its cart, since one
/// count of a coarser encoder over 5 ms is a large force. DAC steps and ranges of the order
/// of each loop's inputs.
const PIL_EQUATION_SCENES: [(&str, &[&str]); 6] = [
    (
        "cartpole-pd",
        &[
            "effects.quantization.h_adc=1.5707963267948966e-3",
            "controller.gains.x.h_adc=1e-4",
            "effects.quantization.h_dac=0.01",
            "effects.saturation.u_max=20.0",
        ],
    ),
    (
        "pendulum-pd",
        &[
            "effects.quantization.h_adc=1.5707963267948966e-3",
            "effects.quantization.h_dac=1e-3",
            "effects.saturation.u_max=2.0",
        ],
    ),
    (
        "duffing-chain",
        &["effects.quantization.h_adc=1e-6", "effects.quantization.h_dac=1e-3", "effects.saturation.u_max=5.0"],
    ),
    (
        "furuta-equations",
        &[
            "effects.quantization.h_adc=3.141592653589793e-3",
            "effects.quantization.h_dac=4.8828125e-3",
            "effects.saturation.u_max=10.0",
        ],
    ),
    (
        "double-pendulum-cart",
        &[
            "effects.quantization.h_adc=9.587379924285257e-5",
            "controller.gains.x.h_adc=1e-5",
            "effects.quantization.h_dac=0.01",
            "effects.saturation.u_max=20.0",
        ],
    ),
    (
        "duffing-chain4",
        &["effects.quantization.h_adc=1e-6", "effects.quantization.h_dac=1e-3", "effects.saturation.u_max=5.0"],
    ),
];

/// Periods of each equation scene's PIL run inside `cargo xtask test` (a few seconds each).
const PIL_EQUATION_PERIODS: u64 = 300;

/// The `--set` overrides a PIL run of `scene` needs: counts quantization and the settings of
/// [`PIL_EQUATION_SCENES`] for the equation scenes, none for the others (quantized already).
fn pil_overrides(scene: &str) -> Vec<String> {
    PIL_EQUATION_SCENES.iter().find(|(name, _)| *name == scene).map_or_else(Vec::new, |(_, set)| {
        std::iter::once("effects.quantization.mode=counts").chain(set.iter().copied()).map(String::from).collect()
    })
}

/// PIL runs of every equation scene ([`PIL_EQUATION_SCENES`], [`PIL_EQUATION_PERIODS`]) on
/// `board`'s machine: on mps2-an386 each fits its model (`qemu/target/pil-equations/SCENE/`),
/// the STM32F407 image on netduinoplus2 runs those models (`qemu/target/pil-equations-stm32f407/`).
/// Each run passes the checks of [`pil`]: codes and predictions identical to the host's, and
/// the whole loop equal to the host-only simulation.
fn pil_equations(board: Board) -> Result<()> {
    let tools = pil_tools(board, Host::Test)?;
    let fitted = qemu_dir().join("target").join("pil-equations");
    let base = match board {
        Board::Mps2An386 => fitted.clone(),
        other => qemu_dir().join("target").join(format!("pil-equations-{}", other.name())),
    };
    for (scene, _) in PIL_EQUATION_SCENES {
        let out = base.join(scene);
        let run = PilRun {
            scene,
            set: pil_overrides(scene),
            model: fitted.join(scene).join("model.bin"),
            fit: board == Board::Mps2An386,
            periods: PIL_EQUATION_PERIODS,
            out: out.clone(),
        };
        let (v, _) = ssmctl_pil(&tools, &run, true).map_err(|e| format!("{scene} on {}: {e}", board.pil_machine()))?;
        println!(
            "pil: PASS on {} ({PIL_EQUATION_PERIODS} periods of {scene}, measured coordinates: {}; codes identical to the host's controller and to the host-only simulation, {} predictions bit-identical; {})",
            board.pil_machine(),
            v["measured_coordinates"],
            v["predictions_compared"],
            out.display()
        );
    }
    Ok(())
}

/// Builds the PIL firmware, fits a model and runs `ssmctl pil`; checks the summary.
fn pil(scene: &str, periods: u64, fresh: bool, host: Host) -> Result<serde_json::Value> {
    let tools = pil_tools(Board::Mps2An386, host)?;
    let out = qemu_dir().join("target").join("pil");
    let run =
        PilRun { scene, set: pil_overrides(scene), model: out.join("model.bin"), fit: true, periods, out: out.clone() };
    let (mut v, cached) = ssmctl_pil(&tools, &run, fresh)?;
    v["cached"] = serde_json::Value::Bool(cached);
    println!(
        "pil: PASS ({periods} periods of {scene}, codes identical to the host's controller and to the host-only simulation, predictions bit-identical; {}{})",
        out.display(),
        if cached { "; reused: same firmware, host, scene and periods as the stored run" } else { "" }
    );
    Ok(v)
}

/// Periods of the STM32 image's PIL run inside `cargo xtask test` (over USART1).
const PIL_STM32_PERIODS: u64 = 500;

/// The STM32F407 image's PIL binary in QEMU's netduinoplus2 (USART1 instead of the CMSDK
/// UART), with the model the mps2-an386 run `pil` fitted (`qemu/target/pil/model.bin`);
/// the same checks as `pil`. Output in `qemu/target/pil-stm32f407/`.
fn pil_stm32(scene: &str, periods: u64) -> Result<serde_json::Value> {
    let tools = pil_tools(Board::Stm32f407, Host::Test)?;
    let out = qemu_dir().join("target").join("pil-stm32f407");
    let model = qemu_dir().join("target").join("pil").join("model.bin");
    let run = PilRun { scene, set: Vec::new(), model, fit: false, periods, out: out.clone() };
    let (v, _) = ssmctl_pil(&tools, &run, true)?;
    println!(
        "pil: PASS on netduinoplus2 (the STM32F407 image over USART1: {periods} periods of {scene}, codes and predictions identical to the host's; {})",
        out.display()
    );
    Ok(v)
}

/// `theta.csv` has the header and one row per period, each `t,x` with finite numbers.
fn theta_csv_check(path: &Path, periods: u64) -> Result<()> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    if lines.next() != Some("t_s,theta_meas_rad") {
        return Err(format!("{}: header is not `t_s,theta_meas_rad`", path.display()));
    }
    let mut n = 0u64;
    for (i, l) in lines.enumerate() {
        let ok = l.split_once(',').is_some_and(|(a, b)| {
            a.parse::<f64>().is_ok_and(f64::is_finite) && b.parse::<f64>().is_ok_and(f64::is_finite)
        });
        if !ok {
            return Err(format!("{}: line {} is not `t,x` with finite numbers: {l:?}", path.display(), i + 2));
        }
        n += 1;
    }
    if n != periods {
        return Err(format!("{}: {n} rows, expected {periods}", path.display()));
    }
    Ok(())
}

/// Options of `cargo xtask pil-record`.
#[derive(Debug, Clone, PartialEq)]
struct RecordArgs {
    out: PathBuf,
    runs: u32,
    periods: u64,
    scene: String,
    seed: u64,
    /// Redo runs even when their stored output has the same fingerprint.
    fresh: bool,
    /// The `ssmctl` build that runs the host side.
    host: Host,
}

fn record_args(rest: &[String]) -> Result<RecordArgs> {
    let mut r = RecordArgs {
        out: PathBuf::new(),
        runs: 3,
        periods: 20_000,
        scene: PIL_SCENE.to_string(),
        seed: 1,
        fresh: false,
        host: Host::Test,
    };
    let mut out = None;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("pil-record: {name} needs a value"));
        let int = |name: &str, v: String| v.parse::<u64>().map_err(|e| format!("pil-record: {name} `{v}`: {e}"));
        match a.as_str() {
            "--out" => out = Some(PathBuf::from(value("--out")?)),
            "--runs" => {
                let v = int("--runs", value("--runs")?)?;
                r.runs = u32::try_from(v)
                    .ok()
                    .filter(|&n| (1..=100).contains(&n))
                    .ok_or(format!("pil-record: --runs {v}: between 1 and 100"))?;
            }
            "--periods" => {
                r.periods = int("--periods", value("--periods")?)?;
                if r.periods < 2 {
                    return Err("pil-record: --periods must be at least 2 (a data set needs two samples)".into());
                }
            }
            "--scene" => r.scene = value("--scene")?,
            "--seed" => r.seed = int("--seed", value("--seed")?)?,
            "--fresh" => r.fresh = true,
            other => {
                return Err(format!(
                    "pil-record: unknown option `{other}` (expected --out DIR, --runs N, --periods P, --scene NAME, --seed S, --fresh)"
                ));
            }
        }
    }
    r.out = out.ok_or("pil-record: --out DIR is required")?;
    Ok(r)
}

/// Initial primary angle of recorded run `r` (1-based): 0.01, -0.015, 0.02, -0.025 rad,
/// repeating; all inside the quantized loop's bounded oscillation.
fn record_theta0(r: u32) -> f64 {
    let i = r.saturating_sub(1);
    let sign = if i.is_multiple_of(2) { 1.0 } else { -1.0 };
    sign * (0.01 + 0.005 * f64::from(i % 4))
}

/// Records the runs: run 1 fits the model (its scene and overrides define it), then the
/// others run concurrently, one QEMU each (each `ssmctl pil` binds its own port). Runs whose
/// fingerprint matches the stored output are reused (`a.fresh`: never).
fn pil_record(a: &RecordArgs) -> Result<bool> {
    let tools = pil_tools(Board::Mps2An386, a.host)?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let model = a.out.join("model.bin");
    let start = Instant::now();
    let mut specs = Vec::new();
    for r in 1..=a.runs {
        let seed = a.seed.checked_add(u64::from(r - 1)).ok_or("pil-record: seed overflows")?;
        let theta0 = record_theta0(r);
        let set = vec![format!("effects.noise.seed={seed}"), format!("initial.state=[{theta0},0.0,0.0,0.0]")];
        let run = PilRun {
            scene: &a.scene,
            set,
            model: model.clone(),
            fit: r == 1,
            periods: a.periods,
            out: a.out.join(format!("run{r}")),
        };
        specs.push((r, seed, theta0, run));
    }
    let one = |(r, seed, theta0, run): &(u32, u64, f64, PilRun<'_>)| -> Result<serde_json::Value> {
        let t0 = Instant::now();
        let (v, cached) = ssmctl_pil(&tools, run, a.fresh)?;
        let secs = t0.elapsed().as_secs_f64();
        println!(
            "pil-record: run {r}/{}: seed {seed}, theta0 {theta0} rad, {} periods {}, identical to the host-only simulation; {}",
            a.runs,
            a.periods,
            if cached {
                "reused (same fingerprint)".to_string()
            } else {
                format!("in {secs:.1} s ({:.0} periods/s)", v["periods_per_s"].as_f64().unwrap_or(0.0))
            },
            run.out.join("theta.csv").display()
        );
        Ok(serde_json::json!({
            "run": r, "seed": seed, "initial_state": [theta0, 0.0, 0.0, 0.0], "periods": a.periods,
            "theta_csv": format!("run{r}/theta.csv"), "wall_seconds": secs, "cached": cached, "summary": v,
        }))
    };
    let mut runs = vec![one(&specs[0])?];
    let rest: Vec<Result<serde_json::Value>> = std::thread::scope(|s| {
        specs[1..]
            .iter()
            .map(|spec| s.spawn(|| one(spec)))
            .collect::<Vec<_>>()
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err("pil-record: a run's thread panicked".into())))
            .collect()
    });
    for r in rest {
        runs.push(r?);
    }
    let total = start.elapsed().as_secs_f64();
    let path = a.out.join("runs.json");
    let reused = runs.iter().all(|r| r["cached"] == serde_json::Value::Bool(true));
    // Reused recordings keep the index written when they were made: rewriting it with this
    // call's wall times would change the bytes the report's cache keys on.
    if reused && path.is_file() {
        println!("pil-record: {} runs x {} periods reused; {} kept", a.runs, a.periods, path.display());
        return Ok(true);
    }
    let index =
        serde_json::json!({ "scene": a.scene, "model": "model.bin", "runs": runs, "total_wall_seconds": total });
    let text = serde_json::to_string_pretty(&index).map_err(|e| e.to_string())?;
    files::write_atomic(&path, text.as_bytes())?;
    println!("pil-record: {} runs x {} periods in {total:.1} s; {}", a.runs, a.periods, path.display());
    Ok(runs.iter().all(|r| r["cached"] == serde_json::Value::Bool(true)))
}

/// The run passes when every period ran, codes agree and predictions are bit-identical.
fn pil_check(v: &serde_json::Value, periods: u64) -> Result<()> {
    let ran = v["periods"].as_u64().ok_or("pil summary: no `periods`")?;
    if ran != periods {
        return Err(format!("pil: {ran} of {periods} periods ran (stopped: {})", v["stopped"]));
    }
    if v["codes_identical"] != serde_json::Value::Bool(true) {
        return Err(format!("pil: device and host codes differ, first at period {}", v["first_code_mismatch"]));
    }
    if v["predictions_bit_identical"] != serde_json::Value::Bool(true) || v["max_pred_rel_diff"].as_f64() != Some(0.0) {
        return Err(format!("pil: predictions differ (max relative difference {})", v["max_pred_rel_diff"]));
    }
    if v["predictions_compared"].as_u64().unwrap_or(0) == 0 {
        return Err("pil: no prediction was compared (window never filled)".into());
    }
    if v["host_sim_codes_identical"] != serde_json::Value::Bool(true)
        || v["host_sim_max_state_diff"].as_f64() != Some(0.0)
    {
        return Err(format!(
            "pil: the run differs from the host-only simulation of the scene (first period {}, max state difference {})",
            v["host_sim_first_mismatch"], v["host_sim_max_state_diff"]
        ));
    }
    Ok(())
}

/// Flash and static RAM of every firmware image: the three QEMU binaries (on-target tests,
/// device table with its K = 1000 model, PIL loop) and the STM32F407 build (built here),
/// with the capacity of the memory map each is linked for.
fn firmware_sizes() -> Result<Vec<serde_json::Value>> {
    if !qemu_dir().join("target-data/model.bin").exists() {
        write_target_data()?;
    }
    let qemu = build_firmware(Board::Mps2An386)?;
    let stm32 = build_firmware(Board::Stm32f407)?;
    let mut out = Vec::new();
    for (name, elf, board) in [
        ("mps2-an386: on-target tests", qemu.clone(), Board::Mps2An386),
        ("mps2-an386: device table", qemu.with_file_name("device_table"), Board::Mps2An386),
        ("mps2-an386: processor in the loop", qemu.with_file_name("pil"), Board::Mps2An386),
        ("stm32f407: on-target tests", stm32, Board::Stm32f407),
    ] {
        let (flash_cap, ram_cap) = board.capacity();
        let bytes = std::fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let s = elf::sizes(&bytes, RAM_ORIGIN)?;
        out.push(serde_json::json!({"config": name, "flash_bytes": s.flash, "ram_bytes": s.ram,
            "flash_capacity": flash_cap, "ram_capacity": ram_cap}));
    }
    Ok(out)
}

fn firmware_size() -> Result<()> {
    for v in firmware_sizes()? {
        let n = |k: &str| v[k].as_u64().unwrap_or(0);
        println!(
            "firmware-size: {}: flash {} B ({:.1} % of {} KiB), static RAM {} B ({:.1} % of {} KiB)",
            v["config"].as_str().unwrap_or("?"),
            n("flash_bytes"),
            100.0 * n("flash_bytes") as f64 / n("flash_capacity") as f64,
            n("flash_capacity") >> 10,
            n("ram_bytes"),
            100.0 * n("ram_bytes") as f64 / n("ram_capacity") as f64,
            n("ram_capacity") >> 10
        );
    }
    Ok(())
}

/// The toolchain's `clippy-driver`.
fn clippy_driver() -> Result<PathBuf> {
    let sysroot = output(cmd("rustc").args(["--print", "sysroot"])).ok_or("`rustc --print sysroot` failed")?;
    let driver = Path::new(sysroot.trim()).join("bin").join("clippy-driver");
    if !driver.exists() {
        return Err(format!("{} is missing (rustup component add clippy)", driver.display()));
    }
    Ok(driver)
}

/// The library crates under the lint policy (docs/decisions/0004): no `unwrap`/`expect`/`panic`
/// outside tests, and no panicking indexing in the crates and modules that parse input
/// (`shared`, `controller`, `ssm::{mat, data, device}`, `sim::scene`). The `deny` attributes
/// live in the crates; the host build's wrapper runs clippy over them ([`wrapper_plan`]).
/// (Every workspace library that denies a clippy lint itself; a unit test keeps the list whole.)
const LINTED_CRATES: [&str; 9] =
    ["shared", "controller", "fileio", "infile", "sim", "ssm", "chaos", "furuta", "chaos_study"];

/// The crates whose API documentation the host build's wrapper builds, warnings denied (broken
/// or ambiguous intra-doc links, stray HTML in doc comments): the library crates and `ssmctl`.
const DOCUMENTED_CRATES: [&str; 7] = ["shared", "controller", "sim", "ssm", "chaos", "furuta", "ssmctl"];

/// Where `cargo xtask test` writes the output of its steps (and of each host test binary).
fn logs_dir() -> PathBuf {
    root().join("target").join("xtask-logs")
}

/// Where `cargo xtask test` writes its step table.
fn steps_json_path() -> PathBuf {
    root().join("target").join("xtask-test-steps.json")
}

/// The host build of `cargo xtask test`: every test binary of the workspace in the test
/// profile (`--timings`: what each crate cost, in `cargo-timings/` of [`build_dir`]) and the
/// lab's programs, its compiler wrapper (`wrap.rs`) checking the lint policy of
/// [`LINTED_CRATES`] and the API docs of [`DOCUMENTED_CRATES`] beside each one's compile, and
/// the lab's programs compiled to metadata only: one front-end pass over the dependencies
/// instead of a second one in check units. A lint or a doc warning fails this build, naming
/// the crate. Then the `ssmctl` the PIL and Slurm steps run, from that build.
fn host_build(plan: &wrap::Plan) -> Result<PathBuf> {
    let mut c = host_cargo()?;
    c.args(["test", "--workspace", "--no-run", "--timings"]).envs(plan.env());
    run(&mut c).map_err(|e| {
        format!(
            "{e} (the build also holds the lint policy of {} and the API docs of {} without warnings: see the wrapper's messages above)",
            LINTED_CRATES.join(", "),
            DOCUMENTED_CRATES.join(", ")
        )
    })?;
    println!("clippy: lint policy holds in {}", LINTED_CRATES.join(", "));
    println!("doc: the API documentation of {} builds without warnings", DOCUMENTED_CRATES.join(", "));
    println!("lab: the research and profiling programs compile");
    ssmctl_bin(Host::Test)
}

/// What the host build asks of its wrapper: lint [`LINTED_CRATES`], document
/// [`DOCUMENTED_CRATES`], check the lab (needs clippy, from the rustup step).
fn wrapper_plan() -> Result<wrap::Plan> {
    let target = build_dir();
    Ok(wrap::Plan {
        lint: LINTED_CRATES.iter().map(|s| s.to_string()).collect(),
        doc: DOCUMENTED_CRATES.iter().map(|s| s.to_string()).collect(),
        check_only: vec!["lab".to_string()],
        clippy: clippy_driver()?,
        doc_dir: target.join("doc"),
        lint_dir: target.join("xtask-lint"),
    })
}

/// The workspace's crates (package names as cargo's timings report them).
const WORKSPACE_CRATES: [&str; 14] = [
    "controller",
    "shared",
    "fileio",
    "infile",
    "sim",
    "ssm",
    "chaos",
    "furuta",
    "chaos_study",
    "ssmctl",
    "python",
    "lab",
    "tests",
    "fuzz-targets",
];

/// The host tests' step name in the table.
const HOST_TESTS_STEP: &str = "host tests (the workspace's test binaries, 2 at a time; doc tests)";

/// Test binaries run side by side: most binaries leave a core idle for part of their run
/// (a last long test, a serial fixture), so two at a time fill both cores of the machine.
const HOST_TEST_JOBS: usize = 2;

/// The host tests of the workspace (without `lab`): every test executable of the host build
/// (`cargo test --no-run`'s), [`HOST_TEST_JOBS`] at a time, longest first by `previous`, each
/// in its package folder as `cargo test` runs it; then the doc tests through cargo. Adds a row
/// per long binary to `steps`; returns all binaries and an error naming the failed ones.
fn host_tests_run(
    steps: &steps::Steps,
    previous: &std::collections::BTreeMap<String, f64>,
    test_times: bool,
) -> (Vec<host_tests::Binary>, Result<()>) {
    let start = steps.elapsed();
    let mut c = match host_cargo() {
        Ok(c) => c,
        Err(e) => return (Vec::new(), Err(e)),
    };
    c.args(["test", "--workspace", "--exclude", "lab", "--no-run", "--message-format=json"]);
    c.stderr(Stdio::inherit());
    let exes = match c.output() {
        Ok(o) if o.status.success() => host_tests::executables(&String::from_utf8_lossy(&o.stdout)),
        Ok(o) => Err(format!("{c:?} failed with {}", o.status)),
        Err(e) => Err(format!("cannot start {c:?}: {e}")),
    };
    let exes = match exes {
        Ok(e) if e.is_empty() => Err("cargo test --no-run listed no test executable".to_string()),
        other => other,
    };
    let exes = match exes {
        Ok(e) => e,
        Err(e) => return (Vec::new(), Err(e)),
    };
    let mut doc = match host_cargo() {
        Ok(c) => c,
        Err(e) => return (Vec::new(), Err(e)),
    };
    doc.args(["test", "--workspace", "--exclude", "lab", "--doc"]);
    let logs = logs_dir().join("host-tests");
    let (binaries, failed) = host_tests::run_parallel(&exes, previous, HOST_TEST_JOBS, test_times, &logs, &mut doc);
    add_test_binaries(steps, start, &binaries);
    let passed: u32 = binaries.iter().map(|b| b.passed).sum();
    let skipped: Vec<&String> = binaries.iter().flat_map(|b| &b.skipped).collect();
    if skipped.is_empty() {
        println!("host tests: {passed} passed in {} binaries, none skipped", binaries.len());
    } else {
        println!(
            "host tests: {passed} passed in {} binaries; {} SKIPPED their work (see below)",
            binaries.len(),
            skipped.len()
        );
        for s in &skipped {
            println!("host tests:   {s}");
        }
    }
    let r = if failed.is_empty() { Ok(()) } else { Err(format!("failed: {}", failed.join(", "))) };
    (binaries, r)
}

/// The stored estimates of the host test binaries' seconds (`cargo xtask build-times
/// --save-estimates` writes them from a run's steps JSON).
fn estimates_path() -> PathBuf {
    root().join("tests").join("host-test-seconds.json")
}

/// Seconds per host test binary, to start the longest first: the last `cargo xtask test`'s
/// (its steps JSON) over the stored estimates, so that a clean clone starts the longest first
/// too; a binary in neither is taken for a short one (started after the others).
fn previous_test_times() -> std::collections::BTreeMap<String, f64> {
    let read = |p: PathBuf| -> serde_json::Value {
        let text = std::fs::read_to_string(p).unwrap_or_default();
        serde_json::from_str(&text).unwrap_or(serde_json::Value::Null)
    };
    let mut times = host_tests::read_estimates(&read(estimates_path()));
    let last = read(steps_json_path());
    times.extend(
        last["host_test_binaries"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|b| Some((b["name"].as_str()?.to_string(), b["seconds"].as_f64()?))),
    );
    times
}

/// `cargo xtask host-tests [--test-times]`: the host build and host tests of `cargo xtask
/// test` alone, with their step table (the JSON is not written: it stays the last full
/// run's); `--test-times` also prints the 20 slowest tests (libtest's `--report-time`).
fn host_tests_only(args: &[String]) -> Result<()> {
    let test_times = match args {
        [] => false,
        [a] if a == "--test-times" => true,
        _ => return Err(format!("host-tests: expected no option or --test-times, got {args:?}")),
    };
    let steps = steps::Steps::new();
    let previous = previous_test_times();
    steps.run("host build (cargo test --no-run, test profile)", || {
        run(host_cargo()?.args(["test", "--workspace", "--exclude", "lab", "--no-run"]))
    })?;
    let mut binaries = Vec::new();
    let r = steps.run(HOST_TESTS_STEP, || {
        let (b, r) = host_tests_run(&steps, &previous, test_times);
        binaries = b;
        r
    });
    println!("\n{}", steps.table());
    if test_times {
        println!("The 20 slowest tests (wall seconds):\n\n{}", host_tests::slowest_tests(&binaries, 20));
    }
    r
}

/// The host tests' binaries as rows of the step table: each one of at least
/// [`TABLE_MIN_SECONDS`], the others as one row; `start` is when the step began.
fn add_test_binaries(steps: &steps::Steps, start: f64, binaries: &[host_tests::Binary]) {
    let row = |name: String, start_s: f64, seconds: f64, ok: bool| steps::Row {
        name,
        start_s,
        seconds,
        error: (!ok).then(|| "failed".to_string()),
    };
    let (long, short): (Vec<_>, Vec<_>) = binaries.iter().partition(|b| b.seconds >= TABLE_MIN_SECONDS);
    for b in long {
        steps.add(row(format!("  host tests: {}", b.name), start + b.start_s, b.seconds, b.ok));
    }
    if let Some(first) = short.first() {
        let seconds = short.iter().map(|b| b.seconds).sum();
        let name = format!("  host tests: {} binaries under {TABLE_MIN_SECONDS} s each", short.len());
        steps.add(row(name, start + first.start_s, seconds, short.iter().all(|b| b.ok)));
    }
}

/// Test binaries shorter than this share one row of the step table (all are in the JSON).
const TABLE_MIN_SECONDS: f64 = 2.0;

/// Waits for `gate`; `Err` naming `what` when the step behind it failed.
fn after<T: Clone>(gate: &steps::Gate<Result<T>>, what: &str) -> Result<T> {
    gate.wait().map_err(|_| format!("not run: {what} failed"))
}

/// The step table's row of `board`'s firmware build.
fn firmware_step(board: Board) -> &'static str {
    match board {
        Board::Mps2An386 => "firmware build (mps2-an386)",
        Board::Stm32f407 => "firmware build (stm32f407, same target dir: the firmware crate only)",
    }
}

/// `cargo xtask test`. Steps start as soon as what they need is there: the rustup and apt
/// installs, the Python venv, rustfmt and the firmware builds run while cargo compiles the
/// host tests (the builds beside it at a lower priority, their output in
/// `target/xtask-logs/`); the host build in [`build_dir`] lints, documents and checks the lab
/// beside its compiles; the two QEMU machines' suites run side by side; the Python module
/// (reusing the host build's dependencies), the PIL runs and Slurm (with the test build's
/// `ssmctl`) follow the host build. Every step runs even when another failed (unless it
/// needs that one); the command ends with the step table (also in
/// `target/xtask-test-steps.json`) and the on-target count, and fails if any step failed.
fn test_all() -> Result<()> {
    use steps::Gate;
    let steps = steps::Steps::new();
    let logs = logs_dir();
    let tools: Gate<Result<()>> = Gate::new();
    let apt_done: Gate<Result<()>> = Gate::new();
    let venv: Gate<Result<PathBuf>> = Gate::new();
    let data: Gate<Result<Vec<Vec<f64>>>> = Gate::new();
    let host: Gate<Result<PathBuf>> = Gate::new();
    let image_mps2: Gate<Result<PathBuf>> = Gate::new();
    let image_stm32: Gate<Result<PathBuf>> = Gate::new();
    let pil_done: Gate<Result<()>> = Gate::new();
    let pil_eq_done: Gate<Result<()>> = Gate::new();
    let results = std::sync::Mutex::new(Vec::<(&str, Result<()>)>::new());
    let on_target = std::sync::Mutex::new((0u32, 0u32));
    let test_binaries = std::sync::Mutex::new(Vec::<host_tests::Binary>::new());
    let previous = previous_test_times();
    let record = |name: &'static str, r: Result<()>| results.lock().unwrap_or_else(|p| p.into_inner()).push((name, r));
    let count = |passed: u32, failed: u32| {
        let mut c = on_target.lock().unwrap_or_else(|p| p.into_inner());
        *c = (c.0 + passed, c.1 + failed);
    };
    std::thread::scope(|s| {
        s.spawn(|| tools.set(steps.run("rustup: thumbv7em target, clippy, rustfmt", rust_tools)));
        s.spawn(|| {
            apt_done.set(steps.run("apt: qemu-system-arm, slurm-wlm, munge", || apt_packages(&logs.join("apt.log"))))
        });
        s.spawn(|| venv.set(steps.run("python: venv (maturin, pytest, numpy)", python::venv)));
        s.spawn(|| data.set(steps.run("firmware: target data (vectors, traces, device table)", write_target_data)));
        s.spawn(|| {
            let r = after(&tools, "rustup")
                .and_then(|()| steps.run("rustfmt --check (workspace, qemu/, tests/fuzz/)", || fmt_check(&logs)));
            record("rustfmt", r);
        });
        // Both boards' images, one after the other in one target dir (the second compiles
        // only the firmware crate), beside the host build.
        s.spawn(|| {
            for (board, gate) in [(Board::Mps2An386, &image_mps2), (Board::Stm32f407, &image_stm32)] {
                let r = after(&tools, "rustup").and_then(|()| after(&data, "target data")).and_then(|_| {
                    let log = logs.join(format!("firmware-{}.log", board.name()));
                    steps.run(firmware_step(board), || build_firmware_with(board, Some(&log)))
                });
                gate.set(r);
            }
        });
        // mps2-an386: on-target suite, device table, then (with the host's ssmctl) PIL.
        s.spawn(|| {
            let board = Board::Mps2An386;
            let built = after(&data, "target data")
                .and_then(|reference| Ok((reference, after(&image_mps2, "firmware build (mps2-an386)")?)));
            let suite = built.clone().and_then(|(_, elf)| {
                after(&apt_done, "apt")?;
                steps.run("qemu: on-target suite (mps2-an386)", || qemu_suite(board, &elf))
            });
            match &suite {
                Ok(r) => count(r.passed, r.failed),
                Err(_) => count(0, 1),
            }
            record("qemu-test (mps2-an386)", suite.map(|_| ()));
            let table = built.clone().and_then(|(reference, elf)| {
                after(&apt_done, "apt")?;
                steps.run("qemu: device table", || {
                    let (t, s) = device_table_measure(&reference, &elf)?;
                    print_table(&t, &s);
                    device_table::check(&t)
                })
            });
            count(u32::from(table.is_ok()), u32::from(table.is_err()));
            record("device-table", table);
            let pil_run = built.and_then(|_| {
                after(&apt_done, "apt")?;
                after(&host, "host build")?;
                steps.run("pil: 2,000 periods (mps2-an386)", || {
                    pil(PIL_SCENE, PIL_TEST_PERIODS, true, Host::Test).map(|_| ())
                })
            });
            count(u32::from(pil_run.is_ok()), u32::from(pil_run.is_err()));
            pil_done.set(pil_run.clone());
            record("pil", pil_run);
            let eq_run = after(&host, "host build").and_then(|_| {
                after(&apt_done, "apt")?;
                steps.run("pil: equation scenes, 6 x 300 periods (mps2-an386)", || pil_equations(board))
            });
            count(u32::from(eq_run.is_ok()), u32::from(eq_run.is_err()));
            pil_eq_done.set(eq_run.clone());
            record("pil equation scenes", eq_run);
        });
        // The STM32F407 image (the one flashed to a board) runs the same suite in QEMU's
        // netduinoplus2 (STM32F405), then a PIL run with the model the mps2-an386 run fitted.
        s.spawn(|| {
            let board = Board::Stm32f407;
            let t = Instant::now();
            let suite = after(&image_stm32, "firmware build (stm32f407)").and_then(|elf| {
                after(&apt_done, "apt")?;
                steps.run("qemu: on-target suite (stm32f407 on netduinoplus2)", || qemu_suite(board, &elf))
            });
            println!(
                "qemu-test: stm32f407 image (built after the mps2-an386 one) + netduinoplus2 run: {:.1} s",
                t.elapsed().as_secs_f64()
            );
            match &suite {
                Ok(r) => count(r.passed, r.failed),
                Err(_) => count(0, 1),
            }
            record("qemu-test (stm32f407)", suite.map(|_| ()));
            let pil_run = after(&pil_done, "pil (mps2-an386), whose model it runs").and_then(|()| {
                steps.run("pil: 500 periods (stm32f407 on netduinoplus2)", || {
                    pil_stm32(PIL_SCENE, PIL_STM32_PERIODS).map(|_| ())
                })
            });
            count(u32::from(pil_run.is_ok()), u32::from(pil_run.is_err()));
            record("pil (stm32f407 on netduinoplus2)", pil_run);
            let eq_run = after(&pil_eq_done, "pil equation scenes (mps2-an386), whose models it runs").and_then(|()| {
                steps.run("pil: equation scenes, 6 x 300 periods (stm32f407 on netduinoplus2)", || pil_equations(board))
            });
            count(u32::from(eq_run.is_ok()), u32::from(eq_run.is_err()));
            record("pil equation scenes (stm32f407 on netduinoplus2)", eq_run);
        });
        // The Python module, built after the host build so it reuses its dependencies.
        s.spawn(|| {
            let built = after(&venv, "python venv")
                .and_then(|_| after(&host, "host build"))
                .and_then(|_| steps.run("python: module build (maturin, optimized)", python::module_build));
            let r = built.and_then(|()| steps.run("python: pytest", python::pytest));
            record("python-test", r);
        });
        // The sweeps under a real Slurm, with the test-profile ssmctl the host tests built.
        s.spawn(|| {
            let r = after(&apt_done, "apt")
                .and_then(|()| after(&host, "host build"))
                .and_then(|bin| steps.run("slurm: sweeps as array jobs", || slurm::slurm_test(Some(bin))));
            record("slurm-test", r);
        });
        // The host build and tests, on this thread.
        let built = after(&tools, "rustup").and_then(|()| wrapper_plan()).and_then(|plan| {
            steps.run("host build (cargo test --no-run, test profile; lint policy, API docs, lab check)", || {
                host_build(&plan)
            })
        });
        host.set(built.clone());
        let tests = after(&host, "host build").and_then(|_| {
            steps.run(HOST_TESTS_STEP, || {
                let (binaries, r) = host_tests_run(&steps, &previous, false);
                *test_binaries.lock().unwrap_or_else(|p| p.into_inner()) = binaries;
                r
            })
        });
        record("host tests", tests);
    });
    for (gate, name) in [(&tools, "rustup"), (&apt_done, "apt")] {
        record(name, gate.wait());
    }
    record("python venv", venv.wait().map(|_| ()));
    record("target data", data.wait().map(|_| ()));
    record("host build", host.wait().map(|_| ()));
    let results = results.into_inner().unwrap_or_else(|p| p.into_inner());
    let failed: Vec<&str> = results.iter().filter(|(_, r)| r.is_err()).map(|(n, _)| *n).collect();
    for (name, r) in &results {
        if let Err(e) = r {
            eprintln!("{name}: {e}");
        }
    }
    println!("\n{}", steps.table());
    let mut extra = steps::cpu_and_load();
    if let Some(o) = extra.as_object_mut() {
        let binaries = test_binaries.into_inner().unwrap_or_else(|p| p.into_inner());
        let list: Vec<serde_json::Value> = binaries
            .iter()
            .map(|b| serde_json::json!({"name": b.name, "start_seconds": b.start_s, "seconds": b.seconds, "passed": b.passed, "ok": b.ok}))
            .collect();
        o.insert("host_test_binaries".into(), list.into());
        // What each crate of the host build cost (all of them when the build started from
        // scratch, only what was recompiled otherwise).
        let timings = build_dir().join("cargo-timings").join("cargo-timing.html");
        match std::fs::read_to_string(&timings).map_err(|e| e.to_string()).and_then(|h| host_tests::timing_units(&h)) {
            Ok(units) => {
                o.insert("host_build_units".into(), host_tests::timing_summary(&units, &WORKSPACE_CRATES, 25));
            }
            Err(e) => eprintln!("steps: {}: {e}", timings.display()),
        }
    }
    println!(
        "cpu: children user {:.0} s, system {:.0} s; load average (1, 5, 15 min) at the end: {}",
        extra["children_cpu_user_seconds"].as_f64().unwrap_or(f64::NAN),
        extra["children_cpu_system_seconds"].as_f64().unwrap_or(f64::NAN),
        extra["load_average_1_5_15_min"].as_str().unwrap_or("?")
    );
    let json = steps_json_path();
    if let Err(e) = steps.write_json(&json, extra) {
        eprintln!("steps: {e}");
    } else {
        println!("steps: {}", json.display());
    }
    let (passed, failed_on_target) = on_target.into_inner().unwrap_or_else(|p| p.into_inner());
    println!("on-target: {passed} passed, {failed_on_target} failed");
    if failed.is_empty() { Ok(()) } else { Err(format!("failed: {}", failed.join(", "))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_without_line_tables_and_in_ci_without_incremental_in_4_codegen_units_unless_told() {
        let s = |v: &'static str| Some(std::ffi::OsStr::new(v));
        let keys = |ci, set: &[&str]| -> Vec<&str> {
            build_env(ci, |k| set.contains(&k)).into_iter().map(|(k, _)| k).collect()
        };
        let always = ["CARGO_PROFILE_DEV_DEBUG", "CARGO_PROFILE_TEST_DEBUG"];
        let ci = [
            "CARGO_PROFILE_DEV_DEBUG",
            "CARGO_PROFILE_TEST_DEBUG",
            "CARGO_INCREMENTAL",
            "CARGO_PROFILE_DEV_CODEGEN_UNITS",
            "CARGO_PROFILE_TEST_CODEGEN_UNITS",
        ];
        assert_eq!(keys(s("true"), &[]), ci);
        assert_eq!(keys(s("1"), &[]), ci);
        for not_ci in [None, s("false"), s("0"), s("")] {
            assert_eq!(keys(not_ci, &[]), always, "{not_ci:?}");
        }
        // A setting the caller made is left to cargo.
        assert_eq!(keys(s("true"), &["CARGO_INCREMENTAL"]), [&ci[..2], &ci[3..]].concat());
        assert_eq!(keys(None, &["CARGO_PROFILE_DEV_DEBUG"]), always[1..]);
        assert!(build_env(s("true"), |_| false).contains(&("CARGO_INCREMENTAL", "0")));
        assert!(build_env(None, |_| false).iter().all(|&(_, v)| v == "false"));
    }

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    /// Every apt-get install of the xtask leaves the recommended packages out (the command
    /// installs on a fresh machine; recommends would add desktop and media stacks).
    #[test]
    fn every_apt_install_is_without_recommends() {
        for list in [&QEMU_APT_INSTALL[..], &slurm::APT_INSTALL[..]] {
            assert_eq!(list[..3], ["install", "-y", "--no-install-recommends"], "{list:?}");
        }
        // Built here, so that this test's own source does not hold the pattern it looks for.
        let install = ["\"install\"", "\"-y\""].join(", ");
        let without = format!("{install}, \"--no-install-recommends\"");
        let dir = root().join("tests/src/xtask");
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            for (i, line) in text.lines().enumerate() {
                if let Some(at) = line.find(&install).filter(|_| !line.trim_start().starts_with("//")) {
                    assert!(
                        line[at..].starts_with(&without),
                        "{}:{}: an apt-get install with recommends: {line}",
                        path.display(),
                        i + 1
                    );
                }
            }
        }
    }

    /// Every workspace library whose sources deny a clippy lint is in [`LINTED_CRATES`], so
    /// the CI host build's wrapper lints it.
    #[test]
    fn every_library_with_a_lint_policy_is_linted() {
        let manifest = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
        let members = manifest.split("members = [").nth(1).unwrap().split(']').next().unwrap();
        let mut with_policy = Vec::new();
        for m in members.split(',').map(|m| m.trim().trim_matches('"')).filter(|m| !m.is_empty()) {
            let src = root().join(m).join("src");
            let name = std::fs::read_to_string(root().join(m).join("Cargo.toml"))
                .unwrap()
                .lines()
                .find_map(|l| l.strip_prefix("name = ").map(|v| v.trim_matches('"').to_string()))
                .unwrap();
            let mut stack = vec![src];
            let mut denies = false;
            while let Some(dir) = stack.pop() {
                for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                    let p = e.path();
                    if p.is_dir() && !p.ends_with("xtask") {
                        stack.push(p);
                    } else if p.extension().is_some_and(|x| x == "rs") {
                        denies |= std::fs::read_to_string(&p).unwrap().contains("deny(clippy::");
                    }
                }
            }
            if denies {
                with_policy.push(name);
            }
        }
        assert!(with_policy.iter().any(|n| n == "sim"), "{with_policy:?}");
        let missing: Vec<_> = with_policy.iter().filter(|n| !LINTED_CRATES.contains(&n.as_str())).collect();
        assert!(missing.is_empty(), "libraries with a clippy policy that LINTED_CRATES leaves out: {missing:?}");
    }

    #[test]
    fn pil_record_options() {
        let r = record_args(&args(&["--out", "d", "--runs", "2", "--periods", "500", "--seed", "7"])).unwrap();
        assert_eq!(
            r,
            RecordArgs {
                out: "d".into(),
                runs: 2,
                periods: 500,
                scene: PIL_SCENE.into(),
                seed: 7,
                fresh: false,
                host: Host::Test
            }
        );
        let d = record_args(&args(&["--out", "x"])).unwrap();
        assert_eq!((d.runs, d.periods, d.seed), (3, 20_000, 1));
        for (bad, says) in [
            (&["--runs", "2"][..], "--out DIR is required"),
            (&["--out", "d", "--runs", "0"], "between 1 and 100"),
            (&["--out", "d", "--periods", "1"], "at least 2"),
            (&["--out", "d", "--seed", "-1"], "--seed `-1`"),
            (&["--out"], "--out needs a value"),
            (&["--out", "d", "--bogus"], "unknown option `--bogus`"),
        ] {
            let e = record_args(&args(bad)).unwrap_err();
            assert!(e.contains(says), "{bad:?}: {e}");
        }
        assert_eq!([1, 2, 3, 4, 5].map(record_theta0), [0.01, -0.015, 0.02, -0.025, 0.01]);
    }

    #[test]
    fn theta_csv_check_counts_rows_and_rejects_bad_lines() {
        let dir = std::env::temp_dir().join(format!("xtask-theta-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("theta.csv");
        std::fs::write(&p, "t_s,theta_meas_rad\n0,0.1\n0.025,0.2\n").unwrap();
        assert!(theta_csv_check(&p, 2).is_ok());
        assert!(theta_csv_check(&p, 3).unwrap_err().contains("2 rows, expected 3"));
        std::fs::write(&p, "t_s,theta_meas_rad\n0,0.1\n0.025,NaN\n").unwrap();
        assert!(theta_csv_check(&p, 2).unwrap_err().contains("line 3"));
        std::fs::write(&p, "t,x\n0,0.1\n").unwrap();
        assert!(theta_csv_check(&p, 1).unwrap_err().contains("header"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
