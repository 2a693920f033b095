//! A Q4_1 × Q8_1 matrix product bitwise equal to candle-core's, and faster: candle 0.11 has
//! SIMD kernels for Q4_0, Q8_0 and the k-quants but computes Q4_1 (SmolLM2's format) one block
//! at a time with a scalar float chain. The activations are quantized to Q8_1 exactly as candle
//! does it (same rounding, same f16 scales); each block's integer dot product is exact whatever
//! the order; the per-block float terms are combined in candle's order, one chain per output,
//! with several outputs side by side (eight lanes of AVX2 where the build has it, else four
//! chains the compiler vectorises), so the result is the same float for float.

use half::f16;

const BLOCK: usize = 32;
/// Bytes of one GGML Q4_1 block: f16 scale, f16 minimum, 16 bytes of nibbles.
const BLOCK_BYTES: usize = 20;

/// Rows are stored in groups of this many, interleaved block by block.
const GROUP: usize = 8;

/// A `rows × columns` Q4_1 matrix, unpacked into separate arrays. Rows come in groups of
/// [`GROUP`], interleaved block by block (group g, block b: the scales, minimums and nibbles of
/// its eight rows side by side), so that the AVX2 kernel reads each with one load; the last
/// group is padded with zero rows.
#[derive(Debug)]
pub(crate) struct Q4_1Matrix {
    rows: usize,
    blocks: usize,
    scales: Vec<f32>,
    minimums: Vec<f32>,
    nibbles: Vec<[u8; 16]>,
}

/// Activation rows quantized to Q8_1: per block a scale `d`, `s = d · Σq`, and 32 `i8`s.
struct Q8_1Rows {
    scales: Vec<f32>,
    sums: Vec<f32>,
    quants: Vec<[i8; BLOCK]>,
}

impl Q4_1Matrix {
    /// From GGML's Q4_1 bytes (row-major blocks); `None` when sizes do not fit.
    pub(crate) fn from_ggml(bytes: &[u8], rows: usize, columns: usize) -> Option<Self> {
        if !columns.is_multiple_of(BLOCK) || bytes.len() != rows * columns / BLOCK * BLOCK_BYTES {
            return None;
        }
        let blocks = columns / BLOCK;
        let count = rows.div_ceil(GROUP) * GROUP * blocks;
        let mut matrix = Q4_1Matrix { rows, blocks, scales: vec![0.0; count], minimums: vec![0.0; count], nibbles: vec![[0; 16]; count] };
        for (i, block) in bytes.chunks_exact(BLOCK_BYTES).enumerate() {
            let at = matrix.index(i / blocks, i % blocks);
            matrix.scales[at] = f16::from_le_bytes([block[0], block[1]]).to_f32();
            matrix.minimums[at] = f16::from_le_bytes([block[2], block[3]]).to_f32();
            matrix.nibbles[at].copy_from_slice(&block[4..]);
        }
        Some(matrix)
    }

    /// Where block `b` of `row` is stored.
    fn index(&self, row: usize, b: usize) -> usize {
        ((row / GROUP) * self.blocks + b) * GROUP + row % GROUP
    }

