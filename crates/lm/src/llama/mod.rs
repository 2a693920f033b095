//! The Llama-family decoder over quantized GGUF weights: RMSNorm, RoPE with the file's
//! parameters, grouped-query attention over a truncatable per-layer KV cache, SwiGLU, and a tied
//! or separate output head. Matrix products are candle's quantized matmuls (`QMatMul`, the
//! activations quantized to the weights' dot-product type); norms, RoPE and SwiGLU work on plain
//! `f32` rows; attention is written by hand over the cache in place (see `attention` for why).

mod config;
mod kv_cache;
mod pool;
mod q4_1;

use std::sync::Arc;

use candle_core::quantized::GgmlDType;
use candle_core::quantized::{QMatMul, QStorage, QTensor};
use candle_core::{Device, Module, Tensor};

pub use config::{Architecture, ModelConfig, RopeConfig};
pub use kv_cache::KvCache;
use q4_1::Q4_1Matrix;

use crate::error::LmError;
use crate::gguf::{GgufFile, Metadata};

/// A weight matrix: Q4_1 through this crate's vectorised kernel (bitwise equal to candle's
/// scalar one), every other type through candle's `QMatMul`.
#[derive(Debug)]
enum Weight {
    Candle(QMatMul),
    Q4_1(Q4_1Matrix),
}

impl Weight {
    fn new(matrix: QTensor) -> Result<Self, LmError> {
        if matrix.dtype() == GgmlDType::Q4_1
            && let [rows, columns] = *matrix.shape().dims()
            && let Some(q4_1) = Q4_1Matrix::from_ggml(&matrix.data()?, rows, columns)
        {
            return Ok(Weight::Q4_1(q4_1));
        }
        Ok(Weight::Candle(QMatMul::from_qtensor(matrix)?))
    }

    fn from_shared(matrix: Arc<QTensor>) -> Result<Self, LmError> {
        if matrix.dtype() == GgmlDType::Q4_1 {
            return Self::new(QTensor::new(QStorage::from_data(matrix.data()?, &Device::Cpu, matrix.dtype())?, matrix.shape().clone())?);
        }
        Ok(Weight::Candle(QMatMul::from_arc(matrix)?))
    }

    /// `x · Wᵀ` for the `n` rows of `x`, row-major.
    fn forward(&self, x: &[f32], n: usize) -> Result<Vec<f32>, LmError> {
        match self {
            Weight::Q4_1(matrix) => Ok(matrix.matmul(x, n)),
            Weight::Candle(matrix) => {
                let x = Tensor::from_slice(x, (n, x.len() / n), &Device::Cpu)?;
                Ok(matrix.forward(&x)?.flatten_all()?.to_vec1::<f32>()?)
            }
        }
    }
}

/// Projections of the same input, as few matmuls as possible: matrices of one quantization type
/// are stacked row-wise at load time (Q, K, V; gate, up), which saves a quantization of the
/// input and a pass through the worker pool per stacked matrix. Each output element is the same
/// dot product as without stacking, so results are bitwise unchanged.
#[derive(Debug)]
struct Projections {
    /// Each matmul and the widths of the outputs it produces, in order.
    groups: Vec<(Weight, Vec<usize>)>,
}

impl Projections {
    fn new(matrices: Vec<QTensor>) -> Result<Self, LmError> {
        let mut groups: Vec<(Vec<QTensor>, Vec<usize>)> = Vec::new();
        for matrix in matrices {
            let rows = matrix.shape().dims()[0];
            // F32/F16 matrices are dequantized by QMatMul anyway: keep them apart.
            let stackable = !matches!(matrix.dtype(), GgmlDType::F32 | GgmlDType::F16 | GgmlDType::BF16);
            match groups.last_mut() {
                Some((members, widths)) if stackable && members[0].dtype() == matrix.dtype() => {
                    members.push(matrix);
                    widths.push(rows);
                }
                _ => groups.push((vec![matrix], vec![rows])),
            }
        }
        let groups = groups
            .into_iter()
            .map(|(members, widths)| {
                let matrix = if members.len() == 1 { members.into_iter().next().expect("one member") } else { stack_rows(&members)? };
                Ok((Weight::new(matrix)?, widths))
            })
            .collect::<Result<_, LmError>>()?;
        Ok(Projections { groups })
    }

    /// `x · Wᵢᵀ` for each of the `N` matrices, in the order given to `new`, each `n × widthᵢ`.
    fn apply<const N: usize>(&self, x: &[f32], n: usize) -> Result<[Vec<f32>; N], LmError> {
        let mut outputs = Vec::new();
        for (matrix, widths) in &self.groups {
            let y = matrix.forward(x, n)?;
            if widths.len() == 1 {
                outputs.push(y);
                continue;
            }
            let total: usize = widths.iter().sum();
            let mut offset = 0;
            for &width in widths {
                let mut part = Vec::with_capacity(n * width);
                for row in 0..n {
                    part.extend_from_slice(&y[row * total + offset..row * total + offset + width]);
                }
                outputs.push(part);
                offset += width;
            }
        }
        debug_assert_eq!(outputs.len(), N);
        let mut outputs = outputs.into_iter();
        Ok(std::array::from_fn(|_| outputs.next().unwrap_or_default()))
    }
}

