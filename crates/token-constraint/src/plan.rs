//! The adapter to the transition model: from a state and a spelling to the state's allowed
//! language, cached by state, and a plan-level constraint that applies each completed
//! action and moves on to the next state's language.

use std::sync::Arc;

use grounding::ActionId;
use rustc_hash::FxHashMap;
use transition_model::{Spelling, State, TransitionModel};

use crate::language::{Language, LanguageBuilder, LanguageConfig, LanguageError, Matcher, Step, TokenError};
use crate::mask::TokenMask;
use crate::vocab::Vocabulary;
use crate::{ChoiceId, TokenId};

/// When the plan may end (command-line names `anywhere`, `at-goal`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, strum::Display, strum::EnumString, strum::IntoStaticStr, strum::VariantNames)]
#[strum(serialize_all = "kebab-case", parse_err_ty = transition_model::UnknownName, parse_err_fn = EndPolicy::unknown)]
pub enum EndPolicy {
    /// At every action boundary: the decoder may stop anywhere and the plan is judged by
    /// validation afterwards.
    #[default]
    Anywhere,
    /// Only where the goal holds, or where no action applies (so that a dead end still
    /// allows a token: the end).
    AtGoal,
}

impl EndPolicy {
    fn unknown(given: &str) -> transition_model::UnknownName {
        transition_model::UnknownName::of::<EndPolicy>("end policy", given)
    }
}

/// The language of one state: its trie, and for each distinct text every applicable
/// action spelled that way (class-level names can spell several grounded actions).
#[derive(Debug)]
pub struct StateLanguage {
    /// The state's language; its choice ids index [`StateLanguage::actions`].
    pub language: Arc<Language>,
    actions: Vec<Vec<ActionId>>,
}

impl StateLanguage {
    /// The applicable actions spelled as `choice`, in increasing id order; the first is the
    /// one a plan executes (as [`TransitionModel::validate_text`] does). Panics if `choice` is
    /// not a choice of this state's language (not below its [`Language::choices`]).
    pub fn actions(&self, choice: ChoiceId) -> &[ActionId] {
        &self.actions[choice as usize]
    }
}

/// Builds and caches the language of each state: revisiting a state costs one hash lookup.
#[derive(Debug)]
pub struct PlanLanguages<'m> {
    model: &'m TransitionModel,
    spelling: &'m Spelling,
    config: LanguageConfig,
    end: EndPolicy,
    cache: FxHashMap<State, Arc<StateLanguage>>,
    applicable: Vec<ActionId>,
    hits: u64,
    misses: u64,
}

impl<'m> PlanLanguages<'m> {
    /// The languages of `model`'s states, spelled by `spelling`, with the default settings:
    /// the plan may end in any state ([`EndPolicy::Anywhere`]: the end-of-sequence token and
    /// `DONE` are allowed where the goal does not hold yet, and the verdict is the
    /// validator's); [`PlanLanguages::with_config`] to allow ending at a goal state only.
    pub fn new(model: &'m TransitionModel, spelling: &'m Spelling) -> PlanLanguages<'m> {
        PlanLanguages::with_config(model, spelling, LanguageConfig::default(), EndPolicy::default())
    }

    /// The languages with `config` (the separator after each action, the end marker) and `end`
    /// (where a plan may end).
    pub fn with_config(model: &'m TransitionModel, spelling: &'m Spelling, config: LanguageConfig, end: EndPolicy) -> PlanLanguages<'m> {
        PlanLanguages { model, spelling, config, end, cache: FxHashMap::default(), applicable: Vec::new(), hits: 0, misses: 0 }
    }

    /// The model whose states these languages are of.
    pub fn model(&self) -> &'m TransitionModel {
        self.model
    }

    /// The spelling that writes the action texts; an applicable action it cannot spell is left
    /// out of the language.
    pub fn spelling(&self) -> &'m Spelling {
        self.spelling
    }

    /// The language of `state`, built on first use.
    pub fn language(&mut self, state: &State) -> Result<Arc<StateLanguage>, LanguageError> {
        if let Some(found) = self.cache.get(state) {
            self.hits += 1;
            return Ok(Arc::clone(found));
        }
        self.misses += 1;
        let built = Arc::new(self.build(state)?);
        self.cache.insert(state.clone(), Arc::clone(&built));
        Ok(built)
    }

    /// The language of `state`, not cached (what a cache miss costs).
    pub fn build(&mut self, state: &State) -> Result<StateLanguage, LanguageError> {
        self.model.applicable(state, &mut self.applicable);
        self.applicable.sort_unstable();
        let mut builder = LanguageBuilder::new(self.config.clone());
        let mut actions: Vec<Vec<ActionId>> = Vec::new();
        let anywhere = self.end == EndPolicy::Anywhere;
        for &action in &self.applicable {
            let Some(text) = self.spelling.spell(action) else { continue };
            let choice = builder.push(text.as_bytes(), anywhere)? as usize;
            if choice == actions.len() {
                actions.push(Vec::new());
            }
            actions[choice].push(action);
        }
        if !anywhere {
            builder.end_here(actions.is_empty() || self.model.is_goal(state));
            let mut next = state.clone();
            for group in &actions {
                next.clone_from(state);
                self.model.apply_into(state, group[0], &mut next);
                if self.model.is_goal(&next) {
                    // Pushing a text again marks it `end_after`, keeping its id.
                    builder.push(self.spelling.spell(group[0]).unwrap_or_default().as_bytes(), true)?;
                }
            }
        }
        Ok(StateLanguage { language: Arc::new(builder.build()), actions })
    }

    /// Cache hits and misses so far.
    pub fn cache_stats(&self) -> (u64, u64) {
        (self.hits, self.misses)
    }
}

