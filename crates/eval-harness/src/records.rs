//! Records are data: one JSON line per finished task, in a file named by the run's
//! configuration, appended so that a killed run loses no finished task and resumes to
//! exactly what an uninterrupted run writes.
//!
//! - **Named by the configuration.** A run's configuration (any `Serialize` value: agent,
//!   model, every setting, seed, benchmark, subset) is written canonically (keys sorted) and
//!   hashed ([`config_hash`], the first 12 hex digits of its sha256). Records go to
//!   `<stem>-<hash>.jsonl`, the configuration beside them in `<stem>-<hash>.config.json`, and
//!   every record carries the hash in its `config` field. Runs that differ in any setting never
//!   share a file; a file whose configuration differs from the run's is refused
//!   ([`RecordError::ConfigMismatch`]).
//! - **Whole or absent.** [`RecordFile::append`] writes a record and its newline in one
//!   `write` on a file opened for appending, then `sync_data`: after a crash or `kill -9` the
//!   file ends with whole records, or with one record cut short — whose task runs again, and
//!   which [`RecordFile::settle`] cuts off once the run has checked the file (a file refused
//!   for other damage is left as it was). A complete line that is not a record of this configuration is never
//!   dropped silently: it is an error naming `file:line`.
//! - **Resume.** [`RecordFile::done`] lists the tasks already recorded; a run skips them. Each
//!   record carries its task's `index` in the run's task list, so shards and resumed runs can
//!   be put back in order.
//! - **Shards.** `--shard i/n` ([`Shard`]) runs the tasks whose index is `i-1` modulo `n`, into
//!   `<stem>-<hash>.shard-i-of-n.jsonl` (the configuration, and so the hash, is the same for
//!   every shard). [`merge`] joins shard files of one configuration into the file an unsharded
//!   run writes, in index order, and refuses mixed configurations, repeated tasks and a shard a
//!   run is still writing; [`RecordFile::check_unmerged`] refuses to resume a shard with tasks
//!   left once that file holds records, which would leave it short of them.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::{Map, Value};

/// Why records cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// A file or folder could not be created, read, written, locked or synced.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A line is not what it must be: a records line that is not UTF-8, not a JSON object, has
    /// no `task`, repeats a task, carries another configuration's hash or a field a report
    /// refuses; or a configuration file that is not JSON.
    #[error("{path}:{line}: {message}")]
    Bad {
        /// The file holding the line.
        path: PathBuf,
        /// The line, 1-based.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The configuration file beside the records holds another configuration than the run's.
    #[error(
        "{path}: these records were made with another configuration ({found}) than this run's ({expected}); \
         use another --out folder, or delete the file to start over"
    )]
    ConfigMismatch {
        /// The configuration file beside the records (`<stem>-<hash>.config.json`).
        path: PathBuf,
        /// The hash of this run's configuration ([`config_hash`]).
        expected: String,
        /// The hash of the configuration in the file.
        found: String,
    },
    /// Another process holds the record file's lock: a run of the same configuration is
    /// writing into the same folder, or [`merge`] is reading the file.
    #[error(
        "{path}: another run is writing these records now, or a merge is reading them (one run of a configuration per folder at a time); wait for it, or use another --out folder"
    )]
    Busy {
        /// The locked record file.
        path: PathBuf,
    },
    /// [`merge`] refused its shard files; the message names the file and the fault.
    #[error("{0}")]
    Merge(String),
    /// [`RecordFile::append`] was given a value that does not serialize to a JSON object with
    /// a string `task`; the message says what it lacks.
    #[error("a record must be a JSON object with a string `task`: {0}")]
    NotARecord(String),
    /// A shard with tasks left to run, beside the unsharded file of its run holding records
    /// ([`merge`]'s output, or a run without shards): resuming it would leave that file short
    /// of the tasks it adds, and that file is what reports, replays and CI read in place of
    /// the shards.
    #[error(
        "{path}: {left} task(s) of this shard are left to run, and {merged} beside it holds this run's records \
         (merged from its shards, or written by a run without --shard), which reports and replays read in place of the \
         shards: resuming the shard would leave that file short of them; resume without --shard (which appends the \
         missing tasks to that file), or move that file out of the folder, resume the shards and merge them again"
    )]
    Merged {
        /// The shard file.
        path: PathBuf,
        /// The merged file beside it (`<stem>-<hash>.jsonl`).
        merged: PathBuf,
        /// How many of the shard's tasks are not recorded yet.
        left: usize,
    },
    /// A run without shards whose file holds no record yet, beside shard files of the same
    /// run that hold records: it would run their tasks again, and the folder would then hold
    /// a file the shards disagree with (in their times), which reports refuse.
    #[error(
        "{path}: shard files of this run are beside it with records ({}) and it holds none: merge them first (`cargo xtask merge`; a run without --shard then resumes the merged file), or resume each with its --shard",
        shards.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    Unmerged {
        /// The unsharded record file.
        path: PathBuf,
        /// The shard files beside it that hold records.
        shards: Vec<PathBuf>,
    },
    /// [`RecordFile::settle`] or [`RecordFile::append`] on a file opened by
    /// [`RecordFile::check_only`]; nothing was written.
    #[error("{path}: opened to be checked only, not written")]
    CheckOnly {
        /// The record file.
        path: PathBuf,
    },
    /// [`RecordFile::append`] was given a task the file records already; nothing was written.
    #[error("{path}: task {task} is recorded already (a file holding a task twice cannot be resumed or reported)")]
    Duplicate {
        /// The record file.
        path: PathBuf,
        /// The task's name (its `task` field).
        task: String,
    },
}