/// One quantized matrix whose rows are those of `parts`, in order (rows are whole blocks).
fn stack_rows(parts: &[QTensor]) -> Result<QTensor, LmError> {
    let columns = parts[0].shape().dims()[1];
    let mut bytes = Vec::new();
    let mut rows = 0;
    for part in parts {
        bytes.extend_from_slice(&part.data()?);
        rows += part.shape().dims()[0];
    }
    let storage = QStorage::from_data(std::borrow::Cow::Owned(bytes), &Device::Cpu, parts[0].dtype())?;
    Ok(QTensor::new(storage, (rows, columns))?)
}

#[derive(Debug)]
struct Layer {
    attn_norm: Vec<f32>,
    /// Q, K, V.
    qkv: Projections,
    /// Qwen2's projection biases.
    bias_q: Option<Vec<f32>>,
    bias_k: Option<Vec<f32>>,
    bias_v: Option<Vec<f32>>,
    /// Qwen3's per-head RMSNorm weights on queries and keys.
    q_norm: Option<Vec<f32>>,
    k_norm: Option<Vec<f32>>,
    wo: Weight,
    ffn_norm: Vec<f32>,
    /// Gate, up.
    gate_up: Projections,
    w_down: Weight,
}

/// A loaded model: configuration and weights. It holds no sequence state; a [`KvCache`] does,
/// so one model can serve many caches (one per search tree, say).
#[derive(Debug)]
pub struct LlamaModel {
    config: ModelConfig,
    vocabulary_size: usize,
    embedding: Arc<QTensor>,
    layers: Vec<Layer>,
    output_norm: Vec<f32>,
    output: Weight,
    /// The output head's quantized rows (the embedding when tied), for [`LlamaModel::output_row`].
    output_rows: Arc<QTensor>,
    /// θ_i for i < rope.dimensions / 2 (after `rope_freqs.weight` where the file has it).
    rope_theta: Vec<f32>,
}

struct Loader<'a> {
    file: &'a mut GgufFile,
}

impl Loader<'_> {
    fn has(&self, name: &str) -> bool {
        self.file.content.tensor_infos.contains_key(name)
    }

    fn tensor(&mut self, name: &str, expected: &[usize]) -> Result<QTensor, LmError> {
        let shape =
            Metadata::new(&self.file.content).tensor_shape(name).ok_or_else(|| LmError::MissingTensor { name: name.to_string() })?;
        if shape != expected {
            return Err(LmError::BadTensorShape { name: name.to_string(), expected: expected.to_vec(), found: shape });
        }
        self.file
            .content
            .tensor(&mut self.file.reader, name, &Device::Cpu)
            .map_err(|e| LmError::MalformedGguf(format!("tensor `{name}`: {}", crate::error::candle_message(&e))))
    }

    fn matrix(&mut self, name: &str, rows: usize, columns: usize) -> Result<Weight, LmError> {
        Weight::new(self.tensor(name, &[rows, columns])?)
    }

    fn projections(&mut self, names: &[(String, usize)], columns: usize) -> Result<Projections, LmError> {
        let matrices = names.iter().map(|(name, rows)| self.tensor(name, &[*rows, columns])).collect::<Result<Vec<_>, _>>()?;
        Projections::new(matrices)
    }

    fn vector(&mut self, name: &str, len: usize) -> Result<Vec<f32>, LmError> {
        let tensor = self.tensor(name, &[len])?;
        Ok(tensor.dequantize(&Device::Cpu)?.to_vec1::<f32>()?)
    }

    fn optional_vector(&mut self, name: &str, len: usize) -> Result<Option<Vec<f32>>, LmError> {
        if self.has(name) { self.vector(name, len).map(Some) } else { Ok(None) }
    }
}

