//! The direct interactive policy baseline (paper §4, Appendix A.2 "Direct Visual Interaction"
//! and the direct-interaction prompt figure): a chat model chooses one class-level action per
//! turn, the environment executes it or answers with its concise failure, and the model sees
//! the outcome on the next turn. No exploration harness, no symbolic state, no planner.
//!
//! Each turn is one request to any [`vlm_client::ChatModel`] (a served model or a local one):
//! a system message (the role, first-person observation, reachability, class-name conventions,
//! exactly one action) and one user message in the figure's parts: the goal sentence, the goal
//! objects' class names, the action forms of the benchmark's command language, the previous
//! actions with their outcomes (`3. walk dishwasher -> success`), the feedback of the last
//! action (the same outcome channel Phase I has: executed, or the environment's own concise
//! failure) and the current observation, its picture attached where the environment renders
//! one. Greedy decoding, at most [`MAX_REPLY_TOKENS`] output tokens (Appendix Table 6: "Qwen
//! direct interactive ... 128 per turn"). The reply is JSON under [`reply_schema`]: `action`, a
//! free string (one command as the benchmark spells it), and `done`.
//!
//! What the model never sees (Appendix A.1, A.2): the scene graph or any hidden state, the
//! admissible-command list (the paper's direct prompt gives action *forms*, not valid actions;
//! "this feedback exposes neither a valid-action list nor a symbolic state"), and any instance
//! identifier other than those the observations show. In VirtualHome the harness accepts only
//! class-level commands (`grab plate`); an instance-level script line (`[GRAB] <plate> (1001)`)
//! is refused without reaching the environment, since the paper's adapter grounds classes and
//! the model may not pick instances.
//!
//! The loop, per turn, within the step limit (20 VirtualHome, 55 ALFWorld, "matched to
//! N_exp + N_plan"):
//! - `done` true, or the action `DONE`: the episode ends ([`DirectEnd::Done`]); nothing is sent;
//! - otherwise the command goes to the environment (one step). Executed: the next observation is
//!   the environment's; the goal check may end the episode ([`DirectEnd::Success`]). Not executed:
//!   the observation stays the previous one ("failed actions receive a short grounding or
//!   reachability error and an unchanged observation");
//! - a reply that cannot be read as the JSON asked for (after `chat_json`'s one repair turn), or
//!   that the model cannot produce at all (a deterministic model error), is a failed turn: it
//!   counts as a step and a failure, and nothing is sent;
//! - after [`FAILURE_LIMIT`] failed turns in a row the episode ends
//!   ([`DirectEnd::Failures`], the paper's "ungroundable threshold", Table 11's *Grounding*);
//! - when every step is spent, [`DirectEnd::Limit`].
//!
//! The failure attribution of §5.3 for direct policies: `grounding` when the failure threshold
//! ended the episode, `goal` otherwise (the interaction limit, or a premature `DONE`).
//! A model that is unreachable ([`ChatErrorKind::is_unavailable`]: connection, timeout, 5xx,
//! 429, a bad URL, a missing key, 401/403/404) is an error of the run ([`DirectError`]), not an
//! episode outcome, so a rerun can resume it.

use std::time::Instant;

use household_sim::{EngineLine, Environment, Event, Judge, Observation};
use serde::Serialize;
use serde_json::{Value, json};
use vlm_client::{ChatErrorKind, ChatModel, ChatRequest, Image, Message, Sampling};

use crate::episode::Attribution;
use crate::goal::ClassGoal;

/// Output tokens per reply (Appendix Table 6: Qwen direct interactive, 128 per turn).
pub const MAX_REPLY_TOKENS: u32 = 128;

/// Failed turns in a row that end an episode. The paper names an "ungroundable threshold"
/// (Table 11) without its value; five is Table 12's persistent-loop length, so a policy that
/// keeps sending a failing request is stopped when its repetition becomes a loop.
pub const FAILURE_LIMIT: usize = 5;

/// The longest action string the schema allows (a command is a few words; a small model under
/// the schema otherwise spells on until the token limit).
pub const MAX_ACTION_CHARS: usize = 120;

/// Settings of one direct episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DirectConfig {
    /// Turns (environment steps and failed turns) per episode.
    pub budget: usize,
    /// Failed turns in a row that end the episode.
    pub failure_limit: usize,
    /// Output tokens per reply, greedy decoding.
    pub max_reply_tokens: u32,
}

