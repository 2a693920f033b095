//! The decoder end to end on small tasks: what every mode returns, MCTS optimality on a
//! small domain, determinism.

mod common;

use std::sync::Arc;
use std::time::Duration;

use common::{TempDir, applicable_in_turn, ground, tiny_model, tiny_uniform};
use lm::LanguageModel;
use mcts::{Backup, Clock, DecodeConfig, Decoder, MctsConfig, Mode, Normalization, SamplingConfig, StopReason, Strategy, ValueConfig};
use transition_model::{Spelling, TransitionModel};

/// Two routes from a to d: a-b-c-d (three steps) and a-e-d (two).
const ROADS_DOMAIN: &str = "(define (domain roads) (:predicates (at ?x) (road ?x ?y))
  (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x)))))";
const ROADS_PROBLEM: &str = "(define (problem p) (:domain roads) (:objects a b c d e)
  (:init (at a) (road a b) (road b c) (road c d) (road a e) (road e d) (road b a) (road c b) (road e a))
  (:goal (at d)))";

/// A task in the PDDL spelling, with `lm`'s constraint vocabulary and the prompt `Plan:`.
struct Setup {
    model: TransitionModel,
    spelling: Spelling,
    vocab: Arc<token_constraint::Vocabulary>,
    prompt: Vec<lm::TokenId>,
}

fn setup(lm: &dyn LanguageModel, domain: &str, problem: &str) -> Setup {
    let model = ground(domain, problem);
    let spelling = Spelling::pddl(model.task());
    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).expect("vocabulary"));
    let prompt = lm.encode("Plan:\n").expect("encodes");
    Setup { model, spelling, vocab, prompt }
}

fn mode(name: &str) -> Mode {
    Mode::from_name(name).expect("known mode")
}

#[test]
fn constrained_mcts_solves_a_small_domain_with_a_uniform_prior() {
    let dir = TempDir::new("roads");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    let mut decoder = Decoder::new(&model, &spelling, vocab, ValueConfig::default());
    let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &DecodeConfig::new(mode("constrained-mcts"))).expect("decodes");
    assert!(outcome.valid && outcome.solved, "{outcome:?}");
    assert_eq!(outcome.stop, StopReason::Goal);
    assert!(applicable_in_turn(&model, &outcome.plan));
    let end = outcome.plan.iter().fold(model.initial_state(), |state, &action| model.apply(&state, action));
    assert!(model.is_goal(&end), "the plan as returned reaches the goal");
    assert!(outcome.stats.simulations > 0 && outcome.stats.nodes > 0);
    if outcome.plan.len() == 2 {
        assert_eq!(outcome.lines, ["(go a e)", "(go e d)"], "the only two-action plan");
    }
}

#[test]
fn mcts_finds_the_optimal_plan_given_enough_simulations() {
    let dir = TempDir::new("optimal");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    // Only the goal matters: no heuristic preference between the two routes' first steps
    // beyond what the search learns.
    let mut decoder = Decoder::new(&model, &spelling, vocab, ValueConfig::default());
    let mut config = DecodeConfig::new(mode("constrained-mcts"));
    config.stop_at_goal = false;
    config.budget.max_actions = 4;
    let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes");
    assert_eq!(outcome.stop, StopReason::Exhausted, "the finite tree is searched to the end");
    assert!(outcome.solved);
    assert_eq!(outcome.lines, ["(go a e)", "(go e d)"]);
}

/// The time limit is read on the budget's clock, and the stop says which: a limit of zero
/// ends every strategy before its first token, on the wall clock and on the processor's.
#[test]
fn the_time_limit_is_read_on_the_budgets_clock() {
    let dir = TempDir::new("clock");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    let mut decoder = Decoder::new(&model, &spelling, vocab, ValueConfig::default());
    for (clock, stop) in [(Clock::Wall, StopReason::WallClock), (Clock::Cpu, StopReason::CpuTime)] {
        for name in ["constrained-mcts", "unconstrained-mcts", "constrained-greedy"] {
            let mut config = DecodeConfig::new(mode(name));
            config.budget.time_limit = Some(Duration::ZERO);
            config.budget.clock = clock;
            let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes");
            assert_eq!(outcome.stop, stop, "{name} on {clock:?}");
            assert!(outcome.plan.is_empty() && !outcome.solved, "{name} on {clock:?}");
            assert_eq!(outcome.stats.decoded_tokens, 0, "{name} on {clock:?}");
        }
        // With room, the same search finds its plan on either clock.
        let mut config = DecodeConfig::new(mode("constrained-mcts"));
        config.budget.clock = clock;
        let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes");
        assert!(outcome.solved, "{clock:?}: {:?}", outcome.stop);
    }
}

#[test]
fn every_backup_and_normalization_finds_the_optimal_plan_when_the_tree_is_exhausted() {
    let dir = TempDir::new("variants");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    for backup in [Backup::Max, Backup::Mean] {
        for normalization in [Normalization::Siblings, Normalization::Tree] {
            for prune_transpositions in [true, false] {
                let search = MctsConfig { backup, normalization, prune_transpositions, ..MctsConfig::default() };
                let mut config = DecodeConfig::new(Mode { constrained: true, strategy: Strategy::Mcts(search) });
                config.stop_at_goal = false;
                config.budget.max_actions = 4;
                let mut decoder = Decoder::new(&model, &spelling, Arc::clone(&vocab), ValueConfig::default());
                let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes");
                let label = format!("{backup:?} {normalization:?} transpositions pruned: {prune_transpositions}");
                assert_eq!(outcome.stop, StopReason::Exhausted, "{label}");
                assert_eq!(outcome.lines, ["(go a e)", "(go e d)"], "{label}");
            }
        }
    }
}

