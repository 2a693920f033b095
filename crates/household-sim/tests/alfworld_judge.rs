//! The judge sees what the agent cannot: the hidden state and what the goal still lacks.

use std::path::Path;

use household_sim::{AlfworldEnv, Environment, Judge};

#[test]
fn the_judge_reports_unmet_goal_literals_until_the_walkthrough_wins() {
    let game = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802");
    let mut env = AlfworldEnv::from_game_file(&game).expect("fixture loads");
    assert_eq!(env.goal().family, "pick_clean_then_place_in_recep");
    assert_eq!(env.goal().sentence, "clean some mug and put it in coffeemachine.");
    assert!(env.goal().formula.contains("(isClean ?o)"), "{}", env.goal().formula);
    env.reset();
    let unmet = env.unmet_goals();
    assert!(!unmet.is_empty());
    assert!(unmet.iter().any(|u| u.contains("isclean")), "{unmet:?}");
    let atoms = env.hidden_atoms();
    assert_eq!(atoms.iter().filter(|a| a.predicate == "atlocation").count(), 1, "the agent is at one place");
    assert!(atoms.iter().any(|a| a.predicate == "inreceptacle" && a.args.iter().any(|x| x.starts_with("mug "))));
    for command in env.walkthrough().to_vec() {
        assert!(env.step(&command).event.executed(), "{command}");
    }
    assert!(env.goal_reached());
    assert!(env.unmet_goals().is_empty());
}