/// Takes the operating system's advisory lock on `file` (`flock`; `shared`, or exclusive),
/// without waiting: `Ok(false)` where another handle holds a lock that excludes it. A file
/// system without locks counts as locked (runs go unguarded there, as before locks were taken).
fn try_lock(file: &File, path: &Path, shared: bool) -> Result<bool, RecordError> {
    let taken = if shared { file.try_lock_shared() } else { file.try_lock() };
    match taken {
        Ok(()) => Ok(true),
        Err(std::fs::TryLockError::WouldBlock) => Ok(false),
        Err(std::fs::TryLockError::Error(e)) if e.kind() == std::io::ErrorKind::Unsupported => Ok(true),
        Err(std::fs::TryLockError::Error(e)) => Err(io(path)(e)),
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io { path: path.to_path_buf(), source }
}

/// `value` as canonical JSON: object keys sorted at every level, no spaces.
pub fn canonical_json(value: &impl Serialize) -> String {
    let value = serde_json::to_value(value).unwrap_or(Value::Null);
    let mut out = String::new();
    write_sorted(&value, &mut out);
    out
}

/// Writes `value` with every object's keys in sorted order, whatever order its map keeps
/// (serde_json keeps insertion order when any crate of the build turns on `preserve_order`).
fn write_sorted(value: &Value, out: &mut String) {
    match value {
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            out.push('{');
            for (i, key) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&Value::from(key.as_str()).to_string());
                out.push(':');
                write_sorted(&map[key], out);
            }
            out.push('}');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_sorted(item, out);
            }
            out.push(']');
        }
        scalar => out.push_str(&scalar.to_string()),
    }
}

/// The first 12 hex digits of the sha256 of [`canonical_json`]`(config)`.
pub fn config_hash(config: &impl Serialize) -> String {
    use sha2::{Digest, Sha256};
    short_hex(&Sha256::digest(canonical_json(config).as_bytes()))
}

/// The first 12 hex digits of a digest: how records name configurations and task lists.
fn short_hex(digest: &[u8]) -> String {
    digest.iter().take(6).map(|b| format!("{b:02x}")).collect()
}

/// The digest of a run's task list that its configuration keeps (`tasks.ids_sha256`): the first
/// 12 hex digits of the sha256 of the ids in the run's order, each followed by a newline. A
/// configuration names the list, not only its length, so that an edited subset file is another
/// run; [`merge`] checks a whole run's records against it.
pub fn task_list_digest<'a>(ids: impl IntoIterator<Item = &'a str>) -> String {
    use sha2::{Digest, Sha256};
    let mut digest = Sha256::new();
    for id in ids {
        digest.update(id.as_bytes());
        digest.update(b"\n");
    }
    short_hex(&digest.finalize())
}

/// One of `count` shards (1-based `index`, `1 <= index <= count`, as [`str::parse`] checks):
/// the tasks whose position is `index - 1` modulo `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, 1-based.
    pub index: usize,
    /// How many shards the run is split into.
    pub count: usize,
}