impl LlamaModel {
    /// Loads the configuration and every weight of an open GGUF file.
    pub fn load(file: &mut GgufFile) -> Result<Self, LmError> {
        let metadata = Metadata::new(&file.content);
        let config = ModelConfig::from_gguf(&metadata)?;
        let embedding_shape =
            metadata.tensor_shape("token_embd.weight").ok_or_else(|| LmError::MissingTensor { name: "token_embd.weight".into() })?;
        let vocabulary_size = match embedding_shape.as_slice() {
            [rows, columns] if *columns == config.embedding => *rows,
            _ => {
                return Err(LmError::BadTensorShape {
                    name: "token_embd.weight".into(),
                    expected: vec![0, config.embedding],
                    found: embedding_shape,
                });
            }
        };
        let vocab_key = format!("{}.vocab_size", config.architecture.name());
        if metadata.get(&vocab_key).is_some() {
            let n = metadata.dimension(&vocab_key)?;
            if n != vocabulary_size {
                return Err(LmError::BadTensorShape {
                    name: "token_embd.weight".into(),
                    expected: vec![n, config.embedding],
                    found: vec![vocabulary_size, config.embedding],
                });
            }
        }
        let half = config.rope.dimensions / 2;
        let mut rope_theta: Vec<f32> =
            (0..half).map(|i| 1.0 / config.rope.base.powf((2 * i) as f32 / config.rope.dimensions as f32)).collect();
        let mut loader = Loader { file };
        if loader.has("rope_freqs.weight") {
            // Llama 3.1-style long-context scaling: llama.cpp divides each θ_i by this factor.
            let factors = loader.vector("rope_freqs.weight", half)?;
            for (theta, factor) in rope_theta.iter_mut().zip(factors) {
                *theta /= factor;
            }
        }
        let embedding = Arc::new(loader.tensor("token_embd.weight", &[vocabulary_size, config.embedding])?);
        let output_rows = if loader.has("output.weight") {
            Arc::new(loader.tensor("output.weight", &[vocabulary_size, config.embedding])?)
        } else {
            embedding.clone()
        };
        let output = Weight::from_shared(output_rows.clone())?;
        let output_norm = loader.vector("output_norm.weight", config.embedding)?;
        let (d, q, kv, ff, hd) = (config.embedding, config.q_dim(), config.kv_dim(), config.feed_forward, config.head_dim);
        let qwen2 = config.architecture == Architecture::Qwen2;
        let qwen3 = config.architecture == Architecture::Qwen3;
        // Not sized by `block_count` up front: a corrupt count (4e9) would abort the allocation;
        // the first missing `blk.{i}` tensor is the error instead.
        let mut layers = Vec::new();
        for i in 0..config.layers {
            let name = |part: &str| format!("blk.{i}.{part}");
            let layer = Layer {
                attn_norm: loader.vector(&name("attn_norm.weight"), d)?,
                qkv: loader.projections(&[(name("attn_q.weight"), q), (name("attn_k.weight"), kv), (name("attn_v.weight"), kv)], d)?,
                bias_q: if qwen2 {
                    Some(loader.vector(&name("attn_q.bias"), q)?)
                } else {
                    loader.optional_vector(&name("attn_q.bias"), q)?
                },
                bias_k: if qwen2 {
                    Some(loader.vector(&name("attn_k.bias"), kv)?)
                } else {
                    loader.optional_vector(&name("attn_k.bias"), kv)?
                },
                bias_v: if qwen2 {
                    Some(loader.vector(&name("attn_v.bias"), kv)?)
                } else {
                    loader.optional_vector(&name("attn_v.bias"), kv)?
                },
                q_norm: if qwen3 { Some(loader.vector(&name("attn_q_norm.weight"), hd)?) } else { None },
                k_norm: if qwen3 { Some(loader.vector(&name("attn_k_norm.weight"), hd)?) } else { None },
                wo: loader.matrix(&name("attn_output.weight"), d, q)?,
                ffn_norm: loader.vector(&name("ffn_norm.weight"), d)?,
                gate_up: loader.projections(&[(name("ffn_gate.weight"), ff), (name("ffn_up.weight"), ff)], d)?,
                w_down: loader.matrix(&name("ffn_down.weight"), d, ff)?,
            };
            layers.push(layer);
        }
        Ok(LlamaModel { config, vocabulary_size, embedding, layers, output_norm, output, output_rows, rope_theta })
    }

    /// The hyper-parameters read from the GGUF metadata.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// Rows of the embedding and output head.
    pub fn vocabulary_size(&self) -> usize {
        self.vocabulary_size
    }

    /// An empty cache shaped for this model.
    pub fn new_cache(&self) -> KvCache {
        KvCache::new(self.config.layers, self.config.kv_dim())
    }

    /// Runs `tokens` at positions `cache.len()..`, appends their keys and values to `cache`, and
    /// returns the logits of the next token after the last of them.
    pub fn forward(&self, cache: &mut KvCache, tokens: &[u32]) -> Result<Vec<f32>, LmError> {
        let hidden = self.forward_hidden(cache, tokens)?;
        self.output_logits(&hidden)
    }

    /// The output head over a final hidden state: the logits of every row.
    pub fn output_logits(&self, hidden: &[f32]) -> Result<Vec<f32>, LmError> {
        self.output.forward(hidden, 1)
    }

    /// Row `token` of the output head, dequantized to `f32`: its logit is the row's dot product
    /// with the final hidden state. (The full head quantizes the hidden state to 8 bits first, as
    /// llama.cpp and candle do; a row dotted in `f32` differs from it by that rounding.)
    pub fn output_row(&self, token: u32) -> Result<Vec<f32>, LmError> {
        if token as usize >= self.vocabulary_size {
            return Err(LmError::TokenOutOfRange { id: token, size: self.vocabulary_size });
        }
        let dtype = self.output_rows.dtype();
        let columns = self.config.embedding;
        let row_bytes = columns / dtype.block_size() * dtype.type_size();
        let data = self.output_rows.data()?;
        let start = token as usize * row_bytes;
        let bytes = data
            .get(start..start + row_bytes)
            .ok_or_else(|| LmError::MalformedGguf(format!("output head: row {token} past the end of {} bytes", data.len())))?;
        let row = QTensor::new(QStorage::from_data(std::borrow::Cow::Borrowed(bytes), &Device::Cpu, dtype)?, columns)?;
        Ok(row.dequantize(&Device::Cpu)?.to_vec1::<f32>()?)
    }

