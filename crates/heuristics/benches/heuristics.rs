//! One evaluation of each heuristic, on real states: along the ALFWorld walkthroughs and
//! EAI gold plans, and along random walks in IPC tasks. The comparison with a reference on the
//! same states is `cargo xtask bench heuristic` (pyperplan's evaluations of the same states,
//! in one run), and with Fast Downward's search on the same tasks `cargo xtask bench plan`.
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use benchmark_data::{Benchmark, Extra, TaskFiles, load};
use criterion::{Criterion, criterion_group, criterion_main};
use transition_model::{Spelling, State, TransitionModel};

fn model(files: &TaskFiles) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("parses");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

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

fn bench(c: &mut Criterion) {
    let mut sets: Vec<(&str, Vec<TaskFiles>)> = Vec::new();
    sets.push(("alfworld-seen", load(Benchmark::AlfworldSeen).expect("fixtures").into_iter().step_by(20).collect()));
    sets.push((
        "virtualhome-eai",
        load(Benchmark::VirtualhomeEai)
            .expect("fixtures")
            .into_iter()
            .filter(|t| matches!(t.extra, Extra::Virtualhome { gold_plan: Some(_), .. }))
            .step_by(40)
            .collect(),
    ));
    let ipc = load(Benchmark::Ipc).expect("fixtures");
    sets.push(("ipc-logistics00", ipc.iter().filter(|t| t.id == "logistics00/instance-13").cloned().collect()));
    sets.push(("ipc-visitall-opt11", ipc.iter().filter(|t| t.id == "visitall-opt11/instance-12").cloned().collect()));
    sets.push(("ipc-elevators-opt08", ipc.iter().filter(|t| t.id == "elevators-opt08/instance-5").cloned().collect()));
    sets.push(("ipc-miconic", ipc.iter().filter(|t| t.id == "miconic/instance-101").cloned().collect()));
    let mut group = c.benchmark_group("heuristic");
    for (name, tasks) in &sets {
        let prepared: Vec<(TransitionModel, Vec<State>)> = tasks
            .iter()
            .map(|t| {
                let m = model(t);
                let s = states(&m, t);
                (m, s)
            })
            .collect();
        let evaluations: usize = prepared.iter().map(|(_, s)| s.len()).sum();
        eprintln!("{name}: {} tasks, {evaluations} states per iteration", prepared.len());
        // The household domains have conditional effects, where admissible LM-cut differs from
        // LM-cut (elsewhere it is the same heuristic).
        let household = !name.starts_with("ipc-");
        let names: &[&str] = if household {
            &["goalcount", "hmax", "hadd", "ff", "lmcut", "lmcut-admissible"]
        } else {
            &["goalcount", "hmax", "hadd", "ff", "lmcut"]
        };
        for &heuristic in names {
            let mut evaluators: Vec<_> = prepared.iter().map(|(m, _)| heuristics::by_name(heuristic, m).expect("heuristic")).collect();
            group.bench_function(format!("{name}/{heuristic}"), |b| {
                b.iter(|| {
                    let mut total = 0u64;
                    for ((_, states), evaluator) in prepared.iter().zip(&mut evaluators) {
                        for state in states {
                            total += u64::from(evaluator.evaluate(state).unwrap_or(0));
                        }
                    }
                    total
                })
            });
        }
    }
    group.finish();
}

