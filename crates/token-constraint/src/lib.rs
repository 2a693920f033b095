//! State-dependent next-token masks: Eq. 7-8 of the paper at the byte level.
//!
//! At every decoding step the model may emit a token `v` only if the partial action `u`
//! followed by `v`'s bytes is still a prefix of the spelling of an action applicable in the
//! current state (then the separator), or of the end of the plan. The pieces:
//!
//! - [`Vocabulary`]: token id → bytes, special and end-of-sequence tokens marked, laid out
//!   once as a flat byte trie ([`VocabTrie`]).
//! - [`Language`]: the allowed strings of one state (a small trie, built per state), and
//!   [`Matcher`]: the position `u` in it, with [`Matcher::fill_mask`] (a paired walk of the
//!   two tries, so a mask costs the allowed tokens and their prefixes, not the vocabulary
//!   size) and [`Matcher::advance`], which reports a completed action.
//! - [`PlanLanguages`] / [`PlanConstraint`] (feature `planning`, on by default): the adapter
//!   to `transition-model`: a state and
//!   a spelling give the state's language, cached by state; completed actions are applied.
//! - `hf` (feature `hf`): a Hugging Face `tokenizer.json` to a [`Vocabulary`].
//!
//! The core never sees a model or a tokenizer library: token ids and bytes only.
//!
//! ```
//! use std::sync::Arc;
//! use token_constraint::{LanguageBuilder, LanguageConfig, Matcher, Step, Vocabulary};
//!
//! // Tokens 0..=6; token 6 is the end of sequence.
//! let vocab = Vocabulary::from_bytes(&["go", " to", " a", " b", "\n", "DONE", "</s>"], &[6]).unwrap();
//! let mut builder = LanguageBuilder::new(LanguageConfig::default());
//! let go_a = builder.push(b"go to a", false).unwrap();
//! builder.push(b"go to b", false).unwrap();
//! let mut matcher = Matcher::new(Arc::new(builder.build()));
//! // At a boundary: start an action, say DONE, or end the sequence.
//! assert_eq!(matcher.mask(&vocab).iter().collect::<Vec<_>>(), vec![0, 5, 6]);
//! for token in [0, 1] {
//!     assert_eq!(matcher.advance(&vocab, token), Ok(Step::Partial));
//! }
//! assert_eq!(matcher.mask(&vocab).iter().collect::<Vec<_>>(), vec![2, 3]);
//! matcher.advance(&vocab, 2).unwrap();
//! assert_eq!(matcher.mask(&vocab).iter().collect::<Vec<_>>(), vec![4]);
//! assert_eq!(matcher.advance(&vocab, 4), Ok(Step::Action(go_a)));
//! ```

mod language;
mod mask;
#[cfg(feature = "planning")]
mod plan;
mod trie;
mod vocab;

#[cfg(feature = "hf")]
pub mod hf;

pub use language::{Language, LanguageBuilder, LanguageConfig, LanguageError, Matcher, Step, TokenError};
pub use mask::TokenMask;
#[cfg(feature = "planning")]
pub use plan::{EndPolicy, PlanConstraint, PlanLanguages, PlanStep, PlanTokenError, StateLanguage};
pub use vocab::{Token, VocabNode, VocabTrie, Vocabulary, VocabularyError};

/// A token id, as the model numbers its vocabulary.
pub type TokenId = u32;

/// One distinct action text of a [`Language`], numbered from 0 in the order added.
pub type ChoiceId = u32;
