//! The local backend: a GGUF model run by this crate's forward pass, with a prefix cache over
//! its KV cache. The cache holds the token sequence whose keys and values it has; a request
//! keeps the longest common prefix, truncates the rest, and runs only the new suffix.
//!
//! Beside it, a *branch store* keeps the keys and values of every position computed so far,
//! in a trie by token prefix (within a memory budget). A search that returns to a branch it
//! left (MCTS selecting a sibling's subtree again) gets that branch's positions copied back
//! into the cache instead of recomputed: only positions never computed before (and the last
//! one, whose logits are needed) go through the model. Keys and values depend only on the
//! tokens up to their position, so a copied position is the one computed then.

use std::path::Path;
use std::sync::Arc;

use crate::error::LmError;
use crate::gguf::{GgufFile, Metadata};
use crate::llama::{KvCache, LlamaModel};
use crate::model::{LanguageModel, Logprobs, Prior, Usage};
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
    /// The final hidden state after `cached`, when the last forward pass ended there.
    last_hidden: Option<Vec<f32>>,
    /// The full head's logits for `last_hidden`, once asked for.
    last_logits: Option<Vec<f32>>,
    /// Output-head rows dequantized for [`LocalModel::logits_among`], by token.
    rows: rustc_hash::FxHashMap<TokenId, Box<[f32]>>,
    store: BranchStore,
    usage: Usage,
}

/// Bytes of keys and values the branch store may hold by default.
pub const DEFAULT_BRANCH_STORE_BYTES: usize = 512 << 20;

const ROOT: u32 = u32::MAX;

/// Dequantized output-head rows kept for constrained priors before the set is emptied: the
/// tokens a task's masks allow are a few thousand, far below this; the cap bounds memory for a
/// long run over many tasks (16 KB a row for a 4096-wide model).
const MAX_KEPT_ROWS: usize = 16_384;

/// Keys and values of positions computed before, by token prefix: a trie from position 0 whose
/// node `i` (the prefix ending at some token) owns row `i` of `rows`. A hash map of edges is
/// all the trie needs (lookups only walk down), so it is written here rather than taken from
/// a crate. When full it is emptied and refills with what the search computes next.
#[derive(Debug, Default)]
struct BranchStore {
    children: rustc_hash::FxHashMap<(u32, TokenId), u32>,
    rows: Vec<f32>,
    row_len: usize,
    max_nodes: usize,
    /// Scratch: the nodes along the request's stored prefix.
    path: Vec<u32>,
}

impl BranchStore {
    fn new(row_len: usize, max_bytes: usize) -> BranchStore {
        let max_nodes = max_bytes / (row_len.max(1) * std::mem::size_of::<f32>());
        BranchStore { row_len, max_nodes, ..BranchStore::default() }
    }

    fn nodes(&self) -> usize {
        self.rows.len() / self.row_len.max(1)
    }

    fn clear(&mut self) {
        self.children.clear();
        self.rows.clear();
    }

    /// Fills `path` with the nodes of the longest stored prefix of `tokens`.
    fn walk(&mut self, tokens: &[TokenId]) {
        self.path.clear();
        let mut node = ROOT;
        for &token in tokens {
            match self.children.get(&(node, token)) {
                Some(&child) => {
                    self.path.push(child);
                    node = child;
                }
                None => break,
            }
        }
    }

    fn row(&self, node: u32) -> &[f32] {
        &self.rows[node as usize * self.row_len..(node as usize + 1) * self.row_len]
    }

