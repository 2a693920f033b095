//! The command-line interfaces other tools rely on: output shapes and exit codes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

fn xtask(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .expect("xtask runs")
}

fn scratch(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xtask-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
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

#[test]
fn validate_reports_valid_invalid_and_bad_input_with_exit_codes() {
    let (domain, problem) = household();
    let good = scratch(
        "good.plan",
        "(grab wineglass kitchentable)\n(walk kitchentable dishwasher)\n(putin wineglass dishwasher)\n; cost = 4 (general cost)\n",
    );
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &good.display().to_string()]);
    assert_eq!(output.status.code(), Some(0));
    assert!(stdout(&output).starts_with("valid"), "{}", stdout(&output));
    assert!(stdout(&output).contains("cost 4"));

    let swapped = scratch("swapped.plan", "(grab wineglass kitchentable)\n(putin wineglass dishwasher)\n(walk kitchentable dishwasher)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &swapped.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert_eq!(
        stdout(&output).trim(),
        "invalid: step 2: `(putin wineglass dishwasher)` ((putin wineglass dishwasher)) is not applicable: unmet (at dishwasher)"
    );

    let short = scratch("short.plan", "(grab wineglass kitchentable)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &short.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with("invalid: goal"), "{}", stdout(&output));
    assert!(stdout(&output).contains("(on wineglass dishwasher)"));

    let unknown = scratch("unknown.plan", "(grab wineglass kitchentable)\n(teleport dishwasher)\n");
    let output = xtask(&["validate", "--domain", &domain, "--problem", &problem, "--plan", &unknown.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with("invalid: step 2: `(teleport dishwasher)`"), "{}", stdout(&output));

    let broken = fixtures().join("pddl-invalid/unclosed-paren.domain.pddl");
    let output =
        xtask(&["validate", "--domain", &broken.display().to_string(), "--problem", &problem, "--plan", &good.display().to_string()]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("unclosed-paren.domain.pddl:7:13: error[unclosed-paren]"), "{stderr}");

    let missing = scratch("exists.plan", "");
    let output = xtask(&["validate", "--domain", &domain, "--problem", "no/such/problem.pddl", "--plan", &missing.display().to_string()]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("no/such/problem.pddl: cannot read"));
}

#[test]
fn validate_reads_alfworld_commands_from_a_game() {
    let game = fixtures().join("alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323");
    let trial = std::fs::read_dir(&game).expect("game folder").next().expect("a trial").expect("entry").path();
    let plan = scratch("walkthrough.txt", "go to desk 1\nuse desklamp 1\ntake alarmclock 2 from desk 1\n");
    let output = xtask(&["validate", "--game", &trial.display().to_string(), "--plan", &plan.display().to_string()]);
    assert_eq!(output.status.code(), Some(0), "{}{}", stdout(&output), String::from_utf8_lossy(&output.stderr));
    let plan = scratch("wrong.txt", "use desklamp 1\n");
    let output = xtask(&["validate", "--game", &trial.display().to_string(), "--plan", &plan.display().to_string()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stdout(&output).starts_with("invalid: step 1: `use desklamp 1`"), "{}", stdout(&output));
}
