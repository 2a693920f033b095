//! A model as the command line names it, parsed once: `uniform` (every allowed token equally
//! likely), `systematic` (Phase I's fixed sweep, no model), `smollm2` (the cached default
//! GGUF), `openai:URL` (a served model), or a path to a GGUF file. Each option states which of
//! these it takes (`--lm`: a language model; `--explorer`: a Phase I policy; `--chat-planner`:
//! a chat model), and a name it does not take is bad input when the command line is read. A
//! spec serialises as the text it was parsed from, so record configurations keep their hashes.

use std::path::PathBuf;

/// A model named on the command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ModelSpec {
    Uniform,
    Systematic,
    Smollm2,
    /// `openai:URL`: the URL of an OpenAI-compatible server (`http://` or `https://`).
    OpenAi(String),
    Gguf(PathBuf),
}

impl std::fmt::Display for ModelSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ModelSpec::Uniform => f.write_str("uniform"),
            ModelSpec::Systematic => f.write_str("systematic"),
            ModelSpec::Smollm2 => f.write_str("smollm2"),
            ModelSpec::OpenAi(url) => write!(f, "openai:{url}"),
            ModelSpec::Gguf(path) => write!(f, "{}", path.display()),
        }
    }
}

impl serde::Serialize for ModelSpec {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl ModelSpec {
    /// Any spec: the names, `openai:` with an http(s) URL, or a `.gguf` path.
    fn parse(text: &str) -> Result<ModelSpec, String> {
        let text = text.trim();
        Ok(match text {
            "uniform" => ModelSpec::Uniform,
            "systematic" => ModelSpec::Systematic,
            "smollm2" => ModelSpec::Smollm2,
            _ => {
                if let Some(url) = text.strip_prefix("openai:") {
                    if !(url.starts_with("http://") || url.starts_with("https://")) {
                        return Err(format!("`{text}`: give the server as openai:http://HOST:PORT/v1"));
                    }
                    // The whole URL, as the client will take it: a bad one is this option's
                    // bad input, not a server that cannot be asked.
                    vlm_client::transport::check_url(url).map_err(|e| e.to_string())?;
                    ModelSpec::OpenAi(url.to_string())
                } else if text.ends_with(".gguf") {
                    ModelSpec::Gguf(PathBuf::from(text))
                } else {
                    return Err(format!("`{text}`: not a model name (uniform, systematic, smollm2), openai:URL or a .gguf path"));
                }
            }
        })
    }

    /// The served model's URL, for `openai:URL`.
    pub fn url(&self) -> Option<&str> {
        match self {
            ModelSpec::OpenAi(url) => Some(url),
            _ => None,
        }
    }

    /// A short name for file names: `openai` for a server (a URL's last segment names
    /// nothing; the configuration's hash tells servers apart), a GGUF file's stem, else the name.
    pub fn short_name(&self) -> String {
        match self {
            ModelSpec::OpenAi(_) => "openai".into(),
            ModelSpec::Gguf(path) => path.file_stem().map_or_else(|| self.to_string(), |s| s.to_string_lossy().into_owned()),
            other => other.to_string(),
        }
    }
}

fn taking(text: &str, allowed: &[fn(&ModelSpec) -> bool], what: &str) -> Result<ModelSpec, String> {
    let spec = ModelSpec::parse(text)?;
    if allowed.iter().any(|ok| ok(&spec)) { Ok(spec) } else { Err(format!("`{text}` is not {what}")) }
}

/// `--lm`: uniform, smollm2, openai:URL or a GGUF path.
pub fn language_model(text: &str) -> Result<ModelSpec, String> {
    taking(text, &[|s| !matches!(s, ModelSpec::Systematic)], "a language model (uniform, smollm2, openai:URL, a .gguf path)")
}

/// `--explorer`: systematic, smollm2, openai:URL or a GGUF path.
pub fn explorer(text: &str) -> Result<ModelSpec, String> {
    taking(text, &[|s| !matches!(s, ModelSpec::Uniform)], "a Phase I policy (systematic, smollm2, openai:URL, a .gguf path)")
}

/// `--chat-planner`: smollm2, openai:URL or a GGUF path.
pub fn chat_model(text: &str) -> Result<ModelSpec, String> {
    taking(text, &[|s| !matches!(s, ModelSpec::Uniform | ModelSpec::Systematic)], "a chat model (smollm2, openai:URL, a .gguf path)")
}

/// How a run talks to its served models (`openai:URL`, whichever options name them): the API
/// key's variable, how long one request may take, how often a failed one is tried again. Not
/// part of a run's configuration, and not serialised: a request that still fails past them
/// stops the run (exit 3) and records nothing, so they change when a run gives up, never what
/// it records.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ServerArgs {
    /// The environment variable holding the served models' API key, sent as a bearer token
    /// (`vllm serve --api-key`, a hosted endpoint) [default: no key].
    #[arg(long, value_name = "VARIABLE")]
    pub api_key_env: Option<String>,
    /// Seconds one request to a served model may take: connect, send and the whole reply
    /// [default: 60 for `--lm`'s one-token completions, 120 for a chat reply, 1800 for a thinking
    /// `--chat-planner`'s (up to 32,768 tokens), 30 for the model list].
    #[arg(long, value_name = "SECONDS", value_parser = crate::input::positive_seconds)]
    pub server_timeout: Option<f64>,
    /// Further attempts after a transient failure (no connection, a timeout, 408, 429, 5xx)
    /// [default: 2 for `--lm`'s completions, 3 otherwise].
    #[arg(long, value_name = "N")]
    pub server_retries: Option<u32>,
}

