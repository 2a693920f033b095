//! Memoisation of a heuristic by state. Callers that evaluate the same states again and
//! again — the remaining-plan-cost searches, whose bounded GBFS runs from neighbouring
//! states cover mostly the same states, and MCTS, which reaches a state along many token
//! paths — pay a hash lookup instead of an evaluation.

use grounding::ActionId;
use rustc_hash::FxHashMap;
use transition_model::State;

use crate::Heuristic;

/// A heuristic with a cache of its values and preferred operators by state. The cache holds
/// at most `capacity` states; when full it is emptied and refilled (the states a search
/// needs next are those it reached last, not the oldest), so memory stays bounded.
pub struct Memo<H> {
    inner: H,
    cache: FxHashMap<State, (Option<u32>, Box<[ActionId]>)>,
    capacity: usize,
    preferred: Vec<ActionId>,
    hits: u64,
    misses: u64,
}

impl<H: Heuristic> std::fmt::Debug for Memo<H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Memo")
            .field("inner", &self.inner.name())
            .field("cached", &self.cache.len())
            .field("capacity", &self.capacity)
            .field("hits", &self.hits)
            .field("misses", &self.misses)
            .finish()
    }
}

impl<H: Heuristic> Memo<H> {
    /// Default capacity: about 100 MB of states on the benchmarks' tasks.
    pub const DEFAULT_CAPACITY: usize = 1 << 19;

    /// Wraps `inner` with a cache of [`Self::DEFAULT_CAPACITY`] states.
    pub fn new(inner: H) -> Memo<H> {
        Memo::with_capacity(inner, Self::DEFAULT_CAPACITY)
    }

    /// Wraps `inner` with a cache of at most `capacity` states (0 is taken as 1).
    pub fn with_capacity(inner: H, capacity: usize) -> Memo<H> {
        Memo { inner, cache: FxHashMap::default(), capacity: capacity.max(1), preferred: Vec::new(), hits: 0, misses: 0 }
    }

    /// Evaluations answered from the cache, and evaluations run.
    pub fn counts(&self) -> (u64, u64) {
        (self.hits, self.misses)
    }

    /// The wrapped heuristic. Its own state (such as its preferred operators) is that of its
    /// last real evaluation, not of a later cache hit.
    pub fn inner(&self) -> &H {
        &self.inner
    }
}

impl<H: Heuristic> Heuristic for Memo<H> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        if let Some((h, preferred)) = self.cache.get(state) {
            self.hits += 1;
            self.preferred.clear();
            self.preferred.extend_from_slice(preferred);
            return *h;
        }
        self.misses += 1;
        let h = self.inner.evaluate(state);
        self.preferred.clear();
        self.preferred.extend_from_slice(self.inner.preferred_operators());
        if self.cache.len() >= self.capacity {
            self.cache.clear();
        }
        self.cache.insert(state.clone(), (h, self.preferred.as_slice().into()));
        h
    }

    fn preferred_operators(&self) -> &[ActionId] {
        &self.preferred
    }
}
