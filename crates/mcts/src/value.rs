//! The value of a plan prefix (paper Eq. 10): `R_G` when the state it reaches satisfies the
//! goal, else `−h(s, G) − λ·|π|`, with `h` a fixed weighted mix of h_FF, LM-cut and the
//! remaining plan cost (Appendix A.4), each in the task's action-cost units.
//!
//! **Default weights: h_FF 1, LM-cut 1, remaining plan cost 1**, the paper's three components
//! (it gives no weights). The third is a lazy GBFS with h_FF and preferred operators, 200
//! expansions, h_FF when it finds nothing. It sees past the delete relaxation's bump on
//! ALFWorld's clean/heat/cool tasks whose object already lies on the target: taking the object
//! raises h_FF and LM-cut (it must come back), which then prefer wandering. It costs about
//! 4.4 ms per state on ALFWorld against 0.18 ms for h_FF, cheap beside a model call (~35 ms
//! with SmolLM2). Measured with SmolLM2 in both phases on the seven ALFWorld-50 games whose
//! 60 s search found no plan at 5bb0492 (1240289, `--subset` of those seven, two lanes):
//! with 1,1,0 `Tomato-None-CounterTop-12` (cool a tomato lying on the counter) still found
//! none in 60 s (3,830 simulations); with 1,1,1 every game whose exploration left the steps
//! for a plan was solved, the slowest in 23 s. `--prior-mix 0.5` on top solved the same games
//! in fewer simulations (449 against 1,365 on that tomato); it changes the paper's prior, so
//! it stays an option. History: with the uniform prior, before the relaxation counted negative
//! preconditions, 1,1,0.5 solved 0 of EAI 27_2, 417_2 and 487_1 in 30 s (1,1,0: 3/3); since,
//! 1,1,1 solves every task of ALFWorld valid_seen and EAI too, at 16,000 simulations/s on
//! ALFWorld against 21,700 for 1,1,0 (`--weights 1,1,0` is the faster choice there).
//!
//! When the bounded search finds no plan, the component falls back to h_FF, which can rank a
//! state whose search gave up above one whose plan it found: on ALFWorld
//! `ButterKnife-None-DiningTable-16`, holding a paper towel roll at the table (6 steps from
//! the goal; the search gave up, h_FF 3) was valued above holding the butter knife (a plan of
//! 4), so SmolLM2's search never left the paper towel roll. h_FF ignored the empty hand that
//! picking up the knife needs; since the relaxation counts negative preconditions it does
//! not, and the task is solved in 37 s (alone, two threads; 45–47 s beside another job).

use heuristics::search::relevant_facts;
use heuristics::{HFF, LmCut, RemainingPlanCost, WeightedMix};
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
    /// `R_G`, the value of a prefix that reaches the goal (1 by default: the paper asks only
    /// `R_G > 0` and gives no value).
    pub goal_reward: f64,
    /// `λ`, the penalty per action of the prefix (0.1 by default: the paper asks only `λ > 0`
    /// and gives no value; 0 is allowed, as an ablation without the penalty).
    pub length_penalty: f64,
}

impl Default for ValueConfig {
    fn default() -> Self {
        ValueConfig { ff: 1.0, lmcut: 1.0, remaining: 1.0, remaining_expansions: 200, goal_reward: 1.0, length_penalty: 0.1 }
    }
}

/// Evaluates states with the mix ([`WeightedMix`] of [`HFF`], [`LmCut`] and
/// [`RemainingPlanCost`]), remembering each state's `h`: MCTS reaches the same state along
/// many token paths, and a revisit costs a hash lookup.
///
/// States are remembered projected onto the facts relevant to the goal
/// ([`relevant_facts`], as A*'s state registry stores them): a fact outside that set is read
/// neither by the goal nor by any action that can change a relevant fact, so two states that
/// differ only there have the same `h` and the same plans. ALFWorld's `look`, `inventory` and
/// `examine` only set `checked`, which nothing reads: projected, they lead back to the state
/// they start from ([`Evaluator::project`], which the search's transposition table uses too).
pub struct Evaluator<'m> {
    model: &'m TransitionModel,
    config: ValueConfig,
    mix: WeightedMix<'m>,
    relevant: Vec<u64>,
    cache: FxHashMap<State, Option<f64>>,
    evaluations: u64,
    lookups: u64,
}

impl std::fmt::Debug for Evaluator<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Evaluator").field("config", &self.config).field("cached", &self.cache.len()).finish_non_exhaustive()
    }
}

impl<'m> Evaluator<'m> {
    /// An evaluator with an empty cache; a heuristic whose weight is not above 0 is left out of
    /// the mix.
    pub fn new(model: &'m TransitionModel, config: ValueConfig) -> Evaluator<'m> {
        let mut mix = WeightedMix::new();
        if config.ff > 0.0 {
            mix = mix.with(config.ff, HFF::new(model));
        }
        if config.lmcut > 0.0 {
            mix = mix.with(config.lmcut, LmCut::new(model));
        }
        if config.remaining > 0.0 {
            mix = mix.with(config.remaining, RemainingPlanCost::new(model, config.remaining_expansions));
        }
        let relevant = relevant_facts(model.task());
        Evaluator { model, config, mix, relevant, cache: FxHashMap::default(), evaluations: 0, lookups: 0 }
    }

    /// `state` with every fact outside the goal's relevant facts cleared (type docs).
    pub fn project(&self, state: &State) -> State {
        let mut projected = state.clone();
        projected.retain(&self.relevant);
        projected
    }

    /// The weights and constants it was made with.
    pub fn config(&self) -> &ValueConfig {
        &self.config
    }

    /// The transition model whose states it evaluates.
    pub fn model(&self) -> &'m TransitionModel {
        self.model
    }

    /// `h(s, G)`: 0 at the goal, `None` for a dead end.
    pub fn heuristic(&mut self, state: &State) -> Option<f64> {
        self.lookups += 1;
        if self.model.is_goal(state) {
            return Some(0.0);
        }
        let key = self.project(state);
        if let Some(&h) = self.cache.get(&key) {
            return h;
        }
        self.evaluations += 1;
        let h = self.mix.evaluate(state);
        self.cache.insert(key, h);
        h
    }

    /// Eq. 10 for a prefix of `length` actions reaching `state`; `None` for a dead end.
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
}
