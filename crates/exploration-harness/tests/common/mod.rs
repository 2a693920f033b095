//! Shared by the agent tests: a wandering policy and what no Phase I may do under it.

use exploration_harness::Episode;
use exploration_harness::phase1::{Policy, PolicyInput, PolicyReply, PolicyUsage, Skill};

/// A policy that never says done and takes skill `i·k mod n` of K_t (less `done`) at its i-th
/// choice: a fixed, model-free stand-in for a model that wanders. A fidgeting one takes
/// `open`, `close` or `look` first whenever one is offered.
pub struct Restless {
    turn: usize,
    stride: usize,
    fidget: bool,
}

impl Restless {
    pub fn new(stride: usize, fidget: bool) -> Restless {
        Restless { turn: 0, stride, fidget }
    }
}

impl Policy for Restless {
    fn name(&self) -> String {
        "restless".into()
    }

    fn choose(&mut self, input: &PolicyInput<'_>) -> Result<PolicyReply, exploration_harness::PolicyError> {
        let choices: Vec<&Skill> = input.skills.list.iter().filter(|s| **s != Skill::Done).collect();
        self.turn += 1;
        let at_hand = choices.iter().find(|s| matches!(s, Skill::Open(_) | Skill::Close(_) | Skill::Look));
        if self.fidget
            && let Some(skill) = at_hand
        {
            return Ok(PolicyReply { proposed: Vec::new(), done: false, skill: (*skill).clone() });
        }
        let skill = choices.get(self.turn * self.stride % choices.len().max(1)).map_or(Skill::Done, |s| (*s).clone());
        Ok(PolicyReply { proposed: Vec::new(), done: skill == Skill::Done, skill })
    }

    fn usage(&self) -> PolicyUsage {
        PolicyUsage::default()
    }
}

/// No skill of Phase I with a target (`goto`, `open`, `close`) was chosen twice, and some were.
pub fn assert_no_target_repeats(episode: &Episode, what: &str) {
    let chosen: Vec<&str> =
        episode.decisions.iter().map(|d| d.skill.as_str()).filter(|s| !s.is_empty() && *s != "look" && *s != "done").collect();
    let distinct: std::collections::BTreeSet<&str> = chosen.iter().copied().collect();
    assert_eq!(distinct.len(), chosen.len(), "{what}: a skill repeated: {chosen:?}");
    assert!(!chosen.is_empty(), "{what}");
}

/// The episode ends where the engine ends it and nowhere else: its engine script, replayed in
/// `env` from a reset, gives each line the outcome the episode recorded, the engine ends the
/// episode (`done`: ALFWorld's game once won) at the last line or at none, and the goal check
/// at the end is the episode's verdict. (EAI's executor ends no episode: a VirtualHome plan is
/// sent whole even when the goal holds before its last line.)
pub fn assert_ends_where_the_engine_does(env: &mut dyn household_sim::Environment, episode: &Episode, what: &str) {
    env.reset();
    let script = &episode.engine_script;
    assert!(
        !env.done() || script.is_empty(),
        "{what}: the engine has ended the episode at the start, yet {} line(s) were sent",
        script.len()
    );
    for (n, line) in script.iter().enumerate() {
        let executed = env.step(&line.line).event.executed();
        assert_eq!(executed, line.executed, "{what}: line {} {}", n + 1, line.line);
        let last = n + 1 == script.len();
        assert!(!env.done() || last, "{what}: the engine ended the episode after line {} of {}: {}", n + 1, script.len(), line.line);
    }
    assert_eq!(env.goal_reached(), episode.success, "{what}: the replay's verdict");
}
