//! The decoder: one code path for every Phase II condition of the paper's ablations
//! (unconstrained / constrained × greedy / sampling / MCTS).

use std::sync::Arc;
use std::time::{Duration, Instant};

use grounding::ActionId;
use lm::{LanguageModel, LmError, Logprobs, Usage};
use serde::Serialize;
use token_constraint::{EndPolicy, LanguageConfig, PlanLanguages, TokenId, Vocabulary};
use transition_model::{Spelling, State, TransitionModel};

use crate::canonical::CanonicalLanguages;
use crate::cursor::{Cursor, Event, Languages};
use crate::sampling::{Sampler, SamplingConfig};
use crate::search::{self, MctsConfig};
use crate::value::{Evaluator, ValueConfig};

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

/// Phase II on one task: the transition model, the spelling the model writes, the
/// vocabulary's byte trie, each state's language (cached) and the value function (cached).
pub struct Decoder<'m> {
    pub(crate) model: &'m TransitionModel,
    pub(crate) vocab: Arc<Vocabulary>,
    pub(crate) languages: Languages<'m>,
    end: EndPolicy,
    pub(crate) evaluator: Evaluator<'m>,
    pub(crate) allowed: Vec<TokenId>,
}

impl std::fmt::Debug for Decoder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decoder").field("evaluator", &self.evaluator).finish_non_exhaustive()
    }
}

/// A model's next-token candidates: (token, probability), most likely first (ties: lower id).
pub(crate) struct Distribution {
    pub candidates: Vec<(TokenId, f32)>,
    /// The mask allowed exactly one token: no model call was made.
    pub forced: bool,
}

/// Tokens less likely than the most likely one by this factor (e^-30) are dropped from an
/// unconstrained distribution before sampling: their mass is below 1e-13 each.
const NEGLIGIBLE_LOGPROB: f32 = 30.0;

