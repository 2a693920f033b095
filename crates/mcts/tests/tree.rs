//! The top of the search tree that MCTS returns (`Outcome::tree`): its counts add up, its
//! priors are probabilities, the returned plan's first action is a row of it, it is the same
//! on every run, and the linear decoders return none.

mod common;

use std::sync::Arc;

use common::{Loaded, TempDir, tiny_uniform};
use lm::LanguageModel;
use mcts::{DecodeConfig, Decoder, Mode, Outcome, RowKind, StopReason, TreeSummary, ValueConfig};
use transition_model::Spelling;

/// Two routes from a to d: a-b-c-d (three steps) and a-e-d (two).
const ROADS_DOMAIN: &str = "(define (domain roads) (:predicates (at ?x) (road ?x ?y))
  (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x)))))";
const ROADS_PROBLEM: &str = "(define (problem p) (:domain roads) (:objects a b c d e)
  (:init (at a) (road a b) (road b c) (road c d) (road a e) (road e d) (road b a) (road c b) (road e a))
  (:goal (at d)))";

fn roads() -> Loaded {
    let model = common::ground(ROADS_DOMAIN, ROADS_PROBLEM);
    let spelling = Spelling::pddl(model.task());
    Loaded { id: "roads".into(), model, spelling }
}

fn decode(lm: &mut dyn LanguageModel, task: &Loaded, config: &DecodeConfig) -> Outcome {
    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).expect("vocabulary"));
    let mut decoder = Decoder::new(&task.model, &task.spelling, vocab, ValueConfig::default());
    let prompt = lm.encode("Plan:\n").expect("encodes");
    decoder.decode(lm, &prompt, &task.model.initial_state(), config).expect("decodes")
}

fn mode(name: &str) -> Mode {
    Mode::from_name(name).expect("known mode")
}

/// What holds of every summary: visits add up to at most their parent's and the
/// simulations, rows are most visited first, priors are probabilities summing to at most 1
/// per level, at most one row per level is on the plan, the second level continues the most
/// visited first action. Returns the summary.
fn check(outcome: &Outcome) -> &TreeSummary {
    let tree = outcome.tree.as_ref().expect("MCTS returns the top of its tree");
    assert!(tree.visits <= outcome.stats.simulations, "{} visits, {} simulations", tree.visits, outcome.stats.simulations);
    assert_eq!(tree.first.visits, tree.visits, "the first level starts at the root");
    assert!(tree.first.after.is_empty());
    for level in std::iter::once(&tree.first).chain(tree.second.as_ref()) {
        let listed: u64 = level.rows.iter().map(|r| r.visits).sum();
        assert!(listed + level.omitted_visits <= level.visits, "{level:?}");
        assert!(level.rows.len() <= TreeSummary::LISTED);
        assert!(level.omitted == 0 || level.rows.len() == TreeSummary::LISTED);
        assert!(level.rows.windows(2).all(|w| w[0].visits >= w[1].visits), "most visited first: {level:?}");
        let prior: f64 = level.rows.iter().map(|r| r.prior).sum();
        assert!(prior <= 1.0 + 1e-6, "priors sum to {prior}");
        for row in &level.rows {
            assert!(row.prior > 0.0 && row.prior <= 1.0 + 1e-6, "{row:?}");
            assert!(row.visits >= 1 && row.tokens >= 1 && row.value.is_finite(), "{row:?}");
            assert!(!row.on_plan || row.kind == RowKind::Action, "{row:?}");
            if row.kind == RowKind::Action {
                assert!(!row.text.is_empty() && !row.text.contains('\n'), "{row:?}");
            }
        }
        assert!(level.rows.iter().filter(|r| r.on_plan).count() <= 1, "{level:?}");
    }
    let complete = tree.first.omitted == 0 && !tree.first.truncated;
    if let Some(first) = outcome.lines.first().filter(|_| complete) {
        let row = tree.first.rows.iter().find(|r| r.on_plan).unwrap_or_else(|| panic!("no row on the plan: {tree:?}"));
        assert_eq!(&row.text, first);
    }
    if let Some(second) = &tree.second {
        let most = tree.first.rows.iter().find(|r| r.kind == RowKind::Action).expect("the second level follows an action");
        assert_eq!(second.after.join("; "), most.text);
        assert_eq!(second.visits, most.visits);
        if let Some(row) = second.rows.iter().find(|r| r.on_plan) {
            let n = second.after.len();
            assert_eq!(outcome.lines[..n], second.after[..], "a second-level row on the plan follows the plan's start");
            assert_eq!(row.text, outcome.lines[n..].iter().take(row.text.split("; ").count()).cloned().collect::<Vec<_>>().join("; "));
        }
    }
    tree
}

