//! `cargo xtask python-test`, also steps of `test`: the Python module `ssm_ctl`
//! (`host/python`) installed into a venv with pip (the maturin build backend) and its pytest
//! tests run. The venv (`target/pyvenv`) is made when missing and given what it lacks
//! (maturin, pytest, numpy from PyPI); later runs reuse it. `test` makes the venv ([`venv`])
//! while cargo compiles, builds the module ([`module_build`]) after the host build and then runs
//! [`pytest`].
//!
//! The module is built optimized with the test profile's settings in the target directory of
//! the xtask's host build (`crate::build_dir`, with its compiler wrapper): maturin's `--profile test` would build a test harness (`cargo rustc` treats
//! that profile name so), so it builds `--profile dev` with the settings the test profile
//! adds to dev ([`TEST_OVER_DEV`]) given as `CARGO_PROFILE_DEV_*`; with equal settings and the
//! workspace's feature sets (`host/python/Cargo.toml`) every dependency `cargo test
//! --workspace` compiled is reused and only the bindings (pyo3, numpy, the module) are
//! compiled. `pip install ./host/python` by a user builds release. `ssm_ctl.__build__` says
//! how the installed module was compiled.

use std::path::PathBuf;
use std::time::Instant;

use crate::{Result, cmd, output, root, run};

/// Where the venv lives.
pub fn venv_dir() -> PathBuf {
    root().join("target").join("pyvenv")
}

/// What the venv needs: the build backend, the test runner, the module's one dependency.
const NEEDS: &[&str] = &["maturin>=1.9,<2", "pytest>=7", "numpy>=1.21"];

/// What `[profile.test]` in the root `Cargo.toml` sets over the dev profile it inherits, as
/// cargo's environment overrides of the dev profile (a unit test checks the two agree).
pub const TEST_OVER_DEV: &[(&str, &str)] = &[("CARGO_PROFILE_DEV_OPT_LEVEL", "2")];

/// Makes the venv when missing and installs what it lacks; returns its python.
pub fn venv() -> Result<PathBuf> {
    let venv = venv_dir();
    let py = venv.join("bin").join("python");
    // A venv without pip is one whose creation was interrupted: make it again.
    if py.exists() && output(cmd(&py).args(["-m", "pip", "--version"])).is_none() {
        println!("python-test: {} has no pip (an interrupted creation); making it again", venv.display());
        std::fs::remove_dir_all(&venv).map_err(|e| format!("removing the broken venv {}: {e}", venv.display()))?;
    }
    if !py.exists() {
        run(cmd("python3").arg("-m").arg("venv").arg(&venv))
            .map_err(|e| format!("{e}: python3 with its venv module is needed for the Python module's tests (Debian: apt-get install python3-venv)"))?;
    }
    if output(cmd(&py).args(["-c", "import maturin, pytest, numpy"])).is_some() {
        println!("python-test: maturin, pytest, numpy present in {}", venv.display());
    } else {
        run(cmd(&py).args(["-m", "pip", "install", "-q", "--disable-pip-version-check"]).args(NEEDS))?;
    }
    Ok(py)
}

/// Builds the module into the venv made by [`venv`] and runs pytest; prints the times.
pub fn module_and_tests() -> Result<()> {
    module_build()?;
    pytest()
}

/// Builds the module and installs it into the venv made by [`venv`]; prints the time.
pub fn module_build() -> Result<()> {
    let t0 = Instant::now();
    let bin = venv_dir().join("bin");
    let py = bin.join("python");
    // The build backend runs `maturin` by name: the venv's bin first, as activation does.
    let path = std::env::join_paths(
        std::iter::once(bin.clone()).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .map_err(|e| format!("PATH: {e}"))?;
    let mut build = cmd(&py);
    build
        .current_dir(root())
        .args([
            "-m",
            "pip",
            "install",
            "-q",
            "--disable-pip-version-check",
            "--no-build-isolation",
            "--no-deps",
            "--force-reinstall",
            "./host/python",
        ])
        .env("PATH", &path)
        .env("MATURIN_PEP517_ARGS", "--profile dev");
    for (k, v) in TEST_OVER_DEV {
        build.env(k, v);
    }
    crate::host_build_env(&mut build)?;
    run(&mut build)?;
    println!("python-test: module build + install {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// The module's pytest tests, in the venv it was installed into; prints the time.
pub fn pytest() -> Result<()> {
    let t0 = Instant::now();
    let py = venv_dir().join("bin").join("python");
    run(cmd(&py).current_dir(root()).args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "host/python/tests"]))?;
    println!("python-test: pytest {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// `cargo xtask python-test`: [`venv`], then [`module_and_tests`]; prints the step's wall time.
pub fn python_test() -> Result<()> {
    let t0 = Instant::now();
    venv()?;
    module_and_tests()?;
    println!("python-test: whole step {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[profile.test]` of the root manifest, as `(CARGO_PROFILE_DEV_KEY, value)` pairs.
    fn test_profile_keys(manifest: &str) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let mut inside = false;
        for line in manifest.lines().map(str::trim) {
            if line.starts_with('[') {
                inside = line == "[profile.test]";
                continue;
            }
            if !inside || line.is_empty() || line.starts_with('#') {
                continue;
            }
            let (k, v) = line.split_once('=').expect("key = value");
            let key = format!("CARGO_PROFILE_DEV_{}", k.trim().to_uppercase().replace('-', "_"));
            out.push((key, v.trim().trim_matches('"').to_string()));
        }
        out
    }

    #[test]
    fn the_module_build_uses_the_test_profile_settings() {
        let manifest = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
        let want = test_profile_keys(&manifest);
        assert!(!want.is_empty(), "no [profile.test] in the root Cargo.toml");
        let have: Vec<(String, String)> = TEST_OVER_DEV.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        assert_eq!(have, want, "python.rs TEST_OVER_DEV must mirror [profile.test] of Cargo.toml");
        assert_eq!(
            test_profile_keys("[profile.test]\n# c\nopt-level = 2\ndebug = \"line-tables-only\"\n[x]\ny = 1\n"),
            [
                ("CARGO_PROFILE_DEV_OPT_LEVEL".to_string(), "2".to_string()),
                ("CARGO_PROFILE_DEV_DEBUG".to_string(), "line-tables-only".to_string())
            ]
        );
    }
}
