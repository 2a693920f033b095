//! The settings and results every Phase II strategy shares: the condition ([`Mode`]), the
//! budget, the MCTS and decoding settings, why a run stopped, its counters, its errors. A leaf
//! module: the strategies (`decode`'s linear decoders, `search`'s MCTS) import it, it imports
//! none of them.

use std::time::Duration;

use grounding::ActionId;
pub use heuristics::search::Clock;
use lm::{LmError, Usage};
use serde::Serialize;
use transition_model::State;

use crate::sampling::SamplingConfig;
use crate::summary::{Backup, TreeSummary};

/// How the next token is chosen.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Strategy {
    /// The most likely token (the lowest id among equals).
    Greedy,
    /// A token sampled from the distribution.
    Sample(SamplingConfig),
    /// Token-level MCTS (paper Eq. 9-10).
    Mcts(MctsConfig),
}

/// A Phase II condition: whether the mask applies, and how tokens are chosen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mode {
    /// Whether each token is masked to the continuations of applicable actions.
    pub constrained: bool,
    /// How the next token is chosen.
    pub strategy: Strategy,
}

/// The Phase II conditions by command-line name: the variants' names, kebab-case
/// (`constrained-mcts`, ..., `sample` for unconstrained sampling).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    strum::Display,
    strum::EnumString,
    strum::IntoStaticStr,
    strum::VariantNames,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case", parse_err_ty = heuristics::UnknownName, parse_err_fn = ModeName::unknown)]
pub enum ModeName {
    /// Masked tokens, chosen by MCTS (the paper's method).
    ConstrainedMcts,
    /// Masked tokens, the most likely each time.
    ConstrainedGreedy,
    /// Any token, chosen by MCTS; the text is parsed into actions line by line.
    UnconstrainedMcts,
    /// Any token, the most likely each time.
    UnconstrainedGreedy,
    /// Any token, sampled.
    Sample,
    /// Masked tokens, sampled.
    ConstrainedSample,
}

impl ModeName {
    fn unknown(given: &str) -> heuristics::UnknownName {
        heuristics::UnknownName::of::<ModeName>("mode", given)
    }

    /// The mode, with default MCTS and sampling settings.
    pub fn mode(self) -> Mode {
        let (constrained, strategy) = match self {
            ModeName::ConstrainedMcts => (true, Strategy::Mcts(MctsConfig::default())),
            ModeName::ConstrainedGreedy => (true, Strategy::Greedy),
            ModeName::UnconstrainedMcts => (false, Strategy::Mcts(MctsConfig::default())),
            ModeName::UnconstrainedGreedy => (false, Strategy::Greedy),
            ModeName::Sample => (false, Strategy::Sample(SamplingConfig::default())),
            ModeName::ConstrainedSample => (true, Strategy::Sample(SamplingConfig::default())),
        };
        Mode { constrained, strategy }
    }
}

impl Mode {
    /// The command-line names, in [`ModeName`]'s order.
    pub const NAMES: &'static [&'static str] = <ModeName as strum::VariantNames>::VARIANTS;

    /// A mode by command-line name, with default MCTS and sampling settings.
    pub fn from_name(name: &str) -> Option<Mode> {
        name.parse::<ModeName>().ok().map(ModeName::mode)
    }

    /// Which condition this is.
    pub fn kind(&self) -> ModeName {
        match (self.constrained, &self.strategy) {
            (true, Strategy::Mcts(_)) => ModeName::ConstrainedMcts,
            (true, Strategy::Greedy) => ModeName::ConstrainedGreedy,
            (false, Strategy::Mcts(_)) => ModeName::UnconstrainedMcts,
            (false, Strategy::Greedy) => ModeName::UnconstrainedGreedy,
            (false, Strategy::Sample(_)) => ModeName::Sample,
            (true, Strategy::Sample(_)) => ModeName::ConstrainedSample,
        }
    }

    /// The command-line name.
    pub fn name(&self) -> &'static str {
        self.kind().into()
    }
}

