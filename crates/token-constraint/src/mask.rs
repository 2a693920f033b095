//! A set of token ids as a bitset over the vocabulary.

use crate::TokenId;

/// Allowed tokens, one bit per vocabulary entry (`words()` is ready for a logits mask).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TokenMask {
    words: Vec<u64>,
    len: usize,
}

impl TokenMask {
    /// An empty mask over `len` tokens.
    pub fn new(len: usize) -> TokenMask {
        TokenMask { words: vec![0; len.div_ceil(64)], len }
    }

    /// Empties the mask and sizes it for `len` tokens, keeping the allocation.
    pub fn reset(&mut self, len: usize) {
        self.words.clear();
        self.words.resize(len.div_ceil(64), 0);
        self.len = len;
    }

    /// Number of tokens the mask ranges over.
    pub fn vocab_len(&self) -> usize {
        self.len
    }

    /// Adds `token`; ids outside the range are ignored.
    #[inline]
    pub fn insert(&mut self, token: TokenId) {
        let i = token as usize;
        if i < self.len {
            self.words[i / 64] |= 1 << (i % 64);
        }
    }

    #[inline]
    pub fn contains(&self, token: TokenId) -> bool {
        let i = token as usize;
        i < self.len && self.words[i / 64] & (1 << (i % 64)) != 0
    }

    /// Number of allowed tokens.
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.words.iter().all(|&w| w == 0)
    }

    /// The allowed tokens in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = TokenId> + '_ {
        self.words.iter().enumerate().flat_map(|(i, &word)| {
            let mut w = word;
            std::iter::from_fn(move || {
                if w == 0 {
                    return None;
                }
                let bit = w.trailing_zeros();
                w &= w - 1;
                Some((i * 64) as TokenId + bit)
            })
        })
    }

    /// The bits, token `i` at bit `i % 64` of word `i / 64`.
    pub fn words(&self) -> &[u64] {
        &self.words
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_go_in_and_come_out_in_order() {
        let mut mask = TokenMask::new(130);
        for t in [129, 0, 64, 63, 200] {
            mask.insert(t);
        }
        assert_eq!(mask.iter().collect::<Vec<_>>(), vec![0, 63, 64, 129]);
        assert_eq!(mask.count(), 4);
        assert!(mask.contains(64) && !mask.contains(65) && !mask.contains(200));
        mask.reset(10);
        assert!(mask.is_empty() && mask.vocab_len() == 10);
    }
}