impl Shard {
    /// Whether the task at `position` (0-based, in the run's task list) is this shard's; a
    /// shard outside `1 <= index <= count` selects none.
    pub fn selects(&self, position: usize) -> bool {
        self.count > 0 && self.index.checked_sub(1).is_some_and(|i| position % self.count == i)
    }

    fn suffix(&self) -> String {
        format!(".shard-{}-of-{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `i/n` with `1 <= i <= n`.
    fn from_str(text: &str) -> Result<Shard, String> {
        let bad = || format!("`{text}`: give the shard as i/n with 1 <= i <= n");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count) = (i.trim().parse::<usize>().map_err(|_| bad())?, n.trim().parse::<usize>().map_err(|_| bad())?);
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// The records of one configuration (and shard), open for appending.
#[derive(Debug)]
pub struct RecordFile {
    path: PathBuf,
    /// For a shard file, the file its run's shards merge into (`<stem>-<hash>.jsonl`).
    merged: Option<PathBuf>,
    hash: String,
    records: Vec<Map<String, Value>>,
    /// The line of each record, 1-based, and the lines of the file.
    lines: Vec<usize>,
    line_count: usize,
    done: BTreeSet<String>,
    /// `None` for a file opened to check only ([`RecordFile::check_only`]) that is not there.
    file: Option<File>,
    /// Opened to check only: nothing is written, settled or appended.
    check_only: bool,
    /// What [`RecordFile::settle`] cuts off: a record cut short after the whole lines, or, with
    /// `fresh`, every earlier record.
    cut: Option<Cut>,
}

/// The end of a record file that [`RecordFile::settle`] cuts off.
#[derive(Debug, Clone, Copy)]
struct Cut {
    /// Where the kept bytes end.
    keep: u64,
    /// The file's length as read: the cut is made only while it still has this length.
    length: u64,
    /// Every earlier record (`fresh`), not a last one cut short.
    fresh: bool,
}

impl RecordFile {
    /// Opens (creating) `<dir>/<stem>-<hash>[.shard-i-of-n].jsonl` for `config`: checks or
    /// writes the configuration file beside it and reads the records already there, passing
    /// over a last record cut short (cut off by [`RecordFile::settle`], once the caller has no
    /// more reason to refuse the file). `fresh` starts the configuration over: the earlier
    /// records are not read, and [`RecordFile::settle`] deletes them (so a run refused before
    /// it settles leaves them as they were).
    pub fn open(dir: &Path, stem: &str, config: &impl Serialize, shard: Option<Shard>, fresh: bool) -> Result<RecordFile, RecordError> {
        RecordFile::read(dir, stem, config, shard, fresh, false)
    }

    /// What [`RecordFile::open`] would read and refuse, creating and changing nothing: a
    /// configuration file of another run is refused, the records are read (none with `fresh`,
    /// or where the file is not there yet), and a run writing them is [`RecordError::Busy`];
    /// the lock is released with the value. The value answers [`RecordFile::check_tasks`],
    /// [`RecordFile::check_unmerged`] and the readers, but settles and appends nothing
    /// ([`RecordError::CheckOnly`]): for a run to check every file it will write before it
    /// starts the first, leaving nothing behind if it is refused.
    pub fn check_only(
        dir: &Path,
        stem: &str,
        config: &impl Serialize,
        shard: Option<Shard>,
        fresh: bool,
    ) -> Result<RecordFile, RecordError> {
        RecordFile::read(dir, stem, config, shard, fresh, true)
    }

    fn read(
        dir: &Path,
        stem: &str,
        config: &impl Serialize,
        shard: Option<Shard>,
        fresh: bool,
        check_only: bool,
    ) -> Result<RecordFile, RecordError> {
        if !check_only {
            std::fs::create_dir_all(dir).map_err(io(dir))?;
        }
        let hash = config_hash(config);
        let name = format!("{stem}-{hash}");
        let config_path = dir.join(format!("{name}.config.json"));
        let config_text = serde_json::to_string_pretty(&serde_json::to_value(config).unwrap_or(Value::Null)).unwrap_or_default() + "\n";
        match std::fs::read_to_string(&config_path) {
            // Compared as the hash compares them (canonical JSON): the text's key order depends
            // on serde_json's `preserve_order`, which another build of the same code may lack.
            Ok(existing) => {
                let found = match serde_json::from_str::<Value>(&existing) {
                    Ok(value) => config_hash(&value),
                    Err(e) => {
                        let message = format!("not a configuration: {e} (delete the file, and its records, to start over)");
                        return Err(RecordError::Bad { path: config_path, line: e.line(), message });
                    }
                };
                if found != hash {
                    return Err(RecordError::ConfigMismatch { path: config_path, expected: hash, found });
                }
            }
            // Written whole or not at all (a file cut short by a crash would refuse every
            // later open as a mismatch): a synced temporary file renamed into place.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if !check_only {
                    write_whole(&config_path, config_text.as_bytes())?;
                }
            }
            Err(e) => return Err(io(&config_path)(e)),
        }
        let path = dir.join(format!("{name}{}.jsonl", shard.map(|s| s.suffix()).unwrap_or_default()));
        let mut file = if check_only {
            match File::open(&path) {
                Ok(file) => Some(file),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) => return Err(io(&path)(e)),
            }
        } else {
            Some(OpenOptions::new().create(true).read(true).append(true).open(&path).map_err(io(&path))?)
        };
        // One writer per record file: two runs of one configuration into one folder would each
        // run the tasks the other has not finished yet and record them twice. The lock is the
        // operating system's advisory file lock (`flock`), held while this value lives and
        // released when the process ends, however it ends, so a killed run leaves none behind.
        // A check takes it shared: it sees a writer as well, and on NFS (locks emulated by
        // fcntl) an exclusive lock needs a handle open for writing.
        if let Some(file) = &file
            && !try_lock(file, &path, check_only)?
        {
            return Err(RecordError::Busy { path });
        }
        // With `fresh`, the earlier records are neither read nor (until `settle`) deleted.
        let mut bytes = Vec::new();
        let fresh_cut = match file.as_mut() {
            Some(file) if fresh => {
                let length = file.metadata().map_err(io(&path))?.len();
                (length > 0).then_some(Cut { keep: 0, length, fresh: true })
            }
            Some(file) => {
                file.read_to_end(&mut bytes).map_err(io(&path))?;
                None
            }
            None => None,
        };
        // A last line without its newline is a record cut short by a crash: its task runs
        // again, and the line is cut off by `settle` (not here: a file the run then refuses,
        // here or in `check_tasks`, is left as it was).
        let (text, torn) = whole_lines(&path, bytes)?;
        let (lines, records): (Vec<usize>, Vec<Map<String, Value>>) = parse_records(&path, &text, Some(&hash))?.into_iter().unzip();
        let cut =
            fresh_cut.or_else(|| (torn > 0).then_some(Cut { keep: text.len() as u64, length: (text.len() + torn) as u64, fresh: false }));
        let done = records.iter().filter_map(|r| r.get("task").and_then(Value::as_str).map(str::to_string)).collect();
        let line_count = text.lines().count();
        let merged = shard.map(|_| dir.join(format!("{name}.jsonl")));
        Ok(RecordFile { path, merged, hash, records, lines, line_count, done, file, check_only, cut })
    }

