//! The forward pass against candle-transformers' quantized llama (the `reference` feature) on
//! tiny random-weight llama files: logits within 1e-3 after a prefill and after each decode
//! step, for tied and separate output heads and several weight types.

#![cfg(feature = "reference")]

mod common;

use candle_core::quantized::GgmlDType;
use common::{TempDir, max_abs_diff, tiny_file};
use lm::reference::ReferenceLlama;
use lm::tiny::TinySpec;
use lm::{LanguageModel, LocalModel, Logprobs};

fn check(spec: &TinySpec) {
    let dir = TempDir::new(&format!("reference-{}-{:?}", spec.tied_output, spec.weight_type));
    let path = tiny_file(&dir, "tiny.gguf", spec);
    let mut ours = LocalModel::load(&path).expect("loads");
    let mut reference = ReferenceLlama::load(&path).expect("reference loads");
    let prompt = ours.encode("<|im_start|>user\n open the fridge, then close the fridge 12<|im_end|>").expect("encodes");
    let mut logits = ours.next_logits(&prompt).expect("runs").to_vec();
    let diff = max_abs_diff(&logits, &reference.forward(&prompt).expect("runs"));
    assert!(diff < 1e-3, "{spec:?}: prefill logits differ by {diff}");
    assert!(logits.iter().map(|l| l.abs()).fold(0.0, f32::max) > 0.1, "logits are not trivially zero");
    let mut sequence = prompt;
    for _ in 0..6 {
        let next = Logprobs::from_logits(&logits).argmax().expect("token");
        sequence.push(next);
        logits = ours.next_logits(&sequence).expect("runs").to_vec();
        let diff = max_abs_diff(&logits, &reference.forward(&[next]).expect("runs"));
        assert!(diff < 1e-3, "{spec:?}: decode logits differ by {diff}");
    }
}

#[test]
fn tiny_llama_logits_match_candle_transformers() {
    check(&TinySpec::default());
    check(&TinySpec { tied_output: false, weight_type: GgmlDType::Q8_0, ..TinySpec::default() });
    check(&TinySpec { weight_type: GgmlDType::Q4_0, ..TinySpec::default() });
}
