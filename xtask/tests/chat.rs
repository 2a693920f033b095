//! `cargo xtask chat`: a local model's reply decoded under a JSON schema, a served model's
//! reply over loopback, and the exit codes: 2 for bad input (an unreadable or non-image file,
//! a schema that is not one, a sampling option out of its range), 3 for a server that still
//! fails after its retries. And `cargo xtask generate` at the edge of the model's context.

mod common;

use std::io::{Read, Write};
use std::net::TcpListener;
use std::process::Output;

use common::{scratch_dir, xtask};

use serde_json::{Value, json};
use tempfile::TempDir;
use vlm_client::{Image, ImageFormat};

fn scratch(dir: &TempDir, name: &str, bytes: &[u8]) -> String {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("write");
    path.display().to_string()
}

fn skill_schema(dir: &TempDir) -> String {
    let schema = json!({
        "type": "object",
        "properties": { "skill": { "enum": ["Goto(fridge 1)", "Open(fridge 1)", "Done"] } },
        "required": ["skill"],
        "additionalProperties": false
    });
    scratch(dir, "skill.schema.json", schema.to_string().as_bytes())
}

fn stdout_json(output: &Output) -> Value {
    serde_json::from_str(String::from_utf8_lossy(&output.stdout).trim()).expect("one JSON object")
}

