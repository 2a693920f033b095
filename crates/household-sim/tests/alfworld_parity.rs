//! Parity with the real ALFWorld engine: every recorded trace in `fixtures/alfworld-traces/`
//! (TextWorld 1.7.0 + alfworld 0.4.2, recorded by `tools/alfworld_record.py`) replayed in
//! [`AlfworldEnv`]; at every step the observation text, the admissible list (same order) and
//! the won flag must be the engine's.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use household_sim::{AlfworldEnv, Environment};
use serde_json::Value;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// One trace: its game, name and recorded steps, in order.
struct Trace {
    game: String,
    name: String,
    steps: Vec<Value>,
}

fn read_traces(split: &str) -> Vec<Trace> {
    let path = fixtures().join("alfworld-traces").join(format!("{split}.jsonl.gz"));
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = BufReader::new(flate2::read::GzDecoder::new(file));
    let mut traces: Vec<Trace> = Vec::new();
    for (number, line) in reader.lines().enumerate() {
        let line = line.unwrap_or_else(|e| panic!("{}:{}: {e}", path.display(), number + 1));
        let value: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{}:{}: {e}", path.display(), number + 1));
        let game = value["game"].as_str().expect("game").to_string();
        let name = value["trace"].as_str().expect("trace").to_string();
        let step = value["step"].as_u64().expect("step");
        match traces.last_mut() {
            Some(t) if t.game == game && t.name == name && step > 0 => t.steps.push(value),
            _ => {
                assert_eq!(step, 0, "{}:{}: a trace starts at step 0", path.display(), number + 1);
                traces.push(Trace { game, name, steps: vec![value] })
            }
        }
    }
    traces
}

/// Where two texts first differ, with some context, for a readable failure.
fn diff(ours: &str, engine: &str) -> String {
    let at = ours.chars().zip(engine.chars()).take_while(|(a, b)| a == b).count();
    let window = |s: &str| s.chars().skip(at.saturating_sub(40)).take(120).collect::<String>();
    format!("first difference at character {at}:\n    ours:   {:?}\n    engine: {:?}", window(ours), window(engine))
}

fn strings(value: &Value) -> Vec<String> {
    value.as_array().expect("a list").iter().map(|v| v.as_str().expect("a string").to_string()).collect()
}

fn check_split(split: &str) {
    let traces = read_traces(split);
    assert!(!traces.is_empty(), "no traces for {split}");
    let mut by_game: BTreeMap<&str, Vec<&Trace>> = BTreeMap::new();
    for trace in &traces {
        by_game.entry(&trace.game).or_default().push(trace);
    }
    let (mut steps, mut identical_steps, mut identical_traces) = (0usize, 0usize, 0usize);
    let mut identical_games = 0usize;
    let mut failures = Vec::new();
    for (game, game_traces) in &by_game {
        let path = fixtures().join("alfworld").join(game);
        let mut env = AlfworldEnv::from_game_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut game_ok = true;
        for trace in game_traces {
            let mut trace_ok = true;
            for recorded in &trace.steps {
                steps += 1;
                let step = recorded["step"].as_u64().expect("step");
                let observation = if step == 0 {
                    env.reset().text
                } else {
                    env.step(recorded["command"].as_str().expect("command")).observation.text
                };
                let admissible = env.admissible_commands().expect("ALFWorld lists admissible commands");
                let mut problems = Vec::new();
                let want = recorded["observation"].as_str().expect("observation");
                if observation != want {
                    problems.push(format!("observation differs, {}", diff(&observation, want)));
                }
                let want = strings(&recorded["admissible"]);
                if admissible != want {
                    let missing: Vec<_> = want.iter().filter(|c| !admissible.contains(c)).collect();
                    let extra: Vec<_> = admissible.iter().filter(|c| !want.contains(c)).collect();
                    problems.push(format!("admissible differs: missing {missing:?}, extra {extra:?}"));
                }
                if env.goal_reached() != recorded["won"].as_bool().expect("won") {
                    problems.push(format!("won: ours {}, engine {}", env.goal_reached(), !env.goal_reached()));
                }
                if problems.is_empty() {
                    identical_steps += 1;
                } else {
                    trace_ok = false;
                    if failures.len() < 20 {
                        let command = recorded.get("command").and_then(Value::as_str).unwrap_or("(reset)");
                        failures.push(format!("{game} [{}] step {step} `{command}`: {}", trace.name, problems.join("; ")));
                    }
                    // The rest of this trace follows from a different state: skip it.
                    break;
                }
            }
            identical_traces += usize::from(trace_ok);
            game_ok &= trace_ok;
        }
        identical_games += usize::from(game_ok);
    }
    println!(
        "{split}: games {identical_games}/{} identical, traces {identical_traces}/{}, steps {identical_steps}/{steps} (steps after a mismatch are not replayed)",
        by_game.len(),
        traces.len()
    );
    assert!(failures.is_empty(), "{split}: mismatches with the engine:\n{}", failures.join("\n"));
}

#[test]
fn valid_seen_traces_match_the_engine_at_every_step() {
    check_split("valid_seen");
}

#[test]
fn valid_train_traces_match_the_engine_at_every_step() {
    check_split("valid_train");
}
