//! The crate's error type: what failed ([`ChatErrorKind`]), where, after how many attempts
//! and how long.

use std::time::Duration;

/// A chat request that failed, after `attempts` tries over `elapsed` (both zero when the
/// request was refused before anything was sent).
#[derive(Debug, thiserror::Error)]
#[error("{url}: {kind} (after {attempts} attempt(s), {:.1} s)", elapsed.as_secs_f64())]
pub struct ChatError {
    /// What failed.
    pub kind: ChatErrorKind,
    /// The endpoint (or `local` for an in-process model).
    pub url: String,
    /// Attempts made, retries included (0 when the request was refused before sending).
    pub attempts: u32,
    /// Time from the start of the first attempt to the failure, waits between attempts included.
    pub elapsed: Duration,
}

/// Why a chat request failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChatErrorKind {
    /// The base URL is not `http(s)://host[:port][/path]`.
    #[error("bad URL: {0}")]
    BadUrl(String),
    /// The configured API-key variable is not set, empty or not Unicode.
    #[error("the API key variable `{0}` is not set (or empty)")]
    MissingApiKey(String),
    /// An image that is neither PNG nor JPEG or does not decode, or a message the API cannot carry.
    #[error("bad input: {0}")]
    BadInput(String),
    /// The host name did not resolve, or the TCP/TLS connection could not be made.
    #[error("cannot connect: {0}")]
    Connect(String),
    /// One attempt (DNS, connect, request and reply) ran past its deadline.
    #[error("no complete reply within {0:?}")]
    Timeout(Duration),
    /// The connection broke mid-request or mid-reply (reset, truncated body).
    #[error("connection failed: {0}")]
    Io(String),
    /// The server answered with a non-2xx status; `retry_after` is its `Retry-After`.
    // The wait a `Retry-After` asked for is said: a request given up at once, since the wait
    // was past what a retry waits, says why.
    #[error("HTTP status {status}{}: {body}", retry_after.map(|wait| format!(" (Retry-After: {} s)", wait.as_secs())).unwrap_or_default())]
    Status {
        /// The HTTP status code.
        status: u16,
        /// The body's first 500 characters (invalid UTF-8 replaced).
        body: String,
        /// The wait the `Retry-After` header asks for, where it is there and readable.
        retry_after: Option<Duration>,
    },
    /// The body is not the JSON of a chat completion.
    #[error("malformed reply: {0}")]
    MalformedReply(String),
    /// The reply held no JSON value satisfying the schema, even after the repair turn.
    #[error("the reply is not the JSON asked for: {error}; reply: {reply}")]
    InvalidJson {
        /// What the last reply got wrong, as [`crate::read_json`] says it.
        error: String,
        /// The last reply's text, cut to its first 500 characters.
        reply: String,
    },
    /// An in-process model failed.
    #[error("model: {0}")]
    Model(String),
}

impl ChatErrorKind {
    /// Errors worth another try: the server may recover (overload, restart, a dropped
    /// connection, a timeout).
    pub fn is_transient(&self) -> bool {
        match self {
            ChatErrorKind::Connect(_) | ChatErrorKind::Timeout(_) | ChatErrorKind::Io(_) => true,
            ChatErrorKind::Status { status, .. } => *status >= 500 || *status == 429 || *status == 408,
            _ => false,
        }
    }

    /// Errors of the run rather than of the model's answer: the model could not be asked, or
    /// what came back is no model's answer. Transient errors that outlived the retries, a bad
    /// URL, a missing key; a body that is not a chat completion (an HTML error page, an
    /// `error` object, no `choices`: [`ChatErrorKind::MalformedReply`]); and any status but a
    /// 4xx that says the request is longer than the model's context ([`context_overflow`]): a
    /// server that refuses the credentials, does not serve the model, rejects the request's
    /// form (a field it does not know) or redirects it elsewhere (a 3xx, not followed) would
    /// otherwise pass for a model that loses every task. A harness stops on these instead of
    /// counting them against the model.
    pub fn is_unavailable(&self) -> bool {
        self.is_transient()
            || matches!(self, ChatErrorKind::BadUrl(_) | ChatErrorKind::MissingApiKey(_) | ChatErrorKind::MalformedReply(_))
            || matches!(self, ChatErrorKind::Status { status, body, .. } if !context_overflow(*status, body))
    }
}

/// Whether a server's 4xx (`status`, the start of its `body`) says the request does not fit
/// the model's context: a request this model cannot take, an outcome of the task (as a local
/// model's context overflow is), not of the run. 413 (the body too large) always; a 400 or 422
/// in the words vLLM, OpenAI, llama.cpp's server and Ollama use for it.
pub fn context_overflow(status: u16, body: &str) -> bool {
    const SAID: [&str; 7] = [
        "context length",
        "context_length",
        "context window",
        "context size",
        "maximum context",
        "too many tokens",
        "exceeds the available context",
    ];
    let body = body.to_lowercase();
    status == 413 || (matches!(status, 400 | 422) && SAID.iter().any(|said| body.contains(said)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the run stops on, and what is the model's: a status (3xx, 4xx) is the run's unless
    /// it says the request is past the model's context, and a body that is no chat completion
    /// is the run's.
    #[test]
    fn only_the_models_answers_are_counted_against_it() {
        let status = |status, body: &str| ChatErrorKind::Status { status, body: body.into(), retry_after: None };
        for run in [
            status(400, "Unrecognized request argument supplied: allowed_token_ids"),
            status(302, "redirected to https://elsewhere.test/v1/chat/completions"),
            status(401, ""),
            status(422, "unknown field `chat_template_kwargs`"),
            status(503, ""),
            ChatErrorKind::MalformedReply("the server reports an error: overloaded".into()),
            ChatErrorKind::Timeout(Duration::from_secs(1)),
        ] {
            assert!(run.is_unavailable(), "{run}");
        }
        for answer in [
            status(400, "This model's maximum context length is 8192 tokens"),
            status(413, ""),
            ChatErrorKind::InvalidJson { error: "not an object".into(), reply: "hello".into() },
        ] {
            assert!(!answer.is_unavailable(), "{answer}");
        }
    }
}
