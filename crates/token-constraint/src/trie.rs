//! The one trie layout both tries use: built breadth first from sorted byte strings into
//! flat arrays, with no per-node allocation.
//!
//! Node `n`'s children are the nodes `first_child[n]..first_child[n + 1]`, in byte order,
//! and `byte[c]` is the byte on the edge into node `c` (the root is node 0). Breadth-first
//! order keeps every node's children contiguous. Written by hand: trie crates (fst,
//! daachorse, toktrie, …) do not give the "follow one byte from this node" step a paired
//! walk of two tries needs.

use std::collections::VecDeque;

/// A trie in the flat layout of the module comment.
#[derive(Debug, Clone, Default)]
pub(crate) struct FlatTrie {
    pub byte: Vec<u8>,
    pub first_child: Vec<u32>,
}

impl FlatTrie {
    /// Builds the trie of `keys`, which must be sorted. `on_node(node, depth, range)` is
    /// called for each node in order, with the range of keys that pass through it (or end
    /// at it: those come first in the range, being the shortest).
    pub fn build<K: AsRef<[u8]>>(keys: &[K], mut on_node: impl FnMut(u32, usize, std::ops::Range<usize>)) -> FlatTrie {
        debug_assert!(keys.windows(2).all(|w| w[0].as_ref() <= w[1].as_ref()), "keys must be sorted");
        let mut byte = vec![0u8];
        let mut first_child = Vec::new();
        let mut queue: VecDeque<(usize, usize, usize)> = VecDeque::new();
        queue.push_back((0, 0, keys.len()));
        let mut next = 1u32;
        let mut node = 0u32;
        while let Some((depth, lo, hi)) = queue.pop_front() {
            on_node(node, depth, lo..hi);
            first_child.push(next);
            let mut i = lo;
            while i < hi && keys[i].as_ref().len() == depth {
                i += 1;
            }
            while i < hi {
                let b = keys[i].as_ref()[depth];
                let start = i;
                while i < hi && keys[i].as_ref()[depth] == b {
                    i += 1;
                }
                byte.push(b);
                queue.push_back((depth + 1, start, i));
                next += 1;
            }
            node += 1;
        }
        first_child.push(next);
        FlatTrie { byte, first_child }
    }

    pub fn node_count(&self) -> usize {
        self.byte.len()
    }

    /// The children of `node` as a range of node ids.
    #[inline]
    pub fn children(&self, node: u32) -> std::ops::Range<u32> {
        self.first_child[node as usize]..self.first_child[node as usize + 1]
    }

    #[inline]
    pub fn has_children(&self, node: u32) -> bool {
        self.first_child[node as usize] != self.first_child[node as usize + 1]
    }

    /// The child of `node` along `byte`: a scan for short rows, bisection for wide ones.
    #[inline]
    pub fn child(&self, node: u32, byte: u8) -> Option<u32> {
        let lo = self.first_child[node as usize] as usize;
        let hi = self.first_child[node as usize + 1] as usize;
        let row = &self.byte[lo..hi];
        if row.len() <= 8 {
            row.iter().position(|&b| b == byte).map(|i| (lo + i) as u32)
        } else {
            row.binary_search(&byte).ok().map(|i| (lo + i) as u32)
        }
    }

    pub fn heap_bytes(&self) -> usize {
        self.byte.capacity() + self.first_child.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_come_breadth_first_with_their_key_ranges() {
        let keys: Vec<&[u8]> = vec![b"", b"a", b"ab", b"ac", b"b"];
        let mut seen = Vec::new();
        let trie = FlatTrie::build(&keys, |node, depth, range| seen.push((node, depth, range)));
        assert_eq!(seen, vec![(0, 0, 0..5), (1, 1, 1..4), (2, 1, 4..5), (3, 2, 2..3), (4, 2, 3..4)]);
        assert_eq!(trie.child(0, b'a'), Some(1));
        assert_eq!(trie.child(1, b'c'), Some(4));
        assert_eq!(trie.child(2, b'a'), None);
        assert!(!trie.has_children(3) && trie.has_children(1));
        assert_eq!(trie.node_count(), 5);
    }
}