impl<'m> Decoder<'m> {
    /// A decoder writing `spelling`'s texts, one action a line (`\n`), ending with the
    /// model's end-of-sequence or `DONE`.
    pub fn new(model: &'m TransitionModel, spelling: &'m Spelling, vocab: Arc<Vocabulary>, value: ValueConfig) -> Decoder<'m> {
        Decoder::with_end_policy(model, spelling, vocab, value, EndPolicy::Anywhere)
    }

    pub fn with_end_policy(
        model: &'m TransitionModel,
        spelling: &'m Spelling,
        vocab: Arc<Vocabulary>,
        value: ValueConfig,
        end: EndPolicy,
    ) -> Decoder<'m> {
        let bytes = PlanLanguages::with_config(model, spelling, LanguageConfig::default(), end);
        let languages = Languages { bytes, canonical: None };
        Decoder { model, vocab, languages, end, evaluator: Evaluator::new(model, value), allowed: Vec::new() }
    }

    pub fn model(&self) -> &'m TransitionModel {
        self.model
    }

    pub fn spelling(&self) -> &'m Spelling {
        self.languages.bytes.spelling()
    }

    pub fn evaluator(&mut self) -> &mut Evaluator<'m> {
        &mut self.evaluator
    }

    /// Encodes every action text of the task with the model's tokenizer, once per decoder
    /// (the canonical constraint's one-time set-up; `decode` does it on first use). Callers
    /// that time the search alone call it first.
    pub fn prepare(&mut self, lm: &dyn LanguageModel) -> Result<(), DecodeError> {
        if self.languages.canonical.is_none() {
            let spelling = self.languages.bytes.spelling();
            let marker = LanguageConfig::default().end_marker.map(|m| String::from_utf8_lossy(&m).into_owned());
            let tokenizer = lm.tokenizer();
            let canonical =
                CanonicalLanguages::new(self.model, spelling, self.end, self.vocab.eos(), marker.as_deref(), |t| tokenizer.encode(t))?;
            self.languages.canonical = Some(canonical);
        }
        Ok(())
    }

    /// Writes a plan from `start` after `prompt` (the rendered prompt's tokens).
    pub fn decode(
        &mut self,
        lm: &mut dyn LanguageModel,
        prompt: &[TokenId],
        start: &State,
        config: &DecodeConfig,
    ) -> Result<Outcome, DecodeError> {
        if lm.vocabulary().len() != self.vocab.len() {
            return Err(DecodeError::VocabularyMismatch { model: lm.vocabulary().len(), constraint: self.vocab.len() });
        }
        if prompt.is_empty() {
            return Err(DecodeError::EmptyPrompt);
        }
        let started = Instant::now();
        let usage_before = lm.usage();
        let (evaluations_before, lookups_before) = self.evaluator.counts();
        let root = match (config.mode.constrained, config.tokenization) {
            (false, _) => Cursor::free(start.clone()),
            (true, Tokenization::Any) => Cursor::constrained(&mut self.languages.bytes, start.clone())?,
            (true, Tokenization::Canonical) => {
                self.prepare(lm)?;
                Cursor::canonical(self.languages.canonical.as_mut().expect("made by prepare"), start.clone())
            }
        };
        let mut stats = Stats::default();
        let run = match &config.mode.strategy {
            Strategy::Greedy => self.linear(lm, prompt, root, config, None, &mut stats, started)?,
            Strategy::Sample(sampling) => {
                self.linear(lm, prompt, root, config, Some(Sampler::new(sampling.clone())), &mut stats, started)?
            }
            Strategy::Mcts(mcts) => search::run(self, lm, prompt, root, config, mcts, &mut stats, started)?,
        };
        let (evaluations, lookups) = self.evaluator.counts();
        stats.usage = lm.usage().since(&usage_before);
        stats.heuristic_evaluations = evaluations - evaluations_before;
        stats.heuristic_lookups = lookups - lookups_before;
        stats.millis = started.elapsed().as_secs_f64() * 1e3;
        Ok(self.outcome(config, run, stats))
    }

    fn outcome(&mut self, config: &DecodeConfig, run: Run, stats: Stats) -> Outcome {
        let spelling = self.languages.bytes.spelling();
        let lines = run.plan.iter().map(|&a| spelling.spell(a).map_or_else(|| self.model.task().action_name(a), str::to_string)).collect();
        // Every action was applicable when applied (constrained: by construction; unconstrained:
        // the parser applies only applicable actions and stops at the first that is not).
        let valid = run.invalid.is_none();
        let solved = valid && self.model.is_goal(&run.end_state);
        let value = if valid { self.evaluator.value(&run.end_state, run.plan.len()) } else { None };
        Outcome {
            mode: config.mode.name(),
            plan: run.plan,
            lines,
            valid,
            solved,
            invalid: run.invalid,
            stop: run.stop,
            text: run.text,
            value,
            stats,
        }
    }

    /// The next-token candidates at `cursor` after `sequence`, most likely first; at most
    /// `keep` of them.
    pub(crate) fn distribution(
        &mut self,
        lm: &mut dyn LanguageModel,
        sequence: &[TokenId],
        cursor: &Cursor,
        keep: usize,
    ) -> Result<Distribution, DecodeError> {
        let mut candidates: Vec<(TokenId, f32)> = if cursor.allowed(&self.vocab, &mut self.allowed).is_some() {
            match self.allowed.len() {
                0 => return Ok(Distribution { candidates: Vec::new(), forced: false }),
                1 => return Ok(Distribution { candidates: vec![(self.allowed[0], 1.0)], forced: true }),
                _ => {
                    let prior = lm.next_logprobs_among(sequence, &self.allowed)?;
                    prior.tokens.iter().zip(&prior.logprobs).map(|(&t, &l)| (t, l.exp())).collect()
                }
            }
        } else {
            match lm.next_logprobs(sequence)? {
                Logprobs::Dense(values) => {
                    let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                    let floor = max - NEGLIGIBLE_LOGPROB;
                    let top = if keep <= SMALL_KEEP {
                        top_candidates(&values, keep.max(1), floor)
                    } else {
                        let mut all: Vec<(TokenId, f32)> =
                            values.iter().enumerate().filter(|&(_, &l)| l >= floor).map(|(i, &l)| (i as TokenId, l)).collect();
                        if all.len() > keep {
                            all.select_nth_unstable_by(keep - 1, by_probability);
                            all.truncate(keep);
                        }
                        all
                    };
                    top.into_iter().map(|(t, l)| (t, l.exp())).collect()
                }
                Logprobs::Sparse { top, .. } => top.into_iter().map(|(t, l)| (t, l.exp())).collect(),
            }
        };
        candidates.sort_unstable_by(by_probability);
        candidates.truncate(keep.max(1));
        Ok(Distribution { candidates, forced: false })
    }

    /// Greedy decoding or sampling: one token at a time until the plan ends.
    #[allow(clippy::too_many_arguments)]
    fn linear(
        &mut self,
        lm: &mut dyn LanguageModel,
        prompt: &[TokenId],
        mut cursor: Cursor,
        config: &DecodeConfig,
        mut sampler: Option<Sampler>,
        stats: &mut Stats,
        started: Instant,
    ) -> Result<Run, DecodeError> {
        let mut sequence = prompt.to_vec();
        let keep = if sampler.is_some() { usize::MAX } else { 1 };
        let budget = &config.budget;
        let stop = loop {
            if config.stop_at_goal && self.model.is_goal(cursor.state()) {
                break StopReason::Goal;
            }
            if sequence.len() - prompt.len() >= budget.max_tokens {
                break StopReason::MaxTokens;
            }
            if budget.wall_clock.is_some_and(|limit| started.elapsed() >= limit) {
                break StopReason::WallClock;
            }
            if budget.model_calls.is_some_and(|limit| stats.decoded_tokens - stats.forced_tokens >= limit) {
                break StopReason::ModelCalls;
            }
            let distribution = self.distribution(lm, &sequence, &cursor, keep)?;
            let token = match &mut sampler {
                Some(sampler) if !distribution.forced => sampler.pick(&distribution.candidates),
                _ => distribution.candidates.first().map(|c| c.0),
            };
            let Some(token) = token else { break StopReason::DeadEnd };
            stats.decoded_tokens += 1;
            stats.forced_tokens += u64::from(distribution.forced);
            sequence.push(token);
            match cursor.advance(self.model, &mut self.languages, &self.vocab, token)? {
                Event::Partial => {}
                Event::Action => {
                    if cursor.plan().len() >= budget.max_actions && !self.model.is_goal(cursor.state()) {
                        break StopReason::MaxActions;
                    }
                }
                Event::End => break if self.model.is_goal(cursor.state()) { StopReason::Goal } else { StopReason::EndOfPlan },
                Event::Invalid(text) => {
                    return Ok(Run {
                        plan: cursor.plan().to_vec(),
                        end_state: cursor.state().clone(),
                        invalid: Some(InvalidStep { step: cursor.plan().len(), text }),
                        stop: StopReason::InvalidAction,
                        text: Some(self.text(&sequence[prompt.len()..])),
                    });
                }
            }
        };
        let text = Some(self.text(&sequence[prompt.len()..]));
        Ok(Run { plan: cursor.plan().to_vec(), end_state: cursor.state().clone(), invalid: None, stop, text })
    }

    fn text(&self, tokens: &[TokenId]) -> String {
        String::from_utf8_lossy(&self.vocab.decode(tokens)).into_owned()
    }
}

