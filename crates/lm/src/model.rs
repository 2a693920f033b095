//! The `LanguageModel` trait that the planner's search talks to, the distributions it returns,
//! and the usage counters every backend keeps.

use serde::Serialize;

use crate::error::LmError;
use crate::tokenizer::Tokenizer;
use crate::vocabulary::{TokenId, Vocabulary};

/// A next-token distribution, as natural logarithms.
#[derive(Debug, Clone, PartialEq)]
pub enum Logprobs {
    /// log p(t) for every token t of the vocabulary (local and uniform backends).
    Dense(Vec<f32>),
    /// The top tokens of a served model, by descending log p; tokens not listed share what is
    /// left of the mass, `1 − Σ p`.
    Sparse {
        /// The listed tokens with their log p, each once, most likely first.
        top: Vec<(TokenId, f32)>,
        /// Tokens in the whole vocabulary, listed or not.
        vocabulary_size: usize,
    },
}

/// A prior over the tokens a constraint allows, renormalised over them (paper Eq. 8):
/// `log p_C(t) = log p(t) − log Σ_{u ∈ C} p(u)` for `t ∈ C`.
#[derive(Debug, Clone, PartialEq)]
pub struct Prior {
    /// The allowed tokens, each once, in the order first given.
    pub tokens: Vec<TokenId>,
    /// `log p_C` of each of `tokens`; `exp` of them sums to 1.
    pub logprobs: Vec<f32>,
    /// How many of `tokens` had no probability from the model and got an estimate (a served
    /// model's top-k that missed them; see [`Logprobs::among`]). 0 for a dense distribution.
    pub estimated: usize,
}

impl Prior {
    /// The prior of distinct `tokens` from their raw logits: the log-softmax over them alone
    /// (accumulated in f64); uniform if no logit is finite.
    pub fn from_logits(tokens: Vec<TokenId>, logits: &[f32]) -> Prior {
        let raw: Vec<f64> = logits.iter().map(|&l| l as f64).collect();
        Prior::normalised(tokens, &raw, 0)
    }

    /// `raw` (unnormalised log-weights of `tokens`) renormalised over them; uniform if none is
    /// finite (every allowed token has probability 0 under the model).
    fn normalised(tokens: Vec<TokenId>, raw: &[f64], estimated: usize) -> Prior {
        let max = raw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let logprobs = if max.is_finite() {
            let log_sum = max + raw.iter().map(|l| (l - max).exp()).sum::<f64>().ln();
            raw.iter().map(|l| (l - log_sum) as f32).collect()
        } else {
            vec![-(tokens.len() as f32).ln(); tokens.len()]
        };
        Prior { tokens, logprobs, estimated }
    }

    /// `allowed` without repeats, in the order first given, each checked against a vocabulary
    /// of `size` tokens; at least one.
    pub(crate) fn distinct_allowed(allowed: &[TokenId], size: usize) -> Result<Vec<TokenId>, LmError> {
        let mut tokens = Vec::with_capacity(allowed.len());
        let mut seen = rustc_hash::FxHashSet::default();
        for &t in allowed {
            if t as usize >= size {
                return Err(LmError::TokenOutOfRange { id: t, size });
            }
            if seen.insert(t) {
                tokens.push(t);
            }
        }
        if tokens.is_empty() {
            return Err(LmError::NoAllowedTokens);
        }
        Ok(tokens)
    }

    /// `p_C(t)` for each allowed token, in the order of `tokens`.
    pub fn probabilities(&self) -> Vec<f32> {
        self.logprobs.iter().map(|l| l.exp()).collect()
    }

    /// The most likely allowed token (the first of equals).
    pub fn argmax(&self) -> Option<TokenId> {
        let mut best: Option<(TokenId, f32)> = None;
        for (&t, &l) in self.tokens.iter().zip(&self.logprobs) {
            if best.is_none_or(|(_, b)| l > b) {
                best = Some((t, l));
            }
        }
        best.map(|(t, _)| t)
    }
}

/// The smallest probability given to a token that a sparse distribution leaves out and whose
/// share of the leftover mass is zero: it keeps log p finite.
const FLOOR_PROBABILITY: f64 = 1e-30;

impl Logprobs {
    /// The log-softmax of raw logits (accumulated in f64).
    pub fn from_logits(logits: &[f32]) -> Self {
        let max = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        if !max.is_finite() {
            let uniform = -(logits.len() as f32).ln();
            return Logprobs::Dense(vec![uniform; logits.len()]);
        }
        let sum: f64 = logits.iter().map(|&l| ((l - max) as f64).exp()).sum();
        let log_sum = max as f64 + sum.ln();
        Logprobs::Dense(logits.iter().map(|&l| (l as f64 - log_sum) as f32).collect())
    }

    /// Tokens in the vocabulary the distribution is over: valid ids are `0..vocabulary_size`.
    pub fn vocabulary_size(&self) -> usize {
        match self {
            Logprobs::Dense(values) => values.len(),
            Logprobs::Sparse { vocabulary_size, .. } => *vocabulary_size,
        }
    }

