//! `cargo xtask soundness`: the sound VirtualHome domain on every task of a folder of task
//! files. Per task: (a) A* with LM-cut on the problem `household_sim::vh_pddl::problem` writes,
//! and (b) EAI's gold PDDL plan rewritten for the domain (its classes bound to instances); both
//! validated under the domain, spelled as the executor's script lines and run in our
//! `VirtualhomeEnv`. One JSON line per task, a record of the run's configuration
//! (`eval_harness::records`: resumed, never mixed with another configuration's);
//! `tools/virtualhome_record.py check` runs the same script lines in the real evolving graph.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use eval_harness::records::{RecordFile, config_hash};
use heuristics::search::SearchStatus;
use household_sim::vh_pddl::{self, SOUND_DOMAIN, VhProblem};
use household_sim::{Environment, Event, IdScope, Judge, VhGoal, VirtualhomeEnv, VirtualhomeTask};
use serde_json::json;
use transition_model::{Spelling, TransitionModel};

use crate::input::InputError;

#[derive(Debug, clap::Args)]
pub struct SoundnessArgs {
    /// Folder of task files `<id>.json.gz` [default: fixtures/virtualhome-eai/graphs; every EAI
    /// task: the folder `cargo xtask fetch-data` prints].
    #[arg(long)]
    tasks: Option<PathBuf>,
    /// EAI's problem files (their objects name the task-relevant classes) and gold PDDL plans
    /// [default: fixtures/virtualhome-eai].
    #[arg(long)]
    eai: Option<PathBuf>,
    /// Search time limit per task, seconds.
    #[arg(long, default_value_t = 60.0, value_parser = crate::input::positive_seconds)]
    time_limit: f64,
    /// What `--time-limit` is read on: `wall` (elapsed time) or `cpu` (this process's processor
    /// time, which other work on the machine does not spend, so a task's status does not
    /// depend on the load).
    #[arg(long, default_value = "wall", value_parser = crate::input::clock())]
    clock: heuristics::search::Clock,
    /// Only the first N tasks (sorted ids); their records stay valid for a longer run (the
    /// file holds every record of the configuration: a longer run's too).
    #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
    limit: Option<usize>,
    /// Folder for the records: one JSON line per task in `virtualhome-soundness-<hash>.jsonl`,
    /// named by the run's configuration (the task folder's ids, EAI's files, the domain, the
    /// time limit and its clock), written beside it as `.config.json`. A rerun resumes; a
    /// killed run loses no finished task; another configuration never shares the file.
    #[arg(long, default_value = "target/soundness")]
    out: PathBuf,
    /// Discard earlier records of this configuration instead of resuming.
    #[arg(long)]
    fresh: bool,
}

/// The version of what a soundness record holds: raised whenever the problem writer
/// (`vh_pddl::problem`), the executor (`VirtualhomeEnv`), the gold plans' rewriting or the
/// spelling of script lines changes a row, so that a resumed run never takes the old rows as
/// the new code's; and where the search changes what it finds (A* with LM-cut). 1: the first
/// with records.
pub const SOUNDNESS_VERSION: u32 = 1;

/// A task file's id: its name without `.json.gz` or `.json` (`VirtualhomeTask::load` checks
/// that the task inside has it).
fn task_id(path: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    name.strip_suffix(".json.gz").or(name.strip_suffix(".json")).unwrap_or(name).to_string()
}

