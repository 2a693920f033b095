//! `LocalChat` (feature `chat`): a local model behind `vlm-client`'s chat interface, its reply
//! decoded under the JSON schema by llguidance. The tiny model's weights are random, so a valid
//! reply here is the schema's doing; with the `real-model` feature SmolLM2-135M must pick a
//! listed skill for a household prompt.

#![cfg(feature = "chat")]

mod common;

use common::{TempDir, tiny_file};
use lm::LanguageModel;
use lm::LocalChat;
use lm::LocalModel;
use lm::tiny::TinySpec;
use serde_json::{Value, json};
use vlm_client::{ChatErrorKind, ChatModel, ChatRequest, Image, ImageFormat, Message, Sampling, chat_json, validate};

fn tiny_chat(dir: &TempDir) -> LocalChat {
    let model = LocalModel::load(&tiny_file(dir, "tiny.gguf", &TinySpec::default())).expect("loads");
    LocalChat::new(model, "tiny").expect("has a chat template")
}

fn request(schema: Value, sampling: Sampling) -> ChatRequest {
    ChatRequest::new(vec![Message::system("Answer in JSON."), Message::user("Which skill next?")])
        .with_sampling(sampling)
        .with_json_schema(schema)
}

#[test]
fn random_weights_still_reply_with_schema_valid_json() {
    let dir = TempDir::new("local-chat-schema");
    let mut chat = tiny_chat(&dir);
    let schemas = [
        json!({ "type": "object", "properties": { "skill": { "enum": ["Goto(fridge 1)", "Open(fridge 1)", "Done"] } }, "required": ["skill"], "additionalProperties": false }),
        json!({
            "type": "object",
            "properties": {
                "seen": { "type": "array", "items": { "enum": ["mug", "apple"] }, "minItems": 1, "maxItems": 2 },
                "ready": { "type": "boolean" },
                "count": { "type": "integer", "minimum": 0, "maximum": 9 }
            },
            "required": ["seen", "ready", "count"],
            "additionalProperties": false
        }),
    ];
    for schema in schemas {
        for sampling in
            [Sampling::greedy(128), Sampling { temperature: Some(1.0), seed: Some(3), max_tokens: Some(128), ..Sampling::default() }]
        {
            let reply = chat_json(&mut chat, &request(schema.clone(), sampling.clone())).expect("valid JSON");
            assert_eq!(validate(&reply.value, &schema, "$"), Ok(()), "{}", reply.reply.text);
            assert!(!reply.repaired, "decoded under the schema: {}", reply.reply.text);
            assert_eq!(reply.reply.finish_reason.as_deref(), Some("stop"), "{sampling:?}");
            assert!(reply.usage.prompt_tokens > 0 && reply.usage.completion_tokens > 0);
        }
    }
    assert_eq!(chat.usage().requests, 4);
    assert_eq!(chat.endpoint(), "local:tiny");
}

#[test]
fn greedy_replies_repeat_and_seeds_steer_sampling() {
    let dir = TempDir::new("local-chat-repeat");
    let mut chat = tiny_chat(&dir);
    let schema = json!({ "type": "object", "properties": { "note": { "type": "string", "maxLength": 12 } }, "required": ["note"] });
    let text = |chat: &mut LocalChat, sampling: Sampling| chat.chat(&request(schema.clone(), sampling)).expect("reply").text;
    assert_eq!(text(&mut chat, Sampling::greedy(40)), text(&mut chat, Sampling::greedy(40)));
    let seeded = |seed| Sampling { temperature: Some(1.0), seed: Some(seed), max_tokens: Some(40), ..Sampling::default() };
    assert_eq!(text(&mut chat, seeded(9)), text(&mut chat, seeded(9)));
}

#[test]
fn tokens_the_schema_forces_skip_the_model_and_leave_the_reply_unchanged() {
    let dir = TempDir::new("local-chat-forced");
    let schema = json!({
        "type": "object",
        "properties": {
            "skill": { "enum": ["Goto(fridge 1)", "Open(fridge 1)", "Goto(countertop 2)", "Done"] },
            "facts": { "type": "array", "items": { "enum": ["(inreceptacle apple fridge)", "(opened fridge)"] }, "maxItems": 2 },
            "done": { "type": "boolean" }
        },
        "required": ["facts", "skill", "done"],
        "additionalProperties": false
    });
    let seeded = Sampling { temperature: Some(1.0), seed: Some(5), max_tokens: Some(96), ..Sampling::default() };
    for sampling in [Sampling::greedy(96), seeded] {
        let mut fast = tiny_chat(&dir);
        let mut slow = tiny_chat(&dir);
        slow.set_fast_forward(false);
        let a = fast.chat(&request(schema.clone(), sampling.clone())).expect("reply");
        let b = slow.chat(&request(schema.clone(), sampling.clone())).expect("reply");
        assert_eq!(a.text, b.text, "{sampling:?}");
        assert_eq!((a.usage.prompt_tokens, a.usage.completion_tokens), (b.usage.prompt_tokens, b.usage.completion_tokens));
        assert_eq!(a.finish_reason, b.finish_reason);
        let (fast_calls, slow_calls) = (fast.model().usage().forward_calls, slow.model().usage().forward_calls);
        // Off, one forward pass a generated token (the first one prefills the prompt); on, the
        // keys, quotes and the rest of each chosen option cost none.
        assert!(slow_calls >= b.usage.completion_tokens, "{slow_calls} calls for {} tokens", b.usage.completion_tokens);
        assert!(2 * fast_calls < slow_calls, "{fast_calls} calls with fast-forward, {slow_calls} without: {}", a.text);
    }
}

