//! The OpenAI-compatible backend against real HTTP servers on loopback, started by each test:
//! one that serves `/v1/completions` from the tiny model (vLLM-style, and plain with text
//! tokens and chunked bodies), and misbehaving ones (no answer, 500s, malformed JSON, a closed
//! connection). Each failure is a typed error after a bounded number of attempts; every server
//! handles a fixed number of connections and stops by itself.

mod common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use common::{TempDir, tiny_file};
use lm::tiny::TinySpec;
use lm::{HttpError, HttpErrorKind, LanguageModel, LmError, LocalModel, Logprobs, OpenAiConfig, OpenAiModel, ServerDialect};
use serde_json::{Value, json};

/// What a test server does with one request.
enum Reply {
    /// Status and body, with Content-Length (or chunked).
    Send { status: u16, body: String, chunked: bool },
    /// Reads until the client gives up and closes: the client's timeout must fire.
    Hang,
    /// Closes the connection without a word.
    Close,
}

/// A server on 127.0.0.1 that answers `requests` requests with `handler`, then stops. Requests
/// may share a connection (the client keeps it alive) until a reply closes it. Returns its
/// address and a handle yielding the request bodies it saw and the connections it accepted.
fn serve(requests: usize, mut handler: impl FnMut(usize, &Value) -> Reply + Send + 'static) -> (SocketAddr, JoinHandle<Served>) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind loopback");
    let address = listener.local_addr().expect("address");
    let handle = std::thread::spawn(move || {
        let mut served = Served { bodies: Vec::new(), connections: 0 };
        while served.bodies.len() < requests {
            let (mut stream, _) = listener.accept().expect("accept");
            served.connections += 1;
            // A bound on how long a broken client could hold the test.
            stream.set_read_timeout(Some(Duration::from_secs(20))).expect("timeout");
            while served.bodies.len() < requests {
                let Some(request) = read_request(&mut stream) else { break };
                let reply = handler(served.bodies.len(), &request);
                served.bodies.push(request);
                match reply {
                    Reply::Send { status, body, chunked } => {
                        let head = if chunked {
                            format!("HTTP/1.1 {status} X\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n")
                        } else {
                            format!("HTTP/1.1 {status} X\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n", body.len())
                        };
                        let mut bytes = head.into_bytes();
                        if chunked {
                            // Uneven chunks, to cross the client's read boundaries.
                            for piece in body.as_bytes().chunks(7) {
                                bytes.extend_from_slice(format!("{:x}\r\n", piece.len()).as_bytes());
                                bytes.extend_from_slice(piece);
                                bytes.extend_from_slice(b"\r\n");
                            }
                            bytes.extend_from_slice(b"0\r\n\r\n");
                        } else {
                            bytes.extend_from_slice(body.as_bytes());
                        }
                        if stream.write_all(&bytes).is_err() {
                            break;
                        }
                    }
                    Reply::Hang => {
                        let mut sink = [0u8; 64];
                        while matches!(stream.read(&mut sink), Ok(n) if n > 0) {}
                        break;
                    }
                    Reply::Close => break,
                }
            }
        }
        served
    });
    (address, handle)
}

/// What a test server saw.
#[derive(Debug)]
struct Served {
    bodies: Vec<Value>,
    connections: usize,
}

fn read_request(stream: &mut TcpStream) -> Option<Value> {
    let mut buffer = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        if let Some(end) = buffer.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&buffer[..end]).to_string();
            assert!(head.starts_with("POST /v1/completions HTTP/1.1\r\n"), "{head}");
            let length: usize = head
                .lines()
                .find_map(|l| l.to_ascii_lowercase().strip_prefix("content-length:").map(|v| v.trim().parse().expect("length")))
                .expect("Content-Length");
            while buffer.len() < end + 4 + length {
                let n = stream.read(&mut chunk).ok()?;
                if n == 0 {
                    return None;
                }
                buffer.extend_from_slice(&chunk[..n]);
            }
            return serde_json::from_slice(&buffer[end + 4..end + 4 + length]).ok();
        }
        let n = stream.read(&mut chunk).ok()?;
        if n == 0 {
            return None;
        }
        buffer.extend_from_slice(&chunk[..n]);
    }
}

