//! The local backend end to end on the tiny random-weight model (`lm::tiny`): tokenizer ids
//! checked by hand, the forward pass, the prefix cache (a sibling branch's logits equal a
//! fresh computation), every architecture variant, and typed errors on malformed files.

mod common;

use candle_core::quantized::GgmlDType;
use candle_core::quantized::gguf_file::Value;
use common::{TempDir, max_abs_diff, read_parts, tiny_file, write_parts};
use lm::tiny::{TinySpec, tiny_gguf_bytes};
use lm::{Architecture, LanguageModel, LmError, LocalModel, Logprobs, TokenKind, UniformModel, Usage, generate_greedy};
use proptest::prelude::*;

fn dense(logprobs: Logprobs) -> Vec<f32> {
    match logprobs {
        Logprobs::Dense(values) => values,
        Logprobs::Sparse { .. } => panic!("the local backend is dense"),
    }
}

/// Byte b of the tiny vocabulary is token 3 + b.
fn byte(b: u8) -> u32 {
    3 + b as u32
}

fn check_encoding(model: &LocalModel, text: &str, expected: &[u32]) {
    let ids = model.encode(text).expect("encodes");
    assert_eq!(ids, expected, "encoding of {text:?}");
    assert_eq!(model.decode(&ids).expect("decodes"), text.as_bytes(), "round trip of {text:?}");
}

#[test]
fn tiny_tokenizer_gives_the_hand_derived_ids() {
    let dir = TempDir::new("tokenizer");
    let model = LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec::default())).expect("loads");
    // Merges 259.. in order: Ġt he Ġthe Ġo pe Ġope Ġopen Ġf ri Ġfri dg Ġfridg Ġfridge Ġ1 12.
    check_encoding(&model, " open the fridge", &[265, 261, 271]);
    // No leading space: `Ġo` does not apply, `pe` does.
    check_encoding(&model, "open", &[byte(b'o'), 263, byte(b'n')]);
    // `smollm` splits every digit alone, so the merges `Ġ 1` and `1 2` never see their pair.
    check_encoding(&model, " 12", &[byte(b' '), byte(b'1'), byte(b'2')]);
    // Control tokens spelled in the text are matched whole.
    check_encoding(
        &model,
        "<|im_start|>user\nhi<|im_end|>",
        &[1, byte(b'u'), byte(b's'), byte(b'e'), byte(b'r'), byte(b'\n'), byte(b'h'), byte(b'i'), 2],
    );
    // Non-ASCII text goes through the byte-level alphabet.
    check_encoding(&model, "é", &[byte(0xC3), byte(0xA9)]);
    let vocabulary = model.vocabulary();
    assert_eq!(vocabulary.len(), 3 + 256 + 15);
    assert_eq!(vocabulary.eos(), 2);
    assert_eq!(vocabulary.bos(), Some(1));
    assert_eq!(vocabulary.kind(0), Some(TokenKind::Control));
    assert!(vocabulary.is_special(1) && !vocabulary.is_special(265));
    assert_eq!(vocabulary.token_bytes(271), Some(&b" fridge"[..]));
}

#[test]
fn chat_prompt_renders_the_files_template() {
    let dir = TempDir::new("chat");
    let model = LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec::default())).expect("loads");
    let prompt = model.chat_prompt("You plan.", "Open the fridge.").expect("renders");
    assert_eq!(prompt, "<|im_start|>system\nYou plan.<|im_end|>\n<|im_start|>user\nOpen the fridge.<|im_end|>\n<|im_start|>assistant\n");
    let ids = model.encode(&prompt).expect("encodes");
    assert_eq!(ids.iter().filter(|&&t| t == 1).count(), 3, "three <|im_start|>");
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(274),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]
    #[test]
    fn any_text_round_trips(text in "\\PC{0,40}") {
        let dir = TempDir::new("roundtrip");
        let model = LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec::default())).expect("loads");
        let ids = model.encode(&text).expect("encodes");
        prop_assert_eq!(model.decode(&ids).expect("decodes"), text.as_bytes().to_vec());
    }
}

