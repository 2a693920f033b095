//! The value of a plan prefix (paper Eq. 8): `R_G` when the state it reaches satisfies the
//! goal, else `−h(s, G) − λ·|π|`, with `h` a fixed weighted mix of h_FF, LM-cut and the
//! remaining plan cost (Appendix A.4), each in the task's action-cost units.

use heuristics::search::{Algorithm, SearchConfig, SearchStatus, search};
use heuristics::{HFF, Heuristic, LmCut};
use rustc_hash::FxHashMap;
use transition_model::{State, TransitionModel};

/// Weights and constants of the value.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ValueConfig {
    /// Weight of h_FF in the mix.
    pub ff: f64,
    /// Weight of LM-cut.
    pub lmcut: f64,
    /// Weight of the remaining plan cost (a bounded lazy GBFS with h_FF; h_FF when it runs out).
    pub remaining: f64,
    /// Expansion budget of each remaining-plan-cost search.
    pub remaining_expansions: u64,
    /// `R_G`, the value of a prefix that reaches the goal.
    pub goal_reward: f64,
    /// `λ`, the penalty per action of the prefix.
    pub length_penalty: f64,
}

impl Default for ValueConfig {
    fn default() -> Self {
        ValueConfig { ff: 1.0, lmcut: 1.0, remaining: 1.0, remaining_expansions: 200, goal_reward: 1.0, length_penalty: 0.1 }
    }
}

/// Evaluates states with the mix, remembering each state's `h`: MCTS reaches the same state
/// along many token paths, and a revisit costs a hash lookup.
///
/// The remaining plan cost is the cost of the plan a bounded lazy GBFS (h_FF, preferred
/// operators) finds from the state, h_FF where it finds none within its budget, ∞ where it
/// proves a dead end. A plan found from `s` also gives every state along it a remaining cost:
/// the cost of the plan's suffix from there, an estimate of the same kind (an upper bound on
/// h*). Those are remembered too, and MCTS, which tends to follow exactly those plans, then
/// finds them without searching again.
pub struct Evaluator<'m> {
    model: &'m TransitionModel,
    config: ValueConfig,
    ff: HFF<'m>,
    lmcut: LmCut,
    search_ff: HFF<'m>,
    search: SearchConfig,
    cache: FxHashMap<State, Option<f64>>,
    remaining: FxHashMap<State, u64>,
    evaluations: u64,
    lookups: u64,
    searches: u64,
}

impl std::fmt::Debug for Evaluator<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Evaluator").field("config", &self.config).field("cached", &self.cache.len()).finish_non_exhaustive()
    }
}

impl<'m> Evaluator<'m> {
    pub fn new(model: &'m TransitionModel, config: ValueConfig) -> Evaluator<'m> {
        let mut search = SearchConfig::new(Algorithm::LazyGbfs);
        search.preferred_operators = true;
        search.max_expansions = Some(config.remaining_expansions);
        Evaluator {
            model,
            config,
            ff: HFF::new(model),
            lmcut: LmCut::new(model),
            search_ff: HFF::new(model),
            search,
            cache: FxHashMap::default(),
            remaining: FxHashMap::default(),
            evaluations: 0,
            lookups: 0,
            searches: 0,
        }
    }

    pub fn config(&self) -> &ValueConfig {
        &self.config
    }

    pub fn model(&self) -> &'m TransitionModel {
        self.model
    }

    /// `h(s, G)`: 0 at the goal, `None` for a dead end.
    pub fn heuristic(&mut self, state: &State) -> Option<f64> {
        self.lookups += 1;
        if self.model.is_goal(state) {
            return Some(0.0);
        }
        if let Some(&h) = self.cache.get(state) {
            return h;
        }
        self.evaluations += 1;
        let h = self.mix(state);
        self.cache.insert(state.clone(), h);
        h
    }

    /// `Σ wᵢ·hᵢ(s) / Σ wᵢ` over the components with positive weight; `None` if any is ∞.
    fn mix(&mut self, state: &State) -> Option<f64> {
        let (w_ff, w_lmcut, w_remaining) = (self.config.ff, self.config.lmcut, self.config.remaining);
        let mut total = 0.0;
        let mut weights = 0.0;
        let ff = self.ff.evaluate(state)?;
        if w_ff > 0.0 {
            total += w_ff * f64::from(ff);
            weights += w_ff;
        }
        if w_lmcut > 0.0 {
            total += w_lmcut * f64::from(self.lmcut.evaluate(state)?);
            weights += w_lmcut;
        }
        if w_remaining > 0.0 {
            total += w_remaining * self.remaining_cost(state, ff)? as f64;
            weights += w_remaining;
        }
        Some(if weights > 0.0 { total / weights } else { 0.0 })
    }

    fn remaining_cost(&mut self, state: &State, ff: u32) -> Option<u64> {
        if let Some(&cost) = self.remaining.get(state) {
            return Some(cost);
        }
        self.searches += 1;
        let result = search(self.model, &mut self.search_ff, &self.search, Some(state));
        match result.status {
            SearchStatus::Unsolvable => None,
            SearchStatus::OutOfBudget => Some(u64::from(ff)),
            SearchStatus::Solved => {
                let task = self.model.task();
                let mut left = result.cost;
                let mut at = state.clone();
                for &action in &result.plan {
                    self.remaining.entry(at.clone()).or_insert(left);
                    left = left.saturating_sub(u64::from(task.action(action).cost));
                    at = self.model.apply(&at, action);
                }
                Some(result.cost)
            }
        }
    }

    /// Eq. 8 for a prefix of `length` actions reaching `state`; `None` for a dead end.
    pub fn value(&mut self, state: &State, length: usize) -> Option<f64> {
        if self.model.is_goal(state) {
            return Some(self.config.goal_reward);
        }
        let h = self.heuristic(state)?;
        Some(-h - self.config.length_penalty * length as f64)
    }

    /// Heuristic evaluations run (cache misses) and requested.
    pub fn counts(&self) -> (u64, u64) {
        (self.evaluations, self.lookups)
    }

    /// Remaining-plan-cost searches run (the rest came from earlier plans' suffixes).
    pub fn searches(&self) -> u64 {
        self.searches
    }
}