    /// `x · Wᵀ` for `m` rows of `x` (`m × columns`), as `m × rows`, on candle's worker pool.
    pub(crate) fn matmul(&self, x: &[f32], m: usize) -> Vec<f32> {
        let columns = self.blocks * BLOCK;
        debug_assert_eq!(x.len(), m * columns);
        let activations = quantize_q8_1(x);
        // A long prefill: work items are blocks of activation rows, each writing its rows of
        // the output in place. Splitting by weight rows (below) writes a transposed output
        // that then has to be turned around, 8% of a 1,300-token prefill.
        const ACTIVATION_ROWS_PER_ITEM: usize = 32;
        if m >= 2 * ACTIVATION_ROWS_PER_ITEM {
            let mut out = vec![0f32; m * self.rows];
            super::pool::for_each_chunk(
                &mut out,
                ACTIVATION_ROWS_PER_ITEM * self.rows,
                true,
                || (),
                |_, item, out| self.rows_for(&activations, item * ACTIVATION_ROWS_PER_ITEM, out),
            );
            return out;
        }
        // Work items are ranges of weight rows; each writes its own slice of a transposed
        // output (row-major by weight row), so no two items share memory.
        const ROWS_PER_ITEM: usize = 16;
        let mut transposed = vec![0f32; self.rows * m];
        let parallel = self.rows * self.blocks * m >= 4096;
        super::pool::for_each_chunk(
            &mut transposed,
            ROWS_PER_ITEM * m,
            parallel,
            || (),
            |_, item, out| {
                let first = item * ROWS_PER_ITEM;
                let end = (first + ROWS_PER_ITEM).min(self.rows);
                let mut row = first;
                #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
                while row + 8 <= end {
                    // Up to ACTIVATION_ROWS activation rows per pass: the eight weight rows'
                    // nibbles are unpacked once per block for all of them.
                    let mut r = 0;
                    while r < m {
                        let count = (m - r).min(avx2::ACTIVATION_ROWS);
                        let values = avx2::eight_row_dots(self, row, &activations, r, count);
                        for (i, row_values) in values.iter().take(count).enumerate() {
                            for (k, &v) in row_values.iter().enumerate() {
                                out[(row - first + k) * m + r + i] = v;
                            }
                        }
                        r += count;
                    }
                    row += 8;
                }
                while row + 4 <= end {
                    for r in 0..m {
                        let values = self.four_row_dots(row, &activations, r);
                        for (k, v) in values.into_iter().enumerate() {
                            out[(row - first + k) * m + r] = v;
                        }
                    }
                    row += 4;
                }
                for row in row..end {
                    for r in 0..m {
                        out[(row - first) * m + r] = self.row_dot(row, &activations, r);
                    }
                }
            },
        );
        if m == 1 {
            return transposed;
        }
        transpose(&transposed, self.rows, m)
    }

    /// Every output of the activation rows `first..first + out.len() / rows`, into `out`
    /// (row-major, `rows` wide): the same kernels as the split by weight rows, so the same floats.
    fn rows_for(&self, x: &Q8_1Rows, first: usize, out: &mut [f32]) {
        let (rows, n) = (self.rows, out.len() / self.rows);
        let mut row = 0;
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        while row + 8 <= rows {
            // Each group's nibbles are read for every activation row of the item while they
            // are in the L1 cache.
            let mut r = 0;
            while r < n {
                let count = (n - r).min(avx2::ACTIVATION_ROWS);
                let values = avx2::eight_row_dots(self, row, x, first + r, count);
                for (i, row_values) in values.iter().take(count).enumerate() {
                    out[(r + i) * rows + row..][..8].copy_from_slice(row_values);
                }
                r += count;
            }
            row += 8;
        }
        while row + 4 <= rows {
            for r in 0..n {
                out[r * rows + row..][..4].copy_from_slice(&self.four_row_dots(row, x, first + r));
            }
            row += 4;
        }
        for row in row..rows {
            for r in 0..n {
                out[r * rows + row] = self.row_dot(row, x, first + r);
            }
        }
    }

    /// Candle's `vec_dot` for Q4_1: per block `sumi · d_w · d_x + m_w · s_x`, summed in order.
    fn row_dot(&self, row: usize, x: &Q8_1Rows, r: usize) -> f32 {
        let a = r * self.blocks;
        let mut sum = 0f32;
        for b in 0..self.blocks {
            let w = self.index(row, b);
            sum +=
                block_dot(&self.nibbles[w], &x.quants[a + b]) as f32 * self.scales[w] * x.scales[a + b] + self.minimums[w] * x.sums[a + b];
        }
        sum
    }
}

