//! Workspace-level checks live in `tests/tests/` (the crate graph); the xtask automation in
//! `src/xtask/`.
