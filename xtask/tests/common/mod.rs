//! Helpers shared by xtask's integration tests: running the built `xtask` from the workspace
//! root, scratch folders, and where the default model file is cached.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the built `xtask` with `args` from the workspace root.
pub fn xtask(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .expect("xtask runs")
}

/// A test's scratch folder (named `<prefix>…`), removed when dropped, also when the test fails.
pub fn scratch_dir(prefix: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(prefix).tempdir().expect("temp dir")
}

/// The default model file in the model cache.
pub fn model_path() -> PathBuf {
    lm::default_model_path()
}
