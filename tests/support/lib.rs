//! Shared helpers for the workspace-level tests in `tests/`: locating the real
//! binaries and the shared fixtures.
#![warn(missing_docs)]

use std::path::PathBuf;

/// The workspace root (where the top-level `Cargo.toml` lives).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}
