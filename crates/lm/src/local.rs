//! The local backend: a GGUF model run by this crate's forward pass, with a prefix cache over
//! its KV cache. The cache holds the token sequence whose keys and values it has; a request
//! keeps the longest common prefix, truncates the rest, and runs only the new suffix.

use std::path::Path;
use std::sync::Arc;

use crate::error::LmError;
use crate::gguf::{GgufFile, Metadata};
use crate::llama::{KvCache, LlamaModel};
use crate::model::{LanguageModel, Logprobs, Usage};
use crate::tokenizer::Tokenizer;
use crate::vocabulary::TokenId;

/// A local model with its own prefix cache. Several `LocalModel`s can share one set of weights
/// ([`LocalModel::with_shared_weights`]), each with its own cache.
#[derive(Debug)]
pub struct LocalModel {
    model: Arc<LlamaModel>,
    tokenizer: Arc<Tokenizer>,
    cache: KvCache,
    /// The tokens whose keys and values are in `cache`, position by position.
    cached: Vec<TokenId>,
    /// The logits after `cached`, when the last forward pass ended there.
    last_logits: Option<Vec<f32>>,
    usage: Usage,
}

impl LocalModel {
    /// Loads the tokenizer and the weights of a llama / qwen2 / qwen3 GGUF file.
    pub fn load(path: &Path) -> Result<Self, LmError> {
        let mut file = GgufFile::open(path)?;
        let tokenizer = Tokenizer::from_gguf(&Metadata::new(&file.content))?;
        let model = LlamaModel::load(&mut file)?;
        if tokenizer.vocabulary().len() > model.vocabulary_size() {
            return Err(LmError::BadMetadata {
                key: "tokenizer.ggml.tokens".into(),
                expected: "no more tokens than rows of token_embd.weight",
                found: format!("{} tokens for {} rows", tokenizer.vocabulary().len(), model.vocabulary_size()),
            });
        }
        Ok(Self::with_shared_weights(Arc::new(model), Arc::new(tokenizer)))
    }

    /// A model over already-loaded weights, with an empty cache of its own.
    pub fn with_shared_weights(model: Arc<LlamaModel>, tokenizer: Arc<Tokenizer>) -> Self {
        let cache = model.new_cache();
        LocalModel { model, tokenizer, cache, cached: Vec::new(), last_logits: None, usage: Usage::default() }
    }

    pub fn weights(&self) -> &Arc<LlamaModel> {
        &self.model
    }

    pub fn shared_tokenizer(&self) -> &Arc<Tokenizer> {
        &self.tokenizer
    }

    /// The token sequence held by the cache.
    pub fn cached_tokens(&self) -> &[TokenId] {
        &self.cached
    }

    /// Bytes held by the KV cache.
    pub fn cache_bytes(&self) -> usize {
        self.cache.memory_bytes()
    }

    /// Empties the cache (the next request recomputes from the first token).
    pub fn clear_cache(&mut self) {
        self.cache.clear();
        self.cached.clear();
        self.last_logits = None;
    }

    /// The raw logits of the token after `tokens`, through the prefix cache.
    pub fn next_logits(&mut self, tokens: &[TokenId]) -> Result<&[f32], LmError> {
        if tokens.is_empty() {
            return Err(LmError::EmptySequence);
        }
        // The model may have more rows than the tokenizer has tokens (padding); ids are checked
        // against the model's rows, the ones it can embed.
        let size = self.model.vocabulary_size();
        if let Some(&id) = tokens.iter().find(|&&id| id as usize >= size) {
            return Err(LmError::TokenOutOfRange { id, size });
        }
        let common = self.cached.iter().zip(tokens).take_while(|(a, b)| a == b).count();
        self.usage.tokens_generated += 1;
        if common == tokens.len() && common == self.cached.len() && self.last_logits.is_some() {
            self.usage.cache_hits += 1;
            self.usage.tokens_reused += tokens.len() as u64;
            return Ok(self.last_logits.as_deref().unwrap_or_default());
        }
        // At least the last token is run, so that its logits exist.
        let keep = common.min(tokens.len() - 1);
        self.cache.truncate(keep);
        self.cached.truncate(keep);
        self.last_logits = None;
        let logits = self.model.forward(&mut self.cache, &tokens[keep..])?;
        self.cached.extend_from_slice(&tokens[keep..]);
        self.usage.forward_calls += 1;
        self.usage.tokens_prefilled += (tokens.len() - keep) as u64;
        self.usage.tokens_reused += keep as u64;
        Ok(self.last_logits.insert(logits))
    }
}

impl LanguageModel for LocalModel {
    fn tokenizer(&self) -> &Tokenizer {
        &self.tokenizer
    }

    fn next_logprobs(&mut self, tokens: &[TokenId]) -> Result<Logprobs, LmError> {
        let vocabulary = self.tokenizer.vocabulary().len();
        let logits = self.next_logits(tokens)?;
        // Rows past the tokenizer's vocabulary (padding) are not tokens: leave them out.
        Ok(Logprobs::from_logits(&logits[..vocabulary.min(logits.len())]))
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}
