//! [`CachedChat`]: a chat model whose replies are kept in a file, so that a request asked
//! again (the same messages, pictures, sampling, schema and model) is answered from the file
//! without running the model.
//!
//! What it is for: the paper's Phase II conditions plan from the *same* Phase I state. Phase I
//! with greedy decoding is a deterministic function of the replies, so a second condition that
//! explores with the same model sends the same requests in the same order; with the cache it
//! replays the first condition's exploration instead of recomputing it, and its records carry
//! the same Phase I (the tokens counted are the ones the model generated then).
//!
//! The key is the SHA-256 of the model's identity and the request's whole body
//! ([`ChatRequest::body`]: messages with their pictures, sampling, seed, schema, template
//! arguments). The identity is the caller's: it must change whenever the model would answer
//! differently (a local model: its file's digest; a server: its URL, the served model's name
//! and what the server lists under it, [`crate::served_models`]). A served model is
//! deterministic at temperature 0 only as far as the server is; the cache returns the reply
//! it saw.
//!
//! The file is JSON lines, one reply a line, appended whole and flushed; a line torn by a
//! killed process (the last one, without its newline) is passed over when the file is read and
//! cut off before the next append (a file refused for a damaged line is left as it was).
//! Processes may share a file (shards of one run): opening and each append hold the operating
//! system's exclusive lock on it (`flock`), so one never reads or cuts another's line half
//! written; a reply another process stored after this one opened the file is not seen by this
//! one, which asks its model and appends the same reply again (the later line wins on the next
//! open, with the same content).
//! Written by hand: a memo table over a JSON-lines file, which no crate offers in this shape.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::{Value, json};
use sha2::{Digest, Sha256};

use crate::client::ChatModel;
use crate::error::{ChatError, ChatErrorKind};
use crate::reply::{ChatReply, Usage};
use crate::request::{ChatRequest, JsonMode};

/// A reply as the file keeps it.
#[derive(Debug, Clone, PartialEq)]
struct Stored {
    text: String,
    reasoning: Option<String>,
    finish_reason: Option<String>,
    json_mode: Option<JsonMode>,
    usage: Usage,
}

/// A chat model behind a reply file (module documentation).
pub struct CachedChat {
    inner: Box<dyn ChatModel>,
    identity: String,
    path: PathBuf,
    file: File,
    replies: BTreeMap<String, Stored>,
    hits: u64,
    /// What the replies answered from the file cost the model when it first gave them.
    cached_usage: Usage,
}

impl std::fmt::Debug for CachedChat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CachedChat")
            .field("identity", &self.identity)
            .field("path", &self.path)
            .field("replies", &self.replies.len())
            .field("hits", &self.hits)
            .finish_non_exhaustive()
    }
}

/// Why a reply file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// The file or its folder could not be created, opened, locked or read.
    #[error("{path}: {source}")]
    Io {
        /// The reply file.
        path: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A whole line of the file is not a stored reply: not JSON, no `key` or `text`, a field of
    /// the wrong type, or an unknown `json_mode`.
    #[error("{path}:{line}: not a cached reply: {message}")]
    BadLine {
        /// The reply file.
        path: String,
        /// The line's number, from 1.
        line: usize,
        /// What is wrong with it (the JSON parser's message, or the field at fault).
        message: String,
    },
}

fn mode_name(mode: JsonMode) -> &'static str {
    match mode {
        JsonMode::Schema => "schema",
        JsonMode::Object => "object",
        JsonMode::Text => "text",
    }
}

fn mode_named(name: &str) -> Option<JsonMode> {
    [JsonMode::Schema, JsonMode::Object, JsonMode::Text].into_iter().find(|&m| mode_name(m) == name)
}

