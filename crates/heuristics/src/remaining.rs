//! "Remaining plan cost": the cost of a plan that a bounded search finds from the state
//! (the third component of the paper's value, Appendix A.4).

use grounding::ActionId;
use rustc_hash::FxHashMap;
use transition_model::{State, TransitionModel};

use crate::memo::Memo;
use crate::relaxation::HFF;
use crate::search::{Algorithm, SearchConfig, SearchStatus, search};
use crate::{Heuristic, INFINITE};

/// Lazy GBFS with h_FF and preferred operators, limited to `max_expansions`. When it finds
/// no plan within the budget, the value is h_FF of the state (an estimate of the same
/// quantity); when it proves the state a dead end, the value is ∞. A found plan is
/// remembered: a later state on it gets the cost of the plan's rest without a search (the
/// value is then the cheapest found plan through that state, so it depends on which states
/// were evaluated before, deterministically).
#[derive(Debug)]
pub struct RemainingPlanCost<'m> {
    model: &'m TransitionModel,
    ff: Memo<HFF<'m>>,
    config: SearchConfig,
    /// Every state on a plan found so far, with the cost of the rest of that plan (the
    /// cheapest if several plans pass through it): a plan from the state, found without
    /// searching again.
    found: FxHashMap<State, u32>,
}

impl<'m> RemainingPlanCost<'m> {
    /// The heuristic on `model`, each search limited to `max_expansions` expanded states (a
    /// budget that gives the same values on any machine). The goal-relevant facts are computed
    /// once here and shared by every search.
    pub fn new(model: &'m TransitionModel, max_expansions: u64) -> RemainingPlanCost<'m> {
        let mut config = SearchConfig::new(Algorithm::LazyGbfs);
        config.preferred_operators = true;
        config.max_expansions = Some(max_expansions);
        config.relevant = Some(crate::search::relevant_facts(model.task()).into());
        RemainingPlanCost { model, ff: Memo::new(HFF::new(model)), config, found: FxHashMap::default() }
    }

    /// Records the suffix costs of `plan` from `state` (bounded like [`Memo`]'s cache).
    fn remember(&mut self, state: &State, plan: &[ActionId]) {
        let task = self.model.task();
        let mut remaining: u64 = plan.iter().map(|&a| u64::from(task.action(a).cost)).sum();
        if self.found.len() + plan.len() >= Memo::<HFF<'_>>::DEFAULT_CAPACITY {
            self.found.clear();
        }
        let mut current = state.clone();
        for &action in plan {
            let cost = remaining.min(u64::from(INFINITE - 1)) as u32;
            let entry = self.found.entry(current.clone()).or_insert(cost);
            *entry = (*entry).min(cost);
            remaining -= u64::from(task.action(action).cost);
            current = self.model.apply(&current, action);
        }
    }
}

impl Heuristic for RemainingPlanCost<'_> {
    fn name(&self) -> &'static str {
        "remaining"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        if let Some(&cost) = self.found.get(state) {
            return Some(cost);
        }
        let result = search(self.model, &mut self.ff, &self.config, Some(state));
        match result.status {
            SearchStatus::Solved => {
                self.remember(state, &result.plan);
                Some(result.cost.min(u64::from(INFINITE - 1)) as u32)
            }
            SearchStatus::Unsolvable | SearchStatus::OverBound => None,
            SearchStatus::OutOfBudget => self.ff.evaluate(state),
        }
    }
}
