//! Laws of the transition model on real fixtures (an IPC blocks and an elevators task with
//! action costs, an ALFWorld game, an EAI VirtualHome problem, the household task whose goal
//! is three steps away), along random walks that
//! proptest draws: the decision tree's applicable actions equal a scan of every action's
//! precondition; `apply` is PDDL's semantics on a set of facts (conditional effects read the
//! old state, deletes before adds); validation accepts exactly the sequences whose every
//! step applies, reporting the first that does not with exactly its unmet preconditions,
//! and ends in the state the walk reached; spelling an action and parsing the text gives
//! back the action, in every surface language the task has.

use std::collections::BTreeSet;
use std::sync::OnceLock;

use benchmark_data::{Benchmark, Extra, TaskFiles, load};
use grounding::{ActionId, FactId, Task};
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, RngSeed};
use transition_model::{PlanError, Spelling, State, TransitionModel, Unmet, normalize, unmet};

fn config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    }
}

/// How many fixtures [`fixtures`] loads.
const FIXTURES: usize = 5;

struct Fixture {
    id: String,
    model: TransitionModel,
    /// PDDL always; ALFWorld commands or VirtualHome verbs where the task has them.
    spellings: Vec<Spelling>,
}

/// The household fixture, whose goal random walks reach often (three steps away).
fn household() -> TaskFiles {
    let dir = benchmark_data::fixtures_dir().join("pddl-valid/household");
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).expect("household fixture");
    TaskFiles {
        id: "household".into(),
        benchmark: Benchmark::Ipc,
        domain_path: dir.join("domain.pddl"),
        domain: read("domain.pddl"),
        problem_path: dir.join("problem.pddl"),
        problem: read("problem.pddl"),
        extra: Extra::None,
    }
}

fn fixtures() -> &'static [Fixture] {
    static LOADED: OnceLock<Vec<Fixture>> = OnceLock::new();
    let fixtures = LOADED.get_or_init(|| {
        // The task `id`, or the first in an ALFWorld game folder `id` (ending with `/`).
        let pick = |benchmark: Benchmark, id: &str| -> TaskFiles {
            let matches = |t: &TaskFiles| t.id == id || (id.ends_with('/') && t.id.starts_with(id));
            load(benchmark).expect("fixtures load").into_iter().find(matches).unwrap_or_else(|| panic!("no fixture {id}"))
        };
        [
            pick(Benchmark::Ipc, "blocks/instance-1"),
            pick(Benchmark::Ipc, "elevators-opt08/instance-1"),
            pick(Benchmark::AlfworldSeen, "pick_clean_then_place_in_recep-DishSponge-None-CounterTop-403/"),
            pick(Benchmark::VirtualhomeEai, "837_2"),
            household(),
        ]
        .into_iter()
        .map(|files| {
            let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
            let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
            let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
            let mut spellings = vec![Spelling::pddl(model.task())];
            match &files.extra {
                Extra::Alfworld(game) => spellings.push(Spelling::alfworld(model.task(), &game.grammar).expect("grammar")),
                Extra::Virtualhome { .. } => spellings.push(Spelling::virtualhome(model.task())),
                Extra::None => {}
            }
            Fixture { id: files.id, model, spellings }
        })
        .collect::<Vec<_>>()
    });
    assert_eq!(fixtures.len(), FIXTURES);
    fixtures
}

/// The applicable actions by a scan of every action's precondition, in id order.
fn scan(model: &TransitionModel, state: &State) -> Vec<ActionId> {
    let task = model.task();
    task.action_ids().filter(|&a| task.action(a).pre.holds(|f| state.contains(f))).collect()
}

fn generated(model: &TransitionModel, state: &State) -> Vec<ActionId> {
    let mut out = Vec::new();
    model.applicable(state, &mut out);
    out.sort_unstable();
    out
}

