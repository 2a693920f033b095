//! The goal parser on every task in fixtures/: ALFWorld's 340 games, EAI's 33 kitchen tasks
//! and the 200 rearrangement tasks, each goal at class level as an insta snapshot (one line a
//! task), and the laws every parse obeys.

use std::path::{Path, PathBuf};

use exploration_harness::{ClassGoal, parse_goal};
use household_sim::{AlfworldEnv, Environment, VirtualhomeEnv, VirtualhomeTask};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn files(dir: &Path, suffix: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.to_string_lossy().ends_with(suffix) {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Every object symbol of the goal has a class (a receptacle may be any: the lamp's table in
/// ALFWorld's look-at tasks); every literal's arguments are symbols.
fn check_laws(task: &str, goal: &ClassGoal) {
    for s in &goal.symbols {
        if s.kind == "object" {
            assert!(s.class.is_some(), "{task}: {} has no class: {goal}", s.name);
        }
    }
    for l in &goal.literals {
        for a in &l.args {
            assert!(goal.symbols.iter().any(|s| &s.name == a), "{task}: {a} is not a symbol: {goal}");
        }
    }
    assert!(!goal.literals.is_empty() || !goal.actions.is_empty() || goal.benchmark.starts_with("virtualhome"), "{task}: empty goal");
}

#[test]
fn alfworld_goals_at_class_level() {
    for split in ["valid_seen", "valid_train"] {
        let mut lines = Vec::new();
        for path in files(&fixtures().join("alfworld").join(split), "game.tw-pddl") {
            let env = AlfworldEnv::from_game_file(&path).unwrap();
            let goal = parse_goal(env.goal()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let task = path.parent().unwrap().strip_prefix(fixtures().join("alfworld").join(split)).unwrap().display().to_string();
            check_laws(&task, &goal);
            assert_eq!(goal.family, env.goal().family);
            lines.push(format!("{task} [{}]: {goal}", goal.family));
        }
        assert_eq!(lines.len(), if split == "valid_seen" { 140 } else { 200 });
        insta::assert_snapshot!(format!("alfworld_{split}"), lines.join("\n"));
    }
}

#[test]
fn virtualhome_goals_at_class_level() {
    for (name, dir) in [
        ("virtualhome_eai", fixtures().join("virtualhome-eai/graphs")),
        ("virtualhome_rearrange", fixtures().join("virtualhome-rearrange")),
    ] {
        let mut lines = Vec::new();
        for path in files(&dir, ".json.gz") {
            let task = VirtualhomeTask::load(&path).unwrap();
            let id = task.task_id.clone();
            let env = VirtualhomeEnv::new(task, "virtualhome");
            let goal = parse_goal(env.goal()).unwrap_or_else(|e| panic!("{id}: {e}"));
            check_laws(&id, &goal);
            lines.push(format!("{id} [{}]: {goal}", goal.family));
        }
        insta::assert_snapshot!(name, lines.join("\n"));
    }
}

#[test]
fn instance_identifiers_and_other_connectives_are_refused() {
    let annotation = |benchmark: &str, formula: &str| household_sim::GoalAnnotation {
        benchmark: benchmark.into(),
        sentence: String::new(),
        formula: formula.into(),
        family: String::new(),
    };
    let instance = parse_goal(&annotation("alfworld", "(exists (?o - object) (and (objectType ?o MugType) (inReceptacle ?o Cabinet_1)))"));
    assert!(matches!(instance, Err(exploration_harness::GoalError::Instance { .. })), "{instance:?}");
    let disjunction = parse_goal(&annotation("alfworld", "(or (isClean ?o) (isHot ?o))"));
    assert!(matches!(disjunction, Err(exploration_harness::GoalError::Unsupported { .. })), "{disjunction:?}");
    let ids = parse_goal(&annotation("virtualhome", r#"{"goal": [{"from_id": 1, "relation_type": "ON", "to_id": 2}], "actions": []}"#));
    assert!(matches!(ids, Err(exploration_harness::GoalError::Instance { .. })), "{ids:?}");
    let garbage = parse_goal(&annotation("virtualhome", "not json"));
    assert!(matches!(garbage, Err(exploration_harness::GoalError::Unreadable { .. })), "{garbage:?}");
}

/// EAI 120_1, "turn on the lights" of the kitchen and the living room: its goal gives two lights
/// each `ON` and `PLUGGED_IN`. A node goal repeated at class level stands for another instance,
/// as a repeated edge goal does, so G asks for two lights, each with both states.
#[test]
fn a_repeated_node_goal_stands_for_another_instance_of_its_class() {
    let annotation = household_sim::GoalAnnotation {
        benchmark: "virtualhome-eai".into(),
        sentence: "Go to the kitchen and living room and turn on the lights.".into(),
        formula: r#"{"goal": [{"class_name": "light", "state": "ON"}, {"class_name": "light", "state": "PLUGGED_IN"},
            {"class_name": "light", "state": "ON"}, {"class_name": "light", "state": "PLUGGED_IN"},
            {"from": "character", "relation_type": "FACING", "to": "light"}], "actions": []}"#
            .into(),
        family: "Turn on light".into(),
    };
    let goal = parse_goal(&annotation).unwrap();
    check_laws("120_1", &goal);
    assert_eq!(
        goal.to_string(),
        "light: object light, light_2: object light, character: character character | on(light), plugged_in(light), on(light_2), \
         plugged_in(light_2), facing(character, light)"
    );
}
