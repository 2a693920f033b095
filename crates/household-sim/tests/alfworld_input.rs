//! Bad input never panics: malformed games give errors that name the file and the field or
//! line; any command text is either executed or answered "Nothing happens." with nothing
//! changed.

use std::path::{Path, PathBuf};

use household_sim::{AlfworldEnv, EnvError, Environment, Event, Judge, NOTHING_HAPPENS};
use proptest::prelude::*;

fn game_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802/game.tw-pddl")
}

fn game_json() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(game_path()).expect("fixture")).expect("json")
}

fn load(value: &serde_json::Value) -> Result<AlfworldEnv, EnvError> {
    AlfworldEnv::from_game_json(&value.to_string(), "test.tw-pddl", "")
}

#[test]
fn a_missing_key_is_named() {
    for key in ["pddl_domain", "pddl_problem", "grammar"] {
        let mut game = game_json();
        game.as_object_mut().expect("object").remove(key);
        let error = load(&game).expect_err("a game without its {key}");
        assert_eq!(error.to_string(), format!("test.tw-pddl: the game has no string field `{key}`"));
    }
}

#[test]
fn malformed_json_names_line_and_column() {
    let error = AlfworldEnv::from_game_json("{\n  \"grammar\": [1, 2,,]\n}", "bad.tw-pddl", "").expect_err("malformed");
    assert!(error.to_string().starts_with("bad.tw-pddl:2:"), "{error}");
}

