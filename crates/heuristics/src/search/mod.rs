//! Classical search over the transition model: A* and greedy best-first search (eager and
//! lazy, optionally with preferred operators), with budgets on expansions and time.
//!
//! Used for "remaining plan cost" from a state, and as a symbolic planner in its own right.
//! States are registered projected onto the goal-relevant facts ([`relevant_facts`]), as
//! Fast Downward's translator drops irrelevant variables: the plans are the same, the space
//! can be much smaller. Heuristics see projected states too, with unchanged values: the delete
//! relaxation keeps only goal-relevant operators, whose preconditions are all relevant facts.
//! Open lists break ties like Fast Downward's: A* orders by (f, h) then insertion order; GBFS
//! by h then insertion order. Dead ends (h = ∞) are never inserted. A* can register states up
//! to a permutation of interchangeable objects ([`SearchConfig::symmetries`], [`symmetry`]).

mod clock;
mod registry;
pub mod symmetry;

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::Arc;
use std::time::Duration;

use grounding::ActionId;
use transition_model::{State, TransitionModel};

use crate::Heuristic;
pub use clock::{Clock, Stopwatch};
pub use registry::{StateId, StateRegistry, relevant_facts};
pub use symmetry::ObjectSymmetries;

/// Which search (command-line names `astar`, `gbfs`, `lazy-gbfs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, strum::EnumString, strum::IntoStaticStr, strum::VariantNames, strum::VariantArray)]
#[strum(serialize_all = "kebab-case", parse_err_ty = crate::UnknownName, parse_err_fn = Algorithm::unknown)]
pub enum Algorithm {
    /// A* on f = g + h: with an admissible heuristic (LM-cut without conditional effects,
    /// [`crate::LmCut::admissible`] with them) its plans are optimal; a cheaper path reopens a
    /// closed state.
    #[strum(serialize = "astar")]
    AStar,
    /// Eager greedy best-first search: successors are evaluated when generated.
    Gbfs,
    /// Lazy greedy best-first search: successors inherit their parent's value and are
    /// evaluated when expanded.
    LazyGbfs,
}

impl Algorithm {
    fn unknown(given: &str) -> crate::UnknownName {
        crate::UnknownName::of::<Algorithm>("search algorithm", given)
    }
}

/// Limits and options of one search.
#[derive(Debug, Clone)]
pub struct SearchConfig {
    /// Which search runs.
    pub algorithm: Algorithm,
    /// Use the heuristic's preferred operators (GBFS only): a second open list holding
    /// only successors reached by preferred operators, alternated with the first, with
    /// Fast Downward's boost of 1000 priority on progress for the lazy variant.
    pub preferred_operators: bool,
    /// Stop (`OutOfBudget`) after expanding this many states: the same answer on any machine.
    pub max_expansions: Option<u64>,
    /// Stop (`OutOfBudget`) after this long, read on `clock`.
    pub time_limit: Option<Duration>,
    /// What `time_limit` is read on (the wall clock by default).
    pub clock: Clock,
    /// A* only: plans costing more are not wanted. A node whose f = g + h exceeds it is pruned
    /// (with an admissible heuristic no plan within the bound is lost; [`crate::LmCut::new`] on a
    /// task with conditional effects may lose one, [`crate::LmCut::admissible`] does not), and a
    /// search that finds none ends `OverBound`. An episode's planner sets it to the steps the
    /// episode has left: a plan that cannot finish is not searched for. (Fast Downward's `bound` is
    /// the same cut, exclusive.)
    pub max_cost: Option<u64>,
    /// The goal-relevant facts states are projected onto ([`relevant_facts`]); computed by
    /// each search when `None`. Set it to share one analysis across many searches.
    pub relevant: Option<Arc<[u64]>>,
    /// A* only: register states up to a permutation of interchangeable objects
    /// ([`symmetry::ObjectSymmetries`]; orbit search): plans stay optimal and are the task's
    /// own, states that differ only in which of several identical objects is where are one.
    /// Off by default, as in Fast Downward.
    pub symmetries: bool,
}

