//! The simplest heuristics: blind and goal count.

use grounding::Task;
use transition_model::{State, TransitionModel};

use crate::Heuristic;

/// 0 in goal states, else the cheapest action cost (Fast Downward's `blind()`).
#[derive(Debug)]
pub struct Blind<'m> {
    model: &'m TransitionModel,
    min_cost: u32,
}

impl<'m> Blind<'m> {
    /// Blind on `model`; the cheapest action cost is read once here (0 for a task without
    /// actions). A task whose goal has no disjunct (it can never hold) is a dead end everywhere.
    pub fn new(model: &'m TransitionModel) -> Blind<'m> {
        let min_cost = model.task().actions.iter().map(|a| a.cost).min().unwrap_or(0);
        Blind { model, min_cost }
    }
}

impl Heuristic for Blind<'_> {
    fn name(&self) -> &'static str {
        "blind"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        if self.model.task().goal.disjuncts.is_empty() {
            return None;
        }
        Some(if self.model.is_goal(state) { 0 } else { self.min_cost })
    }
}

/// The number of goal literals (and clauses) that do not hold, for the goal disjunct with
/// the fewest.
#[derive(Debug)]
pub struct GoalCount<'m> {
    task: &'m Task,
}

impl<'m> GoalCount<'m> {
    /// Goal count on `model`'s goal. A goal without disjuncts makes every state a dead end.
    pub fn new(model: &'m TransitionModel) -> GoalCount<'m> {
        GoalCount { task: model.task() }
    }
}

impl Heuristic for GoalCount<'_> {
    fn name(&self) -> &'static str {
        "goalcount"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        self.task.goal.disjuncts.iter().map(|d| transition_model::unmet(d, state).len() as u32).min()
    }
}