/// A completions answer from the tiny model, as vLLM gives it: logprobs after masking to
/// `allowed_token_ids`, tokens named `token_id:N` when asked, else by their text.
fn model_reply(model: &mut LocalModel, request: &Value) -> String {
    let prompt: Vec<u32> = request["prompt"].as_array().expect("token prompt").iter().map(|v| v.as_u64().expect("id") as u32).collect();
    let k = request["logprobs"].as_u64().expect("logprobs") as usize;
    let Logprobs::Dense(all) = model.next_logprobs(&prompt).expect("runs") else { unreachable!() };
    let mut scored: Vec<(u32, f32)> = match request.get("allowed_token_ids").and_then(Value::as_array) {
        Some(allowed) => {
            let ids: Vec<u32> = allowed.iter().map(|v| v.as_u64().expect("id") as u32).collect();
            let prior = model.next_logprobs_among(&prompt, &ids).expect("prior");
            prior.tokens.iter().copied().zip(prior.logprobs.iter().copied()).collect()
        }
        None => all.iter().enumerate().map(|(i, &l)| (i as u32, l)).collect(),
    };
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    scored.truncate(k);
    let by_id = request.get("return_tokens_as_token_ids").and_then(Value::as_bool).unwrap_or(false);
    let name = |id: u32| {
        if by_id {
            format!("token_id:{id}")
        } else {
            String::from_utf8_lossy(model.vocabulary().token_bytes(id).expect("in range")).into_owned()
        }
    };
    let top: serde_json::Map<String, Value> = scored.iter().map(|&(id, l)| (name(id), json!(l))).collect();
    json!({
        "id": "cmpl-test",
        "object": "text_completion",
        "model": request["model"],
        "choices": [{
            "index": 0,
            "text": name(scored[0].0),
            "logprobs": { "tokens": [name(scored[0].0)], "token_logprobs": [scored[0].1], "top_logprobs": [top], "text_offset": [0] },
            "finish_reason": "length"
        }],
        "usage": { "prompt_tokens": prompt.len(), "completion_tokens": 1, "total_tokens": prompt.len() + 1 }
    })
    .to_string()
}

fn client(address: SocketAddr, dialect: ServerDialect, top_logprobs: usize, tokenizer: &LocalModel) -> OpenAiModel {
    let mut config = OpenAiConfig::new(&format!("http://{address}/v1"), "tiny");
    config.dialect = dialect;
    config.top_logprobs = top_logprobs;
    config.timeout = Duration::from_millis(500);
    config.max_retries = 2;
    config.retry_backoff = Duration::from_millis(1);
    OpenAiModel::new(config, tokenizer.shared_tokenizer().clone()).expect("client")
}

fn tiny(dir: &TempDir) -> LocalModel {
    LocalModel::load(&tiny_file(dir, "tiny.gguf", &TinySpec::default())).expect("loads")
}

fn http_error(result: Result<impl std::fmt::Debug, LmError>) -> HttpError {
    match result {
        Err(LmError::Http(error)) => error,
        other => panic!("expected an HTTP error, got {other:?}"),
    }
}

