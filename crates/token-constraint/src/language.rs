//! The allowed language of one state, and the byte-level matcher that walks it.
//!
//! A [`Language`] holds the texts of the actions applicable in one state, each followed by
//! the separator, plus the end marker, as a trie. The plan language is
//! `(action separator)* (end-marker | EOS)`, and additionally `action EOS` when that
//! action may end the plan. Only the action texts change with the state; everything after
//! a completed action is judged against the *next* state's language (see [`Matcher`]).

use std::sync::Arc;

use std::hash::Hasher;

use hashbrown::HashTable;

use crate::mask::TokenMask;
use crate::trie::FlatTrie;
use crate::vocab::{VocabNode, VocabTrie, Vocabulary};
use crate::{ChoiceId, TokenId};

/// Separator and end marker of a plan language.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct LanguageConfig {
    /// Bytes written after every action (default `\n`).
    pub separator: Vec<u8>,
    /// Text that ends the plan at an action boundary, besides the end-of-sequence token
    /// (default `DONE`, as the paper's prompts say); `None`, or an empty marker, for EOS only.
    pub end_marker: Option<Vec<u8>>,
}

impl Default for LanguageConfig {
    fn default() -> LanguageConfig {
        LanguageConfig { separator: b"\n".to_vec(), end_marker: Some(b"DONE".to_vec()) }
    }
}

/// Why an action text cannot be put in a language.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LanguageError {
    /// The text is empty.
    #[error("action text {index} is empty")]
    EmptyText {
        /// The id it would have had: the number of distinct texts pushed before it.
        index: usize,
    },
    /// The text contains the separator, so the separator could not mark where it ends.
    #[error("action text {text:?} contains the separator {separator:?}")]
    ContainsSeparator {
        /// The text, decoded as UTF-8 (lossily).
        text: String,
        /// The separator, decoded as UTF-8 (lossily).
        separator: String,
    },
    /// The text starts with the end marker, so writing the marker at a boundary would be
    /// ambiguous.
    #[error("action text {text:?} starts with the end marker {marker:?}")]
    StartsWithEndMarker {
        /// The text, decoded as UTF-8 (lossily).
        text: String,
        /// The end marker, decoded as UTF-8 (lossily).
        marker: String,
    },
    /// The configured separator is empty (checked on every push).
    #[error("the separator is empty")]
    EmptySeparator,
}

const NONE: u32 = u32::MAX;
const END: u32 = u32::MAX - 1;

fn hash(bytes: &[u8]) -> u64 {
    let mut hasher = rustc_hash::FxHasher::default();
    hasher.write(bytes);
    hasher.finish()
}

/// Collects the action texts of one state.
#[derive(Debug, Clone)]
pub struct LanguageBuilder {
    config: LanguageConfig,
    bytes: Vec<u8>,
    offsets: Vec<u32>,
    end_after: Vec<bool>,
    index: HashTable<ChoiceId>,
    end_here: bool,
}

impl LanguageBuilder {
    /// An empty builder for `config`; the plan may end at its boundary unless
    /// [`LanguageBuilder::end_here`] says otherwise.
    pub fn new(config: LanguageConfig) -> LanguageBuilder {
        LanguageBuilder { config, bytes: Vec::new(), offsets: vec![0], end_after: Vec::new(), index: HashTable::new(), end_here: true }
    }

    fn text(&self, choice: ChoiceId) -> &[u8] {
        &self.bytes[self.offsets[choice as usize] as usize..self.offsets[choice as usize + 1] as usize]
    }

    /// Adds an action text; `end_after`: the plan may end (EOS) right after this text,
    /// without a separator. A text added twice keeps its first id.
    pub fn push(&mut self, text: &[u8], end_after: bool) -> Result<ChoiceId, LanguageError> {
        let sep = &self.config.separator;
        let lossy = || String::from_utf8_lossy(text).into_owned();
        if sep.is_empty() {
            return Err(LanguageError::EmptySeparator);
        }
        if text.is_empty() {
            return Err(LanguageError::EmptyText { index: self.end_after.len() });
        }
        if text.windows(sep.len()).any(|w| w == sep.as_slice()) {
            return Err(LanguageError::ContainsSeparator { text: lossy(), separator: String::from_utf8_lossy(sep).into_owned() });
        }
        if let Some(marker) = self.config.end_marker.as_ref().filter(|m| !m.is_empty())
            && text.starts_with(marker)
        {
            return Err(LanguageError::StartsWithEndMarker { text: lossy(), marker: String::from_utf8_lossy(marker).into_owned() });
        }
        let h = hash(text);
        if let Some(&id) = self.index.find(h, |&id| self.text(id) == text) {
            self.end_after[id as usize] |= end_after;
            return Ok(id);
        }
        let id = self.end_after.len() as ChoiceId;
        self.bytes.extend_from_slice(text);
        self.offsets.push(self.bytes.len() as u32);
        self.end_after.push(end_after);
        let (bytes, offsets) = (&self.bytes, &self.offsets);
        self.index.insert_unique(h, id, |&id| hash(&bytes[offsets[id as usize] as usize..offsets[id as usize + 1] as usize]));
        Ok(id)
    }