/// PDDL's successor on a set of facts: effects whose condition holds in `before` fire;
/// every delete goes before every add.
fn successor(task: &Task, before: &BTreeSet<FactId>, action: ActionId) -> BTreeSet<FactId> {
    let action = task.action(action);
    let fired: Vec<_> = action.conditional.iter().filter(|e| e.condition.holds(|f| before.contains(&f))).collect();
    let mut after = before.clone();
    for f in action.del.iter().chain(fired.iter().flat_map(|e| &e.del)) {
        after.remove(f);
    }
    after.extend(action.add.iter().chain(fired.iter().flat_map(|e| &e.add)));
    after
}

/// The states and actions of a walk that follows `picks` among the applicable actions
/// (stopping early in a state without any).
fn walk(model: &TransitionModel, picks: &[prop::sample::Index]) -> (Vec<State>, Vec<ActionId>) {
    let mut states = vec![model.initial_state()];
    let mut actions = Vec::new();
    for pick in picks {
        let state = states.last().expect("the initial state");
        let applicable = generated(model, state);
        if applicable.is_empty() {
            break;
        }
        let action = applicable[pick.index(applicable.len())];
        states.push(model.apply(state, action));
        actions.push(action);
    }
    (states, actions)
}

proptest! {
    #![proptest_config(config(128, 0x7472_616e_7369))]

    /// In every state of a random walk, the decision tree finds exactly the actions a scan
    /// finds; every one of them applies as PDDL says.
    #[test]
    fn successor_generator_equals_a_scan_and_apply_is_pddl(
        fixture in 0..FIXTURES, picks in prop::collection::vec(any::<prop::sample::Index>(), 0..40),
    ) {
        let Fixture { id, model, .. } = &fixtures()[fixture];
        let (states, _) = walk(model, &picks);
        for state in &states {
            let applicable = generated(model, state);
            prop_assert_eq!(&applicable, &scan(model, state), "{}", id);
            let facts: BTreeSet<FactId> = state.facts().collect();
            for &action in &applicable {
                prop_assert!(model.is_applicable(state, action));
                let next: BTreeSet<FactId> = model.apply(state, action).facts().collect();
                prop_assert_eq!(next, successor(model.task(), &facts, action), "{}: {}", id, model.task().action_name(action));
            }
        }
    }

    /// A random walk validates exactly when it ends at the goal, with its actions, its cost
    /// and its last state; otherwise the goal is reported unmet after all its steps, with
    /// parts that really do not hold. The same walk written in each spelling validates the
    /// same way (a text naming several actions applies the first applicable one).
    #[test]
    fn a_walk_validates_to_the_state_it_reaches(
        fixture in 0..FIXTURES, picks in prop::collection::vec(any::<prop::sample::Index>(), 0..30),
    ) {
        let Fixture { id, model, spellings } = &fixtures()[fixture];
        let task = model.task();
        let (states, actions) = walk(model, &picks);
        let last = states.last().expect("the initial state");
        let check = |result: Result<transition_model::ValidPlan, PlanError>, actions: &[ActionId], last: &State| -> Result<(), TestCaseError> {
            match result {
                Ok(valid) => {
                    prop_assert!(model.is_goal(last), "{}: validated without reaching the goal", id);
                    prop_assert_eq!(&valid.actions, &actions.to_vec());
                    prop_assert_eq!(valid.cost, actions.iter().map(|&a| u64::from(task.action(a).cost)).sum::<u64>());
                    prop_assert_eq!(&valid.final_state, last);
                }
                Err(PlanError::GoalNotReached { steps, unmet: parts }) => {
                    prop_assert!(!model.is_goal(last), "{}: refused at the goal", id);
                    prop_assert_eq!(steps, actions.len());
                    prop_assert_eq!(parts.is_empty(), task.goal.disjuncts.is_empty());
                    for part in &parts {
                        let holds = match part {
                            Unmet::Literal(l) => last.contains(l.fact()) != l.is_negated(),
                            Unmet::Clause(c) => c.iter().any(|l| last.contains(l.fact()) != l.is_negated()),
                        };
                        prop_assert!(!holds, "{}: reported unmet, but holds: {}", id, part.describe(task));
                    }
                }
                Err(error) => prop_assert!(false, "{}: an applicable walk is refused: {}", id, error.describe(task)),
            }
            Ok(())
        };
        check(model.validate(&actions), &actions, last)?;
        for spelling in spellings {
            let Some(texts) = actions.iter().map(|&a| spelling.spell(a)).collect::<Option<Vec<&str>>>() else { continue };
            // What the text replay executes: the first applicable action spelled the same way.
            let mut state = model.initial_state();
            let mut executed = Vec::new();
            for text in &texts {
                let first = spelling.parse(text).iter().copied().find(|&a| model.is_applicable(&state, a));
                let action = first.expect("the walk's own action is spelled this way and applies");
                state = model.apply(&state, action);
                executed.push(action);
            }
            check(model.validate_text(spelling, &texts), &executed, &state)?;
        }
    }

    /// Validation accepts exactly the sequences whose every step applies: a sequence of
    /// arbitrary actions (each step, at random, applicable or any action of the task) fails
    /// at its first inapplicable step, naming exactly the unmet parts of its precondition.
    #[test]
    fn validation_refuses_at_the_first_inapplicable_step(
        fixture in 0..FIXTURES, steps in prop::collection::vec((any::<bool>(), any::<prop::sample::Index>()), 1..20),
    ) {
        let Fixture { id, model, .. } = &fixtures()[fixture];
        let task = model.task();
        let mut state = model.initial_state();
        let mut plan = Vec::new();
        let mut first_failure = None;
        for (applicable_only, pick) in steps {
            let applicable = generated(model, &state);
            let action = if applicable_only && !applicable.is_empty() {
                applicable[pick.index(applicable.len())]
            } else {
                ActionId::from_index(pick.index(task.actions.len()))
            };
            plan.push(action);
            if !applicable.contains(&action) {
                first_failure = Some((plan.len(), action, state.clone()));
                break;
            }
            state = model.apply(&state, action);
        }
        match (model.validate(&plan), first_failure) {
            (Err(PlanError::Inapplicable { step, text, action, unmet: parts }), Some((expected_step, expected, before))) => {
                prop_assert_eq!(step, expected_step, "{}", id);
                prop_assert_eq!(action, expected);
                prop_assert_eq!(text, task.action_name(expected));
                prop_assert!(!parts.is_empty());
                prop_assert_eq!(parts, unmet(&task.action(expected).pre, &before));
            }
            (Ok(_) | Err(PlanError::GoalNotReached { .. }), None) => {}
            (result, expected) => prop_assert!(
                false,
                "{}: expected a failure at {:?}, got {:?}",
                id,
                expected.map(|(step, _, _)| step),
                result.map(|v| v.actions.len()).map_err(|e| e.describe(task))
            ),
        }
    }

    /// Spelling an action (applicable in a random reachable state, or any action) and
    /// parsing the text back gives a set holding the action, all of whose members are spelled
    /// that way; the text survives changes of case and white space.
    #[test]
    fn spelling_round_trips(
        fixture in 0..FIXTURES,
        picks in prop::collection::vec(any::<prop::sample::Index>(), 0..20),
        any_action in any::<prop::sample::Index>(),
    ) {
        let Fixture { id, model, spellings } = &fixtures()[fixture];
        let task = model.task();
        let (states, _) = walk(model, &picks);
        let mut actions = generated(model, states.last().expect("the initial state"));
        actions.push(ActionId::from_index(any_action.index(task.actions.len())));
        for spelling in spellings {
            for &action in &actions {
                let Some(text) = spelling.spell(action) else {
                    prop_assert!(spelling.language() == transition_model::SurfaceLanguage::Virtualhome, "{}: only VirtualHome leaves actions unspelled", id);
                    continue;
                };
                prop_assert_eq!(text.to_string(), normalize(text), "spellings are normal");
                let parsed = spelling.parse(text);
                prop_assert!(parsed.contains(&action), "{}: `{}` does not parse back to {}", id, text, task.action_name(action));
                for &other in parsed {
                    prop_assert_eq!(spelling.spell(other), Some(text));
                }
                let shouted = format!("  {}  ", text.to_uppercase().replace(' ', "   "));
                prop_assert_eq!(spelling.parse(&shouted), parsed);
            }
        }
    }
}