/// The kinds of request a run makes of a server, each with its own default deadline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// `/completions`, one token with its top logprobs (Phase II's `--lm`).
    Completion,
    /// `/chat/completions`: a Phase I decision, a direct agent's turn, a greedy chat plan.
    Chat,
    /// `/chat/completions` with thinking on: up to 32,768 tokens in one reply.
    ThinkingChat,
    /// `/models`, asked once per server for the run's configuration.
    ModelList,
}

impl ServerArgs {
    /// The options given, `--server-timeout` style, for a check that they are not passed over.
    pub fn given() -> Vec<String> {
        crate::input::given::<ServerArgs>(&[])
    }

    /// Refuses these options where no model of the run is served (they would be passed over).
    pub fn check(models: &[&ModelSpec]) -> Result<(), crate::input::InputError> {
        if models.iter().any(|m| m.url().is_some()) {
            return Ok(());
        }
        crate::input::settings_of(&Self::given(), "a served model (openai:URL), and the run names none").map_or(Ok(()), Err)
    }

    /// The deadline and retries of `request`: the defaults above where not given.
    pub fn policy(&self, request: Request) -> vlm_client::RetryPolicy {
        let (seconds, retries) = match request {
            Request::Completion => (60.0, 2),
            Request::Chat => (120.0, 3),
            Request::ThinkingChat => (1800.0, 3),
            Request::ModelList => (30.0, 3),
        };
        vlm_client::RetryPolicy {
            timeout: std::time::Duration::from_secs_f64(self.server_timeout.unwrap_or(seconds)),
            max_retries: self.server_retries.unwrap_or(retries),
            ..vlm_client::RetryPolicy::default()
        }
    }

    /// The API key, read from `--api-key-env`'s variable; bad input where it is not set, empty,
    /// or holds what a header cannot carry ([`vlm_client::api_key_from_env`]).
    pub fn api_key(&self) -> Result<Option<String>, crate::input::InputError> {
        self.api_key_env
            .as_ref()
            .map(|name| {
                vlm_client::api_key_from_env(name).map_err(|kind| {
                    let why = match kind {
                        vlm_client::ChatErrorKind::BadInput(why) => why,
                        other => other.to_string(),
                    };
                    crate::input::InputError(format!("--api-key-env {name}: {why}"))
                })
            })
            .transpose()
    }

    /// A chat client's settings for `model` at `url`, for `request`.
    pub fn chat_config(&self, url: &str, model: &str, request: Request) -> vlm_client::ClientConfig {
        let mut config = vlm_client::ClientConfig::new(url, model);
        config.api_key_env.clone_from(&self.api_key_env);
        config.retry = self.policy(request);
        config
    }
}

