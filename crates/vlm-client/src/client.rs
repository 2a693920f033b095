//! [`ChatModel`], the interface every chat model answers to, and [`ChatClient`], a served
//! model behind `/v1/chat/completions` (vLLM, llama.cpp's server, Ollama, hosted APIs).

use std::time::Duration;

use crate::error::{ChatError, ChatErrorKind};
use crate::message::Message;
use crate::reply::{ChatReply, Usage, parse_reply};
use crate::request::{ChatRequest, JsonMode, Sampling};
use crate::transport::{self, RetryPolicy};

/// A chat model: messages in, one reply out. A request with a `json_schema` asks the model to
/// answer in JSON; [`crate::chat_json`] reads and checks the reply and repairs it once.
pub trait ChatModel {
    /// Answers `request` with one reply. A served model retries transient failures first, as
    /// its [`RetryPolicy`] allows; the error says how many attempts were made.
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError>;
    /// Where the model is, for error messages (a URL, or `local:...`).
    fn endpoint(&self) -> String;
    /// Usage summed over every call so far.
    fn usage(&self) -> Usage;
}

/// Where the server is and how to talk to it.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientConfig {
    /// `http(s)://host[:port]/v1`: the path before `/chat/completions`.
    pub base_url: String,
    /// The `model` field of each request.
    pub model: String,
    /// The environment variable holding the API key, sent as `Authorization: Bearer ...`
    /// (`None`: no key, as local servers want).
    pub api_key_env: Option<String>,
    /// The deadline of each attempt and the retries after a transient failure.
    pub retry: RetryPolicy,
    /// The strongest way of asking for JSON to try first; a server that refuses a
    /// `response_format` with a 400 is asked again the next weaker way, which is kept for that
    /// schema (or for every schema, where a probe shows the server takes none: see
    /// [`ChatClient`]).
    pub json_mode: JsonMode,
}

impl ClientConfig {
    /// `model` at `base_url` (a trailing `/` dropped): no API key, the default [`RetryPolicy`],
    /// JSON asked for by schema first. The URL is checked by [`ChatClient::new`], not here.
    pub fn new(base_url: &str, model: &str) -> ClientConfig {
        ClientConfig {
            base_url: base_url.trim_end_matches('/').to_string(),
            model: model.to_string(),
            api_key_env: None,
            retry: RetryPolicy::default(),
            json_mode: JsonMode::Schema,
        }
    }
}

/// A served chat model.
#[derive(Debug)]
pub struct ChatClient {
    config: ClientConfig,
    endpoint: String,
    agent: ureq::Agent,
    api_key: Option<String>,
    /// The weaker mode kept for each schema (by its JSON text) a server refused in a stronger
    /// one. Per schema, not for the client's life: a server may refuse one schema and take
    /// another, and a request's mode must not depend on which requests came before it (a
    /// resumed run asks as an uninterrupted one does).
    weakened: std::collections::BTreeMap<String, JsonMode>,
    /// Whether the server takes `response_format: json_schema` at all, learnt from one probe
    /// (the plainest schema, `{"type": "object"}`, one output token) the first time a schema
    /// is refused. A server that refuses the probe too takes no schema, which is a property of
    /// the server, like `no_template_kwargs`: every later request starts one mode weaker, and
    /// Phase I, whose schema changes with its skills, stops paying a refused request a turn. A
    /// server that takes the probe refused that schema only, which is weakened alone.
    schema_support: SchemaSupport,
    /// The server refused `chat_template_kwargs` by name (a hosted API that takes no template
    /// arguments): requests go without them from then on. A property of the server, the same
    /// for every request, so it does not make one request depend on another.
    no_template_kwargs: bool,
    usage: Usage,
}

impl ChatClient {
    /// A client; the URL is checked and the API key read here, so that a bad setting fails
    /// before the first request.
    pub fn new(config: ClientConfig) -> Result<ChatClient, ChatError> {
        let refuse = |kind| ChatError { kind, url: transport::redacted(&config.base_url), attempts: 0, elapsed: Duration::ZERO };
        transport::check_url(&config.base_url).map_err(refuse)?;
        let api_key = match &config.api_key_env {
            Some(name) => Some(transport::api_key_from_env(name).map_err(refuse)?),
            None => None,
        };
        let agent = transport::agent(config.retry.timeout, &config.base_url).map_err(refuse)?;
        Ok(ChatClient {
            endpoint: format!("{}/chat/completions", config.base_url),
            agent,
            weakened: std::collections::BTreeMap::new(),
            schema_support: SchemaSupport::Unknown,
            no_template_kwargs: false,
            api_key,
            usage: Usage::default(),
            config,
        })
    }

    /// The configuration the client was made with.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// How JSON is asked for with `schema` now: as configured, or weaker after the server
    /// refused that schema in a stronger mode and took it in this one.
    pub fn json_mode(&self, schema: &serde_json::Value) -> JsonMode {
        self.weakened.get(&schema.to_string()).copied().unwrap_or(self.first_mode())
    }