#[test]
fn a_search_stopped_at_the_goal_lists_the_first_actions_it_tried() {
    let dir = TempDir::new("tree-goal");
    let mut lm = tiny_uniform(&dir);
    let task = roads();
    let outcome = decode(&mut lm, &task, &DecodeConfig::new(mode("constrained-mcts")));
    assert_eq!(outcome.stop, StopReason::Goal);
    let tree = check(&outcome);
    // The simulation that reached the goal is counted.
    assert_eq!(tree.visits, outcome.stats.simulations);
    // The plan may end anywhere: the end of sequence and `DONE` are branches beside a's roads.
    for row in &tree.first.rows {
        match row.kind {
            RowKind::Action => assert!(["(go a b)", "(go a e)"].contains(&row.text.as_str()), "only a's roads apply first: {row:?}"),
            kind => assert_eq!(kind, RowKind::End, "{row:?}"),
        }
    }
    let on_plan = tree.first.rows.iter().find(|r| r.on_plan).expect("the plan's first action");
    assert_eq!(on_plan.text, outcome.lines[0]);
    // Max backup: the branch to the goal holds the goal reward, the best value there is.
    assert_eq!(on_plan.value, ValueConfig::default().goal_reward);
    assert!(tree.first.rows.iter().all(|r| r.value <= on_plan.value));
    // The uniform prior splits evenly between the two roads out of a.
    let roads: Vec<f64> = tree.first.rows.iter().filter(|r| r.kind == RowKind::Action).map(|r| r.prior).collect();
    assert!(roads.iter().all(|p| (p - roads[0]).abs() < 1e-9), "{roads:?}");
}

#[test]
fn an_exhausted_search_ranks_the_optimal_first_step_first_in_value() {
    let dir = TempDir::new("tree-exhausted");
    let mut lm = tiny_uniform(&dir);
    let task = roads();
    let mut config = DecodeConfig::new(mode("constrained-mcts"));
    config.stop_at_goal = false;
    config.budget.max_actions = 4;
    let outcome = decode(&mut lm, &task, &config);
    assert_eq!(outcome.stop, StopReason::Exhausted);
    assert_eq!(outcome.lines, ["(go a e)", "(go e d)"]);
    let tree = check(&outcome);
    let rows = &tree.first.rows;
    let roads: std::collections::BTreeSet<&str> = rows.iter().filter(|r| r.kind == RowKind::Action).map(|r| r.text.as_str()).collect();
    assert_eq!(roads, ["(go a b)", "(go a e)"].into(), "the exhausted tree tried both roads");
    assert!(rows.iter().any(|r| r.kind == RowKind::End), "and ending the plan at once: {rows:?}");
    let prior: f64 = rows.iter().map(|r| r.prior).sum();
    assert!((prior - 1.0).abs() < 1e-6, "every branch of the root is listed: the priors sum to 1 ({prior})");
    assert!(rows.iter().all(|r| r.closed), "an exhausted tree is closed everywhere: {rows:?}");
    let best = rows.iter().find(|r| r.on_plan).expect("(go a e) is on the plan");
    assert_eq!(best.text, "(go a e)");
    assert!(rows.iter().all(|r| r.value <= best.value), "max backup: both reach the goal, (go a e) no worse: {rows:?}");
    let second = tree.second.as_ref().expect("the search went on past the first action");
    assert!(!second.rows.is_empty());
}

