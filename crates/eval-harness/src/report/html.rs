//! The HTML pages: `index.html` (inputs, the tables, the figures inline, every episode
//! linked) and one page per record (Phase I's decisions with the facts admitted and refused,
//! the grounded problem, the plan, each executed step with its observation, the verdict,
//! precision, recall and attribution, Phase II's summary and the top of its search tree).
//! Every text from a record is escaped: observations carry `<`, `>` and `&`. Pages are
//! well-formed XML as well as HTML.

use std::collections::BTreeSet;
use std::fmt::Write;

use serde_json::{Map, Value};

use super::figures::Figure;
use super::load::{Record, RecordSet};
use super::study::{Study, success, task};
use super::table::Table;

/// `text` with `& < > " '` written as character references: safe in element text and in
/// quoted attribute values alike.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            // Control characters other than tab and line breaks are not allowed in XML.
            c if c.is_control() && !matches!(c, '\t' | '\n' | '\r') => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

/// One page of the report: its path under the output folder (`/`-separated) and its text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Page {
    /// The path under the output folder, `/`-separated, e.g. `episodes/<file stem>/<index>.html`.
    pub path: String,
    /// The whole HTML document.
    pub html: String,
}

const STYLE: &str = "\
body{font-family:system-ui,-apple-system,'Segoe UI',Helvetica,Arial,sans-serif;font-size:14px;line-height:1.45;color:#222;margin:0 auto;max-width:1240px;padding:16px 24px}
h1{font-size:22px;margin:8px 0 4px}h2{font-size:18px;margin:28px 0 6px;border-bottom:1px solid #ddd;padding-bottom:3px}h3{font-size:15px;margin:18px 0 6px}
table{border-collapse:collapse;margin:6px 0 10px;font-size:13px}th,td{border:1px solid #d0d0d0;padding:3px 7px;vertical-align:top;text-align:left}
th{background:#f0f0f0}th.group{text-align:center}.wide{overflow-x:auto}.wide td:first-child{min-width:12em}td.num,th.num{text-align:right;white-space:nowrap}tbody tr:nth-child(even){background:#fafafa}
.caption{color:#555;max-width:980px;margin:2px 0 6px}.note{color:#555;font-size:12px}.empty{font-style:italic;color:#777}
nav a{margin-right:14px}code,pre{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:12px}
pre.scroll{max-height:28em;overflow:auto;background:#f7f7f7;border:1px solid #ddd;padding:8px}
.ok{color:#1a7f37;font-weight:bold}.bad{color:#c62828;font-weight:bold}.warn{background:#fff4e5;border:1px solid #f0c36d;padding:6px 10px}
.verdict{font-size:16px;padding:8px 12px;border:1px solid #ccc;display:inline-block;margin:6px 0}
ul.facts{margin:0;padding-left:18px}td.obs{max-width:640px}.box{max-height:16em;overflow:auto;white-space:pre-wrap}figure{margin:10px 0 24px}figcaption{color:#555;max-width:980px}
.meta{color:#555}details summary{cursor:pointer;color:#355}
";

fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>{}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        escape(title)
    )
}

/// A JSON value for a table cell: text as itself, `null` as a dash, structures as compact
/// JSON (long ones folded).
fn value_html(value: &Value) -> String {
    match value {
        Value::Null => "—".into(),
        Value::String(s) => escape(s),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => match n.as_f64() {
            Some(f) if n.is_f64() => number(f),
            _ => n.to_string(),
        },
        other => {
            let compact = other.to_string();
            if compact.chars().count() <= 160 {
                format!("<code>{}</code>", escape(&compact))
            } else {
                let pretty = serde_json::to_string_pretty(other).unwrap_or(compact);
                format!("<details><summary>{} lines</summary><pre>{}</pre></details>", pretty.lines().count(), escape(&pretty))
            }
        }
    }
}

fn number(value: f64) -> String {
    if value.fract() == 0.0 && value.abs() < 1e15 { format!("{value:.0}") } else { format!("{value:.3}") }
}

fn key_value_table(fields: &Map<String, Value>, leave_out: &[&str]) -> String {
    let mut out = String::from("<table>\n");
    for (key, value) in fields.iter().filter(|(k, _)| !leave_out.contains(&k.as_str())) {
        let _ = writeln!(out, "<tr><th>{}</th><td>{}</td></tr>", escape(key), value_html(value));
    }
    out.push_str("</table>\n");
    out
}

fn facts_list(value: Option<&Value>) -> String {
    let facts: Vec<&str> = value.and_then(Value::as_array).map(|a| a.iter().filter_map(Value::as_str).collect()).unwrap_or_default();
    if facts.is_empty() {
        return "—".into();
    }
    let items: String = facts.iter().map(|f| format!("<li>{}</li>", escape(f))).collect();
    format!("<div class=\"box\"><ul class=\"facts\">{items}</ul></div>")
}

/// The path of each record's page, unique within the report: `episodes/<stem>/<index>.html`.
pub(crate) fn page_paths(sets: &[RecordSet]) -> Vec<Vec<String>> {
    let mut used = BTreeSet::new();
    sets.iter()
        .map(|set| {
            let stem: String = set.stem().chars().map(|c| if c.is_ascii_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect();
            set.records
                .iter()
                .map(|record| {
                    let index = record
                        .fields
                        .get("index")
                        .and_then(Value::as_u64)
                        .map_or_else(|| format!("line{}", record.line), |i| i.to_string());
                    let mut path = format!("episodes/{stem}/{index}.html");
                    let mut extra = 2;
                    while !used.insert(path.clone()) {
                        path = format!("episodes/{stem}/{index}-{extra}.html");
                        extra += 1;
                    }
                    path
                })
                .collect()
        })
        .collect()
}

fn file_name(set: &RecordSet) -> String {
    set.path.file_name().map_or_else(|| set.path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Where `record` of `set` sits in the study: condition label, benchmark, run seed.
fn place(study: &Study<'_>, set: &RecordSet) -> (String, String, String) {
    for ((c, b), runs) in &study.cells {
        for run in runs {
            if run.sets.iter().any(|s| std::ptr::eq(*s, set)) {
                return (study.conditions[*c].label(), study.benchmarks[*b].clone(), run.seed.clone());
            }
        }
    }
    (String::new(), set.config_str("benchmark").unwrap_or_default().to_string(), String::new())
}

fn verdict_html(record: &Record) -> String {
    if success(record) { "<span class=\"ok\">success</span>".into() } else { "<span class=\"bad\">failure</span>".into() }
}

fn field_text(record: &Record, key: &str) -> String {
    match record.fields.get(key) {
        None | Some(Value::Null) => "—".into(),
        Some(Value::String(s)) => escape(s),
        Some(other) => escape(&other.to_string()),
    }
}

/// `index.html`.
pub(crate) fn index(study: &Study<'_>, sets: &[RecordSet], paths: &[Vec<String>], tables: &[Table], figures: &[Figure]) -> String {
    let records: usize = sets.iter().map(|s| s.records.len()).sum();
    let mut body = String::new();
    let _ = writeln!(body, "<h1>Evaluation report</h1>");
    let _ = writeln!(
        body,
        "<p class=\"meta\">{} record file(s), {records} record(s), {} condition(s), {} benchmark(s): {}.</p>",
        sets.len(),
        study.conditions.len(),
        study.benchmarks.len(),
        escape(&study.benchmarks.join(", "))
    );
    body.push_str("<nav><a href=\"#tables\">Tables</a><a href=\"#figures\">Figures</a><a href=\"#episodes\">Episodes</a><a href=\"#inputs\">Inputs</a></nav>\n");
    for line in &study.left_out {
        let _ = writeln!(body, "<p class=\"meta\">Left out: {}.</p>", escape(line));
    }
    let warnings: Vec<&String> = sets.iter().flat_map(|s| &s.warnings).collect();
    if !warnings.is_empty() {
        body.push_str("<div class=\"warn\">");
        for warning in warnings {
            let _ = write!(body, "<div>{}</div>", escape(warning));
        }
        body.push_str("</div>\n");
    }
    body.push_str("<div id=\"tables\">\n");
    for table in tables {
        body.push_str(&table.html());
    }
    body.push_str("</div>\n<div id=\"figures\">\n<h2>Figures</h2>\n");
    for figure in figures {
        let id = figure.name.trim_end_matches(".svg");
        let _ = writeln!(
            body,
            "<figure id=\"figure-{id}\">\n{}<figcaption>{} (<a href=\"{}\">{}</a>)</figcaption>\n</figure>",
            figure.svg,
            escape(&figure.caption),
            figure.name,
            figure.name
        );
    }
    body.push_str("</div>\n<h2 id=\"episodes\">Episodes</h2>\n<p class=\"caption\">One page per record: the Phase I decisions, the grounded problem, the plan, every executed step with its observation, the verdict.</p>\n");
    let set_index = |set: &RecordSet| sets.iter().position(|s| std::ptr::eq(s, set)).unwrap_or_default();
    for (c, condition) in study.conditions.iter().enumerate() {
        for (b, benchmark) in study.benchmarks.iter().enumerate() {
            for run in study.runs(c, b) {
                let seed = if run.seed.is_empty() { String::new() } else { format!(", {}", run.seed) };
                let _ = writeln!(body, "<h3>{} — {}{}</h3>", escape(&condition.label()), escape(benchmark), escape(&seed));
                body.push_str("<table>\n<thead><tr><th class=\"num\">#</th><th>Task</th><th>Verdict</th><th>Terminal</th><th>Attribution</th><th class=\"num\">Steps</th></tr></thead>\n<tbody>\n");
                let mut records = run.records.clone();
                records.sort_by_key(|(_, r)| (r.fields.get("index").and_then(Value::as_u64).unwrap_or(u64::MAX), r.line));
                for (set, record) in records {
                    let s = set_index(set);
                    let r = set.records.iter().position(|x| std::ptr::eq(x, record)).unwrap_or_default();
                    let _ = writeln!(
                        body,
                        "<tr><td class=\"num\">{}</td><td><a href=\"{}\">{}</a></td><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td></tr>",
                        field_text(record, "index"),
                        escape(&paths[s][r]),
                        escape(task(record)),
                        verdict_html(record),
                        field_text(record, "terminal"),
                        field_text(record, "attribution"),
                        field_text(record, "steps")
                    );
                }
                body.push_str("</tbody>\n</table>\n");
            }
        }
    }
    body.push_str("<h2 id=\"inputs\">Inputs</h2>\n<table>\n<thead><tr><th>File</th><th>Condition</th><th>Benchmark</th><th>Run</th><th class=\"num\">Records</th><th>Configuration</th></tr></thead>\n<tbody>\n");
    for set in sets {
        let (label, benchmark, seed) = place(study, set);
        let config = serde_json::to_string_pretty(&Value::Object(set.config.clone())).unwrap_or_default();
        let _ = writeln!(
            body,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td><details><summary>{}</summary><pre>{}</pre></details></td></tr>",
            escape(&set.path.display().to_string()),
            escape(&label),
            escape(&benchmark),
            escape(&seed),
            set.records.len(),
            escape(&set.hash),
            escape(&config)
        );
    }
    body.push_str("</tbody>\n</table>\n");
    page("Evaluation report", &body)
}

/// The decisions of Phase I: the skill, its outcome, the requests it sent, the facts
/// admitted and refused.
fn decisions_html(episode: &Map<String, Value>) -> String {
    let Some(decisions) = episode.get("decisions").and_then(Value::as_array) else {
        return "<p class=\"empty\">This record holds no Phase I decisions.</p>\n".into();
    };
    let steps = episode.get("steps").and_then(Value::as_array);
    let mut out = format!(
        "<p class=\"meta\">Phase I stopped: <strong>{}</strong> after {} step(s).</p>\n",
        episode.get("phase1_stop").map_or_else(|| "—".into(), value_html),
        episode.get("phase1_steps").map_or_else(|| "—".into(), value_html)
    );
    // `reexplore`: instances a hand-over proved unable to meet the goal, after which Phase I went on.
    if let Some(aside) = episode.get("set_aside").and_then(Value::as_array).filter(|a| !a.is_empty()) {
        let names: Vec<String> = aside.iter().map(|x| format!("<code>{}</code>", value_html(x))).collect();
        let _ = writeln!(
            out,
            "<p class=\"meta\">Set aside (a goal fact about it can never hold in the hand-over; Phase I went on): {}.</p>",
            names.join(", ")
        );
    }
    if decisions.is_empty() {
        out.push_str("<p class=\"empty\">No decisions.</p>\n");
        return out;
    }
    out.push_str("<table>\n<thead><tr><th class=\"num\">#</th><th>Skill</th><th>Outcome</th><th>Requests sent</th><th>Facts admitted</th><th>Refused (no evidence)</th><th>Feedback</th></tr></thead>\n<tbody>\n");
    for (i, decision) in decisions.iter().enumerate() {
        let text = |key: &str| decision.get(key).map_or_else(|| "—".into(), value_html);
        let requests: Vec<String> = decision
            .get("steps")
            .and_then(Value::as_array)
            .map(|indices| {
                indices
                    .iter()
                    .filter_map(Value::as_u64)
                    .map(|k| {
                        let command =
                            steps.and_then(|s| s.get(k as usize)).and_then(|s| s.get("command")).and_then(Value::as_str).unwrap_or("?");
                        format!("<div>{}. <code>{}</code></div>", k + 1, escape(command))
                    })
                    .collect()
            })
            .unwrap_or_default();
        let offered = decision.get("offered").and_then(Value::as_array).map_or(0, Vec::len);
        let offered_html = if offered > 0 {
            let items: String = decision["offered"]
                .as_array()
                .into_iter()
                .flatten()
                .filter_map(Value::as_str)
                .map(|s| format!("<li>{}</li>", escape(s)))
                .collect();
            format!("<details><summary>{offered} offered</summary><ul class=\"facts\">{items}</ul></details>")
        } else {
            String::new()
        };
        let required =
            if decision.get("required").and_then(Value::as_bool) == Some(true) { " <em>(required by the harness)</em>" } else { "" };
        let _ = writeln!(
            out,
            "<tr><td class=\"num\">{}</td><td><code>{}</code>{required}{offered_html}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1,
            text("skill"),
            text("outcome"),
            if requests.is_empty() { "—".into() } else { requests.concat() },
            facts_list(decision.get("admitted")),
            facts_list(decision.get("refused")),
            text("feedback")
        );
    }
    out.push_str("</tbody>\n</table>\n");
    out
}

/// Every environment step: the request, whether it executed, what came back.
fn steps_html(steps: &[Value]) -> String {
    if steps.is_empty() {
        return "<p class=\"empty\">No request reached the environment.</p>\n".into();
    }
    // Columns beyond the usual ones (a direct policy's `reason`, `reply`), in first-seen order.
    let usual = ["phase", "command", "executed", "observation"];
    let mut extra: Vec<String> = Vec::new();
    for step in steps {
        for key in step.as_object().into_iter().flat_map(|o| o.keys()) {
            if !usual.contains(&key.as_str()) && !extra.contains(key) {
                extra.push(key.clone());
            }
        }
    }
    let phases = steps.iter().any(|s| s.get("phase").is_some());
    let mut out = String::from("<table>\n<thead><tr><th class=\"num\">#</th>");
    if phases {
        out.push_str("<th>Phase</th>");
    }
    out.push_str("<th>Request</th><th>Executed</th>");
    for key in &extra {
        let mut name: Vec<char> = key.replace('_', " ").chars().collect();
        if let Some(first) = name.first_mut() {
            *first = first.to_ascii_uppercase();
        }
        let _ = write!(out, "<th>{}</th>", escape(&name.into_iter().collect::<String>()));
    }
    out.push_str("<th>Observation</th></tr></thead>\n<tbody>\n");
    for (i, step) in steps.iter().enumerate() {
        let text = |key: &str| step.get(key).map_or_else(|| "—".into(), value_html);
        let executed = match step.get("executed").and_then(Value::as_bool) {
            Some(true) => "<span class=\"ok\">✓ executed</span>",
            Some(false) => "<span class=\"bad\">✗ not executed</span>",
            None => "—",
        };
        let _ = write!(out, "<tr><td class=\"num\">{}</td>", i + 1);
        if phases {
            let _ = write!(out, "<td>{}</td>", text("phase"));
        }
        let _ = write!(out, "<td><code>{}</code></td><td>{executed}</td>", text("command"));
        for key in &extra {
            let _ = write!(out, "<td>{}</td>", text(key));
        }
        let _ = writeln!(out, "<td class=\"obs\"><div class=\"box\">{}</div></td></tr>", text("observation"));
    }
    out.push_str("</tbody>\n</table>\n");
    out
}

/// The episode as the benchmark's own engine is given it on replay (`engine_script`: each line
/// with whether it executed here).
fn engine_script_html(script: &[Value]) -> String {
    if script.is_empty() {
        return "<p class=\"empty\">No command reached the engine (nothing to replay: the engine is judged on the initial state).</p>\n"
            .into();
    }
    let items: String = script
        .iter()
        .map(|line| {
            let text = line.get("line").and_then(Value::as_str).map_or_else(|| escape(&line.to_string()), escape);
            let outcome = match line.get("executed").and_then(Value::as_bool) {
                Some(true) => "<span class=\"ok\">✓</span>",
                Some(false) => "<span class=\"bad\">✗</span>",
                None => "—",
            };
            format!("<li>{outcome} <code>{text}</code></li>")
        })
        .collect();
    format!("<ol>{items}</ol>\n")
}

fn handover_html(episode: &Map<String, Value>) -> String {
    let Some(handover) = episode.get("handover").and_then(Value::as_object) else {
        return "<p class=\"empty\">No hand-over: Phase I produced no grounded problem.</p>\n".into();
    };
    let mut out = String::new();
    match handover.get("problem").and_then(Value::as_str) {
        Some(problem) => {
            let _ = writeln!(
                out,
                "<p class=\"meta\">ŝ0 as a PDDL problem ({} lines):</p>\n<pre class=\"scroll\">{}</pre>",
                problem.lines().count(),
                escape(problem)
            );
        }
        None => out.push_str("<p class=\"empty\">The hand-over holds no problem text.</p>\n"),
    }
    if let Some(binding) = handover.get("binding").and_then(Value::as_object) {
        let _ = writeln!(out, "<details><summary>Binding β: {} symbol(s) → perceived instance</summary>", binding.len());
        out.push_str(&key_value_table(binding, &[]));
        out.push_str("</details>\n");
    }
    let rest: Map<String, Value> =
        handover.iter().filter(|(k, _)| !["problem", "binding"].contains(&k.as_str())).map(|(k, v)| (k.clone(), v.clone())).collect();
    if !rest.is_empty() {
        out.push_str(&key_value_table(&rest, &[]));
    }
    out
}

fn plan_html(episode: &Map<String, Value>) -> String {
    match episode.get("plan").and_then(Value::as_array) {
        None => "<p class=\"empty\">This record holds no plan.</p>\n".into(),
        Some(plan) if plan.is_empty() => "<p class=\"empty\">The plan is empty.</p>\n".into(),
        Some(plan) => {
            let items: String = plan
                .iter()
                .map(|a| format!("<li><code>{}</code></li>", a.as_str().map_or_else(|| escape(&a.to_string()), escape)))
                .collect();
            format!("<ol>{items}</ol>\n")
        }
    }
}

/// A probability for a table cell: three decimals, or two significant digits below 0.001.
fn probability(p: f64) -> String {
    if p > 0.0 && p < 1e-3 { format!("{p:.1e}") } else { format!("{p:.3}") }
}

/// One level of the search tree's summary (`mcts::TreeLevel` as JSON): its rows, most visited
/// first.
fn tree_level_html(level: &Map<String, Value>) -> String {
    let mut rows: Vec<&Map<String, Value>> =
        level.get("rows").and_then(Value::as_array).map(|r| r.iter().filter_map(Value::as_object).collect()).unwrap_or_default();
    let visits = |row: &Map<String, Value>| row.get("visits").and_then(Value::as_u64).unwrap_or(0);
    rows.sort_by_key(|row| std::cmp::Reverse(visits(row)));
    let mut out = String::new();
    if rows.is_empty() {
        out.push_str("<p class=\"empty\">No branch was visited from here.</p>\n");
    } else {
        out.push_str("<table>\n<thead><tr><th class=\"num\">#</th><th>Action</th><th class=\"num\">Visits</th><th class=\"num\">Value</th><th class=\"num\">Prior</th><th>On plan</th></tr></thead>\n<tbody>\n");
        for (i, row) in rows.iter().enumerate() {
            let text = row.get("text").and_then(Value::as_str).filter(|t| !t.is_empty()).map_or_else(|| "—".into(), escape);
            let kind = match row.get("kind").and_then(Value::as_str) {
                Some("action") | None => String::new(),
                Some("end") => " <em>(ends the plan)</em>".into(),
                Some("invalid") => " <em>(names no applicable action)</em>".into(),
                Some("partial") => " <em>(partial: the search stopped inside the action)</em>".into(),
                Some(other) => format!(" <em>({})</em>", escape(other)),
            };
            let on_plan =
                if row.get("on_plan").and_then(Value::as_bool) == Some(true) { "<span class=\"ok\">✓ on plan</span>" } else { "" };
            let _ = writeln!(
                out,
                "<tr><td class=\"num\">{}</td><td><code>{text}</code>{kind}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{on_plan}</td></tr>",
                i + 1,
                visits(row),
                row.get("value").and_then(Value::as_f64).map_or_else(|| "—".into(), |v| format!("{v:.3}")),
                row.get("prior").and_then(Value::as_f64).map_or_else(|| "—".into(), probability),
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }
    let omitted = level.get("omitted").and_then(Value::as_u64).unwrap_or(0);
    if omitted > 0 {
        let _ = writeln!(
            out,
            "<p class=\"note\">{omitted} more branch(es) tried, with {} visit(s) in all, are not listed.</p>",
            level.get("omitted_visits").and_then(Value::as_u64).unwrap_or(0)
        );
    }
    if level.get("truncated").and_then(Value::as_bool) == Some(true) {
        out.push_str("<p class=\"note\">The summary stopped replaying this level's tokens at its limit: branches beyond it are neither listed nor counted.</p>\n");
    }
    out
}

/// The top of Phase II's search tree (`episode.search_tree`, `mcts::TreeSummary` as JSON), or
/// a note that the record holds none.
fn search_tree_html(episode: &Map<String, Value>) -> String {
    let Some(tree) = episode.get("search_tree").and_then(Value::as_object) else {
        return "<p class=\"empty\">This record holds no search tree: its planner builds none (A*, greedy decoding, sampling, a chat \
                model), the search never ran or returned no plan, or the record was written before records kept the tree.</p>\n"
            .into();
    };
    let backup = match tree.get("backup").and_then(Value::as_str) {
        Some("mean") => "the mean of the values (Eq. 10) backed up through it",
        _ => "the best value (Eq. 10) backed up through it",
    };
    let mut out = format!(
        "<p class=\"caption\">{} simulation(s) backed up at the root. The tree's nodes are tokens; a row is a branch from one action \
         boundary to the next, usually the node where an action's line completes. Visits: simulations through it; value: {backup}; \
         prior: the product of its tokens' priors (the masked model distribution, Eq. 8). Visited branches only, most visited first.</p>\n",
        tree.get("visits").and_then(Value::as_u64).unwrap_or(0)
    );
    match tree.get("first").and_then(Value::as_object) {
        Some(first) => out.push_str(&tree_level_html(first)),
        None => out.push_str("<p class=\"empty\">The summary holds no first level.</p>\n"),
    }
    if let Some(second) = tree.get("second").and_then(Value::as_object) {
        let after: Vec<String> = second
            .get("after")
            .and_then(Value::as_array)
            .map(|lines| lines.iter().filter_map(Value::as_str).map(|l| format!("<code>{}</code>", escape(l))).collect())
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "<h3>After {} (the most visited first action, {} visit(s))</h3>",
            if after.is_empty() { "—".into() } else { after.join(" → ") },
            second.get("visits").and_then(Value::as_u64).unwrap_or(0)
        );
        out.push_str(&tree_level_html(second));
    }
    out
}

/// The page of one record.
pub(crate) fn episode_page(study: &Study<'_>, set: &RecordSet, record: &Record) -> String {
    let (label, benchmark, seed) = place(study, set);
    let task = task(record);
    let mut body = String::new();
    let _ = writeln!(body, "<nav><a href=\"../../index.html\">← report</a><a href=\"../../index.html#episodes\">all episodes</a></nav>");
    let _ = writeln!(body, "<h1>{}</h1>", escape(task));
    let _ = writeln!(
        body,
        "<p class=\"meta\">{} — {}{} — <code>{}:{}</code></p>",
        escape(&label),
        escape(&benchmark),
        if seed.is_empty() { String::new() } else { format!(", {}", escape(&seed)) },
        escape(&file_name(set)),
        record.line
    );
    let _ = writeln!(
        body,
        "<div class=\"verdict\">Verdict: {} · terminal: {} · attribution: {} · precision: {} · recall: {}</div>",
        verdict_html(record),
        field_text(record, "terminal"),
        field_text(record, "attribution"),
        record.fields.get("precision").map_or_else(|| "—".into(), value_html),
        record.fields.get("recall").map_or_else(|| "—".into(), value_html)
    );
    match record.fields.get("episode").and_then(Value::as_object) {
        None => {
            body.push_str("<p class=\"empty\">This record holds no episode (the expert's records hold the verdict of the benchmark's own plan only).</p>\n");
            body.push_str("<h2>Record</h2>\n");
            body.push_str(&key_value_table(&record.fields, &["episode"]));
        }
        Some(episode) => {
            if episode.contains_key("decisions") {
                body.push_str("<h2>Phase I: decisions</h2>\n");
                body.push_str(&decisions_html(episode));
            }
            if episode.contains_key("handover") {
                body.push_str("<h2>Grounded problem</h2>\n");
                body.push_str(&handover_html(episode));
            }
            if episode.contains_key("plan") {
                body.push_str("<h2>Plan</h2>\n");
                body.push_str(&plan_html(episode));
            }
            body.push_str("<h2>Executed steps</h2>\n");
            body.push_str(&steps_html(episode.get("steps").and_then(Value::as_array).map_or(&[], Vec::as_slice)));
            if let Some(failure) = episode.get("failure").and_then(Value::as_str) {
                let _ = writeln!(body, "<p><strong>Failure:</strong> {}</p>", escape(failure));
            }
            if let Some(script) = episode.get("engine_script").and_then(Value::as_array) {
                body.push_str("<h2>Engine script</h2>\n<p class=\"caption\">The commands as the benchmark's own engine takes them (ALFWorld's as sent, VirtualHome's grounded script lines), each with its outcome here: what <code>tools/replay_records.py</code> replays.</p>\n");
                body.push_str(&engine_script_html(script));
            }
            if let Some(detail) = episode.get("phase2_detail") {
                body.push_str("<h2>Phase II</h2>\n");
                match detail {
                    Value::Object(detail) => body.push_str(&key_value_table(detail, &[])),
                    Value::Null => {
                        body.push_str("<p class=\"empty\">No Phase II summary: Phase II returned none (see the failure above).</p>\n")
                    }
                    other => {
                        let _ = writeln!(body, "<p>{}</p>", value_html(other));
                    }
                }
            }
            if episode.contains_key("phase2_detail") || episode.contains_key("search_tree") {
                body.push_str("<h2>Phase II search (top of the tree)</h2>\n");
                body.push_str(&search_tree_html(episode));
            }
            body.push_str("<h2>Record</h2>\n");
            body.push_str(&key_value_table(&record.fields, &["episode"]));
            let shown = [
                "decisions",
                "handover",
                "plan",
                "steps",
                "phase2_detail",
                "search_tree",
                "phase1_stop",
                "phase1_steps",
                "failure",
                "engine_script",
            ];
            let rest: Map<String, Value> =
                episode.iter().filter(|(k, _)| !shown.contains(&k.as_str())).map(|(k, v)| (k.clone(), v.clone())).collect();
            if !rest.is_empty() {
                body.push_str("<h2>Other episode fields</h2>\n");
                body.push_str(&key_value_table(&rest, &[]));
            }
        }
    }
    page(&format!("{task} — {label}"), &body)
}
