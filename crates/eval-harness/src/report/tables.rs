//! The paper's tables from records, every number through [`crate::stats`]: task success
//! (Table 1), the component ablation (Tables 2 and 8), accuracy ± sd with task-cluster
//! bootstrap intervals (Table 7), exact McNemar with Holm within each family (Tables 9-10),
//! terminal mechanism (Table 11), failure response (Table 12), failure attribution (Figures
//! 3 and 5 as numbers).

use std::collections::{BTreeMap, BTreeSet};

use super::load::{ATTRIBUTIONS, Record};
use super::metrics;
use super::study::{Condition, Run, Study, success};
use super::table::{Cell, Table};
use super::{ReportError, ReportOptions};
use crate::stats::{self, StatsError};

fn stats_error(context: impl Into<String>) -> impl FnOnce(StatsError) -> ReportError {
    let context = context.into();
    move |source| ReportError::Stats { context, source }
}

/// `x` (a share) as a percent with one decimal, as the paper prints it.
pub(crate) fn percent(share: f64) -> String {
    format!("{:.1}", 100.0 * share)
}

fn p_text(p: f64) -> String {
    if p < 0.001 { "<0.001".into() } else { format!("{p:.3}") }
}

fn indicator(value: bool) -> f64 {
    if value { 1.0 } else { 0.0 }
}

/// The success rate of one run: the mean of its 0/1 outcomes.
pub(crate) fn success_rate(run: &Run<'_>) -> Result<f64, ReportError> {
    let outcomes: Vec<f64> = run.records.iter().map(|(_, r)| indicator(success(r))).collect();
    stats::mean(&outcomes).map_err(stats_error(format!("success rate of {}", run_name(run))))
}

fn run_name(run: &Run<'_>) -> String {
    run.sets.iter().map(|s| s.path.display().to_string()).collect::<Vec<_>>().join(", ")
}

/// Tasks per run: `20`, or `20 × 3` for three runs of 20, or `18–20 × 3`.
fn tasks_text(counts: &[usize]) -> String {
    let (min, max) = (counts.iter().min().copied().unwrap_or(0), counts.iter().max().copied().unwrap_or(0));
    let n = if min == max { min.to_string() } else { format!("{min}–{max}") };
    if counts.len() > 1 { format!("{n} × {}", counts.len()) } else { n }
}

/// The mean over runs of a per-run value (those runs that have one); `None` if none has.
fn mean_over_runs(values: Vec<Option<f64>>, context: &str) -> Result<Option<f64>, ReportError> {
    let values: Vec<f64> = values.into_iter().flatten().collect();
    if values.is_empty() { Ok(None) } else { stats::mean(&values).map(Some).map_err(stats_error(context)) }
}

/// The share of `records` for which `test` holds, by [`stats::mean`] over 0/1 values.
fn share(records: &[&Record], test: impl Fn(&Record) -> bool, context: &str) -> Result<Option<f64>, ReportError> {
    if records.is_empty() {
        return Ok(None);
    }
    let values: Vec<f64> = records.iter().map(|r| indicator(test(r))).collect();
    stats::mean(&values).map(Some).map_err(stats_error(context))
}

fn has_setting<'c>(conditions: impl IntoIterator<Item = &'c Condition>) -> bool {
    conditions.into_iter().any(|c| !c.setting.is_empty())
}

fn condition_cells(condition: &Condition, with_setting: bool) -> Vec<Cell> {
    let mut cells = vec![Cell::from(condition.approach.as_str()), Cell::from(condition.model.as_str())];
    if with_setting {
        cells.push(Cell::from(condition.setting.as_str()));
    }
    cells
}

/// Every table, in the paper's order.
pub(crate) fn tables(study: &Study<'_>, options: &ReportOptions) -> Result<Vec<Table>, ReportError> {
    let mut tables = vec![success_table(study)?, ablation_table(study)?, phase2_table(study, options)?, accuracy_table(study, options)?];
    tables.extend(mcnemar_tables(study, options)?);
    tables.push(terminal_table(study)?);
    tables.push(failure_response_table(study)?);
    tables.push(attribution_table(study)?);
    Ok(tables)
}