/// The tokens of a short prompt.
fn prompt(model: &LocalModel) -> Vec<u32> {
    model.encode("<|im_start|>user\n open the fridge 12<|im_end|>").expect("encodes")
}

fn fresh_logprobs(path: &std::path::Path, tokens: &[u32]) -> Vec<f32> {
    dense(LocalModel::load(path).expect("loads").next_logprobs(tokens).expect("runs"))
}

fn check_branching(spec: &TinySpec) {
    let dir = TempDir::new(&format!("branch-{:?}-{}-{:?}", spec.architecture, spec.tied_output, spec.weight_type));
    let path = tiny_file(&dir, "tiny.gguf", spec);
    let mut model = LocalModel::load(&path).expect("loads");
    let prefix = prompt(&model);
    let branch_a: Vec<u32> = prefix.iter().copied().chain([265, 261, 271]).collect();
    let branch_b: Vec<u32> = prefix.iter().copied().chain([byte(b'x')]).collect();

    let a = dense(model.next_logprobs(&branch_a).expect("runs"));
    let total: f32 = a.iter().map(|l| l.exp()).sum();
    assert!((total - 1.0).abs() < 1e-4, "a distribution: {total}");
    assert!(a.iter().all(|l| l.is_finite()));
    let before = model.usage();
    let b = dense(model.next_logprobs(&branch_b).expect("runs"));
    let cost = model.usage().since(&before);
    assert_eq!(
        cost,
        Usage { forward_calls: 1, tokens_prefilled: 1, tokens_reused: prefix.len() as u64, tokens_generated: 1, cache_hits: 0 }
    );
    assert!(max_abs_diff(&b, &fresh_logprobs(&path, &branch_b)) < 1e-4, "sibling after rewind == fresh");

    // Back to branch a: its positions come back from the branch store, only the last is run
    // again (for its logits), and the answer is the same.
    let before = model.usage();
    let a_again = dense(model.next_logprobs(&branch_a).expect("runs"));
    assert_eq!(
        model.usage().since(&before),
        Usage { forward_calls: 1, tokens_prefilled: 1, tokens_reused: branch_a.len() as u64 - 1, tokens_generated: 1, cache_hits: 0 }
    );
    assert!(max_abs_diff(&a, &a_again) < 1e-4);
    // Without the store, the whole suffix is recomputed.
    model.set_branch_store_bytes(0);
    model.next_logprobs(&branch_b).expect("runs");
    let before = model.usage();
    let a_recomputed = dense(model.next_logprobs(&branch_a).expect("runs"));
    assert_eq!(model.usage().since(&before).tokens_prefilled, 3);
    assert!(max_abs_diff(&a, &a_recomputed) < 1e-4);
    assert_eq!(model.branch_store_bytes(), 0);
    // A budget smaller than a branch: the store empties itself, answers are unchanged.
    let per_position = model.cache_bytes() / model.cached_tokens().len();
    model.set_branch_store_bytes(per_position * (branch_b.len() + 1));
    let b_again = dense(model.next_logprobs(&branch_b).expect("runs"));
    assert_eq!(model.branch_store_bytes(), per_position * branch_b.len());
    assert!(max_abs_diff(&a, &dense(model.next_logprobs(&branch_a).expect("runs"))) < 1e-4);
    assert!(model.branch_store_bytes() <= per_position * (branch_b.len() + 1));
    assert!(max_abs_diff(&b, &b_again) < 1e-4);
    // The same sequence again: no forward pass.
    let before = model.usage();
    assert_eq!(dense(model.next_logprobs(&branch_a).expect("runs")), a_again);
    assert_eq!(
        model.usage().since(&before),
        Usage { forward_calls: 0, tokens_prefilled: 0, tokens_reused: branch_a.len() as u64, tokens_generated: 1, cache_hits: 1 }
    );
    // A strict prefix of the cached sequence: its last token is recomputed.
    let before = model.usage();
    let p = dense(model.next_logprobs(&prefix).expect("runs"));
    assert_eq!(model.usage().since(&before).tokens_prefilled, 1);
    assert!(max_abs_diff(&p, &fresh_logprobs(&path, &prefix)) < 1e-4);
    // Token by token equals all at once.
    model.clear_cache();
    let mut last = Vec::new();
    for end in 1..=branch_a.len() {
        last = dense(model.next_logprobs(&branch_a[..end]).expect("runs"));
    }
    assert!(max_abs_diff(&last, &a) < 1e-4, "incremental decode == prefill");
}

