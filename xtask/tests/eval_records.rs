//! `kill -9` at any moment, then resume: the records are exactly those of an uninterrupted run,
//! none lost, none twice (`eval-harness::records`, through `cargo xtask eval`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// A records folder that does not exist yet (`eval` makes it), inside a temporary folder that
/// is removed when the returned guard is dropped, also when the test fails.
fn run_dir(name: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::Builder::new().prefix("eval-records-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    (tmp, dir)
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
    records_of(&file)
}

/// The record lines of `file`, times left out.
fn records_of(file: &Path) -> Vec<serde_json::Value> {
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
    let (_tmp_whole, whole) = run_dir("whole");
    assert!(eval(&whole).status().expect("runs").success());
    let expected = records(&whole);
    assert_eq!(expected.len(), 140);
    // The replay's configuration carries its own version (it runs no exploration harness).
    let config = std::fs::read_dir(&whole)
        .expect("records folder")
        .flatten()
        .map(|e| e.path())
        .find(|p| p.to_string_lossy().ends_with(".config.json"))
        .expect("the configuration");
    let config: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(config).expect("readable")).expect("JSON");
    assert!(config["replay"].is_u64() && config.get("harness").is_none(), "{config}");

    let (_tmp_killed, killed) = run_dir("killed");
    // Whole records in the file so far (a killed run may leave a torn last line after them).
    let recorded = |out: &Path| -> usize {
        std::fs::read_dir(out)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .find(|p| p.extension().is_some_and(|e| e == "jsonl"))
            .and_then(|file| std::fs::read(file).ok())
            .map_or(0, |bytes| bytes.iter().filter(|&&b| b == b'\n').count())
    };
    let mut interrupted = 0;
    let mut last = 0;
    // Each run is killed once it has recorded something new, a few milliseconds later (a fixed
    // sequence, so kills land at varying points of a record's write): by progress, not by the
    // clock, so every kill lands mid-run on any machine. A run that finishes ends the loop.
    for attempt in 0..40u64 {
        let mut child = eval(&killed).spawn().expect("starts");
        let finished = loop {
            if let Some(status) = child.try_wait().expect("waits") {
                break Some(status);
            }
            if recorded(&killed) > last {
                break None;
            }
            std::thread::sleep(Duration::from_millis(2));
        };
        if let Some(status) = finished {
            assert!(status.success());
            break;
        }
        std::thread::sleep(Duration::from_millis(attempt % 7 * 3));
        child.kill().expect("SIGKILL");
        child.wait().expect("reaped");
        interrupted += 1;
        let now = recorded(&killed);
        assert!(now > last && now <= expected.len(), "the killed run recorded {now} after {last}");
        last = now;
    }
    // Whatever the kills left, a last run completes it.
    assert!(eval(&killed).status().expect("runs").success());
    assert!(interrupted >= 2, "only {interrupted} runs were killed mid-way ({last} records)");
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
    let (_tmp_dir, dir) = run_dir("seeds");
    let run = |limit: &str| {
        Command::new(env!("CARGO_BIN_EXE_xtask"))
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
            .args(["--limit", limit, "--json", "--out"])
            .arg(&dir)
            .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
            .output()
            .expect("runs")
    };
    let output = run("1");
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

    // Every seed's file is checked before any task runs: with seed 42's damaged, a longer run
    // is refused at once, and seed 0's file gets no record first.
    let seed_of = |file: &PathBuf| {
        let config: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(file.with_extension("config.json")).expect("config")).expect("JSON");
        config["decode"]["seed"].as_u64()
    };
    let zero = files.iter().find(|f| seed_of(f) == Some(0)).expect("seed 0's records");
    let forty_two = files.iter().find(|f| seed_of(f) == Some(42)).expect("seed 42's records");
    let mut damaged = std::fs::read_to_string(forty_two).expect("reads");
    damaged.push_str("not a record\n");
    std::fs::write(forty_two, damaged).expect("writes");
    let before = std::fs::read(zero).expect("reads");
    let output = run("2");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("{}:2", forty_two.display())), "{stderr}");
    assert!(std::fs::read(zero).expect("reads") == before, "refused before seed 0 ran a task");

    let refused = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["eval", "--agent", "planner", "--explorer", "systematic", "--seeds", "0,42", "--out"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--seeds: the planner agent has no seed"));
}