/// One success cell: the mean success rate over the runs, with the tasks behind it.
fn success_cell(runs: &[Run<'_>]) -> Result<Cell, ReportError> {
    if runs.is_empty() {
        return Ok(Cell::from("—"));
    }
    let rates: Vec<f64> = runs.iter().map(success_rate).collect::<Result<_, _>>()?;
    let summary = stats::summarize_runs(&rates).map_err(stats_error("success over runs"))?;
    let counts: Vec<usize> = runs.iter().map(|r| r.records.len()).collect();
    Ok(Cell::from(format!("{} (n={})", percent(summary.mean), tasks_text(&counts))))
}

fn success_table(study: &Study<'_>) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "success",
        "Task success (%) (Table 1)",
        "Task success (%) per condition and benchmark: the success rate of the designated run (of a condition run with several \
         seeds, the first in seed order: seed 0, which the paper's main tables report; Table 7 gives the mean over runs); \
         n = tasks. Model: the model of both phases, or Phase I's / Phase II's where they differ (sweep: the systematic explorer, which uses \
         none). Best per column in bold.",
        "No records.",
    );
    let with_setting = has_setting(&study.conditions);
    table.column("Approach", false);
    table.column("Model", false);
    if with_setting {
        table.column("Setting", false);
    }
    let first = table.columns.len();
    for benchmark in &study.benchmarks {
        table.column(benchmark.as_str(), true);
    }
    for (c, condition) in study.conditions.iter().enumerate() {
        let mut row = condition_cells(condition, with_setting);
        for b in 0..study.benchmarks.len() {
            row.push(success_cell(study.designated(c, b))?);
        }
        table.rows.push(row);
    }
    table.bold_best(first..table.columns.len());
    Ok(table)
}

fn ablation_table(study: &Study<'_>) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "ablation",
        "Component ablation (Table 2)",
        "Task success (%) of the agent `ours` under each Phase II condition: search (MCTS) and token-level constraints on or off; \
         the designated run (seed 0) of a condition run with several seeds. Best per column in bold.",
        "No records of the agent `ours`: the ablation compares its Phase II conditions (`--mode`).",
    );
    let ours: Vec<(usize, &Condition)> = study.conditions.iter().enumerate().filter(|(_, c)| c.agent == "ours").collect();
    let with_setting = has_setting(ours.iter().map(|(_, c)| *c));
    for (name, numeric) in [("Method", false), ("Search", false), ("Constraints", false), ("Model", false)] {
        table.column(name, numeric);
    }
    if with_setting {
        table.column("Setting", false);
    }
    let first = table.columns.len();
    for benchmark in &study.benchmarks {
        table.column(benchmark.as_str(), true);
    }
    for (c, condition) in ours {
        let mode = condition.mode.as_deref().unwrap_or("constrained-mcts");
        let method = match mode {
            "constrained-mcts" => "Ours",
            "constrained-greedy" | "unconstrained-greedy" | "chat-greedy" => "Greedy",
            "thinking" | "thinking-recommended" => "Thinking",
            "unconstrained-mcts" => "MCTS",
            "constrained-sample" | "sample" => "Sampling",
            other => other,
        };
        let check = |on: bool| Cell::from(if on { "✓" } else { "–" });
        let mut row = vec![
            Cell::from(method),
            check(mode.ends_with("mcts")),
            check(mode.starts_with("constrained")),
            Cell::from(condition.model.as_str()),
        ];
        if with_setting {
            row.push(Cell::from(condition.setting.as_str()));
        }
        for b in 0..study.benchmarks.len() {
            row.push(success_cell(study.designated(c, b))?);
        }
        table.rows.push(row);
    }
    table.bold_best(first..table.columns.len());
    Ok(table)
}

