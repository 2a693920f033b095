//! The uniform backend: every token equally likely. For symbolic-only runs (the constraint
//! alone chooses) and as a control for what the language model adds.

use std::sync::Arc;

use crate::error::LmError;
use crate::model::{LanguageModel, Logprobs, Prior, Usage};
use crate::tokenizer::Tokenizer;
use crate::vocabulary::TokenId;

/// p(t) = 1/|V| after any sequence; the prior over allowed tokens is uniform over them.
#[derive(Debug, Clone)]
pub struct UniformModel {
    tokenizer: Arc<Tokenizer>,
    usage: Usage,
}

impl UniformModel {
    /// Over the vocabulary of `tokenizer` (any model's: the text ⇄ id map stays meaningful).
    pub fn new(tokenizer: Arc<Tokenizer>) -> Self {
        UniformModel { tokenizer, usage: Usage::default() }
    }

    fn check(&self, tokens: &[TokenId]) -> Result<(), LmError> {
        if tokens.is_empty() {
            return Err(LmError::EmptySequence);
        }
        tokens.iter().try_for_each(|&t| self.tokenizer.vocabulary().check(t))
    }
}

impl LanguageModel for UniformModel {
    fn tokenizer(&self) -> &Tokenizer {
        &self.tokenizer
    }

    fn next_logprobs(&mut self, tokens: &[TokenId]) -> Result<Logprobs, LmError> {
        self.check(tokens)?;
        self.usage.tokens_generated += 1;
        let size = self.tokenizer.vocabulary().len();
        Ok(Logprobs::Dense(vec![-(size as f32).ln(); size]))
    }

    /// Uniform over the allowed tokens, without building the full distribution.
    fn next_logprobs_among(&mut self, tokens: &[TokenId], allowed: &[TokenId]) -> Result<Prior, LmError> {
        self.check(tokens)?;
        let size = self.tokenizer.vocabulary().len();
        let mut unique = Vec::with_capacity(allowed.len());
        let mut seen = rustc_hash::FxHashSet::default();
        for &t in allowed {
            self.tokenizer.vocabulary().check(t)?;
            if seen.insert(t) {
                unique.push(t);
            }
        }
        if unique.is_empty() {
            return Err(LmError::NoAllowedTokens);
        }
        debug_assert!(unique.len() <= size);
        self.usage.tokens_generated += 1;
        let logprob = -(unique.len() as f32).ln();
        Ok(Prior { logprobs: vec![logprob; unique.len()], tokens: unique, estimated: 0 })
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}
