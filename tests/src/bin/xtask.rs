//! Cross-target automation behind `cargo xtask` (alias in `.cargo/config.toml`).
//!
//! - `install`: the thumbv7em-none-eabihf target and `qemu-system-arm`, if missing.
//! - `qemu-test`: generate the model blob and expected outputs, build the firmware in
//!   `qemu/` with its own config, run it under QEMU (hard timeout), pass/fail by exit code.
//! - `firmware-size`: flash/RAM of the firmware for each board configuration.
//! - `test`: install + `cargo test --workspace` + qemu-test + STM32F407 build.

#[path = "../xtask/elf.rs"]
mod elf;
#[path = "../xtask/traces.rs"]
mod traces;
#[path = "../xtask/vectors.rs"]
mod vectors;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

const TARGET: &str = "thumbv7em-none-eabihf";
/// QEMU's own runner already has `timeout 120`; this outer limit also covers the build.
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);
const RAM_ORIGIN: u64 = 0x2000_0000;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ has a parent").to_path_buf()
}

fn qemu_dir() -> PathBuf {
    root().join("qemu")
}

type Result<T> = std::result::Result<T, String>;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("install") => install(),
        Some("qemu-test") => qemu_test().map(|_| ()),
        Some("firmware-size") => firmware_size(),
        Some("test") => test_all(),
        _ => Err("usage: cargo xtask <install | qemu-test | firmware-size | test>".into()),
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
/// cargo (target dir, rustflags of the host build).
fn cmd(program: &str) -> Command {
    let mut c = Command::new(program);
    for var in ["CARGO_TARGET_DIR", "RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_TARGET", "CARGO_MANIFEST_DIR"] {
        c.env_remove(var);
    }
    c
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
    let installed = output(cmd("rustup").args(["target", "list", "--installed"])).unwrap_or_default();
    if installed.lines().any(|l| l.trim() == TARGET) {
        println!("install: target {TARGET} present");
    } else {
        run(cmd("rustup").args(["target", "add", TARGET]))?;
    }
    if output(cmd("qemu-system-arm").arg("--version")).is_some() {
        println!("install: qemu-system-arm present");
    } else {
        let root = output(cmd("id").arg("-u")).is_some_and(|u| u.trim() == "0");
        let apt = |args: &[&str]| {
            if root {
                run(cmd("apt-get").args(args))
            } else {
                run(cmd("sudo").arg("apt-get").args(args))
            }
        };
        apt(&["update"])?;
        apt(&["install", "-y", "qemu-system-arm"])?;
    }
    Ok(())
}

/// On-target results parsed from the firmware's `test NAME ... ok|FAILED` lines.
#[derive(Debug, Default)]
struct TargetResult {
    passed: u32,
    failed: u32,
}

fn write_target_data() -> Result<usize> {
    let v = vectors::generate()?;
    let dir = qemu_dir().join("target-data");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    // Only rewrite on change, so cargo does not rebuild the firmware needlessly.
    let write = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = dir.join(name);
        if std::fs::read(&path).ok().as_deref() != Some(bytes) {
            std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
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
    Ok(v.blob.len())
}

fn build_firmware(stm32: bool) -> Result<PathBuf> {
    let mut c = cmd("cargo");
    c.current_dir(qemu_dir()).args(["build", "--release"]);
    if stm32 {
        c.args(["--features", "stm32f407", "--target-dir", "target/stm32f407"]);
    }
    run(&mut c)?;
    let base = if stm32 { qemu_dir().join("target/stm32f407") } else { qemu_dir().join("target") };
    Ok(base.join(TARGET).join("release").join("firmware"))
}

fn qemu_test() -> Result<TargetResult> {
    write_target_data()?;
    let elf = build_firmware(false)?;
    let start = Instant::now();
    let log = qemu_dir().join("target").join("qemu-test.log");
    let log_file = std::fs::File::create(&log).map_err(|e| format!("{}: {e}", log.display()))?;
    let mut child = cmd("qemu-system-arm")
        .args(["-cpu", "cortex-m4", "-machine", "mps2-an386", "-nographic"])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(&elf)
        .stdin(Stdio::null())
        .stdout(log_file.try_clone().map_err(|e| e.to_string())?)
        .stderr(log_file)
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm (run `cargo xtask install`): {e}"))?;
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break Some(s);
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let text = std::fs::read_to_string(&log).unwrap_or_default();
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
        None => Err(format!("QEMU timed out after {}s ({} passed, {} failed so far)", QEMU_TIMEOUT.as_secs(), r.passed, r.failed)),
        Some(s) if s.success() && r.failed == 0 && r.passed > 0 => {
            println!("qemu-test: PASS ({} passed, 0 failed, {secs:.1} s in QEMU)", r.passed);
            Ok(r)
        }
        Some(s) => Err(format!("qemu-test: FAIL (exit {s}, {} passed, {} failed)", r.passed, r.failed)),
    }
}

fn firmware_size() -> Result<()> {
    if !qemu_dir().join("target-data/model.bin").exists() {
        write_target_data()?;
    }
    for (name, stm32, flash_cap, ram_cap) in
        [("mps2-an386 (QEMU)", false, 4u64 << 20, 4u64 << 20), ("stm32f407", true, 1 << 20, 128 << 10)]
    {
        let elf = build_firmware(stm32)?;
        let bytes = std::fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let s = elf::sizes(&bytes, RAM_ORIGIN)?;
        println!(
            "firmware-size: {name}: flash {} B ({:.1} % of {} KiB), static RAM {} B ({:.1} % of {} KiB)",
            s.flash,
            100.0 * s.flash as f64 / flash_cap as f64,
            flash_cap >> 10,
            s.ram,
            100.0 * s.ram as f64 / ram_cap as f64,
            ram_cap >> 10
        );
    }
    Ok(())
}

fn test_all() -> Result<()> {
    install()?;
    let mut host = cmd("cargo");
    host.current_dir(root()).args(["test", "--workspace"]);
    let host_result = run(&mut host);
    let target = qemu_test();
    let stm32 = build_firmware(true).map(|_| println!("stm32f407 configuration builds and links"));
    let (passed, failed) = match &target {
        Ok(r) => (r.passed, r.failed),
        Err(_) => (0, 1),
    };
    println!("on-target: {passed} passed, {failed} failed");
    host_result?;
    target?;
    stm32?;
    Ok(())
}
