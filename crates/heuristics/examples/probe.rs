//! Probe: A* LM-cut expansions on one IPC instance.
fn main() {
    let id = std::env::args().nth(1).expect("id");
    let files = benchmark_data::load(benchmark_data::Benchmark::Ipc).unwrap().into_iter().find(|t| t.id == id).unwrap();
    let d = pddl_syntax::parse_domain(&files.domain).unwrap();
    let p = pddl_syntax::parse_problem(&files.problem).unwrap();
    let model = transition_model::TransitionModel::new(grounding::ground(&d, &p).unwrap());
    let t = std::time::Instant::now();
    let r = heuristics::search::search(
        &model,
        &mut heuristics::LmCut::new(&model),
        &heuristics::search::SearchConfig::new(heuristics::search::Algorithm::AStar),
        None,
    );
    println!("{id} cost {} expanded {} evaluated {} {:?}", r.cost, r.expanded, r.evaluated, t.elapsed());
}
