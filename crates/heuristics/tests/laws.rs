//! Laws of the heuristics on small random STRIPS tasks with action costs:
//! h_max ≤ LM-cut ≤ h* (h* from A* with the blind heuristic) and LM-cut ≤ h_FF, h_max ≤ h_add;
//! every heuristic is 0 in goal states; a heuristic is ∞ exactly when the delete relaxation
//! cannot reach the goal (checked by a naive fixpoint here); every returned plan validates.

use heuristics::search::{Algorithm, SearchConfig, SearchStatus, search};
use heuristics::{Blind, GoalCount, HAdd, HFF, HMax, Heuristic, LmCut, Memo, RemainingPlanCost, WeightedMix};
use proptest::prelude::*;
use transition_model::{State, TransitionModel};

#[derive(Debug, Clone)]
struct RandomAction {
    pre: Vec<usize>,
    add: Vec<usize>,
    del: Vec<usize>,
    cost: u32,
}

#[derive(Debug, Clone)]
struct RandomTask {
    facts: usize,
    init: Vec<usize>,
    goal: Vec<usize>,
    actions: Vec<RandomAction>,
}

fn random_task() -> impl Strategy<Value = RandomTask> {
    (3usize..8).prop_flat_map(|facts| {
        let subset = move |max: usize| prop::collection::vec(0..facts, 0..max);
        let action = (subset(3), prop::collection::vec(0..facts, 1..3), subset(2), 0u32..4)
            .prop_map(|(pre, add, del, cost)| RandomAction { pre, add, del, cost });
        (Just(facts), subset(3), prop::collection::vec(0..facts, 1..4), prop::collection::vec(action, 1..9))
            .prop_map(|(facts, init, goal, actions)| RandomTask { facts, init, goal, actions })
    })
}

fn pddl(task: &RandomTask) -> (String, String) {
    let atoms = |facts: &[usize]| facts.iter().map(|f| format!("(p{f})")).collect::<Vec<_>>().join(" ");
    let mut domain = String::from("(define (domain random) (:requirements :strips :action-costs) (:predicates");
    for f in 0..task.facts {
        domain.push_str(&format!(" (p{f})"));
    }
    domain.push_str(") (:functions (total-cost) - number)");
    for (i, action) in task.actions.iter().enumerate() {
        let dels: Vec<String> = action.del.iter().map(|f| format!("(not (p{f}))")).collect();
        domain.push_str(&format!(
            " (:action a{i} :parameters () :precondition (and {}) :effect (and {} {} (increase (total-cost) {})))",
            atoms(&action.pre),
            atoms(&action.add),
            dels.join(" "),
            action.cost
        ));
    }
    domain.push(')');
    let problem = format!(
        "(define (problem p) (:domain random) (:init {} (= (total-cost) 0)) (:goal (and {})) (:metric minimize (total-cost)))",
        atoms(&task.init),
        atoms(&task.goal)
    );
    (domain, problem)
}

