//! Laws of the heuristics on small random STRIPS tasks with action costs and negative
//! preconditions, and on others with conditional effects too (admissible LM-cut there): h_max ≤
//! LM-cut ≤ h* (h* from A* with the blind heuristic) and
//! LM-cut ≤ h_FF, h_max ≤ h_add; h_max and h_add equal a naive fixpoint over the whole
//! relaxation (negation facts included, no relevance pruning); every heuristic is 0 in goal
//! states and ∞ exactly when the relaxation cannot reach the goal; every returned plan
//! validates.

use heuristics::search::{Algorithm, SearchConfig, SearchStatus, search};
use heuristics::{Blind, GoalCount, HAdd, HFF, HMax, Heuristic, LmCut, Memo, RemainingPlanCost, WeightedMix};
use proptest::prelude::*;
use transition_model::{State, TransitionModel};

#[derive(Debug, Clone)]
struct RandomAction {
    pre: Vec<usize>,
    /// Facts that must be false.
    neg: Vec<usize>,
    add: Vec<usize>,
    del: Vec<usize>,
    cost: u32,
    /// Conditional effects: their condition (facts that must hold), adds and deletes.
    conditional: Vec<(Vec<usize>, Vec<usize>, Vec<usize>)>,
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
        let action = (subset(3), subset(2), prop::collection::vec(0..facts, 1..3), subset(2), 0u32..4)
            .prop_map(|(pre, neg, add, del, cost)| RandomAction { pre, neg, add, del, cost, conditional: Vec::new() });
        (Just(facts), subset(3), prop::collection::vec(0..facts, 1..4), prop::collection::vec(action, 1..9))
            .prop_map(|(facts, init, goal, actions)| RandomTask { facts, init, goal, actions })
    })
}

/// Tasks whose actions also have up to three conditional effects each, several of which one
/// application can fire together (where charging each apart overestimates).
fn random_conditional_task() -> impl Strategy<Value = RandomTask> {
    (3usize..8).prop_flat_map(|facts| {
        let subset = move |max: usize| prop::collection::vec(0..facts, 0..max);
        let effect = (subset(3), prop::collection::vec(0..facts, 1..3), subset(2));
        let action = (subset(3), subset(2), subset(3), subset(2), 0u32..4, prop::collection::vec(effect, 0..4))
            .prop_map(|(pre, neg, add, del, cost, conditional)| RandomAction { pre, neg, add, del, cost, conditional });
        (Just(facts), subset(3), prop::collection::vec(0..facts, 1..5), prop::collection::vec(action, 1..8))
            .prop_map(|(facts, init, goal, actions)| RandomTask { facts, init, goal, actions })
    })
}