    /// [`LlamaModel::forward`] up to the final hidden state (after the output norm) of the last
    /// token, without the output head.
    pub fn forward_hidden(&self, cache: &mut KvCache, tokens: &[u32]) -> Result<Vec<f32>, LmError> {
        if tokens.is_empty() {
            return Err(LmError::EmptySequence);
        }
        for &id in tokens {
            if id as usize >= self.vocabulary_size {
                return Err(LmError::TokenOutOfRange { id, size: self.vocabulary_size });
            }
        }
        let start = cache.len();
        let total = start + tokens.len();
        if total > self.config.context_length {
            return Err(LmError::ContextOverflow { len: total, max: self.config.context_length });
        }
        let result = self.forward_positions(cache, tokens, start);
        if result.is_err() {
            cache.rollback(start);
        }
        result
    }

    fn forward_positions(&self, cache: &mut KvCache, tokens: &[u32], start: usize) -> Result<Vec<f32>, LmError> {
        let total = start + tokens.len();
        let n = tokens.len();
        let cfg = &self.config;
        let d = cfg.embedding;
        let ids = Tensor::from_slice(tokens, n, &Device::Cpu)?;
        let mut x = self.embedding.embedding(&ids)?.flatten_all()?.to_vec1::<f32>()?;
        let (cos, sin) = self.rope_tables(start, n);
        for (layer, layer_cache) in self.layers.iter().zip(cache.layers_mut()) {
            let h = rms_norm_rows(&x, &layer.attn_norm, d, cfg.rms_eps);
            let [mut q, mut k, mut v] = layer.qkv.apply(&h, n)?;
            add_bias_rows(&mut q, layer.bias_q.as_deref());
            add_bias_rows(&mut k, layer.bias_k.as_deref());
            add_bias_rows(&mut v, layer.bias_v.as_deref());
            if let Some(w) = &layer.q_norm {
                rms_norm_in_place(&mut q, w, cfg.head_dim, cfg.rms_eps);
            }
            if let Some(w) = &layer.k_norm {
                rms_norm_in_place(&mut k, w, cfg.head_dim, cfg.rms_eps);
            }
            self.rotate(&mut q, cfg.heads, &cos, &sin);
            self.rotate(&mut k, cfg.kv_heads, &cos, &sin);
            layer_cache.append(&k, &v);
            let attended = attention(cfg, &q, layer_cache.keys(), layer_cache.values(), start, n);
            let o = layer.wo.forward(&attended, n)?;
            add_in_place(&mut x, &o);
            let h = rms_norm_rows(&x, &layer.ffn_norm, d, cfg.rms_eps);
            let [mut gate, up] = layer.gate_up.apply(&h, n)?;
            for (g, u) in gate.iter_mut().zip(&up) {
                *g = silu(*g) * u;
            }
            let down = layer.w_down.forward(&gate, n)?;
            add_in_place(&mut x, &down);
        }
        cache.set_len(total);
        Ok(rms_norm_rows(&x[(n - 1) * d..], &self.output_norm, d, cfg.rms_eps))
    }

    /// cos/sin of position × θ_i for the `n` positions from `start`, row-major by position.
    fn rope_tables(&self, start: usize, n: usize) -> (Vec<f32>, Vec<f32>) {
        let half = self.rope_theta.len();
        let mut cos = Vec::with_capacity(n * half);
        let mut sin = Vec::with_capacity(n * half);
        for p in start..start + n {
            let position = p as f32 / self.config.rope.linear_scale;
            for &theta in &self.rope_theta {
                let angle = position * theta;
                cos.push(angle.cos());
                sin.push(angle.sin());
            }
        }
        (cos, sin)
    }

    /// Rotates the first `rope.dimensions` of each head of each row (`rows × heads × head_dim`).
    fn rotate(&self, x: &mut [f32], heads: usize, cos: &[f32], sin: &[f32]) {
        let hd = self.config.head_dim;
        let half = self.rope_theta.len();
        let neox = self.config.rope.neox;
        for (row, chunk) in x.chunks_exact_mut(heads * hd).enumerate() {
            let (c, s) = (&cos[row * half..(row + 1) * half], &sin[row * half..(row + 1) * half]);
            for head in chunk.chunks_exact_mut(hd) {
                for i in 0..half {
                    let (a, b) = if neox { (i, i + half) } else { (2 * i, 2 * i + 1) };
                    let (x0, x1) = (head[a], head[b]);
                    head[a] = x0 * c[i] - x1 * s[i];
                    head[b] = x0 * s[i] + x1 * c[i];
                }
            }
        }
    }
}

fn silu(x: f32) -> f32 {
    x / (1.0 + (-x).exp())
}

fn add_in_place(x: &mut [f32], y: &[f32]) {
    for (a, b) in x.iter_mut().zip(y) {
        *a += b;
    }
}

fn add_bias_rows(x: &mut [f32], bias: Option<&[f32]>) {
    if let Some(bias) = bias {
        for row in x.chunks_exact_mut(bias.len()) {
            add_in_place(row, bias);
        }
    }
}

