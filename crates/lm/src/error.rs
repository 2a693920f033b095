//! The crate's one error type, and the typed HTTP error of the OpenAI-compatible backend.

use std::path::PathBuf;
use std::time::Duration;

/// Everything that can go wrong when loading or running a language model.
#[derive(Debug, thiserror::Error)]
pub enum LmError {
    /// A model or tokenizer file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a readable GGUF file (bad magic, truncated header, bad lengths).
    #[error("not a readable GGUF file: {0}")]
    MalformedGguf(String),
    /// A metadata key the model needs is absent.
    #[error("GGUF metadata `{key}` is missing")]
    MissingMetadata {
        /// The key, e.g. `llama.block_count`.
        key: String,
    },
    /// A metadata key has a value of the wrong type or out of range.
    #[error("GGUF metadata `{key}`: expected {expected}, found {found}")]
    BadMetadata {
        /// The key, with `[i]` for an array item.
        key: String,
        /// What the key should hold.
        expected: &'static str,
        /// What it holds, described (long strings cut).
        found: String,
    },
    /// A weight tensor the architecture needs is absent.
    #[error("GGUF tensor `{name}` is missing")]
    MissingTensor {
        /// The tensor's GGUF name, e.g. `blk.0.attn_q.weight`.
        name: String,
    },
    /// A weight tensor has the wrong shape for the configuration in the metadata.
    #[error("GGUF tensor `{name}` has shape {found:?}, the metadata implies {expected:?}")]
    BadTensorShape {
        /// The tensor's GGUF name.
        name: String,
        /// The shape the metadata implies.
        expected: Vec<usize>,
        /// The shape in the file.
        found: Vec<usize>,
    },
    /// `general.architecture` names a model family this crate does not run.
    #[error("unsupported architecture `{0}` in `general.architecture` (supported: llama, qwen2, qwen3)")]
    UnsupportedArchitecture(String),
    /// The tokenizer described by the metadata or `tokenizer.json` is not one this crate builds
    /// (`key` names the field).
    #[error("unsupported tokenizer: `{key}` = `{value}` ({hint})")]
    UnsupportedTokenizer {
        /// The field, e.g. `tokenizer.ggml.pre` or `model.type`.
        key: &'static str,
        /// Its value (a `pre_tokenizer` section cut to 300 characters).
        value: String,
        /// What is supported instead.
        hint: &'static str,
    },
    /// A tokenizer file (`tokenizer.json`, `tokenizer_config.json`) that is not JSON, or not JSON
    /// of the expected shape (serde's message, at the place it stopped).
    #[error("{}:{line}:{column}: {message}", path.display())]
    MalformedJson {
        /// The file (its bare name when the text was given without one).
        path: PathBuf,
        /// Where serde stopped: the line, from 1.
        line: usize,
        /// Where serde stopped: the column, from 1.
        column: usize,
        /// serde's message, without its position.
        message: String,
    },
    /// A tokenizer file whose content is inconsistent: a special token it names is not in the
    /// vocabulary, a token is not a byte-level piece, no end-of-sequence token can be found.
    #[error("{}: {message}", path.display())]
    BadTokenizerFile {
        /// The file at fault (`tokenizer.json` or `tokenizer_config.json`).
        path: PathBuf,
        /// What is inconsistent.
        message: String,
    },
    /// The tokenizer library rejected the vocabulary or an input.
    #[error("tokenizer: {0}")]
    Tokenizer(String),
    /// The model file has no `tokenizer.chat_template`.
    #[error("the model has no chat template (`tokenizer.chat_template` is missing)")]
    NoChatTemplate,
    /// The chat template failed to compile or render.
    #[error("chat template: {0}")]
    ChatTemplate(String),
    /// A token id outside the vocabulary.
    #[error("token id {id} is outside the vocabulary of {size} tokens")]
    TokenOutOfRange {
        /// The id given.
        id: u32,
        /// Tokens in the vocabulary: valid ids are `0..size`.
        size: usize,
    },
    /// A next-token distribution needs at least one token of context.
    #[error("empty token sequence: a next-token distribution needs at least one token")]
    EmptySequence,
    /// `next_logprobs_among` with no allowed token.
    #[error("the set of allowed tokens is empty")]
    NoAllowedTokens,
    /// The sequence is longer than the model's context.
    #[error("a sequence of {len} tokens exceeds the context length of {max}")]
    ContextOverflow {
        /// Tokens in the sequence.
        len: usize,
        /// The model's context length in tokens.
        max: usize,
    },
    /// An error inside candle's tensor code.
    #[error("candle: {}", candle_message(.0))]
    Candle(#[from] candle_core::Error),
    /// The model server could not be reached or gave no usable answer.
    #[error(transparent)]
    Http(#[from] HttpError),
}

/// candle's message without the backtrace it attaches when `RUST_BACKTRACE` is set.
pub(crate) fn candle_message(error: &candle_core::Error) -> String {
    match error {
        candle_core::Error::WithBacktrace { inner, .. } => candle_message(inner),
        candle_core::Error::Context { inner, context } => format!("{context}: {}", candle_message(inner)),
        other => other.to_string(),
    }
}

/// A request to a model server that failed, after `attempts` tries over `elapsed`.
#[derive(Debug, thiserror::Error)]
#[error("{url}: {kind} (after {attempts} attempt(s), {:.1} s)", elapsed.as_secs_f64())]
pub struct HttpError {
    /// What failed.
    pub kind: HttpErrorKind,
    /// The endpoint asked (the base URL, for a URL refused before sending).
    pub url: String,
    /// Attempts made, retries included (0 when the request was refused before sending).
    pub attempts: u32,
    /// Time from the start of the first attempt to the failure, waits between attempts included.
    pub elapsed: Duration,
}

/// Why a model server request failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HttpErrorKind {
    /// The URL is not `http(s)://host[:port][/path]`.
    #[error("unsupported URL: {0}")]
    BadUrl(String),
    /// The host did not resolve, or the TCP or TLS connection could not be made.
    #[error("cannot connect: {0}")]
    Connect(String),
    /// One attempt (DNS, connect, request and answer) ran past the configured timeout.
    #[error("timed out after {0:?}")]
    Timeout(Duration),
    /// The connection broke mid-request or mid-response (reset, truncated body, bad HTTP).
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
    /// The body is not JSON, or not the JSON of a completions response.
    #[error("malformed JSON response: {0}")]
    MalformedJson(String),
}

impl HttpErrorKind {
    /// Errors worth another try: the server may recover (overload, restart, a dropped connection).
    pub fn is_transient(&self) -> bool {
        match self {
            HttpErrorKind::Connect(_) | HttpErrorKind::Timeout(_) | HttpErrorKind::Io(_) => true,
            HttpErrorKind::Status { status, .. } => *status >= 500 || *status == 429 || *status == 408,
            HttpErrorKind::BadUrl(_) | HttpErrorKind::MalformedJson(_) => false,
        }
    }

