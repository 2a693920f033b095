//! The constraint over canonical tokenizations (paper Eq. 5 read literally: `tok(a)` is the
//! tokenizer's encoding of the action's text, and a prefix is a prefix of that token
//! sequence).
//!
//! [`token_constraint`]'s byte-level masks allow every tokenization of an allowed text. A
//! language model puts almost all its mass on the canonical one, so for a model the two
//! agree; for a search they do not: the number of tokenizations of a text grows
//! exponentially with its length, and a uniform prior spreads visits over all of them. Here
//! each state's language is a trie of token sequences, one per distinct action text (`text`
//! followed by the separator, encoded once per task), so each action has exactly one path.
//!
//! Encoding `text + "\n"` as a whole matches what the tokenizer does inside a longer plan for
//! byte-level BPE tokenizers whose pre-tokenizer splits line breaks from words (GPT-2, Llama
//! 3, Qwen, SmolLM2): no pre-token crosses the `\n`, so a plan's canonical encoding is the
//! concatenation of its lines' encodings.

use std::sync::Arc;

use grounding::ActionId;
use rustc_hash::FxHashMap;
use token_constraint::{EndPolicy, TokenId};
use transition_model::{Spelling, State, TransitionModel};

const NONE: u32 = u32::MAX;
const END: u32 = u32::MAX - 1;

/// One state's allowed token sequences as a trie.
#[derive(Debug)]
pub struct TokenLanguage {
    /// Children of each node, sorted by token.
    children: Vec<Vec<(TokenId, u32)>>,
    /// What reaching a node completes: `NONE`, `END` (the end marker), or a choice index.
    event: Vec<u32>,
    /// The applicable actions spelled by each choice, in id order (the first is applied).
    actions: Vec<Vec<ActionId>>,
    /// Whether the plan may end here (end-of-sequence or the end marker at the root).
    end_here: bool,
}

impl TokenLanguage {
    fn new() -> TokenLanguage {
        TokenLanguage { children: vec![Vec::new()], event: vec![NONE], actions: Vec::new(), end_here: false }
    }

    fn insert(&mut self, tokens: &[TokenId], event: u32) {
        let mut node = 0u32;
        for &token in tokens {
            let children = &self.children[node as usize];
            node = match children.binary_search_by_key(&token, |&(t, _)| t) {
                Ok(i) => children[i].1,
                Err(i) => {
                    let child = self.children.len() as u32;
                    self.children[node as usize].insert(i, (token, child));
                    self.children.push(Vec::new());
                    self.event.push(NONE);
                    child
                }
            };
        }
        if self.event[node as usize] == NONE {
            self.event[node as usize] = event;
        }
    }

    fn child(&self, node: u32, token: TokenId) -> Option<u32> {
        let children = &self.children[node as usize];
        children.binary_search_by_key(&token, |&(t, _)| t).ok().map(|i| children[i].1)
    }

    /// Number of distinct action texts.
    pub fn choices(&self) -> usize {
        self.actions.len()
    }
}

/// Builds and caches each state's [`TokenLanguage`] from the canonical encodings of the
/// spelling's texts (encoded once, when the cache is made).
pub struct CanonicalLanguages<'m> {
    model: &'m TransitionModel,
    spelling: &'m Spelling,
    end: EndPolicy,
    eos: Vec<TokenId>,
    end_marker: Option<Vec<TokenId>>,
    encoded: FxHashMap<ActionId, Arc<[TokenId]>>,
    cache: FxHashMap<State, Arc<TokenLanguage>>,
    applicable: Vec<ActionId>,
}

impl std::fmt::Debug for CanonicalLanguages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanonicalLanguages").field("texts", &self.encoded.len()).field("states", &self.cache.len()).finish()
    }
}

