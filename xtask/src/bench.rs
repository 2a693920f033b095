//! `cargo xtask bench`: figures beside the reference systems, measured in one run.
//!
//! `bench ground` grounds every fixture problem with our pipeline (parse + check + ground,
//! median of `--runs`) and with Fast Downward 26.6's translator on the same files, one
//! after the other, so both see the same machine load. Fast Downward's time is its own
//! `Done! [... wall-clock]` figure, which leaves out Python's start-up. It comes from the
//! anchor venv (`../shared/anchors/install.sh planning`; `$ANCHOR_VENV` overrides the path).
//! The ALFWorld domain names problem objects (`SinkType`, ...) as constants without
//! declaring them, which Fast Downward 26.6 rejects; for it, those objects are moved into the
//! domain's `:constants` and both files are written by our pretty-printer.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use anyhow::{Context, bail};
use benchmark_data::{Benchmark, Extra, TaskFiles};
use serde_json::json;

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    which: Which,
}

#[derive(Debug, clap::Subcommand)]
enum Which {
    /// Grounding time and size, ours beside Fast Downward's translator.
    Ground {
        /// Benchmarks: ipc, alfworld-seen, alfworld-train, virtualhome-eai, or all.
        #[arg(long, default_value = "all")]
        benchmark: String,
        /// At most this many tasks per benchmark (evenly spaced).
        #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
        limit: Option<usize>,
        /// Timed runs of ours per task (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = crate::input::at_least_one::<usize>)]
        runs: usize,
        /// Skip Fast Downward.
        #[arg(long)]
        no_reference: bool,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Search speed and coverage, ours beside Fast Downward's search on the same files: the IPC
    /// fixtures, or the benchmarks' own problem files (ALFWorld's games, EAI's tasks).
    Plan {
        /// Configurations: astar-lmcut, astar-lmcut-sym (over states up to interchangeable objects), lazy-ff (lazy GBFS with h_FF), lazy-ff-po (with preferred operators).
        #[arg(long, default_value = "lazy-ff,astar-lmcut")]
        configs: String,
        /// Comma-separated benchmarks (ipc, alfworld-seen, alfworld-train, virtualhome-eai).
        #[arg(long, default_value = "ipc")]
        benchmark: String,
        /// At most this many tasks of each benchmark, evenly spaced.
        #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
        limit: Option<usize>,
        /// Seconds per search, for both planners.
        #[arg(long, default_value_t = 60.0, value_parser = crate::input::positive_seconds)]
        time_limit: f64,
        /// Only instances whose id contains this.
        #[arg(long)]
        filter: Option<String>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Heuristic evaluation time and values on the same states, ours beside pyperplan 2.1's
    /// h_max, h_add, h_FF and LM-cut (the anchor venv's; it parses STRIPS with typing, so of the
    /// IPC fixtures all but elevators' action costs).
    Heuristic {
        /// Comma-separated benchmarks (ipc, alfworld-seen, alfworld-train, virtualhome-eai).
        #[arg(long, default_value = "ipc")]
        benchmark: String,
        /// At most this many tasks of each benchmark, evenly spaced.
        #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
        limit: Option<usize>,
        /// Only tasks whose id contains this.
        #[arg(long)]
        filter: Option<String>,
        /// The states: a seeded random walk of this many steps from the initial state (ALFWorld
        /// and EAI: the states along the task's own plan).
        #[arg(long, default_value_t = 50)]
        walk: usize,
        /// Timed passes over the states, for both (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = crate::input::at_least_one::<usize>)]
        runs: usize,
        /// Skip pyperplan.
        #[arg(long)]
        no_reference: bool,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Next-token masks over Qwen3's vocabulary on real states, ours beside llguidance.
    Mask {
        /// A Hugging Face tokenizer.json [default: fixtures/tokenizers/qwen3/tokenizer.json].
        #[arg(long)]
        tokenizer: Option<PathBuf>,
        /// Use every N-th ALFWorld game and VirtualHome problem.
        #[arg(long, default_value_t = 5, value_parser = crate::input::at_least_one::<usize>)]
        every: usize,
        /// Skip llguidance.
        #[arg(long)]
        no_reference: bool,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Household environment speed (reset, step), ours beside the real engine on the same
    /// games and commands (ALFWorld: TextWorld 1.7.0 + alfworld 0.4.2, from install.sh alfworld).
    Env {
        /// ALFWorld's games: this subset of fixtures/ (a name in fixtures/subsets or a file).
        /// VirtualHome's tasks are always the 33 with a gold program in the parity recordings.
        #[arg(long, default_value = "alfworld-seen-50")]
        subset: String,
        /// At most this many ALFWorld games (evenly spaced); the engine takes seconds per game.
        #[arg(long, default_value_t = 12, value_parser = crate::input::at_least_one::<usize>)]
        limit: usize,
        /// Timed repetitions of ours per game (the median is reported).
        #[arg(long, default_value_t = 20, value_parser = crate::input::at_least_one::<usize>)]
        runs: usize,
        /// Skip the real engine.
        #[arg(long)]
        no_reference: bool,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Local language model speed (prefill, decode, branch rewind) beside candle-transformers' quantized llama.
    Lm(crate::lm::BenchLmArgs),
}

pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        Which::Ground { benchmark, limit, runs, no_reference, json } => ground(&benchmark, limit, runs, no_reference, json),
        Which::Plan { configs, benchmark, limit, time_limit, filter, json } => {
            plan(&configs, &benchmark, limit, time_limit, filter.as_deref(), json)
        }
        Which::Heuristic { benchmark, limit, filter, walk, runs, no_reference, json } => {
            heuristic(&benchmark, limit, filter.as_deref(), walk, runs, no_reference, json)
        }
        Which::Mask { tokenizer, every, no_reference, json } => crate::mask_bench::run(tokenizer, every, no_reference, json),
        Which::Env { subset, limit, runs, no_reference, json } => crate::env::bench(&subset, limit, runs, no_reference, json),
        Which::Lm(args) => crate::lm::bench(args),
    }
}

fn anchor_venv() -> PathBuf {
    std::env::var_os("ANCHOR_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache/nsea-anchors/venv"))
}

/// The pristine Fast Downward 26.6 translator: `python -S` keeps site-packages (where the
/// ALFWorld install puts TextWorld's older translator under the same package name) off the path.
fn fd_translator() -> Option<(PathBuf, PathBuf)> {
    let venv = anchor_venv();
    let python = venv.join("bin/python");
    let lib =
        std::fs::read_dir(venv.join("lib")).ok()?.filter_map(|e| e.ok()).map(|e| e.path()).find(|p| p.join("site-packages").is_dir())?;
    let bin = lib.join("site-packages/up_fast_downward/downward/builds/release/bin");
    (python.exists() && bin.join("fast_downward/translate").is_dir()).then_some((python, bin))
}

struct FdResult {
    wall_s: f64,
    facts: u64,
    operators: u64,
}

fn number_after(text: &str, prefix: &str) -> Option<f64> {
    let line = text.lines().find(|l| l.starts_with(prefix))?;
    line[prefix.len()..].trim().split(|c: char| c.is_whitespace() || c == 's').next()?.parse().ok()
}

fn run_fd(python: &Path, bin: &Path, domain: &Path, problem: &Path, scratch: &Path) -> anyhow::Result<FdResult> {
    let output = Command::new(python)
        .args(["-S", "-m", "fast_downward.translate"])
        .arg(domain)
        .arg(problem)
        .arg("--sas-file")
        .arg(scratch.join("output.sas"))
        .env("PYTHONPATH", bin)
        .env("PYTHONHASHSEED", "0")
        .current_dir(scratch)
        .output()
        .context("cannot run Fast Downward's translator")?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        bail!("translator failed ({}): {}", output.status, stdout.lines().rev().take(3).collect::<Vec<_>>().join(" | "));
    }
    let done = stdout.lines().find(|l| l.starts_with("Done! [")).context("no `Done!` line")?;
    let wall_s =
        done.split(',').nth(1).and_then(|p| p.trim().split('s').next()).and_then(|n| n.parse().ok()).context("unreadable `Done!` line")?;
    Ok(FdResult {
        wall_s,
        facts: number_after(&stdout, "Translator facts:").unwrap_or(f64::NAN) as u64,
        operators: number_after(&stdout, "Translator operators:").unwrap_or(f64::NAN) as u64,
    })
}

/// Domain and problem text Fast Downward 26.6 accepts: constants the domain uses but does not
/// declare are moved there from the problem's objects.
fn fd_compatible(files: &TaskFiles) -> anyhow::Result<(String, String)> {
    let mut domain = pddl_syntax::parse_domain(&files.domain)?;
    let mut problem = pddl_syntax::parse_problem(&files.problem)?;
    let declared: Vec<String> = domain.constants.iter().map(|c| c.name.text.clone()).collect();
    let mut used = Vec::new();
    let text = domain.to_string();
    problem.objects.retain(|object| {
        let name = &object.name.text;
        let in_domain =
            !declared.contains(name) && text.split(|c: char| c.is_whitespace() || c == '(' || c == ')').any(|word| word == name.as_str());
        if in_domain {
            used.push(object.clone());
        }
        !in_domain
    });
    domain.constants.extend(used);
    Ok((domain.to_string(), problem.to_string()))
}

/// The files Fast Downward reads for `files`: ALFWorld's rewritten by [`fd_compatible`] into
/// `scratch`, the others as they are.
fn fd_files(files: &TaskFiles, scratch: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
    if !matches!(files.extra, Extra::Alfworld(_)) {
        return Ok((files.domain_path.clone(), files.problem_path.clone()));
    }
    let (domain, problem) = fd_compatible(files)?;
    let (d, p) = (scratch.join("domain.pddl"), scratch.join("problem.pddl"));
    std::fs::write(&d, domain)?;
    std::fs::write(&p, problem)?;
    Ok((d, p))
}

/// `benchmarks` as `--benchmark` names them (a comma list, or `all`).
fn benchmarks_named(benchmarks: &str) -> anyhow::Result<Vec<Benchmark>> {
    if benchmarks == "all" {
        return Ok(vec![Benchmark::Ipc, Benchmark::AlfworldSeen, Benchmark::AlfworldTrain, Benchmark::VirtualhomeEai]);
    }
    let named: Vec<Benchmark> = benchmarks
        .split(',')
        .map(|n| {
            Benchmark::from_name(n.trim()).ok_or_else(|| crate::input::unknown("benchmark", n, Benchmark::ALL.iter().map(|b| b.name())))
        })
        .collect::<Result<_, _>>()?;
    // Twice would time its tasks twice, and its figures would be counted as two sets' (or one
    // overwrite the other).
    if let Some(twice) = named.iter().enumerate().find(|(i, b)| named[..*i].contains(b)).map(|(_, b)| b.name()) {
        return Err(crate::input::InputError(format!("--benchmark names {twice} twice")).into());
    }
    Ok(named)
}

/// Bad input where `--filter` leaves no task: a run of nothing that would print empty tables.
fn check_filter(filter: Option<&str>, matched: usize, benchmarks: &[Benchmark]) -> anyhow::Result<()> {
    match filter {
        Some(filter) if matched == 0 => {
            let names: Vec<&str> = benchmarks.iter().map(|b| b.name()).collect();
            Err(crate::input::InputError(format!("--filter {filter}: no task id of {} (after --limit) contains it", names.join(", ")))
                .into())
        }
        _ => Ok(()),
    }
}

/// At most `limit` of `all`, evenly spaced.
fn spaced<T>(all: &[T], limit: Option<usize>) -> Vec<&T> {
    match limit {
        Some(n) if n < all.len() => (0..n).map(|i| &all[i * all.len() / n]).collect(),
        _ => all.iter().collect(),
    }
}

fn time_ours(files: &TaskFiles, runs: usize) -> anyhow::Result<(f64, grounding::Task)> {
    let mut times = Vec::with_capacity(runs);
    let mut task = None;
    for _ in 0..runs {
        let start = Instant::now();
        let grounded = crate::input::ground(files)?;
        times.push(start.elapsed().as_secs_f64());
        task = Some(grounded);
    }
    Ok((crate::input::median(times), task.context("no run")?))
}

fn ground(benchmarks: &str, limit: Option<usize>, runs: usize, no_reference: bool, json: bool) -> anyhow::Result<ExitCode> {
    let benchmarks = benchmarks_named(benchmarks)?;
    let reference = if no_reference { None } else { fd_translator() };
    if !no_reference && reference.is_none() {
        eprintln!(
            "Fast Downward's translator not found under {}; run ../shared/anchors/install.sh planning (or pass --no-reference)",
            anchor_venv().display()
        );
    }
    let scratch = std::env::temp_dir().join(format!("xtask-bench-ground-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let mut sets = serde_json::Map::new();
    let mut rows = Vec::new();
    for benchmark in benchmarks {
        let all = benchmark_data::load(benchmark)?;
        let tasks: Vec<&TaskFiles> = spaced(&all, limit);
        let bar = crate::input::progress_bar(format!("ground {}", benchmark.name()), tasks.len());
        let (mut ours_total, mut fd_total, mut ratios) = (0.0, 0.0, Vec::new());
        let (mut our_facts, mut our_actions, mut fd_facts, mut fd_operators, mut fd_failed) = (0usize, 0usize, 0u64, 0u64, 0usize);
        for files in &tasks {
            let (ours_s, task) = time_ours(files, runs)?;
            ours_total += ours_s;
            our_facts += task.facts.len();
            our_actions += task.actions.len();
            let mut row = json!({
                "benchmark": benchmark.name(), "task": files.id,
                "ours_ms": ours_s * 1e3, "facts": task.facts.len(), "actions": task.actions.len(),
            });
            if let Some((python, bin)) = &reference {
                let (domain_path, problem_path) = fd_files(files, &scratch)?;
                match run_fd(python, bin, &domain_path, &problem_path, &scratch) {
                    Ok(fd) => {
                        fd_total += fd.wall_s;
                        fd_facts += fd.facts;
                        fd_operators += fd.operators;
                        ratios.push(fd.wall_s / ours_s);
                        row["fd_ms"] = json!(fd.wall_s * 1e3);
                        row["fd_facts"] = json!(fd.facts);
                        row["fd_operators"] = json!(fd.operators);
                        row["speedup"] = json!(fd.wall_s / ours_s);
                    }
                    Err(error) => {
                        fd_failed += 1;
                        row["fd_error"] = json!(error.to_string());
                    }
                }
            }
            if !json {
                bar.suspend(|| println!("{row}"));
            }
            rows.push(row);
            bar.inc(1);
        }
        bar.finish_and_clear();
        ratios.sort_by(f64::total_cmp);
        let median_ratio = ratios.get(ratios.len() / 2).copied();
        let summary = json!({
            "tasks": tasks.len(),
            "ours_total_ms": ours_total * 1e3,
            "fd_total_ms": (reference.is_some()).then_some(fd_total * 1e3),
            "speedup_total": (reference.is_some() && ours_total > 0.0).then(|| fd_total / ours_total),
            "speedup_median": median_ratio,
            "speedup_min": ratios.first(),
            "facts": our_facts, "actions": our_actions,
            "fd_facts": fd_facts, "fd_operators": fd_operators, "fd_failed": fd_failed,
        });
        if !json {
            eprintln!("{}: {summary}", benchmark.name());
        }
        sets.insert(benchmark.name().to_string(), summary);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    if json {
        println!("{}", json!({ "sets": sets, "tasks": rows }));
    }
    Ok(ExitCode::SUCCESS)
}

/// One search configuration, in both planners.
struct PlanConfig {
    name: &'static str,
    algorithm: heuristics::search::Algorithm,
    heuristic: &'static str,
    preferred: bool,
    /// A* over states up to interchangeable objects (`SearchConfig::symmetries`).
    symmetries: bool,
    fast_downward: &'static str,
}

const PLAN_CONFIGS: &[PlanConfig] = &[
    PlanConfig {
        name: "astar-lmcut",
        algorithm: heuristics::search::Algorithm::AStar,
        heuristic: "lmcut",
        preferred: false,
        symmetries: false,
        fast_downward: "astar(lmcut())",
    },
    // Fast Downward 26.6 from PyPI ships no `symmetries` option: compared with its plain A*.
    PlanConfig {
        name: "astar-lmcut-sym",
        algorithm: heuristics::search::Algorithm::AStar,
        heuristic: "lmcut",
        preferred: false,
        symmetries: true,
        fast_downward: "astar(lmcut())",
    },
    PlanConfig {
        name: "lazy-ff",
        algorithm: heuristics::search::Algorithm::LazyGbfs,
        heuristic: "ff",
        preferred: false,
        symmetries: false,
        fast_downward: "lazy_greedy([ff()])",
    },
    PlanConfig {
        name: "lazy-ff-po",
        algorithm: heuristics::search::Algorithm::LazyGbfs,
        heuristic: "ff",
        preferred: true,
        symmetries: false,
        fast_downward: "let(hff, ff(), lazy_greedy([hff], preferred=[hff]))",
    },
];

struct FdSearch {
    /// Why Fast Downward did not search (an unsupported task or configuration).
    error: Option<String>,
    solved: bool,
    cost: Option<u64>,
    expanded: u64,
    search_s: f64,
}

/// The number right after the last `marker` that is followed by one.
fn number_in(text: &str, marker: &str) -> Option<f64> {
    text.lines().rev().find_map(|line| {
        let after = &line[line.find(marker)? + marker.len()..];
        after.trim_start().split(|c: char| !(c.is_ascii_digit() || c == '.')).next()?.parse().ok()
    })
}

/// Expansions so far: the final count, or the last progress line's (`..., N expanded`) if
/// the search was stopped.
fn expansions_in(text: &str) -> u64 {
    if let Some(n) = number_in(text, "] Expanded ") {
        return n as u64;
    }
    text.lines()
        .rev()
        .find_map(|line| {
            let end = line.find(" expanded")?;
            line[..end].rsplit(|c: char| !c.is_ascii_digit()).next()?.parse().ok()
        })
        .unwrap_or(0)
}

fn run_fd_search(downward: &Path, sas: &Path, search: &str, time_limit: f64) -> anyhow::Result<FdSearch> {
    let input = std::fs::File::open(sas).context("output.sas")?;
    let start = Instant::now();
    let output = Command::new("timeout")
        .arg(format!("{time_limit}"))
        .arg(downward)
        .args(["--search", search])
        .stdin(input)
        // Fast Downward writes its plan (`sas_plan`) into the working directory.
        .current_dir(sas.parent().unwrap_or(Path::new(".")))
        .output()
        .context("cannot run Fast Downward's search")?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let solved = stdout.contains("Solution found!");
    // Fast Downward's exit codes (its `returncodes.py`): 11 unsolvable, 12 unsolved by an
    // incomplete search, 22-24 out of memory or time, and `timeout`'s 124 are a search's
    // outcomes; 34 is a task the search does not support (LM-cut with axioms, which ALFWorld's
    // and EAI's goals become); any other failure is an error of its own.
    let error = match output.status.code() {
        Some(34) => Some("unsupported task (exit 34)".to_string()),
        Some(code) if !solved && ![11, 12, 22, 23, 24, 124].contains(&code) => Some(format!("exit {code}")),
        _ => None,
    };
    Ok(FdSearch {
        error,
        solved,
        cost: solved.then(|| number_in(&stdout, "Plan cost:").map(|c| c as u64)).flatten(),
        expanded: expansions_in(&stdout),
        search_s: number_in(&stdout, "Search time:").unwrap_or_else(|| start.elapsed().as_secs_f64()),
    })
}

fn plan(
    configs: &str,
    benchmarks: &str,
    limit: Option<usize>,
    time_limit: f64,
    filter: Option<&str>,
    json: bool,
) -> anyhow::Result<ExitCode> {
    let benchmarks = benchmarks_named(benchmarks)?;
    let chosen: Vec<&PlanConfig> = configs
        .split(',')
        .map(|name| {
            PLAN_CONFIGS
                .iter()
                .find(|c| c.name == name.trim())
                .ok_or_else(|| crate::input::unknown("config", name, PLAN_CONFIGS.iter().map(|c| c.name)))
        })
        .collect::<Result<_, _>>()?;
    let reference = fd_translator();
    let downward = reference.as_ref().map(|(_, bin)| bin.join("downward")).filter(|p| p.exists());
    if downward.is_none() {
        eprintln!("Fast Downward not found under {}; reporting ours only", anchor_venv().display());
    }
    let scratch = std::env::temp_dir().join(format!("xtask-bench-plan-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let mut rows = Vec::new();
    let mut summary = serde_json::Map::new();
    for config in &chosen {
        // Per domain: our coverage; expansions and seconds over the instances both solved (so a
        // slow timeout does not decide the rate; without Fast Downward, those ours solved);
        // Fast Downward's coverage, expansions and seconds over the same; how many.
        let mut per_domain: std::collections::BTreeMap<String, [f64; 7]> = std::collections::BTreeMap::new();
        let mut all = Vec::new();
        for benchmark in &benchmarks {
            let loaded = benchmark_data::load(*benchmark)?;
            all.extend(spaced(&loaded, limit).into_iter().cloned().map(|files| (*benchmark, files)));
        }
        all.retain(|(_, files)| filter.is_none_or(|f| files.id.contains(f)));
        check_filter(filter, all.len(), &benchmarks)?;
        let bar = crate::input::progress_bar(format!("plan {}", config.name), all.len());
        for (benchmark, files) in all {
            bar.set_message(files.id.clone());
            // IPC by its domains; a benchmark's own problems are one domain.
            let domain = match benchmark {
                Benchmark::Ipc => files.id.split('/').next().unwrap_or_default().to_string(),
                other => other.name().to_string(),
            };
            let model = transition_model::TransitionModel::new(crate::input::ground(&files)?);
            let mut heuristic = heuristics::by_name(config.heuristic, &model).context("heuristic")?;
            let mut search_config = heuristics::search::SearchConfig::new(config.algorithm);
            search_config.preferred_operators = config.preferred;
            search_config.symmetries = config.symmetries;
            search_config.time_limit = Some(std::time::Duration::from_secs_f64(time_limit));
            let ours = heuristics::search::search(&model, heuristic.as_mut(), &search_config, None);
            let ours_solved = ours.status == heuristics::search::SearchStatus::Solved;
            let ours_s = ours.elapsed.as_secs_f64();
            let mut row = json!({
                "config": config.name, "task": files.id,
                "solved": ours_solved, "cost": ours_solved.then_some(ours.cost), "expanded": ours.expanded, "search_s": ours_s,
                "expansions_per_s": ours.expanded as f64 / ours_s.max(1e-9),
            });
            let entry = per_domain.entry(domain).or_default();
            entry[0] += f64::from(u8::from(ours_solved));
            if let (Some((python, bin)), Some(downward)) = (&reference, &downward) {
                let (domain_path, problem_path) = fd_files(&files, &scratch)?;
                // A task Fast Downward cannot translate or search is a row of its own (its
                // `fd_error`), not the end of the run.
                let fd = run_fd(python, bin, &domain_path, &problem_path, &scratch)
                    .and_then(|_| run_fd_search(downward, &scratch.join("output.sas"), config.fast_downward, time_limit));
                match fd {
                    Err(error) => row["fd_error"] = json!(error.to_string()),
                    Ok(fd) => {
                        if let Some(error) = &fd.error {
                            row["fd_error"] = json!(error);
                        }
                        row["fd_solved"] = json!(fd.solved);
                        row["fd_cost"] = json!(fd.cost);
                        row["fd_expanded"] = json!(fd.expanded);
                        row["fd_search_s"] = json!(fd.search_s);
                        row["fd_expansions_per_s"] = json!(fd.expanded as f64 / fd.search_s.max(1e-9));
                        entry[3] += f64::from(u8::from(fd.solved));
                        if fd.solved && ours_solved {
                            entry[1] += ours.expanded as f64;
                            entry[2] += ours_s;
                            entry[4] += fd.expanded as f64;
                            entry[5] += fd.search_s;
                            entry[6] += 1.0;
                        }
                    }
                }
            } else if ours_solved {
                // Ours alone: its rate over the tasks it solved.
                entry[1] += ours.expanded as f64;
                entry[2] += ours_s;
                entry[6] += 1.0;
            }
            if !json {
                bar.suspend(|| println!("{row}"));
            }
            rows.push(row);
            bar.inc(1);
        }
        bar.finish_and_clear();
        let mut domains = serde_json::Map::new();
        for (domain, [solved, expanded, seconds, fd_solved, fd_expanded, fd_seconds, both]) in per_domain {
            // Rates over the tasks both planners solved: none (Fast Downward refused them all,
            // as its LM-cut does tasks with conditional effects) is no rate, not a rate of 0.
            // Without Fast Downward, ours over the tasks it solved, and no coverage of its.
            let fd_ran = downward.is_some();
            let both = both > 0.0;
            let rate = both.then(|| expanded / seconds.max(1e-9));
            let fd_rate = (both && fd_ran).then(|| fd_expanded / fd_seconds.max(1e-9));
            domains.insert(
                domain,
                json!({
                    "coverage": solved, "fd_coverage": fd_ran.then_some(fd_solved),
                    "expansions_per_s": rate, "fd_expansions_per_s": fd_rate, "ratio": rate.zip(fd_rate).map(|(r, f)| r / f.max(1e-9)),
                }),
            );
        }
        if !json {
            eprintln!("{}: {}", config.name, serde_json::Value::Object(domains.clone()));
        }
        summary.insert(config.name.to_string(), serde_json::Value::Object(domains));
    }
    let _ = std::fs::remove_dir_all(&scratch);
    if json {
        println!("{}", json!({ "configs": summary, "tasks": rows }));
    }
    Ok(ExitCode::SUCCESS)
}

/// The heuristics `bench heuristic` compares, by our names (pyperplan's script uses the same).
const COMPARED_HEURISTICS: [&str; 4] = ["hmax", "hadd", "ff", "lmcut"];

/// The states `bench heuristic` evaluates: along the task's own plan (ALFWorld's walkthrough,
/// EAI's gold plan), else a seeded random walk of `walk` steps (as `cargo bench -p heuristics`).
fn bench_states(model: &transition_model::TransitionModel, files: &TaskFiles, walk: usize) -> anyhow::Result<Vec<transition_model::State>> {
    use transition_model::Spelling;
    Ok(match &files.extra {
        Extra::Alfworld(game) => {
            let spelling = Spelling::alfworld(model.task(), &game.grammar)?;
            model.states_along(&spelling, &game.walkthrough).map_err(|e| anyhow::anyhow!("{}: the walkthrough: {e:?}", files.id))?
        }
        Extra::Virtualhome { gold_plan: Some(plan), .. } => {
            model.states_along(&Spelling::pddl(model.task()), plan).map_err(|e| anyhow::anyhow!("{}: the gold plan: {e:?}", files.id))?
        }
        _ => model.random_walk(0x9E37_79B9_7F4A_7C15, walk),
    })
}

/// pyperplan's values and seconds per evaluation on `states` ([`COMPARED_HEURISTICS`]), from
/// `tools/pyperplan_heuristics.py` in the anchor venv.
fn run_pyperplan(
    python: &Path,
    files: &TaskFiles,
    facts: &[String],
    states: &[Vec<String>],
    runs: usize,
    scratch: &Path,
) -> anyhow::Result<serde_json::Value> {
    let states_path = scratch.join("states.json");
    std::fs::write(&states_path, serde_json::to_vec(&json!({"facts": facts, "states": states}))?)?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tools/pyperplan_heuristics.py");
    // PDDL files of their own for ALFWorld's games, whose PDDL is inside the game file.
    let (domain_path, problem_path) = fd_files(files, scratch)?;
    let output = Command::new(python)
        .arg(&script)
        .arg(&domain_path)
        .arg(&problem_path)
        .arg(&states_path)
        .arg(runs.to_string())
        .env("PYTHONHASHSEED", "0")
        .output()
        .context("cannot run pyperplan")?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        bail!("pyperplan failed ({}): {}", output.status, stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or_default().trim());
    }
    serde_json::from_slice(&output.stdout).context("pyperplan's output is not JSON")
}

/// `bench heuristic`: each heuristic on the same states, ours and pyperplan's, one after the
/// other per task (so both see the same load): the median time per evaluation over `runs`
/// passes, and on how many states the values agree.
fn heuristic(
    benchmarks: &str,
    limit: Option<usize>,
    filter: Option<&str>,
    walk: usize,
    runs: usize,
    no_reference: bool,
    json: bool,
) -> anyhow::Result<ExitCode> {
    let benchmarks = benchmarks_named(benchmarks)?;
    let mut selected = Vec::with_capacity(benchmarks.len());
    for benchmark in &benchmarks {
        let loaded = benchmark_data::load(*benchmark)?;
        let mut tasks: Vec<TaskFiles> = spaced(&loaded, limit).into_iter().cloned().collect();
        tasks.retain(|files| filter.is_none_or(|f| files.id.contains(f)));
        selected.push((*benchmark, tasks));
    }
    check_filter(filter, selected.iter().map(|(_, tasks)| tasks.len()).sum(), &benchmarks)?;
    let python = anchor_venv().join("bin/python");
    let reference = !no_reference && {
        let found = Command::new(&python).args(["-c", "import pyperplan"]).output().is_ok_and(|o| o.status.success());
        if !found {
            eprintln!("pyperplan not found in {} (../shared/anchors/install.sh planning); reporting ours only", anchor_venv().display());
        }
        found
    };
    let scratch = std::env::temp_dir().join(format!("xtask-bench-heuristic-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let mut rows = Vec::new();
    // Per heuristic: the sums of ours' and pyperplan's seconds per evaluation over the tasks
    // both evaluated, the states compared and those whose values agree.
    let mut totals: std::collections::BTreeMap<&str, [f64; 4]> = std::collections::BTreeMap::new();
    if !json {
        println!(
            "{:<34} {:>6} {:>6}  {:<6} {:>12} {:>12} {:>8} {:>9}",
            "task", "states", "facts", "h", "ours µs", "pyperplan µs", "ratio", "agree"
        );
    }
    for (benchmark, tasks) in &selected {
        let bar = crate::input::progress_bar(format!("heuristic {}", benchmark.name()), tasks.len());
        for files in tasks {
            bar.set_message(files.id.clone());
            let mut lines = Vec::new();
            let model = transition_model::TransitionModel::new(crate::input::ground(files)?);
            let states = bench_states(&model, files, walk)?;
            let named: Vec<Vec<String>> =
                states.iter().map(|s| s.facts().map(|f| model.task().fact_name(f).to_lowercase()).collect()).collect();
            let facts: Vec<String> = model.task().fact_ids().map(|f| model.task().fact_name(f).to_lowercase()).collect();
            let theirs = if reference { Some(run_pyperplan(&python, files, &facts, &named, runs, &scratch)) } else { None };
            let mut row =
                json!({"benchmark": benchmark.name(), "task": files.id, "states": states.len(), "facts": model.task().facts.len()});
            if let Some(Err(error)) = &theirs {
                row["reference_error"] = json!(format!("{error:#}"));
                lines.push(format!("{:<34} {:>6} {:>6}  pyperplan: {error:#}", files.id, states.len(), model.task().facts.len()));
            }
            let theirs = theirs.and_then(Result::ok);
            if let Some(t) = &theirs {
                row["reference_facts"] = t["facts"].clone();
                row["reference_operators"] = t["operators"].clone();
            }
            for name in COMPARED_HEURISTICS {
                let mut evaluator = heuristics::by_name(name, &model).context("a heuristic of ours")?;
                let values: Vec<Option<u64>> = states.iter().map(|s| evaluator.evaluate(s).map(u64::from)).collect();
                let mut passes = Vec::with_capacity(runs);
                for _ in 0..runs {
                    let start = Instant::now();
                    for state in &states {
                        std::hint::black_box(evaluator.evaluate(state));
                    }
                    passes.push(start.elapsed().as_secs_f64() / states.len().max(1) as f64);
                }
                let ours = crate::input::median(passes);
                let mut entry = json!({"ours_seconds_per_evaluation": ours, "values": values});
                let mut line =
                    format!("{:<34} {:>6} {:>6}  {:<6} {:>12.2}", files.id, states.len(), model.task().facts.len(), name, ours * 1e6);
                if let Some(h) = theirs.as_ref().map(|t| &t["heuristics"][name]) {
                    let seconds = h["seconds_per_evaluation"].as_f64().context("pyperplan's time")?;
                    let reference_values: Vec<Option<u64>> =
                        h["values"].as_array().context("pyperplan's values")?.iter().map(serde_json::Value::as_u64).collect();
                    let agree = values.iter().zip(&reference_values).filter(|(a, b)| a == b).count();
                    entry["reference_seconds_per_evaluation"] = json!(seconds);
                    entry["reference_values"] = json!(reference_values);
                    entry["agree"] = json!(agree);
                    let total = totals.entry(name).or_default();
                    total[0] += ours;
                    total[1] += seconds;
                    total[2] += states.len() as f64;
                    total[3] += agree as f64;
                    line.push_str(&format!(" {:>12.2} {:>7.1}x {:>4}/{:<4}", seconds * 1e6, seconds / ours, agree, states.len()));
                }
                lines.push(line);
                row[name] = entry;
            }
            if !json {
                bar.suspend(|| lines.iter().for_each(|line| println!("{line}")));
            }
            rows.push(row);
            bar.inc(1);
        }
        bar.finish_and_clear();
    }
    std::fs::remove_dir_all(&scratch).ok();
    let summary: serde_json::Map<String, serde_json::Value> = totals
        .iter()
        .map(|(name, [ours, theirs, states, agree])| {
            ((*name).to_string(), json!({"pyperplan_over_ours": theirs / ours, "states": states, "agree": agree}))
        })
        .collect();
    if json {
        println!("{}", json!({"runs": runs, "walk": walk, "tasks": rows, "summary": summary}));
    } else {
        for (name, [ours, theirs, states, agree]) in &totals {
            println!(
                "{name}: pyperplan takes {:.1}x our time (summed over the tasks both evaluated); values agree on {agree}/{states} states",
                theirs / ours
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
