//! The Llama-family decoder over quantized GGUF weights: RMSNorm, RoPE with the file's
//! parameters, grouped-query attention over a truncatable per-layer KV cache, SwiGLU, and a tied
//! or separate output head. Matrix products are candle's quantized matmuls (`QMatMul`, the
//! activations quantized to the weights' dot-product type); everything between them works on
//! plain `f32` rows, so that a decode step is a few dozen kernel calls and no tensor graph.

mod config;
mod kv_cache;

use std::sync::Arc;

use candle_core::quantized::{QMatMul, QTensor};
use candle_core::{Device, Module, Tensor};

pub use config::{Architecture, ModelConfig, RopeConfig};
pub use kv_cache::KvCache;

use crate::error::LmError;
use crate::gguf::{GgufFile, Metadata};

#[derive(Debug)]
struct Layer {
    attn_norm: Vec<f32>,
    wq: QMatMul,
    wk: QMatMul,
    wv: QMatMul,
    /// Qwen2's projection biases.
    bias_q: Option<Vec<f32>>,
    bias_k: Option<Vec<f32>>,
    bias_v: Option<Vec<f32>>,
    /// Qwen3's per-head RMSNorm weights on queries and keys.
    q_norm: Option<Vec<f32>>,
    k_norm: Option<Vec<f32>>,
    wo: QMatMul,
    ffn_norm: Vec<f32>,
    w_gate: QMatMul,
    w_up: QMatMul,
    w_down: QMatMul,
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
    output: QMatMul,
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
            .map_err(|e| LmError::MalformedGguf(format!("tensor `{name}`: {e}")))
    }

    fn matrix(&mut self, name: &str, rows: usize, columns: usize) -> Result<QMatMul, LmError> {
        Ok(QMatMul::from_qtensor(self.tensor(name, &[rows, columns])?)?)
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
        let output = if loader.has("output.weight") {
            loader.matrix("output.weight", vocabulary_size, config.embedding)?
        } else {
            QMatMul::from_arc(embedding.clone())?
        };
        let output_norm = loader.vector("output_norm.weight", config.embedding)?;
        let (d, q, kv, ff, hd) = (config.embedding, config.q_dim(), config.kv_dim(), config.feed_forward, config.head_dim);
        let qwen2 = config.architecture == Architecture::Qwen2;
        let qwen3 = config.architecture == Architecture::Qwen3;
        let mut layers = Vec::with_capacity(config.layers);
        for i in 0..config.layers {
            let name = |part: &str| format!("blk.{i}.{part}");
            let layer = Layer {
                attn_norm: loader.vector(&name("attn_norm.weight"), d)?,
                wq: loader.matrix(&name("attn_q.weight"), q, d)?,
                wk: loader.matrix(&name("attn_k.weight"), kv, d)?,
                wv: loader.matrix(&name("attn_v.weight"), kv, d)?,
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
                w_gate: loader.matrix(&name("ffn_gate.weight"), ff, d)?,
                w_up: loader.matrix(&name("ffn_up.weight"), ff, d)?,
                w_down: loader.matrix(&name("ffn_down.weight"), d, ff)?,
            };
            layers.push(layer);
        }
        Ok(LlamaModel { config, vocabulary_size, embedding, layers, output_norm, output, rope_theta })
    }

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
            let h = Tensor::from_vec(h, (n, d), &Device::Cpu)?;
            let mut q = linear(&layer.wq, &h)?;
            let mut k = linear(&layer.wk, &h)?;
            let mut v = linear(&layer.wv, &h)?;
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
            let o = linear(&layer.wo, &Tensor::from_vec(attended, (n, cfg.q_dim()), &Device::Cpu)?)?;
            add_in_place(&mut x, &o);
            let h = rms_norm_rows(&x, &layer.ffn_norm, d, cfg.rms_eps);
            let h = Tensor::from_vec(h, (n, d), &Device::Cpu)?;
            let mut gate = linear(&layer.w_gate, &h)?;
            let up = linear(&layer.w_up, &h)?;
            for (g, u) in gate.iter_mut().zip(&up) {
                *g = silu(*g) * u;
            }
            let down = linear(&layer.w_down, &Tensor::from_vec(gate, (n, cfg.feed_forward), &Device::Cpu)?)?;
            add_in_place(&mut x, &down);
        }
        cache.set_len(total);
        let last = rms_norm_rows(&x[(n - 1) * d..], &self.output_norm, d, cfg.rms_eps);
        linear(&self.output, &Tensor::from_vec(last, (1, d), &Device::Cpu)?)
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

