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
    /// The configured API-key variable is not set (or not Unicode).
    #[error("the API key variable `{0}` is not set")]
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
    #[error("HTTP status {status}: {body}")]
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

    /// Errors of the run rather than of the model's answer: the model could not be asked
    /// (transient errors that outlived the retries, a bad URL, a missing key, a server that
    /// refuses the credentials or does not serve the model: 401, 403, 404). A harness stops
    /// on these instead of counting them against the model.
    pub fn is_unavailable(&self) -> bool {
        self.is_transient()
            || matches!(self, ChatErrorKind::BadUrl(_) | ChatErrorKind::MissingApiKey(_))
            || matches!(self, ChatErrorKind::Status { status: 401 | 403 | 404, .. })
    }
}
