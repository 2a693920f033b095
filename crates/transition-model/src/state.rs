//! A state: the set of fluent facts that hold, as a bitset.

use grounding::FactId;

/// The facts that hold, one bit per [`FactId`].
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct State {
    words: Box<[u64]>,
}

impl State {
    /// The empty state over `facts` facts.
    pub fn empty(facts: usize) -> State {
        State { words: vec![0; facts.div_ceil(64)].into_boxed_slice() }
    }

    /// The state over `facts` facts in which exactly `true_facts` hold. Panics if a fact id is
    /// not below `facts` rounded up to a multiple of 64.
    pub fn from_facts(facts: usize, true_facts: impl IntoIterator<Item = FactId>) -> State {
        let mut state = State::empty(facts);
        for fact in true_facts {
            state.insert(fact);
        }
        state
    }

    /// Whether `fact` holds. Panics if its id is past the state's words.
    #[inline]
    pub fn contains(&self, fact: FactId) -> bool {
        let i = fact.index();
        self.words[i >> 6] >> (i & 63) & 1 == 1
    }

    /// Makes `fact` hold (no-op if it does). Panics if its id is past the state's words.
    #[inline]
    pub fn insert(&mut self, fact: FactId) {
        let i = fact.index();
        self.words[i >> 6] |= 1 << (i & 63);
    }

    /// Makes `fact` not hold (no-op if it does not). Panics if its id is past the state's words.
    #[inline]
    pub fn remove(&mut self, fact: FactId) {
        let i = fact.index();
        self.words[i >> 6] &= !(1 << (i & 63));
    }

    /// The facts that hold, in id order.
    pub fn facts(&self) -> impl Iterator<Item = FactId> + '_ {
        self.words.iter().enumerate().flat_map(|(w, &word)| {
            let mut bits = word;
            std::iter::from_fn(move || {
                if bits == 0 {
                    return None;
                }
                let bit = bits.trailing_zeros();
                bits &= bits - 1;
                Some(FactId((w as u32) << 6 | bit))
            })
        })
    }

    /// The number of facts true in the state (not the number it ranges over, which
    /// [`State::empty`] takes).
    pub fn len(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Whether no fact is true.
    pub fn is_empty(&self) -> bool {
        self.words.iter().all(|&w| w == 0)
    }

    /// Keeps only the facts set in `mask` (a bit mask over fact ids, as [`State::words`]).
    pub fn retain(&mut self, mask: &[u64]) {
        for (w, m) in self.words.iter_mut().zip(mask) {
            *w &= m;
        }
    }

    /// The raw words, for compact storage (state registries).
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    /// The state whose raw words are `words`, as [`State::words`] returned them: bit `i % 64`
    /// of word `i / 64` is fact `i`.
    pub fn from_words(words: &[u64]) -> State {
        State { words: words.into() }
    }
}
