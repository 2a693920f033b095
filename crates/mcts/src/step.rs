//! One token step, shared by every strategy: [`Stepper`] holds what a step needs for one task
//! (the transition model, the vocabulary's byte trie, each state's language, the value
//! function) and [`Session`] what one decoding run carries (the model, the prompt, the
//! settings, the clock, the counters). The linear decoders (`decode`) and MCTS (`search`)
//! both ask [`Stepper::distribution`] for candidates, append with [`Session::push`] and
//! [`Stepper::advance`], and stop on [`Session::out_of_budget`].

use heuristics::search::{Clock, Stopwatch};
use std::sync::Arc;

use lm::{LanguageModel, Logprobs};
use token_constraint::{TokenId, Vocabulary};
use transition_model::TransitionModel;

use crate::config::{DecodeConfig, DecodeError, Stats, StopReason};
use crate::cursor::{Cursor, Event, Languages};
use crate::value::Evaluator;

/// What a token step needs for one task; the caches (languages, values) persist across runs.
pub(crate) struct Stepper<'m> {
    pub model: &'m TransitionModel,
    pub vocab: Arc<Vocabulary>,
    pub languages: Languages<'m>,
    pub evaluator: Evaluator<'m>,
    /// Scratch buffer of the tokens a mask allows.
    allowed: Vec<TokenId>,
}

/// One decoding run: the model, the prompt's tokens, the settings, when it started and what
/// it has counted so far.
pub(crate) struct Session<'a> {
    pub lm: &'a mut dyn LanguageModel,
    pub prompt: &'a [TokenId],
    pub config: &'a DecodeConfig,
    pub started: Stopwatch,
    pub stats: Stats,
}

impl Session<'_> {
    /// The budget's limits that apply to every strategy: time and model calls (MCTS
    /// adds simulations, the linear decoders the plan's tokens).
    pub fn out_of_budget(&self) -> Option<StopReason> {
        let budget = &self.config.budget;
        if self.started.past(budget.time_limit) {
            return Some(match self.started.clock() {
                Clock::Wall => StopReason::WallClock,
                Clock::Cpu => StopReason::CpuTime,
            });
        }
        if budget.model_calls.is_some_and(|limit| self.stats.decoded_tokens - self.stats.forced_tokens >= limit) {
            return Some(StopReason::ModelCalls);
        }
        None
    }

    /// Appends a token the strategy chose to `sequence`, counting it (and whether the mask
    /// forced it, which cost no model call).
    pub fn push(&mut self, sequence: &mut Vec<TokenId>, token: TokenId, forced: bool) {
        self.stats.decoded_tokens += 1;
        self.stats.forced_tokens += u64::from(forced);
        sequence.push(token);
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

impl<'m> Stepper<'m> {
    pub fn new(model: &'m TransitionModel, vocab: Arc<Vocabulary>, languages: Languages<'m>, evaluator: Evaluator<'m>) -> Stepper<'m> {
        Stepper { model, vocab, languages, evaluator, allowed: Vec::new() }
    }

    /// Moves `cursor` past `token`: through the constraint, applying each action it completes.
    pub fn advance(&mut self, cursor: &mut Cursor, token: TokenId) -> Result<Event, DecodeError> {
        Ok(cursor.advance(self.model, &mut self.languages, &self.vocab, token)?)
    }

    /// The next-token candidates at `cursor` after `sequence`, most likely first; at most
    /// `keep` of them.
    pub fn distribution(
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
