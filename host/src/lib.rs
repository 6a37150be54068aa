//! Host side of the workspace.
