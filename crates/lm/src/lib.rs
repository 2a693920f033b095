//! Language models for the planner (paper §3.2, Eq. 8-9): the next-token distribution at every
//! node of a token-level search tree whose branches share long prefixes.
//!
//! [`LanguageModel`] is the interface: a [`Vocabulary`] (token id → bytes, end-of-sequence and
//! other special tokens) and [`LanguageModel::next_logprobs`] for a full token sequence. Every
//! backend keeps a prefix cache, so that a sequence extending the previous one pays only for its
//! new tokens and a sibling branch rewinds the cache to the common prefix instead of
//! recomputing it. [`LanguageModel::next_logprobs_among`] gives the prior renormalised over the
//! tokens a constraint allows, which is what the search needs at a node. [`Usage`] counts
//! forward calls, prefilled and reused positions, and generated tokens.
//!
//! Backends:
//! - [`LocalModel`]: a llama / qwen2 / qwen3 GGUF file run by this crate's own forward pass on
//!   `candle-core` quantized matmuls ([`LlamaModel`]), with a KV cache that truncates to any
//!   length; its [`Tokenizer`] and [`ChatTemplate`] are built from the GGUF metadata.
//! - [`OpenAiModel`]: a served model (vLLM, llama.cpp server, Ollama) through
//!   `/v1/completions` with `max_tokens = 1` and top-k `logprobs` (plus vLLM's
//!   `allowed_token_ids`), over `vlm-client`'s HTTP transport (`ureq`: keep-alive, rustls,
//!   one deadline per attempt, bounded retries honouring `Retry-After`).
//! - [`UniformModel`]: every token equally likely (symbolic-only runs, a control), over any
//!   [`Tokenizer`]: a GGUF file's, or a Hugging Face `tokenizer.json`'s
//!   ([`Tokenizer::from_tokenizer_json`]), which needs no model file.
//!
//! Features: `local` (the forward pass) and `openai` (the server backend) are on by default;
//! without them the crate is the interface, tokenizers, chat templates, GGUF metadata and the
//! uniform prior. With the `chat` feature, `LocalChat` makes a [`LocalModel`] a `vlm_client::ChatModel`:
//! the chat template renders the messages and, when a JSON schema is asked for, llguidance
//! masks every decoding step to it, so even a 135M model replies with schema-valid JSON.
//!
//! ```
//! # #[cfg(feature = "local")] {
//! use lm::{LanguageModel, LocalModel, tiny};
//! let path = std::env::temp_dir().join(format!("lm-doc-{}.gguf", std::process::id()));
//! tiny::write_tiny_gguf(&path, &tiny::TinySpec::default())?;
//! let mut model = LocalModel::load(&path)?;
//! let prompt = model.encode(" open the fridge")?;
//! let after_prompt = model.next_logprobs(&prompt)?;
//! // A sibling branch: same prompt, another last token; only that token is recomputed.
//! let mut sibling = prompt.clone();
//! *sibling.last_mut().unwrap() = model.encode(" the")?[0];
//! let prior = model.next_logprobs_among(&sibling, &[3, 4, 5])?;
//! assert_eq!(prior.tokens.len(), 3);
//! assert_eq!(model.usage().tokens_prefilled as usize, prompt.len() + 1);
//! # let _ = after_prompt;
//! # std::fs::remove_file(&path).ok();
//! # }
//! # Ok::<(), lm::LmError>(())
//! ```

pub mod cache;
mod chat;
#[cfg(feature = "chat")]
mod chat_model;
mod error;
mod gguf;
#[cfg(feature = "local")]
mod llama;
#[cfg(feature = "local")]
mod local;
mod model;
#[cfg(feature = "openai")]
mod openai;
#[cfg(feature = "reference")]
pub mod reference;
#[cfg(feature = "local")]
pub mod tiny;
mod tokenizer;
mod uniform;
mod vocabulary;

pub use cache::{DEFAULT_MODEL_FILE, default_model_path, model_dir};
pub use chat::ChatTemplate;
#[cfg(feature = "chat")]
pub use chat_model::LocalChat;
pub use error::{HttpError, HttpErrorKind, LmError};
pub use gguf::{GgufFile, Metadata};
#[cfg(feature = "local")]
pub use llama::{Architecture, KvCache, LlamaModel, ModelConfig, RopeConfig};
#[cfg(feature = "local")]
pub use local::{DEFAULT_BRANCH_STORE_BYTES, LocalModel};
pub use model::{LanguageModel, Logprobs, Prior, Usage, generate_greedy};
#[cfg(feature = "openai")]
pub use openai::{OpenAiConfig, OpenAiModel, ServerDialect, UnknownDialect};
pub use tokenizer::{BpeParts, COMMON_BOS_TOKENS, COMMON_STOP_TOKENS, PreTokenizer, Tokenizer};
pub use uniform::UniformModel;
pub use vocabulary::{TokenId, TokenKind, Vocabulary, byte_level_decode, byte_level_encode, char_to_byte_map};
