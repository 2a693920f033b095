//! Helpers shared by xtask's integration tests: running the built `xtask` from the workspace
//! root, and where the default model file is cached.

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

/// The default model file in the model cache (`$NSEA_MODEL_DIR`, else
/// `$XDG_CACHE_HOME/nsea/models`, else `~/.cache/nsea/models`).
pub fn model_path() -> PathBuf {
    let dir = std::env::var_os("NSEA_MODEL_DIR").map(PathBuf::from).unwrap_or_else(|| {
        std::env::var_os("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache"))
            .join("nsea/models")
    });
    dir.join("SmolLM2-135M-Instruct.Q4_1.gguf")
}
