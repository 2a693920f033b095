//! No command line panics or answers with the wrong exit code: random values for every
//! numeric and named option of `plan` (and `validate --spelling`), checked against the rules
//! each option states. All values valid: the run ends with its verdict (0 or 1), or, where a
//! setting is another planner's, exit 2 naming it; any value invalid: exit 2 (bad input) with
//! clap's message. Never a panic, never exit 3.

mod common;

use common::xtask;
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, RngSeed};

/// What a user might type: valid values of some option, edge cases, garbage.
const VALUES: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2.5",
    "0.5",
    "16",
    "1e-300",
    "1e309",
    "inf",
    "-inf",
    "nan",
    "NaN",
    "",
    "abc",
    "100000000000000000000",
    "ff",
    "lmcut",
    "hmax",
    "blind",
    "Ff",
    "astar",
    "gbfs",
    "lazy-gbfs",
    "mcts",
    "constrained-mcts",
    "sample",
    "unconstrained-greedy",
    "max",
    "mean",
    "tree",
    "siblings",
    "canonical",
    "any",
    "anywhere",
    "at-goal",
    "wall",
    "cpu",
    "pddl",
    "alfworld",
    "virtualhome",
];

fn number(text: &str) -> Option<f64> {
    text.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The rule each option states (`--help`), as an oracle.
fn valid(option: &str, value: &str) -> bool {
    let whole = |text: &str| text.parse::<u64>().is_ok();
    match option {
        "--time-limit" => number(value).is_some_and(|v| v > 0.0 && v < 1e9),
        "--heuristic" => ["blind", "goalcount", "hmax", "hadd", "ff", "lmcut", "lmcut-admissible"].contains(&value),
        "--planner" => ["astar", "gbfs", "lazy-gbfs", "mcts"].contains(&value),
        "--mode" => {
            ["constrained-mcts", "constrained-greedy", "unconstrained-mcts", "unconstrained-greedy", "sample", "constrained-sample"]
                .contains(&value)
        }
        "--backup" => ["max", "mean"].contains(&value),
        "--normalization" => ["siblings", "tree"].contains(&value),
        "--tokenization" => ["canonical", "any"].contains(&value),
        "--end" => ["anywhere", "at-goal"].contains(&value),
        "--width" | "--max-actions" | "--model-calls" => whole(value) && value.parse::<u64>().is_ok_and(|v| v >= 1),
        "--clock" => ["wall", "cpu"].contains(&value),
        "--max-expansions" | "--top-k" | "--seed" => whole(value),
        "--exploration" | "--lambda" => number(value).is_some_and(|v| (0.0..=1e9).contains(&v)),
        "--base" => number(value).is_some_and(|v| v > 0.0 && v <= 1e12),
        "--prior-mix" => number(value).is_some_and(|v| (0.0..=1.0).contains(&v)),
        "--temperature" => number(value).is_some_and(|v| (0.0..=1e6).contains(&v)),
        "--top-p" => number(value).is_some_and(|v| v > 0.0 && v <= 1.0),
        other => panic!("no rule for {other}"),
    }
}

/// Whether `option` is a setting of another planner than `planner`, which `plan` refuses
/// rather than pass over: `--heuristic` and `--max-expansions` are the classical planners',
/// Phase II's settings `mcts`'s; the time limit and the clock are everyone's.
fn passed_over(option: &str, planner: &str) -> bool {
    let mcts = planner == "mcts";
    match option {
        "--time-limit" | "--clock" | "--planner" => false,
        "--heuristic" | "--max-expansions" => mcts,
        _ => !mcts,
    }
}

const OPTIONS: &[&str] = &[
    "--time-limit",
    "--heuristic",
    "--planner",
    "--mode",
    "--backup",
    "--normalization",
    "--tokenization",
    "--end",
    "--width",
    "--max-actions",
    "--model-calls",
    "--clock",
    "--max-expansions",
    "--top-k",
    "--seed",
    "--exploration",
    "--lambda",
    "--base",
    "--prior-mix",
    "--temperature",
    "--top-p",
];

fn options() -> impl Strategy<Value = Vec<(&'static str, &'static str)>> {
    proptest::collection::btree_map(proptest::sample::select(OPTIONS), proptest::sample::select(VALUES), 1..5)
        .prop_map(|chosen| chosen.into_iter().collect())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        rng_seed: RngSeed::Fixed(20261202),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn plan_options_give_a_verdict_or_exit_2_never_a_panic(chosen in options()) {
        // `--option=value`, so that values such as `-1` reach the option's parser instead of
        // being read as flags.
        let assigned: Vec<String> = chosen.iter().map(|(option, value)| format!("{option}={value}")).collect();
        let planner = chosen.iter().find(|(o, _)| *o == "--planner").map_or("lazy-gbfs", |(_, v)| *v);
        let mut args: Vec<&str> = vec![
            "plan", "--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", "fixtures/ipc/blocks/instance-1.pddl",
        ];
        args.extend(assigned.iter().map(String::as_str));
        // Short runs whatever else is chosen: Phase II stops after 20 simulations or 20
        // tokens, a classical search after 100,000 expansions (blocks 1 needs a handful).
        if planner == "mcts" {
            args.extend(["--simulations", "20", "--max-tokens", "20"]);
        } else if !chosen.iter().any(|(o, _)| *o == "--max-expansions") {
            args.extend(["--max-expansions", "100000"]);
        }
        let output = xtask(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        prop_assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        let all_valid = chosen.iter().all(|(o, v)| valid(o, v));
        let code = output.status.code();
        if all_valid && chosen.iter().any(|(o, _)| passed_over(o, planner)) {
            prop_assert_eq!(code, Some(2), "{:?}: {}", args, stderr);
            prop_assert!(stderr.contains("is a setting of") || stderr.contains("are settings of"), "{args:?}: {stderr}");
        } else if all_valid {
            prop_assert!(matches!(code, Some(0 | 1)), "{args:?}: exit {code:?}: {stderr}");
        } else {
            prop_assert_eq!(code, Some(2), "{:?}: {}", args, stderr);
            prop_assert!(stderr.contains("invalid value") || stderr.contains("a value is required"), "{args:?}: {stderr}");
        }
    }

    #[test]
    fn validate_spellings_are_checked_by_name(value in proptest::sample::select(VALUES)) {
        let args = [
            "validate", "--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", "fixtures/ipc/blocks/instance-1.pddl",
            "--plan", "fixtures/ipc/blocks/domain.pddl", "--spelling", value,
        ];
        let output = xtask(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        prop_assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        let expected = if value == "virtualhome" {
            // A domain file is not a plan: every line is an unknown script line (exit 1).
            Some(1)
        } else {
            // Unknown spellings; `alfworld`, which needs a game's grammar; and `pddl`, whose
            // plan lines must each be one action `(name arg ...)`: a domain's are malformed.
            Some(2)
        };
        prop_assert_eq!(output.status.code(), expected, "{:?}: {}", args, stderr);
    }
}

/// `--base 0` made PUCB's coefficient infinite and every score NaN; the library refuses it
/// as well as the command line.
#[test]
fn a_zero_base_is_refused_before_any_search() {
    let output = xtask(&[
        "plan",
        "--domain",
        "fixtures/ipc/blocks/domain.pddl",
        "--problem",
        "fixtures/ipc/blocks/instance-1.pddl",
        "--planner",
        "mcts",
        "--base",
        "0",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("--base"));
}
