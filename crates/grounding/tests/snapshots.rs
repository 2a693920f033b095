//! Snapshots of grounded tasks, where the text is the contract: every fact and action (with
//! its precondition and effects) of the smallest IPC blocks instance, and the goal disjuncts
//! two ALFWorld games' `exists` goals become. Written by name, in id order; any change to
//! what grounding produces, prunes or numbers shows up as a diff in `tests/snapshots/`.

use std::fmt::Write;

use benchmark_data::{Benchmark, TaskFiles, load};
use grounding::{Condition, Task, ground};

fn task_files(benchmark: Benchmark, id: &str) -> TaskFiles {
    load(benchmark).expect("fixtures load").into_iter().find(|t| t.id.starts_with(id)).unwrap_or_else(|| panic!("no fixture {id}"))
}

fn ground_files(files: &TaskFiles) -> Task {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
    ground(&domain, &problem).unwrap_or_else(|e| panic!("{}: {e}", files.id))
}

/// `(p a)`, `(not (q b))`, `(or (r a) (not (s b)))`: literals, then clauses.
fn parts(task: &Task, condition: &Condition) -> Vec<String> {
    let mut parts: Vec<String> = condition.literals().map(|l| task.literal_name(l)).collect();
    for clause in &condition.clauses {
        let literals: Vec<String> = clause.iter().map(|&l| task.literal_name(l)).collect();
        parts.push(format!("(or {})", literals.join(" ")));
    }
    parts
}

/// The parts on one line, or `(and)` for the empty condition.
fn condition(task: &Task, condition: &Condition) -> String {
    let parts = parts(task, condition);
    if parts.is_empty() { "(and)".to_string() } else { parts.join(" ") }
}

fn facts(task: &Task, facts: &[grounding::FactId]) -> String {
    facts.iter().map(|&f| task.fact_name(f)).collect::<Vec<_>>().join(" ")
}

/// The balanced s-expression starting at `open` in `text`, on one line.
fn sexpr_at(text: &str, open: usize) -> String {
    let mut depth = 0;
    for (i, c) in text[open..].char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return text[open..=open + i].split_whitespace().collect::<Vec<_>>().join(" ");
                }
            }
            _ => {}
        }
    }
    panic!("unbalanced s-expression at {open}");
}

#[test]
fn blocks_instance_1_grounds_to_these_facts_and_actions() {
    let files = task_files(Benchmark::Ipc, "blocks/instance-1");
    let task = ground_files(&files);
    let mut out = String::new();
    writeln!(out, "domain {}, problem {}, action costs: {}", task.domain_name, task.problem_name, task.uses_costs).unwrap();
    let objects: Vec<&str> = task.objects.iter().map(|o| o.name.as_str()).collect();
    writeln!(out, "objects: {}", objects.join(" ")).unwrap();
    let statics: Vec<String> = task.static_facts.iter().map(|a| task.atom_name(a)).collect();
    writeln!(out, "static facts: {}", if statics.is_empty() { "none".to_string() } else { statics.join(" ") }).unwrap();
    writeln!(out, "\nfacts ({}):", task.facts.len()).unwrap();
    for fact in task.fact_ids() {
        writeln!(out, "  {:>2} {}", fact.index(), task.fact_name(fact)).unwrap();
    }
    writeln!(out, "\ninit: {}", facts(&task, &task.init)).unwrap();
    for (i, disjunct) in task.goal.disjuncts.iter().enumerate() {
        writeln!(out, "goal disjunct {}: {}", i + 1, condition(&task, disjunct)).unwrap();
    }
    writeln!(out, "\nactions ({}):", task.actions.len()).unwrap();
    for id in task.action_ids() {
        let action = task.action(id);
        assert!(action.conditional.is_empty(), "blocks has no conditional effects");
        writeln!(
            out,
            "  {:>2} {} cost {}\n       pre {}\n       add {}\n       del {}",
            id.index(),
            task.action_name(id),
            action.cost,
            condition(&task, &action.pre),
            facts(&task, &action.add),
            facts(&task, &action.del)
        )
        .unwrap();
    }
    insta::assert_snapshot!(out);
}

#[test]
fn alfworld_exists_goals_become_one_disjunct_per_binding() {
    let mut out = String::new();
    for id in ["look_at_obj_in_light-AlarmClock-None-DeskLamp-323/", "pick_clean_then_place_in_recep-DishSponge-None-CounterTop-403/"] {
        let files = task_files(Benchmark::AlfworldSeen, id);
        let task = ground_files(&files);
        let goal = files.problem.find("(:goal").expect("the problem has a goal");
        writeln!(out, "{}\n  PDDL: {}", files.id, sexpr_at(&files.problem, goal)).unwrap();
        writeln!(out, "  grounded: {} disjuncts", task.goal.disjuncts.len()).unwrap();
        for (i, disjunct) in task.goal.disjuncts.iter().enumerate() {
            // One part a line: a disjunct of ALFWorld ids does not fit on one.
            writeln!(out, "  {:>2}. {}", i + 1, parts(&task, disjunct).join("\n      ")).unwrap();
        }
        out.push('\n');
    }
    insta::assert_snapshot!(out);
}
