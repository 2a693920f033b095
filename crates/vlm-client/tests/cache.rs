//! `CachedChat`: a request asked again is answered from the reply file, without the model; the
//! file survives the process, a torn last line is dropped, and a damaged line is named.

use std::cell::Cell;
use std::path::PathBuf;
use std::rc::Rc;

use serde_json::json;
use vlm_client::{CacheError, CachedChat, ChatError, ChatModel, ChatReply, ChatRequest, Message, Sampling, Usage, chat_json};

/// A model that numbers its replies and counts the calls that reached it.
struct Counting {
    calls: Rc<Cell<u64>>,
}

impl ChatModel for Counting {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        self.calls.set(self.calls.get() + 1);
        let asked = request.messages.last().map(Message::joined_text).unwrap_or_default();
        let usage = Usage { requests: 1, prompt_tokens: asked.len() as u64, completion_tokens: 7, reasoning_tokens: None, images: 0 };
        Ok(ChatReply::local(format!("{{\"answer\": \"{asked} #{}\"}}", self.calls.get()), usage))
    }

    fn endpoint(&self) -> String {
        "local:counting".into()
    }

    fn usage(&self) -> Usage {
        Usage { requests: self.calls.get(), completion_tokens: 7 * self.calls.get(), ..Usage::default() }
    }
}

/// A reply file in a folder that does not exist yet, inside a temporary folder that is removed
/// when the returned guard is dropped, also when the test fails.
fn scratch(name: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::Builder::new().prefix("vlm-client-cache-").tempdir().expect("temporary folder");
    let path = tmp.path().join(name).join("replies.jsonl");
    (tmp, path)
}

fn ask(text: &str) -> ChatRequest {
    ChatRequest::new(vec![Message::system("Reply with JSON."), Message::user(text)]).with_sampling(Sampling::greedy(32))
}

fn cached(path: &std::path::Path, identity: &str) -> (CachedChat, Rc<Cell<u64>>) {
    let calls = Rc::new(Cell::new(0));
    (CachedChat::open(Box::new(Counting { calls: calls.clone() }), identity, path).expect("opens"), calls)
}

#[test]
fn a_request_asked_again_is_answered_from_the_file() {
    let (_tmp_path, path) = scratch("again");
    let (mut chat, calls) = cached(&path, "model sha256:aa");
    let first = chat.chat(&ask("where is the mug?")).expect("reply");
    assert!(!first.cached && first.attempts == 1);
    let again = chat.chat(&ask("where is the mug?")).expect("reply");
    assert_eq!(calls.get(), 1, "the second ask never reached the model");
    assert!(again.cached && again.attempts == 0);
    assert_eq!((again.text.as_str(), again.usage.prompt_tokens, again.usage.completion_tokens), (first.text.as_str(), 17, 7));
    // Usage counts the replayed reply as the model spent it first.
    assert_eq!(chat.usage().completion_tokens, 14);
    // Any change to the request is another request: the text, the sampling, the schema.
    chat.chat(&ask("where is the apple?")).expect("reply");
    chat.chat(&ask("where is the mug?").with_sampling(Sampling::greedy(33))).expect("reply");
    let schema = json!({"type": "object", "properties": {"answer": {"type": "string"}}, "required": ["answer"]});
    let json = chat_json(&mut chat, &ask("where is the mug?").with_json_schema(schema.clone())).expect("json");
    assert!(!json.reply.cached);
    assert_eq!(calls.get(), 4);
    assert_eq!((chat.hits(), chat.len()), (1, 4));

    // Another process: the file answers every request it holds; another model identity does not share them.
    let (mut reopened, calls) = cached(&path, "model sha256:aa");
    let replayed = chat_json(&mut reopened, &ask("where is the mug?").with_json_schema(schema)).expect("json");
    assert!(replayed.reply.cached);
    assert_eq!(replayed.value, json.value);
    assert_eq!(reopened.chat(&ask("where is the apple?")).expect("reply").text, "{\"answer\": \"where is the apple? #2\"}");
    assert_eq!(calls.get(), 0);
    let (mut other, calls) = cached(&path, "model sha256:bb");
    assert!(!other.chat(&ask("where is the mug?")).expect("reply").cached);
    assert_eq!(calls.get(), 1);
}