/// Shards run into one records folder: each writes the report of its own records into a folder
/// of its own (none overwrites another's, none is taken for the whole run's), and the merged
/// shards are the records of one unsharded run.
#[test]
fn shards_report_apart_and_merge_to_the_records_of_one_run() {
    let (_tmp_dir, dir) = run_dir("shards");
    for (shard, tasks) in [("1/2", 3), ("2/2", 2)] {
        let output = eval(&dir).args(["--limit", "5", "--json", "--shard", shard]).stdout(Stdio::piped()).output().expect("runs");
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value = serde_json::from_str(String::from_utf8_lossy(&output.stdout).trim()).expect("one JSON object");
        assert_eq!(summary["alfworld-seen"]["tasks"].as_u64(), Some(tasks), "{summary}");
        let folder = dir.join(format!("report-shard-{}", shard.replace('/', "-of-")));
        assert_eq!(summary["report"].as_str().map(PathBuf::from), Some(folder.join("index.html")));
        let markdown = std::fs::read_to_string(folder.join("report.md")).expect("the shard's report");
        assert!(markdown.contains(&format!("(n={tasks})")), "{shard}: {markdown}");
    }
    assert!(!dir.join("report").exists(), "no shard writes the whole run's report");

    let shards: Vec<PathBuf> =
        std::fs::read_dir(&dir).expect("records").flatten().map(|e| e.path()).filter(|p| p.to_string_lossy().ends_with(".jsonl")).collect();
    assert_eq!(shards.len(), 2, "{shards:?}");
    // Five of the run's 140 tasks: shards short of the run's tasks merge only when asked to.
    let short = Command::new(env!("CARGO_BIN_EXE_xtask")).arg("merge").args(&shards).output().expect("runs");
    let stderr = String::from_utf8_lossy(&short.stderr);
    assert_eq!(short.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("5 of the run's 140 tasks recorded"), "{stderr}");
    let merged = Command::new(env!("CARGO_BIN_EXE_xtask")).args(["merge", "--partial"]).args(&shards).output().expect("runs");
    let stderr = String::from_utf8_lossy(&merged.stderr);
    assert!(merged.status.success(), "{stderr}");
    assert!(
        stderr.contains("135 of the run's tasks are not recorded: `eval` with the run's options, without --shard and without --limit"),
        "{stderr}"
    );
    // "N records of configuration C -> PATH"
    let stdout = String::from_utf8_lossy(&merged.stdout);
    let path = stdout.trim().rsplit(" -> ").next().expect("the merged file");

    let (_tmp_whole, whole) = run_dir("whole");
    assert!(eval(&whole).args(["--limit", "5"]).status().expect("runs").success());
    assert_eq!(records_of(Path::new(path)), records(&whole), "the merged shards are the unsharded run's records");

    // A merged run's shard resumed with tasks left would leave the merged file stale: refused,
    // the shard left as it was; with nothing left to run it only reports again.
    let first = shards.iter().find(|p| p.to_string_lossy().ends_with(".shard-1-of-2.jsonl")).expect("shard 1");
    let before = std::fs::read(first).expect("the shard");
    let resumed = eval(&dir).args(["--limit", "7", "--shard", "1/2"]).stderr(Stdio::piped()).output().expect("runs");
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert_eq!(resumed.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("1 task(s) of this shard are left to run") && stderr.contains(path), "{stderr}");
    assert!(std::fs::read(first).expect("the shard") == before, "a refused resume writes nothing");
    // Started over (--fresh), every task of the shard is left: refused too, its records kept.
    let fresh = eval(&dir).args(["--limit", "5", "--shard", "1/2", "--fresh"]).stderr(Stdio::piped()).output().expect("runs");
    let stderr = String::from_utf8_lossy(&fresh.stderr);
    assert_eq!(fresh.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("3 task(s) of this shard are left to run"), "{stderr}");
    assert!(std::fs::read(first).expect("the shard") == before, "a refused fresh start deletes nothing");
    let again = eval(&dir).args(["--limit", "5", "--shard", "1/2"]).stderr(Stdio::piped()).output().expect("runs");
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
}
