//! What a server says it serves: `GET {base}/models`, OpenAI's model list, which vLLM, llama.cpp's
//! `llama-server`, Ollama and hosted APIs answer. A request's `model` field does not say what
//! answered it: llama.cpp's server serves the one file it loaded under any name and echoes the
//! name asked for, so a run's records are named by what the list says instead (the served name
//! and its `root` on vLLM, the loaded file's path or alias on llama.cpp's server).

use serde_json::Value;

use crate::error::{ChatError, ChatErrorKind};
use crate::transport::{self, RetryPolicy};

/// One entry of a server's model list: the fields that name the model and stay the same while
/// the server serves it (not `created`, a time stamp some servers set at each request).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServedModel {
    /// The name requests use (llama.cpp's server: the model file's path, or its `--alias`).
    pub id: String,
    /// What the name serves, where the server says (vLLM: the model's path or hub name).
    pub root: Option<String>,
    /// Who serves it, where the server says (`vllm`, `llamacpp`, an API's organisation).
    pub owned_by: Option<String>,
}

/// The models the server at `base_url` (`http(s)://host[:port]/v1`) lists, or `None` where it
/// has no list (a 404, 405 or 501 for `/models`). A server that cannot be reached, or a list
/// that is not OpenAI's shape, is an error.
pub fn served_models(base_url: &str, api_key: Option<&str>, policy: &RetryPolicy) -> Result<Option<Vec<ServedModel>>, ChatError> {
    let base = base_url.trim_end_matches('/');
    let url = format!("{base}/models");
    let refuse = |kind| ChatError { kind, url: transport::redacted(&url), attempts: 0, elapsed: std::time::Duration::ZERO };
    transport::check_url(base).map_err(refuse)?;
    let agent = transport::agent(policy.timeout, base).map_err(refuse)?;
    let delivered = match transport::get_json(&agent, &url, api_key, policy) {
        Ok(delivered) => delivered,
        Err(ChatError { kind: ChatErrorKind::Status { status: 404 | 405 | 501, .. }, .. }) => return Ok(None),
        Err(error) => return Err(error),
    };
    parse_models(&delivered.body).map(Some).map_err(|why| ChatError {
        kind: ChatErrorKind::MalformedReply(why),
        url,
        attempts: delivered.attempts,
        elapsed: delivered.elapsed,
    })
}

/// Reads a model list body: `{"data": [{"id": ..., "root": ..., "owned_by": ...}, ...]}`.
pub fn parse_models(body: &[u8]) -> Result<Vec<ServedModel>, String> {
    let value: Value = serde_json::from_slice(body).map_err(|e| format!("the model list is not JSON: {e}"))?;
    let data = value.get("data").and_then(Value::as_array).ok_or("the model list has no `data` array")?;
    data.iter()
        .enumerate()
        .map(|(i, entry)| {
            let text = |key: &str| entry.get(key).and_then(Value::as_str).map(str::to_string);
            Ok(ServedModel {
                id: text("id").ok_or_else(|| format!("`data[{i}]` has no string `id`"))?,
                root: text("root"),
                owned_by: text("owned_by"),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_of_vllm_and_llama_cpp_give_their_names() {
        // vLLM 0.x: the served name, its root and the server; `created` is left out.
        let vllm = br#"{"object":"list","data":[{"id":"qwen3-vl","object":"model","created":1733400000,"owned_by":"vllm","root":"Qwen/Qwen3-VL-8B-Instruct","parent":null,"max_model_len":32768}]}"#;
        assert_eq!(
            parse_models(vllm).unwrap(),
            vec![ServedModel { id: "qwen3-vl".into(), root: Some("Qwen/Qwen3-VL-8B-Instruct".into()), owned_by: Some("vllm".into()) }]
        );
        // llama.cpp's server: the loaded file's path as the id.
        let llama = br#"{"models":[{"name":"/m/smollm2.gguf"}],"object":"list","data":[{"id":"/m/smollm2.gguf","object":"model","created":1,"owned_by":"llamacpp","meta":{"n_params":134515008}}]}"#;
        assert_eq!(parse_models(llama).unwrap()[0].id, "/m/smollm2.gguf");
    }

    #[test]
    fn lists_of_another_shape_are_errors_that_say_where() {
        assert!(parse_models(b"<html>").unwrap_err().contains("not JSON"));
        assert!(parse_models(br#"{"choices":[]}"#).unwrap_err().contains("no `data` array"));
        assert_eq!(parse_models(br#"{"data":[{"id":"a"},{"name":"b"}]}"#).unwrap_err(), "`data[1]` has no string `id`");
    }
}
