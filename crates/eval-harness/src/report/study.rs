//! Record files grouped into what the paper's tables compare: a *condition* (every setting
//! of the configuration but the benchmark and the seed), on a *benchmark*, in one or more
//! *runs* (configurations equal but for `seed` / `decode.seed`; shard files of one run are
//! one run). Conditions are named as the paper names its rows: an approach, a model, and
//! the settings that tell apart conditions sharing both.

use std::collections::{BTreeMap, BTreeSet};

use serde_json::{Map, Value};

use super::ReportError;
use super::load::{Record, RecordSet};
use crate::records::RecordError;

/// Configuration keys that name the benchmark (and which of its tasks: `tasks` is the task
/// list's count and digest, `task_files` EAI's files' digest, `task_dir` their folder in records
/// before version 18) rather than the condition; a key stands for the keys under it too.
const BENCHMARK_KEYS: [&str; 5] = ["benchmark", "subset", "task_dir", "task_files", "tasks"];

/// The column a record set belongs to: its benchmark, or the subset of it the run took
/// (`alfworld-seen-12`; `eval --subset default` gives each benchmark its own, so the subset
/// names the column, not the condition).
pub(crate) fn column(set: &RecordSet) -> String {
    let benchmark = set.config_str("benchmark").unwrap_or_default();
    match set.config_str("subset") {
        None | Some("all") => benchmark.to_string(),
        Some(subset) if subset.starts_with(benchmark) => subset.to_string(),
        Some(subset) => format!("{benchmark} ({subset})"),
    }
}
/// Configuration keys that choose how Phase II plans (its model aside).
const PHASE2_CHOICE: [&str; 5] = ["decode.mode", "planner", "chat_planner.chat_planner", "chat_planner.thinking", "lm.lm"];

/// Phase II's model: the chat planner's where one plans (`eval --chat-planner`), else the
/// decoder's.
fn phase2_model(flat: &BTreeMap<String, Value>) -> Option<&Value> {
    flat.get("chat_planner.chat_planner").filter(|v| v.is_string()).or(flat.get("lm.lm"))
}

/// Phase II's condition: a chat planner's (`thinking`, `thinking-recommended`, or
/// `chat-greedy`: unconstrained greedy through a chat endpoint), else the decoder's mode
/// (`decode.mode`, or a `phase2` record's `mode`).
fn phase2_mode(flat: &BTreeMap<String, Value>) -> Option<String> {
    if flat.get("chat_planner.chat_planner").is_some_and(Value::is_string) {
        // `thinking: true` is the configuration before aa01b27, which sampled (Qwen3's own
        // recommendation, temperature 0.6, seeded): a recommended-sampling run, not greedy.
        let mode = match flat.get("chat_planner.thinking") {
            Some(Value::String(s)) if s == "recommended" => "thinking-recommended",
            Some(Value::Bool(true)) => "thinking-recommended",
            Some(Value::String(_)) => "thinking",
            _ => "chat-greedy",
        };
        return Some(mode.into());
    }
    flat.get("decode.mode").or(flat.get("mode")).and_then(Value::as_str).map(str::to_string)
}

/// Configuration keys that tell runs of one condition apart.
const SEED_KEYS: [&str; 2] = ["seed", "decode.seed"];

/// One row of the paper's tables.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Condition {
    pub agent: String,
    /// Phase II's decoding mode (`decode.mode`), where the agent has one.
    pub mode: Option<String>,
    /// The paper's "Approach" column.
    pub approach: String,
    /// The paper's "Model" column.
    pub model: String,
    /// The settings that tell this condition from others of the same approach and model.
    pub setting: String,
    /// The configuration, flattened (`decode.mode`), without benchmark and seed keys.
    pub flat: BTreeMap<String, Value>,
}

impl Condition {
    /// `Approach (model; setting)`, the name in comparisons and figures.
    pub fn label(&self) -> String {
        let inner: Vec<&str> = [self.model.as_str(), self.setting.as_str()].into_iter().filter(|s| !s.is_empty() && *s != "—").collect();
        if inner.is_empty() { self.approach.clone() } else { format!("{} ({})", self.approach, inner.join("; ")) }
    }

