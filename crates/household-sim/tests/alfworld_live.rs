//! The live engine as referee (feature `live-engine`; needs `../shared/anchors/install.sh
//! alfworld`): random walks on games and seeds that are not in `fixtures/alfworld-traces/`,
//! recorded now by the real, unpatched TextWorld engine (`tools/alfworld_record.py
//! --unpatched`, whose lines are alfworld_trace.py's) and replayed in `AlfworldEnv`, which
//! must show the same text, admissible list and won flag at every step.
#![cfg(feature = "live-engine")]

mod common;

use std::process::Command;

use common::{fixtures, parse_traces, replay};

#[test]
fn random_walks_with_new_seeds_match_the_live_engine() {
    // One game of each task type across both splits (the middle one), seed 1000, 30 steps:
    // the unpatched engine takes about 0.2 s a step and 5 s a reset here, and CI runs this.
    let mut games: Vec<String> = Vec::new();
    for task_type in household_sim::TASK_TYPES {
        let mut of_type: Vec<String> = Vec::new();
        for split in ["valid_seen", "valid_train"] {
            let dir = fixtures().join("alfworld").join(split);
            for entry in std::fs::read_dir(&dir).expect("fixtures").flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if name.starts_with(&format!("{task_type}-")) {
                    for trial in std::fs::read_dir(entry.path()).expect("trial folders").flatten() {
                        of_type.push(format!("{split}/{name}/{}", trial.file_name().to_string_lossy()));
                    }
                }
            }
        }
        of_type.sort();
        games.push(of_type[of_type.len() / 2].clone());
    }
    let scratch = std::env::temp_dir().join(format!("alfworld-live-{}.jsonl", std::process::id()));
    let _ = std::fs::remove_file(&scratch);
    let root = fixtures().join("alfworld");
    let seeds = ["1000"];
    let status = Command::new("python3")
        .arg(fixtures().join("../tools/alfworld_record.py"))
        .args([root.as_os_str(), scratch.as_os_str()])
        .args(games.iter().map(|g| root.join(g)))
        .args(["--random", "30", "--seeds", &seeds.join(","), "--unpatched", "--no-walkthrough"])
        .status()
        .expect("python3 runs");
    assert!(status.success(), "the engine failed: install it with `bash ../shared/anchors/install.sh alfworld`");
    let text = std::fs::read_to_string(&scratch).expect("the recorder wrote its traces");
    let _ = std::fs::remove_file(&scratch);
    let traces = parse_traces(text.as_bytes(), "live engine");
    assert_eq!(traces.len(), games.len() * seeds.len());
    let r = replay(&traces, |game| root.join(game));
    println!(
        "live engine: games {}/{} identical, traces {}/{}, steps {}/{}",
        r.identical_games, r.games, r.identical_traces, r.traces, r.identical_steps, r.recorded_steps
    );
    assert!(r.failures.is_empty(), "mismatches with the live engine:\n{}", r.failures.join("\n"));
}