#[test]
fn vllm_style_server_gives_the_local_models_prior() {
    let dir = TempDir::new("openai-vllm");
    let mut local = tiny(&dir);
    let mut served = tiny(&dir);
    let (address, server) =
        serve(2, move |_, request| Reply::Send { status: 200, body: model_reply(&mut served, request), chunked: false });
    let mut remote = client(address, ServerDialect::Vllm, 20, &local);
    let prompt = local.encode("<|im_start|>user\n open the fridge<|im_end|>").expect("encodes");
    let allowed = [265, 261, 271, 3 + b'x' as u32];

    let prior = remote.next_logprobs_among(&prompt, &allowed).expect("served");
    let expected = local.next_logprobs_among(&prompt, &allowed).expect("local");
    assert_eq!(prior.tokens, expected.tokens);
    assert_eq!(prior.estimated, 0, "k >= |allowed|: exact");
    for (a, b) in prior.logprobs.iter().zip(&expected.logprobs) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    let sparse = remote.next_logprobs(&prompt).expect("served");
    let Logprobs::Sparse { top, vocabulary_size } = &sparse else { panic!("a served model is sparse") };
    assert_eq!((top.len(), *vocabulary_size), (20, 274));
    let Logprobs::Dense(full) = local.next_logprobs(&prompt).expect("local") else { unreachable!() };
    for &(id, l) in top {
        assert!((full[id as usize] - l).abs() < 1e-5);
    }
    assert_eq!(sparse.argmax(), Logprobs::Dense(full).argmax());
    // Repeats are answered from memory: the server handled exactly two requests, on one
    // kept-alive connection.
    remote.next_logprobs_among(&prompt, &allowed).expect("cached");
    let usage = remote.usage();
    assert_eq!((usage.forward_calls, usage.cache_hits, usage.tokens_generated), (2, 1, 3));
    assert_eq!(usage.tokens_prefilled, 2 * prompt.len() as u64);
    let served = server.join().expect("server");
    assert_eq!(served.connections, 1, "keep-alive");
    let requests = served.bodies;
    assert_eq!(requests[0]["allowed_token_ids"], json!(allowed));
    assert_eq!(requests[0]["max_tokens"], json!(1));
    assert_eq!(requests[0]["logprobs"], json!(4));
    assert_eq!(requests[1]["logprobs"], json!(20));
}

#[test]
fn plain_server_with_text_tokens_and_chunked_bodies_is_renormalised_here() {
    let dir = TempDir::new("openai-generic");
    let mut local = tiny(&dir);
    let mut served = tiny(&dir);
    let (address, server) = serve(1, move |_, request| Reply::Send { status: 200, body: model_reply(&mut served, request), chunked: true });
    let mut remote = client(address, ServerDialect::Generic, 5, &local);
    let prompt = local.encode(" open the").expect("encodes");
    let Logprobs::Dense(full) = local.next_logprobs(&prompt).expect("local") else { unreachable!() };
    let mut order: Vec<u32> = (0..full.len() as u32).collect();
    order.sort_by(|&a, &b| full[b as usize].total_cmp(&full[a as usize]));
    // Tokens named by text must be valid UTF-8 to be named at all (a lone byte of a character
    // is not): take the two likeliest nameable tokens of the server's top 5.
    let nameable: Vec<u32> =
        order[..5].iter().copied().filter(|&t| std::str::from_utf8(local.vocabulary().token_bytes(t).expect("in range")).is_ok()).collect();
    assert!(nameable.len() >= 2, "the tiny model's top 5 has two text tokens");
    let (first, second, outside) = (nameable[0], nameable[1], order[100]);
    let prior = remote.next_logprobs_among(&prompt, &[first, second, outside]).expect("served");
    assert_eq!(prior.estimated, 1, "the third token is outside the top 5");
    let p = prior.probabilities();
    let exact_ratio = (full[first as usize] - full[second as usize]).exp();
    assert!((p[0] / p[1] - exact_ratio).abs() < 1e-3 * exact_ratio, "listed tokens keep their exact ratio");
    assert!(p[2] <= p[1], "an unlisted token is never likelier than a listed one");
    assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    let requests = server.join().expect("server").bodies;
    assert!(requests[0].get("allowed_token_ids").is_none());
    assert!(requests[0].get("return_tokens_as_token_ids").is_none());
}

#[test]
fn a_server_that_never_answers_times_out_after_bounded_retries() {
    let dir = TempDir::new("openai-timeout");
    let local = tiny(&dir);
    let (address, server) = serve(3, |_, _| Reply::Hang);
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    let error = http_error(remote.next_logprobs(&[5, 6]));
    assert_eq!(error.kind, HttpErrorKind::Timeout(Duration::from_millis(500)));
    assert_eq!(error.attempts, 3);
    assert_eq!(server.join().expect("server").bodies.len(), 3);
    assert_eq!(remote.usage().forward_calls, 3);
}

