//! Grounding laws on mutations of the household fixture (random initial states, random goal
//! formulas): every such problem grounds, deterministically, to a task with ids in range whose
//! facts split the initial atoms into fluent and static ones, and whose actions and goal have
//! the domain's meaning in every reachable state, against a hand-written semantics of the
//! three household actions; a problem naming something undeclared fails with the matching
//! diagnostic.

use std::collections::{BTreeSet, VecDeque};

use grounding::{GroundingError, Task};
use pddl_syntax::DiagnosticKind;
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, RngSeed};

fn household() -> (String, String) {
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures"));
    let read = |p: &str| std::fs::read_to_string(root.join(p)).expect("fixture");
    (read("pddl-valid/household/domain.pddl"), read("pddl-valid/household/problem.pddl"))
}

fn config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    }
}

/// A state of the household world: the atoms that hold, by name.
type Atoms = BTreeSet<String>;

const PLACES: [&str; 2] = ["kitchentable", "dishwasher"];
const CONTAINERS: [&str; 1] = ["dishwasher"];
const ITEMS: [&str; 1] = ["wineglass"];

/// Initial-state pieces: every ground atom of the problem's objects (`(handempty)` is
/// always there), and a negative literal, which `:init` ignores with a warning.
const INIT_PIECES: &[&str] = &[
    "(at kitchentable)",
    "(at dishwasher)",
    "(on wineglass kitchentable)",
    "(on wineglass dishwasher)",
    "(holding wineglass)",
    "(closed dishwasher)",
    "(not (closed dishwasher))",
];

/// Whether a formula holds in a state.
type Meaning = fn(&Atoms) -> bool;

/// Goal pieces with their meaning in a state.
const GOAL_PIECES: &[(&str, Meaning)] = &[
    ("(at dishwasher)", |s| s.contains("(at dishwasher)")),
    ("(closed dishwasher)", |s| s.contains("(closed dishwasher)")),
    ("(holding wineglass)", |s| s.contains("(holding wineglass)")),
    ("(on wineglass dishwasher)", |s| s.contains("(on wineglass dishwasher)")),
    ("(not (handempty))", |s| !s.contains("(handempty)")),
    ("(or (at kitchentable) (holding wineglass))", |s| s.contains("(at kitchentable)") || s.contains("(holding wineglass)")),
    ("(exists (?c - container) (on wineglass ?c))", |s| s.contains("(on wineglass dishwasher)")),
    ("(forall (?p - place) (not (at ?p)))", |s| !s.contains("(at kitchentable)") && !s.contains("(at dishwasher)")),
    ("(imply (holding wineglass) (at dishwasher))", |s| !s.contains("(holding wineglass)") || s.contains("(at dishwasher)")),
    ("(= kitchentable dishwasher)", |_| false),
    ("(not (= wineglass wineglass))", |_| false),
];

fn problem_text(init: &[&str], goal: &[&str]) -> String {
    format!(
        "(define (problem p) (:domain household) (:objects kitchentable - place dishwasher - container wineglass - item)
         (:init (handempty) {}) (:goal (and {})))",
        init.join(" "),
        goal.join(" ")
    )
}

/// The household domain by hand: every applicable action, by its PDDL name, with its
/// successor (deletes before adds).
fn oracle_successors(state: &Atoms) -> Vec<(String, Atoms)> {
    let has = |atom: String| state.contains(&atom);
    let next = |del: &[String], add: &[String]| {
        let mut s = state.clone();
        for d in del {
            s.remove(d);
        }
        s.extend(add.iter().cloned());
        s
    };
    let mut out = Vec::new();
    for from in PLACES {
        for to in PLACES {
            if has(format!("(at {from})")) && from != to {
                out.push((format!("(walk {from} {to})"), next(&[format!("(at {from})")], &[format!("(at {to})")])));
            }
        }
    }
    for i in ITEMS {
        for p in PLACES {
            if has(format!("(at {p})")) && has(format!("(on {i} {p})")) && has("(handempty)".into()) {
                let del = [format!("(on {i} {p})"), "(handempty)".into()];
                out.push((format!("(grab {i} {p})"), next(&del, &[format!("(holding {i})")])));
            }
        }
        for c in CONTAINERS {
            if has(format!("(at {c})")) && has(format!("(holding {i})")) && !has(format!("(closed {c})")) {
                let add = [format!("(on {i} {c})"), "(handempty)".into()];
                out.push((format!("(putin {i} {c})"), next(&[format!("(holding {i})")], &add)));
            }
        }
    }
    out.sort();
    out
}