#[test]
fn a_torn_last_line_is_dropped_and_a_damaged_line_is_named() {
    let (_tmp_path, path) = scratch("torn");
    let (mut chat, _) = cached(&path, "m");
    chat.chat(&ask("one")).expect("reply");
    chat.chat(&ask("two")).expect("reply");
    drop(chat);
    // A writer killed in the middle of its line.
    let whole = std::fs::read_to_string(&path).expect("file");
    let second = whole.lines().nth(1).expect("two lines");
    std::fs::write(&path, format!("{}\n{}", whole.lines().next().expect("line"), &second[..second.len() / 2])).expect("tear");
    let (mut chat, calls) = cached(&path, "m");
    assert_eq!(chat.len(), 1);
    assert!(chat.chat(&ask("one")).expect("reply").cached);
    assert!(!chat.chat(&ask("two")).expect("reply").cached, "the torn reply is asked again");
    assert_eq!(calls.get(), 1);
    drop(chat);
    let text = std::fs::read_to_string(&path).expect("file");
    assert_eq!(text.lines().count(), 2, "the new line is a line of its own:\n{text}");
    assert!(text.lines().all(|l| serde_json::from_str::<serde_json::Value>(l).is_ok()));

    std::fs::write(&path, format!("{}\nnot json\n", text.lines().next().expect("line"))).expect("damage");
    let calls = Rc::new(Cell::new(0));
    let error = CachedChat::open(Box::new(Counting { calls }), "m", &path).expect_err("damaged");
    assert!(matches!(&error, CacheError::BadLine { line: 2, .. }), "{error}");
    assert!(error.to_string().starts_with(&format!("{}:2: ", path.display())), "{error}");
    // A refused file keeps its torn tail: nothing is cut until a reply is appended.
    let damaged = format!("not json\n{}", &second[..second.len() / 2]);
    std::fs::write(&path, &damaged).expect("damage");
    let calls = Rc::new(Cell::new(0));
    let error = CachedChat::open(Box::new(Counting { calls }), "m", &path).expect_err("damaged");
    assert!(matches!(&error, CacheError::BadLine { line: 1, .. }), "{error}");
    assert_eq!(std::fs::read_to_string(&path).expect("file"), damaged);
}

/// Two runs sharing one reply file (shards): a writer killed mid-line after both opened it
/// leaves a torn tail; the next append cuts it first, so the file stays whole lines and every
/// reply either run stored is read back on the next open.
#[test]
fn runs_sharing_a_file_keep_it_whole_lines() {
    let (_tmp_path, path) = scratch("shared");
    let (mut first, _) = cached(&path, "m");
    let (mut second, _) = cached(&path, "m");
    first.chat(&ask("one")).expect("reply");
    // A third writer killed in the middle of its line.
    let mut file = std::fs::OpenOptions::new().append(true).open(&path).expect("open");
    std::io::Write::write_all(&mut file, b"{\"key\":\"abc\",\"te").expect("tear");
    drop(file);
    second.chat(&ask("two")).expect("reply");
    first.chat(&ask("three")).expect("reply");
    drop((first, second));
    let text = std::fs::read_to_string(&path).expect("file");
    assert_eq!(text.lines().count(), 3, "{text}");
    assert!(text.lines().all(|l| serde_json::from_str::<serde_json::Value>(l).is_ok()), "{text}");
    let (mut reopened, calls) = cached(&path, "m");
    assert_eq!(reopened.len(), 3);
    for question in ["one", "two", "three"] {
        assert!(reopened.chat(&ask(question)).expect("reply").cached, "{question}");
    }
    assert_eq!(calls.get(), 0);
}