impl Q4_1Matrix {
    /// [`Q4_1Matrix::row_dot`] for rows `row..row + 4` at once: four independent float chains
    /// (each in candle's order) that the processor overlaps and the compiler puts in one vector.
    fn four_row_dots(&self, row: usize, x: &Q8_1Rows, r: usize) -> [f32; 4] {
        let a = r * self.blocks;
        let mut sums = [0f32; 4];
        for b in 0..self.blocks {
            let (aq, ad, asum) = (&x.quants[a + b], x.scales[a + b], x.sums[a + b]);
            let mut integer = [0i32; 4];
            for (k, value) in integer.iter_mut().enumerate() {
                *value = block_dot(&self.nibbles[self.index(row + k, b)], aq);
            }
            for k in 0..4 {
                let w = self.index(row + k, b);
                sums[k] += integer[k] as f32 * self.scales[w] * ad + self.minimums[w] * asum;
            }
        }
        sums
    }
}

/// The AVX2 kernel: eight weight rows against up to four activation rows, one f32 lane per
/// weight row.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[allow(unsafe_code)]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{Q4_1Matrix, Q8_1Rows};

    fn m128(bytes: &[u8; 16]) -> [i64; 2] {
        let (lo, hi) = bytes.split_at(8);
        [i64::from_le_bytes(lo.try_into().unwrap_or_default()), i64::from_le_bytes(hi.try_into().unwrap_or_default())]
    }

    /// Activation rows one call handles.
    pub(super) const ACTIVATION_ROWS: usize = 4;

    /// `row_dot` for the group of rows `row..row + 8` (`row` a multiple of 8) against the
    /// activation rows `r..r + count` (`count` ≤ [`ACTIVATION_ROWS`]); entry `i` of the result
    /// is for activation row `r + i` (entries past `count` are zero).
    pub(super) fn eight_row_dots(matrix: &Q4_1Matrix, row: usize, x: &Q8_1Rows, r: usize, count: usize) -> [[f32; 8]; ACTIVATION_ROWS] {
        debug_assert_eq!(row % super::GROUP, 0);
        debug_assert!((1..=ACTIVATION_ROWS).contains(&count));
        // SAFETY: this module is compiled only when the whole build enables AVX2
        // (`cfg(target_feature = "avx2")`, e.g. `-C target-cpu=native` on this machine), so
        // the CPU running it has the instructions; the intrinsics touch no memory through
        // pointers (values go in and out by `set`/`extract`), so there is nothing else to uphold.
        unsafe { eight_row_dots_avx2(matrix, row, x, r, count.min(ACTIVATION_ROWS)) }
    }

    #[target_feature(enable = "avx2")]
    fn eight_row_dots_avx2(matrix: &Q4_1Matrix, row: usize, x: &Q8_1Rows, r: usize, count: usize) -> [[f32; 8]; ACTIVATION_ROWS] {
        let blocks = matrix.blocks;
        let low_nibbles = _mm_set1_epi8(0x0F);
        let ones = _mm256_set1_epi16(1);
        let mut acc = [_mm256_setzero_ps(); ACTIVATION_ROWS];
        for b in 0..blocks {
            let base = matrix.index(row, b);
            let nibbles: &[[u8; 16]; 8] = matrix.nibbles[base..base + 8].try_into().unwrap_or(&[[0; 16]; 8]);
            let scales: &[f32; 8] = matrix.scales[base..base + 8].try_into().unwrap_or(&[0.0; 8]);
            let minimums: &[f32; 8] = matrix.minimums[base..base + 8].try_into().unwrap_or(&[0.0; 8]);
            // The eight rows' 32 weights of this block, unpacked once for every activation row.
            let mut weights = [_mm256_setzero_si256(); 8];
            for (w, block) in weights.iter_mut().zip(nibbles) {
                let [lo, hi] = m128(block);
                let q = _mm_set_epi64x(hi, lo);
                let low = _mm_and_si128(q, low_nibbles);
                let high = _mm_and_si128(_mm_srli_epi16::<4>(q), low_nibbles);
                // Lanes 0..16 hold the low nibbles (elements 0..16), 16..32 the high ones.
                *w = _mm256_set_m128i(high, low);
            }
            let scales = _mm256_set_ps(scales[7], scales[6], scales[5], scales[4], scales[3], scales[2], scales[1], scales[0]);
            let minimums =
                _mm256_set_ps(minimums[7], minimums[6], minimums[5], minimums[4], minimums[3], minimums[2], minimums[1], minimums[0]);
            for (i, acc) in acc.iter_mut().enumerate().take(count) {
                let a_at = (r + i) * blocks + b;
                let aq = &x.quants[a_at];
                let mut words = [0i64; 4];
                for (w, chunk) in words.iter_mut().zip(aq.chunks_exact(8)) {
                    let mut bytes = [0u8; 8];
                    for (dst, &src) in bytes.iter_mut().zip(chunk) {
                        *dst = src as u8;
                    }
                    *w = i64::from_le_bytes(bytes);
                }
                let a = _mm256_set_epi64x(words[3], words[2], words[1], words[0]);
                let mut sums = [_mm256_setzero_si256(); 8];
                for (sum, &w) in sums.iter_mut().zip(&weights) {
                    *sum = _mm256_madd_epi16(_mm256_maddubs_epi16(w, a), ones);
                }
                // Eight vectors of eight partial sums → one vector of the eight block sums.
                let t0 = _mm256_hadd_epi32(sums[0], sums[1]);
                let t1 = _mm256_hadd_epi32(sums[2], sums[3]);
                let t2 = _mm256_hadd_epi32(sums[4], sums[5]);
                let t3 = _mm256_hadd_epi32(sums[6], sums[7]);
                let u0 = _mm256_hadd_epi32(t0, t1);
                let u1 = _mm256_hadd_epi32(t2, t3);
                let integer = _mm256_add_epi32(_mm256_permute2x128_si256::<0x20>(u0, u1), _mm256_permute2x128_si256::<0x31>(u0, u1));
                // candle's order: ((sumi · d_w) · d_x) + (m_w · s_x), then added to the running
                // sum; separate multiplies and adds (no fused multiply-add), as the scalar code
                // compiles.
                let term = _mm256_add_ps(
                    _mm256_mul_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(integer), scales), _mm256_set1_ps(x.scales[a_at])),
                    _mm256_mul_ps(minimums, _mm256_set1_ps(x.sums[a_at])),
                );
                *acc = _mm256_add_ps(*acc, term);
            }
        }
        let lane = |v: __m128, i: i32| -> f32 {
            f32::from_bits(match i {
                0 => _mm_extract_ps::<0>(v),
                1 => _mm_extract_ps::<1>(v),
                2 => _mm_extract_ps::<2>(v),
                _ => _mm_extract_ps::<3>(v),
            } as u32)
        };
        let mut out = [[0f32; 8]; ACTIVATION_ROWS];
        for (values, &acc) in out.iter_mut().zip(&acc).take(count) {
            let low = _mm256_castps256_ps128(acc);
            let high = _mm256_extractf128_ps::<1>(acc);
            *values = [lane(low, 0), lane(low, 1), lane(low, 2), lane(low, 3), lane(high, 0), lane(high, 1), lane(high, 2), lane(high, 3)];
        }
        out
    }
}

