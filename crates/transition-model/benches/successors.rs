//! Successor generation on real states: the decision tree beside a scan of every action
//! (the reference it replaces), and apply. States are those visited by the ALFWorld
//! walkthroughs and EAI gold plans, and a seeded random walk from each IPC initial state.
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use benchmark_data::{Benchmark, Extra, TaskFiles, load};
use criterion::{Criterion, criterion_group, criterion_main};
use grounding::ActionId;
use transition_model::{Spelling, State, TransitionModel};

fn model(files: &TaskFiles) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("parses");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

/// States along the task's own plan, or along a seeded random walk.
/// States along the task's own plan (ALFWorld walkthrough, EAI gold plan), or along a
/// seeded random walk.
fn states(model: &TransitionModel, files: &TaskFiles) -> Vec<State> {
    match &files.extra {
        Extra::Alfworld(game) => {
            let spelling = Spelling::alfworld(model.task(), &game.grammar).expect("grammar");
            model.states_along(&spelling, &game.walkthrough).expect("walkthrough applies")
        }
        Extra::Virtualhome { gold_plan: Some(plan), .. } => {
            model.states_along(&Spelling::pddl(model.task()), plan).expect("gold plan applies")
        }
        _ => model.random_walk(0x9E37_79B9_7F4A_7C15, 50),
    }
}

fn scan(model: &TransitionModel, state: &State, out: &mut Vec<ActionId>) {
    out.clear();
    out.extend(model.task().action_ids().filter(|&a| model.is_applicable(state, a)));
}

fn bench(c: &mut Criterion) {
    let mut sets: Vec<(String, Vec<TaskFiles>)> = Vec::new();
    let alfworld = load(Benchmark::AlfworldSeen).expect("fixtures");
    sets.push(("alfworld-seen".into(), alfworld.iter().step_by(14).cloned().collect()));
    let virtualhome = load(Benchmark::VirtualhomeEai).expect("fixtures");
    sets.push((
        "virtualhome-eai".into(),
        virtualhome.iter().filter(|t| matches!(t.extra, Extra::Virtualhome { gold_plan: Some(_), .. })).step_by(30).cloned().collect(),
    ));
    let ipc = load(Benchmark::Ipc).expect("fixtures");
    for domain in ["blocks", "logistics00", "driverlog", "elevators-opt08", "visitall-opt11"] {
        sets.push((format!("ipc-{domain}"), ipc.iter().filter(|t| t.id.starts_with(domain)).rev().take(2).cloned().collect()));
    }
    let mut group = c.benchmark_group("successors");
    for (name, tasks) in &sets {
        let prepared: Vec<(TransitionModel, Vec<State>)> = tasks
            .iter()
            .map(|t| {
                let m = model(t);
                let s = states(&m, t);
                (m, s)
            })
            .collect();
        let mut out = Vec::new();
        group.bench_function(format!("{name}/decision-tree"), |b| {
            b.iter(|| {
                let mut total = 0;
                for (model, states) in &prepared {
                    for state in states {
                        model.applicable(state, &mut out);
                        total += out.len();
                    }
                }
                total
            })
        });
        group.bench_function(format!("{name}/scan-all-actions"), |b| {
            b.iter(|| {
                let mut total = 0;
                for (model, states) in &prepared {
                    for state in states {
                        scan(model, state, &mut out);
                        total += out.len();
                    }
                }
                total
            })
        });
        group.bench_function(format!("{name}/apply"), |b| {
            b.iter(|| {
                let mut count = 0;
                for (model, states) in &prepared {
                    for state in states {
                        model.applicable(state, &mut out);
                        for &action in out.iter().take(8) {
                            count += model.apply(state, action).len();
                        }
                    }
                }
                count
            })
        });
        let states: usize = prepared.iter().map(|(_, s)| s.len()).sum();
        eprintln!("{name}: {} tasks, {states} states per iteration", prepared.len());
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
