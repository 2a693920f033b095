//! The Qwen3 tokenizer the project ships (`fixtures/tokenizers/qwen3/`) as a contract, in insta
//! snapshots (`tests/snapshots/qwen3_snapshots__*.snap`): the ids and pieces of a few reference
//! strings (an ALFWorld command, a VirtualHome line, PDDL, numbers, a contraction, accented and
//! CJK text, emoji, spelled control tokens), and what its chat template renders for a short
//! conversation. Besides the snapshots, every id list decodes back to its text and the prompts
//! encode with their control tokens whole. Needs no model file: only the two JSON files.
//!
//! (SmolLM2's tokenizer lives only inside its GGUF model file, which tests may not need; its
//! ids are checked against llama.cpp's in `tests/real_model.rs`, feature `real-model`.)

use std::fmt::Write;
use std::path::Path;
use std::sync::OnceLock;

use lm::Tokenizer;

fn qwen3() -> &'static Tokenizer {
    static QWEN3: OnceLock<Tokenizer> = OnceLock::new();
    QWEN3.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/tokenizers/qwen3/tokenizer.json");
        Tokenizer::from_tokenizer_json(&path).expect("the Qwen3 tokenizer loads")
    })
}

/// `text`, its ids and each id's piece (lossy UTF-8: a character cut between tokens shows as
/// U+FFFD), one block per text.
fn describe(tokenizer: &Tokenizer, texts: &[&str]) -> String {
    let mut out = String::new();
    for text in texts {
        let ids = tokenizer.encode(text).expect("encodes");
        assert_eq!(tokenizer.decode(&ids).expect("in range"), text.as_bytes(), "{text:?} decodes back to itself");
        let pieces: Vec<String> = ids.iter().map(|&id| tokenizer.decode_lossy(&[id]).expect("in range")).collect();
        writeln!(out, "{text:?}\n  ids:    {ids:?}\n  pieces: {pieces:?}").expect("a String");
    }
    out
}

#[test]
fn qwen3_ids_of_the_reference_strings() {
    let texts = [
        "go to countertop 1\n",
        "take apple 1 from countertop 1\n",
        "heat mug 2 with microwave 1\n",
        "walk kitchen\ngrab cup\nputin cup dishwasher\n",
        "(pickupobjectinreceptacle agent1 apple_bar__minus_00_dot_47 countertop1)",
        "1234567890 -17 3.14159",
        "I'm sure it's DON'T",
        "café naïve résumé",
        "日本語のテキスト",
        "🙂🍎",
        "a  b   c\t\td\n\n",
        "<|im_start|>user\nMake tea.<|im_end|>\n<think>\n\n</think>\n\n<|endoftext|>",
    ];
    insta::assert_snapshot!(describe(qwen3(), &texts));
}

/// `chat_prompt`: the planner's system and user message, the assistant's turn opened, and the
/// prompt's ids (three `<|im_start|>`, two `<|im_end|>`, each one token).
#[test]
fn qwen3_chat_prompt_of_a_system_and_a_user_message() {
    let tokenizer = qwen3();
    let prompt = tokenizer.chat_prompt("You are a household robot.", "Put a clean mug in the coffee machine.").expect("renders");
    let ids = tokenizer.encode(&prompt).expect("encodes");
    assert_eq!(ids.iter().filter(|&&id| id == 151_644).count(), 3, "<|im_start|> is one control token");
    assert_eq!(ids.iter().filter(|&&id| id == 151_645).count(), 2, "<|im_end|> is one control token");
    insta::assert_snapshot!(format!("{prompt}\n---\nids: {ids:?}"));
}

/// The template's history branch on a short conversation: an assistant turn before the last
/// user message loses its `<think>` block; the generation prompt opens the next assistant turn
/// without one (`enable_thinking` undefined, as `transformers` renders it by default).
#[test]
fn qwen3_chat_template_on_a_short_conversation() {
    let template = qwen3().chat_template().expect("tokenizer_config.json has one");
    let messages = [
        ("system", "You are a household robot."),
        ("user", "Put a clean mug in the coffee machine."),
        ("assistant", "<think>\nThe mug is in the sink.\n</think>\n\ngo to sinkbasin 1"),
        ("user", "You arrive at sinkbasin 1. On the sinkbasin 1, you see a mug 1."),
    ];
    let rendered = template.render(&messages, "", "<|im_end|>").expect("renders");
    assert!(!rendered.contains("The mug is in the sink."), "earlier reasoning is dropped");
    // (insta ignores trailing line breaks; the turn's `\n` is part of the contract.)
    assert!(rendered.ends_with("<|im_end|>\n<|im_start|>assistant\n"), "the assistant's turn is opened bare");
    insta::assert_snapshot!(rendered);
}