impl<'m> CanonicalLanguages<'m> {
    /// `encode` is the tokenizer (no special tokens added); `eos` the end-of-sequence tokens;
    /// `end_marker` the text that ends a plan (`DONE`), if any.
    pub fn new<E>(
        model: &'m TransitionModel,
        spelling: &'m Spelling,
        end: EndPolicy,
        eos: &[TokenId],
        end_marker: Option<&str>,
        mut encode: impl FnMut(&str) -> Result<Vec<TokenId>, E>,
    ) -> Result<CanonicalLanguages<'m>, E> {
        let mut encoded = FxHashMap::default();
        let mut line = String::new();
        for (text, actions) in spelling.texts() {
            line.clear();
            line.push_str(text);
            line.push('\n');
            let tokens: Arc<[TokenId]> = encode(&line)?.into();
            for &action in actions {
                encoded.insert(action, Arc::clone(&tokens));
            }
        }
        let end_marker = end_marker.map(&mut encode).transpose()?;
        Ok(CanonicalLanguages {
            model,
            spelling,
            end,
            eos: eos.to_vec(),
            end_marker,
            encoded,
            cache: FxHashMap::default(),
            applicable: Vec::new(),
        })
    }

    pub fn eos(&self) -> &[TokenId] {
        &self.eos
    }

    /// The language of `state`, built on first use.
    pub fn language(&mut self, state: &State) -> Arc<TokenLanguage> {
        if let Some(found) = self.cache.get(state) {
            return Arc::clone(found);
        }
        self.model.applicable(state, &mut self.applicable);
        self.applicable.sort_unstable();
        let mut language = TokenLanguage::new();
        let mut by_text: FxHashMap<&str, u32> = FxHashMap::default();
        for &action in &self.applicable {
            let (Some(text), Some(tokens)) = (self.spelling.spell(action), self.encoded.get(&action)) else { continue };
            let choice = *by_text.entry(text).or_insert_with(|| {
                language.actions.push(Vec::new());
                let choice = (language.actions.len() - 1) as u32;
                language.insert(tokens, choice);
                choice
            });
            language.actions[choice as usize].push(action);
        }
        language.end_here = match self.end {
            EndPolicy::Anywhere => true,
            EndPolicy::AtGoal => language.actions.is_empty() || self.model.is_goal(state),
        };
        if language.end_here
            && let Some(marker) = &self.end_marker
        {
            language.insert(marker, END);
        }
        let language = Arc::new(language);
        self.cache.insert(state.clone(), Arc::clone(&language));
        language
    }
}

/// What a token did, in canonical decoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanonicalStep {
    Partial,
    Action,
    End,
}

/// The position in canonical decoding: the state, its language, the node of the partial
/// action, the plan so far.
#[derive(Debug, Clone)]
pub struct CanonicalCursor {
    state: State,
    language: Arc<TokenLanguage>,
    node: u32,
    plan: Vec<ActionId>,
    finished: bool,
}

impl CanonicalCursor {
    pub fn new(languages: &mut CanonicalLanguages<'_>, state: State) -> CanonicalCursor {
        let language = languages.language(&state);
        CanonicalCursor { state, language, node: 0, plan: Vec::new(), finished: false }
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    pub fn plan(&self) -> &[ActionId] {
        &self.plan
    }

    pub fn at_boundary(&self) -> bool {
        self.node == 0
    }

    /// The allowed next tokens (children of the node; end-of-sequence at a boundary where the
    /// plan may end), into `out` (cleared first).
    pub fn allowed(&self, eos: &[TokenId], out: &mut Vec<TokenId>) {
        out.clear();
        if self.finished {
            return;
        }
        out.extend(self.language.children[self.node as usize].iter().map(|&(t, _)| t));
        if self.node == 0 && self.language.end_here {
            out.extend_from_slice(eos);
        }
    }

    /// Writes `token`; `None` if it is not allowed (the cursor is left as it was).
    pub fn advance(&mut self, languages: &mut CanonicalLanguages<'_>, token: TokenId) -> Option<CanonicalStep> {
        if self.finished {
            return None;
        }
        if self.node == 0 && self.language.end_here && languages.eos.contains(&token) {
            self.finished = true;
            return Some(CanonicalStep::End);
        }
        let child = self.language.child(self.node, token)?;
        match self.language.event[child as usize] {
            NONE => {
                self.node = child;
                Some(CanonicalStep::Partial)
            }
            END => {
                self.node = child;
                self.finished = true;
                Some(CanonicalStep::End)
            }
            choice => {
                let action = self.language.actions[choice as usize][0];
                self.state = languages.model.apply(&self.state, action);
                self.plan.push(action);
                self.language = languages.language(&self.state);
                self.node = 0;
                Some(CanonicalStep::Action)
            }
        }
    }
}
