//! What comes back: the reply text (and any reasoning the server split off), why it stopped,
//! and the usage counts, read from a `/v1/chat/completions` body.

use std::time::Duration;

use serde_json::Value;

use crate::error::ChatErrorKind;
use crate::request::JsonMode;

/// Tokens, images and requests of one call, or summed over many.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Usage {
    /// HTTP requests sent (retries included) or local generations run.
    pub requests: u64,
    /// Prompt tokens, as the server counts them (0 where it reports none).
    pub prompt_tokens: u64,
    /// Generated tokens, as the server counts them (0 where it reports none).
    pub completion_tokens: u64,
    /// Thinking tokens, where the server reports them
    /// (`usage.completion_tokens_details.reasoning_tokens`).
    pub reasoning_tokens: Option<u64>,
    /// Image parts sent in the requests' messages.
    pub images: u64,
}

impl Usage {
    /// Adds `other`'s counts to these; `reasoning_tokens` stays `None` only where both are.
    pub fn add(&mut self, other: &Usage) {
        self.requests += other.requests;
        self.prompt_tokens += other.prompt_tokens;
        self.completion_tokens += other.completion_tokens;
        self.reasoning_tokens = match (self.reasoning_tokens, other.reasoning_tokens) {
            (None, None) => None,
            (a, b) => Some(a.unwrap_or(0) + b.unwrap_or(0)),
        };
        self.images += other.images;
    }
}

/// One reply of a chat model.
#[derive(Debug, Clone, PartialEq)]
pub struct ChatReply {
    /// The reply's content (text parts joined; empty where the server sent none).
    pub text: String,
    /// Thinking the server returned apart from the text (`reasoning_content` or `reasoning`).
    pub reasoning: Option<String>,
    /// Why generation stopped, as the server says it (`stop`, `length`, ...).
    pub finish_reason: Option<String>,
    /// Tokens, images and requests this reply cost (retries included).
    pub usage: Usage,
    /// How JSON was asked for (`None` when no schema was set).
    pub json_mode: Option<JsonMode>,
    /// HTTP attempts this reply took (1 when nothing was retried).
    pub attempts: u32,
    /// Time spent waiting between attempts (backoff or `Retry-After`).
    pub waited: Duration,
    /// Answered from a reply file ([`crate::CachedChat`]) without running the model (then
    /// `attempts` is 0 and `usage` is what the model spent when it first answered).
    pub cached: bool,
}

impl ChatReply {
    /// A reply made on this side (scripted models in tests, a local model): `text` in one
    /// attempt, finished with `stop`, no separate reasoning, no JSON mode.
    pub fn local(text: impl Into<String>, usage: Usage) -> ChatReply {
        ChatReply {
            text: text.into(),
            reasoning: None,
            finish_reason: Some("stop".into()),
            usage,
            json_mode: None,
            attempts: 1,
            waited: Duration::ZERO,
            cached: false,
        }
    }
}

/// Reads a chat completion body.
pub fn parse_reply(body: &[u8]) -> Result<ChatReply, ChatErrorKind> {
    let malformed = |why: String| ChatErrorKind::MalformedReply(why);
    let value: Value = serde_json::from_slice(body).map_err(|e| malformed(format!("not JSON: {e}")))?;
    if let Some(error) = value.get("error") {
        return Err(malformed(format!("the server reports an error: {error}")));
    }
    let choice = value.get("choices").and_then(|c| c.get(0)).ok_or_else(|| malformed("no `choices[0]`".into()))?;
    let message = choice.get("message").filter(|m| m.is_object()).ok_or_else(|| malformed("no `choices[0].message` object".into()))?;
    let text = match message.get("content") {
        Some(Value::String(text)) => text.clone(),
        None | Some(Value::Null) => String::new(),
        // Some servers echo the parts form back.
        Some(Value::Array(parts)) => parts.iter().filter_map(|p| p.get("text").and_then(Value::as_str)).collect(),
        Some(other) => return Err(malformed(format!("`choices[0].message.content` is {other}"))),
    };
    let reasoning = ["reasoning_content", "reasoning"]
        .iter()
        .find_map(|key| message.get(*key).and_then(Value::as_str))
        .filter(|r| !r.is_empty())
        .map(str::to_string);
    let finish_reason = choice.get("finish_reason").and_then(Value::as_str).map(str::to_string);
    let usage = value.get("usage");
    let count = |key: &str| usage.and_then(|u| u.get(key)).and_then(Value::as_u64);
    let reasoning_tokens = usage
        .and_then(|u| u.get("completion_tokens_details"))
        .and_then(|d| d.get("reasoning_tokens"))
        .and_then(Value::as_u64)
        .or_else(|| count("reasoning_tokens"));
    Ok(ChatReply {
        text,
        reasoning,
        finish_reason,
        usage: Usage {
            requests: 0,
            prompt_tokens: count("prompt_tokens").unwrap_or(0),
            completion_tokens: count("completion_tokens").unwrap_or(0),
            reasoning_tokens,
            images: 0,
        },
        json_mode: None,
        attempts: 0,
        waited: Duration::ZERO,
        cached: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_give_text_reasoning_and_usage() {
        let body = br#"{"choices":[{"index":0,"message":{"role":"assistant","content":"{\"skill\":\"Done\"}","reasoning_content":"The mug is found."},"finish_reason":"stop"}],
            "usage":{"prompt_tokens":812,"completion_tokens":40,"completion_tokens_details":{"reasoning_tokens":31}}}"#;
        let reply = parse_reply(body).unwrap();
        assert_eq!(reply.text, r#"{"skill":"Done"}"#);
        assert_eq!(reply.reasoning.as_deref(), Some("The mug is found."));
        assert_eq!(reply.finish_reason.as_deref(), Some("stop"));
        assert_eq!((reply.usage.prompt_tokens, reply.usage.completion_tokens, reply.usage.reasoning_tokens), (812, 40, Some(31)));
    }

    #[test]
    fn bodies_that_are_not_chat_completions_are_typed_errors() {
        for body in [
            &b"{\"choices\": [{\"message\": {\"content\": \"x\"}"[..],
            b"<html>",
            b"{}",
            b"{\"choices\":[{\"text\":\"x\"}]}",
            b"{\"error\":{\"message\":\"overloaded\"}}",
        ] {
            assert!(matches!(parse_reply(body), Err(ChatErrorKind::MalformedReply(_))), "{}", String::from_utf8_lossy(body));
        }
        assert_eq!(parse_reply(br#"{"choices":[{"message":{"content":null}}]}"#).unwrap().text, "");
    }

    #[test]
    fn usage_sums() {
        let mut total = Usage { requests: 1, prompt_tokens: 10, completion_tokens: 2, reasoning_tokens: None, images: 1 };
        total.add(&Usage { requests: 2, prompt_tokens: 5, completion_tokens: 1, reasoning_tokens: Some(4), images: 0 });
        assert_eq!(total, Usage { requests: 3, prompt_tokens: 15, completion_tokens: 3, reasoning_tokens: Some(4), images: 1 });
    }
}