    /// The configuration without what chooses Phase II's condition (the decoder's mode, or a
    /// chat planner and its thinking) and with Phase II's model in one place whichever plans:
    /// conditions equal in it differ only in how the same model plans from the same Phase I
    /// (the component ablation's family).
    pub fn without_mode(&self) -> BTreeMap<&str, &Value> {
        let mut rest: BTreeMap<&str, &Value> =
            self.flat.iter().filter(|(k, _)| !PHASE2_CHOICE.contains(&k.as_str())).map(|(k, v)| (k.as_str(), v)).collect();
        if let Some(model) = phase2_model(&self.flat) {
            rest.insert("phase2 model", model);
        }
        rest
    }

    /// Whether Phase II is a thinking condition (the paper tests it in the main family, as a
    /// baseline, not among the component ablations).
    pub fn is_thinking(&self) -> bool {
        self.mode.as_deref().is_some_and(|m| m.starts_with("thinking"))
    }

    /// Whether this is the paper's method: the agent `ours` with constrained MCTS.
    pub fn is_method(&self) -> bool {
        self.agent == "ours" && matches!(self.mode.as_deref(), None | Some("constrained-mcts"))
    }
}

/// One run of a condition on a benchmark: its records, one per task, in task order.
#[derive(Debug, Clone)]
pub(crate) struct Run<'a> {
    /// `seed=42`, where the configuration has a seed.
    pub seed: String,
    pub sets: Vec<&'a RecordSet>,
    pub records: Vec<(&'a RecordSet, &'a Record)>,
}

impl<'a> Run<'a> {
    /// Task → success.
    pub fn outcomes(&self) -> BTreeMap<&'a str, bool> {
        self.records.iter().map(|(_, r)| (task(r), success(r))).collect()
    }
}

/// A record's task.
pub(crate) fn task(record: &Record) -> &str {
    record.fields.get("task").and_then(Value::as_str).unwrap_or_default()
}

/// A record's verdict (checked on loading).
pub(crate) fn success(record: &Record) -> bool {
    record.fields.get("success").and_then(Value::as_bool).unwrap_or(false)
}

/// Conditions × benchmarks × runs.
#[derive(Debug, Clone)]
pub(crate) struct Study<'a> {
    pub conditions: Vec<Condition>,
    pub benchmarks: Vec<String>,
    /// (condition, benchmark) → runs, in seed order.
    pub cells: BTreeMap<(usize, usize), Vec<Run<'a>>>,
    /// What was left out of every table and why, one line each (records that are not
    /// episodes: the expert's tasks with no plan to replay).
    pub left_out: Vec<String>,
}

/// The `outcome` of a record that is not an episode: the expert agent had no plan for the task
/// (EAI ships none for some), so nothing was judged.
pub(crate) const NOT_JUDGED: &str = "no-plan";

/// Whether a record is an episode the environment judged.
fn judged(record: &Record) -> bool {
    record.fields.get("outcome").and_then(Value::as_str) != Some(NOT_JUDGED)
}

impl<'a> Study<'a> {
    pub fn runs(&self, condition: usize, benchmark: usize) -> &[Run<'a>] {
        self.cells.get(&(condition, benchmark)).map_or(&[], Vec::as_slice)
    }

    /// The designated run of a condition on a benchmark: the first in seed order (seed 0 of
    /// the paper's 0, 42, 1738), which the paper's main tables report for a stochastic
    /// condition (Appendix B: "the main paper reports the seed-0 run"); Table 7 gives the mean
    /// and spread over all runs.
    pub fn designated(&self, condition: usize, benchmark: usize) -> &[Run<'a>] {
        let runs = self.runs(condition, benchmark);
        &runs[..runs.len().min(1)]
    }
}

