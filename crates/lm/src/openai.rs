//! The OpenAI-compatible backend: a served model (vLLM, llama.cpp server, Ollama) asked for one
//! token at a time through `/v1/completions` with `max_tokens = 1`, `temperature = 0` and top-k
//! `logprobs`, the prompt sent as token ids. With vLLM, `allowed_token_ids` masks on the
//! server and `return_tokens_as_token_ids` names tokens by id.
//!
//! What is approximated: the server returns only its top-k tokens. The prior over an allowed
//! set is exact when every allowed token is among them (vLLM with `allowed_token_ids` and
//! `k ≥ |allowed|`, the default case for action spellings); an allowed token outside the top-k
//! gets an estimate from the leftover mass (see [`Logprobs::among`]) and is counted in
//! [`Prior::estimated`]. Prefix reuse across requests is the server's (vLLM's automatic prefix
//! caching, llama.cpp's `cache_prompt`); this side remembers recent answers, so a repeated
//! request costs nothing.
//!
//! The answer's logprobs are read in every layout the servers use: the legacy completions
//! one, `choices[0].logprobs.top_logprobs[0]` as a `{token: logprob}` object (vLLM, OpenAI),
//! and the chat-style one, `choices[0].logprobs.content[0].top_logprobs` as a list of
//! `{token, logprob, bytes?, id?}` (llama.cpp's `llama-server`, Ollama). A token is named by
//! its `id` where the server gives one, else by its `bytes`, else by `token_id:N`
//! (vLLM's `return_tokens_as_token_ids`), else by its text.
//!
//! HTTP is `vlm-client`'s transport: one `ureq` agent per model (keep-alive, rustls, proxies
//! from the environment), one deadline per attempt, bounded retries with jitter honouring
//! `Retry-After`.

use std::sync::Arc;
use std::time::Duration;

use rustc_hash::FxHashMap;
use serde_json::{Value, json};
use vlm_client::transport::{self, RetryPolicy};
use vlm_client::{ChatError, ChatErrorKind};

use crate::error::{HttpError, HttpErrorKind, LmError};
use crate::model::{LanguageModel, Logprobs, Prior, Usage};
use crate::tokenizer::Tokenizer;
use crate::vocabulary::TokenId;

/// Which extensions of the completions API the server has (command-line names `vllm`,
/// `generic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, strum::EnumString, strum::IntoStaticStr, strum::VariantNames)]
#[strum(serialize_all = "lowercase", parse_err_ty = UnknownDialect, parse_err_fn = UnknownDialect::new)]
pub enum ServerDialect {
    /// vLLM: `allowed_token_ids` and `return_tokens_as_token_ids` are sent.
    Vllm,
    /// Plain OpenAI completions (llama.cpp server, Ollama): tokens come back as text and are
    /// mapped to ids through the tokenizer; allowed sets are applied on this side.
    Generic,
}

/// A name that is not a [`ServerDialect`]'s (the error of its
/// [`FromStr`](std::str::FromStr)): names what was given and lists the dialects.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "`{0}` is not a server dialect: the dialects are {dialects}",
    dialects = <ServerDialect as strum::VariantNames>::VARIANTS.join(", ")
)]
pub struct UnknownDialect(pub String);

impl UnknownDialect {
    fn new(given: &str) -> UnknownDialect {
        UnknownDialect(given.to_string())
    }
}

/// Where the server is and how to talk to it.
#[derive(Debug, Clone)]
pub struct OpenAiConfig {
    /// `http(s)://host:port/v1` (the path before `/completions`).
    pub base_url: String,
    /// The `model` field of each request.
    pub model: String,
    /// Sent as `Authorization: Bearer ...` where set.
    pub api_key: Option<String>,
    /// The k of top-k `logprobs` (vLLM's default server limit is 20; OpenAI's is 5).
    pub top_logprobs: usize,
    /// Which API extensions the server has: with vLLM's, allowed sets are masked on the server.
    pub dialect: ServerDialect,
    /// For one attempt: DNS, connect, send and receive.
    pub timeout: Duration,
    /// Further attempts after a transient failure (connection, timeout, 5xx, 429).
    pub max_retries: u32,
    /// Wait before the first retry; doubled for each further one, times a jitter in [0.5, 1).
    pub retry_backoff: Duration,
    /// The longest `Retry-After` honoured (429, 503); a longer one ends the retries.
    pub max_retry_wait: Duration,
    /// Answers remembered for repeated requests, at most (rounded up to an even number): the
    /// most recent half always, an older answer until a newer half replaces it. 0 remembers none.
    pub cache_entries: usize,
}

