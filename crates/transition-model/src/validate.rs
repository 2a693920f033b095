//! Plan validation: replays a plan and reports the first step that fails, with each unmet
//! precondition, or the unmet part of the goal.

use std::fmt;

use grounding::{ActionId, Literal, Task};

use crate::TransitionModel;
use crate::spelling::Spelling;
use crate::state::State;

/// A precondition or goal part that does not hold.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Unmet {
    /// This fact, or for a negated literal its absence, does not hold.
    Literal(Literal),
    /// None of these holds.
    Clause(Vec<Literal>),
}

impl Unmet {
    /// In PDDL with `task`'s names: `(at b)`, `(not (at b))`, or `(or ...)` for a clause.
    pub fn describe(&self, task: &Task) -> String {
        match self {
            Unmet::Literal(literal) => task.literal_name(*literal),
            Unmet::Clause(literals) => {
                let names: Vec<String> = literals.iter().map(|l| task.literal_name(*l)).collect();
                format!("(or {})", names.join(" "))
            }
        }
    }
}

/// The unmet parts of a condition in a state.
pub fn unmet(condition: &grounding::Condition, state: &State) -> Vec<Unmet> {
    let mut out: Vec<Unmet> = condition.literals().filter(|l| state.contains(l.fact()) == l.is_negated()).map(Unmet::Literal).collect();
    for clause in &condition.clauses {
        if !clause.iter().any(|l| state.contains(l.fact()) != l.is_negated()) {
            out.push(Unmet::Clause(clause.clone()));
        }
    }
    out
}

/// A plan that reaches the goal.
#[derive(Debug, Clone)]
pub struct ValidPlan {
    /// The plan's actions, one a step (for a text plan, the action each step applied).
    pub actions: Vec<ActionId>,
    /// The sum of the actions' costs (their number where the task has no costs).
    pub cost: u64,
    /// The state the plan ends in, where the goal holds.
    pub final_state: State,
}

/// Why a plan is not valid. Steps are 1-based.
#[derive(Debug, Clone)]
pub enum PlanError {
    /// The text of step `step` names no action of the task.
    UnknownAction {
        /// The step, 1-based.
        step: usize,
        /// The step as written.
        text: String,
    },
    /// Step `step` names actions, none of them applicable; `action` and `unmet` are the one
    /// closest to applicable and its preconditions that do not hold.
    Inapplicable {
        /// The step, 1-based.
        step: usize,
        /// The step as written.
        text: String,
        /// The grounded action the step names (the closest to applicable, where it names several).
        action: ActionId,
        /// Its preconditions that do not hold in the state before the step.
        unmet: Vec<Unmet>,
    },
    /// Every step applied, but the goal does not hold; `unmet` is for the goal disjunct
    /// closest to holding (empty when the goal can never hold).
    GoalNotReached {
        /// The plan's length.
        steps: usize,
        /// The goal's parts that do not hold at the end.
        unmet: Vec<Unmet>,
    },
}

impl PlanError {
    /// One line, starting `invalid: step K` (or `invalid: goal`), naming what failed.
    pub fn describe(&self, task: &Task) -> String {
        self.describe_located(task, |_| None)
    }

    /// [`PlanError::describe`], with where step K is written after its number where `located`
    /// says (`invalid: step 2 (plan.txt:4): ...`).
    pub fn describe_located(&self, task: &Task, located: impl Fn(usize) -> Option<String>) -> String {
        let at = |step: usize| located(step).map_or_else(String::new, |place| format!(" ({place})"));
        match self {
            PlanError::UnknownAction { step, text } => format!("invalid: step {step}{}: `{text}` is not an action of this task", at(*step)),
            PlanError::Inapplicable { step, text, action, unmet: parts } => {
                let parts: Vec<String> = parts.iter().map(|u| u.describe(task)).collect();
                // The grounded action in parentheses where the plan spelled it otherwise.
                let name = task.action_name(*action);
                let grounded = if name == *text { String::new() } else { format!(" ({name})") };
                format!("invalid: step {step}{}: `{text}`{grounded} is not applicable: unmet {}", at(*step), parts.join(", "))
            }
            PlanError::GoalNotReached { steps, unmet: parts } if parts.is_empty() => {
                format!("invalid: goal: after {steps} step{} the goal does not hold, and no reachable state satisfies it", plural(*steps))
            }
            PlanError::GoalNotReached { steps, unmet: parts } => {
                let parts: Vec<String> = parts.iter().map(|u| u.describe(task)).collect();
                format!("invalid: goal: after {steps} step{} the goal does not hold: unmet {}", plural(*steps), parts.join(", "))
            }
        }
    }
}

