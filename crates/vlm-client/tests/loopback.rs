//! The chat client against HTTP servers on loopback, started by each test and scripted reply
//! by reply: good answers (kept alive between requests), and faults: a server that hangs,
//! answers 500, answers 429 or 503 with `Retry-After`, sends malformed or truncated JSON, or
//! resets the connection. Each ends in a typed error or a correct retry within the per-attempt
//! deadline; the servers report every request they saw and how many connections carried them.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

use serde_json::{Value, json};
use vlm_client::{
    ChatClient, ChatErrorKind, ChatModel, ChatRequest, ClientConfig, Image, ImageFormat, JsonMode, Message, RetryPolicy, Sampling,
    ServedModel, chat_json, served_models,
};

/// What a test server does with one request.
#[derive(Debug, Clone)]
enum Reply {
    /// Status, extra headers and body, with Content-Length, on a connection kept open.
    Send { status: u16, headers: Vec<(&'static str, String)>, body: String },
    /// Reads until the client gives up and closes: the client's deadline must fire.
    Hang,
    /// Drops the connection with the request unread, which makes the kernel reset it.
    Reset,
    /// Promises more body than it sends, then closes.
    Truncated { body: String },
}

fn ok(body: Value) -> Reply {
    Reply::Send { status: 200, headers: Vec::new(), body: body.to_string() }
}

fn status(status: u16, headers: Vec<(&'static str, String)>, body: &str) -> Reply {
    Reply::Send { status, headers, body: body.to_string() }
}

fn completion(content: &str) -> Value {
    json!({
        "id": "chatcmpl-test",
        "object": "chat.completion",
        "choices": [{ "index": 0, "message": { "role": "assistant", "content": content }, "finish_reason": "stop" }],
        "usage": { "prompt_tokens": 21, "completion_tokens": 7, "total_tokens": 28 }
    })
}

/// What the server saw: each request's body, and the connection (counted from 0) it came on.
struct Seen {
    requests: Receiver<(usize, Value)>,
}

impl Seen {
    fn all(&self) -> Vec<(usize, Value)> {
        self.requests.try_iter().collect()
    }
}

/// A server on 127.0.0.1 that plays `script`, one reply per request, then stops accepting.
fn serve(script: Vec<Reply>) -> (SocketAddr, Seen) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind loopback");
    let address = listener.local_addr().expect("address");
    let (sender, requests) = channel();
    std::thread::spawn(move || {
        let mut script = script.into_iter();
        let mut connection = 0;
        while let Some(mut next) = script.next() {
            let Ok((mut stream, _)) = listener.accept() else { return };
            // A bound on how long a broken client could hold the server thread.
            stream.set_read_timeout(Some(Duration::from_secs(30))).ok();
            loop {
                if let Reply::Reset = next {
                    // Wait for the first bytes, leave the rest unread, and close: a reset.
                    let mut first = [0u8; 1];
                    stream.read_exact(&mut first).ok();
                    break;
                }
                let Some(request) = read_request(&mut stream) else { break };
                sender.send((connection, request)).ok();
                match next {
                    Reply::Send { status, headers, body } => {
                        let mut head =
                            format!("HTTP/1.1 {status} X\r\nContent-Type: application/json\r\nContent-Length: {}\r\n", body.len());
                        for (name, value) in headers {
                            head.push_str(&format!("{name}: {value}\r\n"));
                        }
                        head.push_str("\r\n");
                        if stream.write_all(head.as_bytes()).and_then(|_| stream.write_all(body.as_bytes())).is_err() {
                            break;
                        }
                    }
                    Reply::Hang => {
                        let mut sink = [0u8; 64];
                        while matches!(stream.read(&mut sink), Ok(n) if n > 0) {}
                        break;
                    }
                    Reply::Truncated { body } => {
                        let head =
                            format!("HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n", body.len() + 100);
                        stream.write_all(head.as_bytes()).and_then(|_| stream.write_all(body.as_bytes())).ok();
                        break;
                    }
                    Reply::Reset => unreachable!(),
                }
                match script.next() {
                    Some(reply) => next = reply,
                    None => return,
                }
            }
            connection += 1;
        }
    });
    (address, Seen { requests })
}

/// One request off `stream` (its JSON body), or `None` when the client closed it.
fn read_request(stream: &mut TcpStream) -> Option<Value> {
    let mut buffer = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        if let Some(end) = buffer.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&buffer[..end]).to_ascii_lowercase();
            if head.starts_with("get /v1/models http/1.1\r\n") {
                return Some(json!({ "_get": "/v1/models" }));
            }
            assert!(head.starts_with("post /v1/chat/completions http/1.1\r\n"), "{head}");
            let length: usize = head.lines().find_map(|l| l.strip_prefix("content-length:").map(|v| v.trim().parse().expect("length")))?;
            while buffer.len() < end + 4 + length {
                let n = stream.read(&mut chunk).ok().filter(|&n| n > 0)?;
                buffer.extend_from_slice(&chunk[..n]);
            }
            let mut request: Value = serde_json::from_slice(&buffer[end + 4..end + 4 + length]).expect("a JSON body");
            let authorization = head.lines().find_map(|l| l.strip_prefix("authorization:")).map(str::trim);
            request["_authorization"] = json!(authorization);
            return Some(request);
        }
        let n = stream.read(&mut chunk).ok().filter(|&n| n > 0)?;
        buffer.extend_from_slice(&chunk[..n]);
    }
}

