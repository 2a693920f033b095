//! The constraint over canonical tokenizations (paper Eq. 7 read literally: `tok(a)` is the
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

/// One state's allowed token sequences as a trie, in flat arrays (one allocation each, so
/// that building and dropping the language of each new state the search reaches stays cheap).
#[derive(Debug)]
pub struct TokenLanguage {
    /// Each node's children: a range of `edges`.
    spans: Vec<(u32, u32)>,
    /// `(token, child)`, each node's run sorted by token.
    edges: Vec<(TokenId, u32)>,
    /// What reaching a node completes: `NONE`, `END` (the end marker), or a choice index.
    event: Vec<u32>,
    /// Each choice's applicable actions: a range of `choice_actions`, in id order (the first
    /// is applied).
    choice_spans: Vec<(u32, u32)>,
    choice_actions: Vec<ActionId>,
    /// Whether the plan may end here (end-of-sequence or the end marker at the root).
    end_here: bool,
}

impl TokenLanguage {
    fn children(&self, node: u32) -> &[(TokenId, u32)] {
        let (start, end) = self.spans[node as usize];
        &self.edges[start as usize..end as usize]
    }

    fn child(&self, node: u32, token: TokenId) -> Option<u32> {
        let children = self.children(node);
        children.binary_search_by_key(&token, |&(t, _)| t).ok().map(|i| children[i].1)
    }

    /// Number of distinct action texts.
    pub fn choices(&self) -> usize {
        self.choice_spans.len()
    }

    /// The applicable actions spelled by `choice`, in id order.
    pub fn actions(&self, choice: u32) -> &[ActionId] {
        let (start, end) = self.choice_spans[choice as usize];
        &self.choice_actions[start as usize..end as usize]
    }

    /// The trie of `entries` (token sequence, event), built breadth first from the entries
    /// sorted by tokens, so that each node's children are contiguous. Where one sequence is
    /// given twice, the earlier entry's event is kept. `order` is scratch.
    fn build(&mut self, entries: &[(&[TokenId], u32)], order: &mut Vec<u32>, pending: &mut Vec<(u32, u32, u32)>) {
        order.clear();
        order.extend(0..entries.len() as u32);
        order.sort_by(|&a, &b| entries[a as usize].0.cmp(entries[b as usize].0).then(a.cmp(&b)));
        self.spans.clear();
        self.edges.clear();
        self.event.clear();
        // Node n stands for the sequences order[lo..hi], with pending[n] = (lo, hi, depth):
        // they share their first `depth` tokens. Nodes are numbered breadth first.
        pending.clear();
        pending.push((0, order.len() as u32, 0));
        self.event.push(NONE);
        let mut node = 0;
        while node < pending.len() {
            let (mut lo, hi, depth) = pending[node];
            let depth = depth as usize;
            // Sequences that end here sort first among the node's.
            while lo < hi && entries[order[lo as usize] as usize].0.len() == depth {
                if self.event[node] == NONE {
                    self.event[node] = entries[order[lo as usize] as usize].1;
                }
                lo += 1;
            }
            let start = self.edges.len() as u32;
            while lo < hi {
                let token = entries[order[lo as usize] as usize].0[depth];
                let mut end = lo + 1;
                while end < hi && entries[order[end as usize] as usize].0[depth] == token {
                    end += 1;
                }
                let child = pending.len() as u32;
                self.edges.push((token, child));
                pending.push((lo, end, depth as u32 + 1));
                self.event.push(NONE);
                lo = end;
            }
            self.spans.push((start, self.edges.len() as u32));
            node += 1;
        }
    }
}

/// Builds and caches each state's [`TokenLanguage`] from the canonical encodings of the
/// spelling's texts (encoded once, when the cache is made).
pub struct CanonicalLanguages<'m> {
    model: &'m TransitionModel,
    end: EndPolicy,
    eos: Vec<TokenId>,
    end_marker: Option<Vec<TokenId>>,
    /// The encoding of each distinct text (with its separator).
    texts: Vec<Vec<TokenId>>,
    /// The text of each action (`NONE` where the spelling has none), by action index.
    text_of: Vec<u32>,
    cache: FxHashMap<State, Arc<TokenLanguage>>,
    // Scratch, reused across states.
    applicable: Vec<ActionId>,
    /// Each text's choice in the language being built (`NONE` outside it).
    choice_of_text: Vec<u32>,
    choice_texts: Vec<u32>,
    by_choice: Vec<(u32, ActionId)>,
    order: Vec<u32>,
    pending: Vec<(u32, u32, u32)>,
}