fn flatten(prefix: &str, value: &Value, out: &mut BTreeMap<String, Value>) {
    match value {
        Value::Object(map) => {
            for (key, value) in map {
                let key = if prefix.is_empty() { key.clone() } else { format!("{prefix}.{key}") };
                flatten(&key, value, out);
            }
        }
        other => {
            out.insert(prefix.to_string(), other.clone());
        }
    }
}

fn flat(config: &Map<String, Value>, leave_out: &[&str]) -> BTreeMap<String, Value> {
    let mut out = BTreeMap::new();
    flatten("", &Value::Object(config.clone()), &mut out);
    out.retain(|k, _| !leave_out.iter().any(|l| k == l || k.strip_prefix(l).is_some_and(|rest| rest.starts_with('.'))));
    out
}

fn key_text(flat: &BTreeMap<String, Value>) -> String {
    serde_json::to_string(flat).unwrap_or_default()
}

/// Benchmarks in the paper's column order (VirtualHome, then ALFWorld), others after.
fn benchmark_rank(name: &str) -> (usize, String) {
    let known = ["virtualhome-rearrange", "virtualhome-eai", "alfworld-seen", "alfworld-unseen", "alfworld-train"];
    (known.iter().position(|k| name.starts_with(k)).unwrap_or(known.len()), name.to_string())
}

fn agent_rank(agent: &str) -> usize {
    ["ours", "direct", "planner", "expert"].iter().position(|a| *a == agent).unwrap_or(4)
}

fn mode_rank(mode: Option<&str>) -> usize {
    let known = [
        "constrained-mcts",
        "unconstrained-mcts",
        "constrained-greedy",
        "unconstrained-greedy",
        "chat-greedy",
        "thinking",
        "thinking-recommended",
        "constrained-sample",
        "sample",
    ];
    mode.and_then(|m| known.iter().position(|k| *k == m)).unwrap_or(known.len())
}

/// The paper's "Approach" of an agent and its Phase II mode.
fn approach(agent: &str, mode: Option<&str>) -> String {
    match (agent, mode) {
        ("ours", Some("constrained-mcts") | None) => "Ours".into(),
        ("ours", Some("constrained-greedy")) => "Constrained greedy".into(),
        ("ours", Some("unconstrained-mcts")) => "Unconstrained MCTS".into(),
        ("ours", Some("unconstrained-greedy" | "chat-greedy")) => "Unconstrained greedy".into(),
        ("ours", Some("thinking")) => "Thinking".into(),
        ("ours", Some("thinking-recommended")) => "Thinking, recommended sampling".into(),
        ("ours", Some("constrained-sample")) => "Constrained sampling".into(),
        ("ours", Some("sample")) => "Unconstrained sampling".into(),
        ("ours", Some(other)) => format!("Ours ({other})"),
        ("direct", _) => "Direct VLM".into(),
        ("planner", _) => "Planner (A*)".into(),
        ("expert", _) => "Expert plan".into(),
        (other, _) => other.to_string(),
    }
}

/// A model's name as a reader knows it: `uniform` → uniform prior, a path → its file stem, a
/// server → the model it serves.
fn model_name(spec: &str, served: Option<&str>) -> String {
    match spec {
        "uniform" => "uniform prior".into(),
        "smollm2" => "SmolLM2-135M".into(),
        _ if spec.starts_with("openai:") => match served {
            Some(served) if served != "default" => served.to_string(),
            _ => spec.trim_start_matches("openai:").to_string(),
        },
        _ => std::path::Path::new(spec).file_stem().and_then(|s| s.to_str()).unwrap_or(spec).to_string(),
    }
}

