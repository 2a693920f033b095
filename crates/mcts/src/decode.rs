//! The decoder: one code path for every Phase II condition of the paper's ablations
//! (unconstrained / constrained × greedy / sampling / MCTS). Greedy decoding and sampling
//! are here; MCTS is `search`; both step tokens through `step`.

use std::sync::Arc;

use heuristics::search::Stopwatch;
use lm::LanguageModel;
use token_constraint::{EndPolicy, LanguageConfig, PlanLanguages, TokenId, Vocabulary};
use transition_model::{Spelling, State, TransitionModel};

use crate::canonical::CanonicalLanguages;
use crate::config::{DecodeConfig, DecodeError, InvalidStep, Outcome, Run, Stats, StopReason, Strategy, Tokenization};
use crate::cursor::{Cursor, Event, Languages};
use crate::sampling::Sampler;
use crate::search;
use crate::step::{Session, Stepper};
use crate::value::{Evaluator, ValueConfig};

/// Phase II on one task: the transition model, the spelling the model writes, the
/// vocabulary's byte trie, each state's language (cached) and the value function (cached).
pub struct Decoder<'m> {
    stepper: Stepper<'m>,
    end: EndPolicy,
}

impl std::fmt::Debug for Decoder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decoder").field("evaluator", &self.stepper.evaluator).finish_non_exhaustive()
    }
}

impl<'m> Decoder<'m> {
    /// A decoder writing `spelling`'s texts, one action a line (`\n`), ending with the
    /// model's end-of-sequence or `DONE`.
    pub fn new(model: &'m TransitionModel, spelling: &'m Spelling, vocab: Arc<Vocabulary>, value: ValueConfig) -> Decoder<'m> {
        Decoder::with_end_policy(model, spelling, vocab, value, EndPolicy::Anywhere)
    }

    /// As [`Decoder::new`], with `end` saying where the plan may end (anywhere, or at a goal
    /// state only).
    pub fn with_end_policy(
        model: &'m TransitionModel,
        spelling: &'m Spelling,
        vocab: Arc<Vocabulary>,
        value: ValueConfig,
        end: EndPolicy,
    ) -> Decoder<'m> {
        let bytes = PlanLanguages::with_config(model, spelling, LanguageConfig::default(), end);
        let languages = Languages { bytes, canonical: None };
        Decoder { stepper: Stepper::new(model, vocab, languages, Evaluator::new(model, value)), end }
    }

    /// The task's transition model.
    pub fn model(&self) -> &'m TransitionModel {
        self.stepper.model
    }

    /// How actions are written as text.
    pub fn spelling(&self) -> &'m Spelling {
        self.stepper.languages.bytes.spelling()
    }

    /// The value function, with its cache of heuristic values.
    pub fn evaluator(&mut self) -> &mut Evaluator<'m> {
        &mut self.stepper.evaluator
    }

    /// Encodes every action text of the task with the model's tokenizer, once per decoder
    /// (the canonical constraint's one-time set-up; `decode` does it on first use). Callers
    /// that time the search alone call it first.
    pub fn prepare(&mut self, lm: &dyn LanguageModel) -> Result<(), DecodeError> {
        let stepper = &mut self.stepper;
        if stepper.languages.canonical.is_none() {
            let spelling = stepper.languages.bytes.spelling();
            let marker = LanguageConfig::default().end_marker.map(|m| String::from_utf8_lossy(&m).into_owned());
            let tokenizer = lm.tokenizer();
            let canonical = CanonicalLanguages::new(stepper.model, spelling, self.end, stepper.vocab.eos(), marker.as_deref(), |t| {
                tokenizer.encode(t)
            })?;
            stepper.languages.canonical = Some(canonical);
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
        if lm.vocabulary().len() != self.stepper.vocab.len() {
            return Err(DecodeError::VocabularyMismatch { model: lm.vocabulary().len(), constraint: self.stepper.vocab.len() });
        }
        if prompt.is_empty() {
            return Err(DecodeError::EmptyPrompt);
        }
        if let Strategy::Mcts(mcts) = &config.mode.strategy {
            mcts.check()?;
        }
        let started = Stopwatch::start(config.budget.clock);
        let usage_before = lm.usage();
        let (evaluations_before, lookups_before) = self.stepper.evaluator.counts();
        let root = match (config.mode.constrained, config.tokenization) {
            (false, _) => Cursor::free(start.clone()),
            (true, Tokenization::Any) => Cursor::constrained(&mut self.stepper.languages.bytes, start.clone())?,
            (true, Tokenization::Canonical) => {
                self.prepare(lm)?;
                Cursor::canonical(self.stepper.languages.canonical.as_mut().expect("made by prepare"), start.clone())
            }
        };
        let mut session = Session { lm, prompt, config, started, stats: Stats::default() };
        let stepper = &mut self.stepper;
        let run = match &config.mode.strategy {
            Strategy::Greedy => linear(stepper, &mut session, root, None)?,
            Strategy::Sample(sampling) => linear(stepper, &mut session, root, Some(Sampler::new(sampling.clone())))?,
            Strategy::Mcts(mcts) => search::run(stepper, &mut session, root, mcts)?,
        };
        let Session { lm, mut stats, started, .. } = session;
        let (evaluations, lookups) = self.stepper.evaluator.counts();
        stats.usage = lm.usage().since(&usage_before);
        stats.heuristic_evaluations = evaluations - evaluations_before;
        stats.heuristic_lookups = lookups - lookups_before;
        stats.millis = started.wall_elapsed().as_secs_f64() * 1e3;
        Ok(self.outcome(config, run, stats))
    }

    fn outcome(&mut self, config: &DecodeConfig, run: Run, stats: Stats) -> Outcome {
        let stepper = &mut self.stepper;
        let spelling = stepper.languages.bytes.spelling();
        let task = stepper.model.task();
        let lines = run.plan.iter().map(|&a| spelling.spell(a).map_or_else(|| task.action_name(a), str::to_string)).collect();
        // Every action was applicable when applied (constrained: by construction; unconstrained:
        // the parser applies only applicable actions and stops at the first that is not).
        let valid = run.invalid.is_none();
        let solved = valid && stepper.model.is_goal(&run.end_state);
        let value = if valid { stepper.evaluator.value(&run.end_state, run.plan.len()) } else { None };
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
            tree: run.tree,
        }
    }
}