    /// Cuts off a last record cut short by a crash, saying so, or, opened `fresh`, deletes the
    /// earlier records: for the caller to call once it has checked the file (`check_tasks`,
    /// `check_unmerged`, its own reading of the records), so that a file it refuses is left as
    /// it was; [`RecordFile::append`] settles first too. Where a line cut short is no longer
    /// the file's last (another writer, on a file system without locks), it is not cut: every
    /// later open names it. A file opened to check only is [`RecordError::CheckOnly`].
    pub fn settle(&mut self) -> Result<(), RecordError> {
        if self.check_only {
            return Err(RecordError::CheckOnly { path: self.path.clone() });
        }
        let Some(cut) = self.cut.take() else { return Ok(()) };
        let Some(file) = self.file.as_mut() else { return Ok(()) };
        if !cut.fresh && file.metadata().map_err(io(&self.path))?.len() != cut.length {
            return Ok(());
        }
        file.set_len(cut.keep).map_err(io(&self.path))?;
        file.seek(SeekFrom::End(0)).map_err(io(&self.path))?;
        if !cut.fresh {
            eprintln!("{}: cut off a record cut short (a killed run); its task runs again", self.path.display());
        }
        Ok(())
    }

    /// Refuses a record whose task is not among `tasks` (the run's list), naming its line: a
    /// record no run of this configuration can have written, which a report would count.
    pub fn check_tasks(&self, tasks: &BTreeSet<&str>) -> Result<(), RecordError> {
        for (record, &line) in self.records.iter().zip(&self.lines) {
            let task = record.get("task").and_then(Value::as_str).unwrap_or_default();
            if !tasks.contains(task) {
                let message = format!("task {task} is not one of the run's {} tasks", tasks.len());
                return Err(RecordError::Bad { path: self.path.clone(), line, message });
            }
        }
        Ok(())
    }

