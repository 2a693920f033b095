//! Phase I (paper §3.1, Eqs. 1-3) as one loop over a benchmark [`Adapter`]:
//!
//! ```text
//! K_t = H(G, F_t, R_t)                      the controller (Adapter::skills)
//! (P_t, k_t, done_t) = f_φ(o_t, G, F_t, K_t) the policy (Policy::choose)
//! F_{t+1} = U(F_t, P_t, o_{t+1}, e_{t+1})   the evidence update (Adapter::observe, Belief)
//! ```
//!
//! until Ready(F, G) holds, the policy says Done, or the step budget is spent.
//!
//! Rules, each where it is implemented:
//! - Done before Ready (the `done` flag without a valid skill, or the skill `done`) is overruled
//!   while the sweep has an inspection left: the harness takes that skill instead and tells the
//!   policy so (paper §3.1: the harness may require another inspection when evidence is
//!   insufficient); with none left, exploration stops;
//! - the policy may choose only a skill of K_t; a reply naming another skill is refused (the
//!   step is recorded with the feedback "not a valid skill", no command is sent), and so is a
//!   reply that cannot be read; after [`MAX_REFUSALS`] of them in a row exploration stops;
//! - a skill's commands are the adapter's ([`Adapter::commands`]; `Look` may be several);
//!   each is one environment step, counted against the budget, whatever the outcome;
//! - the model's proposed facts are kept as hypotheses ([`Belief::propose`]): they may steer
//!   the next inspection (the adapter puts places they name first), never enter F_t; a fact
//!   enters F_t only as a percept of an observation (U, [`crate::evidence`]);
//! - [`Systematic`] is the control: no model; it takes the sweep's skill (the controller's own
//!   next inspection, [`Skills::sweep`]) and says Done when there is none.

use std::collections::BTreeSet;
use std::fmt;

use household_sim::{Environment, Event, Observation};
use serde::Serialize;

use crate::evidence::{Belief, Fact};
use crate::goal::ClassGoal;

/// Refusals in a row (replies naming a skill outside K_t) after which exploration stops.
pub const MAX_REFUSALS: usize = 3;

/// One skill of the fixed family {Goto(x), Open(x), Close(x), Look, Done} (paper Eq. 1);
/// `x` is a name as the agent perceived it (`fridge 1`, `dishwasher (1000)`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Skill {
    /// Go to the named place.
    Goto(String),
    /// Open the named place.
    Open(String),
    /// Close the named place.
    Close(String),
    /// The active-inspection macro (the adapter says what it does in its benchmark).
    Look,
    /// End exploration; taken only when the sweep has no inspection left.
    Done,
}

impl fmt::Display for Skill {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Skill::Goto(x) => write!(f, "goto {x}"),
            Skill::Open(x) => write!(f, "open {x}"),
            Skill::Close(x) => write!(f, "close {x}"),
            Skill::Look => write!(f, "look"),
            Skill::Done => write!(f, "done"),
        }
    }
}

impl Skill {
    /// Reads [`Skill`]'s `Display` form back (`goto fridge 1`, `look`).
    pub fn parse(text: &str) -> Option<Skill> {
        let text = text.trim();
        let lower = text.to_ascii_lowercase();
        let arg = |prefix: &str| text.get(prefix.len()..).map(str::trim).filter(|x| !x.is_empty()).map(str::to_string);
        if lower == "look" {
            Some(Skill::Look)
        } else if lower == "done" {
            Some(Skill::Done)
        } else if lower.starts_with("goto ") {
            arg("goto ").map(Skill::Goto)
        } else if lower.starts_with("open ") {
            arg("open ").map(Skill::Open)
        } else if lower.starts_with("close ") {
            arg("close ").map(Skill::Close)
        } else {
            None
        }
    }
}

/// K_t: the skills the controller offers now, and the one its own sweep would take.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Skills {
    /// Ordered: the sweep's preference first. Always ends with `Done`.
    pub list: Vec<Skill>,
    /// Index into `list` of the sweep's next inspection; `None` when the sweep has none left.
    pub sweep: Option<usize>,
}

