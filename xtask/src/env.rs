//! `cargo xtask env`: play a household environment from the command line and print what it
//! shows at every step, in exactly the JSON lines `../shared/anchors/alfworld_trace.py` prints
//! for the real engine, so the two can be diffed.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use household_sim::{AlfworldEnv, Environment, PythonRandom};

use crate::input::InputError;

#[derive(Debug, Args)]
pub struct EnvArgs {
    /// An ALFWorld game: `game.tw-pddl` or the folder holding it.
    #[arg(long)]
    game: PathBuf,
    /// Commands to send, one a line (blank lines and `#` lines skipped) [default: the game's
    /// expert walkthrough].
    #[arg(long, conflicts_with = "random")]
    commands: Option<PathBuf>,
    /// Take N steps, each a command drawn from the sorted admissible list by Python's
    /// `random.Random(SEED).choice`, as `alfworld_trace.py --random N --seed S` draws them.
    #[arg(long, value_name = "N")]
    random: Option<usize>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// JSON lines `{step, command, observation, admissible, won}` (step 0 is the reset), as
    /// alfworld_trace.py prints them; without it, readable text.
    #[arg(long)]
    json: bool,
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

pub fn run(args: EnvArgs) -> anyhow::Result<ExitCode> {
    let mut env = AlfworldEnv::from_game_file(&args.game).map_err(|e| InputError(e.to_string()))?;
    let plan: Vec<String> = match (&args.commands, args.random) {
        (Some(path), _) => std::fs::read_to_string(path)
            .map_err(|e| InputError(format!("{}: cannot read: {e}", path.display())))?
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .map(str::to_string)
            .collect(),
        (None, Some(_)) => Vec::new(),
        (None, None) => env.walkthrough().to_vec(),
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