fn pddl(task: &RandomTask) -> (String, String) {
    let atoms = |facts: &[usize]| facts.iter().map(|f| format!("(p{f})")).collect::<Vec<_>>().join(" ");
    let mut domain = String::from("(define (domain random) (:requirements :strips :action-costs :conditional-effects) (:predicates");
    for f in 0..task.facts {
        domain.push_str(&format!(" (p{f})"));
    }
    domain.push_str(") (:functions (total-cost) - number)");
    for (i, action) in task.actions.iter().enumerate() {
        let not = |facts: &[usize]| facts.iter().map(|f| format!("(not (p{f}))")).collect::<Vec<_>>().join(" ");
        let dels = [not(&action.del)];
        let when: Vec<String> = action
            .conditional
            .iter()
            .map(|(condition, add, del)| format!("(when (and {}) (and {} {}))", atoms(condition), atoms(add), not(del)))
            .collect();
        domain.push_str(&format!(
            " (:action a{i} :parameters () :precondition (and {} {}) :effect (and {} {} {} (increase (total-cost) {})))",
            atoms(&action.pre),
            not(&action.neg),
            atoms(&action.add),
            dels.join(" "),
            when.join(" "),
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

/// h_max or h_add of the delete relaxation by a naive Bellman-Ford fixpoint over every
/// action, with Fast Downward's treatment of negative preconditions: fact `f + n` (`n` task
/// facts) stands for "`f` is false", true where the state lacks `f` and added by the actions
/// that delete `f` and do not add it. `None` when the goal is unreachable.
fn naive_relaxed(model: &TransitionModel, state: &State, add: bool) -> Option<u64> {
    let task = model.task();
    let n = task.facts.len();
    let mut cost: Vec<Option<u64>> = (0..2 * n)
        .map(|f| {
            let holds =
                if f < n { state.contains(grounding::FactId(f as u32)) } else { !state.contains(grounding::FactId((f - n) as u32)) };
            holds.then_some(0)
        })
        .collect();
    // A condition's cost: its facts combined, each clause costing its cheapest literal.
    let literal = |l: &grounding::Literal| if l.is_negated() { l.fact().index() + n } else { l.fact().index() };
    let condition = |c: &grounding::Condition, cost: &[Option<u64>]| -> Option<u64> {
        let mut total = 0u64;
        let facts = c.pos.iter().map(|f| f.index()).chain(c.neg.iter().map(|f| f.index() + n));
        let clauses = c.clauses.iter().map(|clause| clause.iter().filter_map(|l| cost[literal(l)]).min());
        for value in facts.map(|f| cost[f]).chain(clauses) {
            let value = value?;
            total = if add { total + value } else { total.max(value) };
        }
        Some(total)
    };
    // A conditional effect needs the action's precondition and its own condition: one set of
    // facts, a fact in both counted once (as Fast Downward's relaxation does).
    let both = |pre: &grounding::Condition, extra: &grounding::Condition| {
        let mut merged = pre.clone();
        merged.pos.extend(&extra.pos);
        merged.neg.extend(&extra.neg);
        merged.clauses.extend(extra.clauses.iter().cloned());
        for list in [&mut merged.pos, &mut merged.neg] {
            list.sort();
            list.dedup();
        }
        merged.clauses.sort();
        merged.clauses.dedup();
        merged
    };
    loop {
        let mut improved = false;
        for action in &task.actions {
            let Some(base) = condition(&action.pre, &cost) else { continue };
            let mut effects = vec![(base, action.add.clone(), action.del.clone())];
            for effect in &action.conditional {
                if let Some(reached) = condition(&both(&action.pre, &effect.condition), &cost) {
                    effects.push((reached, effect.add.clone(), effect.del.clone()));
                }
            }
            for (reached, adds, dels) in effects {
                let reached = reached + u64::from(action.cost);
                let negations = dels.iter().filter(|f| !action.add.contains(f) && !adds.contains(f)).map(|f| f.index() + n);
                for f in adds.iter().map(|f| f.index()).chain(negations).collect::<Vec<_>>() {
                    if cost[f].is_none_or(|c| reached < c) {
                        cost[f] = Some(reached);
                        improved = true;
                    }
                }
            }
        }
        if !improved {
            break;
        }
    }
    task.goal.disjuncts.iter().filter_map(|d| condition(d, &cost)).min()
}

/// The task's transition model and its optimal plan (A* with the blind heuristic).
fn model_and_optimum(task: &RandomTask) -> (TransitionModel, heuristics::search::SearchResult) {
    let (domain, problem) = pddl(task);
    let domain = pddl_syntax::parse_domain(&domain).expect("generated domain parses");
    let problem = pddl_syntax::parse_problem(&problem).expect("generated problem parses");
    // Over declared nullary predicates a generated task always grounds.
    let grounded = grounding::ground(&domain, &problem).unwrap_or_else(|e| panic!("a generated task grounds: {e}"));
    let model = TransitionModel::new(grounded);
    let optimal = search(&model, &mut Blind::new(&model), &SearchConfig::new(Algorithm::AStar), None);
    (model, optimal)
}

/// Whether the delete relaxation reaches the goal from `state`.
fn relaxed_solvable(model: &TransitionModel, state: &State) -> bool {
    naive_relaxed(model, state, false).is_some()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 300,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x6865_7572_6973),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn heuristic_laws_hold(task in random_task()) {
        let (model, optimal) = model_and_optimum(&task);
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
        let mut lmcut_admissible = LmCut::admissible(&model);
        let (mut hmax, mut hadd, mut ff, mut lmcut, mut goalcount) =
            (HMax::new(&model), HAdd::new(&model), HFF::new(&model), LmCut::new(&model), GoalCount::new(&model));
        let mut remaining = optimal.cost;
        for (i, state) in states.iter().enumerate() {
            let values = [hmax.evaluate(state), hadd.evaluate(state), ff.evaluate(state), lmcut.evaluate(state)];
            let full = lmcut_full.evaluate(state);
            // Without conditional effects, sharing has nothing to share: the same heuristic.
            prop_assert_eq!(lmcut_admissible.evaluate(state), values[3], "admissible LM-cut without conditional effects");
            prop_assert_eq!(full.is_some(), values[3].is_some());
            if let (Some(value), Some(max)) = (full, values[0]) {
                prop_assert!(max <= value, "full-recompute LM-cut {} < h_max {}", value, max);
                if optimal.status == SearchStatus::Solved {
                    prop_assert!(u64::from(value) <= remaining, "full-recompute LM-cut {} > h* {}", value, remaining);
                }
            }
            let solvable = relaxed_solvable(&model, state);
            prop_assert_eq!(values[0].map(u64::from), naive_relaxed(&model, state, false), "h_max against the naive fixpoint");
            prop_assert_eq!(values[1].map(u64::from), naive_relaxed(&model, state, true), "h_add against the naive fixpoint");
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

    /// With conditional effects (which Fast Downward's LM-cut refuses), admissible LM-cut
    /// (`LmCut::admissible`) is admissible: h_max ≤ LM-cut ≤ h* on every state of an optimal
    /// plan, incremental or recomputed, and A* with it finds optimal plans; h_max and h_add equal the naive
    /// fixpoint. (Not LM-cut ≤ h_FF: h_FF counts each action of its relaxed plan once, and a
    /// conditional effect may need its action applied twice, once to make its condition true:
    /// `a` adds `p` and, where `p` holds, `g`; h* = h_max = LM-cut = 2, h_FF = 1.)
    #[test]
    fn lmcut_is_admissible_with_conditional_effects(task in random_conditional_task()) {
        let (model, optimal) = model_and_optimum(&task);
        let mut states = vec![model.initial_state()];
        for &action in &optimal.plan {
            let next = model.apply(states.last().expect("a state"), action);
            states.push(next);
        }
        let (mut hmax, mut hadd) = (HMax::new(&model), HAdd::new(&model));
        let (mut lmcut, mut full) = (LmCut::admissible(&model), LmCut::admissible(&model).recomputing());
        let mut remaining = optimal.cost;
        for (i, state) in states.iter().enumerate() {
            let max = hmax.evaluate(state);
            prop_assert_eq!(max.map(u64::from), naive_relaxed(&model, state, false), "h_max against the naive fixpoint");
            prop_assert_eq!(hadd.evaluate(state).map(u64::from), naive_relaxed(&model, state, true), "h_add against the naive fixpoint");
            for (name, value) in [("incremental", lmcut.evaluate(state)), ("recomputed", full.evaluate(state))] {
                prop_assert_eq!(value.is_some(), max.is_some(), "{}: dead end exactly when h_max's", name);
                if let (Some(value), Some(max)) = (value, max) {
                    prop_assert!(max <= value, "{} LM-cut {} < h_max {}", name, value, max);
                    if optimal.status == SearchStatus::Solved {
                        prop_assert!(u64::from(value) <= remaining, "{} LM-cut {} > h* {}", name, value, remaining);
                    }
                }
            }
            if let Some(&action) = optimal.plan.get(i) {
                remaining -= u64::from(model.task().action(action).cost);
            }
        }
        let lmcut_astar = search(&model, &mut LmCut::admissible(&model), &SearchConfig::new(Algorithm::AStar), None);
        prop_assert_eq!(lmcut_astar.status, optimal.status);
        prop_assert_eq!(lmcut_astar.cost, optimal.cost, "A* with admissible LM-cut is optimal");
        // `bounded_plan` finds a plan within a bound of h*, and proves none within one less.
        if optimal.status == SearchStatus::Solved {
            let mut bounded = SearchConfig::new(Algorithm::AStar);
            bounded.max_cost = Some(optimal.cost);
            let plan = heuristics::search::bounded_plan(&model, &bounded);
            prop_assert!(plan.as_ref().is_ok_and(|p| model.validate(p).is_ok_and(|v| v.cost <= optimal.cost)), "{:?}", plan);
            if optimal.cost > 0 {
                bounded.max_cost = Some(optimal.cost - 1);
                let below = heuristics::search::bounded_plan(&model, &bounded);
                prop_assert!(matches!(below, Err(SearchStatus::OverBound)), "{:?}", below);
            }
        }
    }
}

/// The probe that found the overestimate: `act` adds `q` and, where `p` holds, `r1` and `r2`;
/// `fin` needs all three. One `act` after `setp` serves: h* is 3 (`setp`, `act`, `fin`). With
/// `act`'s conditional effects charged apart (`LmCut::new`), LM-cut is 4.
#[test]
fn an_action_whose_conditional_effects_the_goal_needs_is_charged_once() {
    let domain = "(define (domain ce) (:requirements :strips :conditional-effects)\n\
        (:predicates (p) (q) (r1) (r2) (done))\n\
        (:action setp :parameters () :precondition () :effect (p))\n\
        (:action act :parameters () :precondition () :effect (and (q) (when (p) (r1)) (when (p) (r2))))\n\
        (:action fin :parameters () :precondition (and (q) (r1) (r2)) :effect (done)))\n";
    let problem = "(define (problem cep) (:domain ce) (:init) (:goal (done)))\n";
    let task = grounding::ground(&pddl_syntax::parse_domain(domain).unwrap(), &pddl_syntax::parse_problem(problem).unwrap()).unwrap();
    let model = TransitionModel::new(task);
    let init = model.initial_state();
    assert_eq!(LmCut::admissible(&model).evaluate(&init), Some(3));
    assert_eq!(LmCut::admissible(&model).recomputing().evaluate(&init), Some(3));
    assert_eq!(HMax::new(&model).evaluate(&init), Some(3));
    // Charged apart (`lmcut`, the informative one), it overestimates, as its docs say, and A*
    // with it bounded by h* cuts off every plan; `bounded_plan` checks that and finds the plan.
    assert_eq!(LmCut::new(&model).evaluate(&init), Some(4));
    let mut bounded = SearchConfig::new(Algorithm::AStar);
    bounded.max_cost = Some(3);
    assert_eq!(search(&model, &mut LmCut::new(&model), &bounded, None).status, SearchStatus::OverBound);
    assert_eq!(heuristics::search::bounded_plan(&model, &bounded).map(|p| p.len()), Ok(3));
    bounded.max_cost = Some(2);
    assert_eq!(heuristics::search::bounded_plan(&model, &bounded), Err(SearchStatus::OverBound));
    // With no expansion to spend, the initial state's admissible value (3) still proves it.
    bounded.max_expansions = Some(0);
    assert_eq!(heuristics::search::bounded_plan(&model, &bounded), Err(SearchStatus::OverBound));
}

/// On the household benchmarks, where negative preconditions matter (ALFWorld's empty hand,
/// VirtualHome's hands and postures) and the relevance pruning drops most operators, h_max
/// and h_add equal the naive fixpoint over the whole relaxation, along random walks.
#[test]
fn household_relaxations_match_the_naive_fixpoint() {
    use benchmark_data::{Benchmark, load};
    let mut checked = 0;
    for (benchmark, step) in [(Benchmark::AlfworldSeen, 20), (Benchmark::VirtualhomeEai, 40)] {
        for files in load(benchmark).expect("fixtures").into_iter().step_by(step) {
            let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
            let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
            let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
            let (mut hmax, mut hadd) = (HMax::new(&model), HAdd::new(&model));
            for state in model.random_walk(0xC0FFEE, 25) {
                assert_eq!(hmax.evaluate(&state).map(u64::from), naive_relaxed(&model, &state, false), "{}: h_max", files.id);
                assert_eq!(hadd.evaluate(&state).map(u64::from), naive_relaxed(&model, &state, true), "{}: h_add", files.id);
                checked += 1;
            }
        }
    }
    assert!(checked > 200, "{checked} states");
}

/// A conditional effect's condition that repeats the action's precondition counts once, as in
/// Fast Downward (its relaxation sorts and deduplicates each unary operator's preconditions):
/// `make-p` (cost 1) reaches `p`, then `finish` (cost 1) with `(when (p) (g))` reaches `g`, so
/// h_add is 2, not 3. Fast Downward 26.6 gives 2 for add, hmax, ff and lmcut on these files.
#[test]
fn a_condition_that_repeats_the_precondition_counts_once() {
    let domain = "(define (domain d) (:requirements :strips :conditional-effects)\n\
        (:predicates (p) (q) (g))\n\
        (:action make-p :parameters () :precondition (q) :effect (p))\n\
        (:action finish :parameters () :precondition (p) :effect (when (p) (g))))\n";
    let problem = "(define (problem e) (:domain d) (:init (q)) (:goal (g)))\n";
    let task = grounding::ground(&pddl_syntax::parse_domain(domain).unwrap(), &pddl_syntax::parse_problem(problem).unwrap()).unwrap();
    let model = TransitionModel::new(task);
    let init = model.initial_state();
    assert_eq!(HAdd::new(&model).evaluate(&init), Some(2));
    assert_eq!(HMax::new(&model).evaluate(&init), Some(2));
    assert_eq!(HFF::new(&model).evaluate(&init), Some(2));
    assert_eq!(LmCut::new(&model).evaluate(&init), Some(2));
}

/// A conditional effect that cannot fire in the evaluated state (its condition `r` needs `u`,
/// which `drop-u` deleted and nothing adds back) shares its action's cost with the action's
/// reachable part, but lends it no reach: lowering its cost once `a` is cut must not make `g`,
/// and through `c` the goal's `s`, look reachable. h* from that state is 9 (`a`, then `e`).
#[test]
fn a_conditional_effect_out_of_reach_lends_no_reach() {
    let domain = "(define (domain ce2) (:requirements :strips :conditional-effects :action-costs)\n\
        (:predicates (p) (q) (r) (u) (g) (s))\n\
        (:functions (total-cost) - number)\n\
        (:action drop-u :parameters () :precondition (u) :effect (and (not (u)) (increase (total-cost) 0)))\n\
        (:action make-r :parameters () :precondition (u) :effect (and (r) (increase (total-cost) 1)))\n\
        (:action a :parameters () :precondition (p) :effect (and (q) (when (r) (g)) (increase (total-cost) 5)))\n\
        (:action x :parameters () :precondition (p) :effect (and (q) (increase (total-cost) 6)))\n\
        (:action e :parameters () :precondition (p) :effect (and (s) (increase (total-cost) 4)))\n\
        (:action c :parameters () :precondition (g) :effect (and (s) (increase (total-cost) 0))))\n";
    let problem =
        "(define (problem ce2p) (:domain ce2) (:init (p) (u) (= (total-cost) 0)) (:goal (and (q) (s))) (:metric minimize (total-cost)))\n";
    let task = grounding::ground(&pddl_syntax::parse_domain(domain).unwrap(), &pddl_syntax::parse_problem(problem).unwrap()).unwrap();
    let model = TransitionModel::new(task);
    let drop = (0..model.task().actions.len())
        .map(grounding::ActionId::from_index)
        .find(|&id| model.task().schemas[model.task().action(id).schema.index()].name == "drop-u")
        .expect("drop-u");
    let state = model.apply(&model.initial_state(), drop);
    assert_eq!(LmCut::admissible(&model).evaluate(&state), Some(9));
    assert_eq!(LmCut::admissible(&model).recomputing().evaluate(&state), Some(9));
}
