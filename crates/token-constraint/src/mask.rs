//! A set of token ids as a bitset over the vocabulary.

use crate::TokenId;

/// Allowed tokens, one bit per vocabulary entry (`words()` is ready for a logits mask).
#[derive(Debug, Clone, Default)]
pub struct TokenMask {
    words: Vec<u64>,
    len: usize,
    /// Indices of the words that may be non-zero: a reset clears only those, so a sparse
    /// mask over a large vocabulary costs its set bits, not the vocabulary size.
    dirty: Vec<u32>,
}

/// Equal when the same tokens are allowed over the same vocabulary size.
impl PartialEq for TokenMask {
    fn eq(&self, other: &TokenMask) -> bool {
        self.len == other.len && self.words == other.words
    }
}

impl Eq for TokenMask {}

impl TokenMask {
    /// An empty mask over `len` tokens.
    pub fn new(len: usize) -> TokenMask {
        TokenMask { words: vec![0; len.div_ceil(64)], len, dirty: Vec::new() }
    }

    /// Empties the mask and sizes it for `len` tokens, keeping the allocation.
    pub fn reset(&mut self, len: usize) {
        if len == self.len {
            for &w in &self.dirty {
                self.words[w as usize] = 0;
            }
        } else {
            self.words.clear();
            self.words.resize(len.div_ceil(64), 0);
            self.len = len;
        }
        self.dirty.clear();
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
            let word = &mut self.words[i / 64];
            if *word == 0 {
                self.dirty.push((i / 64) as u32);
            }
            *word |= 1 << (i % 64);
        }
    }

    /// Whether `token` is in the mask; false for ids outside its range.
    #[inline]
    pub fn contains(&self, token: TokenId) -> bool {
        let i = token as usize;
        i < self.len && self.words[i / 64] & (1 << (i % 64)) != 0
    }

    /// Number of allowed tokens.
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Whether no token is in the mask.
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
        mask.reset(130);
        assert!(mask.is_empty(), "a reset clears every word that was set");
        mask.insert(5);
        assert_eq!(mask.iter().collect::<Vec<_>>(), vec![5]);
        mask.reset(10);
        assert!(mask.is_empty() && mask.vocab_len() == 10);
    }
}
