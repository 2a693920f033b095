//! The state registry: every state a search meets, stored once, packed into one flat
//! vector of words, with a hash table from contents to a dense `StateId`.

use hashbrown::HashTable;
use rustc_hash::FxHasher;
use std::hash::Hasher;

use transition_model::State;

pub type StateId = u32;

#[derive(Debug, Clone)]
pub struct StateRegistry {
    width: usize,
    words: Vec<u64>,
    table: HashTable<StateId>,
}

fn hash(words: &[u64]) -> u64 {
    let mut hasher = FxHasher::default();
    for &w in words {
        hasher.write_u64(w);
    }
    hasher.finish()
}

impl StateRegistry {
    pub fn new(facts: usize) -> StateRegistry {
        StateRegistry { width: facts.div_ceil(64), words: Vec::new(), table: HashTable::new() }
    }

    pub fn len(&self) -> usize {
        self.words.len().checked_div(self.width).unwrap_or(self.table.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn slice(&self, id: StateId) -> &[u64] {
        &self.words[id as usize * self.width..(id as usize + 1) * self.width]
    }

    /// The id of `state`, registering it if new; `true` when it was new.
    pub fn insert(&mut self, state: &State) -> (StateId, bool) {
        let words = state.words();
        let h = hash(words);
        let width = self.width;
        let stored = &self.words;
        if let Some(&id) = self.table.find(h, |&id| &stored[id as usize * width..(id as usize + 1) * width] == words) {
            return (id, false);
        }
        let id = self.len() as StateId;
        self.words.extend_from_slice(words);
        let stored = &self.words;
        self.table.insert_unique(h, id, |&id| hash(&stored[id as usize * width..(id as usize + 1) * width]));
        (id, true)
    }

    pub fn get(&self, id: StateId) -> State {
        State::from_words(self.slice(id))
    }
}
