//! The terminal mechanism and failure response (Tables 11-12) on hand-made request lists.

use eval_harness::behaviour::{FailureResponse, Terminal, agent_terminal, failed_transitions, failure_response, persistent_loop, terminal};

#[test]
fn failure_responses() {
    let clean = [("go to desk 1", true), ("take pen 1 from desk 1", true)];
    assert_eq!(failure_response(&clean, true), FailureResponse::default());
    let recovered = [("open drawer 1", false), ("go to drawer 1", true), ("open drawer 1", true)];
    let r = failure_response(&recovered, true);
    assert!(r.encounters_failure && r.recovers && !r.repeats_failed_request && !r.persistent_loop);
    let repeated = [("open drawer 1", false), ("open drawer 1", false)];
    let r = failure_response(&repeated, false);
    assert!(r.encounters_failure && !r.recovers && r.repeats_failed_request);
    // A success that never failed is no recovery.
    assert!(!failure_response(&clean, true).recovers);
    // Replies that named no action (recorded as failed turns with no command) are no
    // requests: five of them repeat nothing and make no loop.
    let unreadable = [("", false); 5];
    let r = failure_response(&unreadable, false);
    assert!(r.encounters_failure && !r.repeats_failed_request && !r.persistent_loop, "{r:?}");
    assert!(!persistent_loop(&["", "look", "", "look", "", "look"]));
}

#[test]
fn loops_are_five_identical_requests_or_a_six_step_oscillation() {
    assert!(persistent_loop(&["look"; 5]));
    assert!(!persistent_loop(&["look"; 4]));
    assert!(persistent_loop(&["a", "b", "a", "b", "a", "b"]));
    assert!(!persistent_loop(&["a", "b", "a", "b", "a"]));
    assert!(!persistent_loop(&["a", "b", "a", "b", "a", "c"]));
    assert!(persistent_loop(&["x", "y", "a", "a", "a", "a", "a", "z"]));
}

#[test]
fn terminal_mechanisms() {
    assert_eq!(terminal(true, false, 20, 20), Terminal::Success);
    assert_eq!(terminal(false, true, 3, 20), Terminal::ModelDone);
    assert_eq!(terminal(false, false, 20, 20), Terminal::InteractionLimit);
    assert_eq!(terminal(false, false, 7, 20), Terminal::Grounding);
    // The agent: no plan is the search budget, whatever the steps; a refused plan step is
    // grounding, also when the steps ran out after it; the budget cutting Phase I or the plan
    // short is the interaction limit; a plan that ran to its end short of the goal is the
    // model's end, also when its last step was the budget's last.
    assert_eq!(agent_terminal(true, false, false, true), Terminal::Success);
    assert_eq!(agent_terminal(false, true, false, false), Terminal::SearchBudget);
    assert_eq!(agent_terminal(false, false, true, false), Terminal::Grounding);
    assert_eq!(agent_terminal(false, false, true, true), Terminal::Grounding);
    assert_eq!(agent_terminal(false, false, false, true), Terminal::InteractionLimit);
    assert_eq!(agent_terminal(false, false, false, false), Terminal::ModelDone);
}

/// Table 12's "repeats request" counts over failed requests followed by a request: a turn that
/// named no action (an empty command) is no request, neither the failed one nor the next.
#[test]
fn turns_that_name_no_action_are_no_requests() {
    assert_eq!(failed_transitions(&[("", false), ("", false), ("open fridge", false), ("open fridge", true)]), (1, 1));
    assert_eq!(failed_transitions(&[("open fridge", false), ("", false), ("open fridge", true)]), (0, 0));
    assert_eq!(failed_transitions(&[("open fridge", false), ("go to fridge 1", true), ("open fridge 1", false)]), (1, 0));
    // The episode's flag is the count's.
    assert!(failure_response(&[("", false), ("open fridge", false), ("open fridge", true)], true).repeats_failed_request);
    assert!(!failure_response(&[("open fridge", false), ("", false), ("open fridge", true)], true).repeats_failed_request);
}
