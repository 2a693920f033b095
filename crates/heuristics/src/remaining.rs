//! "Remaining plan cost": the cost of a plan that a bounded search finds from the state
//! (the third component of the paper's value, Appendix A.4).

use transition_model::{State, TransitionModel};

use crate::memo::Memo;
use crate::relaxation::HFF;
use crate::search::{Algorithm, SearchConfig, SearchStatus, search};
use crate::{Heuristic, INFINITE};

/// Lazy GBFS with h_FF and preferred operators, limited to `max_expansions`. When it finds
/// no plan within the budget, the value is h_FF of the state (an estimate of the same
/// quantity); when it proves the state a dead end, the value is ∞.
#[derive(Debug)]
pub struct RemainingPlanCost<'m> {
    model: &'m TransitionModel,
    ff: Memo<HFF<'m>>,
    config: SearchConfig,
}

impl<'m> RemainingPlanCost<'m> {
    pub fn new(model: &'m TransitionModel, max_expansions: u64) -> RemainingPlanCost<'m> {
        let mut config = SearchConfig::new(Algorithm::LazyGbfs);
        config.preferred_operators = true;
        config.max_expansions = Some(max_expansions);
        RemainingPlanCost { model, ff: Memo::new(HFF::new(model)), config }
    }
}

impl Heuristic for RemainingPlanCost<'_> {
    fn name(&self) -> &'static str {
        "remaining"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        let result = search(self.model, &mut self.ff, &self.config, Some(state));
        match result.status {
            SearchStatus::Solved => Some(result.cost.min(u64::from(INFINITE - 1)) as u32),
            SearchStatus::Unsolvable => None,
            SearchStatus::OutOfBudget => self.ff.evaluate(state),
        }
    }
}