/// Three independent switches: every order of switching reaches the same states.
const SWITCHES_DOMAIN: &str = "(define (domain switches) (:predicates (on ?x))
  (:action switch :parameters (?x) :precondition (and) :effect (on ?x)))";
const SWITCHES_PROBLEM: &str = "(define (problem p) (:domain switches) (:objects a b c) (:init) (:goal (and (on a) (on b) (on c))))";

#[test]
fn transposition_pruning_keeps_one_prefix_per_state() {
    let dir = TempDir::new("transpositions");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, SWITCHES_DOMAIN, SWITCHES_PROBLEM);
    let mut run = |prune_transpositions: bool| {
        let search = MctsConfig { prune_transpositions, ..MctsConfig::default() };
        let mut config = DecodeConfig::new(Mode { constrained: true, strategy: Strategy::Mcts(search) });
        config.stop_at_goal = false;
        config.budget.max_actions = 3;
        let mut decoder = Decoder::new(&model, &spelling, Arc::clone(&vocab), ValueConfig::default());
        decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes")
    };
    let pruned = run(true);
    let kept = run(false);
    for outcome in [&pruned, &kept] {
        assert_eq!(outcome.stop, StopReason::Exhausted);
        assert!(outcome.solved && outcome.plan.len() == 3, "{outcome:?}");
    }
    // Kept, the tree holds every order of the switches (3! = 6 goal prefixes); pruned, a
    // state reached a second time with as many actions is a closed leaf, so far fewer
    // simulations exhaust the tree.
    assert!(
        pruned.stats.simulations < kept.stats.simulations,
        "pruned {} simulations, kept {}",
        pruned.stats.simulations,
        kept.stats.simulations
    );
}

#[test]
fn every_mode_runs_and_constrained_modes_stay_valid() {
    let dir = TempDir::new("modes");
    let mut lm = tiny_model(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    let mut decoder = Decoder::new(&model, &spelling, vocab, ValueConfig::default());
    for &name in Mode::NAMES {
        let mut config = DecodeConfig::new(mode(name));
        config.budget.simulations = Some(200);
        config.budget.max_tokens = 64;
        let outcome = decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes");
        assert_eq!(outcome.mode, name);
        assert!(applicable_in_turn(&model, &outcome.plan), "{name}: {outcome:?}");
        if name.starts_with("constrained") {
            assert!(outcome.valid, "{name}: {outcome:?}");
            assert!(outcome.invalid.is_none());
        }
        if outcome.solved {
            assert!(model.is_goal(&outcome.plan.iter().fold(model.initial_state(), |s, &a| model.apply(&s, a))));
        }
        assert!(outcome.stats.usage.tokens_generated + outcome.stats.forced_tokens >= outcome.stats.decoded_tokens.min(1));
    }
}

#[test]
fn identical_seeds_give_identical_results() {
    let dir = TempDir::new("seeds");
    let mut lm = tiny_model(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    let run = |lm: &mut lm::LocalModel, mode: Mode| {
        let mut decoder = Decoder::new(&model, &spelling, Arc::clone(&vocab), ValueConfig::default());
        let mut config = DecodeConfig::new(mode);
        config.budget.simulations = Some(100);
        config.budget.max_tokens = 48;
        let outcome = decoder.decode(lm, &prompt, &model.initial_state(), &config).expect("decodes");
        (outcome.lines, outcome.stop, outcome.stats.simulations, outcome.stats.nodes, outcome.invalid, outcome.text)
    };
    for constrained in [true, false] {
        for seed in [0, 42, 1738] {
            let sample = Mode { constrained, strategy: Strategy::Sample(SamplingConfig { seed, ..SamplingConfig::default() }) };
            assert_eq!(run(&mut lm, sample.clone()), run(&mut lm, sample));
        }
        let search = Mode { constrained, strategy: Strategy::Mcts(MctsConfig::default()) };
        assert_eq!(run(&mut lm, search.clone()), run(&mut lm, search));
    }
    // Different seeds explore: over three seeds, unconstrained sampling writes more than one text.
    let texts: rustc_hash::FxHashSet<_> = [0u64, 1, 2, 3]
        .into_iter()
        .map(|seed| {
            run(
                &mut lm,
                Mode { constrained: false, strategy: Strategy::Sample(SamplingConfig { seed, top_k: None, top_p: 1.0, temperature: 1.0 }) },
            )
        })
        .map(|r| r.5)
        .collect();
    assert!(texts.len() > 1, "{texts:?}");
}

#[test]
fn unconstrained_greedy_reports_the_first_invalid_line() {
    let dir = TempDir::new("invalid");
    let mut lm = tiny_uniform(&dir);
    let Setup { model, spelling, vocab, prompt } = setup(&lm, ROADS_DOMAIN, ROADS_PROBLEM);
    let mut decoder = Decoder::new(&model, &spelling, vocab, ValueConfig::default());
    // The uniform argmax is token 0 (a control token, not a stop token of the tiny model).
    let outcome =
        decoder.decode(&mut lm, &prompt, &model.initial_state(), &DecodeConfig::new(mode("unconstrained-greedy"))).expect("decodes");
    assert!(!outcome.valid && !outcome.solved);
    assert_eq!(outcome.stop, StopReason::InvalidAction);
    assert_eq!(outcome.invalid.as_ref().map(|i| i.step), Some(0));
}