    /// log p(t) where the distribution knows it (a sparse one knows only its top tokens).
    pub fn get(&self, token: TokenId) -> Option<f32> {
        match self {
            Logprobs::Dense(values) => values.get(token as usize).copied(),
            Logprobs::Sparse { top, .. } => top.iter().find(|(t, _)| *t == token).map(|&(_, l)| l),
        }
    }

    /// The most likely token (the lowest id among equals).
    pub fn argmax(&self) -> Option<TokenId> {
        match self {
            Logprobs::Dense(values) => {
                let mut best: Option<(usize, f32)> = None;
                for (i, &l) in values.iter().enumerate() {
                    if best.is_none_or(|(_, b)| l > b) {
                        best = Some((i, l));
                    }
                }
                best.map(|(i, _)| i as TokenId)
            }
            Logprobs::Sparse { top, .. } => {
                let mut best: Option<(TokenId, f32)> = None;
                for &(t, l) in top {
                    if best.is_none_or(|(bt, b)| l > b || (l == b && t < bt)) {
                        best = Some((t, l));
                    }
                }
                best.map(|(t, _)| t)
            }
        }
    }

    /// Renormalises over `allowed` (duplicates ignored): the constrained prior of paper Eq. 8.
    ///
    /// Exact for a dense distribution. For a sparse one, an allowed token outside the top-k has
    /// no probability from the model; it is given the leftover mass spread evenly over every
    /// unlisted token, `(1 − Σ_top p) / (V − k)`, capped at the smallest listed probability (an
    /// unlisted token cannot be likelier than a listed one) and floored at 1e-30. Such tokens are
    /// counted in [`Prior::estimated`]. The estimate keeps their order among themselves flat,
    /// so a search relying on it should ask for a top-k at least as large as the allowed set.
    pub fn among(&self, allowed: &[TokenId]) -> Result<Prior, LmError> {
        let tokens = Prior::distinct_allowed(allowed, self.vocabulary_size())?;
        let mut estimated = 0;
        let raw: Vec<f64> = match self {
            Logprobs::Dense(values) => tokens.iter().map(|&t| values[t as usize] as f64).collect(),
            Logprobs::Sparse { top, vocabulary_size } => {
                let listed: f64 = top.iter().map(|&(_, l)| (l as f64).exp()).sum();
                let unlisted = vocabulary_size.saturating_sub(top.len()).max(1) as f64;
                let smallest = top.iter().map(|&(_, l)| (l as f64).exp()).fold(1.0f64, f64::min);
                let share = ((1.0 - listed).max(0.0) / unlisted).min(smallest).max(FLOOR_PROBABILITY);
                tokens
                    .iter()
                    .map(|&t| match top.iter().find(|(u, _)| *u == t) {
                        Some(&(_, l)) => l as f64,
                        None => {
                            estimated += 1;
                            share.ln()
                        }
                    })
                    .collect()
            }
        };
        Ok(Prior::normalised(tokens, &raw, estimated))
    }
}

/// Work done by a backend since it was made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Usage {
    /// Model evaluations actually run: forward passes, or HTTP requests to a server.
    pub forward_calls: u64,
    /// Token positions pushed through the model (new suffixes; for a server, its prompt tokens).
    pub tokens_prefilled: u64,
    /// Token positions served from the prefix cache instead of recomputed.
    pub tokens_reused: u64,
    /// Next-token distributions returned: each call is one output token, as an API with
    /// `max_tokens = 1` bills it. Summed over all calls, the paper's "generated tokens".
    pub tokens_generated: u64,
    /// Calls answered entirely from the cache (the same sequence as the last one).
    pub cache_hits: u64,
}

impl Usage {
    /// The counts added since `earlier` (a snapshot of the same backend).
    pub fn since(&self, earlier: &Usage) -> Usage {
        Usage {
            forward_calls: self.forward_calls - earlier.forward_calls,
            tokens_prefilled: self.tokens_prefilled - earlier.tokens_prefilled,
            tokens_reused: self.tokens_reused - earlier.tokens_reused,
            tokens_generated: self.tokens_generated - earlier.tokens_generated,
            cache_hits: self.cache_hits - earlier.cache_hits,
        }
    }
}

/// A language model as the planner sees it: a vocabulary, and the next-token distribution after
/// any token sequence. Backends keep a prefix cache, so that a sequence sharing a prefix with the
/// previous one pays only for its new suffix, and a sibling branch rewinds instead of recomputing.
pub trait LanguageModel {
    /// The model's tokenizer (text ⇄ ids, chat template).
    fn tokenizer(&self) -> &Tokenizer;

    /// The distribution of the token after `tokens` (at least one token).
    fn next_logprobs(&mut self, tokens: &[TokenId]) -> Result<Logprobs, LmError>;