#[test]
fn server_errors_are_retried_then_reported_with_the_status() {
    let dir = TempDir::new("openai-500");
    let local = tiny(&dir);
    let (address, server) = serve(3, |_, _| Reply::Send { status: 500, body: "{\"error\": \"overloaded\"}".into(), chunked: false });
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    let error = http_error(remote.next_logprobs(&[5]));
    assert!(matches!(&error.kind, HttpErrorKind::Status { status: 500, body, .. } if body.contains("overloaded")), "{error}");
    assert_eq!(error.attempts, 3);
    assert_eq!(server.join().expect("server").bodies.len(), 3);
    assert!(error.to_string().contains("3 attempt(s)"));
}

#[test]
fn a_transient_failure_then_an_answer_succeeds() {
    let dir = TempDir::new("openai-recover");
    let local = tiny(&dir);
    let mut served = tiny(&dir);
    let (address, server) = serve(3, move |index, request| match index {
        0 => Reply::Send { status: 503, body: "busy".into(), chunked: false },
        1 => Reply::Close,
        _ => Reply::Send { status: 200, body: model_reply(&mut served, request), chunked: false },
    });
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    let prior = remote.next_logprobs_among(&[5, 6], &[7, 8]).expect("third attempt answers");
    assert_eq!(prior.tokens, vec![7, 8]);
    assert_eq!(remote.usage().forward_calls, 3);
    server.join().expect("server");
}

#[test]
fn malformed_answers_are_typed_errors_without_retries() {
    let dir = TempDir::new("openai-malformed");
    let local = tiny(&dir);
    let bodies = [
        ("{\"choices\": [", "EOF"),
        ("{\"choices\": [{\"text\": \"x\"}]}", "logprobs"),
        ("{\"choices\": [{\"logprobs\": {\"content\": []}}]}", "neither"),
        ("{\"choices\": [{\"logprobs\": {\"content\": [{\"top_logprobs\": [{\"token\": \"a\", \"logprob\": null}]}]}}]}", "not a number"),
        ("{\"choices\": [{\"logprobs\": {\"top_logprobs\": [{\"token_id:5\": \"high\"}]}}]}", "not a number"),
        ("{\"choices\": [{\"logprobs\": {\"top_logprobs\": [{\"token_id:5\": 3.5}]}}]}", "not a log-probability"),
        ("{\"choices\": [{\"logprobs\": {\"top_logprobs\": [{\"token_id:99999\": -0.1}]}}]}", "vocabulary"),
        // Not one distribution: probabilities that sum past 1, or to nothing.
        ("{\"choices\": [{\"logprobs\": {\"top_logprobs\": [{\"token_id:5\": 0.0, \"token_id:6\": 0.0}]}}]}", "sum to 2.000"),
        ("{\"choices\": [{\"logprobs\": {\"top_logprobs\": [{\"token_id:5\": -1e39, \"token_id:6\": -1e39}]}}]}", "-inf"),
        ("<html>Bad gateway</html>", "expected value"),
    ];
    let count = bodies.len();
    let (address, server) = serve(count, move |index, _| Reply::Send { status: 200, body: bodies[index].0.into(), chunked: false });
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    for (_, fragment) in bodies {
        let error = http_error(remote.next_logprobs(&[5]));
        assert!(matches!(&error.kind, HttpErrorKind::MalformedJson(m) if m.contains(fragment)), "{error} should mention {fragment}");
        assert_eq!(error.attempts, 1);
    }
    assert_eq!(server.join().expect("server").bodies.len(), count);
}