/// The paper's "Model" column. The paper's agent uses one model in both phases; here Phase I's
/// explorer and Phase II's language model are set apart, so the column names both, `Phase I /
/// Phase II`, where they differ (`sweep` for the systematic explorer, which uses none): a row
/// planned with SmolLM2 from the sweep's state must not read as SmolLM2 in both phases. A
/// `model` setting (the direct policy's) is the one model; the planner names its explorer only;
/// a dash where no model is used (the expert, the planner after the sweep).
fn model(flat: &BTreeMap<String, Value>) -> String {
    let text = |key: &str| flat.get(key).and_then(Value::as_str);
    let served = text("lm.served_model").or(text("served_model"));
    let phase2 = text("model").or(phase2_model(flat).and_then(Value::as_str)).or(text("lm")).map(|spec| model_name(spec, served));
    // A `model` setting is the direct policy's one model: it has no separate explorer.
    let explorer = if text("model").is_some() { None } else { text("explorer") };
    let phase1 = explorer.map(|spec| if spec == "systematic" { "sweep".to_string() } else { model_name(spec, served) });
    match (phase1, phase2) {
        (Some(one), Some(two)) if one == two => one,
        (Some(one), Some(two)) => format!("{one} / {two}"),
        (Some(one), None) if one != "sweep" => one,
        (None, Some(two)) => two,
        _ => "—".into(),
    }
}

fn value_text(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        Value::Null => "none".into(),
        other => other.to_string(),
    }
}

/// Groups record sets into conditions, benchmarks and runs. Two records of one task in one
/// run (the same configuration in two files) are an error naming both places.
pub(crate) fn study(sets: &[RecordSet]) -> Result<Study<'_>, ReportError> {
    let leave_out_condition: Vec<&str> = BENCHMARK_KEYS.iter().chain(&SEED_KEYS).copied().collect();
    let mut condition_keys: BTreeMap<String, BTreeMap<String, Value>> = BTreeMap::new();
    let mut benchmarks = BTreeSet::new();
    for set in sets {
        let flat = flat(&set.config, &leave_out_condition);
        condition_keys.insert(key_text(&flat), flat);
        benchmarks.insert(benchmark_rank(&column(set)));
    }
    let benchmarks: Vec<String> = benchmarks.into_iter().map(|(_, name)| name).collect();

    let mut conditions: Vec<Condition> = condition_keys
        .into_values()
        .map(|flat| {
            let agent = flat.get("agent").and_then(Value::as_str).unwrap_or_default().to_string();
            let mode = phase2_mode(&flat);
            Condition { approach: approach(&agent, mode.as_deref()), model: model(&flat), setting: String::new(), agent, mode, flat }
        })
        .collect();
    settings(&mut conditions);
    conditions
        .sort_by_key(|c| (agent_rank(&c.agent), mode_rank(c.mode.as_deref()), c.approach.clone(), c.model.clone(), c.setting.clone()));
    let index_of: BTreeMap<String, usize> = conditions.iter().enumerate().map(|(i, c)| (key_text(&c.flat), i)).collect();

    // (condition, benchmark) → run key → (seed, sets).
    type RunSets<'s> = BTreeMap<String, (String, Vec<&'s RecordSet>)>;
    let mut grouped: BTreeMap<(usize, usize), RunSets<'_>> = BTreeMap::new();
    for set in sets {
        let condition = index_of[&key_text(&flat(&set.config, &leave_out_condition))];
        let benchmark_name = column(set);
        let benchmark = benchmarks.iter().position(|b| *b == benchmark_name).unwrap_or_default();
        let run_flat = flat(&set.config, &BENCHMARK_KEYS);
        let seed: Vec<String> = SEED_KEYS
            .iter()
            .filter_map(|k| run_flat.get(*k).map(|v| format!("{}={}", k.rsplit('.').next().unwrap_or(k), value_text(v))))
            .collect();
        let entry =
            grouped.entry((condition, benchmark)).or_default().entry(key_text(&run_flat)).or_insert_with(|| (seed.join(", "), Vec::new()));
        entry.1.push(set);
    }
    let mut cells = BTreeMap::new();
    let mut left_out = Vec::new();
    for (cell, runs) in grouped {
        let mut built = Vec::new();
        for (seed, sets) in runs.into_values() {
            let mut by_task: BTreeMap<&str, (&RecordSet, &Record)> = BTreeMap::new();
            let unjudged = sets.iter().flat_map(|s| &s.records).filter(|r| !judged(r)).count();
            if unjudged > 0 {
                let run = if seed.is_empty() { String::new() } else { format!(" ({seed})") };
                left_out.push(format!(
                    "{} on {}{run}: {unjudged} task(s) with no plan to replay (`outcome: {NOT_JUDGED}`), not episodes, left out of every table",
                    conditions[cell.0].label(),
                    benchmarks[cell.1]
                ));
            }
            for set in &sets {
                for record in set.records.iter().filter(|r| judged(r)) {
                    if let Some((other, first)) = by_task.insert(task(record), (set, record)) {
                        return Err(RecordError::Bad {
                            path: set.path.clone(),
                            line: record.line,
                            message: format!(
                                "task {} is recorded again: {}:{} holds it for the same configuration",
                                task(record),
                                other.path.display(),
                                first.line
                            ),
                        }
                        .into());
                    }
                }
            }
            built.push(Run { seed, sets, records: by_task.into_values().collect() });
        }
        built.sort_by_key(|run| seed_order(&run.seed));
        cells.insert(cell, built);
    }
    Ok(Study { conditions, benchmarks, cells, left_out })
}