impl OpenAiConfig {
    /// `model` at `base_url`, as vLLM: no API key, top-20 logprobs, 60 s per attempt, 2 retries
    /// from 250 ms, a `Retry-After` of up to 60 s honoured, 4096 answers remembered.
    pub fn new(base_url: &str, model: &str) -> Self {
        OpenAiConfig {
            base_url: base_url.to_string(),
            model: model.to_string(),
            api_key: None,
            top_logprobs: 20,
            dialect: ServerDialect::Vllm,
            timeout: Duration::from_secs(60),
            max_retries: 2,
            retry_backoff: Duration::from_millis(250),
            max_retry_wait: Duration::from_secs(60),
            cache_entries: 4096,
        }
    }
}

/// A served model.
#[derive(Debug)]
pub struct OpenAiModel {
    config: OpenAiConfig,
    endpoint: String,
    agent: ureq::Agent,
    tokenizer: Arc<Tokenizer>,
    /// Token text → id, for servers that name tokens by text; built on first need.
    text_to_id: Option<FxHashMap<Vec<u8>, TokenId>>,
    answers: Answers,
    usage: Usage,
}

/// A request's key: the prompt's tokens and the allowed tokens (empty: none named).
type AnswerKey = (Vec<TokenId>, Vec<TokenId>);

/// Recent answers in two generations: when the newer one holds half the capacity it becomes
/// the older one, and the answers of the one before are dropped; a hit in the older one moves
/// the answer to the newer. An answer stays remembered until at least half the capacity of
/// other answers has been stored since it was last asked for (MCTS asks again for the prefixes
/// near the root), where emptying one full table would drop the answers just stored too.
/// Written by hand: two hash maps make an approximate LRU whose every operation is one or two
/// lookups, with no recency list to keep.
#[derive(Debug, Default)]
struct Answers {
    newer: FxHashMap<AnswerKey, Logprobs>,
    older: FxHashMap<AnswerKey, Logprobs>,
}

impl Answers {
    fn get(&mut self, key: &AnswerKey, capacity: usize) -> Option<Logprobs> {
        if let Some(answer) = self.newer.get(key) {
            return Some(answer.clone());
        }
        let (key, answer) = self.older.remove_entry(key)?;
        self.insert(key, answer.clone(), capacity);
        Some(answer)
    }

    fn insert(&mut self, key: AnswerKey, answer: Logprobs, capacity: usize) {
        if capacity == 0 {
            return;
        }
        if self.newer.len() >= capacity.div_ceil(2) {
            self.older = std::mem::take(&mut self.newer);
        }
        self.newer.insert(key, answer);
    }
}

impl OpenAiModel {
    /// A client; `tokenizer` must be the served model's (prompts are sent as its ids).
    pub fn new(config: OpenAiConfig, tokenizer: Arc<Tokenizer>) -> Result<Self, LmError> {
        let base = config.base_url.trim_end_matches('/');
        let refuse =
            |kind| HttpError { kind: http_kind(kind), url: transport::redacted(&config.base_url), attempts: 0, elapsed: Duration::ZERO };
        transport::check_url(base).map_err(refuse)?;
        let agent = transport::agent(config.timeout, base).map_err(refuse)?;
        Ok(OpenAiModel {
            endpoint: format!("{base}/completions"),
            agent,
            config,
            tokenizer,
            text_to_id: None,
            answers: Answers::default(),
            usage: Usage::default(),
        })
    }

    /// The configuration the model was made with.
    pub fn config(&self) -> &OpenAiConfig {
        &self.config
    }

    fn check(&self, tokens: &[TokenId]) -> Result<(), LmError> {
        if tokens.is_empty() {
            return Err(LmError::EmptySequence);
        }
        tokens.iter().try_for_each(|&t| self.tokenizer.vocabulary().check(t))
    }