    /// A server that refused this request because it does not fit the model's context (a 4xx
    /// that says so: `vlm_client::context_overflow`), as a local model's context overflow: the
    /// request's failure, which a harness records rather than stopping on. Any other 4xx (the
    /// credentials, the model, a field the server does not know) is the run's, as
    /// `vlm_client::ChatErrorKind::is_unavailable` has it.
    pub fn is_refusal(&self) -> bool {
        // Only the server backend (feature `openai`, over vlm-client) makes these errors.
        #[cfg(feature = "openai")]
        return matches!(self, HttpErrorKind::Status { status, body, .. } if vlm_client::context_overflow(*status, body));
        #[cfg(not(feature = "openai"))]
        false
    }
}

#[cfg(all(test, feature = "openai"))]
mod tests {
    use super::*;

    /// A 4xx that says the request is longer than the model's context is a refusal; one about
    /// the request's form, the server, the key or the rate, and any other failure, is not.
    #[test]
    fn a_refusal_is_a_4xx_about_the_request() {
        let status = |status, body: &str| HttpErrorKind::Status { status, body: body.into(), retry_after: None };
        let vllm = "This model's maximum context length is 8192 tokens. However, you requested 9000 tokens";
        assert!(status(400, vllm).is_refusal() && status(413, "").is_refusal());
        assert!(status(400, "{\"error\":{\"code\":\"context_length_exceeded\"}}").is_refusal());
        assert!(status(400, "the request exceeds the available context size, try increasing it").is_refusal());
        for other in [
            status(400, "Unrecognized request argument supplied: allowed_token_ids"),
            status(422, ""),
            status(401, "context length"),
            status(403, ""),
            status(404, ""),
            status(408, ""),
            status(429, ""),
            status(500, "maximum context length"),
            HttpErrorKind::Io("reset".into()),
        ] {
            assert!(!other.is_refusal(), "{other}");
        }
    }
}
