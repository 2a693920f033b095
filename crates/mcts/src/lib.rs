//! Phase II of the paper: a language model writes the plan token by token under the
//! state-dependent mask of [`token_constraint`], and token-level MCTS (PUCB with the
//! constrained prior, Eq. 8-9; planning-heuristic values, Eq. 10) chooses among executable
//! continuations. The ablations (unconstrained / constrained × greedy / sampling / MCTS)
//! share one [`Decoder`]: the same [`cursor::Cursor`] steps every token, the same
//! distribution request feeds every strategy.
//!
//! ```no_run
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

pub mod canonical;
mod config;
pub mod cursor;
mod decode;
pub mod prompt;
mod sampling;
mod search;
mod step;
mod value;
mod vocab;

pub use config::{
    Backup, Budget, Clock, DecodeConfig, DecodeError, InvalidStep, MctsConfig, Mode, ModeName, Normalization, Outcome, RowKind, Stats,
    StopReason, Strategy, Tokenization, TreeLevel, TreeRow, TreeSummary,
};
pub use decode::Decoder;
/// The error of the option enums' `FromStr` ([`ModeName`], [`Tokenization`], [`Normalization`],
/// [`Backup`], [`Clock`]): the name given and the names there are.
pub use heuristics::UnknownName;
pub use sampling::{Sampler, SamplingConfig};
pub use value::{Evaluator, ValueConfig};
pub use vocab::constraint_vocabulary;
