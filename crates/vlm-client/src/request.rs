//! One chat request: the messages, the sampling settings, the JSON wanted, and the body
//! `/v1/chat/completions` receives for it.

use serde_json::{Map, Value, json};

use crate::message::Message;

/// Sampling settings; `None` leaves the server's default.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sampling {
    /// Softmax temperature; 0 is greedy.
    pub temperature: Option<f64>,
    /// Nucleus sampling: the smallest set of most likely tokens whose probabilities reach this.
    pub top_p: Option<f64>,
    /// Not in OpenAI's API; vLLM, llama.cpp and Ollama read it.
    pub top_k: Option<u32>,
    /// The most tokens the reply may have.
    pub max_tokens: Option<u32>,
    /// Seed of the server's sampler, for repeatable sampling where the server honours it.
    pub seed: Option<u64>,
}

impl Sampling {
    /// Greedy decoding of at most `max_tokens` tokens.
    pub fn greedy(max_tokens: u32) -> Sampling {
        Sampling { temperature: Some(0.0), max_tokens: Some(max_tokens), ..Sampling::default() }
    }
}

/// How a JSON reply is asked of the server (`response_format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum JsonMode {
    /// `{"type": "json_schema", ...}`: the server decodes under the schema.
    Schema,
    /// `{"type": "json_object"}`: any JSON object.
    Object,
    /// No `response_format`; the first JSON object is read out of the text.
    Text,
}

impl JsonMode {
    /// The next weaker mode, for a server that refuses this one.
    pub fn weaker(self) -> Option<JsonMode> {
        match self {
            JsonMode::Schema => Some(JsonMode::Object),
            JsonMode::Object => Some(JsonMode::Text),
            JsonMode::Text => None,
        }
    }
}

/// What to ask a chat model.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChatRequest {
    /// The conversation, oldest message first.
    pub messages: Vec<Message>,
    /// How the reply is decoded.
    pub sampling: Sampling,
    /// A JSON reply satisfying this schema is wanted (see [`crate::chat_json`]).
    pub json_schema: Option<Value>,
    /// Passed to the chat template (vLLM, llama.cpp), e.g. `{"enable_thinking": false}` for
    /// Qwen3.
    pub chat_template_kwargs: Option<Map<String, Value>>,
}

impl ChatRequest {
    /// A request of `messages` with the server's default sampling, no schema and no template
    /// arguments.
    pub fn new(messages: Vec<Message>) -> ChatRequest {
        ChatRequest { messages, ..ChatRequest::default() }
    }

    /// Replaces the sampling settings.
    pub fn with_sampling(mut self, sampling: Sampling) -> ChatRequest {
        self.sampling = sampling;
        self
    }

    /// Asks for a JSON reply satisfying `schema` (see [`crate::chat_json`]).
    pub fn with_json_schema(mut self, schema: Value) -> ChatRequest {
        self.json_schema = Some(schema);
        self
    }

    /// Sets Qwen3's thinking mode through `chat_template_kwargs.enable_thinking`.
    pub fn with_thinking(mut self, enabled: bool) -> ChatRequest {
        self.chat_template_kwargs.get_or_insert_with(Map::new).insert("enable_thinking".into(), json!(enabled));
        self
    }

    /// Image parts over all messages.
    pub fn image_count(&self) -> usize {
        self.messages.iter().map(Message::image_count).sum()
    }

    /// The JSON body for `model`, asking for JSON by `mode` when a schema is set.
    pub fn body(&self, model: &str, mode: JsonMode) -> Value {
        let mut body = Map::new();
        body.insert("model".into(), json!(model));
        body.insert("messages".into(), Value::Array(self.messages.iter().map(Message::to_json).collect()));
        let s = &self.sampling;
        let settings =
            [("temperature", s.temperature.map(|v| json!(v))), ("top_p", s.top_p.map(|v| json!(v))), ("top_k", s.top_k.map(|v| json!(v)))];
        for (name, value) in
            settings.into_iter().chain([("max_tokens", s.max_tokens.map(|v| json!(v))), ("seed", s.seed.map(|v| json!(v)))])
        {
            if let Some(value) = value {
                body.insert(name.into(), value);
            }
        }
        if let Some(schema) = &self.json_schema {
            match mode {
                JsonMode::Schema => {
                    body.insert(
                        "response_format".into(),
                        json!({ "type": "json_schema", "json_schema": { "name": "reply", "strict": true, "schema": schema } }),
                    );
                }
                JsonMode::Object => {
                    body.insert("response_format".into(), json!({ "type": "json_object" }));
                }
                JsonMode::Text => {}
            }
        }
        if let Some(kwargs) = &self.chat_template_kwargs {
            body.insert("chat_template_kwargs".into(), Value::Object(kwargs.clone()));
        }
        Value::Object(body)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::{Image, ImageFormat};

    /// Pretty JSON with keys sorted at every level, whether or not another crate in the build
    /// turns on serde_json's `preserve_order` (feature unification would otherwise change the
    /// snapshot with the set of crates built).
    fn pretty(body: &Value) -> String {
        fn sorted(v: &Value) -> Value {
            match v {
                Value::Object(map) => {
                    let mut keys: Vec<&String> = map.keys().collect();
                    keys.sort();
                    Value::Object(keys.into_iter().map(|k| (k.clone(), sorted(&map[k]))).collect())
                }
                Value::Array(items) => Value::Array(items.iter().map(sorted).collect()),
                other => other.clone(),
            }
        }
        serde_json::to_string_pretty(&sorted(body)).expect("serialises")
    }

    fn request() -> ChatRequest {
        let image = Image::encode_rgb8(ImageFormat::Png, 1, 1, &[255, 255, 255]).unwrap();
        ChatRequest::new(vec![
            Message::system("You choose the next skill."),
            Message::user("Goal: a clean mug in the coffee machine. Skills: Goto(countertop 1), Open(fridge 1), Done.").with_image(image),
        ])
        .with_sampling(Sampling { temperature: Some(0.7), top_p: Some(0.8), top_k: Some(20), max_tokens: Some(256), seed: Some(7) })
        .with_json_schema(json!({
            "type": "object",
            "properties": { "skill": { "enum": ["Goto(countertop 1)", "Open(fridge 1)", "Done"] } },
            "required": ["skill"],
        }))
        .with_thinking(false)
    }

    #[test]
    fn body_with_schema() {
        insta::assert_snapshot!(pretty(&request().body("qwen3-vl-4b", JsonMode::Schema)));
    }

    #[test]
    fn body_with_json_object() {
        insta::assert_snapshot!(pretty(&request().body("qwen3-vl-4b", JsonMode::Object)));
    }

    #[test]
    fn body_of_plain_text() {
        let plain = ChatRequest::new(vec![Message::user("Say hi.")]).with_sampling(Sampling::greedy(8));
        insta::assert_snapshot!(pretty(&plain.body("smollm2", JsonMode::Schema)));
        // Without a schema, no `response_format` whatever the mode.
        assert_eq!(plain.body("smollm2", JsonMode::Schema), plain.body("smollm2", JsonMode::Text));
    }

    #[test]
    fn modes_weaken_to_text() {
        assert_eq!(JsonMode::Schema.weaker(), Some(JsonMode::Object));
        assert_eq!(JsonMode::Object.weaker(), Some(JsonMode::Text));
        assert_eq!(JsonMode::Text.weaker(), None);
    }
}
