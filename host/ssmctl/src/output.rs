//! Writing a command's files: every output goes through the `fileio` crate's writer
//! ([`AtomicFile`], [`write_atomic`]) inside the command's [`Outputs`] transaction, which
//! `cli::run` opens over the command's output paths (see `cli::output_plan`) and commits when
//! the command succeeds: the files appear together or not at all, never through a symbolic
//! link, into a device or over one of the command's inputs.

pub use fileio::{AtomicFile, OutputError, Outputs, check_not_input, create_dir, open_log, write_atomic};

use std::path::{Path, PathBuf};

/// Writes a scene's run: `DIR/<scene>.csv` and `DIR/<scene>.json` (see
/// [`sim::closed_loop::output_names`]), each through an [`AtomicFile`]; returns the CSV path.
/// The command's transaction refuses a target that is one of its inputs (the scene file).
pub fn write_scene_outputs(
    scene: &sim::scene::Scene,
    traj: &sim::closed_loop::Trajectory,
    dir: &Path,
) -> Result<PathBuf, Box<dyn std::error::Error + Send + Sync>> {
    let (csv_name, json_name) = sim::closed_loop::output_names(scene);
    let (csv, json) = (dir.join(&csv_name), dir.join(&json_name));
    create_dir(dir)?;
    let mut f = AtomicFile::create(&csv)?;
    traj.write_csv_to(&mut f)?;
    let text = sim::closed_loop::metadata_json(scene, traj, &csv_name)?;
    f.commit()?;
    write_atomic(&json, text.as_bytes())?;
    Ok(csv)
}