/// Seeds in numeric order (`seed=0`, `seed=42`, `seed=1738`).
fn seed_order(seed: &str) -> (Vec<u64>, String) {
    (seed.split(|c: char| !c.is_ascii_digit()).filter_map(|d| d.parse().ok()).collect(), seed.to_string())
}

/// Fills each condition's `setting`: the keys whose values differ among the conditions of
/// its approach and model, as `key=value` (the key's last segment where that is unambiguous).
fn settings(conditions: &mut [Condition]) {
    let mut groups: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
    for (i, c) in conditions.iter().enumerate() {
        groups.entry((c.approach.clone(), c.model.clone())).or_default().push(i);
    }
    for members in groups.values() {
        if members.len() < 2 {
            continue;
        }
        let keys: BTreeSet<&String> = members.iter().flat_map(|&i| conditions[i].flat.keys()).collect();
        let varying: Vec<String> = keys
            .into_iter()
            .filter(|k| {
                let first = conditions[members[0]].flat.get(*k);
                members.iter().any(|&i| conditions[i].flat.get(*k) != first)
            })
            .cloned()
            .collect();
        let leaf = |k: &str| k.rsplit('.').next().unwrap_or(k).to_string();
        let names: Vec<String> = varying
            .iter()
            .map(|k| if varying.iter().filter(|other| leaf(other) == leaf(k)).count() > 1 { k.clone() } else { leaf(k) })
            .collect();
        for &i in members {
            let parts: Vec<String> = varying
                .iter()
                .zip(&names)
                .map(|(k, name)| format!("{name}={}", conditions[i].flat.get(k).map_or_else(|| "none".into(), value_text)))
                .collect();
            conditions[i].setting = parts.join(", ");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chat_planners_thinking_setting_names_its_condition() {
        let flat = |thinking: Value| {
            BTreeMap::from([
                ("decode.mode".to_string(), Value::from("constrained-mcts")),
                ("chat_planner.chat_planner".to_string(), Value::from("smollm2")),
                ("chat_planner.thinking".to_string(), thinking),
            ])
        };
        let mode = |thinking: Value| phase2_mode(&flat(thinking));
        assert_eq!(mode(Value::Null).as_deref(), Some("chat-greedy"));
        assert_eq!(mode("temperature-zero".into()).as_deref(), Some("thinking"));
        assert_eq!(mode("recommended".into()).as_deref(), Some("thinking-recommended"));
        // Before aa01b27 the setting was a flag, and thinking sampled at temperature 0.6.
        assert_eq!(mode(true.into()).as_deref(), Some("thinking-recommended"));
        assert_eq!(mode(false.into()).as_deref(), Some("chat-greedy"));
        let mut decoder = flat(Value::Null);
        decoder.remove("chat_planner.chat_planner");
        assert_eq!(phase2_mode(&decoder).as_deref(), Some("constrained-mcts"));
    }
}