    /// Refuses to resume a shard file, `left` of whose tasks are still to run, once the
    /// unsharded file of its run beside it holds records ([`RecordError::Merged`]: [`merge`]
    /// made it, or a run without shards wrote it): that file would then miss what the shard
    /// adds, while reports and replays read the shard through it. A shard with nothing left
    /// to run, a shard beside an empty or absent unsharded file, and an unsharded file holding
    /// records pass.
    ///
    /// The other way round, an unsharded file that holds no record yet is refused beside shard
    /// files of its run that hold records ([`RecordError::Unmerged`]): they are to be merged
    /// into it first.
    pub fn check_unmerged(&self, left: usize) -> Result<(), RecordError> {
        match &self.merged {
            Some(merged) if left > 0 && std::fs::metadata(merged).is_ok_and(|m| m.len() > 0) => {
                Err(RecordError::Merged { path: self.path.clone(), merged: merged.clone(), left })
            }
            None if self.records.is_empty() => {
                let shards = self.shards_beside();
                if shards.is_empty() { Ok(()) } else { Err(RecordError::Unmerged { path: self.path.clone(), shards }) }
            }
            _ => Ok(()),
        }
    }

    /// The shard files of this (unsharded) file's run beside it that hold records, sorted.
    fn shards_beside(&self) -> Vec<PathBuf> {
        let (Some(dir), Some(name)) = (self.path.parent(), self.path.file_name().and_then(|n| n.to_str())) else { return Vec::new() };
        let prefix = format!("{}.shard-", name.strip_suffix(".jsonl").unwrap_or(name));
        let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
        let mut shards: Vec<PathBuf> = entries
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with(&prefix) && n.ends_with(".jsonl")))
            .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.len() > 0))
            .collect();
        shards.sort();
        shards
    }

    /// The record file (`<dir>/<stem>-<hash>[.shard-i-of-n].jsonl`).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The configuration's hash, stored in every record.
    pub fn hash(&self) -> &str {
        &self.hash
    }

    /// The tasks recorded so far.
    pub fn done(&self) -> &BTreeSet<String> {
        &self.done
    }

    /// Every record, in the file's order.
    pub fn records(&self) -> &[Map<String, Value>] {
        &self.records
    }

    /// Appends `record` (a JSON object with a string `task`), adding `index` (the task's
    /// position in the run's task list) and `config` (the hash), in one write, synced. A task
    /// recorded already is refused ([`RecordError::Duplicate`]) and nothing is written: a file
    /// holding a task twice is refused by every later open and report.
    pub fn append(&mut self, index: usize, record: &impl Serialize) -> Result<(), RecordError> {
        let Value::Object(mut object) = serde_json::to_value(record).map_err(|e| RecordError::NotARecord(e.to_string()))? else {
            return Err(RecordError::NotARecord("not an object".into()));
        };
        let task = object.get("task").and_then(Value::as_str).ok_or_else(|| RecordError::NotARecord("no `task`".into()))?.to_string();
        if self.done.contains(&task) {
            return Err(RecordError::Duplicate { path: self.path.clone(), task });
        }
        object.insert("index".into(), Value::from(index));
        object.insert("config".into(), Value::from(self.hash.clone()));
        let mut line = Value::Object(object.clone()).to_string();
        line.push('\n');
        self.settle()?;
        let Some(file) = self.file.as_mut() else { return Err(RecordError::CheckOnly { path: self.path.clone() }) };
        file.write_all(line.as_bytes()).map_err(io(&self.path))?;
        file.sync_data().map_err(io(&self.path))?;
        self.done.insert(task);
        self.line_count += 1;
        self.lines.push(self.line_count);
        self.records.push(object);
        Ok(())
    }
}