impl Stored {
    fn to_json(&self, key: &str) -> Value {
        json!({
            "key": key,
            "text": self.text,
            "reasoning": self.reasoning,
            "finish_reason": self.finish_reason,
            "json_mode": self.json_mode.map(mode_name),
            "usage": {
                "prompt_tokens": self.usage.prompt_tokens,
                "completion_tokens": self.usage.completion_tokens,
                "reasoning_tokens": self.usage.reasoning_tokens,
                "images": self.usage.images,
            },
        })
    }

    /// The key and the reply of one line.
    fn from_json(value: &Value) -> Result<(String, Stored), String> {
        let text_field = |name: &str| -> Result<Option<String>, String> {
            match value.get(name) {
                None | Some(Value::Null) => Ok(None),
                Some(Value::String(s)) => Ok(Some(s.clone())),
                Some(other) => Err(format!("\"{name}\" is {other}, not a string")),
            }
        };
        let count = |name: &str| -> Result<Option<u64>, String> {
            match value.get("usage").and_then(|u| u.get(name)) {
                None | Some(Value::Null) => Ok(None),
                Some(v) => v.as_u64().map(Some).ok_or_else(|| format!("\"usage.{name}\" is {v}, not a count")),
            }
        };
        let key = text_field("key")?.ok_or("no \"key\"")?;
        let text = text_field("text")?.ok_or("no \"text\"")?;
        let json_mode = match text_field("json_mode")? {
            None => None,
            Some(name) => Some(mode_named(&name).ok_or_else(|| format!("\"json_mode\" is \"{name}\""))?),
        };
        let usage = Usage {
            requests: 1,
            prompt_tokens: count("prompt_tokens")?.unwrap_or(0),
            completion_tokens: count("completion_tokens")?.unwrap_or(0),
            reasoning_tokens: count("reasoning_tokens")?,
            images: count("images")?.unwrap_or(0),
        };
        Ok((key, Stored { text, reasoning: text_field("reasoning")?, finish_reason: text_field("finish_reason")?, json_mode, usage }))
    }
}

impl CachedChat {
    /// `inner` behind the reply file `path` (created if absent, with its folder); `identity`
    /// names the model (module documentation).
    pub fn open(inner: Box<dyn ChatModel>, identity: &str, path: &Path) -> Result<CachedChat, CacheError> {
        let io = |source| CacheError::Io { path: path.display().to_string(), source };
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(io)?;
        }
        let mut file = OpenOptions::new().read(true).append(true).create(true).open(path).map_err(io)?;
        let mut bytes = Vec::new();
        file.lock().map_err(io)?;
        let read = file.read_to_end(&mut bytes);
        file.unlock().and(read).map_err(io)?;
        let replies = read_replies(path, bytes)?;
        Ok(CachedChat {
            inner,
            identity: identity.to_string(),
            path: path.to_path_buf(),
            file,
            replies,
            hits: 0,
            cached_usage: Usage::default(),
        })
    }

    /// The number of replies the file at `path` holds (0 where there is none yet), checked as
    /// [`CachedChat::open`] checks them, without opening it for writing or asking any model:
    /// for a caller that must ask a server who it is before it can open the file, so that a
    /// damaged file is named before a server that is down.
    pub fn check(path: &Path) -> Result<usize, CacheError> {
        match std::fs::read(path) {
            Ok(bytes) => Ok(read_replies(path, bytes)?.len()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(0),
            Err(source) => Err(CacheError::Io { path: path.display().to_string(), source }),
        }
    }

    /// Replies answered from the file so far.
    pub fn hits(&self) -> u64 {
        self.hits
    }

    /// Replies the file holds.
    pub fn len(&self) -> usize {
        self.replies.len()
    }

    /// Whether the file holds no reply yet.
    pub fn is_empty(&self) -> bool {
        self.replies.is_empty()
    }

    /// The request's key: SHA-256 of the identity and the request's body, in hex.
    pub fn key(&self, request: &ChatRequest) -> String {
        let body = request.body(&self.identity, JsonMode::Schema);
        let mut hasher = Sha256::new();
        hasher.update(self.identity.as_bytes());
        hasher.update([0]);
        hasher.update(body.to_string().as_bytes());
        hasher.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }
}