impl Skills {
    /// Keeps the first `k` `Goto` skills of the controller's order (and the sweep's skill,
    /// whatever it is), every other skill as it was. The paper's K_t omits targets already
    /// inspected or not yet grounded; this also omits, for now, places the controller ranks
    /// below its `k` most promising (they come back as those are inspected). A small model
    /// given every unvisited place tends to follow the pattern of its own history (SmolLM2
    /// opened 27 cabinets one after another where the object stood on the dining table)
    /// rather than the controller's ranking.
    pub fn frontier(&mut self, k: usize) {
        let sweep = self.sweep.map(|i| self.list[i].clone());
        let mut gotos = 0;
        self.list.retain(|s| {
            let goto = matches!(s, Skill::Goto(_));
            gotos += usize::from(goto);
            !goto || gotos <= k || sweep.as_ref() == Some(s)
        });
        self.sweep = sweep.and_then(|s| self.list.iter().position(|x| *x == s));
    }
}

/// How Phase I offers places to a model explorer: at most `width` `Goto` skills at a time
/// ([`Skills::frontier`]), the controller's most promising first.
///
/// With `narrowing` (beyond the paper), the offer narrows by one place each time the model
/// passes over the controller's first place for another one, down to that place alone, and
/// widens back to `width` once the model takes it. The model still chooses where to look while
/// it keeps to the controller's ranking or disagrees with it once; it cannot spend the step
/// budget disagreeing. Measured on EAI's tasks: without narrowing, SmolLM2 passed over the
/// coffee maker that held the coffee filter (183_2, 229_1, 764_2) from the step the controller
/// first offered it until the 20 steps were spent; with it, SmolLM2 wins 321 of the 342 tasks
/// against 317 (docs/ARCHITECTURE.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frontier {
    /// The most `Goto` skills offered at a time (the sweep's own place is kept beyond them).
    pub width: usize,
    /// Narrow the offer while the model passes over the controller's first place.
    pub narrowing: bool,
}

impl Frontier {
    /// The width of the next offer after a decision that chose `chosen` from `offered` (the
    /// offer of width `now`).
    pub fn next_width(&self, now: usize, offered: &Skills, chosen: &Skill) -> usize {
        let first = offered.sweep.map(|i| &offered.list[i]).filter(|s| matches!(s, Skill::Goto(_)));
        match first {
            Some(first) if self.narrowing && first == chosen => self.width,
            Some(_) if self.narrowing && matches!(chosen, Skill::Goto(_)) => now.saturating_sub(1).max(1),
            _ => now,
        }
    }
}

/// One environment step.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct StepRecord {
    /// `explore` or `plan`.
    pub phase: &'static str,
    /// The command sent, in the environment's language.
    pub command: String,
    /// Whether the environment executed it.
    pub executed: bool,
    /// The text of the observation the environment answered with.
    pub observation: String,
}

/// One Phase I decision: the skill chosen, what it sent, and what U did with it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Decision {
    /// The skill taken, as [`Skill`] displays it: the sweep's where the harness overruled Done,
    /// the one the model named where it was refused; empty when the reply could not be read.
    pub skill: String,
    /// Skills offered (K_t).
    pub offered: Vec<String>,
    /// Indices into the episode's steps of the commands this skill sent.
    pub steps: Vec<usize>,
    /// Facts the environment's observations established (F_{t+1} \ F_t, and changed facts).
    pub admitted: Vec<String>,
    /// The model's proposals that no observation backed: kept as hypotheses, not facts.
    pub refused: Vec<String>,
    /// The policy said Done before Ready and the harness took the sweep's skill instead.
    pub required: bool,
    /// `success`, `failed` (a command was not executed), `cut` (the step budget ran out before
    /// the skill's last command), `refused` (not a skill of K_t) or `error` (the policy's reply
    /// could not be read; `feedback` holds the error).
    pub outcome: &'static str,
    /// The outcome the policy is told next turn.
    pub feedback: String,
}

/// What the policy sees at step t (paper's Phase I prompt).
#[derive(Debug, Clone)]
pub struct PolicyInput<'a> {
    /// The benchmark (`alfworld`, `virtualhome-eai`, ...).
    pub benchmark: &'a str,
    /// The task sentence.
    pub task: &'a str,
    /// Goal object classes to find and locate.
    pub objects: &'a [String],
    /// F_t, one fact a line, as the adapter writes it for models.
    pub belief: Vec<String>,
    /// Previous skills with their outcomes (`goto fridge 1 -> success`).
    pub history: Vec<String>,
    /// K_t: the skills the policy may choose from.
    pub skills: &'a Skills,
    /// The outcome of the previous decision, in words (`This is the first step.` at first).
    pub feedback: &'a str,
    /// The current observation (its text, and its picture where the environment renders one).
    pub observation: &'a Observation,
}

