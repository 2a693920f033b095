//! The hyper-parameters of a Llama-family decoder, read from GGUF metadata under the
//! architecture's own prefix (`llama.block_count`, `qwen2.rope.freq_base`, ...).

use crate::error::LmError;
use crate::gguf::Metadata;

/// The model families this crate runs (`general.architecture`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Architecture {
    /// Llama, SmolLM, Mistral-style: interleaved RoPE pairs (llama.cpp's "normal" mode).
    Llama,
    /// Qwen2 / Qwen2.5: biases on the Q, K and V projections, NeoX RoPE (halves).
    Qwen2,
    /// Qwen3: per-head RMSNorm on queries and keys before RoPE, NeoX RoPE, explicit head size.
    Qwen3,
}

impl Architecture {
    /// The family a `general.architecture` value names (`llama`, `qwen2`, `qwen3`); any other
    /// is [`LmError::UnsupportedArchitecture`].
    pub fn from_name(name: &str) -> Result<Self, LmError> {
        match name {
            "llama" => Ok(Architecture::Llama),
            "qwen2" => Ok(Architecture::Qwen2),
            "qwen3" => Ok(Architecture::Qwen3),
            other => Err(LmError::UnsupportedArchitecture(other.to_string())),
        }
    }

    /// The `general.architecture` value, which also prefixes the family's metadata keys.
    pub fn name(self) -> &'static str {
        match self {
            Architecture::Llama => "llama",
            Architecture::Qwen2 => "qwen2",
            Architecture::Qwen3 => "qwen3",
        }
    }

    /// NeoX RoPE rotates pairs `(i, i + d/2)`; the other mode rotates `(2i, 2i + 1)`. The GGUF
    /// converter permutes Llama's Q/K rows for the second (llama.cpp `llama_model_rope_type`).
    pub fn rope_is_neox(self) -> bool {
        matches!(self, Architecture::Qwen2 | Architecture::Qwen3)
    }
}

/// Rotary position embedding parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RopeConfig {
    /// `{arch}.rope.freq_base` (θ, default 10000).
    pub base: f32,
    /// `{arch}.rope.dimension_count`: how many leading dimensions of each head rotate.
    pub dimensions: usize,
    /// NeoX pairing, `(i, i + d/2)`, rather than `(2i, 2i + 1)` ([`Architecture::rope_is_neox`]).
    pub neox: bool,
    /// `{arch}.rope.scaling.factor` with `rope.scaling.type = linear`: positions are divided by it.
    pub linear_scale: f32,
}

/// Everything the forward pass needs to know about the model's shape.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelConfig {
    /// The family, from `general.architecture`.
    pub architecture: Architecture,
    /// `{arch}.block_count`.
    pub layers: usize,
    /// `{arch}.embedding_length`.
    pub embedding: usize,
    /// `{arch}.attention.head_count`.
    pub heads: usize,
    /// `{arch}.attention.head_count_kv` (grouped-query attention; default `heads`).
    pub kv_heads: usize,
    /// `{arch}.attention.key_length` (default `embedding / heads`).
    pub head_dim: usize,
    /// `{arch}.feed_forward_length`.
    pub feed_forward: usize,
    /// `{arch}.context_length`.
    pub context_length: usize,
    /// `{arch}.attention.layer_norm_rms_epsilon`.
    pub rms_eps: f32,
    /// Rotary position embedding parameters.
    pub rope: RopeConfig,
}

impl ModelConfig {
    /// Reads the configuration; every missing or ill-typed key is named in the error.
    pub fn from_gguf(metadata: &Metadata<'_>) -> Result<Self, LmError> {
        let architecture = Architecture::from_name(metadata.string("general.architecture")?)?;
        let arch = architecture.name();
        let key = |suffix: &str| format!("{arch}.{suffix}");
        let layers = metadata.dimension(&key("block_count"))?;
        let embedding = metadata.dimension(&key("embedding_length"))?;
        let heads = metadata.dimension(&key("attention.head_count"))?;
        let kv_heads = metadata.dimension_or(&key("attention.head_count_kv"), heads)?;
        if !heads.is_multiple_of(kv_heads) {
            return Err(LmError::BadMetadata {
                key: key("attention.head_count_kv"),
                expected: "a divisor of attention.head_count",
                found: format!("{kv_heads} (head_count {heads})"),
            });
        }
        let default_head_dim = embedding / heads;
        let head_dim = metadata.dimension_or(&key("attention.key_length"), default_head_dim)?;
        let value_length = metadata.dimension_or(&key("attention.value_length"), head_dim)?;
        if value_length != head_dim {
            return Err(LmError::BadMetadata {
                key: key("attention.value_length"),
                expected: "the same as attention.key_length",
                found: value_length.to_string(),
            });
        }
        if architecture != Architecture::Qwen3 && head_dim * heads != embedding {
            return Err(LmError::BadMetadata {
                key: key("attention.key_length"),
                expected: "embedding_length / head_count",
                found: head_dim.to_string(),
            });
        }
        let feed_forward = metadata.dimension(&key("feed_forward_length"))?;
        let context_length = metadata.dimension_or(&key("context_length"), 4096)?;
        let rms_eps = metadata.float(&key("attention.layer_norm_rms_epsilon"))? as f32;
        if rms_eps <= 0.0 {
            return Err(LmError::BadMetadata {
                key: key("attention.layer_norm_rms_epsilon"),
                expected: "a positive number",
                found: rms_eps.to_string(),
            });
        }
        let dimensions = metadata.dimension_or(&key("rope.dimension_count"), head_dim)?;
        if dimensions > head_dim || !dimensions.is_multiple_of(2) {
            return Err(LmError::BadMetadata {
                key: key("rope.dimension_count"),
                expected: "an even number no larger than the head size",
                found: dimensions.to_string(),
            });
        }
        let base = metadata.float_or(&key("rope.freq_base"), 10_000.0)? as f32;
        // θ ≤ 1 turns the rotary frequencies into noise (every model uses thousands and more);
        // a double too large for f32 is infinite here.
        if !(base > 1.0 && base.is_finite()) {
            return Err(LmError::BadMetadata { key: key("rope.freq_base"), expected: "a number above 1", found: base.to_string() });
        }
        let linear_scale = match metadata.optional_string(&key("rope.scaling.type"))? {
            None | Some("none") => 1.0,
            Some("linear") => {
                let factor = metadata.float_or(&key("rope.scaling.factor"), 1.0)? as f32;
                if factor <= 0.0 {
                    return Err(LmError::BadMetadata {
                        key: key("rope.scaling.factor"),
                        expected: "a positive number",
                        found: factor.to_string(),
                    });
                }
                factor
            }
            Some(other) => {
                return Err(LmError::BadMetadata { key: key("rope.scaling.type"), expected: "none or linear", found: other.to_string() });
            }
        };
        Ok(ModelConfig {
            architecture,
            layers,
            embedding,
            heads,
            kv_heads,
            head_dim,
            feed_forward,
            context_length,
            rms_eps,
            rope: RopeConfig { base, dimensions, neox: architecture.rope_is_neox(), linear_scale },
        })
    }

    /// Width of the query projection (`heads × head_dim`).
    pub fn q_dim(&self) -> usize {
        self.heads * self.head_dim
    }

    /// Width of the key and value projections (`kv_heads × head_dim`).
    pub fn kv_dim(&self) -> usize {
        self.kv_heads * self.head_dim
    }
}