#[test]
fn client_errors_are_not_retried() {
    let dir = TempDir::new("openai-400");
    let local = tiny(&dir);
    let (address, server) =
        serve(1, |_, _| Reply::Send { status: 400, body: "{\"error\": \"logprobs too large\"}".into(), chunked: false });
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    let error = http_error(remote.next_logprobs(&[5]));
    assert!(matches!(error.kind, HttpErrorKind::Status { status: 400, .. }));
    assert_eq!(error.attempts, 1);
    server.join().expect("server");
}

#[test]
fn an_unreachable_server_and_a_bad_url_are_typed_errors() {
    let dir = TempDir::new("openai-refused");
    let local = tiny(&dir);
    let address = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("address");
    // The listener is dropped: nothing listens on the port any more.
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    let error = http_error(remote.next_logprobs(&[5]));
    assert!(matches!(error.kind, HttpErrorKind::Connect(_)), "{error}");
    assert_eq!(error.attempts, 3);
    for url in ["ftp://example.invalid/v1", "127.0.0.1:8000/v1", "http://:80/v1"] {
        let error = OpenAiModel::new(OpenAiConfig::new(url, "m"), Arc::clone(local.shared_tokenizer())).expect_err(url);
        assert!(matches!(error, LmError::Http(HttpError { kind: HttpErrorKind::BadUrl(_), attempts: 0, .. })), "{url}: {error}");
    }
    // https is a URL the client takes (rustls); nothing is sent until the first request.
    OpenAiModel::new(OpenAiConfig::new("https://example.invalid/v1", "m"), Arc::clone(local.shared_tokenizer())).expect("https");
    assert!(matches!(remote.next_logprobs(&[]), Err(LmError::EmptySequence)));
    assert!(matches!(remote.next_logprobs_among(&[5], &[9999]), Err(LmError::TokenOutOfRange { .. })));
}

/// The answer llama.cpp's `llama-server` gives on `/v1/completions` with `logprobs`: the
/// chat-style layout, `choices[0].logprobs.content[0].top_logprobs` as a list of entries with
/// `id`, `token`, `bytes` and `logprob`; `name_by` picks which of them the entries carry.
fn chat_style_reply(model: &mut LocalModel, request: &Value, name_by: &str) -> String {
    let prompt: Vec<u32> = request["prompt"].as_array().expect("token prompt").iter().map(|v| v.as_u64().expect("id") as u32).collect();
    let k = request["logprobs"].as_u64().expect("logprobs") as usize;
    let Logprobs::Dense(all) = model.next_logprobs(&prompt).expect("runs") else { unreachable!() };
    let mut scored: Vec<(u32, f32)> = all.iter().enumerate().map(|(i, &l)| (i as u32, l)).collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    scored.truncate(k);
    let entry = |id: u32, logprob: f32| {
        let bytes = model.vocabulary().token_bytes(id).expect("in range").to_vec();
        let token = String::from_utf8_lossy(&bytes).into_owned();
        match name_by {
            "id" => json!({ "id": id, "token": token, "bytes": bytes, "logprob": logprob }),
            "bytes" => json!({ "token": token, "bytes": bytes, "logprob": logprob }),
            _ => json!({ "token": token, "logprob": logprob }),
        }
    };
    let top: Vec<Value> = scored.iter().map(|&(id, l)| entry(id, l)).collect();
    let mut first = entry(scored[0].0, scored[0].1);
    first["top_logprobs"] = json!(top);
    json!({
        "choices": [{ "index": 0, "text": first["token"], "logprobs": { "content": [first] }, "finish_reason": "length" }],
        "usage": { "prompt_tokens": prompt.len(), "completion_tokens": 1 }
    })
    .to_string()
}