/// The roads with a `look` that only marks where the agent looked: nothing reads `seen`.
const LOOKING_DOMAIN: &str = "(define (domain roads) (:predicates (at ?x) (road ?x ?y) (seen ?x))
  (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x))))
  (:action look :parameters (?x) :precondition (at ?x) :effect (seen ?x)))";

#[test]
fn an_action_that_changes_only_facts_nothing_reads_is_a_transposition() {
    // `(look a)` adds `(seen a)`, which neither the goal nor any action reads: on the facts
    // relevant to the goal it returns to the root's state, so it is closed when first reached
    // and never visited again (as ALFWorld's examine, look and inventory, which set `checked`).
    let dir = TempDir::new("tree-irrelevant");
    let mut lm = tiny_uniform(&dir);
    let model = common::ground(LOOKING_DOMAIN, ROADS_PROBLEM);
    let spelling = Spelling::pddl(model.task());
    let task = Loaded { id: "looking".into(), model, spelling };
    let mut config = DecodeConfig::new(mode("constrained-mcts"));
    config.stop_at_goal = false;
    config.budget.simulations = Some(200);
    let outcome = decode(&mut lm, &task, &config);
    let tree = check(&outcome);
    let look = tree.first.rows.iter().find(|r| r.text == "(look a)").unwrap_or_else(|| panic!("(look a) was tried: {tree:?}"));
    assert!(look.closed && look.visits == 1, "{look:?}");
    let second = tree.second.as_ref().expect("the search went on past the first action");
    let looks: Vec<_> = second.rows.iter().filter(|r| r.text.starts_with("(look")).collect();
    assert!(!looks.is_empty() && looks.iter().all(|r| r.closed && r.visits == 1), "{second:?}");
    assert_eq!(outcome.lines, ["(go a e)", "(go e d)"]);
}

#[test]
fn the_summary_is_the_same_on_every_run() {
    let dir = TempDir::new("tree-determinism");
    let mut lm = tiny_uniform(&dir);
    let task = roads();
    let mut config = DecodeConfig::new(mode("constrained-mcts"));
    config.stop_at_goal = false;
    config.budget.simulations = Some(60);
    let a = decode(&mut lm, &task, &config);
    let b = decode(&mut lm, &task, &config);
    check(&a);
    assert_eq!(a.tree, b.tree);
}

#[test]
fn greedy_decoding_and_sampling_build_no_tree() {
    let dir = TempDir::new("tree-linear");
    let mut lm = tiny_uniform(&dir);
    let task = roads();
    for name in ["constrained-greedy", "constrained-sample", "unconstrained-greedy", "sample"] {
        let mut config = DecodeConfig::new(mode(name));
        config.budget.max_tokens = 64;
        assert_eq!(decode(&mut lm, &task, &config).tree, None, "{name}");
    }
}

#[test]
fn searches_on_fixture_tasks_summarise_their_trees() {
    let dir = TempDir::new("tree-fixtures");
    let mut lm = tiny_uniform(&dir);
    let mut tasks = common::sample(benchmark_data::Benchmark::AlfworldSeen, 2);
    tasks.extend(common::sample(benchmark_data::Benchmark::VirtualhomeEai, 2));
    for task in &tasks {
        for name in ["constrained-mcts", "unconstrained-mcts"] {
            let mut config = DecodeConfig::new(mode(name));
            config.budget.simulations = Some(300);
            config.budget.max_tokens = 160;
            config.budget.max_actions = 12;
            let outcome = decode(&mut lm, task, &config);
            if outcome.stats.simulations == 0 {
                // The goal or a dead end at the root: no search, no tree.
                assert!(matches!(outcome.stop, StopReason::Goal | StopReason::DeadEnd) && outcome.tree.is_none(), "{outcome:?}");
                continue;
            }
            let tree = check(&outcome);
            assert!(!tree.first.rows.is_empty(), "{} {name}: {tree:?}", task.id);
        }
    }
}