    /// The distribution after `tokens` renormalised over `allowed` (paper Eq. 8). Backends that
    /// can mask on their side (vLLM's `allowed_token_ids`) override this.
    fn next_logprobs_among(&mut self, tokens: &[TokenId], allowed: &[TokenId]) -> Result<Prior, LmError> {
        self.next_logprobs(tokens)?.among(allowed)
    }

    /// Counters since the backend was made.
    fn usage(&self) -> Usage;

    /// The tokenizer's vocabulary: each id's bytes and kind, and the stop tokens.
    fn vocabulary(&self) -> &Vocabulary {
        self.tokenizer().vocabulary()
    }

    /// The token ids of `text` by the model's tokenizer, with no BOS added
    /// ([`Tokenizer::encode`]).
    fn encode(&self, text: &str) -> Result<Vec<TokenId>, LmError> {
        self.tokenizer().encode(text)
    }

    /// The bytes of `ids` (control tokens spell themselves); an id outside the vocabulary is
    /// [`LmError::TokenOutOfRange`].
    fn decode(&self, ids: &[TokenId]) -> Result<Vec<u8>, LmError> {
        self.tokenizer().decode(ids)
    }

    /// The prompt text for a system and a user message, by the model's chat template.
    fn chat_prompt(&self, system: &str, user: &str) -> Result<String, LmError> {
        self.tokenizer().chat_prompt(system, user)
    }
}

/// Greedy decoding: up to `max_tokens` most-likely tokens after `prompt`, stopping before a stop
/// token (which is not returned).
pub fn generate_greedy(model: &mut dyn LanguageModel, prompt: &[TokenId], max_tokens: usize) -> Result<Vec<TokenId>, LmError> {
    let mut sequence = prompt.to_vec();
    let mut out = Vec::new();
    while out.len() < max_tokens {
        let next = model.next_logprobs(&sequence)?.argmax().ok_or(LmError::EmptySequence)?;
        if model.vocabulary().is_stop(next) {
            break;
        }
        out.push(next);
        sequence.push(next);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    #[test]
    fn log_softmax_sums_to_one_and_keeps_order() {
        let Logprobs::Dense(values) = Logprobs::from_logits(&[1.0, 3.0, 2.0, -1000.0]) else { unreachable!() };
        let total: f32 = values.iter().map(|l| l.exp()).sum();
        assert!(close(total, 1.0));
        assert!(values[1] > values[2] && values[2] > values[0]);
        assert_eq!(Logprobs::Dense(values).argmax(), Some(1));
    }

    #[test]
    fn dense_prior_is_the_renormalised_distribution() {
        let probs = [0.5f32, 0.2, 0.2, 0.1];
        let dist = Logprobs::Dense(probs.iter().map(|p| p.ln()).collect());
        let prior = dist.among(&[1, 3, 1]).expect("valid");
        assert_eq!(prior.tokens, vec![1, 3]);
        let p = prior.probabilities();
        assert!(close(p[0], 2.0 / 3.0) && close(p[1], 1.0 / 3.0));
        assert_eq!(prior.estimated, 0);
        assert_eq!(prior.argmax(), Some(1));
        assert!(matches!(dist.among(&[]), Err(LmError::NoAllowedTokens)));
        assert!(matches!(dist.among(&[4]), Err(LmError::TokenOutOfRange { id: 4, size: 4 })));
    }

    #[test]
    fn sparse_prior_estimates_unlisted_tokens_from_the_leftover_mass() {
        // Vocabulary of 10; the top-2 hold 0.6 + 0.2; 0.2 is left for 8 unlisted tokens.
        let dist = Logprobs::Sparse { top: vec![(4, 0.6f32.ln()), (7, 0.2f32.ln())], vocabulary_size: 10 };
        let prior = dist.among(&[7, 2]).expect("valid");
        assert_eq!(prior.estimated, 1);
        let p = prior.probabilities();
        assert!(close(p[0], 0.2 / 0.225) && close(p[1], 0.025 / 0.225), "{p:?}");
        // Only listed tokens: exact.
        let prior = dist.among(&[4, 7]).expect("valid");
        assert_eq!(prior.estimated, 0);
        assert!(close(prior.probabilities()[0], 0.75));
        // No leftover mass: the unlisted allowed tokens share the floor, uniformly.
        let full = Logprobs::Sparse { top: vec![(0, 0.0)], vocabulary_size: 3 };
        let prior = full.among(&[1, 2]).expect("valid");
        assert!(close(prior.probabilities()[0], 0.5));
        assert_eq!(prior.estimated, 2);
    }

    #[test]
    fn usage_differences() {
        let a = Usage { forward_calls: 2, tokens_prefilled: 10, tokens_reused: 3, tokens_generated: 2, cache_hits: 0 };
        let b = Usage { forward_calls: 5, tokens_prefilled: 14, tokens_reused: 30, tokens_generated: 6, cache_hits: 1 };
        assert_eq!(b.since(&a), Usage { forward_calls: 3, tokens_prefilled: 4, tokens_reused: 27, tokens_generated: 4, cache_hits: 1 });
    }
}