    /// The mode a schema is first asked in: as configured, or without `json_schema` where the
    /// probe showed the server takes none.
    fn first_mode(&self) -> JsonMode {
        match (self.config.json_mode, self.schema_support) {
            (JsonMode::Schema, SchemaSupport::Refused) => JsonMode::Object,
            (mode, _) => mode,
        }
    }

    /// Asks the plainest schema request there is, once, to tell a server that takes no
    /// `json_schema` from one that refused a particular schema. Returns the attempts it took;
    /// its tokens count in the client's usage. A failure other than a 400/422 (the server
    /// gone) teaches nothing: the question stays open for the next refusal.
    fn probe_schema_support(&mut self) -> u32 {
        let probe = ChatRequest::new(vec![Message::user("Reply with an empty JSON object.")])
            .with_sampling(Sampling::greedy(1))
            .with_json_schema(serde_json::json!({ "type": "object" }));
        let body = probe.body(&self.config.model, JsonMode::Schema).to_string();
        let result = transport::post_json(&self.agent, &self.endpoint, body.as_bytes(), self.api_key.as_deref(), &self.config.retry);
        let attempts = match result {
            Ok(delivered) => {
                self.schema_support = SchemaSupport::Taken;
                if let Ok(reply) = parse_reply(&delivered.body) {
                    let mut counted = reply.usage;
                    counted.requests = 0;
                    self.usage.add(&counted);
                }
                delivered.attempts
            }
            Err(error) => {
                if matches!(error.kind, ChatErrorKind::Status { status: 400 | 422, .. }) {
                    self.schema_support = SchemaSupport::Refused;
                }
                error.attempts
            }
        };
        self.usage.requests += u64::from(attempts);
        attempts
    }
}

/// What the schema probe found ([`ChatClient::probe_schema_support`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SchemaSupport {
    /// No schema refused yet, or the probe failed for another reason.
    Unknown,
    /// The server took the probe: a refusal is about the schema it refused.
    Taken,
    /// The server refused the probe: it takes no `json_schema`.
    Refused,
}

impl ChatModel for ChatClient {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let images = request.image_count() as u64;
        let mut extra_attempts = 0;
        // A 400/422 may refuse the JSON mode, or something else (a prompt past the context, a bad
        // image): a weaker mode is tried, and kept only once a request in it succeeds, so an
        // error of another kind never weakens the requests after it.
        let key = request.json_schema.as_ref().map(|schema| schema.to_string());
        let mut mode = key.as_ref().and_then(|k| self.weakened.get(k)).copied().unwrap_or(self.first_mode());
        let without_kwargs;
        let mut request = request;
        if self.no_template_kwargs && request.chat_template_kwargs.is_some() {
            without_kwargs = ChatRequest { chat_template_kwargs: None, ..request.clone() };
            request = &without_kwargs;
        }
        loop {
            let body = request.body(&self.config.model, mode).to_string();
            let result = transport::post_json(&self.agent, &self.endpoint, body.as_bytes(), self.api_key.as_deref(), &self.config.retry);
            let delivered = match result {
                Ok(delivered) => delivered,
                Err(error) => {
                    self.usage.requests += u64::from(error.attempts);
                    // A server that does not take template arguments names the field it refuses
                    // (OpenAI: "Unrecognized request argument supplied: chat_template_kwargs").
                    if let ChatErrorKind::Status { status: 400 | 422, body, .. } = &error.kind
                        && request.chat_template_kwargs.is_some()
                        && body.contains("chat_template_kwargs")
                    {
                        self.no_template_kwargs = true;
                        let before = error.attempts + extra_attempts;
                        // Asked again from the start, which now leaves them out.
                        return self.chat(request).map(|mut reply| {
                            reply.attempts += before;
                            reply.usage.requests += u64::from(before);
                            reply
                        });
                    }
                    let refused_format = matches!(error.kind, ChatErrorKind::Status { status: 400 | 422, .. });
                    match mode.weaker() {
                        Some(weaker) if refused_format && request.json_schema.is_some() => {
                            extra_attempts += error.attempts;
                            if mode == JsonMode::Schema && self.schema_support == SchemaSupport::Unknown {
                                extra_attempts += self.probe_schema_support();
                            }
                            mode = weaker;
                            continue;
                        }
                        _ => return Err(ChatError { attempts: error.attempts + extra_attempts, ..error }),
                    }
                }
            };
            if let Some(key) = &key
                && mode != self.first_mode()
            {
                self.weakened.insert(key.clone(), mode);
            }
            let attempts = delivered.attempts + extra_attempts;
            self.usage.requests += u64::from(delivered.attempts);
            let mut reply = parse_reply(&delivered.body).map_err(|kind| ChatError {
                kind,
                url: self.endpoint.clone(),
                attempts,
                elapsed: delivered.elapsed,
            })?;
            reply.usage.requests = u64::from(attempts);
            reply.usage.images = images;
            reply.attempts = attempts;
            reply.waited = delivered.waited;
            reply.json_mode = request.json_schema.as_ref().map(|_| mode);
            let mut counted = reply.usage;
            counted.requests = 0;
            self.usage.add(&counted);
            return Ok(reply);
        }
    }

    fn endpoint(&self) -> String {
        self.endpoint.clone()
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}
