//! The state registry: every state a search meets, stored once, packed into one flat
//! vector of words, with a hash table from contents to a dense `StateId`.
//!
//! States are stored projected onto the facts relevant to the goal ([`relevant_facts`]), so
//! two states that differ only in facts no plan can depend on are one state, as they are
//! after Fast Downward's translator drops irrelevant variables. On visitall this is the
//! difference between one state per set of visited cells and one per set of visited *goal*
//! cells.

use hashbrown::HashTable;
use rustc_hash::FxHasher;
use std::hash::Hasher;

use grounding::Task;
use grounding::relevance::{self, Closure};
use transition_model::State;

/// The facts a plan can depend on, as a bit mask over fact ids: the fact closure of
/// [`grounding::relevance`] from the goal, to its fixpoint. A fact outside it is never read
/// by the goal nor by any action that can change a relevant fact, so dropping it from states
/// loses no plan and merges states that are the same for the goal (Fast Downward's
/// translator drops irrelevant variables the same way).
pub fn relevant_facts(task: &Task) -> Vec<u64> {
    relevance::relevant_facts(task, Closure::Facts, None).mask()
}

/// A registered state's index in its [`StateRegistry`]: dense, from 0, in order of registration.
pub type StateId = u32;

/// Every state a search registered, each stored once (projected when built by
/// [`StateRegistry::projected`]), with a [`StateId`] per state.
#[derive(Debug, Clone)]
pub struct StateRegistry {
    width: usize,
    words: Vec<u64>,
    table: HashTable<StateId>,
    /// Facts kept in stored states (all when `None`).
    mask: Option<Vec<u64>>,
    scratch: Vec<u64>,
}

fn hash(words: &[u64]) -> u64 {
    let mut hasher = FxHasher::default();
    for &w in words {
        hasher.write_u64(w);
    }
    hasher.finish()
}

impl StateRegistry {
    /// A registry that stores whole states.
    pub fn new(facts: usize) -> StateRegistry {
        StateRegistry { width: facts.div_ceil(64), words: Vec::new(), table: HashTable::new(), mask: None, scratch: Vec::new() }
    }

    /// A registry that stores states projected onto `mask` (from [`relevant_facts`]).
    pub fn projected(mask: Vec<u64>) -> StateRegistry {
        StateRegistry { width: mask.len(), words: Vec::new(), table: HashTable::new(), mask: Some(mask), scratch: Vec::new() }
    }

    /// The number of distinct (projected) states registered.
    pub fn len(&self) -> usize {
        self.words.len().checked_div(self.width).unwrap_or(self.table.len())
    }

    /// Whether no state is registered.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn slice(&self, id: StateId) -> &[u64] {
        &self.words[id as usize * self.width..(id as usize + 1) * self.width]
    }

    /// The id of `state` (projected), registering it if new; `true` when it was new.
    pub fn insert(&mut self, state: &State) -> (StateId, bool) {
        let words = match &self.mask {
            None => state.words(),
            Some(mask) => {
                self.scratch.clear();
                self.scratch.extend(state.words().iter().zip(mask).map(|(w, m)| w & m));
                &self.scratch
            }
        };
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

    /// The facts stored states keep (`None`: all).
    pub fn mask(&self) -> Option<&[u64]> {
        self.mask.as_deref()
    }

    /// The stored (projected) state.
    pub fn get(&self, id: StateId) -> State {
        State::from_words(self.slice(id))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn task(goal: &str) -> Task {
        let domain = pddl_syntax::parse_domain(
            "(define (domain d) (:predicates (at ?x) (road ?x ?y) (seen ?x) (lamp) (lit ?x))
             (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y))
                :effect (and (at ?y) (not (at ?x)) (seen ?y)))
             (:action light :parameters (?x) :precondition (and (lamp) (at ?x)) :effect (lit ?x)))",
        )
        .expect("domain");
        let problem = pddl_syntax::parse_problem(&format!(
            "(define (problem p) (:domain d) (:objects a b c) (:init (at a) (lamp) (road a b) (road b c) (road c a)) (:goal {goal}))"
        ))
        .expect("problem");
        grounding::ground(&domain, &problem).expect("grounds")
    }

    fn relevant(task: &Task) -> Vec<String> {
        let mask = relevant_facts(task);
        let mut names: Vec<String> = (0..task.facts.len())
            .filter(|&f| mask[f / 64] >> (f % 64) & 1 == 1)
            .map(|f| task.fact_name(grounding::FactId(f as u32)))
            .collect();
        names.sort();
        names
    }

    #[test]
    fn facts_no_plan_reads_are_irrelevant() {
        // `seen` and `lit` are never read: only the robot's position matters.
        assert_eq!(relevant(&task("(at c)")), ["(at a)", "(at b)", "(at c)"]);
        // A goal on `lit b` makes `at` relevant through `light` (and `lamp` is static).
        let lit = relevant(&task("(lit b)"));
        assert!(lit.contains(&"(lit b)".to_string()) && lit.contains(&"(at b)".to_string()), "{lit:?}");
        assert!(!lit.iter().any(|f| f.starts_with("(seen")), "{lit:?}");
    }

    #[test]
    fn projected_states_that_differ_only_in_irrelevant_facts_are_one() {
        let task = task("(at c)");
        let at = |name: &str| (0..task.facts.len() as u32).map(grounding::FactId).find(|&f| task.fact_name(f) == name).expect("fact");
        let mut registry = StateRegistry::projected(relevant_facts(&task));
        let plain = State::from_facts(task.facts.len(), [at("(at b)")]);
        let seen = State::from_facts(task.facts.len(), [at("(at b)"), at("(seen b)")]);
        assert_eq!(registry.insert(&plain), (0, true));
        assert_eq!(registry.insert(&seen), (0, false));
        assert_eq!(registry.get(0), plain);
        let mut whole = StateRegistry::new(task.facts.len());
        whole.insert(&plain);
        assert_eq!(whole.insert(&seen), (1, true));
    }
}