    /// Whether the plan may end at this state's boundary (EOS or the end marker); default true.
    pub fn end_here(&mut self, allowed: bool) -> &mut LanguageBuilder {
        self.end_here = allowed;
        self
    }

    /// The language of the texts pushed, each followed by the separator, plus the end marker
    /// where the plan may end here and the marker is not empty.
    pub fn build(self) -> Language {
        // Keys: every text followed by the separator, and the end marker; sorted, then laid
        // out breadth first like the vocabulary trie.
        let sep = &self.config.separator;
        let choices = self.end_after.len();
        let mut key_bytes = Vec::with_capacity(self.bytes.len() + choices * sep.len() + 8);
        let mut key_range = Vec::with_capacity(choices + 1);
        for c in 0..choices as u32 {
            let start = key_bytes.len();
            key_bytes.extend_from_slice(self.text(c));
            key_bytes.extend_from_slice(sep);
            key_range.push((start, key_bytes.len(), c));
        }
        if self.end_here
            && let Some(marker) = self.config.end_marker.as_ref().filter(|m| !m.is_empty())
        {
            let start = key_bytes.len();
            key_bytes.extend_from_slice(marker);
            key_range.push((start, key_bytes.len(), END));
        }
        let key = |&(s, e, _): &(usize, usize, u32)| &key_bytes[s..e];
        key_range.sort_unstable_by(|a, b| key(a).cmp(key(b)));
        let keys: Vec<&[u8]> = key_range.iter().map(key).collect();
        let mut text_end = Vec::with_capacity(key_bytes.len());
        let mut event = Vec::with_capacity(key_bytes.len());
        let trie = FlatTrie::build(&keys, |_, depth, range| {
            let mut ends = NONE;
            let mut completes = NONE;
            for i in range {
                let (len, id) = (keys[i].len(), key_range[i].2);
                if len == depth {
                    completes = id;
                } else if id != END && len == depth + sep.len() {
                    ends = id;
                }
            }
            text_end.push(ends);
            event.push(completes);
        });
        Language {
            config: self.config,
            bytes: self.bytes,
            offsets: self.offsets,
            end_after: self.end_after,
            end_here: self.end_here,
            trie,
            text_end,
            event,
        }
    }
}

/// The allowed strings of one state, as a trie (see the module comment).
#[derive(Debug, Clone)]
pub struct Language {
    config: LanguageConfig,
    bytes: Vec<u8>,
    offsets: Vec<u32>,
    end_after: Vec<bool>,
    end_here: bool,
    trie: FlatTrie,
    /// Per node: the choice whose text ends here (the separator or EOS may follow).
    text_end: Vec<u32>,
    /// Per node: the choice completed by its separator, `END` for the end marker.
    event: Vec<u32>,
}

impl Language {
    /// The separator and end marker it was built with.
    pub fn config(&self) -> &LanguageConfig {
        &self.config
    }

    /// Number of distinct action texts.
    pub fn choices(&self) -> usize {
        self.end_after.len()
    }

    /// The text of `choice`, without the separator. Panics if `choice` is not below
    /// [`Language::choices`].
    pub fn text(&self, choice: ChoiceId) -> &[u8] {
        &self.bytes[self.offsets[choice as usize] as usize..self.offsets[choice as usize + 1] as usize]
    }

    /// Whether the plan may end at this language's boundary.
    pub fn end_here(&self) -> bool {
        self.end_here
    }

    /// Whether the plan may end right after `choice`'s text.
    pub fn end_after(&self, choice: ChoiceId) -> bool {
        self.end_after[choice as usize]
    }

    /// Number of trie nodes, the root included.
    pub fn node_count(&self) -> usize {
        self.trie.node_count()
    }

    #[inline]
    fn child(&self, node: u32, byte: u8) -> Option<u32> {
        self.trie.child(node, byte)
    }