#[test]
fn sibling_branches_rewind_the_cache_and_match_a_fresh_computation() {
    check_branching(&TinySpec::default());
}

#[test]
fn every_architecture_and_weight_type_runs_and_branches() {
    for architecture in [Architecture::Qwen2, Architecture::Qwen3] {
        check_branching(&TinySpec { architecture, ..TinySpec::default() });
    }
    check_branching(&TinySpec { tied_output: false, weight_type: GgmlDType::Q8_0, ..TinySpec::default() });
    check_branching(&TinySpec { weight_type: GgmlDType::F32, layers: 1, ..TinySpec::default() });
}

#[test]
fn architectures_differ_in_their_outputs() {
    // Same seed, same weights drawn: biases (qwen2), q/k norms (qwen3) and the RoPE mode must
    // change the result, or those code paths are dead.
    let dir = TempDir::new("arch-differ");
    let mut outputs = Vec::new();
    for architecture in [Architecture::Llama, Architecture::Qwen2, Architecture::Qwen3] {
        let path = tiny_file(&dir, &format!("{architecture:?}.gguf"), &TinySpec { architecture, ..TinySpec::default() });
        let mut model = LocalModel::load(&path).expect("loads");
        let config = model.weights().config().clone();
        assert_eq!(config.architecture, architecture);
        assert_eq!(config.rope.neox, architecture != Architecture::Llama);
        outputs.push(dense(model.next_logprobs(&prompt(&model)).expect("runs")));
    }
    assert!(max_abs_diff(&outputs[0], &outputs[1]) > 1e-3);
    assert!(max_abs_diff(&outputs[0], &outputs[2]) > 1e-3);
}

#[test]
fn requests_with_bad_tokens_fail_without_breaking_the_cache() {
    let dir = TempDir::new("bad-requests");
    let path = tiny_file(&dir, "tiny.gguf", &TinySpec { context_length: 40, ..TinySpec::default() });
    let mut model = LocalModel::load(&path).expect("loads");
    let tokens = prompt(&model);
    let good = dense(model.next_logprobs(&tokens).expect("runs"));
    assert!(matches!(model.next_logprobs(&[]), Err(LmError::EmptySequence)));
    assert!(matches!(model.next_logprobs(&[5, 9999]), Err(LmError::TokenOutOfRange { id: 9999, size: 274 })));
    let long = vec![byte(b'a'); 41];
    assert!(matches!(model.next_logprobs(&long), Err(LmError::ContextOverflow { len: 41, max: 40 })));
    assert_eq!(dense(model.next_logprobs(&tokens).expect("runs")), good);
    assert!(matches!(model.next_logprobs_among(&tokens, &[]), Err(LmError::NoAllowedTokens)));
}

#[test]
fn the_prior_over_allowed_tokens_is_the_renormalised_distribution() {
    // The prior dots each allowed row with the hidden state in f32; the full head quantizes the
    // hidden state to 8 bits first (as llama.cpp and candle do) except for an f32 head. So the two
    // agree to float precision with an f32 head, and to that rounding with the tiny model's tied
    // Q8_0 head.
    for (weight_type, tied_output, tolerance) in
        [(GgmlDType::F32, false, 1e-5), (GgmlDType::Q8_0, true, 5e-3), (GgmlDType::Q4_1, true, 5e-3)]
    {
        let dir = TempDir::new(&format!("prior-{weight_type:?}"));
        let mut model =
            LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec { weight_type, tied_output, ..TinySpec::default() })).expect("loads");
        let tokens = prompt(&model);
        let full = dense(model.next_logprobs(&tokens).expect("runs"));
        let allowed = [265, 261, byte(b'z'), 265];
        let prior = model.next_logprobs_among(&tokens, &allowed).expect("runs");
        assert_eq!(prior.tokens, vec![265, 261, byte(b'z')], "distinct, in the order given");
        let mass: f32 = prior.tokens.iter().map(|&t| full[t as usize].exp()).sum();
        let total: f32 = prior.probabilities().iter().sum();
        assert!((total - 1.0).abs() < 1e-5);
        for (i, &t) in prior.tokens.iter().enumerate() {
            let expected = full[t as usize].exp() / mass;
            assert!((prior.probabilities()[i] - expected).abs() < tolerance, "{weight_type:?}: {} vs {expected}", prior.probabilities()[i]);
        }
        // Asked again, the rows are reused and the answer is the same; errors are typed.
        assert_eq!(model.next_logprobs_among(&tokens, &allowed).expect("runs"), prior);
        assert!(matches!(model.next_logprobs_among(&tokens, &[9999]), Err(LmError::TokenOutOfRange { id: 9999, .. })));
    }
}

