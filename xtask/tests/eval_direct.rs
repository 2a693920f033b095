//! `cargo xtask eval --agent direct`: a model that is not there, or no chat model at all, is
//! bad input (exit 2) before any record file is made; so is a reply cache (`--chat-cache`)
//! inside the records folder. Needs no model file.

mod common;

use common::xtask;

/// A records folder that does not exist, inside a temporary folder that is removed when the
/// returned guard is dropped, also when the test fails.
fn out(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = tempfile::Builder::new().prefix("eval-direct-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    (tmp, dir)
}

/// `cargo xtask eval ARGS --limit 1 --out DIR`, which must exit 2; its stderr.
fn refused(args: &[&str], dir: &std::path::Path) -> String {
    let mut all = vec!["eval"];
    all.extend_from_slice(args);
    all.extend(["--limit", "1", "--out", dir.to_str().unwrap()]);
    let output = xtask(&all);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    stderr
}

#[test]
fn an_unknown_model_is_bad_input() {
    let (_tmp_dir, dir) = out("unknown");
    let stderr = refused(&["--agent", "direct", "--explorer", "no-such-model.gguf", "--benchmark", "alfworld-seen"], &dir);
    assert!(stderr.contains("no-such-model.gguf"), "{stderr}");
    assert!(!dir.exists(), "no records for a run that never started");
}

#[test]
fn the_direct_agent_needs_a_chat_model() {
    let (_tmp_dir, dir) = out("systematic");
    let output =
        xtask(&["eval", "--agent", "direct", "--explorer", "systematic", "--benchmark", "alfworld-seen", "--out", dir.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--agent direct needs a chat model"), "{stderr}");

    let output = xtask(&["eval", "--agent", "direct", "--explorer", "smollm2", "--failure-limit", "0", "--out", dir.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(!dir.exists());
}

#[test]
fn a_reply_cache_inside_the_records_folder_is_refused() {
    let (_tmp_dir, dir) = out("cache");
    let cache = dir.join("phase1-replies.jsonl");
    let stderr = refused(&["--explorer", "no-such-model.gguf", "--chat-cache", cache.to_str().unwrap()], &dir);
    assert!(stderr.contains("keep the reply file out of the records folder"), "{stderr}");
    assert!(!dir.exists(), "no records, no reply file");
}