fn client(address: SocketAddr) -> ChatClient {
    let mut config = ClientConfig::new(&format!("http://{address}/v1"), "test-model");
    config.retry = RetryPolicy {
        timeout: Duration::from_millis(400),
        max_retries: 2,
        backoff: Duration::from_millis(1),
        max_wait: Duration::from_secs(2),
    };
    ChatClient::new(config).expect("client")
}

fn skill_request() -> ChatRequest {
    ChatRequest::new(vec![Message::user("Pick a skill: Goto(fridge 1) or Done.")]).with_sampling(Sampling::greedy(32)).with_json_schema(
        json!({
            "type": "object",
            "properties": { "skill": { "enum": ["Goto(fridge 1)", "Done"] } },
            "required": ["skill"]
        }),
    )
}

#[test]
fn replies_come_back_over_one_kept_alive_connection() {
    let (address, seen) = serve(vec![ok(completion("Hello.")), ok(completion("Again.")), ok(completion("Third."))]);
    let mut client = client(address);
    let request = ChatRequest::new(vec![Message::user("Hi")]);
    let texts: Vec<String> = (0..3).map(|_| client.chat(&request).expect("reply").text).collect();
    assert_eq!(texts, ["Hello.", "Again.", "Third."]);
    let requests = seen.all();
    assert_eq!(requests.iter().map(|(connection, _)| *connection).collect::<Vec<_>>(), [0, 0, 0], "keep-alive reuses the connection");
    assert_eq!(requests[0].1["messages"], json!([{ "role": "user", "content": "Hi" }]));
    let usage = client.usage();
    assert_eq!((usage.requests, usage.prompt_tokens, usage.completion_tokens), (3, 63, 21));
}

#[test]
fn json_replies_are_read_and_images_counted() {
    let (address, seen) = serve(vec![ok(completion("Sure: {\"skill\": \"Goto(fridge 1)\"} - it may hold the mug."))]);
    let mut client = client(address);
    let mut request = skill_request();
    let image = Image::encode_rgb8(ImageFormat::Jpeg, 1, 1, &[0, 128, 255]).expect("jpeg");
    request.messages[0] = request.messages[0].clone().with_image(image.clone());
    let reply = chat_json(&mut client, &request).expect("json");
    assert_eq!(reply.value, json!({ "skill": "Goto(fridge 1)" }));
    assert!(!reply.repaired);
    assert_eq!((reply.usage.images, reply.reply.json_mode), (1, Some(JsonMode::Schema)));
    let body = &seen.all()[0].1;
    assert_eq!(body["response_format"]["type"], "json_schema");
    assert_eq!(body["messages"][0]["content"][1]["image_url"]["url"], image.data_url());
}

