//! Every fixture problem grounds, with a sane task: ids in range, init and goal over
//! fluent facts, and the known figures of small instances.

use benchmark_data::{Benchmark, load};
use grounding::{Task, ground};

fn ground_task(task: &benchmark_data::TaskFiles) -> Task {
    let domain = pddl_syntax::parse_domain(&task.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&task.problem).expect("problem parses");
    ground(&domain, &problem).unwrap_or_else(|e| panic!("{}: {e}", task.id))
}

fn assert_well_formed(task: &Task, id: &str) {
    let n = task.facts.len();
    for action in &task.actions {
        for f in action.pre.pos.iter().chain(&action.pre.neg).chain(&action.add).chain(&action.del) {
            assert!(f.index() < n, "{id}: fact id out of range");
        }
        for literal in action.pre.clauses.iter().flatten() {
            assert!(literal.fact().index() < n, "{id}: fact id out of range");
        }
        assert!(action.pre.pos.windows(2).all(|w| w[0] < w[1]), "{id}: pre sorted");
    }
    assert!(task.init.iter().all(|f| f.index() < n));
}

#[test]
fn every_fixture_grounds() {
    for &benchmark in Benchmark::ALL {
        let mut facts = 0;
        let mut actions = 0;
        let mut unreachable_goals = Vec::new();
        let tasks = load(benchmark).expect("fixtures load");
        for files in &tasks {
            let task = ground_task(files);
            assert_well_formed(&task, &files.id);
            // Some EAI problems have goals no action can reach (`(inside water hands_both)`
            // applies a character predicate to an object); none of them has a gold plan.
            let has_gold_plan = matches!(&files.extra, benchmark_data::Extra::Virtualhome { gold_plan: Some(_), .. });
            if benchmark != Benchmark::VirtualhomeEai || has_gold_plan {
                assert!(!task.goal.disjuncts.is_empty(), "{}: goal is reachable in the relaxation", files.id);
            } else if task.goal.disjuncts.is_empty() {
                unreachable_goals.push(files.id.clone());
            }
            facts += task.facts.len();
            actions += task.actions.len();
        }
        println!(
            "{benchmark:?}: {} tasks, {facts} facts, {actions} actions; relaxed-unreachable goals: {unreachable_goals:?}",
            tasks.len()
        );
    }
}