/// The grounded task's view of a state: its applicable actions by name, with successors.
fn task_successors(task: &Task, state: &Atoms) -> Vec<(String, Atoms)> {
    let is_true = |f: grounding::FactId| state.contains(&task.fact_name(f));
    let mut out: Vec<(String, Atoms)> = task
        .action_ids()
        .filter(|&a| task.action(a).pre.holds(is_true))
        .map(|a| {
            let action = task.action(a);
            let mut next = state.clone();
            for &f in &action.del {
                next.remove(&task.fact_name(f));
            }
            for &f in &action.add {
                next.insert(task.fact_name(f));
            }
            assert!(action.conditional.is_empty(), "the household domain has no conditional effects");
            (task.action_name(a), next)
        })
        .collect();
    out.sort();
    out
}

fn assert_ids_in_range(task: &Task) -> Result<(), TestCaseError> {
    let n = task.facts.len();
    let conditions =
        task.actions.iter().map(|a| &a.pre).chain(task.actions.iter().flat_map(|a| a.conditional.iter().map(|e| &e.condition)));
    for condition in conditions.chain(&task.goal.disjuncts) {
        prop_assert!(condition.pos.iter().chain(&condition.neg).all(|f| f.index() < n));
        prop_assert!(condition.clauses.iter().flatten().all(|l| l.fact().index() < n));
    }
    for action in &task.actions {
        prop_assert!(action.add.iter().chain(&action.del).all(|f| f.index() < n));
        prop_assert!(action.conditional.iter().flat_map(|e| e.add.iter().chain(&e.del)).all(|f| f.index() < n));
        prop_assert!(action.schema.index() < task.schemas.len());
        prop_assert!(action.args.iter().all(|o| o.index() < task.objects.len()));
    }
    prop_assert!(task.init.iter().all(|f| f.index() < n));
    Ok(())
}