/// Table 8: every Phase II condition of `ours` a row, every model a column under each
/// benchmark, accuracy ± sample sd over runs; bold, per column, the best and every condition
/// not significantly different from it (as Table 7 decides it, among that column's conditions).
fn phase2_table(study: &Study<'_>, options: &ReportOptions) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "phase2-conditions",
        "Phase II conditions by model (Table 8)",
        format!(
            "Task success (%) of the agent `ours` for every model and Phase II condition, as mean ± sample standard deviation \
             over runs (± 0.0: one run). Bold: the best in each column and every result not significantly different from it \
             (exact paired McNemar against the best, the largest p over run pairs, Holm correction within the column, α = {}).",
            options.alpha
        ),
        "No records of the agent `ours`: the table compares its Phase II conditions (`--mode`, `--chat-planner`).",
    );
    let ours: Vec<usize> = (0..study.conditions.len()).filter(|&c| study.conditions[c].agent == "ours").collect();
    let mut models: Vec<&str> = Vec::new();
    let mut rows: Vec<(&str, &str)> = Vec::new();
    for &c in &ours {
        let condition = &study.conditions[c];
        if !models.contains(&condition.model.as_str()) {
            models.push(&condition.model);
        }
        if !rows.contains(&(condition.approach.as_str(), condition.setting.as_str())) {
            rows.push((&condition.approach, &condition.setting));
        }
    }
    let with_setting = rows.iter().any(|(_, setting)| !setting.is_empty());
    table.column("Condition", false);
    if with_setting {
        table.column("Setting", false);
    }
    // A column per model under each benchmark, where some condition of that model ran there.
    let ran = |b: usize, model: &str| ours.iter().any(|&c| study.conditions[c].model == model && !study.runs(c, b).is_empty());
    let columns: Vec<(usize, &str)> =
        (0..study.benchmarks.len()).flat_map(|b| models.iter().filter(move |m| ran(b, m)).map(move |m| (b, *m))).collect();
    let first = table.columns.len();
    for &(b, model) in &columns {
        table.grouped_column(study.benchmarks[b].as_str(), model, true);
    }
    for (approach, setting) in &rows {
        let mut row = vec![Cell::from(*approach)];
        if with_setting {
            row.push(Cell::from(*setting));
        }
        row.extend(columns.iter().map(|_| Cell::from("—")));
        table.rows.push(row);
    }
    let row_of = |c: usize| {
        let condition = &study.conditions[c];
        rows.iter().position(|&(a, s)| a == condition.approach && s == condition.setting).unwrap_or_default()
    };
    for (k, &(b, model)) in columns.iter().enumerate() {
        let column = first + k;
        let mut means = Vec::new();
        for &c in &ours {
            let runs = study.runs(c, b);
            if study.conditions[c].model != model || runs.is_empty() {
                continue;
            }
            let (mean, text) = accuracy_over_runs(runs, "Table 8's accuracy over runs")?;
            table.rows[row_of(c)][column] = Cell::from(text);
            means.push((c, mean));
        }
        for c in not_worse_than_the_best(study, b, &means, options)? {
            table.rows[row_of(c)][column].bold = true;
        }
        let runs: Vec<&Run<'_>> = ours.iter().filter(|&&c| study.conditions[c].model == model).flat_map(|&c| study.runs(c, b)).collect();
        table.notes.extend(shared_handover_note(&study.benchmarks[b], model, &runs));
    }
    Ok(table)
}