impl DirectConfig {
    /// The paper's settings for `benchmark` (`alfworld`, `virtualhome-*`).
    pub fn paper(benchmark: &str) -> DirectConfig {
        let budget = if is_virtualhome(benchmark) { 20 } else { 55 };
        DirectConfig { budget, failure_limit: FAILURE_LIMIT, max_reply_tokens: MAX_REPLY_TOKENS }
    }
}

fn is_virtualhome(benchmark: &str) -> bool {
    benchmark.starts_with("virtualhome")
}

/// How a direct episode ended (mutually exclusive; Table 11's terminal mechanism).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DirectEnd {
    /// The environment's goal check held after an executed step.
    Success,
    /// The model said DONE short of the goal.
    Done,
    /// Every step of the budget was spent.
    Limit,
    /// [`DirectConfig::failure_limit`] failed turns in a row.
    Failures,
}

/// One turn that did not end the episode by DONE: the request and its outcome.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DirectStep {
    /// The class-level request as the model wrote it (trimmed); empty when the reply could not
    /// be read.
    pub command: String,
    /// Whether the environment executed it.
    pub executed: bool,
    /// Whether it reached the environment (a reply that could not be read, or a VirtualHome
    /// instance-level line, did not).
    pub sent: bool,
    /// Why it was not executed: the environment's answer, or the harness's.
    pub reason: Option<String>,
    /// The model's reply text (at most 500 characters).
    pub reply: String,
    /// The environment's observation text after the step (unchanged view when not executed).
    pub observation: String,
}

/// What the model was shown and spent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct DirectUsage {
    /// Chat requests (a repair turn is a second one).
    pub model_calls: u64,
    /// Prompt tokens over those requests, as the model counts them.
    pub prompt_tokens: u64,
    /// Tokens the model generated over those requests.
    pub generated_tokens: u64,
    /// Observations shown (one per turn), and of them those with a picture (model-visible
    /// images, counted once per turn).
    pub observations: u64,
    /// Of those observations, the ones shown with a picture.
    pub images: u64,
}

/// Everything recorded about one direct episode.
#[derive(Debug, Clone, Serialize)]
pub struct DirectEpisode {
    /// The environment's own goal check after the episode.
    pub success: bool,
    /// What ended the episode.
    pub end: DirectEnd,
    /// Every turn but a final DONE.
    pub steps: Vec<DirectStep>,
    /// §5.3 for direct policies: `grounding` (the failure threshold ended it) or `goal`.
    pub attribution: Option<Attribution>,
    /// The goal's parts that do not hold at the end, from the judge (evaluation only).
    pub unmet_goals: Vec<String>,
    /// The episode as the benchmark's own engine takes it, to replay there (the judge's
    /// [`Judge::engine_script`]; evaluation only).
    pub engine_script: Vec<EngineLine>,
    /// What the model was shown and spent over the episode.
    pub usage: DirectUsage,
    /// The DONE reply, when the model ended the episode.
    pub done_reply: Option<String>,
    /// Wall-clock milliseconds of the whole episode, the reset included.
    pub millis: f64,
    /// Wall-clock milliseconds spent waiting for the model, summed over the requests.
    pub model_millis: f64,
}

impl DirectEpisode {
    /// The requests in order with whether each was executed (`eval_harness::behaviour`'s input).
    pub fn requests(&self) -> Vec<(&str, bool)> {
        self.steps.iter().map(|s| (s.command.as_str(), s.executed)).collect()
    }

    /// Whether the model's DONE ended the episode.
    pub fn model_done(&self) -> bool {
        self.end == DirectEnd::Done
    }
}

/// Why a direct episode could not be run (a model that cannot be reached, a picture that cannot be
/// sent): the run stops and the episode is not recorded.
#[derive(Debug, thiserror::Error)]
pub enum DirectError {
    /// The model could not be reached ([`ChatErrorKind::is_unavailable`]).
    #[error("the chat model is unavailable: {0}")]
    Unavailable(vlm_client::ChatError),
    /// The observation's picture could not be made an image of the request.
    #[error("the observation's picture cannot be sent: {0}")]
    Picture(ChatErrorKind),
}