/// RMSNorm of each `width`-long row: `x / sqrt(mean(x²) + ε) · w`.
fn rms_norm_rows(x: &[f32], weight: &[f32], width: usize, eps: f32) -> Vec<f32> {
    let mut out = x.to_vec();
    rms_norm_in_place(&mut out, weight, width, eps);
    out
}

fn rms_norm_in_place(x: &mut [f32], weight: &[f32], width: usize, eps: f32) {
    for row in x.chunks_exact_mut(width) {
        let sum: f32 = row.iter().map(|v| v * v).sum();
        let scale = (sum / width as f32 + eps).sqrt();
        for (v, w) in row.iter_mut().zip(weight) {
            *v = *v / scale * w;
        }
    }
}

/// Query rows of one work item of [`attention`].
const QUERY_BLOCK: usize = 16;
/// Keys (and values) read per pass of [`attend_block`]: 64 rows of a 64-wide head are 16 KB,
/// which stay in the L1 cache while every query of the work item reads them.
const KEY_BLOCK: usize = 64;

/// Causal grouped-query attention of `n` new query rows (`n × q_dim`, after RoPE) at positions
/// `start..start + n` over the cached keys and values (`positions × kv_dim`, position-major as
/// the cache holds them), returning `n × q_dim`.
///
/// Written by hand on plain slices: one work item per key-value head and block of
/// [`QUERY_BLOCK`] query rows, which reads that head's rows in place (no gather, no copy of the
/// cache) and serves every query head of the group (see [`attend_block`]). No library does this
/// over our cache layout without copies; candle's tensor ops cost a `(total × head_dim)` gather
/// per key-value head, a dozen allocations per head and a gemm dispatch per product on every
/// decode step, which was half the time of a decode step after 500 tokens (issue 23). The sums
/// run in eight lanes, so results differ from candle-transformers' order by rounding only;
/// `logits_match_candle_transformers_quantized_llama` bounds the difference.
///
/// Until the blocking, each (query row, head) was its own item that read all its keys for
/// itself; now a block of keys is read once for the item's queries (the three query heads of
/// a SmolLM2 group and 16 rows), which made a 1,024-token prefill 15-20% faster (ARCHITECTURE).
/// Every query's floats are computed in the same order as then (one score per key in the same
/// chains, the softmax in key order, the values summed in key order), so the result is the
/// same bit for bit (test `blocked_attention_equals_one_query_at_a_time_bit_for_bit`).
fn attention(cfg: &ModelConfig, q: &[f32], keys: &[f32], values: &[f32], start: usize, n: usize) -> Vec<f32> {
    let (hd, heads, kv_heads) = (cfg.head_dim, cfg.heads, cfg.kv_heads);
    let total = start + n;
    let group = heads / kv_heads;
    let kv_dim = kv_heads * hd;
    let q_dim = heads * hd;
    let scale = 1.0 / (hd as f32).sqrt();
    let blocks = n.div_ceil(QUERY_BLOCK);
    // Item `g * blocks + b` writes the rows of block `b` for the query heads of key-value head
    // `g`, laid out `[row][head in group][dimension]` (a short last block leaves zeros).
    let item_len = QUERY_BLOCK * group * hd;
    let mut grouped = vec![0f32; kv_heads * blocks * item_len];
    // About 4 flops per (query, key, dimension); below ~64k of them the pool's wake-up costs
    // more than it saves.
    let parallel = n * heads * total * hd >= 1 << 16;
    pool::for_each_chunk(
        &mut grouped,
        item_len,
        parallel,
        || (Vec::new(), Vec::new()),
        |(queries, scores): &mut (Vec<Query<'_>>, Vec<f32>), item, slot| {
            let (g, b) = (item / blocks, item % blocks);
            let rows = b * QUERY_BLOCK..((b + 1) * QUERY_BLOCK).min(n);
            let head_keys = KvRows { data: keys, stride: kv_dim, offset: g * hd };
            let head_values = KvRows { data: values, stride: kv_dim, offset: g * hd };
            queries.clear();
            for row in rows {
                for h in 0..group {
                    // Query `row` (position start + row) sees keys 0..=start + row.
                    queries.push(Query { vector: &q[row * q_dim + (g * group + h) * hd..][..hd], seen: start + row + 1 });
                }
            }
            let out = &mut slot[..queries.len() * hd];
            attend_block(queries, head_keys, head_values, scale, scores, out);
        },
    );
    let mut out = vec![0f32; n * q_dim];
    for (item, slot) in grouped.chunks_exact(item_len).enumerate() {
        let (g, b) = (item / blocks, item % blocks);
        for (i, row) in (b * QUERY_BLOCK..((b + 1) * QUERY_BLOCK).min(n)).enumerate() {
            let from = &slot[i * group * hd..][..group * hd];
            out[row * q_dim + g * group * hd..][..group * hd].copy_from_slice(from);
        }
    }
    out
}

/// One query vector of a key-value head and how many keys it sees.
struct Query<'a> {
    vector: &'a [f32],
    seen: usize,
}

/// One key-value head's rows in the position-major cache: row `j` is
/// `data[j * stride + offset..][..head_dim]`.
#[derive(Clone, Copy)]
struct KvRows<'a> {
    data: &'a [f32],
    stride: usize,
    offset: usize,
}