/// Whether the Phase II conditions of one model on one benchmark planned from the same Phase I
/// state, as the paper's Phase II comparisons do ("they differ only in planning"): each
/// condition runs Phase I again, greedily, so they should; a served model that answers
/// otherwise, or records of another harness, would not. Compares every run's last hand-over
/// (ŝ0 and β, the episode's `handover`; none where none was made) on the tasks all the runs
/// share. `None` with fewer than two runs or no task to compare.
fn shared_handover_note(benchmark: &str, model: &str, runs: &[&Run<'_>]) -> Option<String> {
    if runs.len() < 2 {
        return None;
    }
    // A record without its episode (a hand-written one, an older file) cannot be compared.
    let handover = |record: &Record| record.fields.get("episode").map(|e| e.get("handover").cloned().unwrap_or(serde_json::Value::Null));
    let by_task: Vec<BTreeMap<&str, Option<serde_json::Value>>> =
        runs.iter().map(|run| run.records.iter().map(|(_, r)| (super::study::task(r), handover(r))).collect()).collect();
    let shared: Vec<&str> = by_task[0].keys().copied().filter(|t| by_task[1..].iter().all(|m| m.contains_key(t))).collect();
    let (compared, unknown): (Vec<&str>, Vec<&str>) = shared.iter().partition(|t| by_task.iter().all(|m| m[*t].is_some()));
    if compared.is_empty() {
        return None;
    }
    let differ: Vec<&str> = compared.iter().copied().filter(|t| by_task[1..].iter().any(|m| m[t] != by_task[0][t])).collect();
    let mut note = format!(
        "{benchmark}, {model}: Phase I's hand-over (ŝ0 and β) is the same in all {} runs on {} of the {} tasks they share",
        runs.len(),
        compared.len() - differ.len(),
        compared.len()
    );
    if !unknown.is_empty() {
        note.push_str(&format!(" and whose records hold the episode ({} without it left out)", unknown.len()));
    }
    if !differ.is_empty() {
        let shown: Vec<&str> = differ.iter().copied().take(5).collect();
        note.push_str(&format!(
            "; on the other {} ({}{}) the conditions planned from different states, so they differ in more than planning",
            differ.len(),
            shown.join(", "),
            if differ.len() > shown.len() { ", …" } else { "" }
        ));
    }
    note.push('.');
    Some(note)
}

/// The mean success rate over `runs` and its cell text, `mean ± sample sd` (± 0.0: one run).
fn accuracy_over_runs(runs: &[Run<'_>], context: &str) -> Result<(f64, String), ReportError> {
    let rates: Vec<f64> = runs.iter().map(success_rate).collect::<Result<_, _>>()?;
    let summary = stats::summarize_runs(&rates).map_err(stats_error(context))?;
    Ok((summary.mean, format!("{} ± {}", percent(summary.mean), percent(summary.sample_std_dev.unwrap_or(0.0)))))
}

fn accuracy_table(study: &Study<'_>, options: &ReportOptions) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "accuracy",
        "Accuracy and robustness (Table 7)",
        format!(
            "Accuracy (%) as mean ± sample standard deviation over runs (a condition with one run is marked ± 0.0, as the paper marks \
             deterministic conditions), and the {:.0}% percentile task-cluster bootstrap interval ({} replicates, seed {}; each \
             replicate resamples tasks, a task's runs kept together). Bold: the highest accuracy on each benchmark and the \
             results not significantly different from it (exact paired McNemar against the best condition on the tasks both \
             ran, the largest p over run pairs, Holm correction within the benchmark, α = {}).",
            100.0 * options.bootstrap.confidence,
            options.bootstrap.replicates,
            options.bootstrap.seed,
            options.alpha
        ),
        "No records.",
    );
    let with_setting = has_setting(&study.conditions);
    table.column("Approach", false);
    table.column("Model", false);
    if with_setting {
        table.column("Setting", false);
    }
    table.column("Runs", true);
    let first = table.columns.len();
    for benchmark in &study.benchmarks {
        table.grouped_column(benchmark.as_str(), "Accuracy (%)", true);
        table.grouped_column(benchmark.as_str(), "95% CI", true);
    }
    // Per benchmark, each condition that ran there and its mean accuracy.
    let mut per_benchmark: Vec<Vec<(usize, f64)>> = vec![Vec::new(); study.benchmarks.len()];
    for (c, condition) in study.conditions.iter().enumerate() {
        let mut row = condition_cells(condition, with_setting);
        let counts: BTreeSet<usize> = (0..study.benchmarks.len()).map(|b| study.runs(c, b).len()).filter(|n| *n > 0).collect();
        row.push(Cell::from(counts.iter().map(usize::to_string).collect::<Vec<_>>().join("/")));
        for (b, means) in per_benchmark.iter_mut().enumerate() {
            let runs = study.runs(c, b);
            if runs.is_empty() {
                row.extend([Cell::from("—"), Cell::from("—")]);
                continue;
            }
            let (mean, accuracy) = accuracy_over_runs(runs, "accuracy over runs")?;
            let mut by_task: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
            for run in runs {
                for (task, ok) in run.outcomes() {
                    by_task.entry(task).or_default().push(indicator(ok));
                }
            }
            // Runs of different task sets (one cut short, a subset edited between them) are
            // averaged as they are, and said so: each run's task count beside the accuracy.
            let outcomes: Vec<BTreeMap<&str, bool>> = runs.iter().map(Run::outcomes).collect();
            let accuracy = if outcomes.windows(2).all(|w| w[0].keys().eq(w[1].keys())) {
                accuracy
            } else {
                let counts: Vec<String> = outcomes.iter().map(|o| o.len().to_string()).collect();
                format!("{accuracy} (runs of {} tasks)", counts.join("/"))
            };
            let tasks: Vec<Vec<f64>> = by_task.into_values().collect();
            let interval = stats::task_cluster_bootstrap(&tasks, &options.bootstrap).map_err(stats_error(format!(
                "bootstrap of {} on {}",
                condition.label(),
                study.benchmarks[b]
            )))?;
            row.push(Cell::from(accuracy));
            row.push(Cell::from(format!("[{}, {}]", percent(interval.lower), percent(interval.upper))));
            means.push((c, mean));
        }
        table.rows.push(row);
    }
    for (b, means) in per_benchmark.iter().enumerate() {
        for c in not_worse_than_the_best(study, b, means, options)? {
            table.rows[c][first + 2 * b].bold = true;
        }
    }
    Ok(table)
}

/// The conditions to bold on benchmark `b`, given each condition's mean accuracy there: those
/// with the highest mean, and every other whose exact McNemar test against the (first) best,
/// Holm-corrected over the benchmark's tests, is not significant at `options.alpha`. A
/// condition sharing no task with the best cannot be compared and is not bold.
fn not_worse_than_the_best(
    study: &Study<'_>,
    b: usize,
    means: &[(usize, f64)],
    options: &ReportOptions,
) -> Result<Vec<usize>, ReportError> {
    let Some(best) = means.iter().map(|&(_, m)| m).reduce(f64::max) else { return Ok(Vec::new()) };
    let mut bold: Vec<usize> = means.iter().filter(|&&(_, m)| m == best).map(|&(c, _)| c).collect();
    let reference = bold[0];
    let mut tested = Vec::new();
    for &(c, mean) in means {
        if mean == best {
            continue;
        }
        if let Some((_, test)) = mcnemar_test(study.runs(reference, b), study.runs(c, b))? {
            tested.push((c, test.p_value));
        }
    }
    if !tested.is_empty() {
        let raw: Vec<f64> = tested.iter().map(|&(_, p)| p).collect();
        let adjusted = stats::holm_adjust(&raw).map_err(stats_error("Holm correction of Table 7's comparisons"))?;
        bold.extend(tested.iter().zip(adjusted).filter(|(_, p)| *p >= options.alpha).map(|(&(c, _), _)| c));
    }
    bold.sort_unstable();
    Ok(bold)
}

/// One McNemar test: a pair of conditions on one benchmark.
struct Test {
    pair: (usize, usize),
    benchmark: usize,
    /// Tasks both runs of the pair whose p is kept ran.
    tasks: usize,
    first_only: u64,
    second_only: u64,
    p: f64,
    holm: f64,
}

/// The paper's two families of comparisons (Appendix B), and the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Family {
    /// The method against the direct policies, unconstrained thinking and the embodied and API
    /// policies, and against itself at another model scale (Table 9).
    Main,
    /// The method against constrained greedy and unconstrained MCTS from the same Phase I
    /// (Table 10).
    Ablation,
    /// Pairs the paper does not test (among baselines; the method against other Phase II
    /// conditions, the A* planner or the expert), Holm-corrected among themselves.
    Other,
}

