//! `cargo xtask env --benchmark virtualhome-eai|virtualhome-rearrange --task ID`: runs commands (a file, or a
//! seeded random program over what is visible at each step) in `VirtualhomeEnv` and prints
//! one JSON line per step and the goal verdict last.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use household_sim::{Environment, IdScope, Judge, PythonRandom, VirtualhomeEnv, VirtualhomeTask};
use serde_json::json;

/// Arguments of the VirtualHome part of `cargo xtask env` (parsed there).
#[derive(Debug)]
pub struct VirtualhomeEnvArgs {
    /// The benchmark.
    pub benchmark: String,
    /// EAI task id (`201_1`): `<task-dir>/<id>.json.gz`.
    pub task: String,
    /// Folder of task files [default: fixtures/virtualhome-eai/graphs, the 33 kitchen tasks].
    pub task_dir: Option<PathBuf>,
    /// Commands, one a line (script lines `[WALK] <plate> (1001)` or class-level `grab plate`);
    /// blank lines and `#` lines skipped.
    pub commands: Option<PathBuf>,
    /// A random program of N steps: each step an action on an object visible at that step.
    pub random: Option<usize>,
    /// Seed of the random program.
    pub seed: u64,
    /// JSON lines (step, command, executed, message, observation; the last line the verdict).
    pub json: bool,
    /// The agent's ids, and instance-level lines only for nodes shown since the reset
    /// ([`IdScope::Perceived`]); else the scene's ids, for any node ([`IdScope::Any`]).
    pub as_agent: bool,
}

/// Actions the random program draws from (uniformly), with their number of objects.
const RANDOM_ACTIONS: &[(&str, usize)] = &[
    ("WALK", 1),
    ("FIND", 1),
    ("GRAB", 1),
    ("OPEN", 1),
    ("CLOSE", 1),
    ("PUTBACK", 2),
    ("PUTIN", 2),
    ("SWITCHON", 1),
    ("SWITCHOFF", 1),
    ("TURNTO", 1),
    ("LOOKAT", 1),
    ("WIPE", 1),
    ("TOUCH", 1),
    ("POUR", 2),
    ("DRINK", 1),
    ("PLUGIN", 1),
    ("WASH", 1),
];

fn random_command(env: &VirtualhomeEnv, rng: &mut PythonRandom) -> String {
    let (action, arity) = RANDOM_ACTIONS[rng.choice_index(RANDOM_ACTIONS.len())];
    let visible = env.visible_objects();
    if visible.is_empty() {
        return "[STANDUP]".to_string();
    }
    let mut line = format!("[{action}]");
    for _ in 0..arity {
        let (id, class) = &visible[rng.choice_index(visible.len())];
        line.push_str(&format!(" <{class}> ({id})"));
    }
    line
}

/// A task of a VirtualHome benchmark: `<task>.json.gz` in `task_dir`, by default
/// fixtures/virtualhome-eai/graphs or fixtures/virtualhome-rearrange.
pub fn load_task(benchmark: &str, task: &str, task_dir: Option<&std::path::Path>) -> anyhow::Result<VirtualhomeTask> {
    let default = if benchmark == "virtualhome-rearrange" { "virtualhome-rearrange" } else { "virtualhome-eai/graphs" };
    let dir = task_dir.map_or_else(|| benchmark_data::fixtures_dir().join(default), std::path::Path::to_path_buf);
    let path = dir.join(format!("{task}.json.gz"));
    if !dir.is_dir() {
        bail!(crate::input::InputError(format!("{}: no such folder of task files", dir.display())));
    }
    if !path.is_file() {
        bail!(crate::input::InputError(format!("no task `{task}` in {} (task files there are `<id>.json.gz`)", dir.display())));
    }
    Ok(VirtualhomeTask::load(&path).map_err(|e| crate::input::InputError(e.to_string()))?)
}

/// Runs `cargo xtask env` for a VirtualHome benchmark. Exit 0 when the goal holds at the
/// end, 1 when not; errors (exit 2) for a missing task or an unreadable command file.
pub fn run(args: &VirtualhomeEnvArgs) -> anyhow::Result<ExitCode> {
    let task = load_task(&args.benchmark, &args.task, args.task_dir.as_deref())?;
    let reference = task.reference_program.clone();
    let mut env = VirtualhomeEnv::new(task, &args.benchmark).with_id_scope(if args.as_agent { IdScope::Perceived } else { IdScope::Any });
    let commands: Option<Vec<String>> = match &args.commands {
        Some(file) => {
            let text = crate::input::read_text(file)?;
            Some(text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')).map(str::to_string).collect())
        }
        // Without commands or random steps: the task's reference program (the rearrangement
        // set's; EAI's task files have none, so nothing is played and the reset is shown).
        None if args.random.is_none() => {
            if reference.is_empty() {
                eprintln!("{}: no reference program in the task file; give --commands FILE or --random N to play", args.task);
            }
            // The program names the scene's ids; an agent's environment shows ids of its own.
            Some(if args.as_agent { reference.iter().map(|line| env.with_shown_ids(line)).collect() } else { reference })
        }
        None => None,
    };
    let steps = commands.as_ref().map_or(args.random.unwrap_or(0), Vec::len);
    let observation = env.reset();
    emit(args.json, json!({"step": 0, "command": null, "executed": true, "message": "", "observation": observation.text}));
    let mut rng = PythonRandom::new(args.seed);
    for step in 1..=steps {
        let command = match &commands {
            Some(list) => list[step - 1].clone(),
            None => random_command(&env, &mut rng),
        };
        let result = env.step(&command);
        let message = match &result.event {
            household_sim::Event::Executed => String::new(),
            household_sim::Event::NotExecuted { reason } => reason.clone(),
        };
        emit(
            args.json,
            json!({"step": step, "command": command, "executed": result.event.executed(), "message": message, "observation": result.observation.text}),
        );
    }
    let reached = env.goal_reached();
    emit(args.json, json!({"goal_reached": reached, "steps": env.steps_taken(), "unmet": env.unmet_goals()}));
    Ok(if reached { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

fn emit(json_lines: bool, value: serde_json::Value) {
    if json_lines {
        println!("{value}");
    } else if let Some(step) = value.get("step") {
        let command = value["command"].as_str().unwrap_or("(reset)");
        println!("--- step {step}: {command}\n{}", value["observation"].as_str().unwrap_or_default());
    } else {
        println!("goal reached: {}; unmet: {}", value["goal_reached"], value["unmet"]);
    }
}
