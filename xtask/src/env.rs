//! `cargo xtask env`: play a household environment from the command line and print what it
//! shows at every step, in exactly the JSON lines `../shared/anchors/alfworld_trace.py` prints
//! for the real engine, so the two can be diffed.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use household_sim::{AlfworldEnv, Environment, Judge, PythonRandom};

use crate::input::InputError;

#[derive(Debug, Args)]
pub struct EnvArgs {
    #[command(flatten)]
    pub which: TaskArgs,
    /// Commands to send, one a line (blank lines and `#` lines skipped) [default: ALFWorld: the
    /// game's expert walkthrough; the rearrangement set: the task's reference program; EAI:
    /// none, the task files have no program].
    #[arg(long, conflicts_with = "random")]
    commands: Option<PathBuf>,
    /// Take N steps. ALFWorld: each a command drawn from the sorted admissible list by
    /// Python's `random.Random(SEED).choice`, as `alfworld_trace.py --random N --seed S` draws
    /// them; VirtualHome: a seeded random program, each step an action on a visible object.
    #[arg(long, value_name = "N")]
    random: Option<usize>,
    /// Seed of the `--random` steps.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// JSON lines `{step, command, observation, admissible, won}` (step 0 is the reset), as
    /// alfworld_trace.py prints them; without it, readable text.
    #[arg(long)]
    json: bool,
    /// VirtualHome: the environment an agent is handed: nodes named by its own ids (a
    /// permutation of the task's, not EAI's), an instance-level line (`[WALK] <plate> (12)`)
    /// taken only for a node an observation has shown since the reset; without it, the scene's
    /// ids and any node, as EAI's executor takes them (gold programs walk to objects in other
    /// rooms by id). A `--commands` file is taken as written; the task's reference program is
    /// given the agent's ids.
    #[arg(long, conflicts_with = "game")]
    as_agent: bool,
}

