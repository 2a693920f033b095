//! Parity with the real evolving graph: every recorded program (EAI's gold program and five
//! seeded random programs per kitchen task, `tools/virtualhome_record.py`) must execute and
//! fail at the same steps and reach the same goal verdict in `VirtualhomeEnv`. With the
//! feature `live-virtualhome`, also records fresh programs on tasks outside the fixtures with
//! the installed executor and compares them the same way.

use std::io::Read as _;
use std::path::{Path, PathBuf};

use household_sim::{Environment, IdScope, Judge, VirtualhomeEnv, VirtualhomeTask};
use serde::Deserialize;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai")
}

/// Programs on which we knowingly differ, with why. `task 721_2 random-1`: GRAB of a drawing
/// that rests on nothing; the executor records (and walks CLOSE to) the first non-room node of
/// its CLOSE set in CPython's set iteration order (freezer 289), ours the lowest node, so a
/// later PUSH of the freezer is close for the executor only.
const KNOWN_DIVERGENCES: &[&str] = &["task 721_2 random-1 "];

#[derive(Deserialize)]
struct Recorded {
    task: String,
    program: String,
    lines: Vec<String>,
    executed: Vec<bool>,
    messages: Vec<String>,
    goal: bool,
    unmet: Vec<String>,
}

fn read_records(path: &Path) -> Vec<Recorded> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut text = String::new();
    flate2::read::GzDecoder::new(&bytes[..]).read_to_string(&mut text).expect("gzip");
    text.lines().map(|l| serde_json::from_str(l).expect("record line")).collect()
}

/// Replays every record in its task and returns (agreeing programs, disagreement reports).
fn compare(records: &[Recorded], task_dir: &Path) -> (usize, Vec<String>) {
    let mut agree = 0;
    let mut reports = Vec::new();
    let mut cache: Vec<(String, VirtualhomeTask)> = Vec::new();
    for record in records {
        let task = match cache.iter().find(|(id, _)| *id == record.task) {
            Some((_, task)) => task.clone(),
            None => {
                let task = VirtualhomeTask::load(&task_dir.join(format!("{}.json.gz", record.task))).expect("task file");
                cache.push((record.task.clone(), task.clone()));
                task
            }
        };
        let mut env = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
        env.reset();
        let mut mismatch = None;
        for (i, line) in record.lines.iter().enumerate() {
            let result = env.step(line);
            if result.event.executed() != record.executed[i] && mismatch.is_none() {
                mismatch = Some(format!(
                    "task {} {} step {} {line}: executor {} ({}), ours {:?}",
                    record.task,
                    record.program,
                    i + 1,
                    record.executed[i],
                    record.messages[i],
                    result.event
                ));
            }
        }
        if mismatch.is_none() && env.goal_reached() != record.goal {
            mismatch = Some(format!(
                "task {} {}: goal executor {} (unmet {:?}), ours {} (unmet {:?})",
                record.task,
                record.program,
                record.goal,
                record.unmet,
                env.goal_reached(),
                env.unmet_goals()
            ));
        }
        match mismatch {
            None => agree += 1,
            Some(report) => reports.push(report),
        }
    }
    (agree, reports)
}

#[test]
fn every_recorded_program_agrees_with_the_evolving_graph() {
    let records = read_records(&fixtures().join("parity/programs.jsonl.gz"));
    let (agree, reports) = compare(&records, &fixtures().join("graphs"));
    let unexpected: Vec<&String> = reports.iter().filter(|r| !KNOWN_DIVERGENCES.iter().any(|k| r.starts_with(k))).collect();
    assert!(unexpected.is_empty(), "{} of {} programs disagree:\n{}", reports.len(), records.len(), reports.join("\n"));
    assert_eq!(reports.len(), KNOWN_DIVERGENCES.len(), "a known divergence went away: update KNOWN_DIVERGENCES\n{reports:?}");
    assert_eq!(agree + KNOWN_DIVERGENCES.len(), records.len());
    // 33 kitchen tasks × (gold + 5 random programs).
    assert_eq!(records.len(), 33 * 6, "recorded programs");
    let gold_reaching = records.iter().filter(|r| r.program == "gold" && r.goal).count();
    assert_eq!(gold_reaching, 33, "every kitchen gold program reaches its goal in the executor");
    let steps: Vec<bool> = records.iter().flat_map(|r| r.executed.iter().copied()).collect();
    assert!(steps.iter().any(|e| !e) && steps.iter().filter(|e| **e).count() > 33 * 10, "both outcomes exercised");
}

#[cfg(feature = "live-virtualhome")]
#[test]
fn live_executor_agrees_on_tasks_outside_the_fixtures() {
    use std::process::Command;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let tmp = std::env::temp_dir().join(format!("vh-live-{}", std::process::id()));
    let tasks = tmp.join("tasks");
    let tool = root.join("tools/virtualhome_record.py");
    // Tasks of other categories (watch TV, drink, read, light, sofa, wash clothes): not in fixtures/.
    let sample = "1057_1,1064_1,1073_1,11_1,124_1,27_2";
    let status = Command::new("python3").arg(&tool).args(["export"]).arg(&tasks).args(["--tasks", sample]).status().expect("python3");
    assert!(status.success(), "export failed: is the executor installed (install.sh virtualhome)?");
    let out = tmp.join("programs.jsonl.gz");
    let status = Command::new("python3").arg(&tool).arg("record").arg(&tasks).arg(&out).args(["--random", "3"]).status().expect("python3");
    assert!(status.success(), "record failed");
    let records = read_records(&out);
    assert_eq!(records.len(), 6 * 4);
    let (agree, reports) = compare(&records, &tasks);
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(reports.is_empty(), "{} of {} programs disagree:\n{}", reports.len(), records.len(), reports.join("\n"));
    assert_eq!(agree, records.len());
}
