//! The VirtualHome rearrangement set (`fixtures/virtualhome-rearrange/`, made by `cargo xtask
//! rearrange`): 50 tasks in each of the paper's four families, goals in EAI's notation over
//! novel object instances, and a reference program per task that executes at every step in
//! `VirtualhomeEnv` and reaches every goal (the real evolving graph's verdicts on the same
//! programs are in `executor.jsonl.gz`).

use std::collections::BTreeMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};

use household_sim::{Environment, Event, IdScope, Judge, VhGoal, VirtualhomeEnv, VirtualhomeTask};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-rearrange")
}

#[test]
fn every_task_has_a_reference_program_that_reaches_every_goal() {
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(dir()).unwrap().map(|e| e.unwrap().path()).filter(|p| p.to_string_lossy().ends_with(".json.gz")).collect();
    files.sort();
    let mut families: BTreeMap<String, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    for path in &files {
        let task = VirtualhomeTask::load(path).unwrap();
        let family = task.task_id.split('-').next().unwrap().to_string();
        *families.entry(family).or_default() += 1;
        assert!(!task.reference_program.is_empty(), "{}: no reference program", task.task_id);
        // Every goal names a node of the scene; objects go INSIDE the appliance.
        assert!(task.goals.iter().any(|g| matches!(g, VhGoal::Edge { .. })), "{}: no edge goal", task.task_id);
        let id = task.task_id.clone();
        let program = task.reference_program.clone();
        let mut env = VirtualhomeEnv::new(task, "virtualhome-rearrange").with_id_scope(IdScope::Any);
        env.reset();
        assert!(!env.goal_reached(), "{id}: the goal holds before any step");
        for line in &program {
            if let Event::NotExecuted { reason } = env.step(line).event {
                failures.push(format!("{id}: {line}: {reason}"));
                break;
            }
        }
        if !env.goal_reached() {
            failures.push(format!("{id}: goal not reached: {:?}", env.unmet_goals()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let expected: BTreeMap<String, usize> = ["dishwasher", "food", "fridge", "microwave"].iter().map(|f| (f.to_string(), 50)).collect();
    assert_eq!(families, expected);
}

#[test]
fn the_real_executor_reached_every_goal_with_the_reference_programs() {
    let mut text = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(dir().join("executor.jsonl.gz")).unwrap()).read_to_string(&mut text).unwrap();
    let rows: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), 200);
    for row in &rows {
        assert_eq!(row["gold_program_ok"], true, "{row}");
    }
}

/// The goal the agent is told names classes, never node ids, on every fixture task of both sets.
#[test]
fn goal_annotations_are_class_level() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    for folder in [root.join("virtualhome-eai/graphs"), dir()] {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if !path.to_string_lossy().ends_with(".json.gz") {
                continue;
            }
            let task = VirtualhomeTask::load(&path).unwrap();
            let goals = task.goals.len();
            let id = task.task_id.clone();
            let node_ids: Vec<u32> = task.init.graph.indices().map(|ix| task.init.graph.node(ix).id).collect();
            let env = VirtualhomeEnv::new(task, "virtualhome");
            let formula = &env.goal().formula;
            let value: serde_json::Value = serde_json::from_str(formula).unwrap_or_else(|e| panic!("{id}: {e}: {formula}"));
            let entries = value["goal"].as_array().unwrap().len() + value["actions"].as_array().unwrap().len();
            assert_eq!(entries, goals, "{id}: {formula}");
            for key in ["\"id\"", "from_id", "to_id"] {
                assert!(!formula.contains(key), "{id}: {formula}");
            }
            for number in formula.split(|c: char| !c.is_ascii_digit()).filter(|s| !s.is_empty()) {
                let n: u32 = number.parse().unwrap();
                assert!(!node_ids.contains(&n), "{id}: node id {n} in {formula}");
            }
        }
    }
}