/// The reply's JSON schema: a free action string and the done flag.
pub fn reply_schema() -> Value {
    json!({
        "type": "object",
        "properties": {
            "action": { "type": "string", "maxLength": MAX_ACTION_CHARS },
            "done": { "type": "boolean" }
        },
        "required": ["action", "done"],
        "additionalProperties": false
    })
}

fn world(benchmark: &str) -> &'static str {
    if is_virtualhome(benchmark) { "VirtualHome" } else { "ALFWorld" }
}

/// The system message: first-person observation, reachability, class-name conventions, one
/// action per turn.
pub fn system_prompt(benchmark: &str) -> String {
    let (reach, names) = if is_virtualhome(benchmark) {
        (
            "The agent can act only on an object it is close to: walk to it first. An object inside a closed container cannot be seen or reached until the container is open.",
            "Name objects and rooms by their VirtualHome class name only (wineglass, kitchentable, kitchen), never with a number: the environment picks the instance.",
        )
    } else {
        (
            "The agent can act only at the receptacle it has gone to, and only on objects it sees there or holds. Objects inside a closed receptacle cannot be seen until it is opened.",
            "Name objects and receptacles exactly as the observation names them: the class name followed by its number.",
        )
    };
    format!(
        "You control an embodied agent in {world}, a household simulator. You see what the agent perceives now, from its first-person view.\n\
         An action takes effect only if its conditions already hold. {reach}\n\
         {names}\n\
         Each turn, choose exactly one next action toward the goal, or DONE once the goal is achieved. Reply with JSON only.",
        world = world(benchmark)
    )
}

/// The action forms of the benchmark's command language (the prompt figure's "ACTION FORMS").
/// ALFWorld: its own command listing (the game's `help`). VirtualHome: the figure's forms for
/// the rearrangement set (walk, grab, open, close, putback, putin; the figure's camera moves
/// `turnleft`, `turnright`, `walkforward` are left out: this environment has no camera pose and
/// refuses them), and for EAI's tasks every action the executor knows, in its declaration order.
pub fn action_forms(benchmark: &str) -> Vec<String> {
    let fixed = |forms: &[&str]| forms.iter().map(|f| f.to_string()).collect::<Vec<String>>();
    let mut forms = if benchmark == "virtualhome-eai" {
        let mut seen = Vec::new();
        let mut forms = Vec::new();
        for name in household_sim::VhAction::all_names() {
            let Some(action) = household_sim::VhAction::parse(name) else { continue };
            if seen.contains(&action) {
                continue;
            }
            seen.push(action);
            let name = action.name().to_ascii_lowercase();
            forms.push(match action.arity() {
                0 => name,
                1 => format!("{name} <object>"),
                _ => format!("{name} <object> <object>"),
            });
        }
        forms
    } else if is_virtualhome(benchmark) {
        fixed(&[
            "walk <object/room>",
            "grab <object>",
            "open <container>",
            "close <container>",
            "putback <object> <surface>",
            "putin <object> <container>",
        ])
    } else {
        fixed(&[
            "look",
            "inventory",
            "go to <receptacle>",
            "open <receptacle>",
            "close <receptacle>",
            "take <object> from <receptacle>",
            "move <object> to <receptacle>",
            "examine <object or receptacle>",
            "use <object>",
            "heat <object> with <receptacle>",
            "clean <object> with <receptacle>",
            "cool <object> with <receptacle>",
            "slice <object> with <object>",
        ])
    };
    forms.push("DONE".to_string());
    forms
}

/// The goal's object classes (the prompt's "Goal objects"), each once, in the goal's order.
pub fn goal_objects(goal: &ClassGoal) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for symbol in goal.symbols.iter().filter(|s| s.kind != "character") {
        if let Some(class) = &symbol.class
            && !out.contains(class)
        {
            out.push(class.clone());
        }
    }
    out
}

/// What the model is shown on one turn.
#[derive(Debug, Clone)]
pub struct DirectInput<'a> {
    /// The benchmark (`alfworld`, `virtualhome-eai`, ...): it decides the world's name and the
    /// action forms.
    pub benchmark: &'a str,
    /// The task sentence.
    pub goal: &'a str,
    /// The goal's object classes ([`goal_objects`]).
    pub objects: &'a [String],
    /// Previous actions with their outcomes, one a line.
    pub history: &'a [String],
    /// The outcome of the last action ([`FIRST_FEEDBACK`] on the first turn).
    pub feedback: &'a str,
    /// The current observation; its picture, where it has one, goes with the message.
    pub observation: &'a Observation,
}