impl ChatModel for CachedChat {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let key = self.key(request);
        if let Some(stored) = self.replies.get(&key) {
            self.hits += 1;
            self.cached_usage.add(&stored.usage);
            return Ok(ChatReply {
                text: stored.text.clone(),
                reasoning: stored.reasoning.clone(),
                finish_reason: stored.finish_reason.clone(),
                usage: stored.usage,
                json_mode: stored.json_mode,
                attempts: 0,
                waited: Duration::ZERO,
                cached: true,
            });
        }
        let reply = self.inner.chat(request)?;
        let stored = Stored {
            text: reply.text.clone(),
            reasoning: reply.reasoning.clone(),
            finish_reason: reply.finish_reason.clone(),
            json_mode: reply.json_mode,
            usage: Usage { requests: 1, ..reply.usage },
        };
        let mut line = stored.to_json(&key).to_string();
        line.push('\n');
        // One write of the whole line, then flushed, under the file's lock: a kill leaves it whole
        // or torn at the end, and a torn end (this process's or another's) is dropped on the next
        // open or before the next append.
        let written = self.file.lock().and_then(|()| {
            let result =
                cut_torn_tail(&self.file, &self.path).and_then(|()| self.file.write_all(line.as_bytes())).and_then(|()| self.file.flush());
            self.file.unlock().and(result)
        });
        written.map_err(|e| ChatError {
            kind: ChatErrorKind::Model(format!("the reply cache {}: {e}", self.path.display())),
            url: self.inner.endpoint(),
            attempts: reply.attempts,
            elapsed: Duration::ZERO,
        })?;
        self.replies.insert(key, stored);
        Ok(reply)
    }

    fn endpoint(&self) -> String {
        self.inner.endpoint()
    }

    /// Every reply's usage, those from the file counted as the model spent them when it first
    /// answered (so a replayed run reports the tokens of the run it replays; [`CachedChat::hits`]
    /// says how many were replayed).
    fn usage(&self) -> Usage {
        let mut usage = self.inner.usage();
        usage.add(&self.cached_usage);
        usage
    }
}

/// The replies of a reply file's `bytes`, by key. A last line without its newline was cut
/// short by a killed writer: passed over here, and cut off before the next append
/// ([`cut_torn_tail`]), so that it starts a line of its own.
fn read_replies(path: &Path, mut bytes: Vec<u8>) -> Result<BTreeMap<String, Stored>, CacheError> {
    bytes.truncate(bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1));
    let mut replies = BTreeMap::new();
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let bad = |message: String| CacheError::BadLine { path: path.display().to_string(), line: i + 1, message };
        let value: Value = serde_json::from_slice(line).map_err(|e| bad(e.to_string()))?;
        let (key, stored) = Stored::from_json(&value).map_err(bad)?;
        replies.insert(key, stored);
    }
    Ok(replies)
}

/// Cuts a last line without its newline (a writer killed mid-line) off the file, so the next
/// append starts a line of its own; reads backwards from the end until a newline.
fn cut_torn_tail(file: &File, path: &Path) -> std::io::Result<()> {
    use std::os::unix::fs::FileExt;
    let len = file.metadata()?.len();
    let mut end = len;
    let mut block = [0u8; 4096];
    let mut whole = 0;
    while end > 0 {
        let start = end.saturating_sub(block.len() as u64);
        let part = &mut block[..(end - start) as usize];
        file.read_exact_at(part, start)?;
        if let Some(i) = part.iter().rposition(|&b| b == b'\n') {
            whole = start + i as u64 + 1;
            break;
        }
        end = start;
    }
    if whole < len {
        // Said, as a records file's torn line is: the reply it held is asked again.
        eprintln!("{}: cut off a reply cut short (a killed run); its request is asked again", path.display());
        file.set_len(whole)?;
    }
    Ok(())
}