impl SearchConfig {
    /// `algorithm` with no budget, no cost bound, no preferred operators and no symmetries, timed
    /// on the wall clock; relevant facts are computed by the search.
    pub fn new(algorithm: Algorithm) -> SearchConfig {
        SearchConfig {
            algorithm,
            preferred_operators: false,
            max_expansions: None,
            time_limit: None,
            clock: Clock::Wall,
            max_cost: None,
            relevant: None,
            symmetries: false,
        }
    }
}

/// How a search ended. As the error of [`optimal_plan`] and its kin it is never `Solved`; it
/// implements `std::error::Error`, so `optimal_plan(..)?` works in a function returning
/// `Box<dyn Error>` or `anyhow::Result`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, strum::IntoStaticStr)]
#[strum(serialize_all = "kebab-case")]
pub enum SearchStatus {
    /// A plan reaching the goal was found.
    Solved,
    /// The whole reachable space (under the heuristic's dead-end pruning) was searched.
    Unsolvable,
    /// A budget ran out.
    OutOfBudget,
    /// No plan within `SearchConfig::max_cost` (A*): the space was searched up to the bound
    /// (whether plans exist beyond it is not known: a state pruned there may be a dead end).
    OverBound,
}

impl SearchStatus {
    /// Its name in records and on the command line: `solved`, `unsolvable`, `out-of-budget`,
    /// `over-bound` (the sentence is its `Display`).
    pub fn name(self) -> &'static str {
        self.into()
    }
}

impl std::fmt::Display for SearchStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SearchStatus::Solved => "solved",
            SearchStatus::Unsolvable => "no plan exists (the reachable states were searched)",
            SearchStatus::OutOfBudget => "no plan found within the search's budget",
            SearchStatus::OverBound => "no plan within the cost bound",
        })
    }
}

impl std::error::Error for SearchStatus {}

/// What a search found and what it cost.
#[derive(Debug, Clone)]
pub struct SearchResult {
    /// How it ended.
    pub status: SearchStatus,
    /// The plan, from the start state to a goal state; empty unless `status` is `Solved`.
    pub plan: Vec<ActionId>,
    /// The plan's cost (action costs, or its length where the task has none); 0 unless
    /// `status` is `Solved` (check the status, not the cost: a goal that holds at the start
    /// is solved at cost 0 too).
    pub cost: u64,
    /// States expanded (their successors generated), as Fast Downward counts them.
    pub expanded: u64,
    /// States whose heuristic value was computed.
    pub evaluated: u64,
    /// Successor states generated.
    pub generated: u64,
    /// Real time the search took (whatever clock its limit was read on).
    pub elapsed: Duration,
}

#[derive(Debug, Clone, Copy)]
struct Node {
    g: u64,
    parent: StateId,
    action: u32,
    closed: bool,
    h: u32,
}

const NO_PARENT: StateId = StateId::MAX;
const UNEVALUATED: u32 = u32::MAX;

struct Space {
    registry: StateRegistry,
    nodes: Vec<Node>,
}

impl Space {
    fn new(task: &grounding::Task, config: &SearchConfig) -> Space {
        let mask = config.relevant.as_deref().map_or_else(|| relevant_facts(task), <[u64]>::to_vec);
        Space { registry: StateRegistry::projected(mask), nodes: Vec::new() }
    }

    fn insert(&mut self, state: &State) -> (StateId, bool) {
        let (id, new) = self.registry.insert(state);
        if new {
            self.nodes.push(Node { g: u64::MAX, parent: NO_PARENT, action: 0, closed: false, h: UNEVALUATED });
        }
        (id, new)
    }

    fn plan(&self, mut id: StateId) -> Vec<ActionId> {
        let mut plan = Vec::new();
        while self.nodes[id as usize].parent != NO_PARENT {
            plan.push(ActionId(self.nodes[id as usize].action));
            id = self.nodes[id as usize].parent;
        }
        plan.reverse();
        plan
    }
}

struct Budget {
    start: Stopwatch,
    config: SearchConfig,
}

impl Budget {
    /// Checked before every expansion: reading the wall clock costs tens of nanoseconds (the
    /// processor clock is read at most once a millisecond, `Stopwatch::past`), an expansion
    /// with an expensive heuristic can cost seconds.
    fn exhausted(&self, expanded: u64) -> bool {
        self.config.max_expansions.is_some_and(|m| expanded >= m) || self.start.past(self.config.time_limit)
    }
}