    /// One completions request with retries; the parsed top-k distribution.
    fn request(&mut self, tokens: &[TokenId], allowed: Option<&[TokenId]>) -> Result<Logprobs, LmError> {
        let key = (tokens.to_vec(), allowed.map(<[TokenId]>::to_vec).unwrap_or_default());
        self.usage.tokens_generated += 1;
        if let Some(answer) = self.answers.get(&key, self.config.cache_entries) {
            self.usage.cache_hits += 1;
            self.usage.tokens_reused += tokens.len() as u64;
            return Ok(answer);
        }
        let top_k = match allowed {
            Some(allowed) if self.config.dialect == ServerDialect::Vllm => allowed.len().min(self.config.top_logprobs),
            _ => self.config.top_logprobs,
        }
        .max(1);
        let mut body = json!({
            "model": self.config.model,
            "prompt": tokens,
            "max_tokens": 1,
            "temperature": 0.0,
            "logprobs": top_k,
        });
        if self.config.dialect == ServerDialect::Vllm {
            body["return_tokens_as_token_ids"] = json!(true);
            if let Some(allowed) = allowed {
                body["allowed_token_ids"] = json!(allowed);
            }
        }
        let body = body.to_string().into_bytes();
        let policy = RetryPolicy {
            timeout: self.config.timeout,
            max_retries: self.config.max_retries,
            backoff: self.config.retry_backoff,
            max_wait: self.config.max_retry_wait,
        };
        let delivered = transport::post_json(&self.agent, &self.endpoint, &body, self.config.api_key.as_deref(), &policy);
        let (attempts, parsed) = match delivered {
            Ok(delivered) => {
                let parsed = self.parse(&delivered.body).map_err(|kind| HttpError {
                    kind,
                    url: self.endpoint.clone(),
                    attempts: delivered.attempts,
                    elapsed: delivered.elapsed,
                });
                (delivered.attempts, parsed)
            }
            Err(ChatError { kind, url, attempts, elapsed }) => (attempts, Err(HttpError { kind: http_kind(kind), url, attempts, elapsed })),
        };
        self.usage.forward_calls += u64::from(attempts);
        let (logprobs, prompt_tokens) = parsed?;
        self.usage.tokens_prefilled += prompt_tokens.unwrap_or(tokens.len() as u64);
        self.answers.insert(key, logprobs.clone(), self.config.cache_entries);
        Ok(logprobs)
    }

    /// The top-k distribution of a completions response, and its `usage.prompt_tokens`.
    fn parse(&mut self, body: &[u8]) -> Result<(Logprobs, Option<u64>), HttpErrorKind> {
        let malformed = |why: String| HttpErrorKind::MalformedJson(why);
        let value: Value = serde_json::from_slice(body).map_err(|e| malformed(format!("{e}")))?;
        let choice = value.get("choices").and_then(|c| c.get(0)).ok_or_else(|| malformed("no `choices[0]`".into()))?;
        let logprobs = choice.get("logprobs").filter(|l| !l.is_null()).ok_or_else(|| malformed("no `choices[0].logprobs`".into()))?;
        let mut entries: Vec<(TokenId, f32)> = Vec::new();
        let mut listed = 0;
        let mut check = |name: &str, logprob: Option<f64>| -> Result<f32, HttpErrorKind> {
            listed += 1;
            let logprob = logprob.ok_or_else(|| malformed(format!("logprob of `{name}` is not a number")))?;
            if logprob > 1e-4 || logprob.is_nan() {
                return Err(malformed(format!("logprob {logprob} of `{name}` is not a log-probability")));
            }
            Ok(logprob.min(0.0) as f32)
        };
        if let Some(top) = logprobs.get("top_logprobs").and_then(|t| t.get(0)).and_then(Value::as_object) {
            // Legacy completions layout: `{token: logprob}`.
            for (name, logprob) in top {
                let logprob = check(name, logprob.as_f64())?;
                // A token text this tokenizer cannot name: left out, its mass joins the rest.
                if let Some(id) = self.token_id(name) {
                    entries.push((id, logprob));
                }
            }
        } else if let Some(top) =
            logprobs.get("content").and_then(|c| c.get(0)).and_then(|c| c.get("top_logprobs")).and_then(Value::as_array)
        {
            // Chat-style layout: `[{token, logprob, bytes?, id?}]`.
            for entry in top {
                let name = entry.get("token").and_then(Value::as_str).unwrap_or_default();
                let logprob = check(name, entry.get("logprob").and_then(Value::as_f64))?;
                if let Some(id) = self.entry_id(entry, name) {
                    entries.push((id, logprob));
                }
            }
        } else {
            return Err(malformed(
                "neither `choices[0].logprobs.top_logprobs[0]` (an object) nor `choices[0].logprobs.content[0].top_logprobs` (a list)"
                    .into(),
            ));
        }
        if entries.is_empty() {
            return Err(malformed(format!("no token of the {listed} top logprobs is in the vocabulary")));
        }
        // One entry per id, its likeliest (two listed names can map to one id, such as a token
        // whose lost bytes the server shows as "�"), then the likeliest first.
        entries.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
        entries.dedup_by_key(|e| e.0);
        entries.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        // Each entry is a log-probability; together, the likeliest tokens of one distribution:
        // their probabilities sum to at most 1 (past rounding), and not all of them to nothing.
        let total: f64 = entries.iter().map(|e| f64::from(e.1).exp()).sum();
        if total > 1.01 {
            return Err(malformed(format!("the top logprobs' probabilities sum to {total:.3}: not one distribution")));
        }
        if total == 0.0 {
            return Err(malformed("every top logprob is -inf: no token is possible".into()));
        }
        let prompt_tokens = value.get("usage").and_then(|u| u.get("prompt_tokens")).and_then(Value::as_u64);
        Ok((Logprobs::Sparse { top: entries, vocabulary_size: self.tokenizer.vocabulary().len() }, prompt_tokens))
    }