#[test]
fn greedy_generation_stops_at_max_tokens_or_a_stop_token() {
    let dir = TempDir::new("greedy");
    let mut model = LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec::default())).expect("loads");
    let tokens = prompt(&model);
    let out = generate_greedy(&mut model, &tokens, 12).expect("generates");
    assert!(out.len() <= 12);
    assert!(out.iter().all(|&t| !model.vocabulary().is_stop(t)));
    // Each step after the first cost one token.
    let usage = model.usage();
    assert_eq!(usage.tokens_generated as usize, if out.len() < 12 { out.len() + 1 } else { 12 });
    assert_eq!(usage.tokens_prefilled, tokens.len() as u64 + usage.tokens_generated - 1);
    // Greedy: each generated token is the argmax after what precedes it.
    let mut fresh = LocalModel::load(&tiny_file(&dir, "again.gguf", &TinySpec::default())).expect("loads");
    let mut sequence = tokens.clone();
    for &t in &out {
        assert_eq!(fresh.next_logprobs(&sequence).expect("runs").argmax(), Some(t));
        sequence.push(t);
    }
}

#[test]
fn uniform_backend_gives_every_token_the_same_probability() {
    let dir = TempDir::new("uniform");
    let local = LocalModel::load(&tiny_file(&dir, "tiny.gguf", &TinySpec::default())).expect("loads");
    let mut uniform = UniformModel::new(local.shared_tokenizer().clone());
    let values = dense(uniform.next_logprobs(&[5]).expect("runs"));
    assert_eq!(values.len(), 274);
    assert!(values.iter().all(|&l| (l - values[0]).abs() < 1e-7));
    assert!((values[0] + (274f32).ln()).abs() < 1e-6);
    let prior = uniform.next_logprobs_among(&[5, 6], &[7, 8, 7, 9]).expect("runs");
    assert_eq!(prior.tokens, vec![7, 8, 9]);
    assert!(prior.probabilities().iter().all(|p| (p - 1.0 / 3.0).abs() < 1e-6));
    assert!(matches!(uniform.next_logprobs_among(&[5], &[400]), Err(LmError::TokenOutOfRange { .. })));
    assert!(matches!(uniform.next_logprobs(&[]), Err(LmError::EmptySequence)));
    assert_eq!(uniform.usage().tokens_generated, 2);
    assert_eq!(uniform.usage().forward_calls, 0);
}

// ---- malformed files ----

fn load_error(name: &str, edit: impl FnOnce(&mut common::Parts)) -> LmError {
    let dir = TempDir::new(&format!("malformed-{name}"));
    let mut parts = read_parts(&tiny_gguf_bytes(&TinySpec::default()).expect("tiny"));
    edit(&mut parts);
    let path = dir.file("bad.gguf");
    write_parts(&path, &parts);
    LocalModel::load(&path).expect_err("must not load")
}

fn set(parts: &mut common::Parts, key: &str, value: Value) {
    match parts.metadata.iter_mut().find(|(k, _)| k == key) {
        Some(entry) => entry.1 = value,
        None => parts.metadata.push((key.to_string(), value)),
    }
}

