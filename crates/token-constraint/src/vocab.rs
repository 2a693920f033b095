//! A vocabulary as token id → bytes, and its byte trie.
//!
//! The trie is laid out once, breadth first, in flat arrays: node `n`'s children are the
//! nodes `first_child[n]..first_child[n + 1]`, sorted by byte, and the tokens spelled by the
//! path to `n` are `tokens[token_start[n]..token_start[n + 1]]` (several ids may share one
//! byte string). Nine bytes per node plus four per token; no pointers to chase but one
//! array index per step. Written by hand: the crates that build tries (toktrie, fst, …) do
//! not give the "follow one byte from this node" step a paired walk needs, or bring a
//! grammar engine with them.

use crate::TokenId;

/// Why a vocabulary could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VocabularyError {
    #[error("end-of-sequence token {token} is outside the vocabulary of {len} tokens")]
    EosOutOfRange { token: TokenId, len: usize },
    #[error("the vocabulary has {len} tokens, more than token ids can number")]
    TooLarge { len: usize },
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

    pub fn len(&self) -> usize {
        self.special.len()
    }

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

    pub fn is_special(&self, token: TokenId) -> bool {
        self.special.get(token as usize).copied().unwrap_or(false)
    }

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
    byte: Vec<u8>,
    first_child: Vec<u32>,
    token_start: Vec<u32>,
    tokens: Vec<TokenId>,
    root_children: Box<[u32; 256]>,
}

const NO_NODE: u32 = u32::MAX;

impl VocabTrie {
    pub const ROOT: VocabNode = 0;

    fn build(tokens: &[Token], special: &[bool]) -> VocabTrie {
        // Sorted byte strings make each node's children arrive in byte order, so a
        // breadth-first pass over runs of equal prefixes lays out the flat arrays directly.
        let mut order: Vec<u32> =
            (0..tokens.len() as u32).filter(|&t| !special[t as usize] && !tokens[t as usize].bytes.is_empty()).collect();
        order.sort_by(|&a, &b| tokens[a as usize].bytes.cmp(&tokens[b as usize].bytes).then(a.cmp(&b)));
        let key = |i: u32| tokens[order[i as usize] as usize].bytes.as_slice();

        let mut byte = vec![0u8];
        let mut first_child = Vec::new();
        let mut token_start = vec![0u32];
        let mut ids = Vec::new();
        // The queue holds, per node in breadth-first order, its depth and the range of
        // `order` whose strings pass through it.
        let mut queue: std::collections::VecDeque<(usize, u32, u32)> = std::collections::VecDeque::new();
        queue.push_back((0, 0, order.len() as u32));
        let mut next_node = 1u32;
        while let Some((depth, lo, hi)) = queue.pop_front() {
            first_child.push(next_node);
            let mut i = lo;
            // Strings that end at this node are first in sorted order.
            while i < hi && key(i).len() == depth {
                ids.push(order[i as usize]);
                i += 1;
            }
            token_start.push(ids.len() as u32);
            while i < hi {
                let b = key(i)[depth];
                let start = i;
                while i < hi && key(i)[depth] == b {
                    i += 1;
                }
                byte.push(b);
                queue.push_back((depth + 1, start, i));
                next_node += 1;
            }
        }
        first_child.push(next_node);
        let mut root_children = Box::new([NO_NODE; 256]);
        for child in first_child[0]..first_child[1] {
            root_children[byte[child as usize] as usize] = child;
        }
        byte.shrink_to_fit();
        ids.shrink_to_fit();
        VocabTrie { byte, first_child, token_start, tokens: ids, root_children }
    }

    pub fn node_count(&self) -> usize {
        self.byte.len()
    }

    /// The child of `node` along `byte`, if some token continues that way.
    #[inline]
    pub fn child(&self, node: VocabNode, byte: u8) -> Option<VocabNode> {
        if node == Self::ROOT {
            let c = self.root_children[byte as usize];
            return (c != NO_NODE).then_some(c);
        }
        let lo = self.first_child[node as usize] as usize;
        let hi = self.first_child[node as usize + 1] as usize;
        let bytes = &self.byte[lo..hi];
        if bytes.len() <= 8 {
            bytes.iter().position(|&b| b == byte).map(|i| (lo + i) as u32)
        } else {
            bytes.binary_search(&byte).ok().map(|i| (lo + i) as u32)
        }
    }

    /// The tokens whose bytes are exactly the path to `node`.
    #[inline]
    pub fn tokens_at(&self, node: VocabNode) -> &[TokenId] {
        &self.tokens[self.token_start[node as usize] as usize..self.token_start[node as usize + 1] as usize]
    }

    /// The children of `node` as (byte, child) pairs in byte order.
    pub fn children(&self, node: VocabNode) -> impl Iterator<Item = (u8, VocabNode)> + '_ {
        let lo = self.first_child[node as usize];
        let hi = self.first_child[node as usize + 1];
        (lo..hi).map(|c| (self.byte[c as usize], c))
    }

    /// Whether some token continues past `node`.
    #[inline]
    pub fn has_children(&self, node: VocabNode) -> bool {
        self.first_child[node as usize] != self.first_child[node as usize + 1]
    }

    pub fn heap_bytes(&self) -> usize {
        self.byte.capacity() + self.first_child.capacity() * 4 + self.token_start.capacity() * 4 + self.tokens.capacity() * 4 + 256 * 4
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