/// A string as Python's `json.dumps` writes it (`ensure_ascii`: every non-ASCII character
/// as `\uXXXX`, astral ones as surrogate pairs).
fn py_string(text: &str, out: &mut String) {
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            c if (c as u32) < 0x20 || (c as u32) > 0x7e => {
                let mut units = [0u16; 2];
                for unit in c.encode_utf16(&mut units) {
                    out.push_str(&format!("\\u{unit:04x}"));
                }
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// One line as `json.dumps` writes the dict alfworld_trace.py builds.
fn py_line(step: usize, command: Option<&str>, observation: &str, admissible: &[String], won: bool) -> String {
    let mut out = format!("{{\"step\": {step}, ");
    if let Some(command) = command {
        out.push_str("\"command\": ");
        py_string(command, &mut out);
        out.push_str(", ");
    }
    out.push_str("\"observation\": ");
    py_string(observation, &mut out);
    out.push_str(", \"admissible\": [");
    for (i, command) in admissible.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        py_string(command, &mut out);
    }
    out.push_str(&format!("], \"won\": {}}}", if won { "true" } else { "false" }));
    out
}

/// Which task: an ALFWorld game, or a task of a VirtualHome benchmark.
#[derive(Debug, Clone, clap::Args)]
pub struct TaskArgs {
    /// An ALFWorld game: `game.tw-pddl` or the folder holding it.
    #[arg(long, required_unless_present = "benchmark", conflicts_with = "benchmark")]
    pub game: Option<PathBuf>,
    /// A VirtualHome benchmark, with `--task`: `virtualhome-eai` (EAI's tasks) or
    /// `virtualhome-rearrange` (the rearrangement set in fixtures/virtualhome-rearrange).
    #[arg(long, value_parser = ["virtualhome-eai", "virtualhome-rearrange"], requires = "task")]
    pub benchmark: Option<String>,
    /// Task id (`201_1`, `dishwasher-000`), with `--benchmark`.
    #[arg(long, requires = "benchmark")]
    pub task: Option<String>,
    /// Folder of VirtualHome task files [default: fixtures/virtualhome-eai/graphs, or
    /// fixtures/virtualhome-rearrange; every EAI task: the folder `cargo xtask fetch-data` prints].
    #[arg(long, requires = "benchmark")]
    pub task_dir: Option<PathBuf>,
}

pub fn run(args: EnvArgs) -> anyhow::Result<ExitCode> {
    let Some(game) = &args.which.game else {
        return crate::env_virtualhome::run(&crate::env_virtualhome::VirtualhomeEnvArgs {
            benchmark: args.which.benchmark.clone().unwrap_or_default(),
            task: args.which.task.clone().unwrap_or_default(),
            task_dir: args.which.task_dir.clone(),
            commands: args.commands.clone(),
            random: args.random,
            seed: args.seed,
            json: args.json,
            as_agent: args.as_agent,
        });
    };
    let mut env = AlfworldEnv::from_game_file(game).map_err(|e| InputError(e.to_string()))?;
    let plan: Vec<String> = match (&args.commands, args.random) {
        (Some(path), _) => crate::input::read_text(path)?
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .map(str::to_string)
            .collect(),
        (None, Some(_)) => Vec::new(),
        (None, None) => {
            if env.walkthrough().is_empty() {
                eprintln!("{}: no walkthrough in the game file; give --commands FILE or --random N to play", game.display());
            }
            env.walkthrough().to_vec()
        }
    };
    let show = |step: usize, command: Option<&str>, observation: &str, env: &AlfworldEnv| {
        let admissible = env.admissible_commands().unwrap_or_default();
        if args.json {
            println!("{}", py_line(step, command, observation, &admissible, env.goal_reached()));
        } else {
            match command {
                Some(command) => println!("[{step}] > {command}\n{observation}\n"),
                None => println!("{observation}\n"),
            }
        }
    };
    let observation = env.reset();
    show(0, None, &observation.text, &env);
    let mut rng = PythonRandom::new(args.seed);
    let steps = args.random.unwrap_or(plan.len());
    for k in 1..=steps {
        if env.goal_reached() {
            break;
        }
        let command = match args.random {
            Some(_) => {
                let admissible = env.admissible_commands().unwrap_or_default();
                if admissible.is_empty() {
                    break;
                }
                admissible[rng.choice_index(admissible.len())].clone()
            }
            None => plan[k - 1].clone(),
        };
        let result = env.step(&command);
        show(k, Some(&command), &result.observation.text, &env);
    }
    if !args.json {
        println!("{}", if env.goal_reached() { "won" } else { "not won" });
    }
    Ok(if env.goal_reached() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// Per game: ours (load + first reset, reset alone, mean step over the walkthrough; medians
/// of `runs`) and the real engine (its reset, which reloads the game, and its mean step over
/// the same walkthrough), measured one after the other in the same run.
pub fn bench(subset: &str, limit: usize, runs: usize, no_reference: bool, json: bool) -> anyhow::Result<ExitCode> {
    use anyhow::Context;
    let tasks = benchmark_data::load_subset(benchmark_data::Benchmark::AlfworldSeen, subset).map_err(|e| InputError(e.to_string()))?;
    let limit = limit.clamp(1, tasks.len().max(1));
    let picked: Vec<&benchmark_data::TaskFiles> = (0..limit).map(|i| &tasks[i * tasks.len() / limit]).collect();
    let mut rows = Vec::new();
    for files in &picked {
        let game = files.problem_path.clone();
        let (mut load, mut reset, mut step) = (Vec::new(), Vec::new(), Vec::new());
        let mut steps = 0;
        for _ in 0..runs {
            let start = std::time::Instant::now();
            let mut env = AlfworldEnv::from_game_file(&game).map_err(|e| InputError(e.to_string()))?;
            env.reset();
            load.push(start.elapsed().as_secs_f64());
            let start = std::time::Instant::now();
            env.reset();
            reset.push(start.elapsed().as_secs_f64());
            let plan = env.walkthrough().to_vec();
            let start = std::time::Instant::now();
            for command in &plan {
                env.step(command);
            }
            step.push(start.elapsed().as_secs_f64() / plan.len().max(1) as f64);
            steps = plan.len();
        }
        rows.push(serde_json::json!({
            "game": files.id,
            "steps": steps,
            "ours_load_reset_ms": crate::input::median(load) * 1e3,
            "ours_reset_us": crate::input::median(reset) * 1e6,
            "ours_step_us": crate::input::median(step) * 1e6,
        }));
    }
    let mut engine_note = None;
    if !no_reference {
        let script = benchmark_data::fixtures_dir().join("../tools/alfworld_time.py");
        let dirs: Vec<PathBuf> = picked.iter().map(|f| f.problem_path.parent().map(PathBuf::from).unwrap_or_default()).collect();
        let output = std::process::Command::new("python3").arg(&script).args(&dirs).output().context("running python3")?;
        let stdout = String::from_utf8_lossy(&output.stdout);
        let lines: Vec<serde_json::Value> = stdout.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
        if output.status.success() && lines.len() == rows.len() {
            for (row, line) in rows.iter_mut().zip(&lines) {
                let reset_s = line["reset_s"][1].as_f64().unwrap_or(f64::NAN);
                let step_s = line["step_s"].as_f64().unwrap_or(f64::NAN) / line["steps"].as_f64().unwrap_or(1.0).max(1.0);
                row["engine_reset_ms"] = serde_json::json!(reset_s * 1e3);
                row["engine_step_us"] = serde_json::json!(step_s * 1e6);
            }
        } else {
            engine_note = Some(format!(
                "the real engine did not run (bash ../shared/anchors/install.sh alfworld installs it): {}",
                lines
                    .first()
                    .map_or_else(|| String::from_utf8_lossy(&output.stderr).lines().last().unwrap_or("").to_string(), |l| l.to_string())
            ));
        }
    }
    let mean = |key: &str| -> Option<f64> {
        let xs: Vec<f64> = rows.iter().filter_map(|r| r[key].as_f64()).collect();
        (xs.len() == rows.len() && !xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
    };
    let (ours_load, ours_reset, ours_step) = (mean("ours_load_reset_ms"), mean("ours_reset_us"), mean("ours_step_us"));
    let (engine_reset, engine_step) = (mean("engine_reset_ms"), mean("engine_step_us"));
    let ratio = |engine: Option<f64>, ours: Option<f64>| engine.zip(ours).map(|(e, o)| e / o);
    let virtualhome = bench_virtualhome(runs, no_reference)?;
    let summary = serde_json::json!({
        "subset": subset,
        "games": rows.len(),
        "runs": runs,
        "ours_load_reset_ms": ours_load,
        "ours_reset_us": ours_reset,
        "ours_step_us": ours_step,
        "engine_reset_ms": engine_reset,
        "engine_step_us": engine_step,
        "reset_speedup_vs_our_load_and_reset": ratio(engine_reset, ours_load),
        "reset_speedup_vs_our_reset": ratio(engine_reset.map(|r| r * 1e3), ours_reset),
        "step_speedup": ratio(engine_step, ours_step),
        "note": engine_note,
        "per_game": rows,
        "virtualhome": virtualhome,
    });
    if json {
        println!("{summary}");
    } else {
        println!("ALFWorld, {} games of {subset} ({runs} runs of ours each):", summary["games"]);
        let show = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3}"));
        println!("  ours:   load+reset {} ms, reset {} us, step {} us", show(ours_load), show(ours_reset), show(ours_step));
        println!("  engine: reset {} ms, step {} us", show(engine_reset), show(engine_step));
        println!(
            "  speed-up: reset {}x (against our load+reset), step {}x",
            show(ratio(engine_reset, ours_load)),
            show(ratio(engine_step, ours_step))
        );
        if let Some(note) = &summary["note"].as_str() {
            println!("  {note}");
        }
        let vh = &summary["virtualhome"];
        let show = |x: &serde_json::Value| x.as_f64().map_or("-".to_string(), |v| format!("{v:.3}"));
        println!("VirtualHome, {} EAI kitchen tasks, gold programs ({runs} runs of ours each):", vh["tasks"]);
        println!(
            "  ours:   load+reset {} ms, reset {} us, execute a line {} us, step with its observation {} us",
            show(&vh["ours_load_reset_ms"]),
            show(&vh["ours_reset_us"]),
            show(&vh["ours_execute_us"]),
            show(&vh["ours_step_us"])
        );
        println!("  engine: load+reset {} ms, execute a line {} us", show(&vh["engine_load_reset_ms"]), show(&vh["engine_step_us"]));
        println!(
            "  speed-up: load+reset {}x, execute {}x, step with observation {}x",
            show(&vh["load_reset_speedup"]),
            show(&vh["execute_speedup"]),
            show(&vh["step_with_observation_speedup"])
        );
        if let Some(note) = vh["note"].as_str() {
            println!("  {note}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// VirtualHome's part of `bench env`: every fixture kitchen task, its gold program (as the
/// parity recordings hold it): ours (load the task file and reset; reset alone; each step,
/// observation included) beside the real evolving graph (`tools/virtualhome_record.py time`:
/// building its planner from the dataset's graph, and executing each line), in one run.
fn bench_virtualhome(runs: usize, no_reference: bool) -> anyhow::Result<serde_json::Value> {
    use anyhow::Context;
    use household_sim::{Environment, IdScope, ScriptLine, VirtualhomeEnv, VirtualhomeTask};
    let root = benchmark_data::fixtures_dir().join("virtualhome-eai");
    let mut text = String::new();
    std::io::Read::read_to_string(
        &mut flate2::read::GzDecoder::new(std::fs::File::open(root.join("parity/programs.jsonl.gz")).context("parity recordings")?),
        &mut text,
    )?;
    let gold: Vec<(String, Vec<String>)> = text
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|r| r["program"] == "gold")
        .map(|r| {
            let lines = r["lines"].as_array().into_iter().flatten().filter_map(|x| x.as_str().map(str::to_string)).collect();
            (r["task"].as_str().unwrap_or_default().to_string(), lines)
        })
        .collect();
    let mut rows = Vec::new();
    for (task_id, lines) in &gold {
        let path = root.join("graphs").join(format!("{task_id}.json.gz"));
        let (mut load, mut reset, mut step, mut execute) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..runs {
            let start = std::time::Instant::now();
            let task = VirtualhomeTask::load(&path).map_err(|e| InputError(e.to_string()))?;
            let init = task.init.clone();
            let mut env = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
            env.reset();
            load.push(start.elapsed().as_secs_f64());
            let start = std::time::Instant::now();
            env.reset();
            reset.push(start.elapsed().as_secs_f64());
            let start = std::time::Instant::now();
            for line in lines {
                env.step(line);
            }
            step.push(start.elapsed().as_secs_f64() / lines.len().max(1) as f64);
            // The executor alone, as the engine's figure is: parse and execute each line.
            let mut world = init.clone();
            let start = std::time::Instant::now();
            for line in lines {
                if let Ok(parsed) = ScriptLine::parse(line) {
                    let _ = world.execute(&parsed);
                }
            }
            execute.push(start.elapsed().as_secs_f64() / lines.len().max(1) as f64);
        }
        rows.push(serde_json::json!({
            "task": task_id, "steps": lines.len(),
            "ours_load_reset_ms": crate::input::median(load) * 1e3, "ours_reset_us": crate::input::median(reset) * 1e6, "ours_step_us": crate::input::median(step) * 1e6,
            "ours_execute_us": crate::input::median(execute) * 1e6,
        }));
    }
    let mut note = None;
    if !no_reference {
        let script = benchmark_data::fixtures_dir().join("../tools/virtualhome_record.py");
        let output = std::process::Command::new("python3")
            .arg(&script)
            .arg("time")
            .args(gold.iter().map(|(t, _)| t))
            .output()
            .context("running python3")?;
        let stdout = String::from_utf8_lossy(&output.stdout);
        let lines: Vec<serde_json::Value> = stdout.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
        if output.status.success() && lines.len() == rows.len() {
            for (row, line) in rows.iter_mut().zip(&lines) {
                let step_s = line["step_s"].as_f64().unwrap_or(f64::NAN) / line["steps"].as_f64().unwrap_or(1.0).max(1.0);
                row["engine_load_reset_ms"] = serde_json::json!(line["reset_s"].as_f64().unwrap_or(f64::NAN) * 1e3);
                row["engine_step_us"] = serde_json::json!(step_s * 1e6);
            }
        } else {
            note = Some(format!(
                "the real executor did not run (bash ../shared/anchors/install.sh virtualhome installs it): {}",
                String::from_utf8_lossy(&output.stderr).lines().last().unwrap_or("")
            ));
        }
    }
    let mean = |key: &str| -> Option<f64> {
        let xs: Vec<f64> = rows.iter().filter_map(|r| r[key].as_f64()).collect();
        (xs.len() == rows.len() && !xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
    };
    let ratio = |engine: Option<f64>, ours: Option<f64>| engine.zip(ours).map(|(e, o)| e / o);
    Ok(serde_json::json!({
        "tasks": rows.len(),
        "ours_load_reset_ms": mean("ours_load_reset_ms"),
        "ours_reset_us": mean("ours_reset_us"),
        "ours_step_us": mean("ours_step_us"),
        "ours_execute_us": mean("ours_execute_us"),
        "engine_load_reset_ms": mean("engine_load_reset_ms"),
        "engine_step_us": mean("engine_step_us"),
        "load_reset_speedup": ratio(mean("engine_load_reset_ms"), mean("ours_load_reset_ms")),
        "execute_speedup": ratio(mean("engine_step_us"), mean("ours_execute_us")),
        "step_with_observation_speedup": ratio(mean("engine_step_us"), mean("ours_step_us")),
        "note": note,
        "per_task": rows,
    }))
}