    /// Emits every token whose bytes, appended at `node`, stay inside the trie: the paired
    /// walk of this trie and the vocabulary trie from their roots. It visits only the
    /// pairs of nodes both tries share, so its cost is the number of allowed tokens and
    /// their prefixes, not the vocabulary size.
    fn walk(&self, node: u32, trie: &VocabTrie, vnode: VocabNode, emit: &mut impl FnMut(TokenId)) {
        for lchild in self.trie.children(node) {
            let Some(vchild) = trie.child(vnode, self.trie.byte[lchild as usize]) else { continue };
            for &t in trie.tokens_at(vchild) {
                emit(t);
            }
            if trie.has_children(vchild) && self.trie.has_children(lchild) {
                self.walk(lchild, trie, vchild, emit);
            }
        }
    }
}

/// What a token did to the partial plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Inside an action text (or the end marker): nothing completed.
    Partial,
    /// The separator after this action was written: the action is complete. The matcher
    /// now waits for the next state's language ([`Matcher::enter`]).
    Action(ChoiceId),
    /// End of sequence right after this action's text: the action completes and the plan ends.
    ActionThenEnd(ChoiceId),
    /// The plan ended at a boundary (EOS or the end marker).
    End,
}

/// Why a token was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TokenError {
    /// The token's bytes leave the language, or it has no bytes, or it is a special token
    /// other than an end-of-sequence token at a point where the plan may end.
    #[error("token {token} ({text:?}) does not extend {prefix:?} towards an allowed action")]
    NotAllowed {
        /// The refused token.
        token: TokenId,
        /// Its bytes, decoded as UTF-8 (lossily).
        text: String,
        /// The partial action it was refused after ([`Matcher::prefix`]), decoded as UTF-8
        /// (lossily).
        prefix: String,
    },
    /// The id is not below the vocabulary's length.
    #[error("token {token} is outside the vocabulary")]
    UnknownToken {
        /// The refused id.
        token: TokenId,
    },
    /// An action was completed: [`Matcher::enter`] must give the next state's language first.
    #[error("an action was completed: enter the next state's language before the next token")]
    AwaitingLanguage,
    /// The plan has ended; no token is allowed.
    #[error("the plan has ended")]
    Finished,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Open,
    AwaitingLanguage,
    Finished,
}

/// The partial action `u` inside one state's language: Eq. 7 of the paper at the byte level.
///
/// **Boundaries.** A token is allowed at `u` iff its bytes `b` make `u·b` a prefix of
/// `text·separator` for an action text of this state, or of the end marker at a boundary.
/// A token may *end* exactly at the separator (that completes the action); a token whose
/// bytes run *past* the separator, into the next action, is refused: those bytes would be
/// judged against a state the plan has not reached. For byte-level BPE tokenizers whose
/// pre-tokenizer splits line breaks from letters (GPT-2, Llama 3, Qwen, SmolLM2) no
/// canonical tokenization crosses a `\n` separator, so nothing they would write is lost.
/// End-of-sequence is allowed only at a boundary: at the start of an action (when the
/// language allows ending there) or right after a complete action text marked
/// `end_after`. Special tokens other than EOS, and tokens with no bytes, are never allowed.
#[derive(Debug, Clone)]
pub struct Matcher {
    language: Arc<Language>,
    node: u32,
    prefix: Vec<u8>,
    phase: Phase,
}

impl Matcher {
    /// A matcher at the start of the first action, in `language` (the start state's).
    pub fn new(language: Arc<Language>) -> Matcher {
        Matcher { language, node: 0, prefix: Vec::new(), phase: Phase::Open }
    }

    /// The current state's language: the one given to [`Matcher::new`] or last to
    /// [`Matcher::enter`].
    pub fn language(&self) -> &Arc<Language> {
        &self.language
    }

    /// The bytes of the partial action written so far.
    pub fn prefix(&self) -> &[u8] {
        &self.prefix
    }

    /// At the start of an action (nothing of it written).
    pub fn at_boundary(&self) -> bool {
        self.phase == Phase::Open && self.node == 0
    }

    /// Whether the plan has ended (end-of-sequence or the end marker); every further token is
    /// refused with [`TokenError::Finished`].
    pub fn is_finished(&self) -> bool {
        self.phase == Phase::Finished
    }

    /// Waiting for [`Matcher::enter`] after a completed action.
    pub fn is_awaiting_language(&self) -> bool {
        self.phase == Phase::AwaitingLanguage
    }

