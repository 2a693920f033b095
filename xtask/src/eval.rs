//! `cargo xtask eval`: runs an agent on benchmark tasks, one JSONL record per task, and a
//! summary per benchmark.
//!
//! Agents so far: `expert`, which executes the benchmark's own expert plan (ALFWorld's
//! walkthrough as TextWorld commands, EAI's gold PDDL plan) through the project's symbolic
//! pipeline: parse, ground, spell, validate. It is the oracle row of the paper's tables and
//! checks the whole symbolic core on every task. Records are appended and flushed as each
//! task finishes, so a killed run loses nothing; a rerun skips the tasks already recorded
//! (`--fresh` starts over).

use std::collections::BTreeSet;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use benchmark_data::{Benchmark, Extra, TaskFiles};
use serde::{Deserialize, Serialize};
use transition_model::{Spelling, TransitionModel};

#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Benchmarks to run: alfworld-seen, alfworld-train, virtualhome-eai, or all.
    #[arg(long, default_value = "all")]
    benchmark: String,
    /// The agent.
    #[arg(long, default_value = "expert", value_parser = ["expert"])]
    agent: String,
    /// Run at most this many tasks per benchmark.
    #[arg(long)]
    limit: Option<usize>,
    /// Folder for `<benchmark>-<agent>.jsonl` records.
    #[arg(long, default_value = "target/eval")]
    out: PathBuf,
    /// Discard earlier records instead of resuming.
    #[arg(long)]
    fresh: bool,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Serialize, Deserialize)]
struct Record {
    benchmark: String,
    task: String,
    agent: String,
    /// `success`, `failure` (the plan is invalid), or `no-plan` (the benchmark has no expert plan).
    outcome: String,
    steps: usize,
    cost: u64,
    /// Why a plan failed, as the validator says it.
    detail: Option<String>,
    facts: usize,
    actions: usize,
    millis: f64,
}

fn run_task(files: &TaskFiles, agent: &str) -> anyhow::Result<Record> {
    let start = Instant::now();
    let model = TransitionModel::new(crate::input::ground(files)?);
    let (spelling, plan) = match &files.extra {
        Extra::Alfworld(game) => (Spelling::alfworld(model.task(), &game.grammar)?, Some(game.walkthrough.clone())),
        Extra::Virtualhome { gold_plan, .. } => (Spelling::pddl(model.task()), gold_plan.clone()),
        Extra::None => (Spelling::pddl(model.task()), None),
    };
    let mut record = Record {
        benchmark: files.benchmark.name().to_string(),
        task: files.id.clone(),
        agent: agent.to_string(),
        outcome: "no-plan".to_string(),
        steps: 0,
        cost: 0,
        detail: None,
        facts: model.task().facts.len(),
        actions: model.task().actions.len(),
        millis: 0.0,
    };
    if let Some(plan) = plan {
        record.steps = plan.len();
        match model.validate_text(&spelling, &plan) {
            Ok(valid) => {
                record.outcome = "success".to_string();
                record.cost = valid.cost;
            }
            Err(error) => {
                record.outcome = "failure".to_string();
                record.detail = Some(error.describe(model.task()));
            }
        }
    }
    record.millis = start.elapsed().as_secs_f64() * 1e3;
    Ok(record)
}

pub fn run(args: EvalArgs) -> anyhow::Result<ExitCode> {
    let benchmarks: Vec<Benchmark> = if args.benchmark == "all" {
        vec![Benchmark::AlfworldSeen, Benchmark::AlfworldTrain, Benchmark::VirtualhomeEai]
    } else {
        args.benchmark
            .split(',')
            .map(|name| {
                Benchmark::from_name(name.trim())
                    .ok_or_else(|| crate::input::unknown("benchmark", name, Benchmark::ALL.iter().map(|b| b.name())))
            })
            .collect::<Result<_, _>>()?
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut summaries = serde_json::Map::new();
    for benchmark in benchmarks {
        let path = args.out.join(format!("{}-{}.jsonl", benchmark.name(), args.agent));
        if args.fresh && path.exists() {
            std::fs::remove_file(&path).with_context(|| format!("cannot remove {}", path.display()))?;
        }
        let mut records: Vec<Record> = Vec::new();
        if path.exists() {
            let file = std::fs::File::open(&path).with_context(|| format!("cannot read {}", path.display()))?;
            for (number, line) in std::io::BufReader::new(file).lines().enumerate() {
                let line = line?;
                if line.trim().is_empty() {
                    continue;
                }
                // A line cut short by a killed run is dropped; its task runs again.
                if let Ok(record) = serde_json::from_str::<Record>(&line) {
                    records.push(record);
                } else {
                    eprintln!(
                        "{}:{}: unreadable record (a run was killed while writing?); its task will run again",
                        path.display(),
                        number + 1
                    );
                }
            }
        }
        let done: BTreeSet<String> = records.iter().map(|r| r.task.clone()).collect();
        let tasks = benchmark_data::load(benchmark)?;
        let tasks: Vec<&TaskFiles> = tasks.iter().take(args.limit.unwrap_or(usize::MAX)).collect();
        let mut out = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        let total = tasks.len();
        for (i, files) in tasks.into_iter().enumerate() {
            if done.contains(&files.id) {
                continue;
            }
            let record = run_task(files, &args.agent).with_context(|| format!("task {}", files.id))?;
            writeln!(out, "{}", serde_json::to_string(&record)?)?;
            out.flush()?;
            records.push(record);
            if (i + 1) % 50 == 0 || i + 1 == total {
                eprintln!("{}: {}/{total}", benchmark.name(), i + 1);
            }
        }
        let keep: BTreeSet<String> =
            benchmark_data::load(benchmark)?.iter().take(args.limit.unwrap_or(usize::MAX)).map(|t| t.id.clone()).collect();
        records.retain(|r| keep.contains(&r.task));
        let with_plan: Vec<&Record> = records.iter().filter(|r| r.outcome != "no-plan").collect();
        let successes = with_plan.iter().filter(|r| r.outcome == "success").count();
        let rate = if with_plan.is_empty() { 0.0 } else { successes as f64 / with_plan.len() as f64 };
        let mean_steps =
            if with_plan.is_empty() { 0.0 } else { with_plan.iter().map(|r| r.steps as f64).sum::<f64>() / with_plan.len() as f64 };
        let mean_millis = if records.is_empty() { 0.0 } else { records.iter().map(|r| r.millis).sum::<f64>() / records.len() as f64 };
        if !args.json {
            println!(
                "{:<16} agent={} tasks={} with-plan={} success={}/{} ({:.1}%) mean-steps={mean_steps:.1} mean-ms={mean_millis:.1}  records: {}",
                benchmark.name(),
                args.agent,
                records.len(),
                with_plan.len(),
                successes,
                with_plan.len(),
                rate * 100.0,
                path.display()
            );
        }
        summaries.insert(
            benchmark.name().to_string(),
            serde_json::json!({
                "agent": args.agent,
                "tasks": records.len(),
                "with_plan": with_plan.len(),
                "successes": successes,
                "success_rate": rate,
                "mean_steps": mean_steps,
                "mean_millis": mean_millis,
                "records": path.display().to_string(),
            }),
        );
    }
    if args.json {
        println!("{}", serde_json::Value::Object(summaries));
    }
    Ok(ExitCode::SUCCESS)
}
