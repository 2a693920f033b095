//! Law: a plan returned by any constrained mode is executable action by action, with the
//! uniform prior and with the tiny model, over ALFWorld and VirtualHome fixture problems,
//! under either tokenization; and a plan reported solved validates with the goal.

mod common;

use std::sync::Arc;

use common::{Loaded, TempDir, applicable_in_turn, sample, tiny_model, tiny_uniform};
use lm::LanguageModel;
use mcts::{DecodeConfig, Decoder, MctsConfig, Mode, SamplingConfig, Strategy, Tokenization, ValueConfig};
use proptest::prelude::*;

fn tasks() -> &'static [Loaded] {
    static TASKS: std::sync::OnceLock<Vec<Loaded>> = std::sync::OnceLock::new();
    TASKS.get_or_init(|| {
        let mut tasks = sample(benchmark_data::Benchmark::AlfworldSeen, 4);
        tasks.extend(sample(benchmark_data::Benchmark::VirtualhomeEai, 4));
        tasks
    })
}

fn strategy(kind: u8, seed: u64) -> Strategy {
    match kind % 3 {
        0 => Strategy::Greedy,
        1 => Strategy::Sample(SamplingConfig { seed, ..SamplingConfig::default() }),
        _ => Strategy::Mcts(MctsConfig::default()),
    }
}

fn check(lm: &mut dyn LanguageModel, task: &Loaded, kind: u8, seed: u64, any: bool, simulations: u64) -> Result<(), TestCaseError> {
    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).expect("vocabulary"));
    let mut decoder = Decoder::new(&task.model, &task.spelling, vocab, ValueConfig::default());
    let mut config = DecodeConfig::new(Mode { constrained: true, strategy: strategy(kind, seed) });
    config.tokenization = if any { Tokenization::Any } else { Tokenization::Canonical };
    config.budget.simulations = Some(simulations);
    config.budget.max_tokens = 160;
    config.budget.max_actions = 12;
    let prompt = lm.encode("Plan:\n").expect("encodes");
    let outcome = decoder.decode(lm, &prompt, &task.model.initial_state(), &config).expect("decodes");
    prop_assert!(outcome.valid, "{}: {outcome:?}", task.id);
    prop_assert!(outcome.invalid.is_none());
    prop_assert!(applicable_in_turn(&task.model, &outcome.plan), "{}: {:?}", task.id, outcome.lines);
    // The text as written parses back to the same plan.
    let states = task.model.states_along(&task.spelling, &outcome.lines);
    prop_assert!(states.is_ok(), "{}: {:?}", task.id, outcome.lines);
    prop_assert_eq!(states.map(|s| s.len()).unwrap_or_default(), outcome.plan.len() + 1);
    if outcome.solved {
        prop_assert!(task.model.validate_text(&task.spelling, &outcome.lines).is_ok(), "{}: {:?}", task.id, outcome.lines);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        rng_seed: proptest::test_runner::RngSeed::Fixed(24),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn constrained_plans_execute_with_the_uniform_prior(task in 0usize..8, kind in 0u8..3, seed in 0u64..1000, any: bool) {
        let dir = TempDir::new(&format!("uniform-{task}-{kind}-{seed}"));
        let mut lm = tiny_uniform(&dir);
        check(&mut lm, &tasks()[task], kind, seed, any, 300)?;
    }

    #[test]
    fn constrained_plans_execute_with_the_tiny_model(task in 0usize..8, kind in 0u8..3, seed in 0u64..1000, any: bool) {
        let dir = TempDir::new(&format!("tiny-{task}-{kind}-{seed}"));
        let mut lm = tiny_model(&dir);
        check(&mut lm, &tasks()[task], kind, seed, any, 40)?;
    }
}