/// Limits on one decoding run. Whichever is reached first ends it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Budget {
    /// MCTS simulations.
    pub simulations: Option<u64>,
    /// Time (the paper: 250 s per task of wall-clock time), read on `clock`.
    pub time_limit: Option<Duration>,
    /// What `time_limit` is read on: the wall clock (the paper's), or the process's processor
    /// time, which other work on the machine does not spend ([`Clock`]).
    pub clock: Clock,
    /// Next-token distributions requested from the model (tokens it generates).
    pub model_calls: Option<u64>,
    /// Tokens of one plan (the paper: 512): greedy and sampled decoding stop there, and MCTS
    /// makes a prefix of this many tokens a leaf (closed, valued where it stands).
    pub max_tokens: usize,
    /// Actions in one plan: a longer prefix is a leaf of the search.
    pub max_actions: usize,
}

impl Default for Budget {
    fn default() -> Self {
        Budget {
            simulations: None,
            time_limit: Some(Duration::from_secs(250)),
            clock: Clock::Wall,
            model_calls: None,
            max_tokens: 512,
            max_actions: 64,
        }
    }
}

/// Which token sequences spell an action under the constraint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, strum::EnumString, strum::IntoStaticStr, strum::VariantNames)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case", parse_err_ty = heuristics::UnknownName, parse_err_fn = Tokenization::unknown)]
pub enum Tokenization {
    /// The tokenizer's own encoding of each action's line (paper Eq. 7): one token path per
    /// action. See [`crate::canonical`].
    #[default]
    Canonical,
    /// Any token sequence whose bytes spell the line ([`token_constraint`]'s byte-level masks).
    Any,
}

impl Tokenization {
    fn unknown(given: &str) -> heuristics::UnknownName {
        heuristics::UnknownName::of::<Tokenization>("tokenization", given)
    }
}

/// Everything one decoding run needs besides the task and the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecodeConfig {
    /// The condition: masked or not, and the strategy.
    pub mode: Mode,
    /// The limits of the run.
    pub budget: Budget,
    /// Constrained modes: canonical tokenizations only, or any.
    pub tokenization: Tokenization,
    /// Stop as soon as the goal holds after an action (the environment ends an episode at
    /// success, so a plan executed open-loop is judged at its first goal state).
    pub stop_at_goal: bool,
}

impl DecodeConfig {
    /// `mode` with the default budget, canonical tokenizations, and a stop at the goal.
    pub fn new(mode: Mode) -> DecodeConfig {
        DecodeConfig { mode, budget: Budget::default(), tokenization: Tokenization::default(), stop_at_goal: true }
    }
}

/// Why decoding stopped; displayed as serialised (`cpu-time`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, strum::Display)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum StopReason {
    /// A prefix reached the goal.
    Goal,
    /// The model ended the plan (end of sequence or `DONE`) short of the goal.
    EndOfPlan,
    /// Unconstrained text named an action that is not applicable (or no action).
    InvalidAction,
    /// A greedy or sampled plan hit `max_tokens`.
    MaxTokens,
    /// The plan reached `max_actions` without the goal.
    MaxActions,
    /// No action applies and the goal does not hold.
    DeadEnd,
    /// MCTS ran [`Budget::simulations`] simulations.
    Simulations,
    /// The time limit, on the wall clock.
    WallClock,
    /// The time limit, on the processor-time clock ([`Clock::Cpu`]).
    CpuTime,
    /// The decoder asked the model for [`Budget::model_calls`] distributions (tokens the mask
    /// forced are not counted).
    ModelCalls,
    /// MCTS explored every branch its width and limits allow.
    Exhausted,
}

impl StopReason {
    /// Whether the run stopped because a budget ran out, the tree was searched through or no
    /// action applied, rather than because a plan ended: a run that stops so without a goal
    /// plan has found none (its best partial plan is not one to send).
    pub fn searched_out(self) -> bool {
        match self {
            StopReason::Simulations
            | StopReason::WallClock
            | StopReason::CpuTime
            | StopReason::ModelCalls
            | StopReason::Exhausted
            | StopReason::DeadEnd => true,
            StopReason::Goal | StopReason::EndOfPlan | StopReason::InvalidAction | StopReason::MaxTokens | StopReason::MaxActions => false,
        }
    }
}

/// The first action of an unconstrained plan that could not be executed.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct InvalidStep {
    /// 0-based index of the step in the plan.
    pub step: usize,
    /// The offending text: the line that names no applicable action (trimmed, lossy UTF-8), a
    /// special token's spelling, or a line past [`crate::cursor::MAX_LINE_BYTES`].
    pub text: String,
}