#[test]
fn a_local_model_replies_with_schema_valid_json() {
    let tmp = scratch_dir("xtask-chat-");
    // The tiny model's weights are random: only the schema makes its reply JSON.
    let model = tmp.path().join("tiny.gguf");
    lm::tiny::write_tiny_gguf(&model, &lm::tiny::TinySpec::default()).expect("tiny model");
    let output = xtask(&[
        "chat",
        "--model",
        &model.display().to_string(),
        "--prompt",
        "Which skill next?",
        "--schema",
        &skill_schema(&tmp),
        "--json",
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let summary = stdout_json(&output);
    let skill = summary["json"]["skill"].as_str().expect("a skill");
    assert!(["Goto(fridge 1)", "Open(fridge 1)", "Done"].contains(&skill), "{summary}");
    assert_eq!(summary["json"], serde_json::from_str::<Value>(summary["reply"].as_str().expect("text")).expect("the reply is the JSON"));
    assert_eq!(summary["repaired"], false);
    assert!(summary["usage"]["prompt_tokens"].as_u64().expect("count") > 0);

    // A local model reads text only.
    let pixel = Image::encode_rgb8(ImageFormat::Png, 1, 1, &[200, 30, 30]).expect("png");
    let image = scratch(&tmp, "pixel.png", pixel.bytes());
    let output = xtask(&["chat", "--model", &model.display().to_string(), "--prompt", "What is this?", "--image", &image]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("text only"), "{}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn a_served_model_gets_the_image_and_its_reply_is_printed() {
    let tmp = scratch_dir("xtask-chat-");
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = listener.local_addr().expect("address");
    let server = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().expect("accept");
        let mut buffer = Vec::new();
        let mut chunk = [0u8; 65536];
        let body_start = loop {
            let n = stream.read(&mut chunk).expect("read");
            assert!(n > 0, "the client closed early");
            buffer.extend_from_slice(&chunk[..n]);
            if let Some(end) = buffer.windows(4).position(|w| w == b"\r\n\r\n") {
                break end + 4;
            }
        };
        let head = String::from_utf8_lossy(&buffer[..body_start]).to_ascii_lowercase();
        let length: usize = head.lines().find_map(|l| l.strip_prefix("content-length:")).expect("length").trim().parse().expect("number");
        while buffer.len() < body_start + length {
            let n = stream.read(&mut chunk).expect("read");
            buffer.extend_from_slice(&chunk[..n]);
        }
        let request: Value = serde_json::from_slice(&buffer[body_start..body_start + length]).expect("JSON");
        let reply = json!({
            "choices": [{ "message": { "role": "assistant", "content": "{\"skill\": \"Open(fridge 1)\"}" }, "finish_reason": "stop" }],
            "usage": { "prompt_tokens": 90, "completion_tokens": 9 }
        })
        .to_string();
        let response = format!(
            "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{reply}",
            reply.len()
        );
        stream.write_all(response.as_bytes()).expect("write");
        request
    });
    let photo = Image::encode_rgb8(ImageFormat::Jpeg, 2, 1, &[10, 20, 30, 40, 50, 60]).expect("jpeg");
    let image = scratch(&tmp, "photo.jpg", photo.bytes());
    let url = format!("openai:http://{address}/v1");
    let output = xtask(&[
        "chat",
        "--model",
        &url,
        "--served-model",
        "qwen3-vl",
        "--prompt",
        "Next?",
        "--image",
        &image,
        "--schema",
        &skill_schema(&tmp),
        "--json",
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let summary = stdout_json(&output);
    assert_eq!(summary["json"], json!({ "skill": "Open(fridge 1)" }));
    assert_eq!(
        summary["usage"],
        json!({ "requests": 1, "prompt_tokens": 90, "completion_tokens": 9, "reasoning_tokens": null, "images": 1 })
    );
    let request = server.join().expect("server");
    assert_eq!(request["model"], "qwen3-vl");
    assert_eq!(request["messages"][0]["content"][1]["image_url"]["url"], photo.data_url());
    assert_eq!(request["response_format"]["json_schema"]["schema"]["required"], json!(["skill"]));
}

/// A server on loopback that answers one chat request with a plain reply, then stops.
fn one_reply_server() -> String {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = listener.local_addr().expect("address");
    std::thread::spawn(move || {
        let Ok((mut stream, _)) = listener.accept() else { return };
        let mut buffer = Vec::new();
        let mut chunk = [0u8; 65536];
        while !buffer.windows(4).any(|w| w == b"\r\n\r\n") {
            match stream.read(&mut chunk) {
                Ok(n) if n > 0 => buffer.extend_from_slice(&chunk[..n]),
                _ => return,
            }
        }
        let reply = json!({ "choices": [{ "message": { "role": "assistant", "content": "hello" }, "finish_reason": "stop" }] }).to_string();
        let response = format!(
            "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{reply}",
            reply.len()
        );
        stream.write_all(response.as_bytes()).ok();
    });
    format!("openai:http://{address}/v1")
}

/// The proxy is chosen per scheme and host as curl chooses it: an HTTPS proxy does not carry a
/// plain-HTTP server's requests (ureq sent them there), `NO_PROXY` takes address ranges, a
/// failure through a proxy names it and its variable (it read as the server's), and a value
/// that is no proxy URL is bad input naming the variable.
#[test]
fn proxies_are_chosen_per_scheme_and_named_in_failures() {
    // A port nothing listens on any more: a proxy there refuses every connection.
    let closed = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("address").port();
    let dead = format!("http://127.0.0.1:{closed}");
    let chat = |url: &str, vars: &[(&str, &str)]| {
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_xtask"));
        command.args(["chat", "--model", url, "--prompt", "x", "--retries", "0"]);
        command.current_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".."));
        for name in ["http_proxy", "HTTP_PROXY", "https_proxy", "HTTPS_PROXY", "all_proxy", "ALL_PROXY", "no_proxy", "NO_PROXY"] {
            command.env_remove(name);
        }
        command.envs(vars.iter().copied());
        let output = command.output().expect("xtask runs");
        (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    let (code, stderr) = chat(&one_reply_server(), &[("HTTPS_PROXY", &dead)]);
    assert_eq!(code, Some(0), "not through the HTTPS proxy: {stderr}");
    let (code, stderr) = chat(&one_reply_server(), &[("HTTP_PROXY", &dead), ("NO_PROXY", "10.0.0.0/8,127.0.0.0/8")]);
    assert_eq!(code, Some(0), "NO_PROXY's range holds the server: {stderr}");
    let (code, stderr) = chat(&one_reply_server(), &[("HTTP_PROXY", &dead)]);
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.contains(&format!("(through the proxy {dead} from HTTP_PROXY)")), "{stderr}");
    let (code, stderr) = chat(&one_reply_server(), &[("http_proxy", "::::")]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("http_proxy=http://::::: not a proxy this client can use"), "{stderr}");
}

#[test]
fn bad_input_exits_2_and_a_failing_server_exits_3() {
    let tmp = scratch_dir("xtask-chat-");
    // A port nothing listens on any more.
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("address").port();
    let url = &format!("openai:http://127.0.0.1:{port}/v1");
    let check = |args: &[&str], code: i32, message: &str| {
        let output = xtask(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: `{stderr}` should mention `{message}`");
    };
    let missing = tmp.path().join("missing.png").display().to_string();
    check(&["chat", "--model", url, "--prompt", "x", "--image", &missing], 2, "cannot read");
    let gif = scratch(&tmp, "anim.gif", b"GIF89a....");
    check(&["chat", "--model", url, "--prompt", "x", "--image", &gif], 2, "not a PNG or JPEG image");
    let whole = Image::encode_rgb8(ImageFormat::Png, 4, 4, &[90; 48]).expect("png");
    let cut = scratch(&tmp, "cut.png", &whole.bytes()[..whole.bytes().len() / 2]);
    check(&["chat", "--model", url, "--prompt", "x", "--image", &cut], 2, "a PNG image that does not decode");
    let not_json = scratch(&tmp, "bad.schema.json", b"{ type: object }");
    check(&["chat", "--model", url, "--prompt", "x", "--schema", &not_json], 2, "not JSON");
    let bad_type = scratch(&tmp, "type.schema.json", br#"{"type": "dict"}"#);
    check(&["chat", "--model", url, "--prompt", "x", "--schema", &bad_type], 2, "unknown type \"dict\"");
    check(&["chat", "--model", "openai:ftp://host/v1", "--prompt", "x"], 2, "bad URL");
    check(&["chat", "--model", url, "--prompt", "x", "--api-key-env", "XTASK_CHAT_TEST_NO_SUCH_KEY"], 2, "XTASK_CHAT_TEST_NO_SUCH_KEY");
    // A local model asks no server: its options would be passed over.
    let model = tmp.path().join("tiny.gguf");
    lm::tiny::write_tiny_gguf(&model, &lm::tiny::TinySpec::default()).expect("tiny model");
    let local = model.display().to_string();
    check(
        &["chat", "--model", &local, "--prompt", "x", "--timeout", "5", "--retries", "1"],
        2,
        "--timeout, --retries are settings of a served model",
    );
    // Credentials in the URL would be printed and kept: refused, and not printed.
    let output = xtask(&["chat", "--model", "openai:http://user:secret@127.0.0.1:9/v1", "--prompt", "x"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("a URL with credentials") && !stderr.contains("secret"), "{stderr}");
    // Sampling options out of their range are refused before any request (NaN reached a local
    // model as garbage and a server as `null`, its own default).
    for (option, value) in [("--temperature", "NaN"), ("--temperature", "-1"), ("--temperature", "inf"), ("--top-p", "0"), ("--top-p", "2")]
    {
        check(&["chat", "--model", url, "--prompt", "x", &format!("{option}={value}")], 2, option);
    }
    check(&["chat", "--model", url, "--prompt", "x", "--max-tokens", "0"], 2, "--max-tokens");
    // Connection refused on every attempt.
    check(&["chat", "--model", url, "--prompt", "x", "--retries", "1", "--timeout", "5"], 3, "cannot connect");
}

/// `generate`: a prompt that fills the tiny model's context (256 tokens) is bad input, exit 2,
/// naming `--prompt` (it was exit 3, "a failure outside the input"); one that nearly fills it
/// generates up to the context's end and says so.
#[test]
fn generate_stops_at_the_context_and_refuses_a_prompt_that_fills_it() {
    let tmp = scratch_dir("xtask-generate-");
    let model = tmp.path().join("tiny.gguf");
    lm::tiny::write_tiny_gguf(&model, &lm::tiny::TinySpec::default()).expect("tiny model");
    let model = model.display().to_string();
    let long = "a ".repeat(400);
    let output = xtask(&["generate", "--model", &model, "--raw", "--prompt", &long, "--max-tokens", "4"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--prompt") && stderr.contains("context of 256"), "{stderr}");
    // The tiny tokenizer spells "a " as one token or two: find a prompt a few tokens short.
    let output = xtask(&["generate", "--model", &model, "--raw", "--prompt", &"a ".repeat(120), "--max-tokens", "1", "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let per_copy = stdout_json(&output)["prompt_tokens"].as_u64().expect("a count") as f64 / 120.0;
    let copies = ((250.0 / per_copy) as usize).min(255);
    let output = xtask(&["generate", "--model", &model, "--raw", "--prompt", &"a ".repeat(copies), "--max-tokens", "200", "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let summary = stdout_json(&output);
    let (prompt, generated) = (summary["prompt_tokens"].as_u64().expect("count"), summary["generated_tokens"].as_u64().expect("count"));
    assert!(prompt < 256, "{summary}");
    // The tiny model's weights are fixed (seed 7): it writes no stop token before the end.
    assert_eq!(summary["stopped"], "context_length", "{summary}");
    assert_eq!(prompt + generated, 257, "up to the context, the last token from its full length: {summary}");
}
