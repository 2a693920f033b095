//! f_φ over a chat model (paper Eq. 2 and its Phase I prompt figure): any
//! [`vlm_client::ChatModel`], a served (vision-)language model or a local one.
//!
//! The request: one system message (the role, and the reply's contract), one user message in
//! the prompt figure's sections (Task, Objects to find and locate, Current belief, Previous
//! actions, Valid skills right now, Feedback, Observation) with the observation's picture
//! where the environment renders one. Greedy decoding, at most 512 output tokens (Appendix
//! Table 6). The reply is JSON under [`reply_schema`]: `facts` (proposed, `pred(a, b)`),
//! `action` (one of the valid skills, an enum) and `done`.

use serde_json::{Value, json};
use vlm_client::{ChatError, ChatErrorKind, ChatModel, ChatRequest, Image, JsonReply, Message, Sampling, chat_json};

use crate::evidence::Fact;
use crate::phase1::{Policy, PolicyError, PolicyInput, PolicyReply, PolicyUsage, RunError, Skill};

/// Output tokens per reply (Appendix Table 6).
pub const MAX_REPLY_TOKENS: u32 = 512;

/// A chat model as the Phase I policy.
pub struct ChatPolicy {
    model: Box<dyn ChatModel>,
    name: String,
    usage: PolicyUsage,
    /// The last request's prompt text, for traces.
    pub last_prompt: String,
}

impl std::fmt::Debug for ChatPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChatPolicy").field("name", &self.name).field("usage", &self.usage).finish_non_exhaustive()
    }
}

impl ChatPolicy {
    /// `model` as the policy; `name` is what [`Policy::name`] returns for it (`openai:URL`,
    /// `local:NAME`, ...).
    pub fn new(model: Box<dyn ChatModel>, name: &str) -> ChatPolicy {
        ChatPolicy { model, name: name.to_string(), usage: PolicyUsage::default(), last_prompt: String::new() }
    }
}

/// The reply's JSON schema: `action` is one of `skills`; at most 6 facts of at most 80
/// characters each (a small model under the schema otherwise spells one fact until the token
/// limit cuts the JSON off).
pub fn reply_schema(skills: &[Skill]) -> Value {
    let names: Vec<String> = skills.iter().map(Skill::to_string).collect();
    json!({
        "type": "object",
        "properties": {
            "facts": { "type": "array", "items": { "type": "string", "maxLength": 80 }, "maxItems": 6 },
            "action": { "enum": names },
            "done": { "type": "boolean" }
        },
        "required": ["facts", "action", "done"],
        "additionalProperties": false
    })
}

/// The system message: the paper's Phase I preamble, in the benchmark's words.
pub fn system_prompt(benchmark: &str) -> String {
    let world = if benchmark.starts_with("virtualhome") { "VirtualHome, a household simulator" } else { "ALFWorld, a household simulator" };
    format!(
        "You are a vision-language agent in {world}.\n\
         You see what the agent perceives now. Your only job in this phase is to find the listed objects and determine where each one is.\n\
         Do not plan or execute the household chore. Reply with JSON only."
    )
}

/// What one [`chat_json`] cost, counted one way for Phase I and the direct policy
/// (`DirectUsage`), so that their figures compare: every request (a repair turn is a second
/// one, a reply that could not be read counts too) and the tokens the model read and wrote in
/// all of them, as its usage says.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Spent {
    pub calls: u64,
    pub prompt_tokens: u64,
    pub generated_tokens: u64,
}

/// [`chat_json`], and what it cost.
pub(crate) fn chat_json_counted(model: &mut dyn ChatModel, request: &ChatRequest) -> (Result<JsonReply, ChatError>, Spent) {
    let before = model.usage();
    let answer = chat_json(model, request);
    let after = model.usage();
    let calls = match &answer {
        Ok(reply) => 1 + u64::from(reply.repaired),
        Err(e) if matches!(e.kind, ChatErrorKind::InvalidJson { .. }) => 2,
        Err(_) => 1,
    };
    let spent = Spent {
        calls,
        prompt_tokens: after.prompt_tokens.saturating_sub(before.prompt_tokens),
        generated_tokens: after.completion_tokens.saturating_sub(before.completion_tokens),
    };
    (answer, spent)
}

