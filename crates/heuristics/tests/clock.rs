//! The clock a search's limit is read on. One test in its own binary (its own process): the
//! processor-time clock counts every thread of the process, so other tests running beside it
//! would spend it.

use std::time::{Duration, Instant};

use benchmark_data::{Benchmark, load};
use heuristics::LmCut;
use heuristics::search::{Algorithm, Clock, SearchConfig, SearchStatus, Stopwatch, search};
use transition_model::TransitionModel;

#[test]
fn the_processor_clock_counts_work_not_waiting() {
    assert!(Clock::Cpu.available(), "this platform reads the process's processor time");
    assert_eq!("cpu".parse::<Clock>().ok(), Some(Clock::Cpu));
    assert_eq!("wall".parse::<Clock>().ok(), Some(Clock::Wall));
    assert_eq!(Clock::default(), Clock::Wall);
    assert_eq!(serde_json::to_string(&Clock::Cpu).expect("serialises"), "\"cpu\"");

    // Waiting: the wall clock runs, the processor clock (nearly) does not.
    let (wall, cpu) = (Stopwatch::start(Clock::Wall), Stopwatch::start(Clock::Cpu));
    std::thread::sleep(Duration::from_millis(300));
    assert!(wall.elapsed() >= Duration::from_millis(300), "{:?}", wall.elapsed());
    assert!(cpu.elapsed() < Duration::from_millis(150), "a sleeping process used {:?} of processor time", cpu.elapsed());
    assert_eq!(cpu.clock(), Clock::Cpu);
    assert!(cpu.wall_elapsed() >= Duration::from_millis(300), "wall_elapsed is real time on any clock");

    // Working on one thread: the processor clock runs, and never faster than real time.
    let (wall, cpu) = (Instant::now(), Stopwatch::start(Clock::Cpu));
    let mut x = 0u64;
    while !cpu.past(Some(Duration::from_millis(100))) {
        for i in 0..10_000u64 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
        }
    }
    std::hint::black_box(x);
    assert!(cpu.elapsed() >= Duration::from_millis(100));
    // `past` reads the processor clock at most once a millisecond of real time: one thread
    // overshoots by about that, far from the limit's own size.
    assert!(cpu.elapsed() < Duration::from_millis(150), "the limit was overshot: {:?}", cpu.elapsed());
    assert!(
        wall.elapsed() + Duration::from_millis(20) >= cpu.elapsed(),
        "one thread: {:?} of processor time in {:?}",
        cpu.elapsed(),
        wall.elapsed()
    );

    // A search's time limit is read on its clock: none left, no expansion on either; with
    // room, the same plan on either.
    let files = load(Benchmark::Ipc).expect("fixtures").into_iter().find(|f| f.id.starts_with("gripper/")).expect("a gripper task");
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
    let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
    let mut plans = Vec::new();
    for clock in [Clock::Wall, Clock::Cpu] {
        let mut config = SearchConfig::new(Algorithm::AStar);
        config.clock = clock;
        config.time_limit = Some(Duration::ZERO);
        let result = search(&model, &mut LmCut::new(&model), &config, None);
        assert_eq!((result.status, result.expanded), (SearchStatus::OutOfBudget, 0), "{clock:?}");
        config.time_limit = Some(Duration::from_secs(600));
        let result = search(&model, &mut LmCut::new(&model), &config, None);
        assert_eq!(result.status, SearchStatus::Solved, "{clock:?}");
        plans.push(result.plan);
    }
    assert_eq!(plans[0], plans[1]);
}