    /// Stores positions `path.len()..tokens.len()` of `tokens` from `cache` (which holds at
    /// least `tokens.len()` positions), after the stored prefix found by the last `walk`.
    fn insert(&mut self, tokens: &[TokenId], cache: &KvCache) {
        if self.max_nodes == 0 {
            return;
        }
        let mut from = self.path.len().min(tokens.len());
        if self.nodes() + (tokens.len() - from) > self.max_nodes {
            self.clear();
            self.path.clear();
            from = 0;
            if tokens.len() > self.max_nodes {
                return;
            }
        }
        let mut node = from.checked_sub(1).map_or(ROOT, |i| self.path[i]);
        for (pos, &token) in tokens.iter().enumerate().skip(from) {
            let child = self.nodes() as u32;
            cache.copy_position(pos, &mut self.rows);
            self.children.insert((node, token), child);
            self.path.push(child);
            node = child;
        }
    }
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
        let store = BranchStore::new(cache.position_len(), DEFAULT_BRANCH_STORE_BYTES);
        LocalModel {
            model,
            tokenizer,
            cache,
            cached: Vec::new(),
            last_hidden: None,
            last_logits: None,
            rows: rustc_hash::FxHashMap::default(),
            store,
            usage: Usage::default(),
        }
    }

    /// Sets the branch store's budget in bytes (0 turns it off); empties it.
    pub fn set_branch_store_bytes(&mut self, bytes: usize) {
        self.store = BranchStore::new(self.cache.position_len(), bytes);
    }

    /// Bytes held by the branch store.
    pub fn branch_store_bytes(&self) -> usize {
        self.store.rows.len() * std::mem::size_of::<f32>()
    }

    /// The weights, to share with another model ([`LocalModel::with_shared_weights`]).
    pub fn weights(&self) -> &Arc<LlamaModel> {
        &self.model
    }

    /// The tokenizer, to share with another model ([`LocalModel::with_shared_weights`]).
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

    /// Empties the cache and the branch store (the next request recomputes from the first
    /// token).
    pub fn clear_cache(&mut self) {
        self.cache.clear();
        self.cached.clear();
        self.last_hidden = None;
        self.last_logits = None;
        self.store.clear();
    }

    /// The raw logits of the token after `tokens`, through the prefix cache.
    pub fn next_logits(&mut self, tokens: &[TokenId]) -> Result<&[f32], LmError> {
        self.advance(tokens)?;
        if self.last_logits.is_none() {
            let logits = self.model.output_logits(self.last_hidden.as_deref().unwrap_or_default())?;
            self.last_logits = Some(logits);
        }
        Ok(self.last_logits.as_deref().unwrap_or_default())
    }

    /// The logits of `allowed` only, after `tokens`: each row of the output head dotted with the
    /// final hidden state in `f32` ([`LlamaModel::output_row`]; rows dequantized once and kept).
    /// A constrained prior needs no other logit (Eq. 8's normaliser is over the allowed tokens),
    /// so the full head, a large share of a step for a small model, is skipped.
    pub fn logits_among(&mut self, tokens: &[TokenId], allowed: &[TokenId]) -> Result<Vec<f32>, LmError> {
        let size = self.tokenizer.vocabulary().len().min(self.model.vocabulary_size());
        if let Some(&id) = allowed.iter().find(|&&id| id as usize >= size) {
            return Err(LmError::TokenOutOfRange { id, size });
        }
        self.advance(tokens)?;
        if self.rows.len() + allowed.len() > MAX_KEPT_ROWS {
            self.rows.clear();
        }
        let hidden = self.last_hidden.as_deref().unwrap_or_default();
        let mut logits = Vec::with_capacity(allowed.len());
        for &token in allowed {
            let row = match self.rows.entry(token) {
                std::collections::hash_map::Entry::Occupied(row) => row.into_mut(),
                std::collections::hash_map::Entry::Vacant(slot) => slot.insert(self.model.output_row(token)?.into_boxed_slice()),
            };
            logits.push(row.iter().zip(hidden).map(|(w, h)| w * h).sum());
        }
        Ok(logits)
    }

    /// Brings the cache to `tokens` (prefix cache, then branch store, then the model for the
    /// rest, at least the last token) and leaves the final hidden state after them.
    fn advance(&mut self, tokens: &[TokenId]) -> Result<(), LmError> {
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
        if common == tokens.len() && common == self.cached.len() && self.last_hidden.is_some() {
            self.usage.cache_hits += 1;
            self.usage.tokens_reused += tokens.len() as u64;
            return Ok(());
        }
        // At least the last token is run, so that its hidden state exists.
        let mut keep = common.min(tokens.len() - 1);
        self.cache.truncate(keep);
        self.cached.truncate(keep);
        self.last_hidden = None;
        self.last_logits = None;
        // Positions past the common prefix that an earlier request computed: copied back.
        self.store.walk(tokens);
        let restore = self.store.path.len().min(tokens.len() - 1);
        if restore > keep {
            for pos in keep..restore {
                self.cache.push_position(self.store.row(self.store.path[pos]));
            }
            self.cached.extend_from_slice(&tokens[keep..restore]);
            keep = restore;
        }
        let hidden = self.model.forward_hidden(&mut self.cache, &tokens[keep..])?;
        self.store.insert(tokens, &self.cache);
        self.cached.extend_from_slice(&tokens[keep..]);
        self.usage.forward_calls += 1;
        self.usage.tokens_prefilled += (tokens.len() - keep) as u64;
        self.usage.tokens_reused += keep as u64;
        self.last_hidden = Some(hidden);
        Ok(())
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

    /// Only the allowed tokens' logits are computed ([`LocalModel::logits_among`]).
    fn next_logprobs_among(&mut self, tokens: &[TokenId], allowed: &[TokenId]) -> Result<Prior, LmError> {
        let size = self.tokenizer.vocabulary().len().min(self.model.vocabulary_size());
        let unique = Prior::distinct_allowed(allowed, size)?;
        let logits = self.logits_among(tokens, &unique)?;
        Ok(Prior::from_logits(unique, &logits))
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}