/// The example fact Phase I's VirtualHome prompt shows: ids no scene of EAI's or the
/// rearrangement set's holds (theirs stay below 2,100).
pub const VIRTUALHOME_EXAMPLE: &str = "INSIDE(plate (9001), cabinet (9002))";

/// The user message's text (the prompt figure's sections).
pub fn user_prompt(input: &PolicyInput<'_>) -> String {
    let list = |items: &[String], empty: &str| if items.is_empty() { empty.to_string() } else { items.join("\n") };
    let skills: Vec<String> = input.skills.list.iter().map(|s| format!("- {s}")).collect();
    // A fact in the benchmark's own vocabulary, as its perceiver reads it back. VirtualHome's
    // names no node of any scene (a real id, such as 1001, is a goal's plate in some EAI tasks).
    let example = if input.benchmark.starts_with("virtualhome") { VIRTUALHOME_EXAMPLE } else { "inReceptacle(mug 2, countertop 1)" };
    format!(
        "Task:\n{task}\nFind each listed object and determine where it is.\n\n\
         Objects to find and locate:\n{objects}\n\n\
         Current belief:\n{belief}\n\n\
         Previous actions:\n{history}\n\n\
         Valid skills right now:\n{skills}\n\n\
         Feedback:\n{feedback}\n\n\
         Observation:\n{observation}\n\n\
         Return visible predicates in \"facts\" (each as predicate(argument, argument), e.g. {example}), \
         exactly one valid skill in \"action\", and \"done\": true only after every listed object has a grounded placement.",
        task = input.task,
        objects = input.objects.join(", "),
        belief = list(&input.belief, "nothing yet"),
        history = list(&input.history, "none"),
        skills = skills.join("\n"),
        feedback = input.feedback,
        observation = input.observation.text.trim(),
    )
}

impl Policy for ChatPolicy {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn choose(&mut self, input: &PolicyInput<'_>) -> Result<PolicyReply, PolicyError> {
        let text = user_prompt(input);
        let mut user = Message::user(text.clone());
        self.usage.observations += 1;
        if let Some(image) = &input.observation.image {
            // A picture the API cannot carry is the run's failure: no model could read it.
            let image =
                Image::from_bytes(image.bytes.clone()).map_err(|e| RunError(format!("the observation's picture cannot be sent: {e}")))?;
            user = user.with_image(image);
            self.usage.images += 1;
        }
        let request = ChatRequest::new(vec![Message::system(system_prompt(input.benchmark)), user])
            .with_sampling(Sampling::greedy(MAX_REPLY_TOKENS))
            // Thinking off (the paper's Phase I setting; a template without it ignores this).
            .with_thinking(false)
            .with_json_schema(reply_schema(&input.skills.list));
        self.last_prompt = text;
        let (answer, spent) = chat_json_counted(self.model.as_mut(), &request);
        self.usage.calls += spent.calls;
        self.usage.prompt_tokens += spent.prompt_tokens;
        self.usage.generated_tokens += spent.generated_tokens;
        let reply = answer.map_err(|e| {
            if e.kind.is_unavailable() {
                PolicyError::Run(RunError(format!("the chat model is unavailable: {e}")))
            } else {
                PolicyError::Unreadable(e.to_string())
            }
        })?;
        self.usage.cached_calls += u64::from(reply.reply.cached);
        read_reply(&reply.value).map_err(PolicyError::Unreadable)
    }

    fn usage(&self) -> PolicyUsage {
        self.usage
    }
}

/// The policy's reply out of the JSON value (already checked against [`reply_schema`]);
/// unreadable facts are dropped (they could never be admitted anyway).
pub fn read_reply(value: &Value) -> Result<PolicyReply, String> {
    let action = value.get("action").and_then(Value::as_str).ok_or("the reply has no \"action\"")?;
    let skill = Skill::parse(action).ok_or_else(|| format!("\"{action}\" is not a skill"))?;
    let proposed = value
        .get("facts")
        .and_then(Value::as_array)
        .map(|facts| facts.iter().filter_map(Value::as_str).filter_map(Fact::parse).collect())
        .unwrap_or_default();
    let done = value.get("done").and_then(Value::as_bool).unwrap_or(false);
    Ok(PolicyReply { proposed, skill, done })
}
