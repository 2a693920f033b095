//! The `--json` outputs other tools read, as snapshots: their fields, shapes and values on
//! fixed inputs. Times are redacted (`[millis]`); everything else is deterministic, so a
//! change to any field, a renamed key or a different plan fails here until the snapshot is
//! reviewed and accepted (`cargo insta review`, or `INSTA_UPDATE=always` and a look at the
//! diff).

mod common;

use common::xtask;
use serde_json::Value;

/// Runs xtask and parses its stdout as JSON (one object, or one per line).
fn json(args: &[&str]) -> Value {
    let output = xtask(args);
    assert!(matches!(output.status.code(), Some(0 | 1)), "{args:?}: {}", String::from_utf8_lossy(&output.stderr));
    let text = String::from_utf8_lossy(&output.stdout);
    match serde_json::from_str(&text) {
        Ok(value) => value,
        Err(_) => Value::Array(text.lines().map(|l| serde_json::from_str(l).expect("a JSON line")).collect()),
    }
}

const BLOCKS: [&str; 4] = ["--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", "fixtures/ipc/blocks/instance-10.pddl"];

#[test]
fn ground_json() {
    let value = json(&[&["ground"], &BLOCKS[..], &["--json"]].concat());
    insta::assert_json_snapshot!(value, { ".millis" => "[millis]" });
}

#[test]
fn heuristic_json() {
    insta::assert_json_snapshot!(json(&[&["heuristic"], &BLOCKS[..], &["--json"]].concat()));
}

#[test]
fn plan_json_classical_and_phase_two() {
    let astar = json(&[&["plan"], &BLOCKS[..], &["--planner", "astar", "--heuristic", "lmcut", "--json"]].concat());
    insta::assert_json_snapshot!("plan_astar_lmcut", astar, { ".millis" => "[millis]" });
    let mcts = json(&[&["plan"], &BLOCKS[..], &["--planner", "mcts", "--lm", "uniform", "--simulations", "400", "--json"]].concat());
    insta::assert_json_snapshot!("plan_mcts_uniform", mcts, { ".millis" => "[millis]", ".total_millis" => "[millis]" });
}

#[test]
fn env_json_lines_of_a_virtualhome_task() {
    let lines = json(&["env", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--json"]);
    insta::assert_json_snapshot!(lines);
}

#[test]
fn agent_json_of_a_rearrangement_episode() {
    let record = json(&["agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--json"]);
    insta::assert_json_snapshot!(record, {
        ".episode.phase2_detail.millis" => "[millis]",
        ".episode.phase1_ms" => "[millis]",
        ".episode.phase2_ms" => "[millis]",
        ".episode.execute_ms" => "[millis]",
    });
}
