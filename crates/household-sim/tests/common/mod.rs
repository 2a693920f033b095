//! Shared by the ALFWorld parity tests: reading recorded engine traces and replaying them.

// Each test binary that includes this module uses a part of it.
#![allow(dead_code)]

use std::io::BufRead;
use std::path::{Path, PathBuf};

use household_sim::{AlfworldEnv, Environment, Judge};
use serde_json::Value;

pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// One trace: its game, name and recorded steps, in order.
pub struct Trace {
    pub game: String,
    pub name: String,
    pub steps: Vec<Value>,
}

pub fn read_traces(split: &str) -> Vec<Trace> {
    let path = fixtures().join("alfworld-traces").join(format!("{split}.jsonl.gz"));
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parse_traces(std::io::BufReader::new(flate2::read::GzDecoder::new(file)), &path.display().to_string())
}

/// Traces from JSON lines as tools/alfworld_record.py writes them.
pub fn parse_traces(reader: impl BufRead, path: &str) -> Vec<Trace> {
    let mut traces: Vec<Trace> = Vec::new();
    for (number, line) in reader.lines().enumerate() {
        let line = line.unwrap_or_else(|e| panic!("{}:{}: {e}", path, number + 1));
        let value: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{}:{}: {e}", path, number + 1));
        let game = value["game"].as_str().expect("game").to_string();
        let name = value["trace"].as_str().expect("trace").to_string();
        let step = value["step"].as_u64().expect("step");
        match traces.last_mut() {
            Some(t) if t.game == game && t.name == name && step > 0 => t.steps.push(value),
            _ => {
                assert_eq!(step, 0, "{}:{}: a trace starts at step 0", path, number + 1);
                traces.push(Trace { game, name, steps: vec![value] })
            }
        }
    }
    traces
}

/// Where two texts first differ, with some context, for a readable failure.
pub fn diff(ours: &str, engine: &str) -> String {
    let at = ours.chars().zip(engine.chars()).take_while(|(a, b)| a == b).count();
    let window = |s: &str| s.chars().skip(at.saturating_sub(40)).take(120).collect::<String>();
    format!("first difference at character {at}:\n    ours:   {:?}\n    engine: {:?}", window(ours), window(engine))
}

pub fn strings(value: &Value) -> Vec<String> {
    value.as_array().expect("a list").iter().map(|v| v.as_str().expect("a string").to_string()).collect()
}

/// What a replay found: counts of identical games, traces and steps, and the first few
/// mismatches (a trace stops at its first mismatch: the rest follows from another state).
#[derive(Debug, Default)]
pub struct Replay {
    pub games: usize,
    pub identical_games: usize,
    pub traces: usize,
    pub identical_traces: usize,
    /// Steps recorded (a trace stops replaying at its first mismatch).
    pub recorded_steps: usize,
    pub identical_steps: usize,
    pub failures: Vec<String>,
}

/// Replays `traces` in [`AlfworldEnv`]; `game_dir` maps a trace's game to its folder.
pub fn replay(traces: &[Trace], game_dir: impl Fn(&str) -> PathBuf) -> Replay {
    let mut by_game: std::collections::BTreeMap<&str, Vec<&Trace>> = std::collections::BTreeMap::new();
    for trace in traces {
        by_game.entry(&trace.game).or_default().push(trace);
    }
    let (mut identical_steps, mut identical_traces) = (0usize, 0usize);
    let mut identical_games = 0usize;
    let mut failures = Vec::new();
    for (game, game_traces) in &by_game {
        let path = game_dir(game);
        let mut env = AlfworldEnv::from_game_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut game_ok = true;
        for trace in game_traces {
            let mut trace_ok = true;
            for recorded in &trace.steps {
                let step = recorded["step"].as_u64().expect("step");
                let observation =
                    if step == 0 { env.reset().text } else { env.step(recorded["command"].as_str().expect("command")).observation.text };
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
    Replay {
        games: by_game.len(),
        identical_games,
        traces: traces.len(),
        identical_traces,
        recorded_steps: traces.iter().map(|t| t.steps.len()).sum(),
        identical_steps,
        failures,
    }
}
