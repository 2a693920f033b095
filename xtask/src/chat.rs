//! `cargo xtask chat`: one chat turn with a local model (SmolLM2 or any GGUF file, replies
//! decoded under the JSON schema) or a served one (`openai:URL`, any OpenAI-compatible
//! `/v1/chat/completions`, with images). Prints the reply, the parsed JSON and the usage.
//!
//! Exit codes, as every command's: 0 a reply; 1 a reply that is no answer (no valid JSON after
//! the repair turn); 2 bad input (an unreadable or non-PNG/JPEG image, a schema file that is
//! not a JSON schema, a bad URL, a missing API key); 3 the model failed (a server still
//! unreachable or failing after its retries, a reply that is not a chat completion), with the
//! typed error.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use lm::{LocalChat, LocalModel};
use serde_json::{Value, json};
use vlm_client::{
    ChatClient, ChatError, ChatErrorKind, ChatModel, ChatRequest, Image, Message, Sampling, Usage, chat_json, check_schema, first_object,
};

use crate::input::InputError;

#[derive(Debug, clap::Args)]
pub struct ChatArgs {
    /// `smollm2` (the fetched default, run here), a path to a GGUF file, or `openai:URL` (a
    /// server's base URL, e.g. `openai:http://127.0.0.1:8080/v1`).
    #[arg(long, default_value = "smollm2")]
    model: String,
    /// The model name an `openai:` server serves.
    #[arg(long, default_value = "default")]
    served_model: String,
    /// The user message.
    #[arg(long)]
    prompt: String,
    /// A system message before it.
    #[arg(long)]
    system: Option<String>,
    /// A PNG or JPEG image sent with the prompt (repeatable; served models only).
    #[arg(long)]
    image: Vec<PathBuf>,
    /// A JSON schema file: the reply must be a JSON object satisfying it.
    #[arg(long)]
    schema: Option<PathBuf>,
    /// Reply length at most, in tokens (at least 1).
    #[arg(long, default_value_t = 256, value_parser = crate::input::at_least_one::<u32>)]
    max_tokens: u32,
    /// Sampling temperature, in [0, 1e6] (0: greedy) [default: greedy here, the server's
    /// default there].
    #[arg(long, value_parser = crate::input::number_in(0.0, false, 1e6))]
    temperature: Option<f64>,
    /// Nucleus sampling, in (0, 1]: sample among the most likely tokens that together hold
    /// this much probability [default: all, here; the server's default there].
    #[arg(long, value_parser = crate::input::number_in(0.0, true, 1.0))]
    top_p: Option<f64>,
    /// Sample among this many most likely tokens [default: all, here; the server's default there].
    #[arg(long)]
    top_k: Option<u32>,
    /// Seed of the sampler (a sampled reply is the same for the same seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Qwen3's thinking mode (`chat_template_kwargs.enable_thinking`).
    #[arg(long)]
    thinking: Option<bool>,
    /// The environment variable holding the server's API key.
    #[arg(long)]
    api_key_env: Option<String>,
    /// Seconds one attempt may take (DNS, connect, request and reply).
    #[arg(long, default_value_t = 120.0, value_parser = crate::input::positive_seconds)]
    timeout: f64,
    /// Further attempts after a transient failure.
    #[arg(long, default_value_t = 3)]
    retries: u32,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

fn read_image(path: &Path) -> anyhow::Result<Image> {
    let bytes = std::fs::read(path).map_err(|e| InputError(format!("{}: cannot read: {e}", path.display())))?;
    Image::from_bytes(bytes).map_err(|e| InputError(format!("{}: {e}", path.display())).into())
}

fn read_schema(path: &Path) -> anyhow::Result<Value> {
    let text = crate::input::read_text(path)?;
    let schema: Value = serde_json::from_str(&text).map_err(|e| InputError(format!("{}: not JSON: {e}", path.display())))?;
    check_schema(&schema).map_err(|e| InputError(format!("{}: not a usable JSON schema: {e}", path.display())))?;
    Ok(schema)
}

/// Errors the user can fix by changing the command (exit 2), as opposed to a failing model.
fn is_bad_input(error: &ChatError) -> bool {
    matches!(error.kind, ChatErrorKind::BadInput(_) | ChatErrorKind::BadUrl(_) | ChatErrorKind::MissingApiKey(_))
}

fn model_for(args: &ChatArgs) -> anyhow::Result<Box<dyn ChatModel>> {
    if let Some(url) = args.model.strip_prefix("openai:") {
        // `chat`'s own names for the server options of the other commands.
        let server = crate::model_spec::ServerArgs {
            api_key_env: args.api_key_env.clone(),
            server_timeout: Some(args.timeout),
            server_retries: Some(args.retries),
        };
        let config = server.chat_config(url, &args.served_model, crate::model_spec::Request::Chat);
        return Ok(Box::new(ChatClient::new(config).map_err(|e| InputError(e.to_string()))?));
    }
    // A local model asks no server: these would be passed over.
    let given: Vec<String> =
        ["api_key_env", "timeout", "retries"].into_iter().filter(|id| crate::input::typed(id)).map(crate::input::option_name).collect();
    if let Some(error) = crate::input::settings_of(&given, "a served model (--model openai:URL)") {
        return Err(error.into());
    }
    let path = crate::lm::resolve_model(&args.model)?;
    let model = LocalModel::load(&path).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
    let name = path.file_name().map_or_else(|| args.model.clone(), |n| n.to_string_lossy().into_owned());
    Ok(Box::new(LocalChat::new(model, &name).map_err(|e| InputError(format!("{}: {e}", path.display())))?))
}

fn usage_json(usage: &Usage) -> Value {
    json!({
        "requests": usage.requests,
        "prompt_tokens": usage.prompt_tokens,
        "completion_tokens": usage.completion_tokens,
        "reasoning_tokens": usage.reasoning_tokens,
        "images": usage.images,
    })
}

pub fn run(args: ChatArgs) -> anyhow::Result<ExitCode> {
    let mut user = Message::user(args.prompt.clone());
    for path in &args.image {
        user = user.with_image(read_image(path)?);
    }
    let schema = args.schema.as_deref().map(read_schema).transpose()?;
    let mut messages = Vec::new();
    if let Some(system) = &args.system {
        messages.push(Message::system(system.clone()));
    }
    messages.push(user);
    let mut request = ChatRequest::new(messages).with_sampling(Sampling {
        temperature: args.temperature,
        top_p: args.top_p,
        top_k: args.top_k,
        max_tokens: Some(args.max_tokens),
        seed: args.seed,
    });
    if let Some(schema) = schema {
        request = request.with_json_schema(schema);
    }
    if let Some(thinking) = args.thinking {
        request = request.with_thinking(thinking);
    }
    let mut model = model_for(&args)?;
    let start = Instant::now();
    let outcome = if request.json_schema.is_some() {
        chat_json(model.as_mut(), &request).map(|r| (r.reply, Some(r.value), r.repaired, r.usage))
    } else {
        model.chat(&request).map(|reply| {
            let parsed = first_object(&reply.text).ok();
            let usage = reply.usage;
            (reply, parsed, false, usage)
        })
    };
    let seconds = start.elapsed().as_secs_f64();
    let (reply, parsed, repaired, usage) = match outcome {
        Ok(outcome) => outcome,
        Err(error) if is_bad_input(&error) => return Err(InputError(error.to_string()).into()),
        Err(error) => {
            if args.json {
                println!(
                    "{}",
                    json!({ "model": args.model, "error": error.to_string(), "attempts": error.attempts, "elapsed_s": error.elapsed.as_secs_f64() })
                );
            }
            eprintln!("error: {error}");
            let answered = matches!(error.kind, ChatErrorKind::InvalidJson { .. });
            return Ok(ExitCode::from(if answered { 1 } else { 3 }));
        }
    };
    if args.json {
        let summary = json!({
            "model": args.model,
            "reply": reply.text,
            "reasoning": reply.reasoning,
            "json": parsed,
            "repaired": repaired,
            "finish_reason": reply.finish_reason,
            "attempts": reply.attempts,
            "usage": usage_json(&usage),
            "seconds": seconds,
        });
        println!("{}", serde_json::to_string(&summary).context("serialising the summary")?);
    } else {
        println!("{}", reply.text);
        if let Some(value) = &parsed {
            println!("json: {value}");
        }
        println!(
            "usage: {} prompt + {} completion tokens{}, {} image(s), {} request(s), {seconds:.2} s",
            usage.prompt_tokens,
            usage.completion_tokens,
            usage.reasoning_tokens.map(|r| format!(" ({r} reasoning)")).unwrap_or_default(),
            usage.images,
            usage.requests
        );
    }
    Ok(ExitCode::SUCCESS)
}