proptest! {
    #![proptest_config(config(128, 0x6772_6f75_6e64))]

    /// Any initial state and goal over the problem's objects grounds, twice to the same task;
    /// the initial atoms are exactly the fluent initial facts plus the static facts; and in
    /// every state reachable from the initial state (found by the hand-written semantics),
    /// the task's applicable actions, their successors and the goal's truth are the domain's.
    #[test]
    fn mutated_problems_ground_to_the_domains_meaning(
        init in prop::collection::vec(prop::sample::select(INIT_PIECES), 0..5),
        goal in prop::collection::vec(prop::sample::select(GOAL_PIECES), 0..4),
    ) {
        let (domain, _) = household();
        let goal_texts: Vec<&str> = goal.iter().map(|(text, _)| *text).collect();
        let text = problem_text(&init, &goal_texts);
        let domain = pddl_syntax::parse_domain(&domain).expect("domain");
        let problem = pddl_syntax::parse_problem(&text).unwrap_or_else(|e| panic!("{text}: {e:?}"));
        let task = grounding::ground(&domain, &problem).unwrap_or_else(|e| panic!("{text}: {e}"));
        let again = grounding::ground(&domain, &problem).expect("grounds twice");
        prop_assert_eq!(&task.facts, &again.facts);
        prop_assert_eq!(&task.actions, &again.actions);
        prop_assert_eq!(&task.init, &again.init);
        prop_assert_eq!(&task.goal, &again.goal);
        assert_ids_in_range(&task)?;

        let initial: Atoms = std::iter::once("(handempty)").chain(init.iter().copied().filter(|p| !p.starts_with("(not"))).map(String::from).collect();
        let grounded: Atoms = task.init.iter().map(|&f| task.fact_name(f)).chain(task.static_facts.iter().map(|a| task.atom_name(a))).collect();
        prop_assert_eq!(&grounded, &initial, "fluent initial facts + static facts = the initial atoms");

        let mut seen = BTreeSet::from([initial.clone()]);
        let mut queue = VecDeque::from([initial]);
        let mut goal_reachable = false;
        while let Some(state) = queue.pop_front() {
            let expected = oracle_successors(&state);
            prop_assert_eq!(&task_successors(&task, &state), &expected, "applicable actions and successors in {:?}", state);
            let holds = goal.iter().all(|(_, meaning)| meaning(&state));
            prop_assert_eq!(task.goal.holds(|f| state.contains(&task.fact_name(f))), holds, "goal in {:?}", state);
            goal_reachable |= holds;
            for (_, next) in expected {
                if seen.insert(next.clone()) {
                    queue.push_back(next);
                }
            }
        }
        if goal_reachable {
            prop_assert!(!task.goal.disjuncts.is_empty());
        }
    }

    /// One piece naming an undeclared object or predicate, applying a predicate to the wrong
    /// number of arguments, or using an unbound variable, in the initial state or the goal:
    /// grounding refuses the problem with that diagnostic.
    #[test]
    fn problems_naming_undeclared_things_are_refused_with_the_diagnostic(
        init in prop::collection::vec(prop::sample::select(&INIT_PIECES[..6]), 0..4),
        goal in prop::collection::vec(prop::sample::select(GOAL_PIECES), 0..3),
        bad in prop::sample::select(&[
            ("(at garage)", DiagnosticKind::UnknownObject, true),
            ("(hovering wineglass)", DiagnosticKind::UnknownPredicate, true),
            ("(on wineglass)", DiagnosticKind::ArityMismatch, true),
            ("(holding ?x)", DiagnosticKind::UnknownVariable, false),
        ][..]),
        in_init: bool,
        position in any::<prop::sample::Index>(),
    ) {
        let (text, kind, may_be_init) = bad;
        let (mut init, mut goal): (Vec<&str>, Vec<&str>) = (init, goal.iter().map(|(t, _)| *t).collect());
        let side = if in_init && may_be_init { &mut init } else { &mut goal };
        let at = position.index(side.len() + 1);
        side.insert(at, text);
        let problem_text = problem_text(&init, &goal);
        let domain = pddl_syntax::parse_domain(&household().0).expect("domain");
        let problem = pddl_syntax::parse_problem(&problem_text).unwrap_or_else(|e| panic!("{problem_text}: {e:?}"));
        match grounding::ground(&domain, &problem) {
            Err(GroundingError::Invalid { domain, problem }) => {
                prop_assert!(domain.is_empty(), "the domain checks");
                let kinds: Vec<DiagnosticKind> = problem.iter().filter(|d| d.is_error()).map(|d| d.kind).collect();
                prop_assert_eq!(kinds, vec![kind], "{}", problem_text);
            }
            other => prop_assert!(false, "{problem_text}: {:?}", other.map(|t| t.actions.len())),
        }
    }
}

#[test]
fn household_grounds_to_the_expected_task() {
    let (domain, problem) = household();
    let task =
        grounding::ground(&pddl_syntax::parse_domain(&domain).expect("domain"), &pddl_syntax::parse_problem(&problem).expect("problem"))
            .expect("grounds");
    let mut names: Vec<String> = task.action_ids().map(|a| task.action_name(a)).collect();
    names.sort();
    // Walk between the two places (a container is a place), grab from either place, put
    // into the dishwasher; `closed` is never true, so `(not (closed ...))` is static and gone.
    assert_eq!(
        names,
        [
            "(grab wineglass dishwasher)",
            "(grab wineglass kitchentable)",
            "(putin wineglass dishwasher)",
            "(walk dishwasher kitchentable)",
            "(walk kitchentable dishwasher)",
        ]
    );
    assert!(task.uses_costs);
    assert_eq!(task.actions.iter().map(|a| a.cost).sum::<u32>(), 1 + 1 + 1 + 2 + 2);
    assert!(!task.has_unit_costs(), "walking costs 2");
    let mut unit = task.clone();
    unit.actions.retain(|a| a.cost == 1);
    assert!(unit.has_unit_costs());
    let mut facts: Vec<String> = task.fact_ids().map(|f| task.fact_name(f)).collect();
    facts.sort();
    assert_eq!(
        facts,
        [
            "(at dishwasher)",
            "(at kitchentable)",
            "(handempty)",
            "(holding wineglass)",
            "(on wineglass dishwasher)",
            "(on wineglass kitchentable)"
        ]
    );
    assert_eq!(task.goal.disjuncts.len(), 1);
    assert!(task.actions.iter().all(|a| a.pre.neg.is_empty() && a.pre.clauses.is_empty()));
}
