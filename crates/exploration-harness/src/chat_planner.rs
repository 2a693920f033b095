//! Phase II by a chat model without the constraint: the paper's *unconstrained thinking*
//! conditions (a served model with its thinking mode on and a 32K-token budget, decoded at
//! temperature zero as in the main paper's tables or with the model's recommended sampling over
//! three seeds as in its appendix; Table 6 of the paper) and unconstrained greedy decoding
//! through a chat endpoint. The model
//! reads the same planning prompt as the constrained conditions (`mcts::prompt`, from the same
//! grounded state ŝ0) and writes the plan as text; nothing checks its tokens.
//!
//! **Reading the plan.** The thinking is dropped (the server's separate `reasoning`, or the
//! text up to the last `</think>`). Then line by line, blank lines skipped: the end marker
//! `DONE` ends the plan; a line is spelled as the benchmark spells actions (leading list
//! markers such as `1.` or `-` are taken off) and executed in the transition model as
//! `validate_text` does — the first action with that text applicable in the current state. The
//! first line that names no applicable action ends the plan there: its valid prefix is the
//! plan, and the record says which line failed. So a plan is what the environment would run
//! open-loop until its first unexecutable step.

use serde_json::json;
use transition_model::State;
use vlm_client::{ChatModel, ChatRequest, Message, Sampling};

use crate::episode::{Grounded, PhaseTwo};
use crate::phase1::RunError;

/// How the chat model is asked.
#[derive(Debug, Clone, PartialEq)]
pub struct ChatPlannerConfig {
    /// Ask for the model's thinking mode (`chat_template_kwargs.enable_thinking`).
    pub thinking: bool,
    /// Decoding settings: temperature, top-p, top-k, the output-token limit, the seed.
    pub sampling: Sampling,
    /// What the planning prompt shows (the facts relevant to the goal by default, or all).
    pub prompt: mcts::prompt::PromptOptions,
}

impl ChatPlannerConfig {
    /// Greedy, thinking off, at most 512 tokens (the paper's greedy conditions, Table 6).
    pub fn greedy() -> ChatPlannerConfig {
        ChatPlannerConfig { thinking: false, sampling: Sampling::greedy(512), prompt: mcts::prompt::PromptOptions::default() }
    }

    /// Thinking on, temperature zero, at most 32,768 tokens: the main paper's thinking rows
    /// ("Qwen thinking, main paper" in its table of decoding settings).
    pub fn thinking() -> ChatPlannerConfig {
        ChatPlannerConfig { thinking: true, sampling: Sampling::greedy(32_768), prompt: mcts::prompt::PromptOptions::default() }
    }

    /// Thinking on with the recommended sampling the paper's appendix uses for it (temperature
    /// 1.0, top-p 0.95, top-k 20, at most 32,768 tokens: "Qwen thinking, supplementary"), `seed`
    /// one of its three runs (0, 42, 1738).
    pub fn thinking_recommended(seed: u64) -> ChatPlannerConfig {
        let sampling = Sampling { temperature: Some(1.0), top_p: Some(0.95), top_k: Some(20), max_tokens: Some(32_768), seed: Some(seed) };
        ChatPlannerConfig { thinking: true, sampling, prompt: mcts::prompt::PromptOptions::default() }
    }
}

/// The plan text without the thinking: the text after the last `</think>`, if any.
pub fn strip_thinking(text: &str) -> &str {
    text.rfind("</think>").map_or(text, |at| &text[at + "</think>".len()..])
}

/// A line as an action text: trimmed, list markers (`1.`, `2)`, `-`, `*`) taken off.
fn action_text(line: &str) -> &str {
    let line = line.trim();
    let unnumbered = line.trim_start_matches(|c: char| c.is_ascii_digit());
    let line = if unnumbered.len() < line.len() {
        unnumbered.strip_prefix('.').or_else(|| unnumbered.strip_prefix(')')).map_or(line, str::trim_start)
    } else {
        line
    };
    line.strip_prefix("- ").or_else(|| line.strip_prefix("* ")).unwrap_or(line).trim()
}

