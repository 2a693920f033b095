//! candle-transformers' quantized Llama, behind the `reference` feature: the implementation this
//! crate's forward pass is checked against (tests) and timed beside (`cargo xtask bench lm`).
//! It reads only `llama.*` metadata, so it runs llama-architecture files.

use std::path::Path;

use candle_core::{Device, IndexOp, Tensor};
use candle_transformers::models::quantized_llama::ModelWeights;

use crate::error::LmError;
use crate::gguf::GgufFile;
use crate::vocabulary::TokenId;

/// candle-transformers' `quantized_llama::ModelWeights` with the position it has reached.
#[derive(Debug)]
pub struct ReferenceLlama {
    weights: ModelWeights,
    position: usize,
}

impl ReferenceLlama {
    /// Loads a llama-architecture GGUF file onto the CPU, with an empty KV cache.
    pub fn load(path: &Path) -> Result<Self, LmError> {
        let mut file = GgufFile::open(path)?;
        let weights = ModelWeights::from_gguf(file.content, &mut file.reader, &Device::Cpu)?;
        Ok(ReferenceLlama { weights, position: 0 })
    }

    /// Runs `tokens` after what came before (its KV cache only grows) and returns the logits of
    /// the next token.
    pub fn forward(&mut self, tokens: &[TokenId]) -> Result<Vec<f32>, LmError> {
        if tokens.is_empty() {
            return Err(LmError::EmptySequence);
        }
        let input = Tensor::new(tokens, &Device::Cpu)?.unsqueeze(0)?;
        let logits = self.weights.forward(&input, self.position)?;
        self.position += tokens.len();
        Ok(logits.i(0)?.to_vec1::<f32>()?)
    }

    /// Empties the KV cache.
    pub fn reset(&mut self) {
        self.weights.clear_kv_cache();
        self.position = 0;
    }
}
