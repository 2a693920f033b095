//! How an episode ended and how the agent met failure (the paper's Tables 11 and 12),
//! computed from the requests it sent and whether the environment executed each.
//!
//! - **Terminal mechanism** ([`Terminal`]): success; the grounding layer refused a request
//!   (the step could not be executed, and the episode ended there, or the agent's open-loop plan
//!   ran to its end short of the goal); the
//!   interaction limit (the step budget); the model's own `DONE`; for the agent, also Phase II's
//!   search budget (no plan) ([`agent_terminal`]).
//! - **Failure response** ([`FailureResponse`]), over the sequence of requests:
//!   *encounters failure* — some request was not executed; *recovers* — after the first
//!   failure, the episode still succeeded; *repeats the failed request* — some failed request
//!   is sent again immediately after; *persistent loop* — at least five identical consecutive
//!   requests, or a six-step two-action oscillation (`a b a b a b` with `a ≠ b`).

use serde::Serialize;

/// Why an episode ended (Table 11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Terminal {
    /// The episode reached its goal.
    Success,
    /// A request the environment refused ended the episode (or, for the agent, the open-loop
    /// plan with a refused step ran to its end short of the goal).
    Grounding,
    /// The step budget ran out (for the agent, only where it cut the episode short:
    /// `exploration_harness::Episode::budget_spent`).
    InteractionLimit,
    /// The model said it was done short of the goal (for the agent: Phase I's `done` with
    /// nothing planned, or a plan that ran to its end, every step executed, without the goal).
    ModelDone,
    /// The agent's Phase II search returned no plan within its budget (no request was refused).
    SearchBudget,
}

/// The failure response of one episode (Table 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct FailureResponse {
    /// Some request was not executed.
    pub encounters_failure: bool,
    /// Some request failed and the episode still succeeded.
    pub recovers: bool,
    /// A failed request was sent again as the very next request.
    pub repeats_failed_request: bool,
    /// The requests hold a loop ([`persistent_loop`]): five identical in a row, or a six-step
    /// two-action oscillation.
    pub persistent_loop: bool,
}

/// The failure response of `requests` (each: the command, whether it was executed) in an
/// episode that ended in `success`.
pub fn failure_response(requests: &[(&str, bool)], success: bool) -> FailureResponse {
    let first_failure = requests.iter().position(|(_, ok)| !ok);
    FailureResponse {
        encounters_failure: first_failure.is_some(),
        recovers: first_failure.is_some() && success,
        repeats_failed_request: failed_transitions(requests).1 > 0,
        persistent_loop: persistent_loop(requests.iter().map(|(c, _)| *c).collect::<Vec<_>>().as_slice()),
    }
}

/// Failed requests followed by another request, and how many of those the same request
/// followed (Table 12's "repeats request" is the second over the first). An empty command (a
/// reply that named no action, recorded as a failed turn) is no request: it neither counts as
/// a failed request nor as the request that follows one.
pub fn failed_transitions(requests: &[(&str, bool)]) -> (usize, usize) {
    let failed: Vec<&[(&str, bool)]> = requests.windows(2).filter(|w| !w[0].1 && !w[0].0.is_empty() && !w[1].0.is_empty()).collect();
    (failed.len(), failed.iter().filter(|w| w[0].0 == w[1].0).count())
}

/// At least five identical consecutive requests, or six consecutive requests alternating
/// between two different actions. An empty command (a reply that named no action, recorded as
/// a failed turn) is no request: it takes part in neither.
pub fn persistent_loop(commands: &[&str]) -> bool {
    let same_five = commands.windows(5).any(|w| !w[0].is_empty() && w.iter().all(|c| *c == w[0]));
    let oscillation = commands
        .windows(6)
        .any(|w| !w[0].is_empty() && !w[1].is_empty() && w[0] != w[1] && w.iter().enumerate().all(|(i, c)| *c == w[i % 2]));
    same_five || oscillation
}

/// The agent's terminal mechanism (Phase I, then an open-loop plan): success; the search
/// budget when Phase II returned no plan; grounding when the environment refused a plan step
/// (the earlier cause where the steps also ran out after it); the interaction limit when the
/// step budget ended the episode (`budget_spent`: Phase I spent it, or the plan still had steps
/// to send); else the model's own end (Phase I's `done` with no plan, or a plan that ran to its
/// end short of the goal, on the budget's last step too: the plan's end is the model's `DONE`).
pub fn agent_terminal(success: bool, no_plan: bool, any_refused: bool, budget_spent: bool) -> Terminal {
    if success {
        Terminal::Success
    } else if no_plan {
        Terminal::SearchBudget
    } else if any_refused {
        Terminal::Grounding
    } else if budget_spent {
        Terminal::InteractionLimit
    } else {
        Terminal::ModelDone
    }
}

/// The terminal mechanism: `success`, else `model_done` when the model ended the episode,
/// else the interaction limit when `steps_used` reached `budget`, else grounding.
pub fn terminal(success: bool, model_done: bool, steps_used: usize, budget: usize) -> Terminal {
    if success {
        Terminal::Success
    } else if model_done {
        Terminal::ModelDone
    } else if steps_used >= budget {
        Terminal::InteractionLimit
    } else {
        Terminal::Grounding
    }
}