fn family(a: &Condition, b: &Condition) -> Family {
    let (method, other) = match (a.is_method(), b.is_method()) {
        (true, false) => (a, b),
        (false, true) => (b, a),
        (true, true) if a.model != b.model => return Family::Main,
        _ => return Family::Other,
    };
    let ablated = other.agent == "ours"
        && matches!(other.mode.as_deref(), Some("constrained-greedy" | "unconstrained-mcts"))
        && method.without_mode() == other.without_mode();
    if ablated {
        Family::Ablation
    } else if other.agent == "direct" || other.is_thinking() {
        Family::Main
    } else {
        Family::Other
    }
}

/// The run pairs a McNemar test of two conditions compares (Appendix B): a condition with one
/// run (a deterministic one) against each run of the other; two conditions with several runs
/// seed with seed, and a run whose seed the other condition lacks against each of its runs
/// (with no seed in common, every run with every run), so that no run is left out.
fn run_pairs<'r, 'a>(first: &'r [Run<'a>], second: &'r [Run<'a>]) -> Vec<(&'r Run<'a>, &'r Run<'a>)> {
    let every = first.iter().flat_map(|a| second.iter().map(move |b| (a, b)));
    if first.len() == 1 || second.len() == 1 {
        return every.collect();
    }
    let unmatched = |run: &Run<'_>, others: &[Run<'_>]| !others.iter().any(|other| other.seed == run.seed);
    every.filter(|(a, b)| a.seed == b.seed || unmatched(a, second) || unmatched(b, first)).collect()
}

/// The exact McNemar test of two conditions: each run pair ([`run_pairs`]) on the tasks both of
/// its runs hold, and of those the largest p (the paper's conservative rule), with the task
/// count of its pair. `None` where no pair shares a task.
fn mcnemar_test(first: &[Run<'_>], second: &[Run<'_>]) -> Result<Option<(usize, stats::McNemar)>, ReportError> {
    let mut worst: Option<(usize, stats::McNemar)> = None;
    for (a, b) in run_pairs(first, second) {
        let (a, b) = (a.outcomes(), b.outcomes());
        let (va, vb): (Vec<bool>, Vec<bool>) = a.iter().filter_map(|(task, &x)| b.get(task).map(|&y| (x, y))).unzip();
        if va.is_empty() {
            continue;
        }
        let test = stats::mcnemar_exact(&va, &vb).map_err(stats_error("McNemar"))?;
        if worst.is_none_or(|(_, w)| test.p_value > w.p_value) {
            worst = Some((va.len(), test));
        }
    }
    Ok(worst)
}

