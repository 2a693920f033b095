//! Parity with the real ALFWorld engine: every recorded trace in `fixtures/alfworld-traces/`
//! (TextWorld 1.7.0 + alfworld 0.4.2, recorded by `tools/alfworld_record.py`) replayed in
//! [`AlfworldEnv`]; at every step the observation text, the admissible list (same order) and
//! the won flag must be the engine's.

mod common;

use common::{fixtures, read_traces, replay, strings};
use household_sim::PythonRandom;

fn check_split(split: &str) {
    let traces = read_traces(split);
    assert!(!traces.is_empty(), "no traces for {split}");
    let r = replay(&traces, |game| fixtures().join("alfworld").join(game));
    println!(
        "{split}: games {}/{} identical, traces {}/{}, steps {}/{} recorded",
        r.identical_games, r.games, r.identical_traces, r.traces, r.identical_steps, r.recorded_steps
    );
    assert!(r.failures.is_empty(), "{split}: mismatches with the engine:\n{}", r.failures.join("\n"));
}

#[test]
fn valid_seen_traces_match_the_engine_at_every_step() {
    check_split("valid_seen");
}

#[test]
fn valid_train_traces_match_the_engine_at_every_step() {
    check_split("valid_train");
}

/// `cargo xtask env --random N --seed S` draws what `alfworld_trace.py --random N --seed S`
/// draws: Python's `random.Random(S).choice` over the sorted admissible list.
#[test]
fn seeded_random_walks_draw_the_engines_commands() {
    let mut walks = 0;
    for split in ["valid_seen", "valid_train"] {
        for trace in read_traces(split) {
            let Some(seed) = trace.name.strip_prefix("random-").and_then(|r| r.split_once("-seed-")).map(|(_, s)| s) else {
                continue;
            };
            let mut rng = PythonRandom::new(seed.parse().expect("a numeric seed"));
            for pair in trace.steps.windows(2) {
                let mut admissible = strings(&pair[0]["admissible"]);
                admissible.sort();
                let drawn = &admissible[rng.choice_index(admissible.len())];
                assert_eq!(drawn, pair[1]["command"].as_str().expect("command"), "{} [{}]", trace.game, trace.name);
            }
            walks += 1;
        }
    }
    assert!(walks > 0);
}