/// f_φ's reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PolicyReply {
    /// P_t: facts the model claims (never admitted without evidence).
    pub proposed: Vec<Fact>,
    /// k_t: the skill chosen; one outside K_t is refused.
    pub skill: Skill,
    /// done_t: the model deems exploration over. Read as [`Skill::Done`] only where `skill`
    /// is not offered; otherwise `skill` is taken.
    pub done: bool,
}

/// What a policy spent, counted as the direct policy's [`crate::DirectUsage`] is: every chat
/// request (a repair turn is a second one, a reply that could not be read counts too), and the
/// tokens the model read and wrote in all of them. Zero for the systematic sweep.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct PolicyUsage {
    /// Chat requests.
    pub calls: u64,
    /// Prompt tokens over those requests, as the model counts them (an image's tokens
    /// included where a server counts them).
    pub prompt_tokens: u64,
    /// Tokens the model generated over those requests.
    pub generated_tokens: u64,
    /// Observations shown to the model, and of them those with a picture.
    pub observations: u64,
    /// Of those observations, the ones shown with a picture.
    pub images: u64,
    /// Calls answered from a reply cache (`vlm_client::CachedChat`) instead of the model: the
    /// tokens above count what the model generated when it first answered them.
    #[serde(skip_serializing_if = "is_zero")]
    pub cached_calls: u64,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

impl PolicyUsage {
    /// What was used after `earlier` (a reading of the same policy's usage).
    pub fn since(&self, earlier: &PolicyUsage) -> PolicyUsage {
        PolicyUsage {
            calls: self.calls.saturating_sub(earlier.calls),
            prompt_tokens: self.prompt_tokens.saturating_sub(earlier.prompt_tokens),
            generated_tokens: self.generated_tokens.saturating_sub(earlier.generated_tokens),
            observations: self.observations.saturating_sub(earlier.observations),
            images: self.images.saturating_sub(earlier.images),
            cached_calls: self.cached_calls.saturating_sub(earlier.cached_calls),
        }
    }
}

/// Why a policy gave no reply.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PolicyError {
    /// The model answered, but not with a reply that can be read: the model's failure, refused
    /// like an invalid skill.
    #[error("{0}")]
    Unreadable(String),
    /// The model could not be asked: the run's failure, not the model's ([`RunError`]).
    #[error(transparent)]
    Run(#[from] RunError),
}

/// A failure of the run rather than of the agent: a model that cannot be reached, a setting it
/// refuses, an internal error. The episode is not an outcome: a harness stops the run without
/// recording it, and a rerun resumes that task.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct RunError(pub String);

/// The policy f_φ (paper Eq. 2).
pub trait Policy {
    /// `systematic`, `openai:URL`, `local:NAME`, ...
    fn name(&self) -> String;
    /// f_φ: the reply to one step's input. [`PolicyError::Unreadable`] is refused like an
    /// invalid skill; [`PolicyError::Run`] stops the run.
    fn choose(&mut self, input: &PolicyInput<'_>) -> Result<PolicyReply, PolicyError>;
    /// Usage summed over every call so far (a harness reading one episode takes the difference:
    /// [`PolicyUsage::since`]).
    fn usage(&self) -> PolicyUsage;
}

/// The model-free control: the controller's own sweep.
#[derive(Debug, Clone, Copy, Default)]
pub struct Systematic;

impl Policy for Systematic {
    fn name(&self) -> String {
        "systematic".into()
    }

    fn choose(&mut self, input: &PolicyInput<'_>) -> Result<PolicyReply, PolicyError> {
        let skill = input.skills.sweep.map_or(Skill::Done, |i| input.skills.list[i].clone());
        Ok(PolicyReply { proposed: Vec::new(), done: skill == Skill::Done, skill })
    }

