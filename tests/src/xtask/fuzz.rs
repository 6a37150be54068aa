//! `cargo xtask fuzz [--seconds N] [TARGET ...]`: runs the coverage-guided fuzz targets of
//! `tests/fuzz` (cargo-fuzz, libFuzzer) one after the other, N seconds each (default 60),
//! from their seeds, regressions and the local corpus (`tests/fuzz/corpus/TARGET`, grown by
//! the run), with a memory limit and a per-input timeout. Needs a nightly toolchain and
//! `cargo-fuzz`; says so, and how to get them, when either is missing. The same targets'
//! corpora are replayed on stable by `cargo test -p fuzz-targets` (part of `test`).

use super::{Result, cmd, output, root, run};

/// The targets (tests/fuzz/fuzz_targets/*.rs, bodies in tests/fuzz-targets).
const TARGETS: [&str; 10] = [
    "scene_toml",
    "csv_data",
    "model_json",
    "model_blob",
    "pil_frames",
    "cli_options",
    "mat_file",
    "sweep_spec",
    "shard_file",
    "plant_expressions",
];

pub fn fuzz(args: &[String]) -> Result<()> {
    let mut seconds = 60u64;
    let mut targets = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--seconds" => {
                seconds = it
                    .next()
                    .and_then(|v| v.parse().ok())
                    .filter(|&s| s >= 1)
                    .ok_or("fuzz: --seconds needs a number of seconds >= 1")?;
            }
            t if TARGETS.contains(&t) => targets.push(t),
            other => return Err(format!("fuzz: unknown argument `{other}` (targets: {})", TARGETS.join(", "))),
        }
    }
    if targets.is_empty() {
        targets = TARGETS.to_vec();
    }
    if output(cmd("cargo").args(["+nightly", "--version"])).is_none() {
        return Err("fuzz: no nightly toolchain (libFuzzer needs it): `rustup toolchain install nightly`. The corpora are replayed on stable by `cargo test -p fuzz-targets`.".into());
    }
    if output(cmd("cargo").args(["+nightly", "fuzz", "--version"])).is_none() {
        return Err("fuzz: cargo-fuzz is not installed: `cargo install cargo-fuzz`. The corpora are replayed on stable by `cargo test -p fuzz-targets`.".into());
    }
    let dir = root().join("tests/fuzz");
    for t in &targets {
        let corpus = dir.join("corpus").join(t);
        std::fs::create_dir_all(&corpus).map_err(|e| format!("{}: {e}", corpus.display()))?;
        println!("fuzz: {t} for {seconds} s");
        run(cmd("cargo").current_dir(&dir).args(["+nightly", "fuzz", "run", t]).arg(&corpus).arg(dir.join("seeds").join(t)).arg(dir.join("regressions").join(t)).args([
            "--",
            &format!("-max_total_time={seconds}"),
            "-rss_limit_mb=2048",
            "-timeout=10",
            "-print_final_stats=1",
        ]))
        .map_err(|e| format!("fuzz: {t} found a failing input (see tests/fuzz/artifacts/{t}/; fix it, then keep the input in tests/fuzz/regressions/{t}/): {e}"))?;
    }
    println!("fuzz: {} targets, {seconds} s each, no finding", targets.len());
    Ok(())
}