/// A plan from the initial state by A* with LM-cut ([`crate::LmCut::new`]) within
/// `time_limit`, or the status that stopped it. Optimal where LM-cut is admissible, on tasks
/// without conditional effects; with them it may be costlier (for a proof, search with
/// [`crate::LmCut::admissible`]).
pub fn optimal_plan(model: &TransitionModel, time_limit: Duration) -> Result<Vec<ActionId>, SearchStatus> {
    let mut config = SearchConfig::new(Algorithm::AStar);
    config.time_limit = Some(time_limit);
    astar_lmcut(model, &config)
}

/// [`optimal_plan`] bounded by expanded states instead of time: the same answer on any machine
/// under any load (for tests and reproducible records).
pub fn optimal_plan_expanding(model: &TransitionModel, max_expansions: u64) -> Result<Vec<ActionId>, SearchStatus> {
    let mut config = SearchConfig::new(Algorithm::AStar);
    config.max_expansions = Some(max_expansions);
    astar_lmcut(model, &config)
}

/// A* with LM-cut under any [`SearchConfig`] (its algorithm is taken to be A*): budgets on
/// expansions and time, and a bound on the plan's cost.
pub fn optimal_plan_with(model: &TransitionModel, config: &SearchConfig) -> Result<Vec<ActionId>, SearchStatus> {
    astar_lmcut(model, &SearchConfig { algorithm: Algorithm::AStar, ..config.clone() })
}

/// A* with LM-cut within `config.max_cost` (and its budgets), whose `OverBound` is a proof: on a
/// task with conditional effects, where [`crate::LmCut::new`] may overestimate and cut off a plan
/// within the bound, an `OverBound` is checked by A* again with [`crate::LmCut::admissible`] on
/// what is left of the budget (mostly weaker, and slower per evaluation, so such a check may spend
/// the rest of the budget before it ends `OutOfBudget`; a plan it finds is returned). A plan
/// returned is within the bound, optimal where LM-cut is admissible.
pub fn bounded_plan(model: &TransitionModel, config: &SearchConfig) -> Result<Vec<ActionId>, SearchStatus> {
    let config = SearchConfig { algorithm: Algorithm::AStar, ..config.clone() };
    let stopwatch = Stopwatch::start(config.clock);
    let first = search(model, &mut crate::LmCut::new(model), &config, None);
    let result = if first.status == SearchStatus::OverBound && model.task().has_conditional_effects() {
        // A budget used up still lets the initial state's value prove the bound (A* prunes it
        // before it asks the budget).
        let mut left = config.clone();
        left.max_expansions = config.max_expansions.map(|m| m.saturating_sub(first.expanded));
        left.time_limit = config.time_limit.map(|t| t.saturating_sub(stopwatch.elapsed()));
        search(model, &mut crate::LmCut::admissible(model), &left, None)
    } else {
        first
    };
    match result.status {
        SearchStatus::Solved => Ok(result.plan),
        other => Err(other),
    }
}

fn astar_lmcut(model: &TransitionModel, config: &SearchConfig) -> Result<Vec<ActionId>, SearchStatus> {
    let mut heuristic = crate::LmCut::new(model);
    let result = search(model, &mut heuristic, config, None);
    match result.status {
        SearchStatus::Solved => Ok(result.plan),
        other => Err(other),
    }
}

/// Runs a search from `start` (the task's initial state when `None`).
pub fn search(model: &TransitionModel, heuristic: &mut dyn Heuristic, config: &SearchConfig, start: Option<&State>) -> SearchResult {
    let budget = Budget { start: Stopwatch::start(config.clock), config: config.clone() };
    let initial = start.cloned().unwrap_or_else(|| model.initial_state());
    match config.algorithm {
        Algorithm::AStar => astar(model, heuristic, &budget, initial),
        Algorithm::Gbfs => eager_greedy(model, heuristic, &budget, initial),
        Algorithm::LazyGbfs => lazy_greedy(model, heuristic, &budget, initial),
    }
}