/// The `columns × rows` matrix of the row-major `rows × columns` one, sixteen columns (one
/// cache line of each input row) at a time, so that the output is written as sixteen
/// sequential streams. Written value by value down each input row, every write went to another
/// cache line, and at the strides of these matrices (multiples of 256 bytes) the lines fell
/// into a few cache sets and evicted each other: the transpose was 8% of a long prefill.
fn transpose(matrix: &[f32], rows: usize, columns: usize) -> Vec<f32> {
    const LINE: usize = 16;
    let mut out = vec![0f32; rows * columns];
    for column_start in (0..columns).step_by(LINE) {
        let width = LINE.min(columns - column_start);
        for row in 0..rows {
            let values = &matrix[row * columns + column_start..][..width];
            for (i, &v) in values.iter().enumerate() {
                out[(column_start + i) * rows + row] = v;
            }
        }
    }
    out
}

/// Σ_j lo(q_j)·a_j + hi(q_j)·a_{j+16}: exact in i32, shaped for 16-lane i16 SIMD.
#[inline(always)]
fn block_dot(q: &[u8; 16], a: &[i8; BLOCK]) -> i32 {
    let mut products = [0i16; BLOCK];
    for j in 0..16 {
        products[j] = (q[j] & 0x0F) as i16 * a[j] as i16;
        products[j + 16] = (q[j] >> 4) as i16 * a[j + 16] as i16;
    }
    products.iter().map(|&p| p as i32).sum()
}