impl<'a> KvRows<'a> {
    fn row(&self, j: usize, head_dim: usize) -> &'a [f32] {
        &self.data[j * self.stride + self.offset..][..head_dim]
    }
}

/// Attention of several queries of one key-value head, into `out` (`queries.len() × head_dim`,
/// zeroed): each query's scaled scores, their softmax, and the weighted sum of the values,
/// which uses the unnormalised weights `exp(s_j - max)` and is scaled by `1 / Σ` once at the
/// end. The keys, then the values, are read [`KEY_BLOCK`] rows at a time, each block by every
/// query before the next, so a block is read from memory once for all of them; each query's
/// scores and sums still run over its keys in order, as if it were alone.
fn attend_block(queries: &[Query<'_>], keys: KvRows<'_>, values: KvRows<'_>, scale: f32, scores: &mut Vec<f32>, out: &mut [f32]) {
    let Some(first) = queries.first() else { return };
    let hd = first.vector.len();
    let longest = queries.iter().map(|query| query.seen).max().unwrap_or(0);
    // Query i's scores are `scores[offsets[i]..offsets[i] + seen]`.
    let mut offsets = Vec::with_capacity(queries.len());
    let mut len = 0;
    for query in queries {
        offsets.push(len);
        len += query.seen;
    }
    scores.clear();
    scores.resize(len, 0.0);
    for from in (0..longest).step_by(KEY_BLOCK) {
        for (query, &offset) in queries.iter().zip(&offsets) {
            let keys_read = from..(from + KEY_BLOCK).min(query.seen);
            if !keys_read.is_empty() {
                let at = offset + keys_read.start..offset + keys_read.end;
                score_keys(query.vector, keys, keys_read, scale, &mut scores[at]);
            }
        }
    }
    let mut sums = Vec::with_capacity(queries.len());
    for (query, &offset) in queries.iter().zip(&offsets) {
        let weights = &mut scores[offset..offset + query.seen];
        let max = weights.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let mut sum = 0.0f32;
        for weight in weights.iter_mut() {
            *weight = (*weight - max).exp();
            sum += *weight;
        }
        sums.push(sum);
    }
    for from in (0..longest).step_by(KEY_BLOCK) {
        for ((query, &offset), slot) in queries.iter().zip(&offsets).zip(out.chunks_exact_mut(hd)) {
            let to = (from + KEY_BLOCK).min(query.seen);
            if from < to {
                add_weighted_values(&scores[offset + from..offset + to], values, from, slot);
            }
        }
    }
    for (slot, sum) in out.chunks_exact_mut(hd).zip(sums) {
        let inverse = 1.0 / sum;
        slot.iter_mut().for_each(|o| *o *= inverse);
    }
}

/// Whether the attention kernels run vectorised for this head size.
fn vectorised(hd: usize) -> bool {
    cfg!(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma")) && hd.is_multiple_of(8)
}

/// `out[i] = (query · key_{keys_read.start + i}) · scale`.
fn score_keys(query: &[f32], keys: KvRows<'_>, keys_read: std::ops::Range<usize>, scale: f32, out: &mut [f32]) {
    let hd = query.len();
    if vectorised(hd) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
        simd::scores(query, keys, keys_read, scale, out);
    } else {
        for (score, j) in out.iter_mut().zip(keys_read) {
            *score = dot(query, keys.row(j, hd)) * scale;
        }
    }
}

/// `out += Σ_i weights[i] · value_{first + i}`, in order of `i`.
fn add_weighted_values(weights: &[f32], values: KvRows<'_>, first: usize, out: &mut [f32]) {
    let hd = out.len();
    if vectorised(hd) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
        simd::weighted_sum(weights, values, first, out);
    } else {
        for (j, &weight) in (first..).zip(weights) {
            for (o, v) in out.iter_mut().zip(values.row(j, hd)) {
                *o += weight * v;
            }
        }
    }
}

/// The attention kernels with AVX2 and fused multiply-adds, for head sizes that are a multiple
/// of eight.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
#[allow(unsafe_code)]
mod simd {
    use std::arch::x86_64::*;

    use super::KvRows;

    /// Eight floats.
    ///
    /// SAFETY (of the calls below): this module is compiled only when the whole build enables
    /// AVX2 and FMA, so the CPU running it has them; every load and store goes through a
    /// reference to exactly eight floats.
    #[inline(always)]
    fn load(x: &[f32; 8]) -> __m256 {
        unsafe { _mm256_loadu_ps(x.as_ptr()) }
    }

    #[inline(always)]
    fn horizontal_sum(v: __m256) -> f32 {
        unsafe {
            let pair = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
            let pair = _mm_add_ps(pair, _mm_movehl_ps(pair, pair));
            _mm_cvtss_f32(_mm_add_ss(pair, _mm_movehdup_ps(pair)))
        }
    }