fn finish(
    status: SearchStatus,
    space: &Space,
    goal: Option<StateId>,
    model: &TransitionModel,
    counts: (u64, u64, u64),
    budget: &Budget,
) -> SearchResult {
    let plan = goal.map(|g| space.plan(g)).unwrap_or_default();
    let cost = transition_model::plan_cost(model.task(), &plan);
    SearchResult { status, plan, cost, expanded: counts.0, evaluated: counts.1, generated: counts.2, elapsed: budget.start.wall_elapsed() }
}

fn astar(model: &TransitionModel, heuristic: &mut dyn Heuristic, budget: &Budget, initial: State) -> SearchResult {
    let task = model.task();
    let mut space = Space::new(task, &budget.config);
    let mut symmetries = budget.config.symmetries.then(|| ObjectSymmetries::detect(task)).filter(|s| !s.is_trivial());
    let (mut perm, mut image) = (Vec::new(), State::empty(task.facts.len()));
    let (mut expanded, mut evaluated, mut generated) = (0u64, 0u64, 0u64);
    let mut open: BinaryHeap<Reverse<(u64, u32, u64, StateId)>> = BinaryHeap::new();
    let mut sequence = 0u64;
    let (root, _) = space.insert(&initial);
    evaluated += 1;
    let Some(h) = heuristic.evaluate(&initial) else {
        return finish(SearchStatus::Unsolvable, &space, None, model, (0, evaluated, 0), budget);
    };
    let solved = |space: &Space, goal: StateId, counts, symmetries: &mut Option<ObjectSymmetries>| {
        let mut result = finish(SearchStatus::Solved, space, Some(goal), model, counts, budget);
        if let Some(symmetries) = symmetries {
            result.plan = unpermute(space, root, model, symmetries, &result.plan);
        }
        result
    };
    space.nodes[root as usize].g = 0;
    space.nodes[root as usize].h = h;
    let over = |f: u64| budget.config.max_cost.is_some_and(|bound| f > bound);
    // Whether the bound cut anything: then an empty open list means no plan within it.
    let mut pruned = over(u64::from(h));
    if !pruned {
        open.push(Reverse((u64::from(h), h, sequence, root)));
    }
    let mut applicable = Vec::new();
    while let Some(Reverse((f, _, _, id))) = open.pop() {
        let node = space.nodes[id as usize];
        if node.closed || node.g + u64::from(node.h) < f {
            continue; // stale entry
        }
        let state = space.registry.get(id);
        if model.is_goal(&state) {
            return solved(&space, id, (expanded, evaluated, generated), &mut symmetries);
        }
        if budget.exhausted(expanded) {
            return finish(SearchStatus::OutOfBudget, &space, None, model, (expanded, evaluated, generated), budget);
        }
        space.nodes[id as usize].closed = true;
        expanded += 1;
        model.applicable(&state, &mut applicable);
        for &action in &applicable {
            generated += 1;
            let mut next = model.apply(&state, action);
            if let Some(symmetries) = symmetries.as_mut() {
                canonicalize(symmetries, space.registry.mask(), &mut next, &mut perm, &mut image);
            }
            let g = node.g + u64::from(task.action(action).cost);
            let (child, new) = space.insert(&next);
            let child_node = &mut space.nodes[child as usize];
            if !new && g >= child_node.g {
                continue;
            }
            if child_node.h == UNEVALUATED {
                evaluated += 1;
                match heuristic.evaluate(&next) {
                    Some(h) => space.nodes[child as usize].h = h,
                    None => {
                        space.nodes[child as usize].h = crate::INFINITE;
                        continue;
                    }
                }
            }
            let child_node = &mut space.nodes[child as usize];
            if child_node.h == crate::INFINITE {
                continue;
            }
            if over(g + u64::from(child_node.h)) {
                pruned = true;
                continue;
            }
            // A cheaper path reopens a closed state (an admissible heuristic need not be
            // consistent, and LM-cut is not).
            child_node.g = g;
            child_node.parent = id;
            child_node.action = action.0;
            child_node.closed = false;
            sequence += 1;
            open.push(Reverse((g + u64::from(child_node.h), child_node.h, sequence, child)));
        }
    }
    let status = if pruned { SearchStatus::OverBound } else { SearchStatus::Unsolvable };
    finish(status, &space, None, model, (expanded, evaluated, generated), budget)
}