    fn usage(&self) -> PolicyUsage {
        PolicyUsage::default()
    }
}

/// R_t: what Phase I did so far.
#[derive(Debug, Clone, Default)]
pub struct Record {
    /// Every decision, in order, refused and unreadable ones included; a `Done` that ends the
    /// exploration is not recorded here.
    pub decisions: Vec<Decision>,
    /// Every environment step, in order.
    pub steps: Vec<StepRecord>,
    /// Perceived instances a hand-over bound to a goal symbol where ŝ0 proved the goal
    /// unreachable (a goal fact about them that no sequence of actions can make true, e.g. a
    /// computer that is unplugged and has no plug to put in): Ready and β pass them over, so
    /// Phase I goes on to find another instance of the class (`crate::episode`'s
    /// re-exploration). Empty in the paper's episode, which stops at the first Ready.
    pub set_aside: BTreeSet<String>,
}

impl Record {
    /// The last command the environment executed, if any.
    pub fn last_executed(&self) -> Option<&str> {
        self.steps.iter().rev().find(|s| s.executed).map(|s| s.command.as_str())
    }
}

/// A benchmark's side of Phase I: how its observations are read, which skills exist now, what
/// commands a skill sends, when the goal's objects are grounded, and the hand-over.
pub trait Adapter {
    /// Reads an observation (step 0: the reset's) into F_t: U's percepts.
    fn observe(&mut self, observation: &Observation, step: usize, belief: &mut Belief);
    /// K_t = H(G, F_t, R_t). An adapter sees the environment only through observations and
    /// outcomes (`observe`, R_t): the methods here are not given it.
    fn skills(&self, goal: &ClassGoal, belief: &Belief, record: &Record) -> Skills;
    /// The environment commands of a skill of K_t.
    fn commands(&self, skill: &Skill, goal: &ClassGoal, belief: &Belief, record: &Record) -> Vec<String>;
    /// A command that still reaches the end of a skill whose last command (R_t's last step) was
    /// not executed, decided from that outcome (default: none); once per skill. If it executes,
    /// the skill has executed. ALFWorld: a `go to` the place whose location the agent already
    /// stands at does nothing ("Nothing happens."), and examining the place shows it.
    fn recover(&self, _skill: &Skill, _record: &Record) -> Option<String> {
        None
    }
    /// A command the outcome of a skill's commands calls for, decided from F_t after them
    /// (default: none). Both adapters: a `goto` that arrives at a closed place that opens is
    /// followed by opening it, since a closed place shows nothing of what it holds; otherwise a
    /// model that walks on instead inspects nothing (SmolLM2 walked to 20 closed cabinets of
    /// ALFWorld without opening one).
    fn follow_up(&self, _skill: &Skill, _belief: &Belief, _record: &Record) -> Option<String> {
        None
    }
    /// Ready(F, G): the goal's objects and relations are grounded, by instances not in
    /// `record.set_aside`.
    fn ready(&self, goal: &ClassGoal, belief: &Belief, record: &Record) -> bool;
    /// The goal's object classes, as the prompt lists them.
    fn objects_to_find(&self, goal: &ClassGoal) -> Vec<String>;
    /// F_t as the prompt's "Current belief" shows it, one fact a line (default: the facts that
    /// hold).
    fn belief_lines(&self, _goal: &ClassGoal, belief: &Belief) -> Vec<String> {
        belief.facts().iter().filter(|f| f.holds).map(Fact::to_string).collect()
    }
}

/// The result of Phase I.
#[derive(Debug, Clone)]
pub struct Exploration {
    /// F_t, the hypotheses and the places, as exploration left them.
    pub belief: Belief,
    /// R_t: the decisions and steps taken.
    pub record: Record,
    /// Why exploration stopped: `goal` (the environment's goal check holds: the episode is
    /// over), `ready`, `done` (the policy), `budget`, `refusals`, or `policy error: ...`.
    pub stop: String,
    /// The last observation (the policy's input if Phase I [`resume`]s).
    pub observation: Observation,
}

/// Phase I within `budget` environment steps, offering `Goto` skills as `frontier` says
/// ([`Frontier`]; `None`: every unvisited place). `first` is the reset's observation.
pub fn explore(
    env: &mut dyn Environment,
    adapter: &mut dyn Adapter,
    policy: &mut dyn Policy,
    goal: &ClassGoal,
    first: &Observation,
    budget: usize,
    frontier: Option<Frontier>,
) -> Result<Exploration, RunError> {
    let mut belief = Belief::default();
    adapter.observe(first, 0, &mut belief);
    let start = Exploration { belief, record: Record::default(), stop: String::new(), observation: first.clone() };
    resume(env, adapter, policy, goal, start, "This is the first step.", budget, frontier)
}

/// Phase I again from where `exploration` stopped (its F_t, R_t and last observation), with
/// `feedback` as the policy's first feedback, until Ready, Done or `budget` steps in all
/// (counting `exploration`'s own).
#[allow(clippy::too_many_arguments)]
pub fn resume(
    env: &mut dyn Environment,
    adapter: &mut dyn Adapter,
    policy: &mut dyn Policy,
    goal: &ClassGoal,
    exploration: Exploration,
    feedback: &str,
    budget: usize,
    frontier: Option<Frontier>,
) -> Result<Exploration, RunError> {
    let Exploration { mut belief, mut record, observation, .. } = exploration;
    let objects = adapter.objects_to_find(goal);
    let sentence = env.goal().sentence.clone();
    let benchmark = env.goal().benchmark.clone();
    let mut observation = observation;
    let mut feedback = feedback.to_string();
    let mut refusals = 0;
    // The frontier's width now (it narrows as `Frontier` says).
    let mut width = frontier.map(|f| f.width);
    let stop = loop {
        // The engine has ended the episode (ALFWorld's game is done once won).
        if env.done() {
            break "goal".to_string();
        }
        if adapter.ready(goal, &belief, &record) {
            break "ready".to_string();
        }
        if record.steps.len() >= budget {
            break "budget".to_string();
        }
        let mut skills = adapter.skills(goal, &belief, &record);
        if let Some(k) = width {
            skills.frontier(k);
        }
        let history = record
            .decisions
            .iter()
            .filter(|d| d.outcome != "error")
            .enumerate()
            .map(|(i, d)| format!("{}. {} -> {}", i + 1, d.skill, d.outcome))
            .collect();
        let input = PolicyInput {
            benchmark: &benchmark,
            task: &sentence,
            objects: &objects,
            belief: adapter.belief_lines(goal, &belief),
            history,
            skills: &skills,
            feedback: &feedback,
            observation: &observation,
        };
        let reply = match policy.choose(&input) {
            Ok(reply) => reply,
            Err(PolicyError::Run(e)) => return Err(e),
            Err(PolicyError::Unreadable(e)) => {
                // An unreadable reply is refused like an invalid skill.
                refusals += 1;
                feedback = "Your reply could not be read; answer with the JSON asked for.".to_string();
                record.decisions.push(Decision {
                    skill: String::new(),
                    offered: skills.list.iter().map(Skill::to_string).collect(),
                    steps: Vec::new(),
                    admitted: Vec::new(),
                    refused: Vec::new(),
                    required: false,
                    outcome: "error",
                    feedback: format!("policy error: {e}"),
                });
                if refusals >= MAX_REFUSALS {
                    break format!("policy error: {e}");
                }
                continue;
            }
        };
        let before = belief.facts();
        belief.propose(&reply.proposed);
        let offered: Vec<String> = skills.list.iter().map(Skill::to_string).collect();
        // Done before Ready: the harness requires the sweep's next inspection while it has one
        // (the paper: "the harness may require another inspection or container-opening action
        // when evidence is insufficient"); with none left, Done stands.
        let mut reply = reply;
        let mut required = false;
        if reply.skill == Skill::Done || (reply.done && !skills.list.contains(&reply.skill)) {
            match skills.sweep {
                Some(i) => {
                    reply.skill = skills.list[i].clone();
                    required = true;
                }
                None => break "done".to_string(),
            }
        }
        if !skills.list.contains(&reply.skill) {
            refusals += 1;
            feedback = format!("\"{}\" is not a valid skill right now; choose one of the valid skills.", reply.skill);
            record.decisions.push(Decision {
                skill: reply.skill.to_string(),
                offered,
                steps: Vec::new(),
                admitted: Vec::new(),
                refused: reply.proposed.iter().map(Fact::to_string).collect(),
                required: false,
                outcome: "refused",
                feedback: feedback.clone(),
            });
            if refusals >= MAX_REFUSALS {
                break "refusals".to_string();
            }
            continue;
        }
        refusals = 0;
        if let (Some(f), Some(now)) = (frontier, width) {
            width = Some(f.next_width(now, &skills, &reply.skill));
        }
        let mut steps = Vec::new();
        // Commands of this skill not executed and not recovered: the skill executed when none.
        let mut unrecovered = 0usize;
        let mut reason = String::new();
        let mut pending = adapter.commands(&reply.skill, goal, &belief, &record);
        pending.reverse();
        let mut followed = false;
        // The step budget ran out before a command of the skill could be sent.
        let mut cut = false;
        // The recovery command, once sent (`Adapter::recover`).
        let (mut recovered, mut recovering) = (false, false);
        loop {
            let command = match pending.pop() {
                Some(c) => c,
                None if unrecovered == 0 && !followed => {
                    followed = true;
                    match adapter.follow_up(&reply.skill, &belief, &record) {
                        Some(c) => c,
                        None => break,
                    }
                }
                None => break,
            };
            if record.steps.len() >= budget {
                cut = true;
                break;
            }
            let result = env.step(&command);
            let step = record.steps.len() + 1;
            adapter.observe(&result.observation, step, &mut belief);
            let executed = result.event.executed();
            if let Event::NotExecuted { reason: r } = &result.event {
                unrecovered += 1;
                reason = r.clone();
            }
            steps.push(record.steps.len());
            record.steps.push(StepRecord { phase: "explore", command, executed, observation: result.observation.text.clone() });
            observation = result.observation;
            if env.done() {
                break;
            }
            // A recovery that executes makes up for the failure it answered, not for others.
            if recovering && executed {
                unrecovered -= 1;
            }
            recovering = false;
            if !executed
                && !recovered
                && let Some(command) = adapter.recover(&reply.skill, &record)
            {
                (recovered, recovering) = (true, true);
                pending.push(command);
            }
        }
        let after = belief.facts();
        let admitted: Vec<String> = after.iter().filter(|f| !before.contains(f)).map(Fact::to_string).collect();
        let refused: Vec<String> = reply.proposed.iter().filter(|f| !after.contains(f)).map(Fact::to_string).collect();
        let executed_all = unrecovered == 0;
        feedback = match (executed_all, required) {
            (true, false) => "The previous action executed successfully.".to_string(),
            (true, true) => format!("Not every listed object is grounded yet, so the harness inspected instead: {}.", reply.skill),
            (false, _) => format!("The previous action could not be executed: {reason}."),
        };
        let outcome = match (executed_all, cut) {
            (false, _) => "failed",
            (true, true) => "cut",
            (true, false) => "success",
        };
        record.decisions.push(Decision {
            skill: reply.skill.to_string(),
            offered,
            steps,
            admitted,
            refused,
            required,
            outcome,
            feedback: feedback.clone(),
        });
    };
    Ok(Exploration { belief, record, stop, observation })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skills_read_back_as_written() {
        for skill in [
            Skill::Goto("fridge 1".into()),
            Skill::Open("dishwasher (1000)".into()),
            Skill::Close("cabinet 10".into()),
            Skill::Look,
            Skill::Done,
        ] {
            assert_eq!(Skill::parse(&skill.to_string()), Some(skill.clone()), "{skill}");
        }
        assert_eq!(Skill::parse("goto"), None);
        assert_eq!(Skill::parse("fly to the moon"), None);
    }

    #[test]
    fn a_frontier_keeps_the_first_places_and_every_other_skill() {
        let goto = |x: &str| Skill::Goto(x.into());
        let all =
            vec![Skill::Open("fridge 1".into()), goto("countertop 1"), goto("cabinet 1"), goto("cabinet 2"), Skill::Look, Skill::Done];
        let mut skills = Skills { list: all.clone(), sweep: Some(1) };
        skills.frontier(1);
        assert_eq!(skills.list, [Skill::Open("fridge 1".into()), goto("countertop 1"), Skill::Look, Skill::Done]);
        assert_eq!(skills.sweep, Some(1), "the sweep's skill, where it now stands");
        // The sweep's place stays offered even past the frontier.
        let mut skills = Skills { list: all.clone(), sweep: Some(3) };
        skills.frontier(1);
        assert_eq!(skills.list, [Skill::Open("fridge 1".into()), goto("countertop 1"), goto("cabinet 2"), Skill::Look, Skill::Done]);
        assert_eq!(skills.sweep, Some(2));
        let mut wide = Skills { list: all.clone(), sweep: None };
        wide.frontier(5);
        assert_eq!(wide.list, all, "a frontier wider than the places keeps them all");
    }
}
