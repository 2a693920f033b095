//! `cargo xtask eval --agent direct`: a model that is not there, or no chat model at all, is
//! bad input (exit 2) before any record file is made; so is a reply cache (`--chat-cache`)
//! inside the records folder. A served model is named by what its server lists. Needs no
//! model file.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use common::xtask;

/// A records folder that does not exist, inside a temporary folder that is removed when the
/// returned guard is dropped, also when the test fails.
fn out(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = tempfile::Builder::new().prefix("eval-direct-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    (tmp, dir)
}

/// `cargo xtask eval ARGS --limit 1 --out DIR`, which must exit 2; its stderr.
fn refused(args: &[&str], dir: &std::path::Path) -> String {
    let mut all = vec!["eval"];
    all.extend_from_slice(args);
    all.extend(["--limit", "1", "--out", dir.to_str().unwrap()]);
    let output = xtask(&all);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    stderr
}

#[test]
fn an_unknown_model_is_bad_input() {
    let (_tmp_dir, dir) = out("unknown");
    let stderr = refused(&["--agent", "direct", "--explorer", "no-such-model.gguf", "--benchmark", "alfworld-seen"], &dir);
    assert!(stderr.contains("no-such-model.gguf"), "{stderr}");
    assert!(!dir.exists(), "no records for a run that never started");
}

/// ALFWorld's F_str is read off valid_train's problem files: an agent with Phase I is not
/// evaluated there (it would know facts of each game's own problem); the expert and the direct
/// policy, which use no F_str, are.
#[test]
fn agents_with_phase_one_are_not_evaluated_on_the_set_f_str_comes_from() {
    let (_tmp_dir, dir) = out("train");
    for agent in ["ours", "planner"] {
        let stderr = refused(&["--agent", agent, "--explorer", "systematic", "--benchmark", "alfworld-train"], &dir);
        assert!(stderr.contains(&format!("--agent {agent}: alfworld-train is the set ALFWorld's F_str is derived from")), "{stderr}");
        assert!(!dir.exists(), "no records for a run that never started");
    }
    let output = xtask(&["eval", "--agent", "expert", "--benchmark", "alfworld-train", "--limit", "1", "--out", dir.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
}

/// The expert replays the benchmark's own plans: an episode's setting given to it (a model, a
/// budget, a search option) would be passed over, so it is refused, naming them.
#[test]
fn episode_settings_given_to_the_expert_are_refused() {
    let (_tmp_dir, dir) = out("expert");
    let stderr =
        refused(&["--agent", "expert", "--explorer", "openai:http://127.0.0.1:9/v1", "--budget", "10", "--failure-limit", "2"], &dir);
    assert!(
        stderr.contains("--explorer, --budget, --failure-limit are settings of the agents that explore and plan; the expert replays"),
        "{stderr}"
    );
    assert!(!dir.exists());
}

#[test]
fn the_direct_agent_needs_a_chat_model() {
    let (_tmp_dir, dir) = out("systematic");
    let output =
        xtask(&["eval", "--agent", "direct", "--explorer", "systematic", "--benchmark", "alfworld-seen", "--out", dir.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--agent direct needs a chat model"), "{stderr}");

    let output = xtask(&["eval", "--agent", "direct", "--explorer", "smollm2", "--failure-limit", "0", "--out", dir.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(!dir.exists());
}

#[test]
fn a_reply_cache_inside_the_records_folder_is_refused() {
    let (_tmp_dir, dir) = out("cache");
    let cache = dir.join("phase1-replies.jsonl");
    let stderr = refused(&["--explorer", "no-such-model.gguf", "--chat-cache", cache.to_str().unwrap()], &dir);
    assert!(stderr.contains("keep the reply file out of the records folder"), "{stderr}");
    // A reply file no model would fill: the sweep explores, or the direct agent (no Phase I).
    let elsewhere = dir.with_extension("replies.jsonl");
    for args in [&["--explorer", "systematic"][..], &["--agent", "direct", "--explorer", "smollm2"]] {
        let stderr = refused(&[args, &["--chat-cache", elsewhere.to_str().unwrap()]].concat(), &dir);
        assert!(stderr.contains("this run asks none"), "{args:?}: {stderr}");
    }
    assert!(!elsewhere.exists());
    assert!(!dir.exists(), "no records, no reply file");
}

/// How the loopback server behaves beyond answering.
#[derive(Clone, Default)]
struct Manner {
    /// Answer only requests bearing this key (`Authorization: Bearer KEY`); 401 otherwise.
    key: Option<&'static str>,
    /// Wait this long before answering a chat request.
    chat_delay: std::time::Duration,
}

/// A model server on loopback: `GET /v1/models` lists `listed`'s one id, and every chat request
/// is answered DONE (the direct agent ends its episode). Counts the chat requests.
fn done_server(listed: Arc<Mutex<String>>, chats: Arc<AtomicUsize>) -> String {
    server_in_manner(listed, chats, Manner::default())
}

/// [`done_server`], behaving as `manner` says.
fn server_in_manner(listed: Arc<Mutex<String>>, chats: Arc<AtomicUsize>, manner: Manner) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = listener.local_addr().expect("address");
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(stream) = stream else { return };
            let (listed, chats, manner) = (listed.clone(), chats.clone(), manner.clone());
            std::thread::spawn(move || serve_connection(stream, &listed, &chats, &manner));
        }
    });
    format!("http://{address}/v1")
}

/// Requests on one kept-alive connection until the client closes it.
fn serve_connection(mut stream: TcpStream, listed: &Mutex<String>, chats: &AtomicUsize, manner: &Manner) {
    let mut buffer = Vec::new();
    let mut chunk = [0u8; 65536];
    loop {
        let Some(end) = buffer.windows(4).position(|w| w == b"\r\n\r\n") else {
            match stream.read(&mut chunk) {
                Ok(n) if n > 0 => buffer.extend_from_slice(&chunk[..n]),
                _ => return,
            }
            continue;
        };
        let head = String::from_utf8_lossy(&buffer[..end]).to_ascii_lowercase();
        let length: usize = head.lines().find_map(|l| l.strip_prefix("content-length:")).map_or(0, |v| v.trim().parse().expect("length"));
        while buffer.len() < end + 4 + length {
            match stream.read(&mut chunk) {
                Ok(n) if n > 0 => buffer.extend_from_slice(&chunk[..n]),
                _ => return,
            }
        }
        buffer.drain(..end + 4 + length);
        if let Some(key) = manner.key
            && !head.lines().any(|l| l.trim() == format!("authorization: bearer {key}"))
        {
            let body = r#"{"error": {"message": "Unauthorized", "type": "invalid_request_error"}}"#;
            let reply =
                format!("HTTP/1.1 401 Unauthorized\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}", body.len());
            if stream.write_all(reply.as_bytes()).is_err() {
                return;
            }
            continue;
        }
        let body = if head.starts_with("get /v1/models ") {
            serde_json::json!({ "object": "list", "data": [{ "id": *listed.lock().unwrap(), "object": "model", "created": 1, "owned_by": "test" }] })
        } else {
            assert!(head.starts_with("post /v1/chat/completions "), "{head}");
            chats.fetch_add(1, Ordering::SeqCst);
            std::thread::sleep(manner.chat_delay);
            serde_json::json!({
                "choices": [{ "message": { "role": "assistant", "content": "{\"action\": \"DONE\", \"done\": true}" }, "finish_reason": "stop" }],
                "usage": { "prompt_tokens": 300, "completion_tokens": 12 }
            })
        }
        .to_string();
        let reply = format!("HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}", body.len());
        if stream.write_all(reply.as_bytes()).is_err() {
            return;
        }
    }
}

/// A server behind the same URL and model name can serve another model (llama.cpp's server
/// answers to any name with the file it loaded): the run's configuration names what the server
/// lists, so another model's records go to another file, and the same model's run resumes.
#[test]
fn a_served_model_is_named_by_what_its_server_lists() {
    let (_tmp_dir, dir) = out("served");
    let listed = Arc::new(Mutex::new("/models/first.gguf".to_string()));
    let chats = Arc::new(AtomicUsize::new(0));
    let url = done_server(listed.clone(), chats.clone());
    let explorer = format!("openai:{url}");
    let run = || {
        #[rustfmt::skip]
        let output = xtask(&[
            "eval", "--agent", "direct", "--explorer", &explorer, "--served-model", "default", "--benchmark", "alfworld-seen",
            "--limit", "1", "--out", dir.to_str().unwrap(), "--json",
        ]);
        assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
        std::path::PathBuf::from(summary["alfworld-seen"]["records"].as_str().expect("the records' file"))
    };
    let served = |records: &std::path::Path| {
        let config: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(records.with_extension("config.json")).expect("config")).expect("JSON");
        config["served"][format!("{url} served-model:default")].clone()
    };
    let first = run();
    assert_eq!(served(&first), serde_json::json!({ "id": "/models/first.gguf", "owned_by": "test" }));
    assert_eq!(chats.load(Ordering::SeqCst), 1, "one turn: DONE");
    // The same model again: the run is done, nothing is asked.
    assert_eq!(run(), first);
    assert_eq!(chats.load(Ordering::SeqCst), 1);
    // Another model behind the same URL and name: another run, in a file of its own.
    *listed.lock().unwrap() = "/models/second.gguf".to_string();
    let second = run();
    assert_ne!(second, first);
    assert_eq!(served(&second)["id"], "/models/second.gguf");
    assert_eq!(chats.load(Ordering::SeqCst), 2);
    assert_eq!(std::fs::read_to_string(&first).expect("records").lines().count(), 1, "the first run's records untouched");
}

/// `--api-key-env`, `--server-timeout` and `--server-retries` reach every request of the run:
/// the model list and the chat. A server that wants a key answers with the key's variable
/// given, and refuses without it (exit 3: nothing recorded); an unset variable is bad input; a
/// reply slower than the deadline stops the run after the retries asked for, recording
/// nothing; and the options where no model is served would be passed over, so are refused.
#[test]
fn the_server_options_reach_every_request_of_the_run() {
    let (_tmp_dir, dir) = out("server");
    let chats = Arc::new(AtomicUsize::new(0));
    let listed = Arc::new(Mutex::new("/models/keyed.gguf".to_string()));
    let manner = Manner { key: Some("sekrit"), ..Manner::default() };
    let explorer = format!("openai:{}", server_in_manner(listed.clone(), chats.clone(), manner));
    let run = |extra: &[&str], key: Option<&str>| {
        let mut args = vec!["eval", "--agent", "direct", "--explorer", &explorer, "--benchmark", "alfworld-seen", "--limit", "1"];
        args.extend_from_slice(&["--out", dir.to_str().unwrap()]);
        args.extend_from_slice(extra);
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_xtask"));
        command.args(&args).current_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".."));
        command.env_remove("XTASK_TEST_SERVER_KEY");
        if let Some(key) = key {
            command.env("XTASK_TEST_SERVER_KEY", key);
        }
        let output = command.output().expect("xtask runs");
        (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    let key = ["--api-key-env", "XTASK_TEST_SERVER_KEY"];
    let (code, stderr) = run(&key, None);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("--api-key-env XTASK_TEST_SERVER_KEY: the API key variable `XTASK_TEST_SERVER_KEY` is not set"), "{stderr}");
    // Empty, or holding what a header cannot carry: bad input naming the variable, before any
    // request (a newline failed at the first request, retried as a broken connection).
    for (value, why) in
        [("", "is not set (or empty)"), ("sek\nrit", "the control character '\\n'"), ("sekrét", "the non-ASCII character 'é'")]
    {
        let (code, stderr) = run(&key, Some(value));
        assert_eq!(code, Some(2), "{value:?}: {stderr}");
        assert!(stderr.contains("--api-key-env XTASK_TEST_SERVER_KEY: ") && stderr.contains(why), "{value:?}: {stderr}");
    }
    assert_eq!(chats.load(Ordering::SeqCst), 0);
    let (code, stderr) = run(&["--server-retries", "0"], None);
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.contains("401"), "{stderr}");
    assert_eq!(chats.load(Ordering::SeqCst), 0, "refused at the model list");
    let (code, stderr) = run(&key, Some("sekrit"));
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(chats.load(Ordering::SeqCst), 1, "one turn: DONE");

    // A server slower than the deadline: one attempt and one retry, then the run stops.
    let (_slow_dir, slow) = out("slow");
    let chats = Arc::new(AtomicUsize::new(0));
    let manner = Manner { chat_delay: std::time::Duration::from_secs(5), ..Manner::default() };
    let explorer = format!("openai:{}", server_in_manner(listed, chats.clone(), manner));
    #[rustfmt::skip]
    let output = xtask(&[
        "eval", "--agent", "direct", "--explorer", &explorer, "--benchmark", "alfworld-seen", "--limit", "1",
        "--server-timeout", "0.5", "--server-retries", "1", "--out", slow.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("no complete reply within 500ms (after 2 attempt(s)"), "{stderr}");
    assert_eq!(chats.load(Ordering::SeqCst), 2);
    let records: usize = std::fs::read_dir(&slow)
        .expect("the records folder")
        .filter_map(Result::ok)
        .filter(|e| e.path().extension().is_some_and(|x| x == "jsonl"))
        .map(|e| std::fs::read_to_string(e.path()).expect("records").lines().count())
        .sum();
    assert_eq!(records, 0, "a run stopped by its server records nothing");

    // No served model: the options would be passed over.
    let (_none_dir, none) = out("none");
    let stderr = refused(&["--agent", "planner", "--explorer", "systematic", "--server-timeout", "5", "--api-key-env", "HOME"], &none);
    assert!(
        stderr.contains("--api-key-env, --server-timeout are settings of a served model (openai:URL), and the run names none"),
        "{stderr}"
    );
}

/// Input that leaves nothing to run, or runs a benchmark twice, is refused before any file is
/// made: an empty subset, a shard that selects no task, a benchmark named twice, two subsets
/// of one benchmark, a subset of a benchmark the run does not take, `--limit 0`.
#[test]
fn a_run_of_nothing_or_of_a_benchmark_twice_is_refused_before_any_file() {
    let (tmp_dir, dir) = out("nothing");
    let empty = tmp_dir.path().join("virtualhome-eai-empty.txt");
    std::fs::write(&empty, "# nothing yet\n").expect("writes");
    let one = tmp_dir.path().join("virtualhome-eai-one.txt");
    std::fs::write(&one, "1004_2\n").expect("writes");
    let (empty, one) = (empty.display().to_string(), one.display().to_string());
    let both = format!("{one},{empty}");
    let sweep = ["--agent", "planner", "--explorer", "systematic", "--benchmark", "virtualhome-eai"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--subset", &empty], "virtualhome-eai: no task to run"),
        (vec!["--subset", &one, "--shard", "2/2"], "--shard 2/2: selects no task of the run"),
        (vec!["--subset", &both], "are both subsets of virtualhome-eai"),
        // A subset for a benchmark the run does not take (it was passed over).
        (
            vec!["--subset", "virtualhome-eai-50,alfworld-seen-12"],
            "--subset alfworld-seen-12: a subset of none of the run's benchmarks (virtualhome-eai)",
        ),
    ];
    for (extra, said) in &cases {
        let mut args = vec!["eval"];
        args.extend(sweep);
        args.extend(extra.iter().copied());
        args.extend(["--out", dir.to_str().unwrap()]);
        let output = xtask(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains(said), "{extra:?}: {stderr}");
        assert!(!dir.exists(), "{extra:?}: no records folder for a run that never started");
    }
    let stderr = refused(&["--benchmark", "virtualhome-eai,virtualhome-eai", "--agent", "planner", "--explorer", "systematic"], &dir);
    assert!(stderr.contains("--benchmark names virtualhome-eai twice"), "{stderr}");
    let output = xtask(&["eval", "--limit", "0", "--out", dir.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(!dir.exists());
    // A file where the records folder or the report's folder would go.
    std::fs::write(&dir, "").expect("writes");
    for command in [
        &["eval", "--agent", "expert", "--limit", "1", "--out"][..],
        &["report", "fixtures", "--out"],
        &["phase2", "--benchmark", "alfworld-seen", "--lm", "uniform", "--limit", "1", "--out"],
    ] {
        let output = xtask(&[command, &[dir.to_str().unwrap()]].concat());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{command:?}: {stderr}");
        assert!(stderr.contains("a file is there, not a folder"), "{command:?}: {stderr}");
    }
}

/// A record of a task outside the run's list (an edited file) is refused on resume, naming its
/// line, rather than counted with the run's.
#[test]
fn a_record_of_another_task_is_refused_on_resume() {
    let (_tmp_dir, dir) = out("foreign");
    let args = ["eval", "--agent", "planner", "--explorer", "systematic", "--benchmark", "virtualhome-eai", "--limit", "1", "--json"];
    let run = || xtask(&[&args[..], &["--out", dir.to_str().unwrap()]].concat());
    let output = run();
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    let records = std::path::PathBuf::from(summary["virtualhome-eai"]["records"].as_str().expect("the records' file"));
    let text = std::fs::read_to_string(&records).expect("records");
    let line = text.lines().next().expect("a record");
    let task = serde_json::from_str::<serde_json::Value>(line).expect("JSON")["task"].as_str().expect("a task").to_string();
    std::fs::write(&records, format!("{text}{}\n", line.replace(&format!("\"task\":\"{task}\""), "\"task\":\"zzz_9\""))).expect("writes");
    let output = run();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("{}:2: task zzz_9 is not one of the run's", records.display())), "{stderr}");
}
