//! Where local model files live: the model cache, outside any repository. `cargo xtask
//! fetch-model` fills it; tests, benchmarks and the command line read the default model there.

use std::path::PathBuf;

/// The default model's file name (SmolLM2-135M-Instruct, Q4_1).
pub const DEFAULT_MODEL_FILE: &str = "SmolLM2-135M-Instruct.Q4_1.gguf";

/// The model cache: `$NSEA_MODEL_DIR`, else `$XDG_CACHE_HOME/nsea/models`, else
/// `~/.cache/nsea/models`.
pub fn model_dir() -> PathBuf {
    cache_dir("NSEA_MODEL_DIR", "models")
}

/// One of the project's caches: `$VAR` when set and not empty, else `$XDG_CACHE_HOME/nsea/SUB`, else
/// `~/.cache/nsea/SUB` (models here; `cargo xtask fetch-data`'s task files under `data`).
pub fn cache_dir(var: &str, sub: &str) -> PathBuf {
    // Empty is unset, as the XDG base directory specification has it for its variables (an
    // empty path would be the working folder).
    let set = |name: &str| std::env::var_os(name).filter(|value| !value.is_empty());
    if let Some(dir) = set(var) {
        return PathBuf::from(dir);
    }
    let cache = set("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache"));
    cache.join("nsea").join(sub)
}

/// Where the default model is (or will be, once fetched).
pub fn default_model_path() -> PathBuf {
    model_dir().join(DEFAULT_MODEL_FILE)
}