    /// Starts the next action in `language` (the state after the completed action).
    pub fn enter(&mut self, language: Arc<Language>) {
        self.language = language;
        self.node = 0;
        self.prefix.clear();
        self.phase = Phase::Open;
    }

    fn eos_allowed(&self) -> bool {
        if self.phase != Phase::Open {
            return false;
        }
        if self.node == 0 {
            return self.language.end_here;
        }
        let choice = self.language.text_end[self.node as usize];
        choice != NONE && self.language.end_after[choice as usize]
    }

    /// Calls `emit` once per allowed token.
    pub fn for_each_allowed(&self, vocab: &Vocabulary, mut emit: impl FnMut(TokenId)) {
        if self.phase != Phase::Open {
            return;
        }
        self.language.walk(self.node, vocab.trie(), VocabTrie::ROOT, &mut emit);
        if self.eos_allowed() {
            vocab.eos().iter().copied().for_each(emit);
        }
    }

    /// The next-token mask at `u`, into `mask` (cleared first; resized to the vocabulary).
    pub fn fill_mask(&self, vocab: &Vocabulary, mask: &mut TokenMask) {
        mask.reset(vocab.len());
        self.for_each_allowed(vocab, |t| mask.insert(t));
    }

    /// The next-token mask at `u`.
    pub fn mask(&self, vocab: &Vocabulary) -> TokenMask {
        let mut mask = TokenMask::new(vocab.len());
        self.fill_mask(vocab, &mut mask);
        mask
    }

    /// The allowed tokens at `u`, in no particular order, into `out` (cleared first).
    pub fn allowed(&self, vocab: &Vocabulary, out: &mut Vec<TokenId>) {
        out.clear();
        self.for_each_allowed(vocab, |t| out.push(t));
    }

    /// Whether `token` is allowed at `u`, without computing the mask.
    pub fn is_allowed(&self, vocab: &Vocabulary, token: TokenId) -> bool {
        self.step(vocab, token).is_ok()
    }

    /// What [`Matcher::advance`] would report for `token`, without moving.
    pub fn peek(&self, vocab: &Vocabulary, token: TokenId) -> Result<Step, TokenError> {
        self.step(vocab, token).map(|(_, step)| step)
    }

    fn step(&self, vocab: &Vocabulary, token: TokenId) -> Result<(u32, Step), TokenError> {
        match self.phase {
            Phase::Open => {}
            Phase::AwaitingLanguage => return Err(TokenError::AwaitingLanguage),
            Phase::Finished => return Err(TokenError::Finished),
        }
        if token as usize >= vocab.len() {
            return Err(TokenError::UnknownToken { token });
        }
        let refuse = || TokenError::NotAllowed {
            token,
            text: String::from_utf8_lossy(vocab.token_bytes(token)).into_owned(),
            prefix: String::from_utf8_lossy(&self.prefix).into_owned(),
        };
        if vocab.is_special(token) {
            if !vocab.is_eos(token) || !self.eos_allowed() {
                return Err(refuse());
            }
            let choice = self.language.text_end[self.node as usize];
            return Ok((self.node, if self.node == 0 { Step::End } else { Step::ActionThenEnd(choice) }));
        }
        let bytes = vocab.token_bytes(token);
        if bytes.is_empty() {
            return Err(refuse());
        }
        let mut node = self.node;
        for &b in bytes {
            node = self.language.child(node, b).ok_or_else(refuse)?;
        }
        Ok((
            node,
            match self.language.event[node as usize] {
                NONE => Step::Partial,
                END => Step::End,
                choice => Step::Action(choice),
            },
        ))
    }

    /// Writes `token`: moves `u`, and reports a completed action or the end of the plan.
    /// A refused token leaves the matcher as it was.
    pub fn advance(&mut self, vocab: &Vocabulary, token: TokenId) -> Result<Step, TokenError> {
        let (node, step) = self.step(vocab, token)?;
        match step {
            Step::Partial => {
                self.node = node;
                self.prefix.extend_from_slice(vocab.token_bytes(token));
            }
            Step::Action(_) => {
                self.node = node;
                self.prefix.extend_from_slice(vocab.token_bytes(token));
                self.phase = Phase::AwaitingLanguage;
            }
            Step::ActionThenEnd(_) | Step::End => {
                if !vocab.is_special(token) {
                    self.prefix.extend_from_slice(vocab.token_bytes(token));
                }
                self.node = node;
                self.phase = Phase::Finished;
            }
        }
        Ok(step)
    }
}
