//! An OpenAI-compatible chat client for vision-language models: the policy f_φ of Phase I
//! (paper Eq. 2) and the direct-policy baselines send the goal, the belief, the skills and
//! the current view, and read back a JSON reply.
//!
//! - [`ChatRequest`]: [`Message`]s of text and [`Image`] parts (PNG or JPEG, sent as base64
//!   `data:` URLs), [`Sampling`] settings, an optional JSON schema for the reply, and
//!   `chat_template_kwargs` (Qwen3's `enable_thinking`).
//! - [`ChatModel`]: the interface; [`ChatClient`] implements it over `/v1/chat/completions`
//!   (vLLM, llama.cpp's server, Ollama, hosted APIs over https), asking for JSON with
//!   `response_format` as a JSON schema where the server takes it, else as a JSON object, else
//!   not at all. A local model can implement it too (`lm`'s `LocalChat` decodes under the
//!   schema).
//! - [`chat_json`]: the first JSON object of the reply, checked against the schema, with at
//!   most one repair turn quoting the error.
//! - [`transport`]: the HTTP path on `ureq` (keep-alive pool, rustls, proxies from the
//!   environment): one deadline per attempt covering DNS, connect, request and reply;
//!   bounded retries with exponential backoff and jitter, honouring `Retry-After` on 429 and
//!   503. Every failure is a [`ChatError`] carrying the attempts and the elapsed time.
//! - [`served_models`]: what a server lists at `GET /models`, which names a served model
//!   where a request's `model` field does not (llama.cpp's server answers to any name).
//!
//! ```no_run
//! use vlm_client::{ChatClient, ChatRequest, ClientConfig, Message, Sampling, chat_json};
//! let mut client = ChatClient::new(ClientConfig::new("http://127.0.0.1:8080/v1", "default"))?;
//! let request = ChatRequest::new(vec![Message::user("Which skill next? Goto(fridge 1) or Done.")])
//!     .with_sampling(Sampling::greedy(64))
//!     .with_json_schema(serde_json::json!({
//!         "type": "object",
//!         "properties": { "skill": { "enum": ["Goto(fridge 1)", "Done"] } },
//!         "required": ["skill"]
//!     }));
//! let reply = chat_json(&mut client, &request)?;
//! println!("{} ({} prompt tokens)", reply.value["skill"], reply.usage.prompt_tokens);
//! # Ok::<(), vlm_client::ChatError>(())
//! ```

mod cache;
mod client;
mod error;
mod json;
mod message;
mod models;
pub mod proxy;
mod reply;
mod request;
pub mod transport;

pub use cache::{CacheError, CachedChat};
pub use client::{ChatClient, ChatModel, ClientConfig};
pub use error::{ChatError, ChatErrorKind, context_overflow};
pub use json::{JsonReply, chat_json, check_schema, first_object, read_json, validate};
pub use message::{Image, ImageFormat, Message, Part, Role};
pub use models::{ServedModel, parse_models, served_models};
pub use reply::{ChatReply, Usage, parse_reply};
pub use request::{ChatRequest, JsonMode, Sampling};
pub use transport::{RetryPolicy, api_key_from_env};
