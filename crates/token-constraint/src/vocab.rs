//! A vocabulary as token id → bytes, and its byte trie.
//!
//! The trie is laid out once in the flat breadth-first layout of [`crate::trie`]; the
//! tokens spelled by the path to node `n` are `tokens[token_start[n]..token_start[n + 1]]`
//! (several ids may share one byte string), and the root's 256 children are a direct
//! table. Nine bytes per node plus four per token.

use crate::TokenId;
use crate::trie::FlatTrie;

/// Why a vocabulary could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VocabularyError {
    /// An end-of-sequence id is not below the number of tokens.
    #[error("end-of-sequence token {token} is outside the vocabulary of {len} tokens")]
    EosOutOfRange {
        /// The end-of-sequence id.
        token: TokenId,
        /// The number of tokens.
        len: usize,
    },
    /// More tokens than `u32` ids can number, or more than `u32::MAX` bytes of token text in
    /// all.
    #[error("the vocabulary of {len} tokens is too large: more tokens than u32 ids can number, or more than u32::MAX bytes of token text")]
    TooLarge {
        /// The number of tokens.
        len: usize,
    },
}

/// One entry of a vocabulary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Token {
    /// The bytes the token stands for in text (for a special token, its literal text).
    pub bytes: Vec<u8>,
    /// Control tokens (`<|im_end|>`, `<s>`, …): never matched by their bytes.
    pub special: bool,
}

/// Token id → bytes, with the special tokens and the end-of-sequence tokens marked.
#[derive(Debug, Clone)]
pub struct Vocabulary {
    bytes: Vec<u8>,
    offsets: Vec<u32>,
    special: Vec<bool>,
    eos: Vec<TokenId>,
    trie: VocabTrie,
}

impl Vocabulary {
    /// A vocabulary whose token `i` is `tokens[i]`; `eos` lists the tokens that end a
    /// sequence (they are also marked special).
    pub fn new(tokens: Vec<Token>, eos: &[TokenId]) -> Result<Vocabulary, VocabularyError> {
        let len = tokens.len();
        if u32::try_from(len).is_err() {
            return Err(VocabularyError::TooLarge { len });
        }
        let mut bytes = Vec::with_capacity(tokens.iter().map(|t| t.bytes.len()).sum());
        let mut offsets = Vec::with_capacity(len + 1);
        let mut special = Vec::with_capacity(len);
        offsets.push(0);
        for token in &tokens {
            bytes.extend_from_slice(&token.bytes);
            offsets.push(u32::try_from(bytes.len()).map_err(|_| VocabularyError::TooLarge { len })?);
            special.push(token.special);
        }
        let mut eos = eos.to_vec();
        eos.sort_unstable();
        eos.dedup();
        for &token in &eos {
            let Some(flag) = special.get_mut(token as usize) else {
                return Err(VocabularyError::EosOutOfRange { token, len });
            };
            *flag = true;
        }
        let trie = VocabTrie::build(&tokens, &special);
        Ok(Vocabulary { bytes, offsets, special, eos, trie })
    }

    /// A vocabulary from plain byte strings, none special.
    pub fn from_bytes<B: AsRef<[u8]>>(tokens: &[B], eos: &[TokenId]) -> Result<Vocabulary, VocabularyError> {
        Vocabulary::new(tokens.iter().map(|b| Token { bytes: b.as_ref().to_vec(), special: false }).collect(), eos)
    }

    /// Number of tokens; ids run from 0 to `len() - 1`.
    pub fn len(&self) -> usize {
        self.special.len()
    }

    /// Whether the vocabulary has no tokens.
    pub fn is_empty(&self) -> bool {
        self.special.is_empty()
    }