/// What A* with `SearchConfig::symmetries` adds per generated state: the image's permutation
/// and the permuted state, on random-walk states of tasks with interchangeable objects (an
/// LM-cut evaluation of the same states is in `heuristic`; Fast Downward 26.6 from PyPI has no
/// symmetries to compare with).
fn symmetry(c: &mut Criterion) {
    let ipc = load(Benchmark::Ipc).expect("fixtures");
    let mut group = c.benchmark_group("symmetry");
    for id in ["gripper/instance-5", "gripper/instance-20"] {
        let files = ipc.iter().find(|t| t.id == id).expect("instance");
        let model = model(files);
        let mask = heuristics::search::relevant_facts(model.task());
        let states: Vec<State> = model
            .random_walk(0x9E37_79B9_7F4A_7C15, 200)
            .into_iter()
            .map(|mut s| {
                s.retain(&mask);
                s
            })
            .collect();
        let mut symmetries = heuristics::search::ObjectSymmetries::detect(model.task());
        eprintln!("{id}: {} classes, {} states per iteration", symmetries.classes().len(), states.len());
        let (mut perm, mut image) = (Vec::new(), State::empty(model.task().facts.len()));
        group.bench_function(format!("{id}/image"), |b| {
            b.iter(|| {
                let mut moved = 0;
                for state in &states {
                    if symmetries.canonical_permutation(state, &mut perm) {
                        symmetries.permute_state(state, &perm, &mut image);
                        moved += 1;
                    }
                }
                moved
            })
        });
        group.bench_function(format!("{id}/lmcut"), |b| {
            let mut lmcut = heuristics::LmCut::new(&model);
            b.iter(|| states.iter().map(|s| u64::from(heuristics::Heuristic::evaluate(&mut lmcut, s).unwrap_or(0))).sum::<u64>())
        });
    }
    group.finish();
}

/// Finding the interchangeable objects of EAI hand-overs (`fixtures/virtualhome-eai/handovers/`):
/// `detect` against the definition it agrees with (`detect_by_definition`: every candidate
/// swap checked against every action, each compared whole), in the same run. 580_1 grounds to
/// 209,055 actions, 826_1 to 16,719.
fn symmetry_detect(c: &mut Criterion) {
    let root = benchmark_data::fixtures_dir().join("virtualhome-eai");
    let read = |path: std::path::PathBuf| std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let domain = pddl_syntax::parse_domain(&read(root.join("virtualhome-sound.pddl"))).expect("parses");
    let mut group = c.benchmark_group("symmetry-detect");
    group.sample_size(10);
    for id in ["826_1", "580_1"] {
        let problem = pddl_syntax::parse_problem(&read(root.join(format!("handovers/{id}.pddl")))).expect("parses");
        let task = grounding::ground(&domain, &problem).expect("grounds");
        let found = heuristics::search::ObjectSymmetries::detect(&task);
        eprintln!("{id}: {} actions, {} classes", task.actions.len(), found.classes().len());
        group.bench_function(format!("{id}/detect"), |b| b.iter(|| heuristics::search::ObjectSymmetries::detect(&task).classes().len()));
        group.bench_function(format!("{id}/definition"), |b| {
            b.iter(|| heuristics::search::ObjectSymmetries::detect_by_definition(&task).classes().len())
        });
    }
    group.finish();
}

/// The time limit read before every expansion, on each clock (`search::Clock`): blind A*, whose
/// expansions are the cheapest, so the read weighs most (blocks instance-10, 36,657 expansions).
fn clock(c: &mut Criterion) {
    use heuristics::search::{Algorithm, Clock, SearchConfig, search};
    let files = load(Benchmark::Ipc).expect("fixtures").into_iter().find(|t| t.id == "blocks/instance-10").expect("blocks/instance-10");
    let model = model(&files);
    let mut group = c.benchmark_group("clock");
    group.sample_size(10);
    for clock in [Clock::Wall, Clock::Cpu] {
        let mut config = SearchConfig::new(Algorithm::AStar);
        config.time_limit = Some(std::time::Duration::from_secs(1000));
        config.clock = clock;
        group.bench_function(format!("blocks-10/astar-blind/{}", clock.name()), |b| {
            b.iter(|| search(&model, &mut heuristics::Blind::new(&model), &config, None).expanded)
        });
    }
    group.finish();
}

criterion_group!(benches, bench, symmetry, symmetry_detect, clock);
criterion_main!(benches);