/// Writes `path` whole or not at all: `bytes` into a temporary file beside it, synced, then
/// renamed over `path`, and the folder synced so that the rename survives a crash. The
/// temporary file is this process's own, so that shards started together, each writing the
/// same configuration file, never write into one temporary file.
fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or_default();
    let partial = path.with_extension(format!("{extension}.{}.partial", std::process::id()));
    let mut file = File::create(&partial).map_err(io(&partial))?;
    file.write_all(bytes).map_err(io(&partial))?;
    file.sync_all().map_err(io(&partial))?;
    std::fs::rename(&partial, path).map_err(io(path))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        // Not every platform opens a folder as a file; the rename stands either way.
        if let Ok(dir) = File::open(dir) {
            let _ = dir.sync_all();
        }
    }
    Ok(())
}

/// The whole lines of a records file's `bytes` as text, and the length in bytes of a last line
/// cut short (0 when the file ends with a newline). The cut is made on the bytes: a record cut
/// short by a killed run can end inside a character, which must not make the whole lines
/// before it unreadable. A whole line that is not UTF-8 is an error naming it.
pub(crate) fn whole_lines(path: &Path, mut bytes: Vec<u8>) -> Result<(String, usize), RecordError> {
    let whole = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let torn = bytes.len() - whole;
    bytes.truncate(whole);
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        RecordError::Bad { path: path.to_path_buf(), line, message: "not UTF-8 text".into() }
    })?;
    Ok((text, torn))
}

/// A record and the line (1-based) it was read from.
pub(crate) type LineRecord = (usize, Map<String, Value>);

/// The records of a JSONL file, each with its line (1-based): every non-empty line an object
/// with a `task`, and, with `hash`, that configuration.
pub(crate) fn parse_records(path: &Path, text: &str, hash: Option<&str>) -> Result<Vec<LineRecord>, RecordError> {
    let mut records = Vec::new();
    let mut seen = BTreeSet::new();
    for (number, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let bad = |message: String| RecordError::Bad { path: path.to_path_buf(), line: number + 1, message };
        let record: Map<String, Value> = serde_json::from_str(line).map_err(|e| bad(format!("not a JSON object: {e}")))?;
        let task = record.get("task").and_then(Value::as_str).ok_or_else(|| bad("no `task` field".into()))?;
        if let Some(hash) = hash {
            let found = record.get("config").and_then(Value::as_str).unwrap_or("none");
            if found != hash {
                return Err(bad(format!("a record of configuration {found}, in the file of {hash}")));
            }
        }
        if !seen.insert(task.to_string()) {
            return Err(bad(format!("task {task} is recorded twice")));
        }
        records.push((number + 1, record));
    }
    Ok(records)
}

/// What [`merge`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Merged {
    /// The merged file, `<stem>-<hash>.jsonl` beside the shards.
    pub path: PathBuf,
    /// How many records it holds.
    pub records: usize,
    /// The configuration's hash, the `config` field of every record.
    pub config: String,
    /// The run's task count from the configuration beside the shards; `None` when it gives
    /// none (a configuration written before the count was), so completeness went unchecked.
    pub expected: Option<u64>,
}

