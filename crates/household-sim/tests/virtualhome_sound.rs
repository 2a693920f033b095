//! The sound VirtualHome domain on every fixture task: A* with LM-cut finds a plan on the problem
//! `virtualhome::pddl::problem` writes, and that plan, as script lines, executes at every step in
//! `VirtualhomeEnv` (whose executor matches the evolving graph on every recorded program) and
//! reaches every goal.

use std::path::{Path, PathBuf};

use household_sim::vh_pddl::{self as pddl, SOUND_DOMAIN};
use household_sim::{Environment, Event, IdScope, Judge, VirtualhomeEnv, VirtualhomeTask};
use transition_model::TransitionModel;

/// A* expansions per plan: a bound that holds on any machine under any load (not a time limit).
const EXPANSIONS: u64 = 1_000_000;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai")
}

/// The object names of EAI's own problem file for the task (its task-relevant classes); none
/// for the four tasks EAI has no problem file for.
fn eai_classes(task: &str) -> Vec<String> {
    let root = fixtures().join("problem_pddl");
    for category in std::fs::read_dir(&root).unwrap() {
        let path = category.unwrap().path().join(format!("{task}.pddl"));
        if let Ok(text) = std::fs::read_to_string(&path) {
            let problem = pddl_syntax::parse_problem(&text).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
            return problem.objects.iter().map(|o| o.name.text.clone()).collect();
        }
    }
    Vec::new()
}

fn plan_task(task: &VirtualhomeTask) -> Result<Vec<String>, String> {
    let classes = eai_classes(&task.task_id);
    let classes: Vec<&str> = classes.iter().map(String::as_str).collect();
    let problem = pddl::problem(task, &classes).map_err(|e| e.to_string())?;
    let domain = pddl_syntax::parse_domain(SOUND_DOMAIN).map_err(|e| format!("domain: {e:?}"))?;
    let parsed = pddl_syntax::parse_problem(&problem.text).map_err(|e| format!("problem: {e:?}\n{}", problem.text))?;
    let report = pddl_syntax::check(&domain, Some(&parsed));
    assert!(!report.has_errors(), "{}: {report:?}", task.task_id);
    let grounded = grounding::ground(&domain, &parsed).map_err(|e| e.to_string())?;
    let model = TransitionModel::new(grounded);
    let plan = heuristics::search::optimal_plan_expanding(&model, EXPANSIONS).map_err(|status| format!("{status:?}"))?;
    let world = &task.init;
    plan.iter().map(|&a| problem.script_line(world, &model.task().action_name(a))).collect()
}

#[test]
fn every_fixture_task_has_a_plan_that_executes_and_reaches_its_goal() {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(fixtures().join("graphs")).unwrap().map(|e| e.unwrap().path()).collect();
    dirs.sort();
    assert_eq!(dirs.len(), 33);
    let mut failures = Vec::new();
    for path in dirs {
        let task = VirtualhomeTask::load(&path).unwrap();
        let id = task.task_id.clone();
        let script = match plan_task(&task) {
            Ok(script) => script,
            Err(e) => {
                failures.push(format!("{id}: no plan: {e}"));
                continue;
            }
        };
        let mut env = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
        env.reset();
        for (i, line) in script.iter().enumerate() {
            if let Event::NotExecuted { reason } = env.step(line).event {
                failures.push(format!("{id}: step {} {line}: {reason}\n  plan: {script:?}", i + 1));
                break;
            }
        }
        if !env.goal_reached() {
            failures.push(format!("{id}: goal not reached: {:?}\n  plan: {script:?}", env.unmet_goals()));
        }
    }
    assert!(failures.is_empty(), "{} tasks failed:\n{}", failures.len(), failures.join("\n"));
}