/// What a token did to the plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlanStep {
    /// Inside an action text or the end marker: nothing completed, the state is unchanged.
    Partial,
    /// An action completed and was applied; `alternatives` are the other applicable
    /// actions with the same spelling (not applied).
    Action {
        /// The action applied: the first in id order of the applicable actions so spelled.
        action: ActionId,
        /// The other applicable actions with the same spelling, in increasing id order.
        alternatives: Vec<ActionId>,
    },
    /// The plan ended; `action` is set when the end-of-sequence came right after an action.
    End {
        /// The action completed by the end-of-sequence token, and applied; `None` when the plan
        /// ended at a boundary.
        action: Option<ActionId>,
        /// Whether the goal holds in the state the plan ended in (after `action`, if any).
        goal_reached: bool,
    },
}

/// Why a plan-level step failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlanTokenError {
    /// The token was refused; the constraint is unchanged.
    #[error(transparent)]
    Token(#[from] TokenError),
    /// The next state's language could not be built after a completed action; the constraint
    /// is unchanged.
    #[error(transparent)]
    Language(#[from] LanguageError),
}

/// Constrained decoding of a whole plan: the current state, the partial action in it, and
/// the actions written so far. Clone it to branch.
#[derive(Debug, Clone)]
pub struct PlanConstraint {
    state: State,
    current: Arc<StateLanguage>,
    matcher: Matcher,
    plan: Vec<ActionId>,
}

impl PlanConstraint {
    /// Starts a plan in `state`.
    pub fn new(languages: &mut PlanLanguages<'_>, state: State) -> Result<PlanConstraint, LanguageError> {
        let current = languages.language(&state)?;
        let matcher = Matcher::new(Arc::clone(&current.language));
        Ok(PlanConstraint { state, current, matcher, plan: Vec::new() })
    }

    /// The current state: the start state with every completed action applied.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The actions completed so far.
    pub fn plan(&self) -> &[ActionId] {
        &self.plan
    }

    /// The matcher in the current state's language; its [`Matcher::prefix`] is the partial
    /// action.
    pub fn matcher(&self) -> &Matcher {
        &self.matcher
    }

    /// Whether the plan has ended; [`PlanConstraint::advance`] then refuses every token.
    pub fn is_finished(&self) -> bool {
        self.matcher.is_finished()
    }

    /// The next-token mask in the current state, into `mask` (cleared first; resized to the
    /// vocabulary), as [`Matcher::fill_mask`].
    pub fn fill_mask(&self, vocab: &Vocabulary, mask: &mut TokenMask) {
        self.matcher.fill_mask(vocab, mask);
    }

    /// The allowed next tokens, in no particular order, into `out` (cleared first).
    pub fn allowed(&self, vocab: &Vocabulary, out: &mut Vec<TokenId>) {
        self.matcher.allowed(vocab, out);
    }

    /// Writes `token`. On a completed action, applies it and enters the next state's
    /// language. A refused token leaves the constraint as it was.
    pub fn advance(&mut self, languages: &mut PlanLanguages<'_>, vocab: &Vocabulary, token: TokenId) -> Result<PlanStep, PlanTokenError> {
        let step = self.matcher.peek(vocab, token)?;
        Ok(match step {
            Step::Partial => {
                self.matcher.advance(vocab, token)?;
                PlanStep::Partial
            }
            Step::Action(choice) => {
                let group = self.current.actions(choice);
                let (action, alternatives) = (group[0], group[1..].to_vec());
                let next = languages.model().apply(&self.state, action);
                let language = languages.language(&next)?;
                self.matcher.advance(vocab, token)?;
                self.matcher.enter(Arc::clone(&language.language));
                self.current = language;
                self.state = next;
                self.plan.push(action);
                PlanStep::Action { action, alternatives }
            }
            Step::ActionThenEnd(choice) => {
                let action = self.current.actions(choice)[0];
                self.matcher.advance(vocab, token)?;
                self.state = languages.model().apply(&self.state, action);
                self.plan.push(action);
                PlanStep::End { action: Some(action), goal_reached: languages.model().is_goal(&self.state) }
            }
            Step::End => {
                self.matcher.advance(vocab, token)?;
                PlanStep::End { action: None, goal_reached: languages.model().is_goal(&self.state) }
            }
        })
    }
}