    /// `out[i] = (query · key_{keys_read.start + i}) · scale`, in four chains per key: chunk
    /// `c` of eight dimensions goes to chain `c % 4`, in order, and the chains are summed as
    /// `(0 + 1) + (2 + 3)`. The chains are named variables, not an array indexed by `c % 4`:
    /// indexed, the compiler kept them on the stack, and every multiply-add waited on a store
    /// and a load (about 125 cycles a key on a 1,300-token prefill, 42% of its time).
    pub(super) fn scores(query: &[f32], keys: KvRows<'_>, keys_read: std::ops::Range<usize>, scale: f32, out: &mut [f32]) {
        let hd = query.len();
        let (query, _) = query.as_chunks::<8>();
        for (score, j) in out.iter_mut().zip(keys_read) {
            let (key, _) = keys.row(j, hd).as_chunks::<8>();
            let zero = unsafe { _mm256_setzero_ps() };
            let (mut a0, mut a1, mut a2, mut a3) = (zero, zero, zero, zero);
            let mut qs = query.chunks_exact(4);
            let mut ks = key.chunks_exact(4);
            for (q, k) in (&mut qs).zip(&mut ks) {
                unsafe {
                    a0 = _mm256_fmadd_ps(load(&q[0]), load(&k[0]), a0);
                    a1 = _mm256_fmadd_ps(load(&q[1]), load(&k[1]), a1);
                    a2 = _mm256_fmadd_ps(load(&q[2]), load(&k[2]), a2);
                    a3 = _mm256_fmadd_ps(load(&q[3]), load(&k[3]), a3);
                }
            }
            for (c, (q, k)) in qs.remainder().iter().zip(ks.remainder()).enumerate() {
                let chain = match c {
                    0 => &mut a0,
                    1 => &mut a1,
                    _ => &mut a2,
                };
                *chain = unsafe { _mm256_fmadd_ps(load(q), load(k), *chain) };
            }
            let total = unsafe { _mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3)) };
            *score = horizontal_sum(total) * scale;
        }
    }

    /// `out += Σ_i weights[i] · value_{first + i}`: each dimension's sum runs over `i` in
    /// order, from the value in `out` (so a sum split over calls is the sum of one call, and
    /// how dimensions are grouped changes no float). 64 dimensions at a time in eight
    /// registers, then eight at a time.
    pub(super) fn weighted_sum(weights: &[f32], values: KvRows<'_>, first: usize, out: &mut [f32]) {
        let hd = out.len();
        let mut from = 0;
        while from + 64 <= hd {
            accumulate::<8>(weights, values, first, from, hd, out);
            from += 64;
        }
        while from + 8 <= hd {
            accumulate::<1>(weights, values, first, from, hd, out);
            from += 8;
        }
    }

    /// [`weighted_sum`] over dimensions `from..from + 8 * N`, with `N` accumulators that the
    /// compiler keeps in registers (a constant count: a count known only at run time kept
    /// them on the stack).
    #[inline(always)]
    fn accumulate<const N: usize>(weights: &[f32], values: KvRows<'_>, first: usize, from: usize, hd: usize, out: &mut [f32]) {
        let (out, _) = out[from..from + 8 * N].as_chunks_mut::<8>();
        let mut acc = [unsafe { _mm256_setzero_ps() }; N];
        for l in 0..N {
            acc[l] = load(&out[l]);
        }
        for (j, &weight) in (first..).zip(weights) {
            let w = unsafe { _mm256_set1_ps(weight) };
            let (row, _) = values.row(j, hd)[from..from + 8 * N].as_chunks::<8>();
            for l in 0..N {
                acc[l] = unsafe { _mm256_fmadd_ps(w, load(&row[l]), acc[l]) };
            }
        }
        for l in 0..N {
            unsafe { _mm256_storeu_ps(out[l].as_mut_ptr(), acc[l]) };
        }
    }
}

fn sum8(lanes: &[f32; 8]) -> f32 {
    ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) + ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]))
}