/// `s` unless there is one.
fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanError::UnknownAction { step, text } => write!(f, "step {step}: unknown action `{text}`"),
            PlanError::Inapplicable { step, text, .. } => write!(f, "step {step}: `{text}` is not applicable"),
            PlanError::GoalNotReached { steps, .. } => write!(f, "the goal does not hold after {steps} step{}", plural(*steps)),
        }
    }
}

impl std::error::Error for PlanError {}

impl TransitionModel {
    /// Replays `plan` from the initial state.
    pub fn validate(&self, plan: &[ActionId]) -> Result<ValidPlan, PlanError> {
        // An id past the task's actions (another task's plan) is an unknown action, not a panic.
        let actions = self.task().actions.len();
        let steps = plan.iter().map(|&a| {
            if a.index() < actions {
                (self.task().action_name(a), vec![a])
            } else {
                (format!("action #{} of {actions}", a.index()), Vec::new())
            }
        });
        self.replay(steps)
    }

    /// Replays a plan written in a surface language, one action per entry. A text that
    /// names several actions applies the first of them (in id order) that is applicable.
    pub fn validate_text<S: AsRef<str>>(&self, spelling: &Spelling, plan: &[S]) -> Result<ValidPlan, PlanError> {
        let steps = plan.iter().map(|text| (text.as_ref().trim().to_string(), spelling.parse(text.as_ref()).to_vec()));
        self.replay(steps)
    }

    /// The states a text plan visits, from the initial state to the last (the plan need not
    /// reach the goal; it must apply).
    pub fn states_along<S: AsRef<str>>(&self, spelling: &Spelling, plan: &[S]) -> Result<Vec<State>, PlanError> {
        let mut states = vec![self.initial_state()];
        let steps = plan.iter().map(|text| (text.as_ref().trim().to_string(), spelling.parse(text.as_ref()).to_vec()));
        match self.replay_into(steps, Some(&mut states)) {
            Ok(_) | Err(PlanError::GoalNotReached { .. }) => Ok(states),
            Err(error) => Err(error),
        }
    }

    fn replay(&self, steps: impl Iterator<Item = (String, Vec<ActionId>)>) -> Result<ValidPlan, PlanError> {
        self.replay_into(steps, None)
    }

    fn replay_into(
        &self,
        steps: impl Iterator<Item = (String, Vec<ActionId>)>,
        mut visited: Option<&mut Vec<State>>,
    ) -> Result<ValidPlan, PlanError> {
        let task = self.task();
        let mut state = self.initial_state();
        let mut actions = Vec::new();
        let mut cost: u64 = 0;
        let mut count = 0;
        for (index, (text, candidates)) in steps.enumerate() {
            let step = index + 1;
            count = step;
            if candidates.is_empty() {
                return Err(PlanError::UnknownAction { step, text });
            }
            let Some(&action) = candidates.iter().find(|&&a| self.is_applicable(&state, a)) else {
                let (action, parts) = candidates
                    .iter()
                    .map(|&a| (a, unmet(&task.action(a).pre, &state)))
                    .min_by_key(|(_, parts)| parts.len())
                    .unwrap_or_else(|| (candidates[0], Vec::new()));
                return Err(PlanError::Inapplicable { step, text, action, unmet: parts });
            };
            state = self.apply(&state, action);
            if let Some(visited) = visited.as_deref_mut() {
                visited.push(state.clone());
            }
            cost += u64::from(task.action(action).cost);
            actions.push(action);
        }
        if !self.is_goal(&state) {
            let closest = task.goal.disjuncts.iter().map(|d| unmet(d, &state)).min_by_key(Vec::len).unwrap_or_default();
            return Err(PlanError::GoalNotReached { steps: count, unmet: closest });
        }
        Ok(ValidPlan { actions, cost, final_state: state })
    }
}

/// Cost of a plan (sum of action costs).
pub fn plan_cost(task: &Task, plan: &[ActionId]) -> u64 {
    plan.iter().map(|&a| u64::from(task.action(a).cost)).sum()
}
