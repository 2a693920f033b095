//! `cargo xtask plan` and `cargo xtask heuristic`: the symbolic planner and the
//! initial-state heuristic values.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::ValueEnum;
use heuristics::HeuristicName;
use heuristics::search::{Algorithm, SearchConfig, SearchStatus, search};
use serde_json::json;
use transition_model::TransitionModel;

use crate::input::{self, TaskArgs};

#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    #[command(flatten)]
    task: TaskArgs,
    /// The planner: a classical search, or `mcts` (Phase II: see --mode and --lm).
    #[arg(long, value_enum, default_value_t = Planner::LazyGbfs)]
    planner: Planner,
    /// The heuristic.
    #[arg(long, default_value = "ff", value_parser = crate::input::choice::<HeuristicName>())]
    heuristic: HeuristicName,
    /// Use the heuristic's preferred operators (GBFS).
    #[arg(long)]
    preferred: bool,
    /// A*: register states up to a permutation of interchangeable objects (orbit search over
    /// the task's object symmetries; plans stay optimal and name the task's own objects).
    #[arg(long)]
    symmetries: bool,
    /// Stop after this many expansions.
    #[arg(long)]
    max_expansions: Option<u64>,
    /// A*: plans costing more are not searched for, and a search that finds none within it
    /// ends `over-bound` (Fast Downward's `bound`, but inclusive). A proof that no plan fits
    /// needs an admissible heuristic: with conditional effects, `lmcut-admissible`, not `lmcut`.
    #[arg(long)]
    max_cost: Option<u64>,
    /// Stop after this many seconds of search (on `--clock`).
    #[arg(long, value_parser = crate::input::positive_seconds)]
    time_limit: Option<f64>,
    /// Write the plan here, in Fast Downward's format.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    lm: crate::phase2::LmArgs,
    #[command(flatten)]
    decode: crate::phase2::DecodeArgs,
}

/// `plan --planner`: a classical search, or Phase II.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Planner {
    Astar,
    Gbfs,
    LazyGbfs,
    Mcts,
}

impl Planner {
    /// The classical search, `None` for `mcts`.
    fn algorithm(self) -> Option<Algorithm> {
        match self {
            Planner::Astar => Some(Algorithm::AStar),
            Planner::Gbfs => Some(Algorithm::Gbfs),
            Planner::LazyGbfs => Some(Algorithm::LazyGbfs),
            Planner::Mcts => None,
        }
    }
}

/// The plan in Fast Downward's format: one `(action args)` a line, then the cost line.
pub fn plan_text(model: &TransitionModel, plan: &[grounding::ActionId], cost: u64) -> String {
    let mut text = String::new();
    for &action in plan {
        text.push_str(&model.task().action_name(action));
        text.push('\n');
    }
    let kind = if model.task().uses_costs { "general cost" } else { "unit cost" };
    text.push_str(&format!("; cost = {cost} ({kind})\n"));
    text
}

pub fn plan(args: PlanArgs) -> anyhow::Result<ExitCode> {
    if args.symmetries && args.planner != Planner::Astar {
        return Err(crate::input::InputError("--symmetries is a setting of --planner astar".to_string()).into());
    }
    if args.max_cost.is_some() && args.planner != Planner::Astar {
        return Err(crate::input::InputError("--max-cost is a setting of --planner astar".to_string()).into());
    }
    // A setting of one planner given to another would be passed over in silence.
    if args.preferred && !matches!(args.planner, Planner::Gbfs | Planner::LazyGbfs) {
        return Err(crate::input::InputError("--preferred is a setting of --planner gbfs or lazy-gbfs".to_string()).into());
    }
    let passed_over = if args.planner == Planner::Mcts {
        ["heuristic", "max_expansions"].into_iter().filter(|id| input::typed(id)).map(input::option_name).collect()
    } else {
        let mut options = input::given::<crate::phase2::LmArgs>(&[]);
        options.extend(input::given::<crate::phase2::DecodeArgs>(&["clock"]));
        options
    };
    let whose = if args.planner == Planner::Mcts { "the classical planners (astar, gbfs, lazy-gbfs)" } else { "--planner mcts" };
    if let Some(error) = input::settings_of(&passed_over, whose) {
        return Err(error.into());
    }
    args.out.as_deref().map(|out| input::file_to_write(out, "--out")).transpose()?;
    let files = args.task.load()?;
    let Some(algorithm) = args.planner.algorithm() else {
        let limit = args.time_limit.unwrap_or(crate::phase2::DEFAULT_TIME_LIMIT);
        return crate::phase2::plan_one(&files, &args.lm, &args.decode, limit, args.out.as_deref(), args.json);
    };
    let model = TransitionModel::new(input::ground(&files)?);
    if algorithm == Algorithm::AStar && args.heuristic == HeuristicName::Lmcut && model.task().has_conditional_effects() {
        eprintln!(
            "note: this task has conditional effects, where `lmcut` charges each apart and may overestimate: \
             the plan may not be optimal, nor an over-bound a proof (`--heuristic lmcut-admissible` is admissible, and mostly weaker)"
        );
    }
    let mut heuristic = args.heuristic.build(&model);
    let mut config = SearchConfig::new(algorithm);
    config.max_cost = args.max_cost;
    config.preferred_operators = args.preferred;
    config.symmetries = args.symmetries;
    config.max_expansions = args.max_expansions;
    config.time_limit = args.time_limit.map(Duration::from_secs_f64);
    config.clock = args.decode.clock;
    let start = Instant::now();
    let result = search(&model, heuristic.as_mut(), &config, None);
    let millis = start.elapsed().as_secs_f64() * 1e3;
    let solved = result.status == SearchStatus::Solved;
    if solved {
        model
            .validate(&result.plan)
            .map_err(|e| anyhow::anyhow!("internal error: the plan found does not validate: {}", e.describe(model.task())))?;
        if let Some(out) = &args.out {
            crate::input::write_output(out, "--out", plan_text(&model, &result.plan, result.cost))?;
        }
    }
    let status = result.status.name();
    if args.json {
        println!(
            "{}",
            json!({
                "task": files.id, "planner": args.planner.to_possible_value().map(|v| v.get_name().to_string()),
                "heuristic": args.heuristic.name(), "preferred": args.preferred, "symmetries": args.symmetries,
                "solved": solved, "status": status, "cost": solved.then_some(result.cost), "length": solved.then_some(result.plan.len()),
                "expanded": result.expanded, "evaluated": result.evaluated, "generated": result.generated, "millis": millis,
            })
        );
    } else {
        if solved {
            print!("{}", plan_text(&model, &result.plan, result.cost));
        }
        eprintln!("{status}: {} expanded, {} evaluated, {millis:.1} ms", result.expanded, result.evaluated);
    }
    Ok(if solved { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

#[derive(Debug, clap::Args)]
pub struct HeuristicArgs {
    #[command(flatten)]
    task: TaskArgs,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn heuristic(args: HeuristicArgs) -> anyhow::Result<ExitCode> {
    let files = args.task.load()?;
    let model = TransitionModel::new(input::ground(&files)?);
    let state = model.initial_state();
    let mut values = serde_json::Map::new();
    for &name in <HeuristicName as strum::VariantArray>::VARIANTS {
        values.insert(name.name().to_string(), json!(name.build(&model).evaluate(&state)));
    }
    if args.json {
        println!("{}", serde_json::Value::Object(values));
    } else {
        for (name, value) in values {
            println!("{name:<16} {}", if value.is_null() { "dead end".to_string() } else { value.to_string() });
        }
    }
    Ok(ExitCode::SUCCESS)
}
