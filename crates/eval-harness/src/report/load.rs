//! Reading record files for a report: each `<stem>-<hash>[.shard-i-of-n].jsonl` with the
//! `<stem>-<hash>.config.json` beside it, every line checked (a record of that configuration,
//! a string `task`, a boolean `success`, a known `terminal` and `attribution`, counts that are
//! whole numbers, a duration, fractions and objects where present), any fault an error naming
//! the file, the line and the field.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use super::ReportError;
use crate::records::{RecordError, parse_records};

/// One record and the line it was read from (1-based).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// The line of the file, 1-based.
    pub line: usize,
    /// The record's JSON object, as read.
    pub fields: Map<String, Value>,
}

/// The records of one file and the configuration they were made with.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSet {
    /// The file, as given.
    pub path: PathBuf,
    /// The configuration (`.config.json`): agent, benchmark, model, mode, seed, ...
    pub config: Map<String, Value>,
    /// Its hash, the `config` field of every record.
    pub hash: String,
    /// The records, in the file's order.
    pub records: Vec<Record>,
    /// What was left out, and why (a last line cut short by a run in progress or killed).
    pub warnings: Vec<String>,
}

impl RecordSet {
    /// The file name without `.jsonl` and without a shard suffix: `<stem>-<hash>`.
    pub fn stem(&self) -> String {
        record_stem(&self.path)
    }

    /// Whether the file is one shard of a run (`.shard-i-of-n.jsonl`).
    pub fn is_shard(&self) -> bool {
        self.path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.contains(".shard-"))
    }

    /// A string field of the configuration.
    pub fn config_str(&self, key: &str) -> Option<&str> {
        self.config.get(key).and_then(Value::as_str)
    }
}

/// The terminal mechanisms a record may name (`behaviour::Terminal`, kebab-case).
pub const TERMINALS: [&str; 5] = ["success", "grounding", "interaction-limit", "model-done", "search-budget"];
/// The failure classes a record may name (`attribution`; null for a success).
pub const ATTRIBUTIONS: [&str; 4] = ["representation", "search", "grounding", "goal"];

fn record_stem(path: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let name = name.strip_suffix(".jsonl").unwrap_or(name);
    name.split(".shard-").next().unwrap_or(name).to_string()
}

/// The record files named by `arguments`: a file as itself, a folder as the `*.jsonl` files
/// directly inside it (sorted). A file named twice (itself and through its folder, or under
/// two spellings of its path) is read once, where its first naming puts it.
pub fn record_paths(arguments: &[PathBuf]) -> Result<Vec<PathBuf>, ReportError> {
    let mut paths = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    let mut push = |paths: &mut Vec<PathBuf>, path: PathBuf| {
        if seen.insert(std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone())) {
            paths.push(path);
        }
    };
    for argument in arguments {
        if argument.is_dir() {
            let entries = std::fs::read_dir(argument).map_err(|source| RecordError::Io { path: argument.clone(), source })?;
            let mut found: Vec<PathBuf> =
                entries.flatten().map(|e| e.path()).filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "jsonl")).collect();
            if found.is_empty() {
                return Err(ReportError::NoRecords(format!("{}: no `*.jsonl` record files in this folder", argument.display())));
            }
            found.sort();
            for path in found {
                push(&mut paths, path);
            }
        } else {
            push(&mut paths, argument.clone());
        }
    }
    if paths.is_empty() {
        return Err(ReportError::NoRecords("no record files given".into()));
    }
    Ok(paths)
}