    /// The id of a chat-style entry: its `id` where the server gives one (llama.cpp), else its
    /// `bytes`, else its text.
    fn entry_id(&mut self, entry: &Value, name: &str) -> Option<TokenId> {
        if let Some(id) = entry.get("id").and_then(Value::as_u64) {
            let id = TokenId::try_from(id).ok()?;
            return self.tokenizer.vocabulary().check(id).is_ok().then_some(id);
        }
        if let Some(bytes) = entry.get("bytes").and_then(Value::as_array) {
            let bytes: Option<Vec<u8>> = bytes.iter().map(|b| b.as_u64().and_then(|b| u8::try_from(b).ok())).collect();
            if let Some(bytes) = bytes {
                return self.id_of_bytes(&bytes);
            }
        }
        self.token_id(name)
    }

    fn token_id(&mut self, name: &str) -> Option<TokenId> {
        if let Some(id) = name.strip_prefix("token_id:").and_then(|n| n.parse::<TokenId>().ok()) {
            return (self.tokenizer.vocabulary().check(id).is_ok()).then_some(id);
        }
        self.id_of_bytes(name.as_bytes())
    }

    fn id_of_bytes(&mut self, bytes: &[u8]) -> Option<TokenId> {
        let vocabulary = self.tokenizer.vocabulary();
        let map = self.text_to_id.get_or_insert_with(|| {
            let mut map = FxHashMap::default();
            // Text tokens first, so that a control token spelled like text does not shadow it.
            for (id, bytes) in vocabulary.iter() {
                if !vocabulary.is_special(id) {
                    map.entry(bytes.to_vec()).or_insert(id);
                }
            }
            for (id, bytes) in vocabulary.iter() {
                map.entry(bytes.to_vec()).or_insert(id);
            }
            map
        });
        map.get(bytes).copied()
    }
}

/// The transport's error as this crate's.
fn http_kind(kind: ChatErrorKind) -> HttpErrorKind {
    match kind {
        ChatErrorKind::BadUrl(why) => HttpErrorKind::BadUrl(why),
        ChatErrorKind::Connect(why) => HttpErrorKind::Connect(why),
        ChatErrorKind::Timeout(after) => HttpErrorKind::Timeout(after),
        ChatErrorKind::Status { status, body, retry_after } => HttpErrorKind::Status { status, body, retry_after },
        ChatErrorKind::MalformedReply(why) | ChatErrorKind::InvalidJson { error: why, .. } => HttpErrorKind::MalformedJson(why),
        // Said once: both kinds print "connection failed: ".
        ChatErrorKind::Io(why) => HttpErrorKind::Io(why),
        other @ (ChatErrorKind::MissingApiKey(_) | ChatErrorKind::BadInput(_) | ChatErrorKind::Model(_)) => {
            HttpErrorKind::Io(other.to_string())
        }
    }
}

impl LanguageModel for OpenAiModel {
    fn tokenizer(&self) -> &Tokenizer {
        &self.tokenizer
    }

    /// The server's top-k as a sparse distribution.
    fn next_logprobs(&mut self, tokens: &[TokenId]) -> Result<Logprobs, LmError> {
        self.check(tokens)?;
        self.request(tokens, None)
    }

    /// With vLLM, the server masks to `allowed` and returns up to `top_logprobs` of them; the
    /// answer is renormalised over `allowed` either way (see the module notes).
    fn next_logprobs_among(&mut self, tokens: &[TokenId], allowed: &[TokenId]) -> Result<Prior, LmError> {
        self.check(tokens)?;
        if allowed.is_empty() {
            return Err(LmError::NoAllowedTokens);
        }
        allowed.iter().try_for_each(|&t| self.tokenizer.vocabulary().check(t))?;
        self.request(tokens, Some(allowed))?.among(allowed)
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}