/// Up to this many candidates, a dense distribution's best are picked in one pass.
const SMALL_KEEP: usize = 256;

/// The `keep` (at least 1) most likely tokens of a dense distribution of logprobs at or above
/// `floor`, in [`by_probability`]'s order (a total order, so the set is the one a full
/// selection picks), in one pass over a sorted buffer of `keep` entries. Selecting from a
/// list of all entries instead took ~100 ms per call on a flat distribution over Qwen3's
/// 151k tokens (the uniform model, unconstrained), where every entry ties on probability.
fn top_candidates(values: &[f32], keep: usize, floor: f32) -> Vec<(TokenId, f32)> {
    let mut top: Vec<(TokenId, f32)> = Vec::with_capacity(keep);
    for (token, &logprob) in values.iter().enumerate() {
        if logprob < floor {
            continue;
        }
        let entry = (token as TokenId, logprob);
        if top.len() == keep {
            // The worst kept entry is the last; a later token ties lose to it (higher id).
            if by_probability(&entry, &top[keep - 1]) != std::cmp::Ordering::Less {
                continue;
            }
            top.pop();
        }
        let at = top.partition_point(|kept| by_probability(kept, &entry) == std::cmp::Ordering::Less);
        top.insert(at, entry);
    }
    top
}

/// Higher probability first, then lower token id.
pub(crate) fn by_probability(a: &(TokenId, f32), b: &(TokenId, f32)) -> std::cmp::Ordering {
    b.1.total_cmp(&a.1).then(a.0.cmp(&b.0))
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

#[cfg(test)]
mod top_candidates_tests {
    use super::*;

    /// The one-pass pick equals sorting everything and taking the first `keep`, on flat,
    /// random and partly tied distributions, with and without entries below the floor.
    #[test]
    fn picks_what_a_full_sort_picks() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for case in 0..60 {
            let len = 1 + (next() % 400) as usize;
            let values: Vec<f32> = (0..len)
                .map(|_| match case % 3 {
                    0 => -1.0,
                    1 => -((next() % 1000) as f32) / 10.0,
                    _ => -((next() % 4) as f32) * 20.0,
                })
                .collect();
            let keep = 1 + (next() % 20) as usize;
            let floor = if case % 2 == 0 { f32::NEG_INFINITY } else { -30.0 };
            let mut all: Vec<(TokenId, f32)> =
                values.iter().enumerate().filter(|&(_, &l)| l >= floor).map(|(i, &l)| (i as TokenId, l)).collect();
            all.sort_unstable_by(by_probability);
            all.truncate(keep);
            assert_eq!(top_candidates(&values, keep, floor), all, "case {case}");
        }
    }
}