/// `sets` without the files that hold no record yet (a run that has not finished its first
/// task) and without the shard files whose merged file (`cargo xtask merge`) is among them,
/// with a note for each one left out: a folder holds both after a merge, and the merged file
/// holds the shards' records (the same `<stem>-<hash>`, so the same configuration). A shard
/// record that the merged file lacks, or holds otherwise (a shard written after the merge),
/// is an error that asks for the merge again. An unsharded file with no record is no merged
/// file.
pub fn without_merged_shards(sets: &[RecordSet]) -> Result<(Vec<RecordSet>, Vec<String>), ReportError> {
    let mut kept = Vec::with_capacity(sets.len());
    let mut notes = Vec::new();
    for set in sets {
        if set.records.is_empty() {
            notes.push(format!("{}: no record yet", set.path.display()));
            continue;
        }
        let merged = |m: &&RecordSet| set.is_shard() && !m.is_shard() && m.stem() == set.stem() && !m.records.is_empty();
        let Some(whole) = sets.iter().find(merged) else {
            kept.push(set.clone());
            continue;
        };
        let task = |r: &Record| r.fields.get("task").and_then(Value::as_str).unwrap_or_default().to_string();
        let held: BTreeMap<String, &Record> = whole.records.iter().map(|r| (task(r), r)).collect();
        for record in &set.records {
            if held.get(&task(record)).is_none_or(|m| m.fields != record.fields) {
                let message = format!(
                    "task {} is not in the merged file {} as it is here (a shard written after the merge, or the merged file started over with --fresh): move the merged file away, then merge the shards again",
                    task(record),
                    whole.path.display()
                );
                return Err(RecordError::Bad { path: set.path.clone(), line: record.line, message }.into());
            }
        }
        notes.push(format!("{}: its records are those of the merged {}", set.path.display(), whole.path.display()));
    }
    Ok((kept, notes))
}

/// Reads the record file at `path` and the configuration beside it.
pub fn load(path: &Path) -> Result<RecordSet, ReportError> {
    if path.extension().is_none_or(|e| e != "jsonl") {
        return Err(ReportError::NoRecords(format!(
            "{}: not a record file; record files end in `.jsonl`, with the `.config.json` that `cargo xtask eval` writes beside them",
            path.display()
        )));
    }
    // A records file that is not there is said so first (not its configuration's absence).
    std::fs::metadata(path).map_err(|source| RecordError::Io { path: path.to_path_buf(), source })?;
    let config_path = path.with_file_name(format!("{}.config.json", record_stem(path)));
    let config_fault = |reason: String| ReportError::Config { path: path.to_path_buf(), config: config_path.clone(), reason };
    let config_text = std::fs::read_to_string(&config_path).map_err(|e| config_fault(format!("cannot read it: {e}")))?;
    let config: Map<String, Value> =
        serde_json::from_str(&config_text).map_err(|e| config_fault(format!("not a JSON object: {e} (line {})", e.line())))?;
    for key in ["agent", "benchmark"] {
        if !config.get(key).is_some_and(Value::is_string) {
            return Err(config_fault(format!("no string `{key}`")));
        }
    }
    // The hash every record of this configuration carries (`records::config_hash`).
    let expected = crate::records::config_hash(&Value::Object(config.clone()));
    let bytes = std::fs::read(path).map_err(|source| RecordError::Io { path: path.to_path_buf(), source })?;
    let (text, torn) = crate::records::whole_lines(path, bytes)?;
    let mut warnings = Vec::new();
    if torn > 0 {
        let line = text.lines().count() + 1;
        warnings.push(format!("{}:{line}: a record cut short (a run in progress, or killed) is left out", path.display()));
    }
    let text = text.as_str();
    let parsed = parse_records(path, text, None)?;
    let mut records = Vec::with_capacity(parsed.len());
    for (line, fields) in parsed {
        let found = fields.get("config").and_then(Value::as_str).unwrap_or("none");
        if found != expected {
            // The file's name carries the hash of the configuration it was made with: where the
            // records agree with it, the configuration file is the one that changed.
            let message = if record_stem(path).ends_with(&format!("-{found}")) {
                format!(
                    "a record of configuration {found}, as the file's name says, but the configuration {} beside it is another ({expected}): edited after the run?",
                    config_path.display()
                )
            } else {
                format!("a record of configuration {found}, beside the configuration {} ({expected})", config_path.display())
            };
            return Err(RecordError::Bad { path: path.to_path_buf(), line, message }.into());
        }
        check(path, line, &fields)?;
        // A record of a task outside the run's list (its configuration's `tasks.count`): not a
        // record this run can have written.
        if let (Some(count), Some(index)) = (task_count(&config), fields.get("index").and_then(Value::as_u64))
            && index >= count
        {
            let message = format!("`index` is {index}, past the run's {count} tasks ({})", config_path.display());
            return Err(RecordError::Bad { path: path.to_path_buf(), line, message }.into());
        }
        records.push(Record { line, fields });
    }
    if let Some(count) = task_count(&config)
        && records.len() as u64 > count
    {
        let message = format!("{} records of a run of {count} tasks ({})", records.len(), config_path.display());
        return Err(RecordError::Bad { path: path.to_path_buf(), line: records.last().map_or(1, |r| r.line), message }.into());
    }
    Ok(RecordSet { path: path.to_path_buf(), config, hash: expected, records, warnings })
}