pub fn run(args: SoundnessArgs) -> anyhow::Result<ExitCode> {
    crate::input::folder_to_write(&args.out, "--out")?;
    if args.out.extension().is_some_and(|e| e == "jsonl") {
        return Err(InputError(format!(
            "--out {}: a folder for the records (the file is named by the run's configuration, and printed)",
            args.out.display()
        ))
        .into());
    }
    // The defaults are in the fixtures folder `benchmark_data` reads (`NSEA_FIXTURES`, else the
    // checkout's, whatever the working folder), as `eval`'s and `phase2`'s are.
    let fixtures = benchmark_data::fixtures_dir();
    let dir = args.tasks.clone().unwrap_or_else(|| fixtures.join("virtualhome-eai/graphs"));
    let eai = args.eai.clone().unwrap_or_else(|| fixtures.join("virtualhome-eai"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| InputError(format!("{}: cannot read the task folder: {e}", dir.display())))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(".json.gz") || p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    let ids: Vec<String> = files.iter().map(|p| task_id(p)).collect();
    if ids.is_empty() {
        return Err(InputError(format!("{}: no task files (`<id>.json.gz`) there", dir.display())).into());
    }
    let classes = eai_problem_classes(&eai.join("problem_pddl"))?;
    let gold_path = eai.join("gold_pddl_plan.json");
    let gold_text = std::fs::read_to_string(&gold_path).map_err(|e| InputError(format!("{}: cannot read: {e}", gold_path.display())))?;
    let gold: BTreeMap<String, Vec<String>> =
        serde_json::from_str(&gold_text).map_err(|e| InputError(format!("{}: {e}", gold_path.display())))?;
    let domain = pddl_syntax::parse_domain(SOUND_DOMAIN).map_err(|e| anyhow::anyhow!("the sound domain does not parse: {e:?}"))?;

    // The run's configuration names its records: the task list (every task of the folder, so
    // a `--limit` run's records are a longer run's), EAI's files by content, the domain, the
    // search's limit and its clock (named only where it is `cpu`, as in `eval`). The task list
    // is named as every run's is (`task_list_digest`, which `merge` checks); other contents by
    // the records' own short digest (`config_hash`, of their canonical JSON).
    let mut config = json!({
        "command": "soundness",
        "version": SOUNDNESS_VERSION,
        "tasks": {"count": ids.len(), "ids_sha256": eval_harness::records::task_list_digest(ids.iter().map(String::as_str))},
        "gold_sha256": config_hash(&gold),
        "problem_classes_sha256": config_hash(&classes),
        "domain_sha256": config_hash(&SOUND_DOMAIN),
        "time_limit": args.time_limit,
    });
    if !args.clock.is_wall() {
        config["clock"] = json!(<&str>::from(args.clock));
    }
    let mut records = RecordFile::open(&args.out, "virtualhome-soundness", &config, None, args.fresh)
        .and_then(|file| file.check_tasks(&ids.iter().map(String::as_str).collect()).map(|()| file))
        .map_err(|e| InputError(e.to_string()))?;
    records.settle()?;
    let run = args.limit.map_or(files.len(), |n| n.min(files.len()));
    let bar = crate::input::progress_bar("soundness".into(), run);
    for (index, path) in files.iter().enumerate().take(run) {
        bar.inc(1);
        if records.done().contains(&ids[index]) {
            continue;
        }
        let row = check_task(path, &classes, &gold, &domain, &args)?;
        records.append(index, &row)?;
    }
    bar.finish_and_clear();
    // The figures of this run's tasks, those of an earlier run of the configuration included.
    let rows: Vec<&serde_json::Map<String, serde_json::Value>> =
        records.records().iter().filter(|r| r.get("index").and_then(|i| i.as_u64()).is_some_and(|i| (i as usize) < run)).collect();
    let count = |test: &dyn Fn(&serde_json::Map<String, serde_json::Value>) -> bool| rows.iter().filter(|r| test(r)).count();
    let yes = |r: &serde_json::Map<String, serde_json::Value>, key: &str| r.get(key) == Some(&json!(true));
    eprintln!(
        "{run} tasks: (a) A* solved {}, executed and reached the goal in our executor {}; (b) gold PDDL plans {}: valid under the sound domain {}, reached the goal in our executor {}",
        count(&|r| r.get("status").and_then(|s| s.as_str()) == Some("solved")),
        count(&|r| yes(r, "ours_executed") && yes(r, "ours_goal")),
        count(&|r| r.contains_key("gold_plan") || r.contains_key("gold_error")),
        count(&|r| yes(r, "gold_valid")),
        count(&|r| yes(r, "gold_ours_executed") && yes(r, "gold_ours_goal")),
    );
    println!("{}", records.path().display());
    Ok(ExitCode::SUCCESS)
}

/// One task's row: (a) A* with LM-cut on the problem the sound domain's writer makes, and (b)
/// EAI's gold PDDL plan rewritten for the domain; each validated, spelled as script lines and
/// run in our executor.
fn check_task(
    path: &Path,
    classes: &BTreeMap<String, Vec<String>>,
    gold: &BTreeMap<String, Vec<String>>,
    domain: &pddl_syntax::Domain,
    args: &SoundnessArgs,
) -> anyhow::Result<serde_json::Value> {
    let task = VirtualhomeTask::load(path).map_err(|e| InputError(e.to_string()))?;
    let id = task.task_id.clone();
    let task_classes: Vec<&str> = classes.get(&id).map(|c| c.iter().map(String::as_str).collect()).unwrap_or_default();
    let mut row = json!({"task": id, "task_name": task.task_name});
    let problem = match vh_pddl::problem(&task, &task_classes) {
        Ok(p) => p,
        Err(e) => {
            row["status"] = json!("unexpressible");
            row["error"] = json!(e.to_string());
            return Ok(row);
        }
    };
    let parsed =
        pddl_syntax::parse_problem(&problem.text).map_err(|e| anyhow::anyhow!("{id}: the written problem does not parse: {e:?}"))?;
    let model = TransitionModel::new(grounding::ground(domain, &parsed).with_context(|| format!("{id}: grounding"))?);
    row["objects"] = json!(problem.objects.len());
    row["actions"] = json!(model.task().actions.len());

    // (a) A* with LM-cut.
    let start = Instant::now();
    let mut search = heuristics::search::SearchConfig::new(heuristics::search::Algorithm::AStar);
    (search.time_limit, search.clock) = (Some(Duration::from_secs_f64(args.time_limit)), args.clock);
    let result = heuristics::search::optimal_plan_with(&model, &search);
    row["millis"] = json!(start.elapsed().as_secs_f64() * 1e3);
    row["status"] = json!(match &result {
        Ok(_) => "solved",
        Err(SearchStatus::Unsolvable) => "unsolvable",
        Err(_) => "out-of-budget",
    });
    if let Ok(plan) = result {
        let plan: Vec<String> = plan.iter().map(|&a| model.task().action_name(a)).collect();
        let script = spell(&problem, &task, &plan)?;
        let (executed, goal) = run_in_env(&task, &script);
        row["plan"] = json!(plan);
        row["script"] = json!(script);
        row["ours_executed"] = json!(executed);
        row["ours_goal"] = json!(goal);
    }

    // (b) EAI's gold PDDL plan, its classes bound to instances.
    if let Some(steps) = gold.get(&id) {
        match rewrite_gold(&task, &problem, steps) {
            Ok(plan) => {
                let verdict = validate(&model, &plan);
                let script = spell(&problem, &task, &plan)?;
                let (executed, goal) = run_in_env(&task, &script);
                row["gold_plan"] = json!(plan);
                row["gold_script"] = json!(script);
                row["gold_valid"] = json!(verdict.is_ok());
                if let Err(why) = verdict {
                    row["gold_invalid"] = json!(why);
                }
                row["gold_ours_executed"] = json!(executed);
                row["gold_ours_goal"] = json!(goal);
            }
            Err(why) => row["gold_error"] = json!(why),
        }
    }
    Ok(row)
}

/// Task id → the object names of EAI's problem file (`<dir>/<Category>/<id>.pddl`).
fn eai_problem_classes(dir: &Path) -> anyhow::Result<BTreeMap<String, Vec<String>>> {
    let mut out = BTreeMap::new();
    let categories = std::fs::read_dir(dir).map_err(|e| InputError(format!("{}: cannot read: {e}", dir.display())))?;
    for category in categories.flatten() {
        for file in std::fs::read_dir(category.path())?.flatten() {
            let path = file.path();
            let Some(id) = path.file_stem().and_then(|s| s.to_str()).map(str::to_string) else { continue };
            let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
            let problem = pddl_syntax::parse_problem(&text).map_err(|e| InputError(e.render(&path.display().to_string(), &text)))?;
            out.insert(id, problem.objects.iter().map(|o| o.name.text.clone()).collect());
        }
    }
    Ok(out)
}

fn spell(problem: &VhProblem, task: &VirtualhomeTask, plan: &[String]) -> anyhow::Result<Vec<String>> {
    plan.iter().map(|step| problem.script_line(&task.init, step).map_err(|e| anyhow::anyhow!("{}: {step}: {e}", task.task_id))).collect()
}

/// Runs script lines in our executor: (every line executed, every goal holds at the end).
fn run_in_env(task: &VirtualhomeTask, script: &[String]) -> (bool, bool) {
    let mut env = VirtualhomeEnv::new(task.clone(), "virtualhome-eai").with_id_scope(IdScope::Any);
    env.reset();
    let executed = script.iter().all(|line| !matches!(env.step(line).event, Event::NotExecuted { .. }));
    (executed, executed && env.unmet_goals().is_empty())
}

/// `Ok` when the plan is applicable at every step and reaches the goal, else why not.
fn validate(model: &TransitionModel, plan: &[String]) -> Result<(), String> {
    model.validate_text(&Spelling::pddl(model.task()), plan).map(|_| ()).map_err(|e| e.describe(model.task()))
}

/// EAI's gold plan (`walk_towards character plate`) with each class bound to an instance: the
/// instance of that class named by the task's goal, else the lowest id of the class in the
/// problem (the rule of `../shared/anchors/virtualhome_replay.py` without the gold program),
/// written by its name in `problem`.
fn rewrite_gold(task: &VirtualhomeTask, problem: &VhProblem, steps: &[String]) -> Result<Vec<String>, String> {
    let g = &task.init.graph;
    let by_id: BTreeMap<u32, &str> = problem.objects.iter().map(|(n, &id)| (id, n.as_str())).collect();
    let class_of = |id: u32| g.index_of(id).map(|ix| g.node(ix).class_name.as_str());
    let mut bound: BTreeMap<&str, u32> = BTreeMap::new();
    for goal in &task.goals {
        let ids = match goal {
            VhGoal::State { node, .. } => vec![*node],
            VhGoal::Edge { from, to, .. } => vec![*from, *to],
            VhGoal::Action { .. } => vec![],
        };
        for id in ids {
            if let Some(class) = class_of(id) {
                bound.entry(class).or_insert(id);
            }
        }
    }
    let mut plan = Vec::with_capacity(steps.len());
    for step in steps {
        let words: Vec<&str> = step.split_whitespace().collect();
        let mut out = Vec::with_capacity(words.len());
        for (i, word) in words.iter().enumerate() {
            if i == 0 || *word == vh_pddl::CHARACTER {
                out.push(word.to_string());
                continue;
            }
            let id = match bound.get(word) {
                Some(&id) => id,
                None => *by_id
                    .keys()
                    .find(|&&id| class_of(id) == Some(word))
                    .ok_or_else(|| format!("`{word}` names no instance in the problem ({step})"))?,
            };
            out.push(by_id.get(&id).ok_or_else(|| format!("{word} ({id}) is not in the problem"))?.to_string());
        }
        plan.push(format!("({})", out.join(" ")));
    }
    Ok(plan)
}