fn mcnemar_tables(study: &Study<'_>, options: &ReportOptions) -> Result<Vec<Table>, ReportError> {
    let mut families: [Vec<Test>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let n = study.conditions.len();
    for benchmark in 0..study.benchmarks.len() {
        for i in 0..n {
            for j in i + 1..n {
                let (first, second) = (study.runs(i, benchmark), study.runs(j, benchmark));
                if first.is_empty() || second.is_empty() {
                    continue;
                }
                if let Some((tasks, test)) = mcnemar_test(first, second)? {
                    let family = match family(&study.conditions[i], &study.conditions[j]) {
                        Family::Main => 0,
                        Family::Ablation => 1,
                        Family::Other => 2,
                    };
                    families[family].push(Test {
                        pair: (i, j),
                        benchmark,
                        tasks,
                        first_only: test.first_only,
                        second_only: test.second_only,
                        p: test.p_value,
                        holm: 1.0,
                    });
                }
            }
        }
    }
    for family in &mut families {
        if family.is_empty() {
            continue;
        }
        let raw: Vec<f64> = family.iter().map(|t| t.p).collect();
        let adjusted = stats::holm_adjust(&raw).map_err(stats_error("Holm correction"))?;
        for (test, holm) in family.iter_mut().zip(adjusted) {
            test.holm = holm;
        }
    }
    let [main, ablation, other] = families;
    let described = |what: &str, tests: &[Test]| {
        format!(
            "Exact paired McNemar tests ({what}; m = {} tests), Holm correction within the family, significant at α = {}. \
             n = tasks both runs ran; b/c = tasks only the first / only the second solved. A condition with several runs \
             is paired run by run (against one run, each run; against several, seed with seed, a run without a match with \
             each) and the largest exact p \
             over the pairs is kept, with its pair's n and b/c.",
            tests.len(),
            options.alpha
        )
    };
    Ok(vec![
        mcnemar_table(
            study,
            "mcnemar-main",
            "Paired significance: main comparisons (Table 9)",
            described(
                "the paper's main family: the method, `ours` with constrained MCTS, against the direct policies and the thinking \
                 conditions, and against itself with another model",
                &main,
            ),
            "No main comparison: records of the method (`ours`, constrained MCTS) and of a direct policy, a thinking condition \
             or the method with another model, on shared tasks.",
            &main,
            options,
        ),
        mcnemar_table(
            study,
            "mcnemar-ablation",
            "Paired significance: component ablations (Table 10)",
            described(
                "the paper's ablation family: the method against constrained greedy and unconstrained MCTS, otherwise equal",
                &ablation,
            ),
            "No ablation pair: records of `ours` under constrained MCTS and under constrained greedy or unconstrained MCTS, \
             otherwise equal, on shared tasks.",
            &ablation,
            options,
        ),
        mcnemar_table(
            study,
            "mcnemar-other",
            "Paired significance: comparisons beyond the paper's families",
            described("every other pair of conditions, a family of its own so that the paper's two keep their size", &other),
            "No other pair of conditions shares a task on any benchmark.",
            &other,
            options,
        ),
    ])
}

fn mcnemar_table(
    study: &Study<'_>,
    id: &'static str,
    title: &str,
    caption: String,
    empty: &str,
    tests: &[Test],
    options: &ReportOptions,
) -> Table {
    let mut table = Table::new(id, title, caption, empty);
    table.column("Comparison", false);
    for benchmark in &study.benchmarks {
        table.grouped_column(benchmark.as_str(), "n (b/c)", true);
        table.grouped_column(benchmark.as_str(), "p", true);
        table.grouped_column(benchmark.as_str(), "Holm p", true);
        table.grouped_column(benchmark.as_str(), "Sig.", false);
    }
    let pairs: BTreeSet<(usize, usize)> = tests.iter().map(|t| t.pair).collect();
    for (i, j) in pairs {
        let mut row = vec![Cell::from(format!("{} vs. {}", study.conditions[i].label(), study.conditions[j].label()))];
        for b in 0..study.benchmarks.len() {
            match tests.iter().find(|t| t.pair == (i, j) && t.benchmark == b) {
                Some(t) => row.extend([
                    Cell::from(format!("{} ({}/{})", t.tasks, t.first_only, t.second_only)),
                    Cell::from(p_text(t.p)),
                    Cell::from(p_text(t.holm)),
                    Cell::from(if t.holm < options.alpha { "✓" } else { "–" }),
                ]),
                None => row.extend(["—", "—", "—", "—"].map(Cell::from)),
            }
        }
        table.rows.push(row);
    }
    table
}

/// Rows per benchmark, then condition, for the cells whose records `holds` something: every
/// run of each, or the designated run only ([`Study::designated`]).
fn environment_rows<'s, 'a>(study: &'s Study<'a>, designated: bool, holds: impl Fn(&Record) -> bool) -> Vec<(usize, usize, &'s [Run<'a>])> {
    let mut rows = Vec::new();
    for b in 0..study.benchmarks.len() {
        for c in 0..study.conditions.len() {
            let runs = if designated { study.designated(c, b) } else { study.runs(c, b) };
            if runs.iter().any(|run| run.records.iter().any(|(_, r)| holds(r))) {
                rows.push((b, c, runs));
            }
        }
    }
    rows
}

fn environment_columns(table: &mut Table, with_setting: bool) {
    for name in ["Environment", "Approach", "Model"] {
        table.column(name, false);
    }
    if with_setting {
        table.column("Setting", false);
    }
    table.column("Tasks", true);
}