/// Joins shard files (`<stem>-<hash>.shard-i-of-n.jsonl`) of one configuration into
/// `<stem>-<hash>.jsonl` beside them, records in `index` order. Refused: files of different
/// configurations (by their names or their records), a record whose `index` is not its
/// shard's, a task in two files, a shard of the run not given, a target file that already holds
/// records, a record a report would refuse (`report::load`'s checks, naming the shard's line),
/// shards without their run's configuration beside them (`<stem>-<hash>.config.json`, whose
/// hash must be the records'), an index past the run's task count (`tasks.count`), and, unless
/// `partial`, a run short of tasks: fewer records than that count are shards not run to their
/// end (resume them, or merge a `--limit` run with `partial`).
pub fn merge(shards: &[PathBuf], partial: bool) -> Result<Merged, RecordError> {
    let first = shards.first().ok_or_else(|| RecordError::Merge("no shard files given".into()))?;
    // Each file's `<stem>-<hash>` and shard, from its name.
    let named: Vec<(String, Shard)> = shards
        .iter()
        .map(|path| {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            name.strip_suffix(".jsonl")
                .and_then(|n| n.rsplit_once(".shard-"))
                .and_then(|(base, i_of_n)| Some((base.to_string(), i_of_n.replace("-of-", "/").parse::<Shard>().ok()?)))
                .ok_or_else(|| RecordError::Merge(format!("{}: not a shard file (`<stem>-<hash>.shard-i-of-n.jsonl`)", path.display())))
        })
        .collect::<Result<_, _>>()?;
    let base = named[0].0.as_str();
    // Each record with its line as the shard holds it: the merged file is written from the lines,
    // not from the parsed values, so it holds the bytes the run wrote (serde_json reads a float
    // to the nearest double only within an ulp or so, and writing it again could change it).
    let mut all: Vec<(PathBuf, Map<String, Value>, String)> = Vec::new();
    let mut config: Option<String> = None;
    // Each shard's file, locked (shared) until the merged file is written: a shard a run is
    // still writing would go on past the merge, and no run starts one while it is merged.
    let mut locked = Vec::with_capacity(shards.len());
    // Every file is a shard of one run: the name's `<stem>-<hash>` is the first's.
    for (path, (file_base, shard)) in shards.iter().zip(&named) {
        if file_base.as_str() != base {
            return Err(RecordError::Merge(format!(
                "{}: a shard of {file_base}, not of {base}: shards of different runs do not merge",
                path.display()
            )));
        }
        let mut file = File::open(path).map_err(io(path))?;
        if !try_lock(&file, path, true)? {
            return Err(RecordError::Merge(format!("{}: a run is still writing this shard; merge once it has ended", path.display())));
        }
        // Read through the locked handle: where locks are the process's (fcntl, as on NFS),
        // closing another handle to the file would drop this one's.
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes).map_err(io(path))?;
        locked.push(file);
        let (text, torn) = whole_lines(path, bytes)?;
        if torn > 0 {
            return Err(RecordError::Merge(format!("{}: its last record is cut short; resume that shard first", path.display())));
        }
        let lines: Vec<&str> = text.lines().collect();
        for (line, record) in parse_records(path, &text, None)? {
            // What a report reads of it, checked here: a merged file passes on no record the
            // report would refuse, and the error names the shard's line, not the merged file's.
            crate::report::check_record(path, line, &record)?;
            let hash = record.get("config").and_then(Value::as_str).unwrap_or("none").to_string();
            match &config {
                None => config = Some(hash),
                Some(expected) if *expected != hash => {
                    return Err(RecordError::Merge(format!(
                        "{}: records of configuration {hash}, others of {expected}: shards of different runs do not merge",
                        path.display()
                    )));
                }
                Some(_) => {}
            }
            let index = record.get("index").and_then(Value::as_u64);
            if !index.is_some_and(|i| shard.selects(i as usize)) {
                return Err(RecordError::Merge(format!(
                    "{}: task {} has index {}, which is not shard {} of {}'s",
                    path.display(),
                    record.get("task").and_then(Value::as_str).unwrap_or_default(),
                    index.map_or("none".to_string(), |i| i.to_string()),
                    shard.index,
                    shard.count
                )));
            }
            all.push((path.clone(), record, lines[line - 1].trim().to_string()));
        }
    }
    let config = config.ok_or_else(|| RecordError::Merge("the shard files hold no records".into()))?;
    if !base.ends_with(&format!("-{config}")) {
        return Err(RecordError::Merge(format!("the records are of configuration {config}, the files' names of {base}")));
    }
    // Every shard of the run, once: a merged file short of a shard would pass for the whole run.
    let numbers: Vec<Shard> = named.iter().map(|(_, shard)| *shard).collect();
    let count = numbers[0].count;
    if let Some(other) = numbers.iter().find(|s| s.count != count) {
        return Err(RecordError::Merge(format!("shards of {count} and of {} given: one run's shards all have the same n", other.count)));
    }
    // The run's configuration beside the shards, as `eval` wrote it: the records' (its hash),
    // and, where it gives one, the run's task count: fewer records are shards that did not
    // finish, which a merged file would pass off as the whole run; an index past it is no
    // task of the run; a shard that selects none of its tasks ran nothing and wrote no file.
    let config_path = first.with_file_name(format!("{base}.config.json"));
    let text = std::fs::read_to_string(&config_path).map_err(|e| {
        RecordError::Merge(format!("{}: cannot read the run's configuration beside the shards: {e}", config_path.display()))
    })?;
    let written: Value = serde_json::from_str(&text)
        .map_err(|e| RecordError::Merge(format!("{}:{}:{}: not JSON: {e}", config_path.display(), e.line(), e.column().max(1))))?;
    if config_hash(&written) != config {
        return Err(RecordError::Merge(format!(
            "{}: the configuration {} beside the shards, whose records are of {config}",
            config_path.display(),
            config_hash(&written)
        )));
    }
    let expected = written.pointer("/tasks/count").and_then(Value::as_u64);
    let selects_any = |index: usize| expected.is_none_or(|n| (0..n as usize).any(|i| Shard { index, count }.selects(i)));
    let missing: Vec<String> =
        (1..=count).filter(|i| !numbers.iter().any(|s| s.index == *i) && selects_any(*i)).map(|i| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(RecordError::Merge(format!(
            "shard(s) {} of {count} not given: the merged file is the whole run's, so every shard is needed",
            missing.join(", ")
        )));
    }
    let mut seen: BTreeMap<&str, &Path> = BTreeMap::new();
    for (path, record, _) in &all {
        let task = record.get("task").and_then(Value::as_str).unwrap_or_default();
        if let Some(other) = seen.insert(task, path) {
            let files = if other == path.as_path() {
                format!("{} is given twice", path.display())
            } else {
                format!("{} and {}", other.display(), path.display())
            };
            return Err(RecordError::Merge(format!("task {task} is in two shard files: {files}")));
        }
    }
    if let Some(count) = expected
        && let Some((path, record, _)) = all.iter().find(|(_, r, _)| r.get("index").and_then(Value::as_u64).is_some_and(|i| i >= count))
    {
        return Err(RecordError::Merge(format!(
            "{}: task {} has index {}, past the run's {count} tasks",
            path.display(),
            record.get("task").and_then(Value::as_str).unwrap_or_default(),
            record.get("index").unwrap_or(&Value::Null)
        )));
    }
    let mut all: Vec<(Map<String, Value>, String)> = all.into_iter().map(|(_, record, line)| (record, line)).collect();
    if let Some(expected) = expected
        && (all.len() as u64) < expected
        && !partial
    {
        let short: Vec<String> = numbers
            .iter()
            .filter_map(|shard| {
                let want = (0..expected as usize).filter(|&i| shard.selects(i)).count();
                let have =
                    all.iter().filter(|(r, _)| r.get("index").and_then(Value::as_u64).is_some_and(|i| shard.selects(i as usize))).count();
                (have < want).then(|| format!("shard {} of {} has {have} of its {want}", shard.index, shard.count))
            })
            .collect();
        return Err(RecordError::Merge(format!(
            "{} of the run's {expected} tasks recorded ({}): resume the shards to their end, or merge a shorter (`--limit`) run with --partial",
            all.len(),
            short.join(", ")
        )));
    }
    all.sort_by_key(|(r, _)| r.get("index").and_then(Value::as_u64).unwrap_or(u64::MAX));
    // A whole run's tasks, in its order, are the list its configuration names (a record whose
    // task was edited, or filed under another run's name, would pass for one of the run's).
    if let Some(named) = written.pointer("/tasks/ids_sha256").and_then(Value::as_str)
        && expected == Some(all.len() as u64)
    {
        let found = task_list_digest(all.iter().map(|(r, _)| r.get("task").and_then(Value::as_str).unwrap_or_default()));
        if found != named {
            return Err(RecordError::Merge(format!(
                "the records' tasks, in their order, are not the run's: their list's digest is {found}, the configuration's {named} ({})",
                config_path.display()
            )));
        }
    }
    let target = first.with_file_name(format!("{base}.jsonl"));
    // The target locked (made if need be) before it is looked at: an empty one may be a run
    // without shards that has not recorded its first task yet, whose file the merged one would
    // be renamed over, and none starts writing it until the merge is done.
    let existing = OpenOptions::new().create(true).truncate(false).write(true).open(&target).map_err(io(&target))?;
    if !try_lock(&existing, &target, false)? {
        return Err(RecordError::Merge(format!("{}: a run is writing it; merge once it has ended", target.display())));
    }
    if existing.metadata().map_err(io(&target))?.len() > 0 {
        return Err(RecordError::Merge(format!("{}: already holds records; move it away to merge into it", target.display())));
    }
    locked.push(existing);
    let text: String = all.iter().map(|(_, line)| format!("{line}\n")).collect();
    write_whole(&target, text.as_bytes())?;
    drop(locked);
    Ok(Merged { path: target, records: all.len(), config, expected })
}
