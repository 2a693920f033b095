//! Grounding never panics: problems with mutated initial states and goals either ground or
//! return an error. And grounding is deterministic.

use proptest::prelude::*;

fn household() -> (String, String) {
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures"));
    let read = |p: &str| std::fs::read_to_string(root.join(p)).expect("fixture");
    (read("pddl-valid/household/domain.pddl"), read("pddl-valid/household/problem.pddl"))
}

const PIECES: &[&str] = &[
    "(at dishwasher)",
    "(closed dishwasher)",
    "(holding wineglass)",
    "(on wineglass dishwasher)",
    "(not (handempty))",
    "(or (at kitchentable) (holding wineglass))",
    "(exists (?c - container) (on wineglass ?c))",
    "(forall (?p - place) (not (at ?p)))",
    "(= kitchentable dishwasher)",
    "(not (= wineglass wineglass))",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_problems_ground_or_fail_cleanly(
        init in prop::collection::vec(prop::sample::select(PIECES), 0..5),
        goal in prop::collection::vec(prop::sample::select(PIECES), 0..4),
    ) {
        let (domain, _) = household();
        let problem = format!(
            "(define (problem p) (:domain household) (:objects kitchentable - place dishwasher - container wineglass - item)
             (:init (handempty) {}) (:goal (and {})))",
            init.join(" "),
            goal.join(" ")
        );
        let domain = pddl_syntax::parse_domain(&domain).expect("domain");
        let Ok(problem) = pddl_syntax::parse_problem(&problem) else { return Ok(()) };
        if let Ok(task) = grounding::ground(&domain, &problem) {
            let again = grounding::ground(&domain, &problem).expect("grounds twice");
            prop_assert_eq!(&task.actions, &again.actions);
            prop_assert_eq!(&task.goal, &again.goal);
            for action in &task.actions {
                for f in action.pre.pos.iter().chain(&action.add).chain(&action.del) {
                    prop_assert!(f.index() < task.facts.len());
                }
            }
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
