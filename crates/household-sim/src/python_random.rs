//! Python's `random.Random(seed).choice`, so that a seeded random walk here draws the same
//! commands as `alfworld_trace.py --random N --seed S` draws in the real engine, and the two
//! can be compared step by step.
//!
//! CPython seeds MT19937 from an integer with `init_by_array` over its 32-bit words (least
//! significant first; `[0]` for zero), and `choice(seq)` is `seq[_randbelow(len(seq))]`,
//! where `_randbelow(n)` draws `getrandbits(k)` (`k = n.bit_length()`, the top `k` bits of
//! one 32-bit output) until the draw is below `n`. The generator is `rand_mt`'s.

use rand_mt::Mt;

/// A Python `random.Random(seed)`, for `choice` only.
#[derive(Debug, Clone)]
pub struct PythonRandom {
    mt: Mt,
}

impl PythonRandom {
    /// The generator `random.Random(seed)` makes, for a non-negative integer seed.
    pub fn new(seed: u64) -> PythonRandom {
        let mut key: Vec<u32> = Vec::new();
        let mut rest = seed;
        while rest > 0 {
            key.push(rest as u32);
            rest >>= 32;
        }
        if key.is_empty() {
            key.push(0);
        }
        PythonRandom { mt: Mt::new_with_key(key) }
    }

    fn getrandbits(&mut self, k: u32) -> u32 {
        debug_assert!((1..=32).contains(&k));
        self.mt.next_u32() >> (32 - k)
    }

    /// The index `choice` picks from a sequence of `len` items (`len > 0`).
    pub fn choice_index(&mut self, len: usize) -> usize {
        assert!(len > 0 && len <= u32::MAX as usize, "choice from an empty or huge sequence");
        let n = len as u32;
        let k = 32 - n.leading_zeros();
        loop {
            let r = self.getrandbits(k);
            if r < n {
                return r as usize;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[random.Random(s).choice(range(10)) for _ in range(8)]` for s = 0 and s = 1738, and
    /// `random.Random(2**40 + 7).choice(range(1000))` three times, as CPython 3.11 prints them.
    #[test]
    fn draws_what_cpython_draws() {
        let draws = |seed: u64, n: usize, count: usize| {
            let mut rng = PythonRandom::new(seed);
            (0..count).map(|_| rng.choice_index(n)).collect::<Vec<_>>()
        };
        assert_eq!(draws(0, 10, 8), PY_SEED_0);
        assert_eq!(draws(1738, 10, 8), PY_SEED_1738);
        assert_eq!(draws((1 << 40) + 7, 1000, 3), PY_SEED_BIG);
    }

    const PY_SEED_0: [usize; 8] = [6, 6, 0, 4, 8, 7, 6, 4];
    const PY_SEED_1738: [usize; 8] = [8, 1, 6, 3, 8, 5, 2, 6];
    const PY_SEED_BIG: [usize; 3] = [628, 765, 834];
}