/// `state` as the search registers it under object symmetries: projected (so that the image
/// depends only on what is stored), then permuted to its image.
fn canonicalize(
    symmetries: &mut ObjectSymmetries,
    mask: Option<&[u64]>,
    state: &mut State,
    perm: &mut symmetry::Permutation,
    image: &mut State,
) {
    if let Some(mask) = mask {
        state.retain(mask);
    }
    if symmetries.canonical_permutation(state, perm) {
        symmetries.permute_state(state, perm, image);
        std::mem::swap(state, image);
    }
}

/// A plan over registered images, from `root`, as the task's own actions: each step's
/// successor is made again to recover the permutation that made its image.
fn unpermute(space: &Space, root: StateId, model: &TransitionModel, symmetries: &mut ObjectSymmetries, plan: &[ActionId]) -> Vec<ActionId> {
    let mut state = space.registry.get(root);
    let (mut perm, mut image) = (Vec::new(), State::empty(model.task().facts.len()));
    let mut steps = Vec::with_capacity(plan.len());
    for &action in plan {
        let mut next = model.apply(&state, action);
        canonicalize(symmetries, space.registry.mask(), &mut next, &mut perm, &mut image);
        steps.push((action, perm.clone()));
        state = next;
    }
    symmetries.unpermute_plan(model.task(), &steps)
}

/// Two open lists (all successors; preferred successors only), alternated; `boost` extra
/// turns for the preferred list each time the best h improves.
struct Alternation<T: Ord> {
    lists: [BinaryHeap<Reverse<T>>; 2],
    priority: [i64; 2],
    use_preferred: bool,
}

impl<T: Ord> Alternation<T> {
    fn new(use_preferred: bool) -> Self {
        Alternation { lists: [BinaryHeap::new(), BinaryHeap::new()], priority: [0, 0], use_preferred }
    }

    fn push(&mut self, entry: T, preferred: bool)
    where
        T: Clone,
    {
        if self.use_preferred && preferred {
            self.lists[1].push(Reverse(entry.clone()));
        }
        self.lists[0].push(Reverse(entry));
    }

    fn boost(&mut self, amount: i64) {
        if self.use_preferred {
            self.priority[1] -= amount;
        }
    }

    fn pop(&mut self) -> Option<T> {
        let candidates = if self.use_preferred { 2 } else { 1 };
        let mut best: Option<usize> = None;
        for i in 0..candidates {
            if self.lists[i].is_empty() {
                continue;
            }
            if best.is_none_or(|b| self.priority[i] < self.priority[b]) {
                best = Some(i);
            }
        }
        let i = best?;
        self.priority[i] += 1;
        self.lists[i].pop().map(|Reverse(e)| e)
    }
}