/// The user message's text (the prompt figure's parts, in its order).
pub fn user_prompt(input: &DirectInput<'_>) -> String {
    let view = if input.observation.image.is_some() { "the first-person image and the observation" } else { "the observation" };
    let history = if input.history.is_empty() { "none".to_string() } else { input.history.join("\n") };
    format!(
        "Goal: {goal}\n\
         Goal objects (exact {world} class names): {objects}\n\
         Use {view} and choose the next action toward the goal.\n\
         Output only one action line (or DONE).\n\n\
         Action forms:\n{forms}\n\n\
         Previous actions:\n{history}\n\n\
         Feedback:\n{feedback}\n\n\
         Observation:\n{observation}\n\n\
         Reply with JSON only: {{\"action\": \"<one action line>\", \"done\": false}}. Set \"done\" to true only once the goal is achieved.",
        goal = input.goal.trim(),
        world = world(input.benchmark),
        objects = input.objects.join(", "),
        forms = action_forms(input.benchmark).join("\n"),
        feedback = input.feedback,
        observation = input.observation.text.trim(),
    )
}

/// The model's reply: an action, or DONE.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DirectReply {
    /// One command as the model wrote it, trimmed, not empty.
    Act(String),
    /// `done` true, or the action `DONE`: the episode ends.
    Done,
}

/// Reads a reply already checked against [`reply_schema`]: `done` true, or the action `DONE`
/// (any case), is DONE (the action is then not executed: the figure's DONE replaces an action);
/// an empty action is an error.
pub fn read_reply(value: &Value) -> Result<DirectReply, String> {
    let action = value.get("action").and_then(Value::as_str).ok_or("the reply has no \"action\"")?.trim();
    let done = value.get("done").and_then(Value::as_bool).unwrap_or(false);
    if done || action.eq_ignore_ascii_case("done") {
        return Ok(DirectReply::Done);
    }
    if action.is_empty() {
        return Err("the action is empty".to_string());
    }
    Ok(DirectReply::Act(action.to_string()))
}

/// The feedback on the first turn.
pub const FIRST_FEEDBACK: &str = "This is the first step.";
/// The feedback after an executed action (the figure's successful-action feedback).
pub const SUCCESS_FEEDBACK: &str =
    "Previous action executed successfully.\nHere is the updated first-person view. Choose the next action (or DONE).";

/// The feedback after a failed action (the figure's failed-action feedback, with the
/// environment's reason).
pub fn failure_feedback(command: &str, reason: &str) -> String {
    let reason = reason.trim().trim_end_matches('.');
    format!(
        "Your action \"{command}\" could not be executed: {reason} (invalid or unreachable).\nThe view did not change. Try a different next action."
    )
}

/// The feedback after a reply that could not be read.
pub fn unreadable_feedback(error: &str) -> String {
    format!(
        "Your reply could not be read as an action: {}.\nThe view did not change. Reply with the JSON asked for.",
        error.trim().trim_end_matches('.')
    )
}

/// The first `chars` characters of `text`.
fn clip(text: &str, chars: usize) -> String {
    text.chars().take(chars).collect()
}

