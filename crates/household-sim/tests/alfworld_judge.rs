//! The judge sees what the agent cannot: the hidden state and what the goal still lacks.

use std::path::Path;

use household_sim::{AlfworldEnv, EngineLine, Environment, Judge};

fn mug_game() -> AlfworldEnv {
    let game = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802");
    AlfworldEnv::from_game_file(&game).expect("fixture loads")
}

#[test]
fn the_judge_reports_unmet_goal_literals_until_the_walkthrough_wins() {
    let mut env = mug_game();
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

#[test]
fn the_engine_script_holds_every_command_as_sent_with_its_outcome() {
    let mut env = mug_game();
    env.reset();
    let first = env.walkthrough()[0].clone();
    for command in ["fly to the moon", &format!("  {first} "), "look", "take mug 99 from desk 1"] {
        env.step(command);
    }
    let line = |line: &str, executed: bool| EngineLine { line: line.to_string(), executed };
    assert_eq!(
        env.engine_script(),
        vec![
            line("fly to the moon", false),
            line(&format!("  {first} "), true),
            line("look", true),
            line("take mug 99 from desk 1", false)
        ]
    );
    env.reset();
    assert_eq!(env.engine_script(), vec![]);
}

/// Once the game is won, the engine takes no command, as TextWorld 1.7.0 does (checked on
/// `look_at_obj_in_light-AlarmClock-None-DeskLamp-323`: after the winning `take`, `look`, `go to
/// desk 1` and `take the moon` each got the winning step's observation, and the move count stayed
/// 3): the last observation again, no step counted, no line in the engine script, no change.
#[test]
fn after_the_win_the_engine_takes_no_command() {
    let mut env = mug_game();
    env.reset();
    let mut last = String::new();
    for command in env.walkthrough().to_vec() {
        last = env.step(&command).observation.text;
    }
    assert!(env.done());
    let (steps, script, atoms) = (env.steps_taken(), env.engine_script().len(), env.hidden_atoms());
    for command in ["look", "go to countertop 1", "take the moon"] {
        let after = env.step(command);
        assert_eq!(after.observation.text, last, "{command}");
        assert!(!after.event.executed(), "{command}");
    }
    assert_eq!((env.steps_taken(), env.engine_script().len()), (steps, script));
    assert_eq!(env.hidden_atoms(), atoms);
    assert!(env.goal_reached());
}
