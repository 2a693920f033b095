//! `kill -9` at any moment, then resume: the records are exactly those of an uninterrupted run,
//! none lost, none twice (`eval-harness::records`, through `cargo xtask eval`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn run_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("eval-records-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    dir
}

fn eval(out: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_xtask"));
    command
        .args(["eval", "--agent", "expert", "--benchmark", "alfworld-seen", "--out"])
        .arg(out)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    command
}

/// The record lines of the run's one record file, times left out.
fn records(out: &Path) -> Vec<serde_json::Value> {
    let file = std::fs::read_dir(out)
        .expect("records folder")
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "jsonl"))
        .expect("a record file");
    std::fs::read_to_string(file)
        .expect("readable")
        .lines()
        .map(|line| {
            let mut record: serde_json::Value = serde_json::from_str(line).expect("whole records only");
            record.as_object_mut().expect("object").remove("millis");
            record
        })
        .collect()
}

#[test]
fn killed_runs_resume_to_exactly_the_records_of_an_uninterrupted_run() {
    let whole = run_dir("whole");
    assert!(eval(&whole).status().expect("runs").success());
    let expected = records(&whole);
    assert_eq!(expected.len(), 140);

    let killed = run_dir("killed");
    let mut interrupted = 0;
    // Kill after growing delays (a fixed sequence); each run gets further, and a run that
    // finishes before its kill ends the loop.
    for attempt in 0..40u64 {
        let mut child = eval(&killed).spawn().expect("starts");
        std::thread::sleep(Duration::from_millis(150 + 37 * attempt));
        match child.try_wait().expect("waits") {
            Some(status) => {
                assert!(status.success());
                break;
            }
            None => {
                child.kill().expect("SIGKILL");
                child.wait().expect("reaped");
                interrupted += 1;
            }
        }
    }
    // Whatever the kills left, a last run completes it.
    assert!(eval(&killed).status().expect("runs").success());
    assert!(interrupted >= 2, "only {interrupted} runs were killed mid-way");
    let got = records(&killed);
    assert_eq!(got.len(), expected.len(), "records lost or repeated");
    for (i, (a, b)) in got.iter().zip(&expected).enumerate() {
        assert_eq!(a, b, "record {i}");
    }
}

/// `--seeds`: one run per seed, each with its own record file named by its configuration, all
/// in the report as runs of one condition; an agent without a seed refuses the option.
#[test]
fn seeds_make_one_run_each() {
    let dir = run_dir("seeds");
    let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args([
            "eval",
            "--explorer",
            "systematic",
            "--lm",
            "uniform",
            "--mode",
            "sample",
            "--seeds",
            "0,42",
            "--benchmark",
            "alfworld-seen",
            "--time-limit",
            "5",
        ])
        .args(["--limit", "1", "--json", "--out"])
        .arg(&dir)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let (a, b) = (&summary["alfworld-seen seed 0"], &summary["alfworld-seen seed 42"]);
    assert_eq!((a["tasks"].as_u64(), b["tasks"].as_u64()), (Some(1), Some(1)), "{summary}");
    assert_ne!(a["config"], b["config"], "each seed is its own configuration");
    let files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("records")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
        .collect();
    assert_eq!(files.len(), 2, "{files:?}");
    for file in &files {
        let config: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(file.with_extension("config.json")).expect("config beside")).expect("JSON");
        assert!([0, 42].contains(&config["decode"]["seed"].as_u64().expect("a seed")), "{config}");
        // The agent's behaviour is part of the configuration: an older agent's records are another's.
        assert_eq!(config["harness"].as_u64(), Some(u64::from(exploration_harness::HARNESS_VERSION)), "{config}");
    }
    let report = std::fs::read_to_string(dir.join("report/report.md")).expect("the report");
    assert!(report.contains("alfworld-seen"), "{report}");

    let refused = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["eval", "--agent", "planner", "--explorer", "systematic", "--seeds", "0,42", "--out"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--seeds: the planner agent has no seed"));
    std::fs::remove_dir_all(&dir).ok();
}
