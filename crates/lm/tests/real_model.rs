//! Tests on the real default model, SmolLM2-135M-Instruct Q4_1 (98 MB), behind the
//! `real-model` feature: `cargo xtask fetch-model` puts the file in the model cache first
//! (`.ci/run` does both). Token ids must equal llama.cpp's for the same file
//! (`fixtures/smollm2_token_ids.json`, see `fixtures/README.md`); with the `reference` feature the
//! logits must be within 1e-3 of candle-transformers' quantized llama.

#![cfg(feature = "real-model")]

mod common;

#[cfg(feature = "reference")]
use common::max_abs_diff;
use common::model_path;
use lm::{LanguageModel, LocalModel, Logprobs, Usage, generate_greedy};
use serde_json::Value;

fn dense(logprobs: Logprobs) -> Vec<f32> {
    match logprobs {
        Logprobs::Dense(values) => values,
        Logprobs::Sparse { .. } => panic!("the local backend is dense"),
    }
}

#[test]
fn token_ids_equal_llama_cpp() {
    let model = LocalModel::load(&model_path()).expect("loads");
    let fixture: Value = serde_json::from_str(include_str!("fixtures/smollm2_token_ids.json")).expect("fixture is JSON");
    let cases = fixture["cases"].as_array().expect("cases");
    assert!(cases.len() >= 20);
    for case in cases {
        let text = case["text"].as_str().expect("text");
        let expected: Vec<u32> = case["ids"].as_array().expect("ids").iter().map(|v| v.as_u64().expect("id") as u32).collect();
        assert_eq!(model.encode(text).expect("encodes"), expected, "ids of {text:?}");
        assert_eq!(model.decode(&expected).expect("decodes"), text.as_bytes(), "bytes of {text:?}");
    }
    let vocabulary = model.vocabulary();
    assert_eq!(vocabulary.len(), 49_152);
    assert_eq!((vocabulary.eos(), vocabulary.bos()), (2, Some(1)));
    assert_eq!(vocabulary.token_bytes(2), Some(&b"<|im_end|>"[..]));
}

#[test]
fn chat_prompt_and_greedy_answer() {
    let mut model = LocalModel::load(&model_path()).expect("loads");
    let prompt = model.chat_prompt("You are a helpful assistant.", "What is the capital of France?").expect("renders");
    assert_eq!(
        prompt,
        "<|im_start|>system\nYou are a helpful assistant.<|im_end|>\n<|im_start|>user\nWhat is the capital of France?<|im_end|>\n<|im_start|>assistant\n"
    );
    let ids = model.encode(&prompt).expect("encodes");
    let answer = generate_greedy(&mut model, &ids, 24).expect("generates");
    let text = String::from_utf8_lossy(&model.decode(&answer).expect("decodes")).into_owned();
    assert!(text.contains("Paris"), "{text}");
}

#[test]
fn a_sibling_branch_costs_its_suffix_and_matches_a_fresh_computation() {
    let path = model_path();
    let mut model = LocalModel::load(&path).expect("loads");
    let prefix =
        model.encode("<|im_start|>user\nPut a clean mug in the coffeemachine.<|im_end|>\n<|im_start|>assistant\ngo to").expect("encodes");
    let a: Vec<u32> = prefix.iter().copied().chain(model.encode(" countertop 1").expect("encodes")).collect();
    let b: Vec<u32> = prefix.iter().copied().chain(model.encode(" sinkbasin").expect("encodes")).collect();
    model.next_logprobs(&a).expect("runs");
    let before = model.usage();
    let sibling = dense(model.next_logprobs(&b).expect("runs"));
    let suffix = (b.len() - prefix.len()) as u64;
    assert_eq!(
        model.usage().since(&before),
        Usage { forward_calls: 1, tokens_prefilled: suffix, tokens_reused: prefix.len() as u64, tokens_generated: 1, cache_hits: 0 }
    );
    let fresh = dense(LocalModel::load(&path).expect("loads").next_logprobs(&b).expect("runs"));
    // Bit for bit: every row of every matrix product, and each query's attention, depends only
    // on that position's own activations and the cache before it (activations are quantized to
    // 8 bits per 32-value block of one row), so computing the positions in chunks of other
    // sizes (the prefix inside `a`, then a 3-token suffix, against all of `b` at once) changes
    // nothing. (Until issue 23, attention in candle's tensor ops rounded differently with the
    // chunk's shape: total variation 0.023 here, as candle-transformers' quantized llama shows.)
    assert_eq!(sibling, fresh, "the sibling branch differs from a fresh computation");
    // Chunked the same way, it is the same bit for bit, whatever was computed in between.
    let c: Vec<u32> = prefix.iter().copied().chain(model.encode(" fridge 1").expect("encodes")).collect();
    let mut other = LocalModel::load(&path).expect("loads");
    other.next_logprobs(&a).expect("runs");
    other.next_logprobs(&c).expect("runs");
    assert_eq!(dense(other.next_logprobs(&b).expect("runs")), sibling);
}