/// What the server at `url` serves when asked for `name`, by its model list
/// ([`vlm_client::served_models`]): the entry named `name`; the only entry, where the server
/// lists one and `name` is not it (llama.cpp's server answers to any name with the file it
/// loaded); else every id listed (`{"listed": [...]}`); `"unlisted"` where the server has no
/// list. A server that cannot be reached is an error: the run cannot say what it would record.
/// Asked once per process for each URL and name.
pub fn served_identity(url: &str, name: &str, server: &ServerArgs) -> anyhow::Result<serde_json::Value> {
    use serde_json::json;
    use std::collections::BTreeMap;
    use std::sync::{Mutex, OnceLock};
    static ASKED: OnceLock<Mutex<BTreeMap<(String, String), serde_json::Value>>> = OnceLock::new();
    let key = (url.to_string(), name.to_string());
    if let Some(known) = ASKED.get_or_init(Default::default).lock().expect("not poisoned").get(&key) {
        return Ok(known.clone());
    }
    let key_text = server.api_key()?;
    let listed = vlm_client::served_models(url, key_text.as_deref(), &server.policy(Request::ModelList)).map_err(|e| -> anyhow::Error {
        // A URL or proxy setting the client refuses before any request is the command's input.
        match e.kind {
            vlm_client::ChatErrorKind::BadUrl(why) => crate::input::InputError(format!("{url}: bad URL: {why}")).into(),
            _ => anyhow::anyhow!("cannot ask {url} which model it serves: {e}"),
        }
    })?;
    let entry = |m: &vlm_client::ServedModel| {
        let mut entry = json!({ "id": m.id });
        for (key, value) in [("root", &m.root), ("owned_by", &m.owned_by)] {
            if let Some(value) = value {
                entry[key] = json!(value);
            }
        }
        entry
    };
    let identity = match listed {
        None => json!("unlisted"),
        Some(models) => match models.iter().find(|m| m.id == name) {
            Some(model) => entry(model),
            None if models.len() == 1 => entry(&models[0]),
            None => {
                let mut ids: Vec<&str> = models.iter().map(|m| m.id.as_str()).collect();
                ids.sort_unstable();
                json!({ "listed": ids })
            }
        },
    };
    ASKED.get_or_init(Default::default).lock().expect("not poisoned").insert(key, identity.clone());
    Ok(identity)
}

/// The `served` entry of a run's configuration: for each served model among `models` (a spec
/// and the name it is asked by), what its server serves ([`served_identity`]), keyed
/// `URL served-model:NAME` (the chat cache's identity of a served model); `None`
/// where the run asks no server, so that the hashes of other runs stay as they were.
pub fn served_entry(models: &[(&ModelSpec, &str)], server: &ServerArgs) -> anyhow::Result<Option<serde_json::Value>> {
    let mut served = serde_json::Map::new();
    for (spec, name) in models {
        if let Some(url) = spec.url() {
            served.insert(format!("{url} served-model:{name}"), served_identity(url, name, server)?);
        }
    }
    Ok((!served.is_empty()).then_some(serde_json::Value::Object(served)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kind of request waits its own default; the options, where given, set every kind's.
    #[test]
    fn server_deadlines_default_per_request_and_are_set_for_all() {
        let defaults = ServerArgs::default();
        let seconds = |args: &ServerArgs, r| (args.policy(r).timeout.as_secs_f64(), args.policy(r).max_retries);
        assert_eq!(seconds(&defaults, Request::Completion), (60.0, 2));
        assert_eq!(seconds(&defaults, Request::Chat), (120.0, 3));
        assert_eq!(seconds(&defaults, Request::ThinkingChat), (1800.0, 3), "32,768 tokens of thinking in one reply");
        assert_eq!(seconds(&defaults, Request::ModelList), (30.0, 3));
        let given = ServerArgs { server_timeout: Some(7.5), server_retries: Some(0), api_key_env: None };
        for request in [Request::Completion, Request::Chat, Request::ThinkingChat, Request::ModelList] {
            assert_eq!(seconds(&given, request), (7.5, 0));
        }
        assert_eq!(given.api_key().expect("no key asked for"), None);
    }

    #[test]
    fn specs_parse_print_back_and_are_checked_per_option() {
        for text in ["uniform", "systematic", "smollm2", "openai:http://127.0.0.1:8080/v1", "models/x.gguf"] {
            assert_eq!(ModelSpec::parse(text).expect(text).to_string(), text);
        }
        assert_eq!(ModelSpec::parse("openai:http://h:1/v1").unwrap().short_name(), "openai");
        assert_eq!(ModelSpec::parse("/m/SmolLM2.Q4_1.gguf").unwrap().short_name(), "SmolLM2.Q4_1");
        assert!(ModelSpec::parse("openai:localhost:8080").is_err());
        for bad in ["openai:http://:80/v1", "openai:http://", "openai:http://a b/v1", "openai:http://h/v1?x=1", "openai:http://h:99999/v1"]
        {
            assert!(ModelSpec::parse(bad).is_err(), "{bad}");
        }
        assert!(ModelSpec::parse("gpt-9").is_err());
        assert!(language_model("systematic").is_err() && language_model("uniform").is_ok());
        assert!(explorer("uniform").is_err() && explorer("systematic").is_ok());
        assert!(chat_model("uniform").is_err() && chat_model("systematic").is_err() && chat_model("smollm2").is_ok());
        assert_eq!(serde_json::to_string(&ModelSpec::Smollm2).unwrap(), "\"smollm2\"");
    }
}