    /// The bytes of `token` (empty for an id outside the vocabulary).
    pub fn token_bytes(&self, token: TokenId) -> &[u8] {
        let i = token as usize;
        if i >= self.len() {
            return &[];
        }
        &self.bytes[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Whether `token` is special (marked so, or an end-of-sequence token): never matched by its
    /// bytes. False for an id outside the vocabulary.
    pub fn is_special(&self, token: TokenId) -> bool {
        self.special.get(token as usize).copied().unwrap_or(false)
    }

    /// Whether `token` is one of the end-of-sequence tokens ([`Self::eos`]).
    pub fn is_eos(&self, token: TokenId) -> bool {
        self.eos.binary_search(&token).is_ok()
    }

    /// The end-of-sequence tokens, sorted.
    pub fn eos(&self) -> &[TokenId] {
        &self.eos
    }

    /// The byte trie of the non-special tokens.
    pub fn trie(&self) -> &VocabTrie {
        &self.trie
    }

    /// The bytes of a token sequence, special tokens as their literal text.
    pub fn decode(&self, tokens: &[TokenId]) -> Vec<u8> {
        tokens.iter().flat_map(|&t| self.token_bytes(t).iter().copied()).collect()
    }

    /// Heap bytes held by the vocabulary and its trie.
    pub fn heap_bytes(&self) -> usize {
        self.bytes.capacity() + self.offsets.capacity() * 4 + self.special.capacity() + self.eos.capacity() * 4 + self.trie.heap_bytes()
    }
}

/// A node of the [`VocabTrie`]; the root is [`VocabTrie::ROOT`].
pub type VocabNode = u32;

/// The byte trie of a vocabulary's non-special, non-empty tokens (see the module comment).
#[derive(Debug, Clone)]
pub struct VocabTrie {
    trie: FlatTrie,
    token_start: Vec<u32>,
    tokens: Vec<TokenId>,
    root_children: Box<[u32; 256]>,
}

const NO_NODE: u32 = u32::MAX;

impl VocabTrie {
    /// The root: the empty byte string, at which no token ends.
    pub const ROOT: VocabNode = 0;

    fn build(tokens: &[Token], special: &[bool]) -> VocabTrie {
        let mut order: Vec<u32> =
            (0..tokens.len() as u32).filter(|&t| !special[t as usize] && !tokens[t as usize].bytes.is_empty()).collect();
        order.sort_by(|&a, &b| tokens[a as usize].bytes.cmp(&tokens[b as usize].bytes).then(a.cmp(&b)));
        let keys: Vec<&[u8]> = order.iter().map(|&t| tokens[t as usize].bytes.as_slice()).collect();
        let mut token_start = vec![0u32];
        let mut ids = Vec::with_capacity(order.len());
        let trie = FlatTrie::build(&keys, |_, depth, range| {
            // The keys that end at this node come first in its range.
            ids.extend(range.clone().take_while(|&i| keys[i].len() == depth).map(|i| order[i]));
            token_start.push(ids.len() as u32);
        });
        ids.shrink_to_fit();
        token_start.shrink_to_fit();
        let mut root_children = Box::new([NO_NODE; 256]);
        for child in trie.children(0) {
            root_children[trie.byte[child as usize] as usize] = child;
        }
        VocabTrie { trie, token_start, tokens: ids, root_children }
    }

    /// Number of nodes, the root included.
    pub fn node_count(&self) -> usize {
        self.trie.node_count()
    }

    /// The child of `node` along `byte`, if some token continues that way.
    #[inline]
    pub fn child(&self, node: VocabNode, byte: u8) -> Option<VocabNode> {
        if node == Self::ROOT {
            let c = self.root_children[byte as usize];
            return (c != NO_NODE).then_some(c);
        }
        self.trie.child(node, byte)
    }

    /// The tokens whose bytes are exactly the path to `node`.
    #[inline]
    pub fn tokens_at(&self, node: VocabNode) -> &[TokenId] {
        &self.tokens[self.token_start[node as usize] as usize..self.token_start[node as usize + 1] as usize]
    }

    /// The children of `node` as (byte, child) pairs in byte order.
    pub fn children(&self, node: VocabNode) -> impl Iterator<Item = (u8, VocabNode)> + '_ {
        self.trie.children(node).map(|c| (self.trie.byte[c as usize], c))
    }

    /// Whether some token continues past `node`.
    #[inline]
    pub fn has_children(&self, node: VocabNode) -> bool {
        self.trie.has_children(node)
    }

    /// Heap bytes held by the trie, its 256-entry root table included.
    pub fn heap_bytes(&self) -> usize {
        self.trie.heap_bytes() + self.token_start.capacity() * 4 + self.tokens.capacity() * 4 + 256 * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walk(trie: &VocabTrie, bytes: &[u8]) -> Option<VocabNode> {
        bytes.iter().try_fold(VocabTrie::ROOT, |n, &b| trie.child(n, b))
    }

    #[test]
    fn every_token_is_found_at_the_end_of_its_path() {
        let words: Vec<&[u8]> = vec![b"a", b"ab", b"abc", b"b", b"ab", b"", b"zzzz", b"ba"];
        let vocab = Vocabulary::from_bytes(&words, &[]).unwrap();
        let trie = vocab.trie();
        assert_eq!(trie.tokens_at(walk(trie, b"ab").unwrap()), &[1, 4]);
        assert_eq!(trie.tokens_at(walk(trie, b"abc").unwrap()), &[2]);
        assert_eq!(trie.tokens_at(walk(trie, b"zz").unwrap()), &[] as &[u32]);
        assert_eq!(trie.tokens_at(walk(trie, b"zzzz").unwrap()), &[6]);
        assert!(walk(trie, b"abd").is_none());
        assert!(walk(trie, b"c").is_none());
        // The empty token is in no node: no path spells it.
        assert_eq!(trie.tokens_at(VocabTrie::ROOT), &[] as &[u32]);
        let children: Vec<u8> = trie.children(VocabTrie::ROOT).map(|(b, _)| b).collect();
        assert_eq!(children, b"abz");
    }

    #[test]
    fn special_tokens_stay_out_of_the_trie_and_eos_is_special() {
        let tokens = vec![
            Token { bytes: b"a".to_vec(), special: false },
            Token { bytes: b"<end>".to_vec(), special: true },
            Token { bytes: b"<".to_vec(), special: false },
        ];
        let vocab = Vocabulary::new(tokens, &[2]).unwrap();
        assert!(vocab.is_special(1) && vocab.is_special(2) && !vocab.is_special(0));
        assert!(vocab.is_eos(2) && !vocab.is_eos(1));
        assert!(vocab.trie().child(VocabTrie::ROOT, b'<').is_none());
        assert_eq!(vocab.decode(&[0, 1, 0]), b"a<end>a");
        assert_eq!(Vocabulary::from_bytes(&[b"a"], &[1]).unwrap_err(), VocabularyError::EosOutOfRange { token: 1, len: 1 });
    }

    #[test]
    fn wide_nodes_are_searched_by_bisection() {
        let words: Vec<Vec<u8>> = (0u8..=255).map(|b| vec![b'x', b]).chain([b"x".to_vec()]).collect();
        let vocab = Vocabulary::from_bytes(&words, &[]).unwrap();
        let x = vocab.trie().child(VocabTrie::ROOT, b'x').unwrap();
        for b in 0u8..=255 {
            let node = vocab.trie().child(x, b).unwrap();
            assert_eq!(vocab.trie().tokens_at(node), &[u32::from(b)]);
        }
    }
}