#[test]
fn malformed_files_give_typed_errors_that_name_the_field() {
    let dir = TempDir::new("garbage");
    let garbage = dir.file("garbage.gguf");
    std::fs::write(&garbage, b"this is not a model file at all").expect("write");
    let error = LocalModel::load(&garbage).expect_err("not GGUF");
    assert!(matches!(&error, LmError::MalformedGguf(m) if m.contains("magic")), "{error}");
    assert!(!error.to_string().contains('\n'), "one line, no backtrace even under RUST_BACKTRACE: {error}");
    let truncated = dir.file("truncated.gguf");
    let bytes = tiny_gguf_bytes(&TinySpec::default()).expect("tiny");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).expect("write");
    assert!(matches!(LocalModel::load(&truncated), Err(LmError::MalformedGguf(_))));
    assert!(matches!(LocalModel::load(&dir.file("absent.gguf")), Err(LmError::Io { .. })));

    let error = load_error("no-block-count", |p| p.metadata.retain(|(k, _)| k != "llama.block_count"));
    assert!(matches!(&error, LmError::MissingMetadata { key } if key == "llama.block_count"), "{error}");
    let error = load_error("arch", |p| set(p, "general.architecture", Value::String("mamba".into())));
    assert!(matches!(&error, LmError::UnsupportedArchitecture(a) if a == "mamba"), "{error}");
    let error = load_error("heads-type", |p| set(p, "llama.attention.head_count", Value::String("four".into())));
    assert!(matches!(&error, LmError::BadMetadata { key, .. } if key == "llama.attention.head_count"), "{error}");
    let error = load_error("kv-heads", |p| set(p, "llama.attention.head_count_kv", Value::U32(3)));
    assert!(matches!(&error, LmError::BadMetadata { key, .. } if key == "llama.attention.head_count_kv"), "{error}");
    for (name, base) in [("theta-zero", 0.0), ("theta-negative", -1.0), ("theta-tiny", 1e-30), ("theta-huge", 1e300)] {
        let error = load_error(name, |p| set(p, "llama.rope.freq_base", Value::F64(base)));
        assert!(matches!(&error, LmError::BadMetadata { key, .. } if key == "llama.rope.freq_base"), "{error}");
    }
    let error = load_error("tokenizer-model", |p| set(p, "tokenizer.ggml.model", Value::String("llama".into())));
    assert!(matches!(&error, LmError::UnsupportedTokenizer { key: "tokenizer.ggml.model", .. }), "{error}");
    let error = load_error("pre", |p| set(p, "tokenizer.ggml.pre", Value::String("tekken".into())));
    assert!(matches!(&error, LmError::UnsupportedTokenizer { key: "tokenizer.ggml.pre", .. }), "{error}");
    let error = load_error("merge", |p| set(p, "tokenizer.ggml.merges", Value::Array(vec![Value::String("nospace".into())])));
    assert!(matches!(&error, LmError::BadMetadata { key, .. } if key == "tokenizer.ggml.merges[0]"), "{error}");
    let error = load_error("eos", |p| p.metadata.retain(|(k, _)| k != "tokenizer.ggml.eos_token_id"));
    assert!(matches!(&error, LmError::MissingMetadata { key } if key == "tokenizer.ggml.eos_token_id"), "{error}");
    let error = load_error("template", |p| set(p, "tokenizer.chat_template", Value::String("{% if %}".into())));
    assert!(matches!(&error, LmError::ChatTemplate(_)), "{error}");
    let error = load_error("tensor", |p| p.tensors.retain(|(n, _)| n != "blk.1.ffn_up.weight"));
    assert!(matches!(&error, LmError::MissingTensor { name } if name == "blk.1.ffn_up.weight"), "{error}");
    let error = load_error("shape", |p| set(p, "llama.feed_forward_length", Value::U32(96)));
    assert!(matches!(&error, LmError::BadTensorShape { name, .. } if name == "blk.0.ffn_gate.weight"), "{error}");
    // Messages say which key.
    assert!(
        load_error("msg", |p| p.metadata.retain(|(k, _)| k != "llama.embedding_length")).to_string().contains("llama.embedding_length")
    );
}