#[test]
fn llama_server_style_logprobs_are_read_by_id_bytes_or_text() {
    let dir = TempDir::new("openai-chat-style");
    let mut local = tiny(&dir);
    let mut served = tiny(&dir);
    let ways = ["id", "bytes", "text"];
    let (address, server) = serve(ways.len(), move |index, request| Reply::Send {
        status: 200,
        body: chat_style_reply(&mut served, request, ways[index]),
        chunked: false,
    });
    let mut remote = client(address, ServerDialect::Generic, 8, &local);
    for (index, way) in ways.iter().enumerate() {
        // A new prompt each time, so that no answer comes from the client's memory.
        let prompt = [5, 6 + index as u32];
        let Logprobs::Dense(full) = local.next_logprobs(&prompt).expect("local") else { unreachable!() };
        let Logprobs::Sparse { top, .. } = remote.next_logprobs(&prompt).expect("served") else { panic!("sparse") };
        // By id or bytes every entry is named; by text, only those that are valid UTF-8.
        if *way != "text" {
            assert_eq!(top.len(), 8, "{way}");
        }
        assert!(top.len() >= 2, "{way}: at least two entries named");
        for &(id, l) in &top {
            assert!((full[id as usize] - l).abs() < 1e-5, "{way}: token {id}");
        }
    }
    assert_eq!(server.join().expect("server").connections, 1);
}

#[test]
fn a_429_is_retried() {
    let dir = TempDir::new("openai-429");
    let local = tiny(&dir);
    let mut served = tiny(&dir);
    let (address, server) = serve(2, move |index, request| match index {
        0 => Reply::Send { status: 429, body: "slow down".into(), chunked: false },
        _ => Reply::Send { status: 200, body: model_reply(&mut served, request), chunked: false },
    });
    let mut remote = client(address, ServerDialect::Vllm, 5, &local);
    remote.next_logprobs(&[5, 6]).expect("the second attempt answers");
    assert_eq!(remote.usage().forward_calls, 2);
    server.join().expect("server");
}

/// The dialects by name, and a name that is none of them refused with the list.
#[test]
fn server_dialects_parse_by_name_and_refuse_others_with_the_list() {
    assert_eq!("vllm".parse::<ServerDialect>(), Ok(ServerDialect::Vllm));
    assert_eq!("generic".parse::<ServerDialect>(), Ok(ServerDialect::Generic));
    let error = "llama.cpp".parse::<ServerDialect>().expect_err("not a dialect");
    assert_eq!(error, lm::UnknownDialect("llama.cpp".into()));
    assert_eq!(error.to_string(), "`llama.cpp` is not a server dialect: the dialects are vllm, generic");
}

/// A full answer memory forgets its oldest answers, not the ones just stored or asked for:
/// with room for 4, after five prompts the fourth is still answered without the server (which
/// stops after five requests, so a sixth would fail), and so is one asked for again in between.
#[test]
fn a_full_answer_memory_keeps_the_recent_answers() {
    let dir = TempDir::new("openai-memory");
    let local = tiny(&dir);
    let mut served = tiny(&dir);
    let (address, server) =
        serve(6, move |_, request| Reply::Send { status: 200, body: model_reply(&mut served, request), chunked: false });
    let mut config = OpenAiConfig::new(&format!("http://{address}/v1"), "tiny");
    config.cache_entries = 4;
    config.timeout = Duration::from_millis(500);
    config.retry_backoff = Duration::from_millis(1);
    let mut remote = OpenAiModel::new(config, local.shared_tokenizer().clone()).expect("client");
    let prompts: Vec<Vec<u32>> = ["open the", "go to the", "take the", "put the", "close the", "clean the"]
        .iter()
        .map(|t| local.encode(t).expect("encodes"))
        .collect();
    for prompt in &prompts[..5] {
        remote.next_logprobs(prompt).expect("served");
    }
    assert_eq!(remote.usage().forward_calls, 5);
    // The fourth and fifth are remembered; the fourth, asked again, is kept past a new prompt.
    remote.next_logprobs(&prompts[3]).expect("remembered");
    remote.next_logprobs(&prompts[4]).expect("remembered");
    remote.next_logprobs(&prompts[5]).expect("served");
    remote.next_logprobs(&prompts[3]).expect("remembered");
    let usage = remote.usage();
    assert_eq!((usage.forward_calls, usage.cache_hits), (6, 3));
    server.join().expect("server");
}