/// Runs one direct episode (module documentation). `env` is reset first; the model is handed
/// only what the environment shows; the judge is asked only after the episode.
pub fn run_direct<E: Environment + Judge>(
    env: &mut E,
    model: &mut dyn ChatModel,
    goal: &ClassGoal,
    config: &DirectConfig,
) -> Result<DirectEpisode, DirectError> {
    let start = Instant::now();
    let mut observation = env.reset();
    let annotation = env.goal().clone();
    let benchmark = annotation.benchmark.as_str();
    let objects = goal_objects(goal);
    let system = system_prompt(benchmark);
    let mut history: Vec<String> = Vec::new();
    let mut feedback = FIRST_FEEDBACK.to_string();
    let mut steps: Vec<DirectStep> = Vec::new();
    let mut usage = DirectUsage::default();
    let mut failures_in_a_row = 0;
    let mut model_millis = 0.0;
    let mut done_reply = None;
    let end = loop {
        // The paper's direct policies end on the simulator's success (Appendix: Direct Visual
        // Interaction), in both benchmarks: the harness asks the goal check, not the model.
        if env.goal_reached() {
            break DirectEnd::Success;
        }
        if steps.len() >= config.budget {
            break DirectEnd::Limit;
        }
        if failures_in_a_row >= config.failure_limit {
            break DirectEnd::Failures;
        }
        let input = DirectInput {
            benchmark,
            goal: &annotation.sentence,
            objects: &objects,
            history: &history,
            feedback: &feedback,
            observation: &observation,
        };
        let mut user = Message::user(user_prompt(&input));
        if let Some(picture) = &observation.image {
            user = user.with_image(Image::from_bytes(picture.bytes.clone()).map_err(DirectError::Picture)?);
            usage.images += 1;
        }
        usage.observations += 1;
        let request = ChatRequest::new(vec![Message::system(system.clone()), user])
            .with_sampling(Sampling::greedy(config.max_reply_tokens))
            // Thinking off (the paper's direct interactive setting).
            .with_thinking(false)
            .with_json_schema(reply_schema());
        let asked = Instant::now();
        let (answer, spent) = crate::chat_policy::chat_json_counted(model, &request);
        model_millis += asked.elapsed().as_secs_f64() * 1e3;
        usage.model_calls += spent.calls;
        usage.prompt_tokens += spent.prompt_tokens;
        usage.generated_tokens += spent.generated_tokens;
        let (reply_text, reply) = match answer {
            Ok(json) => (json.reply.text.clone(), read_reply(&json.value)),
            Err(error) if error.kind.is_unavailable() => return Err(DirectError::Unavailable(error)),
            Err(error) => match &error.kind {
                ChatErrorKind::InvalidJson { error, reply } => (reply.clone(), Err(error.clone())),
                kind => (String::new(), Err(kind.to_string())),
            },
        };
        let step = match reply {
            Ok(DirectReply::Done) => {
                done_reply = Some(clip(&reply_text, 500));
                break DirectEnd::Done;
            }
            Err(error) => {
                feedback = unreadable_feedback(&error);
                DirectStep {
                    command: String::new(),
                    executed: false,
                    sent: false,
                    reason: Some(format!("the reply could not be read: {error}")),
                    reply: clip(&reply_text, 500),
                    observation: observation.text.clone(),
                }
            }
            Ok(DirectReply::Act(command)) if is_virtualhome(benchmark) && command.starts_with('[') => {
                let reason = "only class-level actions of the listed forms are accepted, without instance numbers";
                feedback = failure_feedback(&command, reason);
                DirectStep {
                    command,
                    executed: false,
                    sent: false,
                    reason: Some(reason.to_string()),
                    reply: clip(&reply_text, 500),
                    observation: observation.text.clone(),
                }
            }
            Ok(DirectReply::Act(command)) => {
                let result = env.step(&command);
                match result.event {
                    Event::Executed => {
                        feedback = SUCCESS_FEEDBACK.to_string();
                        observation = result.observation;
                        DirectStep {
                            command,
                            executed: true,
                            sent: true,
                            reason: None,
                            reply: clip(&reply_text, 500),
                            observation: observation.text.clone(),
                        }
                    }
                    Event::NotExecuted { reason } => {
                        // The view does not change: the previous observation stays the current one.
                        feedback = failure_feedback(&command, &reason);
                        DirectStep {
                            command,
                            executed: false,
                            sent: true,
                            reason: Some(reason),
                            reply: clip(&reply_text, 500),
                            observation: observation.text.clone(),
                        }
                    }
                }
            }
        };
        failures_in_a_row = if step.executed { 0 } else { failures_in_a_row + 1 };
        let shown = if step.command.is_empty() { "(unreadable reply)" } else { step.command.as_str() };
        let outcome = if step.executed { "success" } else { "failed (invalid or unreachable)" };
        history.push(format!("{}. {shown} -> {outcome}", steps.len() + 1));
        steps.push(step);
    };
    let success = env.goal_reached();
    let attribution = match (success, end) {
        (true, _) => None,
        (false, DirectEnd::Failures) => Some(Attribution::Grounding),
        (false, _) => Some(Attribution::Goal),
    };
    Ok(DirectEpisode {
        success,
        end,
        steps,
        attribution,
        unmet_goals: env.unmet_goals(),
        engine_script: env.engine_script(),
        usage,
        done_reply,
        millis: start.elapsed().as_secs_f64() * 1e3,
        model_millis,
    })
}
