//! Grounding time (parse + check + ground) on real fixture problems. The comparison with
//! Fast Downward's translator on the same files is `cargo xtask bench ground`.
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use benchmark_data::{Benchmark, TaskFiles, load};
use criterion::{Criterion, criterion_group, criterion_main};

fn pick(benchmark: Benchmark, ids: &[&str]) -> Vec<TaskFiles> {
    let all = load(benchmark).expect("fixtures");
    ids.iter().map(|id| all.iter().find(|t| t.id.starts_with(id)).unwrap_or_else(|| panic!("fixture {id}")).clone()).collect()
}

fn bench(c: &mut Criterion) {
    let mut tasks = pick(
        Benchmark::Ipc,
        &[
            "blocks/instance-50",
            "logistics00/instance-40",
            "driverlog/instance-20",
            "elevators-opt08/instance-20",
            "visitall-opt11/instance-20",
        ],
    );
    tasks.extend(pick(
        Benchmark::AlfworldSeen,
        &[
            "look_at_obj_in_light-AlarmClock-None-DeskLamp-323",
            "pick_two_obj_and_place-Pan-None-CounterTop-14",
            "pick_heat_then_place_in_recep-Tomato-None-DiningTable-16",
        ],
    ));
    tasks.extend(pick(Benchmark::VirtualhomeEai, &["384_1", "419_2"]));
    let mut group = c.benchmark_group("ground");
    for task in &tasks {
        let name = task.id.split('/').next().unwrap_or_default().chars().take(40).collect::<String>()
            + "/"
            + task.id.rsplit('/').next().unwrap_or_default();
        group.bench_function(name, |b| {
            b.iter(|| {
                let domain = pddl_syntax::parse_domain(&task.domain).expect("parses");
                let problem = pddl_syntax::parse_problem(&task.problem).expect("parses");
                grounding::ground(&domain, &problem).expect("grounds")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