/// Whether the delete relaxation reaches the goal from `state` (naive fixpoint).
fn relaxed_solvable(model: &TransitionModel, state: &State) -> bool {
    let task = model.task();
    let mut reached: Vec<bool> = (0..task.facts.len()).map(|f| state.contains(grounding::FactId(f as u32))).collect();
    loop {
        let mut grew = false;
        for action in &task.actions {
            if action.pre.pos.iter().all(|f| reached[f.index()]) {
                for f in &action.add {
                    if !reached[f.index()] {
                        reached[f.index()] = true;
                        grew = true;
                    }
                }
            }
        }
        if !grew {
            break;
        }
    }
    task.goal.disjuncts.iter().any(|d| d.pos.iter().all(|f| reached[f.index()]))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn heuristic_laws_hold(task in random_task()) {
        let (domain, problem) = pddl(&task);
        let domain = pddl_syntax::parse_domain(&domain).expect("generated domain parses");
        let problem = pddl_syntax::parse_problem(&problem).expect("generated problem parses");
        let Ok(grounded) = grounding::ground(&domain, &problem) else { return Ok(()) };
        let model = TransitionModel::new(grounded);
        let optimal = search(&model, &mut Blind::new(&model), &SearchConfig::new(Algorithm::AStar), None);
        let mut states = vec![model.initial_state()];
        if optimal.status == SearchStatus::Solved {
            let valid = model.validate(&optimal.plan).expect("A* plans validate");
            prop_assert_eq!(valid.cost, optimal.cost);
            for &action in &optimal.plan {
                let next = model.apply(states.last().expect("a state"), action);
                states.push(next);
            }
        }
        let mut lmcut_full = LmCut::full(&model);
        let (mut hmax, mut hadd, mut ff, mut lmcut, mut goalcount) =
            (HMax::new(&model), HAdd::new(&model), HFF::new(&model), LmCut::new(&model), GoalCount::new(&model));
        let mut remaining = optimal.cost;
        for (i, state) in states.iter().enumerate() {
            let values = [hmax.evaluate(state), hadd.evaluate(state), ff.evaluate(state), lmcut.evaluate(state)];
            let full = lmcut_full.evaluate(state);
            prop_assert_eq!(full.is_some(), values[3].is_some());
            if let (Some(value), Some(max)) = (full, values[0]) {
                prop_assert!(max <= value, "full-recompute LM-cut {} < h_max {}", value, max);
                if optimal.status == SearchStatus::Solved {
                    prop_assert!(u64::from(value) <= remaining, "full-recompute LM-cut {} > h* {}", value, remaining);
                }
            }
            let solvable = relaxed_solvable(&model, state);
            for value in values {
                prop_assert_eq!(value.is_some(), solvable, "dead end exactly when relaxed-unsolvable");
            }
            if let [Some(max), Some(add), Some(ff_value), Some(cut)] = values {
                prop_assert!(max <= cut, "h_max {} > LM-cut {}", max, cut);
                prop_assert!(cut <= ff_value, "LM-cut {} > h_FF {}", cut, ff_value);
                prop_assert!(max <= add);
                if optimal.status == SearchStatus::Solved {
                    prop_assert!(u64::from(cut) <= remaining, "LM-cut {} > h* {}", cut, remaining);
                }
            }
            if model.is_goal(state) {
                prop_assert_eq!(values, [Some(0); 4]);
                prop_assert_eq!(goalcount.evaluate(state), Some(0));
            }
            if i < optimal.plan.len() {
                remaining -= u64::from(model.task().action(optimal.plan[i]).cost);
            }
        }
        for (algorithm, preferred) in [(Algorithm::Gbfs, false), (Algorithm::LazyGbfs, true), (Algorithm::AStar, false)] {
            let mut config = SearchConfig::new(algorithm);
            config.preferred_operators = preferred;
            let result = search(&model, &mut HFF::new(&model), &config, None);
            prop_assert_eq!(result.status == SearchStatus::Solved, optimal.status == SearchStatus::Solved);
            if result.status == SearchStatus::Solved {
                model.validate(&result.plan).expect("plans validate");
            }
        }
        // Remaining plan cost is the cost of a real plan: never below h*, ∞ only when unsolvable.
        let remaining_cost = RemainingPlanCost::new(&model, 10_000).evaluate(&model.initial_state());
        if optimal.status == SearchStatus::Solved {
            prop_assert!(remaining_cost.is_some_and(|c| u64::from(c) >= optimal.cost));
        } else if !relaxed_solvable(&model, &model.initial_state()) {
            prop_assert_eq!(remaining_cost, None);
        }
        // Along the optimal plan, a remembered suffix never undercuts h* either.
        if optimal.status == SearchStatus::Solved {
            let mut remaining = RemainingPlanCost::new(&model, 10_000);
            let mut h_star = optimal.cost;
            for (i, state) in states.iter().enumerate() {
                let value = remaining.evaluate(state);
                prop_assert!(value.is_some_and(|c| u64::from(c) >= h_star), "remaining {:?} < h* {}", value, h_star);
                if let Some(&action) = optimal.plan.get(i) {
                    h_star -= u64::from(model.task().action(action).cost);
                }
            }
        }
        // Memo answers as the heuristic it wraps, values and preferred operators, also when
        // its cache fills up (capacity 2) and starts again.
        let mut memo = Memo::with_capacity(HFF::new(&model), 2);
        let mut plain = HFF::new(&model);
        for state in states.iter().chain(states.iter().rev()) {
            prop_assert_eq!(memo.evaluate(state), plain.evaluate(state));
            prop_assert_eq!(memo.preferred_operators(), plain.preferred_operators());
        }
        prop_assert!(memo.counts().0 + memo.counts().1 == 2 * states.len() as u64);
        prop_assert!(memo.counts().0 >= 1, "the last state, asked twice in a row, is a hit");
        // The mix is the weighted average of its parts; a dead end for one is a dead end for it.
        let state = model.initial_state();
        let (ff_value, cut_value) = (HFF::new(&model).evaluate(&state), LmCut::new(&model).evaluate(&state));
        let mixed = WeightedMix::new().with(1.0, HFF::new(&model)).with(3.0, LmCut::new(&model)).evaluate(&state);
        match (ff_value, cut_value) {
            (Some(a), Some(b)) => prop_assert!((mixed.expect("mix") - (f64::from(a) + 3.0 * f64::from(b)) / 4.0).abs() < 1e-9),
            _ => prop_assert_eq!(mixed, None),
        }
        let lmcut_astar = search(&model, &mut LmCut::new(&model), &SearchConfig::new(Algorithm::AStar), None);
        prop_assert_eq!(lmcut_astar.status, optimal.status);
        prop_assert_eq!(lmcut_astar.cost, optimal.cost, "A* with LM-cut is optimal");
    }
}