impl std::fmt::Debug for CanonicalLanguages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanonicalLanguages").field("texts", &self.texts.len()).field("states", &self.cache.len()).finish()
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
        let mut texts = Vec::new();
        let mut text_of = Vec::new();
        let mut line = String::new();
        for (text, actions) in spelling.texts() {
            line.clear();
            line.push_str(text);
            line.push('\n');
            let id = texts.len() as u32;
            texts.push(encode(&line)?);
            for &action in actions {
                if text_of.len() <= action.index() {
                    text_of.resize(action.index() + 1, NONE);
                }
                text_of[action.index()] = id;
            }
        }
        let end_marker = end_marker.map(&mut encode).transpose()?;
        let choice_of_text = vec![NONE; texts.len()];
        Ok(CanonicalLanguages {
            model,
            end,
            eos: eos.to_vec(),
            end_marker,
            texts,
            text_of,
            cache: FxHashMap::default(),
            applicable: Vec::new(),
            choice_of_text,
            choice_texts: Vec::new(),
            by_choice: Vec::new(),
            order: Vec::new(),
            pending: Vec::new(),
        })
    }

    /// The end-of-sequence tokens, which end a plan at an action boundary where it may end.
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
        // Choices are the distinct texts, numbered in order of their first action.
        self.choice_texts.clear();
        self.by_choice.clear();
        for &action in &self.applicable {
            let Some(&text) = self.text_of.get(action.index()).filter(|&&t| t != NONE) else { continue };
            let slot = &mut self.choice_of_text[text as usize];
            if *slot == NONE {
                *slot = self.choice_texts.len() as u32;
                self.choice_texts.push(text);
            }
            self.by_choice.push((*slot, action));
        }
        // Stable: each choice's actions stay in id order.
        self.by_choice.sort_by_key(|&(choice, _)| choice);
        let mut language = TokenLanguage {
            spans: Vec::new(),
            edges: Vec::new(),
            event: Vec::new(),
            choice_spans: Vec::with_capacity(self.choice_texts.len()),
            choice_actions: self.by_choice.iter().map(|&(_, a)| a).collect(),
            end_here: false,
        };
        let mut start = 0;
        for choice in 0..self.choice_texts.len() as u32 {
            let end = start + self.by_choice[start..].iter().take_while(|&&(c, _)| c == choice).count();
            language.choice_spans.push((start as u32, end as u32));
            start = end;
        }
        language.end_here = match self.end {
            EndPolicy::Anywhere => true,
            EndPolicy::AtGoal => self.choice_texts.is_empty() || self.model.is_goal(state),
        };
        let mut entries: Vec<(&[TokenId], u32)> =
            self.choice_texts.iter().enumerate().map(|(choice, &text)| (self.texts[text as usize].as_slice(), choice as u32)).collect();
        if language.end_here
            && let Some(marker) = &self.end_marker
        {
            entries.push((marker.as_slice(), END));
        }
        language.build(&entries, &mut self.order, &mut self.pending);
        for &text in &self.choice_texts {
            self.choice_of_text[text as usize] = NONE;
        }
        let language = Arc::new(language);
        self.cache.insert(state.clone(), Arc::clone(&language));
        language
    }
}

/// What a token did, in canonical decoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanonicalStep {
    /// Inside an action's token sequence (or the end marker's): nothing completed.
    Partial,
    /// An action's line completed; the first applicable action it spells was applied.
    Action,
    /// The plan ended: an end-of-sequence token at a boundary, or the end marker's last token.
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
    /// Starts a plan in `state`, at an action boundary (its language built if not cached yet).
    pub fn new(languages: &mut CanonicalLanguages<'_>, state: State) -> CanonicalCursor {
        let language = languages.language(&state);
        CanonicalCursor { state, language, node: 0, plan: Vec::new(), finished: false }
    }

    /// The state after the plan's actions.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The actions applied so far, in order.
    pub fn plan(&self) -> &[ActionId] {
        &self.plan
    }

    /// Whether nothing of the next action has been written yet.
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
        out.extend(self.language.children(self.node).iter().map(|&(t, _)| t));
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
                let action = self.language.actions(choice)[0];
                self.state = languages.model.apply(&self.state, action);
                self.plan.push(action);
                self.language = languages.language(&self.state);
                self.node = 0;
                Some(CanonicalStep::Action)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn built(entries: &[(&[TokenId], u32)]) -> TokenLanguage {
        let mut language = TokenLanguage {
            spans: Vec::new(),
            edges: Vec::new(),
            event: Vec::new(),
            choice_spans: Vec::new(),
            choice_actions: Vec::new(),
            end_here: false,
        };
        language.build(entries, &mut Vec::new(), &mut Vec::new());
        language
    }

    /// The node a sequence leads to, if the trie has it.
    fn walk(language: &TokenLanguage, tokens: &[TokenId]) -> Option<u32> {
        tokens.iter().try_fold(0, |node, &t| language.child(node, t))
    }

    #[test]
    fn trie_holds_each_sequence_once_with_sorted_children() {
        let entries: [(&[TokenId], u32); 6] = [(&[5, 2, 9], 0), (&[5, 2], 1), (&[3], 2), (&[5, 7, 1], 3), (&[5, 2], 4), (&[3, 8], END)];
        let language = built(&entries);
        // Every sequence ends at a node carrying its event; a repeated one keeps the first.
        assert_eq!(walk(&language, &[5, 2, 9]).map(|n| language.event[n as usize]), Some(0));
        assert_eq!(walk(&language, &[5, 2]).map(|n| language.event[n as usize]), Some(1));
        assert_eq!(walk(&language, &[3]).map(|n| language.event[n as usize]), Some(2));
        assert_eq!(walk(&language, &[5, 7, 1]).map(|n| language.event[n as usize]), Some(3));
        assert_eq!(walk(&language, &[3, 8]).map(|n| language.event[n as usize]), Some(END));
        // Inner nodes complete nothing; missing paths are absent.
        assert_eq!(walk(&language, &[5]).map(|n| language.event[n as usize]), Some(NONE));
        assert_eq!(walk(&language, &[5, 3]), None);
        assert_eq!(walk(&language, &[7]), None);
        // Root children sorted; one node per distinct prefix (root, 3, 3 8, 5, 5 2, 5 2 9, 5 7, 5 7 1).
        assert_eq!(language.children(0).iter().map(|&(t, _)| t).collect::<Vec<_>>(), vec![3, 5]);
        assert_eq!(language.spans.len(), 8);
        assert_eq!(language.event.len(), 8);
    }

    #[test]
    fn empty_language_is_a_lone_root() {
        let language = built(&[]);
        assert!(language.children(0).is_empty());
        assert_eq!(language.event, vec![NONE]);
    }
}