fn environment_cells(study: &Study<'_>, b: usize, c: usize, counts: &[usize], with_setting: bool) -> Vec<Cell> {
    let mut row = vec![Cell::from(study.benchmarks[b].as_str())];
    row.extend(condition_cells(&study.conditions[c], with_setting));
    row.push(Cell::from(tasks_text(counts)));
    row
}

fn optional_percent(value: Option<f64>) -> Cell {
    Cell::from(value.map_or_else(|| "–".to_string(), percent))
}

fn terminal_table(study: &Study<'_>) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "terminal",
        "Terminal mechanism (Table 11)",
        "How each episode ended, as a percentage of all tasks (the designated run: seed 0 of a condition run with several \
         seeds, as the paper's Table 11): success; grounding (a refused request ended the \
         episode, or for `ours` a plan with a refused step ran to its end short of the goal); the interaction limit; the \
         model's own Done (for `ours`, also a plan that ran to its end, every step executed, short of the goal); Phase II's search budget (`ours` only: no plan).",
        "No records carry a terminal mechanism (`terminal`): the expert's records do not.",
    );
    let rows = environment_rows(study, true, |r| metrics::terminal(r).is_some());
    let with_setting = has_setting(rows.iter().map(|(_, c, _)| &study.conditions[*c]));
    environment_columns(&mut table, with_setting);
    let kinds = [
        ("success", "Success"),
        ("grounding", "Grounding"),
        ("interaction-limit", "Interaction limit"),
        ("model-done", "Model Done"),
        ("search-budget", "Search budget"),
    ];
    for (_, name) in kinds {
        table.column(name, true);
    }
    for (b, c, runs) in rows {
        let per_run: Vec<Vec<&Record>> =
            runs.iter().map(|run| run.records.iter().map(|(_, r)| *r).filter(|r| metrics::terminal(r).is_some()).collect()).collect();
        let counts: Vec<usize> = per_run.iter().map(Vec::len).collect();
        let mut row = environment_cells(study, b, c, &counts, with_setting);
        for (kind, _) in kinds {
            let shares = per_run
                .iter()
                .map(|records| share(records, |r| metrics::terminal(r) == Some(kind), "terminal share"))
                .collect::<Result<_, _>>()?;
            row.push(optional_percent(mean_over_runs(shares, "terminal share over runs")?));
        }
        table.rows.push(row);
    }
    Ok(table)
}

fn failure_response_table(study: &Study<'_>) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "failure-response",
        "Failure response (Table 12)",
        "Encounters failure: tasks with a request the environment did not execute (% of all tasks). Recovers task: success among \
         those tasks. Repeats request: failed requests followed at once by the same request (% of failed requests followed by \
         another). Persistent loop: tasks with five identical consecutive requests or a six-step two-action oscillation (% of all \
         tasks). The designated run (seed 0 of a condition run with several seeds, as the paper's Table 12); – where nothing \
         was counted. A reply that named no action is a failed turn but no request: it repeats nothing and makes no loop.",
        "No records carry a failure response (`failure_response`): the expert's records do not.",
    );
    let rows = environment_rows(study, true, |r| metrics::failure_flag(r, "encounters_failure").is_some());
    let with_setting = has_setting(rows.iter().map(|(_, c, _)| &study.conditions[*c]));
    environment_columns(&mut table, with_setting);
    for name in ["Encounters failure", "Recovers task", "Repeats request", "Persistent loop"] {
        table.column(name, true);
    }
    let mut fell_back = false;
    for (b, c, runs) in rows {
        let per_run: Vec<Vec<&Record>> = runs
            .iter()
            .map(|run| run.records.iter().map(|(_, r)| *r).filter(|r| metrics::failure_flag(r, "encounters_failure").is_some()).collect())
            .collect();
        let counts: Vec<usize> = per_run.iter().map(Vec::len).collect();
        let mut row = environment_cells(study, b, c, &counts, with_setting);
        let flag = |r: &Record, name: &str| metrics::failure_flag(r, name) == Some(true);
        let (mut encounters, mut recovers, mut repeats, mut loops) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut marked = false;
        for records in &per_run {
            encounters.push(share(records, |r| flag(r, "encounters_failure"), "encounters failure")?);
            let affected: Vec<&Record> = records.iter().copied().filter(|r| flag(r, "encounters_failure")).collect();
            recovers.push(share(&affected, success, "recovers task")?);
            loops.push(share(records, |r| flag(r, "persistent_loop"), "persistent loop")?);
            let requests: Option<Vec<Vec<(&str, bool)>>> = records.iter().map(|r| metrics::requests(r)).collect();
            match requests {
                Some(requests) => {
                    let mut followed = Vec::new();
                    for request in &requests {
                        let (failed, repeated) = crate::behaviour::failed_transitions(request);
                        followed.extend(std::iter::repeat_n(1.0, repeated));
                        followed.extend(std::iter::repeat_n(0.0, failed - repeated));
                    }
                    repeats.push(if followed.is_empty() {
                        None
                    } else {
                        Some(stats::mean(&followed).map_err(stats_error("repeats request"))?)
                    });
                }
                // Without the requests, the share of affected tasks that repeated one.
                None => {
                    marked = true;
                    repeats.push(share(&affected, |r| flag(r, "repeats_failed_request"), "repeats request")?);
                }
            }
        }
        fell_back |= marked;
        row.push(optional_percent(mean_over_runs(encounters, "encounters failure over runs")?));
        row.push(optional_percent(mean_over_runs(recovers, "recovers task over runs")?));
        let mut repeats = optional_percent(mean_over_runs(repeats, "repeats request over runs")?);
        if marked {
            repeats.text.push_str(" †");
        }
        row.push(repeats);
        row.push(optional_percent(mean_over_runs(loops, "persistent loop over runs")?));
        table.rows.push(row);
    }
    if fell_back {
        table.notes.push("† These records hold no request list: the share of affected tasks that repeated a failed request.".into());
    }
    Ok(table)
}

