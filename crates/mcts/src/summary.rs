//! What a search leaves for a report: the top of its tree ([`TreeSummary`]) and the statistic
//! its nodes keep ([`Backup`]). These need no model or mask, so they are here without the
//! `decoder` feature, for the crates that record or read an episode (`exploration-harness`).

use serde::{Deserialize, Serialize};

/// The top of an MCTS tree, for a report: the first actions the search tried, and the actions
/// it tried after the most visited of them. A tree node is a token; a row here is the node
/// where an action's line completes (the tokens between are one row), so a row is an action
/// with the statistics of the node that completes it. Under [`Tokenization::Any`](crate::Tokenization::Any) one action
/// can be written by several token sequences, each its own branch, so the same line may stand
/// in several rows (three `DONE` rows from three splits of it). Only visited branches are listed, at
/// most [`TreeSummary::LISTED`] per level, most visited first (ties: the node made first), so
/// the summary is small and deterministic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TreeSummary {
    /// The root's visits: the simulations whose values were backed up (the one that reached
    /// the goal, which ends the search, included).
    pub visits: u64,
    /// What a row's `value` is: the best value backed up through it (`max`) or their mean.
    pub backup: Backup,
    /// The first actions tried.
    pub first: TreeLevel,
    /// The actions tried after the most visited first action, when the search went on from
    /// it.
    pub second: Option<TreeLevel>,
}

/// The branches tried from one action boundary up to the next.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TreeLevel {
    /// The plan's lines before this level (empty at the root).
    pub after: Vec<String>,
    /// The visits of the node the level starts from.
    pub visits: u64,
    /// Most visited first.
    pub rows: Vec<TreeRow>,
    /// Branches tried beyond the rows listed, and their visits.
    pub omitted: usize,
    /// Visits of the branches counted in `omitted`, summed.
    pub omitted_visits: u64,
    /// The level's subtree was larger than [`TreeSummary::STEPS`] token steps: the branches
    /// beyond them are neither rows nor counted in `omitted`.
    pub truncated: bool,
}

/// One branch of a [`TreeLevel`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TreeRow {
    /// The action's line (the lines joined by `; `, when one token completed several); for a
    /// branch that ended otherwise, the text its tokens write (trimmed, lossy UTF-8, special
    /// tokens spelled out).
    pub text: String,
    /// How the branch ends.
    pub kind: RowKind,
    /// Tokens from the level's start to the row's node.
    pub tokens: usize,
    /// Simulations through the row's node.
    pub visits: u64,
    /// `Q` of the row's node as the search backs it up (Eq. 10 values; see `backup`).
    pub value: f64,
    /// The prior of the row's tokens: the product of each token's prior given the ones before
    /// (the masked model distribution of Eq. 8, as the search mixes it), so at most 1 over a
    /// level.
    pub prior: f64,
    /// The row's actions begin the returned plan.
    pub on_plan: bool,
    /// The search closed the branch (goal, dead end, end of plan, transposition, limit, or
    /// every continuation closed).
    pub closed: bool,
}

/// How a [`TreeRow`]'s branch ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RowKind {
    /// An action's line completed.
    Action,
    /// The plan ended (end of sequence or `DONE`).
    End,
    /// Unconstrained text wrote a line that names no applicable action.
    Invalid,
    /// The search has not yet written past a partial action here.
    Partial,
}

impl TreeSummary {
    /// Rows listed per level.
    pub const LISTED: usize = 24;
    /// Token steps replayed per level at most.
    pub const STEPS: usize = 4096;
}

/// The statistic a node keeps of the values backed up through it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, strum::EnumString, strum::IntoStaticStr, strum::VariantNames)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case", parse_err_ty = heuristics::UnknownName, parse_err_fn = Backup::unknown)]
pub enum Backup {
    /// The mean (Monte-Carlo backup, as AlphaZero).
    Mean,
    /// The best value seen below the node (a Bellman backup for a deterministic model: the
    /// value of a prefix is the value of its best continuation found so far).
    Max,
}

impl Backup {
    fn unknown(given: &str) -> heuristics::UnknownName {
        heuristics::UnknownName::of::<Backup>("backup", given)
    }
}