/// Counters of one run.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Stats {
    /// MCTS simulations started (0 for greedy decoding and sampling).
    pub simulations: u64,
    /// Search-tree nodes (token prefixes) created.
    pub nodes: u64,
    /// Token positions the decoder appended (in MCTS, over all simulations).
    pub decoded_tokens: u64,
    /// Tokens appended without asking the model: the mask allowed exactly one.
    pub forced_tokens: u64,
    /// The model's work (forward calls, positions prefilled / reused, distributions returned).
    pub usage: Usage,
    /// Heuristic evaluations run while decoding (cache misses). The final plan's
    /// [`Outcome::value`](crate::Outcome::value) is computed after these counts are taken and is
    /// not among them, so a greedy decode may show 0 beside a value.
    pub heuristic_evaluations: u64,
    /// States whose heuristic was asked for while decoding (cache hits and goal states
    /// included; the final value's lookup not counted, as above).
    pub heuristic_lookups: u64,
    /// Real time the run took (whatever clock its limit was read on).
    pub millis: f64,
}

/// The result of one decoding run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// The condition's command-line name ([`Mode::name`]).
    pub mode: &'static str,
    /// The plan's actions (for an invalid unconstrained plan, the valid prefix).
    #[serde(skip)]
    pub plan: Vec<ActionId>,
    /// The plan as written, one action a line.
    pub lines: Vec<String>,
    /// Every action applicable in turn (always true for constrained modes).
    pub valid: bool,
    /// Valid, and the goal holds after the last action.
    pub solved: bool,
    /// The first step that could not be executed (unconstrained modes only).
    pub invalid: Option<InvalidStep>,
    /// Why decoding stopped.
    pub stop: StopReason,
    /// The text greedy decoding or sampling wrote (lossy UTF-8; special tokens spelled out).
    /// MCTS writes many texts: `None`.
    pub text: Option<String>,
    /// Eq. 10 of the plan (`None` for an invalid plan or a dead end).
    pub value: Option<f64>,
    /// The run's counters.
    pub stats: Stats,
    /// The top of the search tree: `None` for greedy decoding and sampling, which build no
    /// tree, and for a search that never started (the goal or a dead end at the root).
    pub tree: Option<TreeSummary>,
}

/// Why decoding failed (as opposed to producing a bad plan, which is an [`Outcome`]).
///
/// Each variant that wraps another error says it in its own message and gives no `source`, so
/// that a chain printed whole (`anyhow`'s `{:#}`) says it once.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// The language model failed (a forward pass, a server request, the tokenizer).
    #[error("language model: {0}")]
    Model(LmError),
    /// A state's action texts cannot make a byte-level language (an empty text or separator, a
    /// text holding the separator or starting with the end marker).
    #[error("action language: {0}")]
    Language(token_constraint::LanguageError),
    /// A bug: the decoder wrote a token the constraint does not allow.
    #[error("internal error: the decoder wrote a token the constraint refuses: {0}")]
    Token(token_constraint::PlanTokenError),
    /// The model and the constraint's vocabulary differ in size (the vocabulary was made for
    /// another model).
    #[error("the model's vocabulary has {model} tokens, the constraint's {constraint}")]
    VocabularyMismatch {
        /// Tokens in the model's vocabulary.
        model: usize,
        /// Tokens in the constraint's vocabulary.
        constraint: usize,
    },
    /// The prompt has no token: the model needs at least one to predict from.
    #[error("the prompt is empty")]
    EmptyPrompt,
    /// An MCTS setting that [`MctsConfig::check`] refuses.
    #[error("bad setting: {0}")]
    Config(String),
}

impl From<LmError> for DecodeError {
    fn from(error: LmError) -> Self {
        DecodeError::Model(error)
    }
}

impl From<token_constraint::LanguageError> for DecodeError {
    fn from(error: token_constraint::LanguageError) -> Self {
        DecodeError::Language(error)
    }
}

impl From<token_constraint::PlanTokenError> for DecodeError {
    fn from(error: token_constraint::PlanTokenError) -> Self {
        DecodeError::Token(error)
    }
}

