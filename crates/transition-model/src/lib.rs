//! The transition model of a grounded task: states, applicable actions, successors, plan
//! validation, and action spelling.
//!
//! A [`State`] is a bitset over the task's fluent facts. The [`SuccessorGenerator`] (Fast
//! Downward's decision tree over preconditions) finds the applicable actions without
//! scanning every action. [`TransitionModel::apply`] fires conditional effects evaluated
//! in the state before the action, deletes before adds. [`TransitionModel::validate`] and
//! [`TransitionModel::validate_text`] report the first failing step with each unmet
//! precondition, or the unmet goal. [`Spelling`] turns actions into text and back in three
//! surface languages: PDDL, ALFWorld's TextWorld commands, VirtualHome's class-level verbs.
//!
//! ```
//! let domain = pddl_syntax::parse_domain("(define (domain d) (:predicates (at ?x) (road ?x ?y))
//!     (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x)))))").unwrap();
//! let problem = pddl_syntax::parse_problem("(define (problem p) (:domain d) (:objects a b c)
//!     (:init (at a) (road a b) (road b c)) (:goal (at c)))").unwrap();
//! let model = transition_model::TransitionModel::new(grounding::ground(&domain, &problem).unwrap());
//! let spelling = transition_model::Spelling::pddl(model.task());
//! let plan = model.validate_text(&spelling, &["(go a b)", "(go b c)"]).unwrap();
//! assert_eq!(plan.cost, 2);
//! let error = model.validate_text(&spelling, &["(go b c)"]).unwrap_err();
//! assert_eq!(error.describe(model.task()), "invalid: step 1: `(go b c)` is not applicable: unmet (at b)");
//! ```

mod names;
mod spelling;
mod state;
mod successor;
mod validate;

pub use names::UnknownName;
pub use spelling::{ObjectNames, Spelling, SpellingError, SurfaceLanguage, alfworld, natural_order, normalize, virtualhome};
pub use state::State;
pub use successor::SuccessorGenerator;
pub use validate::{PlanError, Unmet, ValidPlan, plan_cost, unmet};

/// The grounded task and its ids, which this crate's signatures use: a user of the model needs
/// no direct dependency on `grounding` to name them.
pub use grounding::{ActionId, FactId, Task};

/// A task with its successor generator.
#[derive(Debug, Clone)]
pub struct TransitionModel {
    task: Task,
    successors: SuccessorGenerator,
}

impl TransitionModel {
    /// The model of a grounded task (`grounding::ground`): builds its successor generator.
    pub fn new(task: Task) -> TransitionModel {
        let successors = SuccessorGenerator::new(&task);
        TransitionModel { task, successors }
    }

    /// The grounded task: its facts, actions, goal and names.
    pub fn task(&self) -> &Task {
        &self.task
    }

    /// The task's initial state.
    pub fn initial_state(&self) -> State {
        State::from_facts(self.task.facts.len(), self.task.init.iter().copied())
    }

    /// The actions applicable in `state`, into `out` (cleared first).
    pub fn applicable(&self, state: &State, out: &mut Vec<ActionId>) {
        self.successors.applicable(&self.task, state, out);
    }

    /// Whether `action`'s precondition (positive and negative facts and clauses) holds in `state`;
    /// checks the one action directly, without the successor generator.
    pub fn is_applicable(&self, state: &State, action: ActionId) -> bool {
        self.task.action(action).pre.holds(|f| state.contains(f))
    }

    /// The successor of `state` under `action` (which must be applicable; not checked).
    pub fn apply(&self, state: &State, action: ActionId) -> State {
        let mut next = state.clone();
        self.apply_into(state, action, &mut next);
        next
    }

    /// Writes the successor of `state` under `action` into `next`, which must start as a
    /// copy of `state`. Conditions of conditional effects are read from `state`.
    pub fn apply_into(&self, state: &State, action: ActionId, next: &mut State) {
        let action = self.task.action(action);
        for &fact in &action.del {
            next.remove(fact);
        }
        let fired = |e: &&grounding::ConditionalEffect| e.condition.holds(|f| state.contains(f));
        for effect in action.conditional.iter().filter(fired) {
            for &fact in &effect.del {
                next.remove(fact);
            }
        }
        for &fact in &action.add {
            next.insert(fact);
        }
        for effect in action.conditional.iter().filter(fired) {
            for &fact in &effect.add {
                next.insert(fact);
            }
        }
    }

    /// Whether the task's goal holds in `state` (a state of this model).
    pub fn is_goal(&self, state: &State) -> bool {
        self.task.goal.holds(|f| state.contains(f))
    }

    /// The decision tree [`Self::applicable`] walks, built once in [`Self::new`].
    pub fn successor_generator(&self) -> &SuccessorGenerator {
        &self.successors
    }

    /// The states of a seeded random walk of at most `steps` actions from the initial state
    /// (it stops early in a state without applicable actions), the initial state first.
    /// Deterministic for a seed; for benchmarks and tests that need realistic states.
    pub fn random_walk(&self, seed: u64, steps: usize) -> Vec<State> {
        let mut state = self.initial_state();
        let mut states = vec![state.clone()];
        let mut applicable = Vec::new();
        // xorshift64: a fixed, dependency-free sequence.
        let mut random = seed | 1;
        for _ in 0..steps {
            self.applicable(&state, &mut applicable);
            if applicable.is_empty() {
                break;
            }
            random ^= random << 13;
            random ^= random >> 7;
            random ^= random << 17;
            state = self.apply(&state, applicable[(random % applicable.len() as u64) as usize]);
            states.push(state.clone());
        }
        states
    }
}