fn eager_greedy(model: &TransitionModel, heuristic: &mut dyn Heuristic, budget: &Budget, initial: State) -> SearchResult {
    let task = model.task();
    let mut space = Space::new(task, &budget.config);
    let (mut expanded, mut evaluated, mut generated) = (0u64, 0u64, 0u64);
    let mut open: Alternation<(u32, u64, StateId)> = Alternation::new(budget.config.preferred_operators);
    let mut sequence = 0u64;
    let (root, _) = space.insert(&initial);
    evaluated += 1;
    let Some(h) = heuristic.evaluate(&initial) else {
        return finish(SearchStatus::Unsolvable, &space, None, model, (0, evaluated, 0), budget);
    };
    space.nodes[root as usize].g = 0;
    space.nodes[root as usize].h = h;
    // Preferred operators of evaluated, not yet expanded states.
    let mut preferred_of: rustc_hash::FxHashMap<StateId, Box<[ActionId]>> = rustc_hash::FxHashMap::default();
    if budget.config.preferred_operators {
        preferred_of.insert(root, heuristic.preferred_operators().into());
    }
    open.push((h, sequence, root), false);
    let mut applicable = Vec::new();
    while let Some((_, _, id)) = open.pop() {
        if space.nodes[id as usize].closed {
            continue;
        }
        let state = space.registry.get(id);
        if model.is_goal(&state) {
            return finish(SearchStatus::Solved, &space, Some(id), model, (expanded, evaluated, generated), budget);
        }
        if budget.exhausted(expanded) {
            return finish(SearchStatus::OutOfBudget, &space, None, model, (expanded, evaluated, generated), budget);
        }
        space.nodes[id as usize].closed = true;
        expanded += 1;
        let parent_preferred = preferred_of.remove(&id).unwrap_or_default();
        model.applicable(&state, &mut applicable);
        let g_parent = space.nodes[id as usize].g;
        for &action in &applicable {
            generated += 1;
            let next = model.apply(&state, action);
            let (child, new) = space.insert(&next);
            if !new {
                continue;
            }
            evaluated += 1;
            let Some(h) = heuristic.evaluate(&next) else {
                space.nodes[child as usize].h = crate::INFINITE;
                continue;
            };
            let node = &mut space.nodes[child as usize];
            node.h = h;
            node.g = g_parent + u64::from(task.action(action).cost);
            node.parent = id;
            node.action = action.0;
            if budget.config.preferred_operators {
                preferred_of.insert(child, heuristic.preferred_operators().into());
            }
            sequence += 1;
            open.push((h, sequence, child), parent_preferred.contains(&action));
        }
    }
    finish(SearchStatus::Unsolvable, &space, None, model, (expanded, evaluated, generated), budget)
}

fn lazy_greedy(model: &TransitionModel, heuristic: &mut dyn Heuristic, budget: &Budget, initial: State) -> SearchResult {
    let task = model.task();
    let mut space = Space::new(task, &budget.config);
    let (mut expanded, mut evaluated, mut generated) = (0u64, 0u64, 0u64);
    // Entries: (parent's h, insertion order, parent, action).
    let mut open: Alternation<(u32, u64, StateId, u32)> = Alternation::new(budget.config.preferred_operators);
    let mut sequence = 0u64;
    let (root, _) = space.insert(&initial);
    space.nodes[root as usize].g = 0;
    let mut current = Some((root, NO_PARENT, 0u32));
    let mut applicable = Vec::new();
    let mut best_h = u32::MAX;
    while let Some((id, parent, action)) = current.take() {
        let state = space.registry.get(id);
        if space.nodes[id as usize].closed {
            // Already expanded through another path.
        } else {
            if parent != NO_PARENT {
                let node = &mut space.nodes[id as usize];
                node.parent = parent;
                node.action = action;
            }
            evaluated += 1;
            if let Some(h) = heuristic.evaluate(&state) {
                space.nodes[id as usize].h = h;
                if model.is_goal(&state) {
                    return finish(SearchStatus::Solved, &space, Some(id), model, (expanded, evaluated, generated), budget);
                }
                if budget.exhausted(expanded) {
                    return finish(SearchStatus::OutOfBudget, &space, None, model, (expanded, evaluated, generated), budget);
                }
                if h < best_h {
                    best_h = h;
                    open.boost(1000);
                }
                space.nodes[id as usize].closed = true;
                expanded += 1;
                let preferred = heuristic.preferred_operators();
                model.applicable(&state, &mut applicable);
                for &successor_action in &applicable {
                    generated += 1;
                    sequence += 1;
                    open.push((h, sequence, id, successor_action.0), preferred.contains(&successor_action));
                }
            } else {
                space.nodes[id as usize].closed = true;
            }
        }
        // Next: generate the successor of the best entry whose state is new.
        while let Some((_, _, from, via)) = open.pop() {
            let from_state = space.registry.get(from);
            let next = model.apply(&from_state, ActionId(via));
            let (child, _) = space.insert(&next);
            if space.nodes[child as usize].closed {
                continue;
            }
            let g = space.nodes[from as usize].g + u64::from(task.action(ActionId(via)).cost);
            if g < space.nodes[child as usize].g {
                space.nodes[child as usize].g = g;
            }
            current = Some((child, from, via));
            break;
        }
    }
    finish(SearchStatus::Unsolvable, &space, None, model, (expanded, evaluated, generated), budget)
}