/// `a · b` in eight independent lanes (which the compiler keeps in one vector register).
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [0f32; 8];
    let (a8, a_rest) = a.as_chunks::<8>();
    let (b8, b_rest) = b.as_chunks::<8>();
    for (x, y) in a8.iter().zip(b8) {
        for k in 0..8 {
            lanes[k] += x[k] * y[k];
        }
    }
    let mut sum = sum8(&lanes);
    for (x, y) in a_rest.iter().zip(b_rest) {
        sum += x * y;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-layer configuration for the attention tests.
    fn attention_config(hd: usize, heads: usize, kv_heads: usize) -> ModelConfig {
        ModelConfig {
            architecture: Architecture::Llama,
            layers: 1,
            embedding: heads * hd,
            heads,
            kv_heads,
            head_dim: hd,
            feed_forward: 1,
            context_length: 1000,
            rms_eps: 1e-5,
            rope: RopeConfig { base: 10000.0, dimensions: hd, linear_scale: 1.0, neox: false },
        }
    }

    /// Deterministic pseudo-random queries, keys and values for `n` new rows after `start`
    /// cached ones: queries and keys in [-2, 2), values in [-0.5, 0.5).
    fn attention_inputs(cfg: &ModelConfig, start: usize, n: usize, state: &mut u64) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let mut random = || {
            *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (*state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let (q_dim, kv_dim, total) = (cfg.heads * cfg.head_dim, cfg.kv_heads * cfg.head_dim, start + n);
        let q = (0..n * q_dim).map(|_| random() * 4.0).collect();
        let k = (0..total * kv_dim).map(|_| random() * 4.0).collect();
        let v = (0..total * kv_dim).map(|_| random()).collect();
        (q, k, v)
    }

    /// The attention kernel against the definition computed in f64, on random inputs: a
    /// prefill from position 0, one decode step and a three-token step over a cache; head sizes
    /// of 64 and 128 (the vectorised kernel) and 40 and 20 (not a multiple of 64, or of 8).
    #[test]
    fn attention_is_causal_softmax_attention() {
        for hd in [64, 128, 40, 20] {
            attention_is_causal_softmax_attention_with(hd);
        }
    }

    fn attention_is_causal_softmax_attention_with(hd: usize) {
        let cfg = attention_config(hd, 9, 3);
        let mut state = 1u64;
        let (heads, kv_dim) = (9, 3 * hd);
        for (start, n) in [(0usize, 5usize), (30, 1), (30, 3), (600, 1)] {
            let (q, k, v) = attention_inputs(&cfg, start, n, &mut state);
            let ours = attention(&cfg, &q, &k, &v, start, n);
            for row in 0..n {
                for head in 0..heads {
                    let query = &q[(row * heads + head) * hd..][..hd];
                    let kv = (head / 3) * hd;
                    let seen = start + row + 1;
                    let scores: Vec<f64> = (0..seen)
                        .map(|j| (0..hd).map(|i| query[i] as f64 * k[j * kv_dim + kv + i] as f64).sum::<f64>() / (hd as f64).sqrt())
                        .collect();
                    let max = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    let weights: Vec<f64> = scores.iter().map(|s| (s - max).exp()).collect();
                    let sum: f64 = weights.iter().sum();
                    for i in 0..hd {
                        let expected: f64 = (0..seen).map(|j| weights[j] / sum * v[j * kv_dim + kv + i] as f64).sum();
                        let got = ours[(row * heads + head) * hd + i] as f64;
                        assert!(
                            (got - expected).abs() < 1e-5,
                            "head size {hd}, start {start}, row {row}, head {head}, dim {i}: {got} vs {expected}"
                        );
                    }
                }
            }
        }
    }

    /// One query's attention as it was computed before the blocking: all its keys scored in
    /// one pass, the softmax, then all its values summed in one pass.
    fn attend_one(query: &[f32], keys: KvRows<'_>, values: KvRows<'_>, seen: usize, scale: f32) -> Vec<f32> {
        let mut scores = vec![0f32; seen];
        score_keys(query, keys, 0..seen, scale, &mut scores);
        let max = scores.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let mut sum = 0.0f32;
        for score in scores.iter_mut() {
            *score = (*score - max).exp();
            sum += *score;
        }
        let mut out = vec![0f32; query.len()];
        add_weighted_values(&scores, values, 0, &mut out);
        let inverse = 1.0 / sum;
        out.iter_mut().for_each(|o| *o *= inverse);
        out
    }

    /// The blocked kernel (queries grouped by key-value head and row block, keys and values
    /// read a block at a time) gives every query exactly the floats it got alone: prefills
    /// shorter and longer than a query block and a key block, decode steps over long caches,
    /// head sizes of the vectorised (64, 128) and portable (40, 20) kernels, and a group of one.
    #[test]
    fn blocked_attention_equals_one_query_at_a_time_bit_for_bit() {
        let mut state = 7u64;
        for (hd, heads, kv_heads) in [(64, 9, 3), (128, 4, 2), (40, 9, 3), (20, 2, 2)] {
            let cfg = attention_config(hd, heads, kv_heads);
            let (group, kv_dim, scale) = (heads / kv_heads, kv_heads * hd, 1.0 / (hd as f32).sqrt());
            for (start, n) in [(0usize, 1usize), (0, 37), (0, 150), (100, 1), (130, 20), (200, 65)] {
                let (q, k, v) = attention_inputs(&cfg, start, n, &mut state);
                let blocked = attention(&cfg, &q, &k, &v, start, n);
                for row in 0..n {
                    for head in 0..heads {
                        let offset = (head / group) * hd;
                        let alone = attend_one(
                            &q[(row * heads + head) * hd..][..hd],
                            KvRows { data: &k, stride: kv_dim, offset },
                            KvRows { data: &v, stride: kv_dim, offset },
                            start + row + 1,
                            scale,
                        );
                        let got = &blocked[(row * heads + head) * hd..][..hd];
                        let same = got.iter().zip(&alone).all(|(a, b)| a.to_bits() == b.to_bits());
                        assert!(same, "head size {hd}, start {start}, n {n}, row {row}, head {head}: {got:?} vs {alone:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn rms_norm_gives_unit_root_mean_square() {
        let x = [3.0f32, 4.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let out = rms_norm_rows(&x, &[1.0; 4], 4, 0.0);
        assert!((out[0] - 1.2).abs() < 1e-6 && (out[1] - 1.6).abs() < 1e-6);
        assert!(out[4..].iter().all(|v| (v - 1.0).abs() < 1e-6));
    }
}