/// What reading a plan text found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadPlan {
    /// The applicable prefix: one action per line read, in order, each applicable after those
    /// before it.
    pub actions: Vec<grounding::ActionId>,
    /// The first line that names no applicable action (1-based line of the plan text) and the
    /// line.
    pub invalid: Option<(usize, String)>,
}

/// Reads `text` (thinking already dropped) as a plan from the grounded initial state.
pub fn read_plan(grounded: &Grounded, text: &str) -> ReadPlan {
    let model = &grounded.model;
    let mut state: State = model.initial_state();
    let mut actions = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let action = action_text(line);
        if action.is_empty() {
            continue;
        }
        if action.eq_ignore_ascii_case("done") {
            break;
        }
        let Some(&chosen) = grounded.spelling.parse(action).iter().find(|&&a| model.is_applicable(&state, a)) else {
            return ReadPlan { actions, invalid: Some((number + 1, line.trim().to_string())) };
        };
        state = model.apply(&state, chosen);
        actions.push(chosen);
    }
    ReadPlan { actions, invalid: None }
}

/// Phase II by `chat`: the planning prompt of ŝ0, one reply, the plan read from it.
/// A model that cannot be asked ([`vlm_client::ChatErrorKind::is_unavailable`]) is the run's
/// failure; any other error (a prompt past the model's context, say) is this planner's: no
/// plan, with the error as the reason.
pub fn plan_by_chat(chat: &mut dyn ChatModel, grounded: &Grounded, config: &ChatPlannerConfig) -> Result<PhaseTwo, RunError> {
    let initial = grounded.model.initial_state();
    let prompt = mcts::prompt::planning_prompt(&grounded.model, &grounded.spelling, &initial, &config.prompt);
    let request = ChatRequest::new(vec![Message::system(prompt.system), Message::user(prompt.user)])
        .with_sampling(config.sampling.clone())
        .with_thinking(config.thinking);
    let reply = match chat.chat(&request) {
        Ok(reply) => reply,
        Err(e) if e.kind.is_unavailable() => return Err(RunError(format!("the chat planner is unavailable: {e}"))),
        Err(e) => {
            // What is left once the run's errors are out: a status that says the request is
            // past the model's context, or another failure of the request itself (an
            // in-process model's, a request it cannot take).
            let stop = if matches!(e.kind, vlm_client::ChatErrorKind::Status { .. }) { "context-overflow" } else { "request-failed" };
            return Ok(PhaseTwo {
                model_calls: 1,
                detail: json!({"planner": "chat", "thinking": config.thinking, "stop": stop, "error": e.to_string()}),
                no_plan: Some(format!("{stop}: the chat planner's request failed: {e}")),
                ..PhaseTwo::default()
            });
        }
    };
    let plan_text = strip_thinking(&reply.text);
    let read = read_plan(grounded, plan_text);
    let reasoning_chars = reply.reasoning.as_ref().map_or(0, String::len) + (reply.text.len() - plan_text.len());
    Ok(PhaseTwo {
        model_calls: 1,
        generated_tokens: reply.usage.completion_tokens,
        detail: json!({
            "planner": "chat", "thinking": config.thinking, "temperature": config.sampling.temperature,
            "top_p": config.sampling.top_p, "top_k": config.sampling.top_k, "seed": config.sampling.seed,
            "valid": read.invalid.is_none(),
            "invalid": read.invalid.as_ref().map(|(line, text)| format!("line {line}: {text:?}")),
            "plan_text": plan_text.trim(), "reasoning_chars": reasoning_chars, "finish_reason": reply.finish_reason,
        }),
        invalid_step: read.invalid.as_ref().map(|(_, text)| text.clone()),
        actions: read.actions,
        search_tree: None,
        no_plan: None,
    })
}
