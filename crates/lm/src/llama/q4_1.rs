//! A Q4_1 × Q8_1 matrix product in safe Rust that the compiler vectorises, bitwise equal to
//! candle-core's: candle 0.11 has SIMD kernels for Q4_0, Q8_0 and the k-quants but computes
//! Q4_1 (SmolLM2's format) with a scalar loop. The activations are quantized to Q8_1 exactly as
//! candle does it (same rounding, same f16 scales), each block's integer dot product is exact
//! whatever the order, and the per-block float terms are combined in candle's order, so the
//! result is the same float for float.

use std::sync::Mutex;

use half::f16;

const BLOCK: usize = 32;
/// Bytes of one GGML Q4_1 block: f16 scale, f16 minimum, 16 bytes of nibbles.
const BLOCK_BYTES: usize = 20;

/// A `rows × columns` Q4_1 matrix, unpacked into separate arrays.
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
        let count = rows * columns / BLOCK;
        let (mut scales, mut minimums, mut nibbles) = (Vec::with_capacity(count), Vec::with_capacity(count), Vec::with_capacity(count));
        for block in bytes.chunks_exact(BLOCK_BYTES) {
            scales.push(f16::from_le_bytes([block[0], block[1]]).to_f32());
            minimums.push(f16::from_le_bytes([block[2], block[3]]).to_f32());
            let mut q = [0u8; 16];
            q.copy_from_slice(&block[4..]);
            nibbles.push(q);
        }
        Some(Q4_1Matrix { rows, blocks: columns / BLOCK, scales, minimums, nibbles })
    }

    /// `x · Wᵀ` for `m` rows of `x` (`m × columns`), as `m × rows`, on candle's worker pool.
    pub(crate) fn matmul(&self, x: &[f32], m: usize) -> Vec<f32> {
        let columns = self.blocks * BLOCK;
        debug_assert_eq!(x.len(), m * columns);
        let activations = quantize_q8_1(x);
        // Work items are ranges of weight rows; each writes its own slice of a transposed
        // output (row-major by weight row), so no two items share memory.
        const ROWS_PER_ITEM: usize = 16;
        let mut transposed = vec![0f32; self.rows * m];
        let items: Vec<Mutex<&mut [f32]>> = transposed.chunks_mut(ROWS_PER_ITEM * m).map(Mutex::new).collect();
        let work = |range: std::ops::Range<usize>| {
            for item in range {
                let Ok(mut out) = items[item].lock() else { continue };
                let first = item * ROWS_PER_ITEM;
                let end = (first + ROWS_PER_ITEM).min(self.rows);
                let mut row = first;
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
            }
        };
        if self.rows * self.blocks * m < 4096 {
            work(0..items.len());
        } else {
            candle_core::utils::barrier_pool().execute_chunked(items.len(), work);
        }
        drop(items);
        if m == 1 {
            return transposed;
        }
        let mut out = vec![0f32; m * self.rows];
        for (row, values) in transposed.chunks_exact(m).enumerate() {
            for (r, v) in values.iter().enumerate() {
                out[r * self.rows + row] = *v;
            }
        }
        out
    }

    /// Candle's `vec_dot` for Q4_1: per block `sumi · d_w · d_x + m_w · s_x`, summed in order.
    fn row_dot(&self, row: usize, x: &Q8_1Rows, r: usize) -> f32 {
        let w = row * self.blocks..(row + 1) * self.blocks;
        let a = r * self.blocks..(r + 1) * self.blocks;
        let mut sum = 0f32;
        for ((((q, &wd), &wm), (aq, &ad)), &asum) in self.nibbles[w.clone()]
            .iter()
            .zip(&self.scales[w.clone()])
            .zip(&self.minimums[w])
            .zip(x.quants[a.clone()].iter().zip(&x.scales[a.clone()]))
            .zip(&x.sums[a])
        {
            sum += block_dot(q, aq) as f32 * wd * ad + wm * asum;
        }
        sum
    }
}

impl Q4_1Matrix {
    /// [`Q4_1Matrix::row_dot`] for rows `row..row + 4` at once: four independent float chains
    /// (each in candle's order) that the processor overlaps and the compiler puts in one vector.
    fn four_row_dots(&self, row: usize, x: &Q8_1Rows, r: usize) -> [f32; 4] {
        let blocks = self.blocks;
        let a = r * blocks;
        let mut sums = [0f32; 4];
        for b in 0..blocks {
            let (aq, ad, asum) = (&x.quants[a + b], x.scales[a + b], x.sums[a + b]);
            let mut integer = [0i32; 4];
            for (k, value) in integer.iter_mut().enumerate() {
                *value = block_dot(&self.nibbles[(row + k) * blocks + b], aq);
            }
            for k in 0..4 {
                let w = (row + k) * blocks + b;
                sums[k] += integer[k] as f32 * self.scales[w] * ad + self.minimums[w] * asum;
            }
        }
        sums
    }
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
    fn equals_candles_q4_1_matmul_bit_for_bit() {
        for (rows, columns, m) in [(37, 64, 1), (64, 128, 3), (130, 256, 17), (8, 64, 1), (3, 576, 2)] {
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