#[test]
fn images_and_unusable_schemas_are_bad_input() {
    let dir = TempDir::new("local-chat-bad");
    let mut chat = tiny_chat(&dir);
    let image = Image::encode_rgb8(ImageFormat::Png, 1, 1, &[0, 0, 0]).expect("png");
    let with_image = ChatRequest::new(vec![Message::user("What is this?").with_image(image)]);
    let error = chat.chat(&with_image).expect_err("text only");
    assert!(matches!(&error.kind, ChatErrorKind::BadInput(m) if m.contains("text only")), "{error}");
    let unsatisfiable = request(
        json!({ "type": "object", "properties": { "a": { "$ref": "#/definitions/missing" } }, "required": ["a"] }),
        Sampling::greedy(8),
    );
    let error = chat.chat(&unsatisfiable).expect_err("llguidance refuses");
    assert!(matches!(&error.kind, ChatErrorKind::BadInput(m) if m.contains("JSON schema")), "{error}");
}

#[test]
fn without_a_schema_the_reply_is_free_text_up_to_max_tokens() {
    let dir = TempDir::new("local-chat-free");
    let mut chat = tiny_chat(&dir);
    let reply = chat.chat(&ChatRequest::new(vec![Message::user("Hi")]).with_sampling(Sampling::greedy(5))).expect("reply");
    assert!(reply.usage.completion_tokens <= 5);
    assert_eq!(reply.json_mode, None);
    if reply.usage.completion_tokens == 5 {
        assert_eq!(reply.finish_reason.as_deref(), Some("length"));
    }
}

#[cfg(feature = "real-model")]
#[test]
fn smollm2_picks_a_listed_skill() {
    let path = lm::default_model_path();
    let mut chat = LocalChat::new(LocalModel::load(&path).expect("fetch-model first"), "smollm2").expect("chat template");
    let skills = ["Goto(countertop 1)", "Open(fridge 1)", "Goto(sinkbasin 1)", "Done"];
    let schema = json!({
        "type": "object",
        "properties": { "skill": { "enum": skills }, "reason": { "type": "string", "maxLength": 60 } },
        "required": ["skill", "reason"],
        "additionalProperties": false
    });
    let request = ChatRequest::new(vec![
        Message::system("You control a household robot. Reply with JSON."),
        Message::user(format!(
            "Goal: a cold apple on the table. The apple is in the closed fridge. Skills: {}. Which skill next?",
            skills.join(", ")
        )),
    ])
    .with_sampling(Sampling::greedy(160))
    .with_json_schema(schema.clone());
    let reply = chat_json(&mut chat, &request).expect("valid JSON");
    assert_eq!(validate(&reply.value, &schema, "$"), Ok(()), "{}", reply.reply.text);
    assert!(skills.contains(&reply.value["skill"].as_str().expect("skill")));
}

/// A reply asked for more tokens than the model's context holds (the paper's thinking
/// condition asks for 32,768; SmolLM2's context is 8,192) ends at the context, finish reason
/// `length`, as a server's does, instead of failing with a context overflow.
#[test]
fn a_reply_longer_than_the_context_stops_at_the_context() {
    let dir = TempDir::new("local-chat-context");
    let spec = TinySpec::default();
    let mut chat = tiny_chat(&dir);
    let request = ChatRequest::new(vec![Message::user("Write the plan, one action a line.")]);
    let mut stopped_at_the_context = 0;
    for seed in 0..8 {
        let sampling = Sampling { temperature: Some(1.5), seed: Some(seed), max_tokens: Some(32_768), ..Sampling::default() };
        let reply = chat.chat(&request.clone().with_sampling(sampling)).expect("a reply, not an overflow");
        let total = reply.usage.prompt_tokens + reply.usage.completion_tokens;
        assert!(total <= spec.context_length as u64, "{total} tokens in a context of {}", spec.context_length);
        if reply.finish_reason.as_deref() == Some("length") {
            assert_eq!(total, spec.context_length as u64);
            stopped_at_the_context += 1;
        }
    }
    assert!(stopped_at_the_context > 0, "no reply ran to the context");
}
