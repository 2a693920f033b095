//! A tiny random-weight GGUF model, written on demand: the default tests, the benches and the
//! OpenAI-compatible test server run the full loading, tokenizer and forward path on it
//! without the 98 MB model file.
//!
//! The vocabulary, drawn here so that tests can check encodings by hand:
//!
//! ```text
//! 0 <|endoftext|>   1 <|im_start|>   2 <|im_end|>          (control tokens; eos = 2)
//! 3 ..= 258         the 256 byte-level characters, byte b at id 3 + b
//! 259 ..            one token per merge below, in order:
//!                   Ġ t → Ġt, h e → he, Ġt he → Ġthe, Ġ o → Ġo, p e → pe, Ġo pe → Ġope,
//!                   Ġope n → Ġopen, Ġ f → Ġf, r i → ri, Ġf ri → Ġfri, d g → dg, Ġfri dg → Ġfridg,
//!                   Ġfridg e → Ġfridge, Ġ 1 → Ġ1, 1 2 → 12
//! ```

use std::io::Cursor;
use std::path::Path;

use candle_core::quantized::gguf_file::{self, Value};
use candle_core::quantized::{GgmlDType, QTensor};
use candle_core::{Device, Tensor};

use crate::error::LmError;
use crate::llama::Architecture;
use crate::vocabulary::byte_level_encode;

/// The merges of the tiny vocabulary, in priority order.
pub const TINY_MERGES: [&str; 15] =
    ["Ġ t", "h e", "Ġt he", "Ġ o", "p e", "Ġo pe", "Ġope n", "Ġ f", "r i", "Ġf ri", "d g", "Ġfri dg", "Ġfridg e", "Ġ 1", "1 2"];

/// The ChatML template the tiny model carries (SmolLM2's, without its default system line).
pub const TINY_CHAT_TEMPLATE: &str = "{% for message in messages %}{{'<|im_start|>' + message['role'] + '\n' + message['content'] + '<|im_end|>' + '\n'}}{% endfor %}{% if add_generation_prompt %}{{ '<|im_start|>assistant\n' }}{% endif %}";

/// What to write.
#[derive(Debug, Clone)]
pub struct TinySpec {
    /// The family written: Qwen2 adds Q, K and V biases, Qwen3 per-head Q and K norms and an
    /// explicit head size.
    pub architecture: Architecture,
    /// No `output.weight`: the output head is the embedding.
    pub tied_output: bool,
    /// Type of the projection matrices (`Q4_1` as in SmolLM2, `Q8_0`, `F32`, ...).
    pub weight_type: GgmlDType,
    /// Seed of the weights' generator: the same spec writes the same bytes on every machine.
    pub seed: u64,
    /// Transformer blocks (`{arch}.block_count`).
    pub layers: usize,
    /// `{arch}.context_length`, in tokens.
    pub context_length: usize,
}

impl Default for TinySpec {
    fn default() -> Self {
        TinySpec {
            architecture: Architecture::Llama,
            tied_output: true,
            weight_type: GgmlDType::Q4_1,
            seed: 7,
            layers: 2,
            context_length: 256,
        }
    }
}

/// Embedding width of the tiny model.
pub const TINY_EMBEDDING: usize = 64;
/// Attention heads of the tiny model (head size `TINY_EMBEDDING / TINY_HEADS` = 16).
pub const TINY_HEADS: usize = 4;
/// Key/value heads of the tiny model: two query heads share each.
pub const TINY_KV_HEADS: usize = 2;
/// Feed-forward width of the tiny model.
pub const TINY_FEED_FORWARD: usize = 128;

/// The tiny vocabulary's tokens (byte-level spellings) and kinds (GGUF codes).
pub fn tiny_tokens() -> (Vec<String>, Vec<i32>) {
    let mut tokens: Vec<String> = ["<|endoftext|>", "<|im_start|>", "<|im_end|>"].iter().map(|s| s.to_string()).collect();
    let mut kinds = vec![3; 3];
    for b in 0..=255u8 {
        tokens.push(byte_level_encode(&[b]));
        kinds.push(1);
    }
    for merge in TINY_MERGES {
        tokens.push(merge.replace(' ', ""));
        kinds.push(1);
    }
    (tokens, kinds)
}

/// SplitMix64: a small deterministic generator, so that the file is the same on every machine.
struct Rng(u64);

impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[-scale, scale]`.
    fn symmetric(&mut self, n: usize, scale: f32) -> Vec<f32> {
        (0..n).map(|_| (self.next_f32() * 2.0 - 1.0) * scale).collect()
    }
}

fn quantized(data: Vec<f32>, shape: &[usize], dtype: GgmlDType) -> Result<QTensor, LmError> {
    let tensor = Tensor::from_vec(data, shape, &Device::Cpu)?;
    Ok(QTensor::quantize(&tensor, dtype)?)
}

/// The bytes of a tiny model file.
pub fn tiny_gguf_bytes(spec: &TinySpec) -> Result<Vec<u8>, LmError> {
    let arch = spec.architecture.name();
    let (d, heads, kv_heads, ff) = (TINY_EMBEDDING, TINY_HEADS, TINY_KV_HEADS, TINY_FEED_FORWARD);
    let head_dim = d / heads;
    let (tokens, kinds) = tiny_tokens();
    let vocab = tokens.len();
    let mut rng = Rng(spec.seed);

    let string = |s: &str| Value::String(s.to_string());
    let mut metadata: Vec<(String, Value)> = vec![
        ("general.architecture".into(), string(arch)),
        ("general.name".into(), string("tiny random test model")),
        (format!("{arch}.block_count"), Value::U32(spec.layers as u32)),
        (format!("{arch}.context_length"), Value::U32(spec.context_length as u32)),
        (format!("{arch}.embedding_length"), Value::U32(d as u32)),
        (format!("{arch}.feed_forward_length"), Value::U32(ff as u32)),
        (format!("{arch}.attention.head_count"), Value::U32(heads as u32)),
        (format!("{arch}.attention.head_count_kv"), Value::U32(kv_heads as u32)),
        (format!("{arch}.attention.layer_norm_rms_epsilon"), Value::F32(1e-5)),
        (format!("{arch}.rope.freq_base"), Value::F32(10_000.0)),
        (format!("{arch}.rope.dimension_count"), Value::U32(head_dim as u32)),
        ("tokenizer.ggml.model".into(), string("gpt2")),
        ("tokenizer.ggml.pre".into(), string("smollm")),
        ("tokenizer.ggml.tokens".into(), Value::Array(tokens.iter().map(|t| string(t)).collect())),
        ("tokenizer.ggml.token_type".into(), Value::Array(kinds.iter().map(|&k| Value::I32(k)).collect())),
        ("tokenizer.ggml.merges".into(), Value::Array(TINY_MERGES.iter().map(|m| string(m)).collect())),
        ("tokenizer.ggml.bos_token_id".into(), Value::U32(1)),
        ("tokenizer.ggml.eos_token_id".into(), Value::U32(2)),
        ("tokenizer.ggml.add_bos_token".into(), Value::Bool(false)),
        ("tokenizer.chat_template".into(), string(TINY_CHAT_TEMPLATE)),
    ];
    if spec.architecture == Architecture::Qwen3 {
        metadata.push((format!("{arch}.attention.key_length"), Value::U32(head_dim as u32)));
        metadata.push((format!("{arch}.attention.value_length"), Value::U32(head_dim as u32)));
    }

    let matrix_scale = |columns: usize| 1.5 / (columns as f32).sqrt();
    let mut tensors: Vec<(String, QTensor)> = Vec::new();
    tensors.push(("token_embd.weight".into(), quantized(rng.symmetric(vocab * d, 1.0), &[vocab, d], GgmlDType::Q8_0)?));
    let norm = |rng: &mut Rng, n: usize| -> Result<QTensor, LmError> {
        let data: Vec<f32> = rng.symmetric(n, 0.2).into_iter().map(|x| 1.0 + x).collect();
        quantized(data, &[n], GgmlDType::F32)
    };
    tensors.push(("output_norm.weight".into(), norm(&mut rng, d)?));
    if !spec.tied_output {
        tensors.push(("output.weight".into(), quantized(rng.symmetric(vocab * d, matrix_scale(d)), &[vocab, d], spec.weight_type)?));
    }
    let (q_dim, kv_dim) = (heads * head_dim, kv_heads * head_dim);
    for i in 0..spec.layers {
        let mut matrix = |name: &str, rows: usize, columns: usize| -> Result<(), LmError> {
            let data = rng.symmetric(rows * columns, matrix_scale(columns));
            tensors.push((format!("blk.{i}.{name}"), quantized(data, &[rows, columns], spec.weight_type)?));
            Ok(())
        };
        matrix("attn_q.weight", q_dim, d)?;
        matrix("attn_k.weight", kv_dim, d)?;
        matrix("attn_v.weight", kv_dim, d)?;
        matrix("attn_output.weight", d, q_dim)?;
        matrix("ffn_gate.weight", ff, d)?;
        matrix("ffn_up.weight", ff, d)?;
        matrix("ffn_down.weight", d, ff)?;
        tensors.push((format!("blk.{i}.attn_norm.weight"), norm(&mut rng, d)?));
        tensors.push((format!("blk.{i}.ffn_norm.weight"), norm(&mut rng, d)?));
        if spec.architecture == Architecture::Qwen2 {
            for (name, n) in [("attn_q.bias", q_dim), ("attn_k.bias", kv_dim), ("attn_v.bias", kv_dim)] {
                tensors.push((format!("blk.{i}.{name}"), quantized(rng.symmetric(n, 0.3), &[n], GgmlDType::F32)?));
            }
        }
        if spec.architecture == Architecture::Qwen3 {
            tensors.push((format!("blk.{i}.attn_q_norm.weight"), norm(&mut rng, head_dim)?));
            tensors.push((format!("blk.{i}.attn_k_norm.weight"), norm(&mut rng, head_dim)?));
        }
    }

    let metadata_refs: Vec<(&str, &Value)> = metadata.iter().map(|(k, v)| (k.as_str(), v)).collect();
    let tensor_refs: Vec<(&str, &QTensor)> = tensors.iter().map(|(k, t)| (k.as_str(), t)).collect();
    let mut out = Cursor::new(Vec::new());
    gguf_file::write(&mut out, &metadata_refs, &tensor_refs)?;
    Ok(out.into_inner())
}

/// Writes a tiny model file to `path`.
pub fn write_tiny_gguf(path: &Path, spec: &TinySpec) -> Result<(), LmError> {
    let bytes = tiny_gguf_bytes(spec)?;
    std::fs::write(path, bytes).map_err(|source| LmError::Io { path: path.to_path_buf(), source })
}