/// candle's `quantize_row_q8_1`, value for value.
fn quantize_q8_1(x: &[f32]) -> Q8_1Rows {
    let count = x.len() / BLOCK;
    let mut rows = Q8_1Rows { scales: Vec::with_capacity(count), sums: Vec::with_capacity(count), quants: Vec::with_capacity(count) };
    for block in x.chunks_exact(BLOCK) {
        let amax = block.iter().fold(0f32, |m, v| m.max(v.abs()));
        let d = amax / 127.0;
        let id = if d != 0.0 { 1.0 / d } else { 0.0 };
        let d16 = f16::from_f32(d);
        let mut q = [0i8; BLOCK];
        let mut sum = 0i32;
        for j in 0..BLOCK {
            q[j] = (block[j] * id).round() as i8;
            sum += q[j] as i32;
        }
        rows.scales.push(d16.to_f32());
        rows.sums.push((f16::from_f32(sum as f32) * d16).to_f32());
        rows.quants.push(q);
    }
    rows
}

#[cfg(test)]
mod tests {
    use candle_core::quantized::{GgmlDType, QMatMul, QTensor};
    use candle_core::{Device, Module, Tensor};

    use super::*;

    fn pseudo_random(n: usize, seed: u32) -> Vec<f32> {
        let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state % 20_001) as f32 / 10_000.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn transpose_moves_every_value_once() {
        for (rows, columns) in [(1, 1), (3, 70), (70, 3), (33, 65), (64, 64)] {
            let matrix: Vec<f32> = (0..rows * columns).map(|i| i as f32).collect();
            let out = transpose(&matrix, rows, columns);
            for r in 0..rows {
                for c in 0..columns {
                    assert_eq!(out[c * rows + r], matrix[r * columns + c], "{rows} x {columns} at ({r}, {c})");
                }
            }
        }
    }

    #[test]
    fn equals_candles_q4_1_matmul_bit_for_bit() {
        for (rows, columns, m) in [(37, 64, 1), (64, 128, 3), (130, 256, 17), (8, 64, 1), (3, 576, 2), (43, 64, 70), (64, 128, 64)] {
            let w = Tensor::from_vec(pseudo_random(rows * columns, 1), (rows, columns), &Device::Cpu).expect("tensor");
            let q = QTensor::quantize(&w, GgmlDType::Q4_1).expect("quantize");
            let ours = Q4_1Matrix::from_ggml(&q.data().expect("bytes"), rows, columns).expect("fits");
            let x = pseudo_random(m * columns, 2);
            let candle = QMatMul::from_qtensor(q)
                .expect("matmul")
                .forward(&Tensor::from_vec(x.clone(), (m, columns), &Device::Cpu).expect("tensor"))
                .expect("forward")
                .flatten_all()
                .expect("flat")
                .to_vec1::<f32>()
                .expect("vec");
            let mine = ours.matmul(&x, m);
            assert_eq!(mine.len(), candle.len());
            for (i, (a, b)) in mine.iter().zip(&candle).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "({rows}x{columns}, m={m}) element {i}: {a} vs {b}");
            }
        }
        assert!(Q4_1Matrix::from_ggml(&[0; 19], 1, 32).is_none());
    }
}
