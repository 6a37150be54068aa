//! `cargo xtask python-test`, also a step of `test`: the Python module `ssm_ctl`
//! (`host/python`) installed into a venv with pip (the maturin build backend) and its pytest
//! tests run. The venv (`target/pyvenv`) is made when missing and given what it lacks
//! (maturin, pytest, numpy from PyPI); later runs reuse it.
//!
//! The module is built in the workspace's target directory with the `dev` profile, so the
//! dependencies `cargo test --workspace` compiled just before are reused (only the
//! bindings are compiled again); `pip install ./host/python` by a user builds release.

use std::path::PathBuf;
use std::time::Instant;

use crate::{Result, cmd, output, root, run};

/// Where the venv lives.
pub fn venv_dir() -> PathBuf {
    root().join("target").join("pyvenv")
}

/// What the venv needs: the build backend, the test runner, the module's one dependency.
const NEEDS: &[&str] = &["maturin>=1.9,<2", "pytest>=7", "numpy>=1.21"];

/// Makes the venv when missing, installs what it lacks, builds and installs the module,
/// runs pytest. Prints the step's wall time.
pub fn python_test() -> Result<()> {
    let t0 = Instant::now();
    let venv = venv_dir();
    let bin = venv.join("bin");
    let py = bin.join("python");
    if !py.exists() {
        run(cmd("python3").arg("-m").arg("venv").arg(&venv))
            .map_err(|e| format!("{e}: python3 with its venv module is needed for the Python module's tests (Debian: apt-get install python3-venv)"))?;
    }
    if output(cmd(&py).args(["-c", "import maturin, pytest, numpy"])).is_some() {
        println!("python-test: maturin, pytest, numpy present in {}", venv.display());
    } else {
        run(cmd(&py).args(["-m", "pip", "install", "-q", "--disable-pip-version-check"]).args(NEEDS))?;
    }
    // The build backend runs `maturin` by name: the venv's bin first, as activation does.
    let path = std::env::join_paths(
        std::iter::once(bin.clone()).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .map_err(|e| format!("PATH: {e}"))?;
    let t_build = Instant::now();
    run(cmd(&py)
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
        .env("MATURIN_PEP517_ARGS", "--profile dev"))?;
    let build_s = t_build.elapsed().as_secs_f64();
    let t_tests = Instant::now();
    run(cmd(&py).current_dir(root()).args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "host/python/tests"]))?;
    println!(
        "python-test: module build + install {build_s:.1} s, pytest {:.1} s, whole step {:.1} s",
        t_tests.elapsed().as_secs_f64(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