#[test]
fn a_bad_reply_gets_one_repair_turn_quoting_the_error() {
    let (address, seen) = serve(vec![ok(completion("{\"skill\": \"Fly\"}")), ok(completion("{\"skill\": \"Done\"}"))]);
    let mut client = client(address);
    let reply = chat_json(&mut client, &skill_request()).expect("repaired");
    assert_eq!((reply.value, reply.repaired, reply.usage.requests), (json!({ "skill": "Done" }), true, 2));
    let repair = &seen.all()[1].1["messages"];
    assert_eq!(repair[1], json!({ "role": "assistant", "content": "{\"skill\": \"Fly\"}" }));
    let quoted = repair[2]["content"].as_str().expect("text");
    assert!(quoted.starts_with(r#"Your reply could not be used: $.skill: "Fly" is not one of "Goto(fridge 1)", "Done""#), "{quoted}");
}

#[test]
fn two_bad_replies_are_an_invalid_json_error() {
    let (address, _seen) = serve(vec![ok(completion("I would go to the fridge.")), ok(completion("{\"skill\": \"Goto(fri"))]);
    let mut client = client(address);
    let error = chat_json(&mut client, &skill_request()).expect_err("no JSON");
    let ChatErrorKind::InvalidJson { error: why, reply } = &error.kind else { panic!("{error}") };
    assert!(why.starts_with("invalid JSON at byte 0: EOF"), "{why}");
    assert_eq!(reply, "{\"skill\": \"Goto(fri");
    assert_eq!(error.attempts, 2);
}

/// A server that takes no `response_format` at all: the first refusal of a schema is followed by
/// one probe (the plainest schema), which it refuses too, so the server takes no schema; then
/// `json_object`, refused as well, then plain text. Later requests start without a schema.
#[test]
fn a_server_refusing_response_format_is_asked_more_plainly() {
    let refusal = "{\"error\": {\"message\": \"response_format json_schema is not supported\"}}";
    let (address, seen) = serve(vec![
        status(400, Vec::new(), refusal),
        status(400, Vec::new(), refusal),
        status(400, Vec::new(), refusal),
        ok(completion("{\"skill\": \"Done\"}")),
        ok(completion("{\"skill\": \"Done\"}")),
    ]);
    let mut client = client(address);
    let reply = chat_json(&mut client, &skill_request()).expect("json");
    assert_eq!((reply.value, reply.reply.json_mode, reply.reply.attempts), (json!({ "skill": "Done" }), Some(JsonMode::Text), 4));
    // The weaker mode is kept for later requests.
    assert_eq!(chat_json(&mut client, &skill_request()).expect("json").reply.attempts, 1);
    let bodies = seen.all();
    let formats: Vec<Value> = bodies.iter().map(|(_, body)| body["response_format"]["type"].clone()).collect();
    assert_eq!(formats, [json!("json_schema"), json!("json_schema"), json!("json_object"), Value::Null, Value::Null]);
    // The probe: the plainest schema, one output token.
    assert_eq!(bodies[1].1["response_format"]["json_schema"]["schema"], json!({ "type": "object" }));
    assert_eq!(bodies[1].1["max_tokens"], 1);
    assert_eq!(client.usage().requests, 5);
}

/// A server that takes no `json_schema` but does take `json_object` (the probe is refused):
/// every schema is asked as a JSON object from then on, a new schema included, so a run whose
/// schema changes every turn (Phase I's skills) pays one refused request and one probe in all,
/// not one refusal a turn.
#[test]
fn a_server_that_takes_no_schema_is_asked_for_json_objects_from_then_on() {
    let refusal =
        "{\"error\": {\"message\": \"Invalid parameter: 'response_format' of type 'json_schema' is not supported with this model.\"}}";
    let (address, seen) = serve(vec![
        status(400, Vec::new(), refusal),
        status(400, Vec::new(), refusal),
        ok(completion("{\"skill\": \"Done\"}")),
        ok(completion("{\"skill\": \"Done\"}")),
    ]);
    let mut client = client(address);
    let first = chat_json(&mut client, &skill_request()).expect("json");
    assert_eq!((first.reply.json_mode, first.reply.attempts), (Some(JsonMode::Object), 3));
    let mut other = skill_request();
    other.json_schema = Some(json!({"type": "object", "properties": {"skill": {"enum": ["Done"]}}, "required": ["skill"]}));
    assert_eq!(client.json_mode(other.json_schema.as_ref().unwrap()), JsonMode::Object);
    let second = chat_json(&mut client, &other).expect("json");
    assert_eq!((second.reply.json_mode, second.reply.attempts), (Some(JsonMode::Object), 1));
    let formats: Vec<Value> = seen.all().into_iter().map(|(_, body)| body["response_format"]["type"].clone()).collect();
    assert_eq!(formats, [json!("json_schema"), json!("json_schema"), json!("json_object"), json!("json_object")]);
}

/// A server that refuses one schema and takes another: the weaker mode is kept for the schema it
/// was refused, not for every later request, so a request is asked the same way whatever came
/// before it (a resumed run asks as an uninterrupted one).
#[test]
fn a_weaker_mode_is_kept_for_the_schema_that_needed_it() {
    let refusal = "{\"error\": {\"message\": \"this schema is not supported\"}}";
    let (address, seen) = serve(vec![
        status(400, Vec::new(), refusal),
        // The probe, which the server takes: the refusal was about that schema.
        ok(completion("{}")),
        ok(completion("{\"skill\": \"Done\"}")),
        ok(completion("{\"skill\": \"Done\"}")),
        ok(completion("{\"skill\": \"Done\"}")),
    ]);
    let mut client = client(address);
    let refused = skill_request();
    let mut other = skill_request();
    other.json_schema = Some(json!({"type": "object", "properties": {"skill": {"enum": ["Done"]}}, "required": ["skill"]}));
    assert_eq!(chat_json(&mut client, &refused).expect("json").reply.json_mode, Some(JsonMode::Object));
    assert_eq!(chat_json(&mut client, &other).expect("json").reply.json_mode, Some(JsonMode::Schema));
    assert_eq!(chat_json(&mut client, &refused).expect("json").reply.attempts, 1);
    let formats: Vec<Value> = seen.all().into_iter().map(|(_, body)| body["response_format"]["type"].clone()).collect();
    assert_eq!(formats, [json!("json_schema"), json!("json_schema"), json!("json_object"), json!("json_schema"), json!("json_object")]);
}

/// A hosted API that takes no template arguments refuses `chat_template_kwargs` by name: the
/// request goes again without them, and so do later ones (a property of the server).
#[test]
fn a_server_refusing_template_arguments_is_asked_without_them() {
    let refusal = "{\"error\": {\"message\": \"Unrecognized request argument supplied: chat_template_kwargs\"}}";
    let (address, seen) =
        serve(vec![status(400, Vec::new(), refusal), ok(completion("{\"skill\": \"Done\"}")), ok(completion("{\"skill\": \"Done\"}"))]);
    let mut client = client(address);
    let reply = chat_json(&mut client, &skill_request().with_thinking(false)).expect("json");
    assert_eq!((reply.reply.json_mode, reply.reply.attempts), (Some(JsonMode::Schema), 2));
    chat_json(&mut client, &skill_request().with_thinking(false)).expect("json");
    let kwargs: Vec<bool> = seen.all().into_iter().map(|(_, body)| body.get("chat_template_kwargs").is_some()).collect();
    assert_eq!(kwargs, [true, false, false]);
}

/// A 400 that is not about the JSON mode (a prompt past the context) fails in every mode, and
/// the next request is asked with the full schema again: only a weaker mode that worked is kept.
#[test]
fn an_error_of_another_kind_does_not_weaken_later_requests() {
    let too_long = "{\"error\": {\"message\": \"the request exceeds the available context size\"}}";
    let (address, seen) = serve(vec![
        status(400, Vec::new(), too_long),
        // The probe, short enough to be taken.
        ok(completion("{}")),
        status(400, Vec::new(), too_long),
        status(400, Vec::new(), too_long),
        ok(completion("{\"skill\": \"Done\"}")),
    ]);
    let mut client = client(address);
    let error = chat_json(&mut client, &skill_request()).expect_err("too long in every mode");
    assert!(matches!(error.kind, ChatErrorKind::Status { status: 400, .. }), "{error}");
    assert_eq!(client.json_mode(skill_request().json_schema.as_ref().unwrap()), JsonMode::Schema);
    let reply = chat_json(&mut client, &skill_request()).expect("json");
    assert_eq!((reply.reply.json_mode, reply.reply.attempts), (Some(JsonMode::Schema), 1));
    let formats: Vec<Value> = seen.all().into_iter().map(|(_, body)| body["response_format"]["type"].clone()).collect();
    assert_eq!(formats, [json!("json_schema"), json!("json_schema"), json!("json_object"), Value::Null, json!("json_schema")]);
}

#[test]
fn a_hanging_server_is_a_timeout_after_every_attempt() {
    let (address, seen) = serve(vec![Reply::Hang, Reply::Hang, Reply::Hang]);
    let error = client(address).chat(&skill_request()).expect_err("hangs");
    assert_eq!(error.kind, ChatErrorKind::Timeout(Duration::from_millis(400)));
    assert_eq!(error.attempts, 3);
    assert_eq!(seen.all().len(), 3);
}

#[test]
fn server_errors_are_retried_then_reported() {
    let (address, _seen) = serve(vec![status(500, Vec::new(), "boom"), ok(completion("fine"))]);
    let reply = client(address).chat(&ChatRequest::new(vec![Message::user("Hi")])).expect("recovers");
    assert_eq!((reply.text.as_str(), reply.attempts), ("fine", 2));

    let (address, _seen) = serve(vec![status(500, Vec::new(), "boom"); 3]);
    let error = client(address).chat(&ChatRequest::new(vec![Message::user("Hi")])).expect_err("keeps failing");
    assert_eq!(error.kind, ChatErrorKind::Status { status: 500, body: "boom".into(), retry_after: None });
    assert_eq!(error.attempts, 3);
    assert!(error.to_string().contains("after 3 attempt(s)"), "{error}");
}

/// A redirect is not followed (a client following a 302 sends the POST again as a GET): the
/// status comes back, naming where the server points, after one attempt, and stops a harness.
#[test]
fn a_redirect_is_reported_with_its_location_not_followed() {
    for code in [301, 302, 307, 308] {
        let (address, seen) =
            serve(vec![status(code, vec![("Location", "https://elsewhere.test/v1/chat/completions".to_string())], "<html>moved</html>")]);
        let error = client(address).chat(&skill_request()).expect_err("redirected");
        let expected = "redirected to https://elsewhere.test/v1/chat/completions; requests follow no redirect: name that URL";
        assert_eq!(error.kind, ChatErrorKind::Status { status: code, body: expected.into(), retry_after: None }, "{code}");
        assert_eq!(error.attempts, 1);
        assert!(error.kind.is_unavailable() && !error.kind.is_transient(), "{code}");
        let seen = seen.all();
        assert_eq!(seen.len(), 1, "one request, the POST, and no second one anywhere");
    }
}

#[test]
fn retry_after_is_honoured_on_429_and_503() {
    let busy = |code| status(code, vec![("Retry-After", "1".to_string())], "busy");
    let (address, _seen) = serve(vec![busy(429), busy(503), ok(completion("fine"))]);
    let reply = client(address).chat(&ChatRequest::new(vec![Message::user("Hi")])).expect("recovers");
    assert_eq!((reply.attempts, reply.waited), (3, Duration::from_secs(2)), "waited exactly what the server asked");

    // Asked to wait longer than the policy allows: no retry, the typed status.
    let (address, _seen) = serve(vec![status(429, vec![("Retry-After", "3600".to_string())], "later")]);
    let error = client(address).chat(&ChatRequest::new(vec![Message::user("Hi")])).expect_err("too long a wait");
    assert_eq!(error.kind, ChatErrorKind::Status { status: 429, body: "later".into(), retry_after: Some(Duration::from_secs(3600)) });
    assert_eq!(error.attempts, 1);
}

#[test]
fn malformed_and_truncated_replies() {
    // A 200 whose body is not a chat completion: not retried, a typed error.
    let (address, _seen) = serve(vec![Reply::Send { status: 200, headers: Vec::new(), body: "{\"choices\": [".into() }]);
    let error = client(address).chat(&skill_request()).expect_err("malformed");
    assert!(matches!(&error.kind, ChatErrorKind::MalformedReply(why) if why.starts_with("not JSON")), "{error}");
    assert_eq!(error.attempts, 1);

    // A body cut short by a closed connection: retried.
    let (address, _seen) = serve(vec![Reply::Truncated { body: "{\"choices\": [".into() }, ok(completion("whole"))]);
    let reply = client(address).chat(&skill_request()).expect("recovers");
    assert_eq!((reply.text.as_str(), reply.attempts), ("whole", 2));

    let (address, _seen) = serve(vec![Reply::Truncated { body: "{".into() }; 3]);
    let error = client(address).chat(&skill_request()).expect_err("always cut");
    assert!(matches!(error.kind, ChatErrorKind::Io(_)), "{error}");
    assert_eq!(error.attempts, 3);
}

#[test]
fn reset_connections_are_retried() {
    let (address, _seen) = serve(vec![Reply::Reset, ok(completion("after a reset"))]);
    let reply = client(address).chat(&skill_request()).expect("recovers");
    assert_eq!((reply.text.as_str(), reply.attempts), ("after a reset", 2));

    let (address, _seen) = serve(vec![Reply::Reset, Reply::Reset, Reply::Reset]);
    let error = client(address).chat(&skill_request()).expect_err("always reset");
    assert!(matches!(error.kind, ChatErrorKind::Io(_) | ChatErrorKind::Connect(_)), "{error}");
    assert_eq!(error.attempts, 3);
}

#[test]
fn nobody_listening_is_a_connect_error() {
    let address = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("address");
    let error = client(address).chat(&skill_request()).expect_err("refused");
    assert!(matches!(error.kind, ChatErrorKind::Connect(_)), "{error}");
    assert_eq!(error.attempts, 3);
}

#[test]
fn the_api_key_comes_from_the_environment() {
    let (address, seen) = serve(vec![ok(completion("authorised"))]);
    let mut config = ClientConfig::new(&format!("http://{address}/v1"), "m");
    config.api_key_env = Some("VLM_CLIENT_TEST_KEY_UNSET".into());
    let error = ChatClient::new(config.clone()).expect_err("unset");
    assert_eq!((error.kind, error.attempts), (ChatErrorKind::MissingApiKey("VLM_CLIENT_TEST_KEY_UNSET".into()), 0));
    // Cargo sets `CARGO_PKG_NAME` for the test process (tests cannot set variables safely).
    config.api_key_env = Some("CARGO_PKG_NAME".into());
    ChatClient::new(config).expect("client").chat(&ChatRequest::new(vec![Message::user("Hi")])).expect("reply");
    assert_eq!(seen.all()[0].1["_authorization"], json!("bearer vlm-client"));
}

#[test]
fn bad_urls_fail_before_any_request() {
    for url in ["ftp://host/v1", "localhost:8080", "http://:1/v1", "http://user:secret@host:8000/v1"] {
        let error = ChatClient::new(ClientConfig::new(url, "m")).expect_err(url);
        assert!(matches!(error.kind, ChatErrorKind::BadUrl(_)), "{url}: {error}");
        assert_eq!(error.attempts, 0);
        assert!(!error.to_string().contains("secret"), "credentials are not printed: {error}");
    }
}

/// A server (or a proxy) that echoes the request's `Authorization` header in an error body
/// does not have the key printed.
#[test]
fn an_echoed_key_is_not_printed() {
    let (address, _seen) = serve(vec![status(401, Vec::new(), r#"{"error": "bad header: Bearer vlm-client"}"#)]);
    let mut config = ClientConfig::new(&format!("http://{address}/v1"), "m");
    // Cargo sets `CARGO_PKG_NAME` (`vlm-client`) for the test process.
    config.api_key_env = Some("CARGO_PKG_NAME".into());
    let error = ChatClient::new(config).expect("client").chat(&ChatRequest::new(vec![Message::user("Hi")])).expect_err("401");
    assert_eq!(
        error.kind,
        ChatErrorKind::Status { status: 401, body: r#"{"error": "bad header: Bearer [the API key]"}"#.into(), retry_after: None }
    );
}

#[test]
fn the_model_list_names_what_the_server_serves() {
    let policy = RetryPolicy {
        timeout: Duration::from_millis(400),
        max_retries: 1,
        backoff: Duration::from_millis(1),
        max_wait: Duration::from_secs(1),
    };
    let listed =
        json!({ "object": "list", "data": [{ "id": "/models/smollm2.gguf", "object": "model", "created": 17, "owned_by": "llamacpp" }] });
    let (address, seen) = serve(vec![status(503, Vec::new(), "loading"), ok(listed)]);
    // A 503 is retried like a chat request; the list's entry comes back without its time stamp.
    let models = served_models(&format!("http://{address}/v1/"), None, &policy).expect("listed").expect("a list");
    assert_eq!(models, vec![ServedModel { id: "/models/smollm2.gguf".into(), root: None, owned_by: Some("llamacpp".into()) }]);
    assert_eq!(seen.all().iter().map(|(_, request)| request["_get"].clone()).collect::<Vec<_>>(), vec![json!("/v1/models"); 2]);
    // A server without the endpoint has no list: not an error.
    let (address, _) = serve(vec![status(404, Vec::new(), "not found")]);
    assert_eq!(served_models(&format!("http://{address}/v1"), None, &policy).expect("no list"), None);
    // Nobody listening is the transport's error, after its retries.
    let nobody = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("address");
    let error = served_models(&format!("http://{nobody}/v1"), None, &policy).expect_err("refused");
    assert!(matches!(error.kind, ChatErrorKind::Connect(_)), "{error}");
    assert_eq!(error.attempts, 2);
}
