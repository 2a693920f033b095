//! Phase II of the paper: a language model writes the plan token by token under the
//! state-dependent mask of [`token_constraint`], and token-level MCTS (PUCB with the
//! constrained prior, Eq. 8-9; planning-heuristic values, Eq. 10) chooses among executable
//! continuations. The ablations (unconstrained / constrained × greedy / sampling / MCTS)
//! share one [`Decoder`]: the same [`cursor::Cursor`] steps every token, the same
//! distribution request feeds every strategy.
//!
//! ```no_run
//! # #[cfg(feature = "decoder")]
//! # fn demo(model: &transition_model::TransitionModel, lm: &mut dyn lm::LanguageModel) -> Result<(), Box<dyn std::error::Error>> {
//! use std::sync::Arc;
//! use mcts::{DecodeConfig, Decoder, Mode, ValueConfig};
//! let spelling = transition_model::Spelling::pddl(model.task());
//! let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary())?);
//! let mut decoder = Decoder::new(model, &spelling, vocab, ValueConfig::default());
//! // A prompt's tokens as the model reads a prompt: BOS in front where it wants one. (The
//! // paper's Phase II prompt is `prompt::PlanningPrompt`, rendered by the model's template.)
//! let prompt = lm.tokenizer().encode_prompt("Plan:\n")?;
//! let config = DecodeConfig::new(Mode::from_name("constrained-mcts").unwrap());
//! let outcome = decoder.decode(lm, &prompt, &model.initial_state(), &config)?;
//! assert!(outcome.valid);
//! # Ok(()) }
//! ```
//!
//! The decoder is the default feature `decoder` (the language model, `lm`, and the token
//! masks). Without it the crate is what an episode's record and a chat planner need of Phase
//! II, with no model in its dependency tree: the planning prompt ([`prompt`], less
//! `PlanningPrompt::render`), the summary of a search tree ([`TreeSummary`], [`Backup`]) and
//! the value of a plan ([`Evaluator`]).

// Without the decoder, the crate documentation's links to it have nothing to point at.
#![cfg_attr(not(feature = "decoder"), allow(rustdoc::broken_intra_doc_links))]

#[cfg(feature = "decoder")]
pub mod canonical;
#[cfg(feature = "decoder")]
mod config;
#[cfg(feature = "decoder")]
pub mod cursor;
#[cfg(feature = "decoder")]
mod decode;
pub mod prompt;
#[cfg(feature = "decoder")]
mod sampling;
#[cfg(feature = "decoder")]
mod search;
#[cfg(feature = "decoder")]
mod step;
mod summary;
mod value;
#[cfg(feature = "decoder")]
mod vocab;

#[cfg(feature = "decoder")]
pub use config::{
    Budget, Clock, DecodeConfig, DecodeError, InvalidStep, MctsConfig, Mode, ModeName, Normalization, Outcome, Stats, StopReason, Strategy,
    Tokenization,
};
#[cfg(feature = "decoder")]
pub use decode::Decoder;
/// The error of the option enums' `FromStr` ([`Backup`], and with the decoder [`ModeName`],
/// [`Tokenization`], [`Normalization`], [`Clock`]): the name given and the names there are.
pub use heuristics::UnknownName;
#[cfg(feature = "decoder")]
pub use sampling::{Sampler, SamplingConfig};
pub use summary::{Backup, RowKind, TreeLevel, TreeRow, TreeSummary};
pub use value::{Evaluator, ValueConfig};
#[cfg(feature = "decoder")]
pub use vocab::constraint_vocabulary;