/// The search's settings (paper Appendix A.4).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MctsConfig {
    /// Children kept per expanded node: the most likely allowed tokens.
    pub width: usize,
    /// `c_explore`, the constant part of the PUCB coefficient.
    pub exploration: f64,
    /// `c_base`: the coefficient grows by `ln((N + c_base + 1) / c_base)`.
    pub base: f64,
    /// Tokens one rollout may write before it is valued where it stands.
    pub tokens_per_expansion: usize,
    /// Close a prefix whose state repeats an earlier state of the same prefix: with
    /// non-negative costs such a plan is never needed.
    pub prune_cycles: bool,
    /// Close a prefix whose state another prefix of the tree reached first with no more
    /// actions (a transposition): every continuation of it is open to the other prefix at no
    /// higher cost. Implies `prune_cycles`.
    pub prune_transpositions: bool,
    /// How a node's value summarises the values backed up through it.
    pub backup: Backup,
    /// Over which values `Q` is min-max normalised into `[0, 1]`.
    pub normalization: Normalization,
    /// `ε`: a node's children take the prior `(1 − ε)·p + ε/k` (`k` children) instead of the
    /// model's `p`. 0 (the default) is the paper's prior (Eq. 8). A small model can give the
    /// right token a prior so small that PUCB tries it only after thousands of visits to its
    /// siblings; mixing in the uniform over the kept children bounds that wait, as AlphaZero's
    /// root noise does. The children kept (the `width` most likely) are the same either way.
    pub prior_mix: f64,
    /// Divide each open child's prior by the total prior of the node's open children in
    /// PUCB, so that `p(v | n)` is the model's belief in `v` given that `v` is still open.
    /// Without it, a closed child keeps its share: once a token the model is sure of closes
    /// (SmolLM2 gives ALFWorld plans' end token 0.95 at the root), its siblings share what is
    /// left and PUCB hardly explores them. Not in the paper, whose Eq. 9 does not say what
    /// happens to a closed child's prior.
    pub renormalize_prior: bool,
}

/// The range `Q` is min-max normalised over, so that it and the prior term are on one scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, strum::EnumString, strum::IntoStaticStr, strum::VariantNames)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case", parse_err_ty = heuristics::UnknownName, parse_err_fn = Normalization::unknown)]
pub enum Normalization {
    /// Every value the tree has backed up (MuZero).
    Tree,
    /// The visited open children of the node being selected from: the best is 1, the worst
    /// 0, whatever the spread of values elsewhere in the tree.
    Siblings,
}

impl Normalization {
    fn unknown(given: &str) -> heuristics::UnknownName {
        heuristics::UnknownName::of::<Normalization>("normalization", given)
    }
}

impl MctsConfig {
    /// Checks the settings PUCB needs to give finite scores: `exploration` finite and at
    /// least 0, `base` finite and above 0 (at 0 the coefficient is infinite and every score
    /// NaN), `prior_mix` in `[0, 1]`, `width` at least 1.
    pub fn check(&self) -> Result<(), DecodeError> {
        let bad = |what: String| Err(DecodeError::Config(what));
        if !(self.exploration.is_finite() && self.exploration >= 0.0) {
            return bad(format!("exploration {} is not a finite number at least 0", self.exploration));
        }
        if !(self.base.is_finite() && self.base > 0.0) {
            return bad(format!("base {} is not a finite number above 0", self.base));
        }
        if !(0.0..=1.0).contains(&self.prior_mix) {
            return bad(format!("prior mix {} is not in [0, 1]", self.prior_mix));
        }
        if self.width == 0 {
            return bad("width 0 keeps no child".into());
        }
        Ok(())
    }
}

impl Default for MctsConfig {
    fn default() -> Self {
        MctsConfig {
            width: 16,
            exploration: 2.5,
            base: 10.0,
            tokens_per_expansion: 128,
            prune_cycles: true,
            prune_transpositions: true,
            backup: Backup::Max,
            normalization: Normalization::Siblings,
            prior_mix: 0.0,
            renormalize_prior: false,
        }
    }
}

/// What a strategy returns.
#[derive(Debug)]
pub(crate) struct Run {
    pub plan: Vec<ActionId>,
    pub end_state: State,
    pub invalid: Option<InvalidStep>,
    pub stop: StopReason,
    pub text: Option<String>,
    pub tree: Option<TreeSummary>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wrapped error is said once when the chain is printed whole: the wrapper's message
    /// holds it, and it is no `source` (it was both, and anyhow's `{:#}` printed a server's
    /// error twice).
    #[test]
    fn a_wrapped_error_is_said_once() {
        let error = DecodeError::from(LmError::NoChatTemplate);
        assert!(std::error::Error::source(&error).is_none());
        assert_eq!(error.to_string(), format!("language model: {}", LmError::NoChatTemplate));
    }
}