/// Greedy decoding (no sampler) or sampling: one token at a time until the plan ends.
fn linear(
    stepper: &mut Stepper<'_>,
    session: &mut Session<'_>,
    mut cursor: Cursor,
    mut sampler: Option<Sampler>,
) -> Result<Run, DecodeError> {
    let prompt = session.prompt;
    let model = stepper.model;
    let mut sequence = prompt.to_vec();
    let keep = if sampler.is_some() { usize::MAX } else { 1 };
    let budget = &session.config.budget;
    let text = |stepper: &Stepper<'_>, sequence: &[TokenId]| {
        String::from_utf8_lossy(&stepper.vocab.decode(&sequence[prompt.len()..])).into_owned()
    };
    let stop = loop {
        if session.config.stop_at_goal && model.is_goal(cursor.state()) {
            break StopReason::Goal;
        }
        if sequence.len() - prompt.len() >= budget.max_tokens {
            break StopReason::MaxTokens;
        }
        if let Some(stop) = session.out_of_budget() {
            break stop;
        }
        let distribution = stepper.distribution(session.lm, &sequence, &cursor, keep)?;
        let token = match &mut sampler {
            Some(sampler) if !distribution.forced => sampler.pick(&distribution.candidates),
            _ => distribution.candidates.first().map(|c| c.0),
        };
        let Some(token) = token else { break StopReason::DeadEnd };
        session.push(&mut sequence, token, distribution.forced);
        match stepper.advance(&mut cursor, token)? {
            Event::Partial => {}
            Event::Action => {
                if cursor.plan().len() >= budget.max_actions && !model.is_goal(cursor.state()) {
                    break StopReason::MaxActions;
                }
            }
            Event::End => break if model.is_goal(cursor.state()) { StopReason::Goal } else { StopReason::EndOfPlan },
            Event::Invalid(line) => {
                return Ok(Run {
                    plan: cursor.plan().to_vec(),
                    end_state: cursor.state().clone(),
                    invalid: Some(InvalidStep { step: cursor.plan().len(), text: line }),
                    stop: StopReason::InvalidAction,
                    text: Some(text(stepper, &sequence)),
                    tree: None,
                });
            }
        }
    };
    let (plan, end_state) = (cursor.plan().to_vec(), cursor.state().clone());
    Ok(Run { plan, end_state, invalid: None, stop, text: Some(text(stepper, &sequence)), tree: None })
}