/// The failure classes in the order of the paper's attribution figures, with their names.
pub(crate) const ATTRIBUTION_NAMES: [(&str, &str); 4] =
    [("representation", "Representation"), ("search", "Search"), ("grounding", "Grounding"), ("goal", "Goal not reached")];

/// Failure attribution of one condition on one benchmark, as shares of all tasks (means over
/// runs).
pub(crate) struct AttributionShares {
    /// Records with an `attribution` field, per run.
    pub counts: Vec<usize>,
    pub successes: f64,
    /// Each failure class of [`ATTRIBUTION_NAMES`], then failures with no class.
    pub classes: Vec<f64>,
}

/// The attribution shares of `runs`; `None` where no run's records carry `attribution`.
pub(crate) fn attribution_shares(runs: &[Run<'_>]) -> Result<Option<AttributionShares>, ReportError> {
    let per_run: Vec<Vec<&Record>> =
        runs.iter().map(|run| run.records.iter().map(|(_, r)| *r).filter(|r| metrics::attribution(r).is_some()).collect()).collect();
    if per_run.iter().all(Vec::is_empty) {
        return Ok(None);
    }
    let counts: Vec<usize> = per_run.iter().map(Vec::len).collect();
    let class_share = |test: &dyn Fn(&Record) -> bool| -> Result<f64, ReportError> {
        let shares = per_run.iter().map(|records| share(records, test, "attribution share")).collect::<Result<_, _>>()?;
        Ok(mean_over_runs(shares, "attribution share over runs")?.unwrap_or(0.0))
    };
    let successes = class_share(&|r: &Record| success(r))?;
    let mut classes = Vec::new();
    for (class, _) in ATTRIBUTION_NAMES {
        debug_assert!(ATTRIBUTIONS.contains(&class));
        classes.push(class_share(&|r: &Record| !success(r) && metrics::attribution(r) == Some(Some(class)))?);
    }
    classes.push(class_share(&|r: &Record| !success(r) && metrics::attribution(r) == Some(None))?);
    Ok(Some(AttributionShares { counts, successes, classes }))
}

fn attribution_table(study: &Study<'_>) -> Result<Table, ReportError> {
    let mut table = Table::new(
        "attribution",
        "Failure attribution (Figures 3 and 5)",
        "Each failed task at the earliest boundary that prevented completion, as a percentage of all tasks (mean over runs): \
         representation (Phase I's state), search (no plan within budget), grounding (a request could not be executed as \
         intended), goal not reached (executable, but the goal is false at the end). Successful tasks contribute to none.",
        "No records carry a failure attribution (`attribution`): the expert's records do not.",
    );
    let rows = environment_rows(study, false, |r| metrics::attribution(r).is_some());
    let with_setting = has_setting(rows.iter().map(|(_, c, _)| &study.conditions[*c]));
    environment_columns(&mut table, with_setting);
    table.column("Success", true);
    for (_, name) in ATTRIBUTION_NAMES {
        table.column(name, true);
    }
    table.column("Unattributed", true);
    for (b, c, runs) in rows {
        let Some(AttributionShares { counts, successes, classes }) = attribution_shares(runs)? else { continue };
        let mut row = environment_cells(study, b, c, &counts, with_setting);
        row.push(Cell::from(percent(successes)));
        row.extend(classes.into_iter().map(|s| Cell::from(percent(s))));
        table.rows.push(row);
    }
    Ok(table)
}
