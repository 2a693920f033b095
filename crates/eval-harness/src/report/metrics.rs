//! What a record says, whichever agent wrote it: `ours` and `planner` records keep Phase I's
//! usage under `episode.phase1_usage` and Phase II's tokens beside it; a `direct` record keeps
//! its usage under `episode.usage` (or at the top); the expert records none of it. Each
//! reader returns `None` where the record does not say.

use serde_json::Value;

use super::load::Record;

/// The value at a dotted `path` (`episode.usage.images`) of a record's fields, if there.
pub(crate) fn field_at<'a>(fields: &'a serde_json::Map<String, Value>, path: &str) -> Option<&'a Value> {
    let mut parts = path.split('.');
    let mut value = fields.get(parts.next()?)?;
    for part in parts {
        value = value.get(part)?;
    }
    Some(value)
}

fn at<'a>(record: &'a Record, path: &str) -> Option<&'a Value> {
    field_at(&record.fields, path)
}

fn first_number(record: &Record, paths: &[&str]) -> Option<f64> {
    paths.iter().find_map(|p| at(record, p).and_then(Value::as_f64))
}

/// The sum of those of `paths` the record holds, if any.
fn sum_of(record: &Record, paths: &[&str]) -> Option<f64> {
    let found: Vec<f64> = paths.iter().filter_map(|p| at(record, p).and_then(Value::as_f64)).collect();
    if found.is_empty() { None } else { Some(found.iter().sum()) }
}

/// Tokens the models generated for the task (Phase I and Phase II together).
pub(crate) fn generated_tokens(record: &Record) -> Option<f64> {
    first_number(record, &["generated_tokens", "tokens", "episode.usage.generated_tokens"])
        .or_else(|| sum_of(record, &["phase1_tokens", "phase2_tokens"]))
}

/// Images shown to a model during the task.
pub(crate) fn images(record: &Record) -> Option<f64> {
    first_number(record, &["images", "episode.usage.images", "episode.phase1_usage.images"])
}

/// Observations shown to a model during the task.
pub(crate) fn observations(record: &Record) -> Option<f64> {
    first_number(record, &["observations", "episode.usage.observations", "episode.phase1_usage.observations"])
}

/// Model calls made for the task.
pub(crate) fn model_calls(record: &Record) -> Option<f64> {
    first_number(record, &["model_calls", "calls", "episode.usage.model_calls"])
        .or_else(|| sum_of(record, &["phase1_calls", "phase2_calls"]))
}

/// The terminal mechanism (Table 11), where recorded.
pub(crate) fn terminal(record: &Record) -> Option<&str> {
    record.fields.get("terminal").and_then(Value::as_str)
}

/// The failure class: `None` where the record has no `attribution` field, `Some(None)` for a
/// recorded null (a success, or a failure nobody attributed).
pub(crate) fn attribution(record: &Record) -> Option<Option<&str>> {
    record.fields.get("attribution").map(Value::as_str)
}

/// One flag of the failure response (Table 12), where recorded.
pub(crate) fn failure_flag(record: &Record, flag: &str) -> Option<bool> {
    at(record, "failure_response").and_then(|r| r.get(flag)).and_then(Value::as_bool)
}

/// The requests sent to the environment, each with whether it executed (`episode.steps`).
pub(crate) fn requests(record: &Record) -> Option<Vec<(&str, bool)>> {
    let steps = at(record, "episode.steps")?.as_array()?;
    steps.iter().map(|s| Some((s.get("command")?.as_str()?, s.get("executed")?.as_bool()?))).collect()
}
