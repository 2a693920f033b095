//! `cargo xtask agent --game G`: the paper's agent on one ALFWorld game. Phase I with the
//! systematic explorer (`exploration_harness::alfworld`), ŝ0 written as a problem of ALFWorld's
//! domain, Phase II by A* with LM-cut on it (the symbolic planner; the model-driven Phase II
//! modes come with the rest of the exploration-harness issue), the plan executed open-loop; the
//! game's own goal check is the verdict. Exit 0 won, 1 not won, 2 bad input.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use exploration_harness::alfworld::run_episode;
use exploration_harness::{Ontology, parse_goal};
use household_sim::{AlfworldEnv, Environment};
use serde_json::json;
use transition_model::TransitionModel;

use crate::input::InputError;

#[derive(Debug, clap::Args)]
pub struct AgentArgs {
    /// An ALFWorld game: `game.tw-pddl` or the folder holding it.
    #[arg(long)]
    game: PathBuf,
    /// Phase I's explorer (only `systematic` so far: the fixed sweep, no model).
    #[arg(long, default_value = "systematic", value_parser = ["systematic"])]
    explorer: String,
    /// Environment steps for the whole episode (the paper: 55 for ALFWorld).
    #[arg(long, default_value_t = 55)]
    budget: usize,
    /// Seconds of search for Phase II.
    #[arg(long, default_value_t = 60)]
    time_limit: u64,
    /// Write every command sent to the game, one a line (replayable in the real engine with
    /// `../shared/anchors/alfworld_replay.py GAME PLAN`).
    #[arg(long)]
    commands_out: Option<PathBuf>,
    /// Print one JSON object (steps, the grounded problem, the plan, the verdict).
    #[arg(long)]
    json: bool,
}

pub fn run(args: AgentArgs) -> anyhow::Result<ExitCode> {
    let game = if args.game.is_dir() { args.game.join("game.tw-pddl") } else { args.game.clone() };
    let mut env = AlfworldEnv::from_game_file(&game).map_err(|e| InputError(e.to_string()))?;
    let goal = parse_goal(env.goal()).map_err(|e| InputError(e.to_string()))?;
    let fixtures = benchmark_data::fixtures_dir();
    let ontology_path = fixtures.join("ontology/alfworld.txt");
    let ontology = Ontology::from_text(
        &std::fs::read_to_string(&ontology_path).with_context(|| format!("cannot read {}", ontology_path.display()))?,
        &ontology_path.display().to_string(),
    )
    .map_err(|e| InputError(e.to_string()))?;
    let domain_text = std::fs::read_to_string(fixtures.join("alfworld/alfred.pddl")).context("ALFWorld's domain")?;
    let domain = pddl_syntax::parse_domain(&domain_text).map_err(|e| anyhow::anyhow!("alfred.pddl: {e:?}"))?;
    // The game's command grammar (the same file for every game): how plans are spelled.
    let grammar = std::fs::read_to_string(fixtures.join("alfworld/alfred.twl2")).context("ALFWorld's grammar")?;
    let limit = Duration::from_secs(args.time_limit);
    let mut planning_ms = 0.0;
    let mut plan = |model: &TransitionModel| {
        let start = Instant::now();
        let result = heuristics::search::optimal_plan(model, limit);
        planning_ms = start.elapsed().as_secs_f64() * 1e3;
        result.map_err(|status| format!("{status:?}"))
    };
    let start = Instant::now();
    let episode = run_episode(&mut env, &goal, &ontology, &domain, &grammar, args.budget, &mut plan);
    let millis = start.elapsed().as_secs_f64() * 1e3;
    if let Some(path) = &args.commands_out {
        let text: String = episode.steps.iter().map(|s| format!("{}\n", s.command)).collect();
        std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.json {
        println!(
            "{}",
            json!({
                "game": game.display().to_string(), "explorer": args.explorer, "goal": goal.to_string(),
                "success": episode.success, "failure": episode.failure, "phase1_steps": episode.phase1_steps,
                "env_steps": episode.steps.len(), "plan": episode.plan,
                "steps": episode.steps.iter().map(|s| json!({"phase": s.phase, "command": s.command, "executed": s.executed, "observation": s.observation})).collect::<Vec<_>>(),
                "problem": episode.handover.as_ref().map(|h| h.problem.clone()),
                "binding": episode.handover.as_ref().map(|h| h.binding.clone()),
                "planning_ms": planning_ms, "millis": millis,
            })
        );
    } else {
        for s in &episode.steps {
            println!("[{}] {} -> {}", s.phase, s.command, s.observation.lines().next().unwrap_or(""));
        }
        println!("{}", if episode.success { "won".to_string() } else { format!("not won: {}", episode.failure.as_deref().unwrap_or("?")) });
    }
    Ok(if episode.success { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
