//! A fixed weighted combination of heuristics, as the paper's MCTS value uses
//! (Appendix A.4: Fast Forward, LM-cut and remaining plan cost).

use transition_model::State;

use crate::Heuristic;

/// `Σ wᵢ·hᵢ(s) / Σ wᵢ`; a dead end for any component is a dead end for the mix.
pub struct WeightedMix<'m> {
    parts: Vec<(f64, Box<dyn Heuristic + 'm>)>,
}

impl std::fmt::Debug for WeightedMix<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts: Vec<(f64, &str)> = self.parts.iter().map(|(w, h)| (*w, h.name())).collect();
        f.debug_struct("WeightedMix").field("parts", &parts).finish()
    }
}

impl<'m> WeightedMix<'m> {
    /// A mix without components: [`Self::evaluate`] gives `Some(0.0)` until [`Self::with`]
    /// adds one.
    pub fn new() -> WeightedMix<'m> {
        WeightedMix { parts: Vec::new() }
    }

    /// Adds `heuristic` with `weight`. Weights are relative: the value is divided by their sum,
    /// and is 0 where that sum is not positive.
    pub fn with(mut self, weight: f64, heuristic: impl Heuristic + 'm) -> WeightedMix<'m> {
        self.parts.push((weight, Box::new(heuristic)));
        self
    }

    /// The weighted average, or `None` for a dead end.
    pub fn evaluate(&mut self, state: &State) -> Option<f64> {
        let mut total = 0.0;
        let mut weights = 0.0;
        for (weight, heuristic) in &mut self.parts {
            total += *weight * f64::from(heuristic.evaluate(state)?);
            weights += *weight;
        }
        Some(if weights > 0.0 { total / weights } else { 0.0 })
    }

    /// Each component's value from one evaluation, by name.
    pub fn components(&mut self, state: &State) -> Vec<(&'static str, Option<u32>)> {
        self.parts.iter_mut().map(|(_, h)| (h.name(), h.evaluate(state))).collect()
    }
}

impl Default for WeightedMix<'_> {
    fn default() -> Self {
        WeightedMix::new()
    }
}