/// How far our logits may be from candle-transformers' quantized llama on the same file and
/// tokens. Both quantize activations to 8 bits before every matrix product, but our attention
/// sums in another order (eight lanes, fused multiply-adds; issue 23), and one rounding flipped
/// in an activation quantum compounds over 30 layers. Measured on this test's tokens: at most
/// 1.19 on a single logit over the whole vocabulary, total variation between the two
/// distributions at most 0.067 (candle-transformers' own prefill and prefix-then-suffix differ
/// by 0.023 on other tokens), and the same best token at every step but one, a near-tie of
/// 0.112 in the other's logits.
#[cfg(feature = "reference")]
const REFERENCE_MAX_LOGIT_DIFF: f32 = 1.5;
#[cfg(feature = "reference")]
const REFERENCE_TOTAL_VARIATION: f32 = 0.1;
#[cfg(feature = "reference")]
const REFERENCE_BEST_TOKEN_GAP: f32 = 0.3;

#[cfg(feature = "reference")]
fn assert_close_to_reference(ours: &[f32], theirs: &[f32], what: &str) {
    let diff = max_abs_diff(ours, theirs);
    let (p, q) = (Logprobs::from_logits(ours), Logprobs::from_logits(theirs));
    let (Logprobs::Dense(p), Logprobs::Dense(q)) = (&p, &q) else { unreachable!("from_logits is dense") };
    let total_variation: f32 = p.iter().zip(q).map(|(a, b)| (a.exp() - b.exp()).abs()).sum::<f32>() / 2.0;
    eprintln!("{what}: largest logit difference {diff:.3}, total variation {total_variation:.4}");
    assert!(diff < REFERENCE_MAX_LOGIT_DIFF, "{what}: logits differ by {diff}");
    assert!(total_variation < REFERENCE_TOTAL_VARIATION, "{what}: total variation {total_variation}");
    // Each side's best token is the other's best or a near-tie there.
    for (a, b, side) in [(ours, theirs, "ours"), (theirs, ours, "theirs")] {
        let best = Logprobs::from_logits(a).argmax().expect("nonempty") as usize;
        let gap = b.iter().copied().fold(f32::NEG_INFINITY, f32::max) - b[best];
        eprintln!("{what}: {side} best token {best} is {gap:.3} below the other's best");
        assert!(gap <= REFERENCE_BEST_TOKEN_GAP, "{what}: {side} best token {best} is {gap} below the other's best");
    }
}

#[cfg(feature = "reference")]
#[test]
fn logits_match_candle_transformers_quantized_llama() {
    let path = model_path();
    let mut model = LocalModel::load(&path).expect("loads");
    let mut reference = lm::reference::ReferenceLlama::load(&path).expect("reference loads");
    let prompt = model.encode(&model.chat_prompt("You plan household tasks.", "Make a cup of coffee.").expect("renders")).expect("encodes");
    let mut ours = model.next_logits(&prompt).expect("runs").to_vec();
    let theirs = reference.forward(&prompt).expect("runs");
    assert_close_to_reference(&ours, &theirs, "prefill");
    // Then token by token through both caches.
    let mut sequence = prompt.clone();
    for step in 0..8 {
        let next = Logprobs::from_logits(&ours).argmax().expect("token");
        sequence.push(next);
        let ours_step = model.next_logits(&sequence).expect("runs").to_vec();
        let theirs_step = reference.forward(&[next]).expect("runs");
        assert_close_to_reference(&ours_step, &theirs_step, &format!("decode step {step}"));
        ours = ours_step;
    }
    // Steps of several tokens at once (a constrained decoder sends the tokens the mask forced
    // with the next one).
    for width in 2..=4 {
        let next: Vec<_> = (0..width).map(|i| prompt[10 + i]).collect();
        sequence.extend_from_slice(&next);
        let ours_step = model.next_logits(&sequence).expect("runs").to_vec();
        let theirs_step = reference.forward(&next).expect("runs");
        assert_close_to_reference(&ours_step, &theirs_step, &format!("a {width}-token step"));
    }
}

#[test]
fn the_prior_over_allowed_tokens_matches_the_full_head() {
    let mut model = LocalModel::load(&model_path()).expect("loads");
    let prompt =
        model.encode("<|im_start|>user\nPut a clean mug in the coffeemachine.<|im_end|>\n<|im_start|>assistant\ngo to").expect("encodes");
    let allowed: Vec<u32> = [" countertop", " sinkbasin", " coffeemachine", " cabinet", " fridge"]
        .iter()
        .map(|w| model.encode(w).expect("encodes")[0])
        .collect();
    let Logprobs::Dense(full) = model.next_logprobs(&prompt).expect("runs") else { unreachable!() };
    let expected = Logprobs::Dense(full).among(&allowed).expect("allowed");
    let prior = model.next_logprobs_among(&prompt, &allowed).expect("runs");
    assert_eq!(prior.tokens, expected.tokens);
    // Rows dotted in f32 against the full head's 8-bit activations: the same prior up to that
    // rounding.
    let total_variation: f32 = prior.probabilities().iter().zip(expected.probabilities()).map(|(a, b)| (a - b).abs()).sum::<f32>() / 2.0;
    // Measured: 0.0104 on this prompt since attention was rewritten (issue 23; 0.009 before).
    assert!(total_variation < 0.02, "total variation {total_variation}");
    assert_eq!(prior.argmax(), expected.argmax());
}

