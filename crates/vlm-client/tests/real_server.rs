//! The chat client against a real llama.cpp `llama-server` serving SmolLM2-135M-Instruct,
//! behind the `real-server` feature; `.ci/run` starts the server and passes its base URL in
//! `NSEA_LLAMA_SERVER_URL`. The server decodes under the `response_format` JSON schema, so
//! even this small model's reply must be schema-valid JSON naming a listed skill.

#![cfg(feature = "real-server")]

use serde_json::json;
use vlm_client::{ChatClient, ChatModel, ChatRequest, ClientConfig, JsonMode, Message, Sampling, chat_json, validate};

fn client() -> ChatClient {
    let url = std::env::var("NSEA_LLAMA_SERVER_URL").expect("NSEA_LLAMA_SERVER_URL: the base URL of a llama-server (see .ci/run)");
    ChatClient::new(ClientConfig::new(&url, "smollm2")).expect("client")
}

#[test]
fn a_json_reply_satisfies_the_schema() {
    let skills = ["Goto(countertop 1)", "Open(fridge 1)", "Goto(sinkbasin 1)", "Done"];
    let schema = json!({
        "type": "object",
        "properties": { "skill": { "enum": skills }, "reason": { "type": "string", "maxLength": 80 } },
        "required": ["skill", "reason"],
        "additionalProperties": false
    });
    let request = ChatRequest::new(vec![
        Message::system("You control a household robot. Answer with JSON."),
        Message::user(format!("Goal: put a cold apple on the table. You see a fridge. Skills: {}. Which skill next?", skills.join(", "))),
    ])
    .with_sampling(Sampling { seed: Some(1), ..Sampling::greedy(96) })
    .with_json_schema(schema.clone());
    let mut client = client();
    let reply = chat_json(&mut client, &request).expect("a JSON reply");
    assert_eq!(validate(&reply.value, &schema, "$"), Ok(()));
    assert!(skills.contains(&reply.value["skill"].as_str().expect("a skill")), "{}", reply.value);
    assert_eq!(reply.reply.json_mode, Some(JsonMode::Schema), "llama-server takes json_schema");
    assert!(!reply.repaired, "decoded under the schema: no repair needed");
    assert!(reply.usage.prompt_tokens > 20 && reply.usage.completion_tokens > 0, "{:?}", reply.usage);
}

#[test]
fn plain_text_replies_and_usage() {
    let mut client = client();
    // The server applies the model's chat template; what a 135M model answers is not the
    // client's business, so this checks the reply's shape and the usage it reports.
    let request = ChatRequest::new(vec![Message::system("You are a helpful assistant."), Message::user("What is the capital of France?")])
        .with_sampling(Sampling::greedy(24));
    let reply = client.chat(&request).expect("a reply");
    assert!(!reply.text.trim().is_empty(), "{reply:?}");
    assert_eq!(reply.attempts, 1);
    let usage = client.usage();
    assert_eq!(usage.requests, 1);
    assert!(usage.prompt_tokens > 10 && (1..=24).contains(&usage.completion_tokens), "{usage:?}");
}

#[test]
fn the_server_lists_the_file_it_loaded() {
    let url = std::env::var("NSEA_LLAMA_SERVER_URL").expect("NSEA_LLAMA_SERVER_URL: the base URL of a llama-server (see .ci/run)");
    let models = vlm_client::served_models(&url, None, &vlm_client::RetryPolicy::default())
        .expect("reachable")
        .expect("llama-server lists its model");
    // `.ci/run` starts the server without `--alias`: the id is the path of the GGUF it loaded,
    // whatever name a request gives.
    assert_eq!(models.len(), 1, "{models:?}");
    assert!(models[0].id.ends_with(".gguf"), "{models:?}");
}