/// The run's task count, where its configuration gives one (`tasks.count`, from stop 53 on).
pub(crate) fn task_count(config: &Map<String, Value>) -> Option<u64> {
    config.get("tasks").and_then(|t| t.get("count")).and_then(Value::as_u64)
}

/// The fields a report reads from every record (`merge` checks them too).
pub(crate) fn check(path: &Path, line: usize, fields: &Map<String, Value>) -> Result<(), RecordError> {
    let bad = |message: String| RecordError::Bad { path: path.to_path_buf(), line, message };
    if !fields.get("success").is_some_and(Value::is_boolean) {
        return Err(bad("no boolean `success`: every record says whether its task succeeded".into()));
    }
    if fields.get("task").and_then(Value::as_str).is_none_or(str::is_empty) {
        return Err(bad("no `task`: every record names its task (a non-empty string)".into()));
    }
    if let Some(terminal) = fields.get("terminal")
        && !terminal.as_str().is_some_and(|t| TERMINALS.contains(&t))
    {
        return Err(bad(format!("`terminal` is {terminal}, not one of {}", TERMINALS.join(", "))));
    }
    // How the episode ended agrees with whether it succeeded (the agents' `terminal`, the
    // expert's `outcome`): a record that says both cannot be counted either way.
    let success = fields.get("success").and_then(Value::as_bool) == Some(true);
    for key in ["terminal", "outcome"] {
        if let Some(end) = fields.get(key).and_then(Value::as_str)
            && (end == "success") != success
        {
            return Err(bad(format!("`{key}` is \"{end}\" but `success` is {success}")));
        }
    }
    if let Some(attribution) = fields.get("attribution")
        && !(attribution.is_null() || attribution.as_str().is_some_and(|a| ATTRIBUTIONS.contains(&a)))
    {
        return Err(bad(format!("`attribution` is {attribution}, not null or one of {}", ATTRIBUTIONS.join(", "))));
    }
    // The figures the tables and plots read ([`super::metrics`]), each where present.
    let at = |path: &str| super::metrics::field_at(fields, path);
    for path in COUNTS {
        if let Some(value) = at(path)
            && value.as_u64().is_none_or(|n| n > MAX_COUNT)
        {
            return Err(bad(format!("`{path}` is {value}, not a count (a whole number from 0 to {MAX_COUNT})")));
        }
    }
    if let Some(value) = at("millis")
        && !value.as_f64().is_some_and(|ms| ms.is_finite() && ms >= 0.0)
    {
        return Err(bad(format!("`millis` is {value}, not a duration (a number of milliseconds, at least 0)")));
    }
    for path in ["precision", "recall"] {
        if let Some(value) = at(path)
            && !(value.is_null() || value.as_f64().is_some_and(|x| (0.0..=1.0).contains(&x)))
        {
            return Err(bad(format!("`{path}` is {value}, not null or a fraction from 0 to 1")));
        }
    }
    for path in ["episode", "failure_response"] {
        if let Some(value) = at(path)
            && !(value.is_object() || value.is_null())
        {
            return Err(bad(format!("`{path}` is {value}, not an object")));
        }
    }
    if let Some(Value::Object(flags)) = at("failure_response")
        && let Some((flag, value)) = flags.iter().find(|(_, v)| !v.is_boolean())
    {
        return Err(bad(format!("`failure_response.{flag}` is {value}, not a boolean")));
    }
    Ok(())
}

/// The counts a report reads from a record (steps, tokens, calls, images, observations), by
/// their paths; each must be a whole number from 0 to [`MAX_COUNT`] where present.
const COUNTS: [&str; 20] = [
    "steps",
    "index",
    "generated_tokens",
    "tokens",
    "prompt_tokens",
    "model_calls",
    "calls",
    "images",
    "observations",
    "phase1_tokens",
    "phase2_tokens",
    "phase1_calls",
    "phase2_calls",
    "phase1_steps",
    "episode.usage.generated_tokens",
    "episode.usage.model_calls",
    "episode.usage.images",
    "episode.usage.observations",
    "episode.phase1_usage.images",
    "episode.phase1_usage.observations",
];

/// The largest count a record may hold (2^53: counts beyond it are not exact as JSON numbers).
const MAX_COUNT: u64 = 1 << 53;