/// The reference prompts of the greedy tests: chat and raw text, household words, one of about
/// 800 tokens so that attention runs over a deep cache.
fn reference_prompts(model: &LocalModel) -> Vec<(&'static str, String)> {
    let room = "You are in the middle of a kitchen. Looking quickly around you, you see a cabinet 4, a cabinet 3, \
                a cabinet 2, a cabinet 1, a coffeemachine 1, a countertop 2, a countertop 1, a fridge 1, a microwave 1, \
                a sinkbasin 1 and a toaster 1. ";
    let long =
        format!("{}Your task is to: put a clean mug in the coffeemachine. Which place do you look at first, and why?", room.repeat(10));
    vec![
        ("coffee", model.chat_prompt("You plan household tasks.", "Make a cup of coffee.").expect("renders")),
        (
            "plan",
            model
                .chat_prompt(
                    "You write plans for a household robot, one action per line.",
                    &format!("{room}Your task is to: put a clean mug in the coffeemachine."),
                )
                .expect("renders"),
        ),
        ("raw_plan", "Plan:\ngo to countertop 1\ntake mug 1 from countertop 1\ngo to sinkbasin 1\n".to_string()),
        (
            "json",
            model
                .chat_prompt("Reply with one JSON object with the keys \"skill\" and \"done\".", &format!("{room}Find a mug."))
                .expect("renders"),
        ),
        ("long", model.chat_prompt("You are a helpful assistant.", &long).expect("renders")),
    ]
}

/// Greedy continuations of the reference prompts, token for token, as a snapshot: any change to
/// the forward pass's arithmetic shows here first.
#[test]
fn greedy_continuations_of_the_reference_prompts() {
    let mut model = LocalModel::load(&model_path()).expect("loads");
    let mut lines = Vec::new();
    for (name, prompt) in reference_prompts(&model) {
        let ids = model.encode(&prompt).expect("encodes");
        let answer = generate_greedy(&mut model, &ids, 48).expect("generates");
        let text = String::from_utf8_lossy(&model.decode(&answer).expect("decodes")).into_owned();
        lines.push(format!("{name} ({} prompt tokens): {answer:?}\n  {text:?}", ids.len()));
    }
    insta::assert_snapshot!(lines.join("\n"));
}

/// Largest gap, in logits, allowed between the best token and the token the forward pass chose
/// before attention was rewritten (issue 23). With activations quantized to 8 bits before every
/// matrix product, summing attention in another order moves logits by up to about 0.7 over the
/// whole vocabulary (`cargo xtask bench lm`, `reference_max_logit_diff`), so a token that won
/// by less than that before may now lose. Measured on these prompts: 223 of the 226 steps
/// choose the same token as before, and the other three are within 0.086 of the best.
const NEAR_TIE: f32 = 0.15;

/// The continuations the forward pass gave before the attention rewrite
/// (`fixtures/smollm2_greedy_before.json`), fed back token by token: at every step the old
/// token must still be the best or within [`NEAR_TIE`] of it, so a changed greedy continuation
/// is a near-tie decided the other way, never a different model.
#[test]
fn the_greedy_continuations_from_before_are_still_best_up_to_near_ties() {
    let mut model = LocalModel::load(&model_path()).expect("loads");
    let fixture: Value = serde_json::from_str(include_str!("fixtures/smollm2_greedy_before.json")).expect("fixture is JSON");
    let prompts = reference_prompts(&model);
    let cases = fixture["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), prompts.len());
    let (mut steps, mut agreeing, mut widest) = (0usize, 0usize, 0.0f32);
    for (case, (name, prompt)) in cases.iter().zip(&prompts) {
        assert_eq!(case["name"].as_str(), Some(*name));
        let mut sequence = model.encode(prompt).expect("encodes");
        assert_eq!(case["prompt_tokens"].as_u64(), Some(sequence.len() as u64), "{name}: the prompt's tokens");
        for (step, token) in case["continuation"].as_array().expect("ids").iter().enumerate() {
            let token = token.as_u64().expect("id") as u32;
            let logits = model.next_logits(&sequence).expect("runs").to_vec();
            let best = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let gap = best - logits[token as usize];
            assert!(gap <= NEAR_TIE, "{name}, step {step}: token {token} is {gap} below the best");
            steps += 1;
            agreeing += usize::from(gap == 0.0);
            widest = widest.max(gap);
            sequence.push(token);
        }
    }
    eprintln!("{agreeing} of {steps} steps choose the same token; the widest gap is {widest:.3}");
}