/// A game file with a byte that is not UTF-8 names the file, line and column (it said only
/// "stream did not contain valid UTF-8"); a byte-order mark is read past, as `benchmark_data`
/// reads the same files.
#[test]
fn a_game_file_that_is_not_utf8_names_line_and_column() {
    let dir = std::env::temp_dir().join(format!("alfworld-input-utf8-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let file = dir.join("game.tw-pddl");
    std::fs::write(&file, b"{\n  \"pddl_domain\": \"\xc3\xa9\xff\"\n}").expect("written");
    let error = AlfworldEnv::from_game_file(&file).expect_err("not UTF-8").to_string();
    assert_eq!(error, format!("{}:2:20: not UTF-8 text (byte 0xff)", file.display()));
    let mut text = b"\xef\xbb\xbf".to_vec();
    text.extend(std::fs::read(game_path()).expect("fixture"));
    std::fs::write(&file, text).expect("written");
    let loaded = AlfworldEnv::from_game_file(&file);
    std::fs::remove_dir_all(&dir).expect("removed");
    loaded.expect("a game after a byte-order mark");
}

#[test]
fn a_grammar_naming_an_unknown_symbol_is_an_error_with_its_position() {
    let mut game = game_json();
    let grammar = game["grammar"].as_str().expect("grammar").replace("#examineReceptacle.feedback#", "#no.such.symbol#");
    // Found first in an action's feedback: the error is at that action's block.
    let used = grammar.find("feedback :: \"#no.such.symbol#\"").expect("an action's feedback names it");
    let block = grammar[..used].rfind("action ").expect("its block");
    let line = grammar[..block].matches('\n').count() + 1;
    let column = block - grammar[..block].rfind('\n').map_or(0, |n| n + 1) + 1;
    game["grammar"] = serde_json::Value::String(grammar);
    let error = load(&game).expect_err("unknown symbol");
    let text = error.to_string();
    assert!(text.contains(&format!("the `grammar` field, line {line}, column {column}: ")), "{text}");
    assert!(text.contains("`#no.such.symbol#`") && text.contains("which it does not define"), "{text}");

    let mut game = game_json();
    let grammar =
        game["grammar"].as_str().expect("grammar").replacen("action GotoLocation {", "action GotoLocation {\n  bogus :: \"x\";", 1);
    game["grammar"] = serde_json::Value::String(grammar);
    let text = load(&game).expect_err("unknown part").to_string();
    assert!(text.contains("the `grammar` field, line") && text.contains("unknown part `bogus`"), "{text}");
}

/// A production that does not read is placed at its symbol's key in the grammar block, not at
/// the grammar's first line.
#[test]
fn a_production_that_does_not_read_is_placed_at_its_symbol() {
    let mut game = game_json();
    let grammar = game["grammar"].as_str().expect("grammar").to_string();
    let key = grammar.find("\"examineReceptacle.feedback\"").expect("the symbol's key");
    let after = key + grammar[key..].find("\"rhs\": \"").expect("a production") + "\"rhs\": \"".len();
    let mut broken = grammar.clone();
    broken.insert_str(after, "{r.na-me} ");
    let line = grammar[..key].matches('\n').count() + 1;
    let column = grammar[..key].chars().rev().take_while(|&c| c != '\n').count() + 1;
    game["grammar"] = serde_json::Value::String(broken);
    let text = match load(&game) {
        Ok(_) => panic!("a production with an unsupported expression loaded"),
        Err(error) => error.to_string(),
    };
    assert!(text.contains(&format!("the `grammar` field, line {line}, column {column}: ")), "{text}");
    assert!(text.contains("a `examineReceptacle.feedback` production"), "{text}");
}

#[test]
fn broken_pddl_is_reported_with_the_field() {
    let mut game = game_json();
    game["pddl_problem"] = serde_json::Value::String("(define (problem p) (:domain alfred) (:init (atlocation".into());
    let text = load(&game).expect_err("broken problem").to_string();
    assert!(text.starts_with("test.tw-pddl: the `pddl_problem` field is not valid PDDL"), "{text}");

    // PDDL that parses but does not check (an atom with a wrong arity): the field, line and
    // column of each error.
    let mut game = game_json();
    let problem = game["pddl_problem"].as_str().expect("problem");
    let at = problem.find("(:init").expect(":init") + "(:init".len();
    let line = problem[..at].lines().count();
    game["pddl_problem"] = serde_json::Value::String(format!("{}\n(opened){}", &problem[..at], &problem[at..]));
    let text = load(&game).expect_err("a wrong arity").to_string();
    assert!(text.starts_with("test.tw-pddl: the `pddl_problem` field is not valid PDDL"), "{text}");
    assert!(text.contains(&format!("test.tw-pddl (pddl_problem):{}:1: error[", line + 1)), "{text}");
}

fn snapshot(env: &AlfworldEnv) -> (Vec<String>, bool, Vec<String>) {
    (env.admissible_commands().expect("listed"), env.goal_reached(), env.hidden_atoms().iter().map(|a| a.to_string()).collect())
}

#[test]
fn empty_and_huge_commands_change_nothing() {
    let mut env = AlfworldEnv::from_game_file(&game_path()).expect("fixture loads");
    env.reset();
    let before = snapshot(&env);
    let mut noise = String::new();
    let mut x: u32 = 12345;
    while noise.len() < 10_240 {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        noise.push(char::from_u32(x >> 16 & 0x10ffff).unwrap_or('\u{fffd}'));
    }
    for command in ["", "   ", "\n", noise.as_str(), "go to", "take mug 1 from"] {
        let result = env.step(command);
        assert_eq!(result.observation.text, NOTHING_HAPPENS);
        assert_eq!(result.event, Event::NotExecuted { reason: NOTHING_HAPPENS.into() });
        assert_eq!(snapshot(&env), before);
    }
    assert_eq!(env.steps_taken(), 6);
}

#[test]
fn surrounding_white_space_is_stripped_as_python_strips_it() {
    let mut env = AlfworldEnv::from_game_file(&game_path()).expect("fixture loads");
    env.reset();
    let command = env.admissible_commands().expect("listed")[0].clone();
    let result = env.step(&format!(" \t{command}\u{1f}\n"));
    assert!(result.event.executed(), "{command}");
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(17),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    /// Any text: an admissible command is executed; anything else is "Nothing happens." and
    /// leaves the admissible list, the goal and the hidden state as they were.
    #[test]
    fn any_command_is_executed_or_changes_nothing(commands in proptest::collection::vec(
        prop_oneof![any::<String>(), "(go to|take|open|close|examine|use|move|heat|cool|clean) [a-z]{1,12} [0-9]( from [a-z]{3,10} [0-9])?", Just("look".to_string()), Just("inventory".to_string())],
        1..12,
    )) {
        let mut env = AlfworldEnv::from_game_file(&game_path()).expect("fixture loads");
        env.reset();
        for command in commands {
            let before = snapshot(&env);
            let stripped = command.trim_matches(|c: char| c.is_whitespace() || ('\u{1c}'..='\u{1f}').contains(&c));
            let admissible = before.0.iter().any(|a| a == stripped);
            let result = env.step(&command);
            prop_assert_eq!(result.event.executed(), admissible);
            if !admissible {
                prop_assert_eq!(result.observation.text, NOTHING_HAPPENS);
                prop_assert_eq!(snapshot(&env), before);
            }
        }
    }
}