/// `x · Wᵀ` for the rows of `x`, as a flat row-major vector.
fn linear(w: &QMatMul, x: &Tensor) -> Result<Vec<f32>, LmError> {
    Ok(w.forward(x)?.flatten_all()?.to_vec1::<f32>()?)
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

/// 8 independent accumulators, so that the compiler can vectorise without reassociating.
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let mut ca = a.chunks_exact(8);
    let mut cb = b.chunks_exact(8);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for i in 0..8 {
            acc[i] += x[i] * y[i];
        }
    }
    let mut sum: f32 = acc.iter().sum();
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        sum += x * y;
    }
    sum
}

/// Causal grouped-query attention of `n` new query rows at positions `start..start + n` over the
/// cached keys and values (`positions × kv_dim`), returning `n × q_dim`.
fn attention(cfg: &ModelConfig, q: &[f32], keys: &[f32], values: &[f32], start: usize, n: usize) -> Vec<f32> {
    let (hd, heads, kv_dim, q_dim) = (cfg.head_dim, cfg.heads, cfg.kv_dim(), cfg.q_dim());
    let group = heads / cfg.kv_heads;
    let scale = 1.0 / (hd as f32).sqrt();
    let head_rows = |head: usize| -> Vec<f32> {
        let kv_offset = (head / group) * hd;
        let mut out = vec![0f32; n * hd];
        let mut scores = Vec::with_capacity(start + n);
        for t in 0..n {
            let query = &q[t * q_dim + head * hd..t * q_dim + (head + 1) * hd];
            let visible = start + t + 1;
            scores.clear();
            let mut max = f32::NEG_INFINITY;
            for j in 0..visible {
                let s = dot(query, &keys[j * kv_dim + kv_offset..j * kv_dim + kv_offset + hd]) * scale;
                max = max.max(s);
                scores.push(s);
            }
            let mut total = 0f32;
            for s in scores.iter_mut() {
                *s = (*s - max).exp();
                total += *s;
            }
            let row = &mut out[t * hd..(t + 1) * hd];
            for (j, &p) in scores.iter().enumerate() {
                let value = &values[j * kv_dim + kv_offset..j * kv_dim + kv_offset + hd];
                for (o, v) in row.iter_mut().zip(value) {
                    *o += p * v;
                }
            }
            let inv = 1.0 / total;
            row.iter_mut().for_each(|o| *o *= inv);
        }
        out
    };
    let per_head: Vec<Vec<f32>> = if n * (start + n) * heads >= 16_384 {
        // Prefill: heads in parallel on candle's worker pool (the one its matmuls use).
        let slots: Vec<std::sync::OnceLock<Vec<f32>>> = (0..heads).map(|_| std::sync::OnceLock::new()).collect();
        candle_core::utils::barrier_pool().execute_chunked(heads, |range| {
            for head in range {
                let _ = slots[head].set(head_rows(head));
            }
        });
        slots.into_iter().map(|slot| slot.into_inner().unwrap_or_default()).collect()
    } else {
        (0..heads).map(head_rows).collect()
    };
    let mut out = vec![0f32; n * q_dim];
    for (head, rows) in per_head.iter().enumerate() {
        for t in 0..n {
            out[t * q_dim + head * hd..t * q_dim + (head + 1) * hd].copy_from_slice(&rows[t * hd..(t + 1) * hd]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_a_plain_sum() {
        let a: Vec<f32> = (0..19).map(|i| i as f32 * 0.5).collect();
        let b: Vec<f32> = (0..19).map(|i| 1.0 - i as f32 * 0.25).collect();
        let plain: f32 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((dot(&a, &b) - plain).abs() < 1e-4);
    }

    #[test]
    fn rms_norm_gives_unit_root_mean_square() {
        let x = [3.0f32, 4.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let out = rms_norm_rows(&x, &[1.0; 4], 4, 0.0);
        assert!((out[0] - 1.2).abs() < 1e-6 && (out[1] - 1.6).abs() < 1e-6);
        assert!(out[4..].iter().all(|v| (v - 1.0).abs() < 1e-6));
    }
}
