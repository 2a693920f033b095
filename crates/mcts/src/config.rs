//! The settings and results every Phase II strategy shares: the condition ([`Mode`]), the
//! budget, the MCTS and decoding settings, why a run stopped, its counters, its errors. A leaf
//! module: the strategies (`decode`'s linear decoders, `search`'s MCTS) import it, it imports
//! none of them.

use std::time::Duration;

use grounding::ActionId;
use lm::{LmError, Usage};
use serde::Serialize;
use transition_model::State;

use crate::sampling::SamplingConfig;

/// How the next token is chosen.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Strategy {
    /// The most likely token (the lowest id among equals).
    Greedy,
    /// A token sampled from the distribution.
    Sample(SamplingConfig),
    /// Token-level MCTS (paper Eq. 7-8).
    Mcts(MctsConfig),
}

/// A Phase II condition: whether the mask applies, and how tokens are chosen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mode {
    pub constrained: bool,
    pub strategy: Strategy,
}

impl Mode {
    /// The command-line names.
    pub const NAMES: [&'static str; 6] =
        ["constrained-mcts", "constrained-greedy", "unconstrained-mcts", "unconstrained-greedy", "sample", "constrained-sample"];

    /// A mode by command-line name, with default MCTS and sampling settings.
    pub fn from_name(name: &str) -> Option<Mode> {
        let (constrained, strategy) = match name {
            "constrained-mcts" => (true, Strategy::Mcts(MctsConfig::default())),
            "constrained-greedy" => (true, Strategy::Greedy),
            "unconstrained-mcts" => (false, Strategy::Mcts(MctsConfig::default())),
            "unconstrained-greedy" => (false, Strategy::Greedy),
            "sample" => (false, Strategy::Sample(SamplingConfig::default())),
            "constrained-sample" => (true, Strategy::Sample(SamplingConfig::default())),
            _ => return None,
        };
        Some(Mode { constrained, strategy })
    }

    /// The command-line name.
    pub fn name(&self) -> &'static str {
        match (self.constrained, &self.strategy) {
            (true, Strategy::Mcts(_)) => "constrained-mcts",
            (true, Strategy::Greedy) => "constrained-greedy",
            (false, Strategy::Mcts(_)) => "unconstrained-mcts",
            (false, Strategy::Greedy) => "unconstrained-greedy",
            (false, Strategy::Sample(_)) => "sample",
            (true, Strategy::Sample(_)) => "constrained-sample",
        }
    }
}

/// Limits on one decoding run. Whichever is reached first ends it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Budget {
    /// MCTS simulations.
    pub simulations: Option<u64>,
    /// Wall-clock time (the paper: 250 s per task).
    pub wall_clock: Option<Duration>,
    /// Next-token distributions requested from the model (tokens it generates).
    pub model_calls: Option<u64>,
    /// Tokens of one greedy or sampled plan (the paper: 512).
    pub max_tokens: usize,
    /// Actions in one plan: a longer prefix is a leaf of the search.
    pub max_actions: usize,
}

impl Default for Budget {
    fn default() -> Self {
        Budget { simulations: None, wall_clock: Some(Duration::from_secs(250)), model_calls: None, max_tokens: 512, max_actions: 64 }
    }
}

/// Which token sequences spell an action under the constraint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tokenization {
    /// The tokenizer's own encoding of each action's line (paper Eq. 5): one token path per
    /// action. See [`crate::canonical`].
    #[default]
    Canonical,
    /// Any token sequence whose bytes spell the line ([`token_constraint`]'s byte-level masks).
    Any,
}

/// Everything one decoding run needs besides the task and the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecodeConfig {
    pub mode: Mode,
    pub budget: Budget,
    /// Constrained modes: canonical tokenizations only, or any.
    pub tokenization: Tokenization,
    /// Stop as soon as the goal holds after an action (the environment ends an episode at
    /// success, so a plan executed open-loop is judged at its first goal state).
    pub stop_at_goal: bool,
}

impl DecodeConfig {
    pub fn new(mode: Mode) -> DecodeConfig {
        DecodeConfig { mode, budget: Budget::default(), tokenization: Tokenization::default(), stop_at_goal: true }
    }
}

/// Why decoding stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
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
    Simulations,
    WallClock,
    ModelCalls,
    /// MCTS explored every branch its width and limits allow.
    Exhausted,
}

/// The first action of an unconstrained plan that could not be executed.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct InvalidStep {
    /// 0-based index of the step in the plan.
    pub step: usize,
    pub text: String,
}

/// Counters of one run.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Stats {
    pub simulations: u64,
    /// Search-tree nodes (token prefixes) created.
    pub nodes: u64,
    /// Token positions the decoder appended (in MCTS, over all simulations).
    pub decoded_tokens: u64,
    /// Tokens appended without asking the model: the mask allowed exactly one.
    pub forced_tokens: u64,
    /// The model's work (forward calls, positions prefilled / reused, distributions returned).
    pub usage: Usage,
    /// Heuristic evaluations run, and states looked up (including cache hits).
    pub heuristic_evaluations: u64,
    pub heuristic_lookups: u64,
    pub millis: f64,
}

/// The result of one decoding run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
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
    pub invalid: Option<InvalidStep>,
    pub stop: StopReason,
    /// The text greedy decoding or sampling wrote (lossy UTF-8; special tokens spelled out).
    /// MCTS writes many texts: `None`.
    pub text: Option<String>,
    /// Eq. 8 of the plan (`None` for an invalid plan or a dead end).
    pub value: Option<f64>,
    pub stats: Stats,
}

/// Why decoding failed (as opposed to producing a bad plan, which is an [`Outcome`]).
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("language model: {0}")]
    Model(#[from] LmError),
    #[error("action language: {0}")]
    Language(#[from] token_constraint::LanguageError),
    #[error("internal error: the decoder wrote a token the constraint refuses: {0}")]
    Token(#[from] token_constraint::PlanTokenError),
    #[error("the model's vocabulary has {model} tokens, the constraint's {constraint}")]
    VocabularyMismatch { model: usize, constraint: usize },
    #[error("the prompt is empty")]
    EmptyPrompt,
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
    /// model's `p`. 0 (the default) is the paper's prior (Eq. 6). A small model can give the
    /// right token a prior so small that PUCB tries it only after thousands of visits to its
    /// siblings; mixing in the uniform over the kept children bounds that wait, as AlphaZero's
    /// root noise does. The children kept (the `width` most likely) are the same either way.
    pub prior_mix: f64,
}

/// The range `Q` is min-max normalised over, so that it and the prior term are on one scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Normalization {
    /// Every value the tree has backed up (MuZero).
    Tree,
    /// The visited open children of the node being selected from: the best is 1, the worst
    /// 0, whatever the spread of values elsewhere in the tree.
    Siblings,
}

/// The statistic a node keeps of the values backed up through it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Backup {
    /// The mean (Monte-Carlo backup, as AlphaZero).
    Mean,
    /// The best value seen below the node (a Bellman backup for a deterministic model: the
    /// value of a prefix is the value of its best continuation found so far).
    Max,
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
}
