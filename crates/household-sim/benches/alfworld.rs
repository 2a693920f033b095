//! ALFWorld engine speed on real games: loading a game, resetting it, and stepping through
//! its expert walkthrough. `cargo xtask bench env` puts the same figures beside the real
//! engine's, measured in one run.
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use std::path::PathBuf;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use household_sim::{AlfworldEnv, Environment};

fn games() -> Vec<(String, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/alfworld/valid_seen");
    [
        "look_at_obj_in_light-AlarmClock-None-DeskLamp-323",
        "pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26",
        "pick_two_obj_and_place-SoapBar-None-GarbageCan-418",
    ]
    .iter()
    .map(|name| {
        let dir = root.join(name);
        let trial = std::fs::read_dir(&dir).expect("fixture").flatten().map(|e| e.path()).min().expect("a trial");
        (name.split('-').next().unwrap_or(name).to_string(), trial)
    })
    .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("alfworld");
    for (family, game) in games() {
        group.bench_with_input(BenchmarkId::new("load_and_reset", &family), &game, |b, game| {
            b.iter(|| {
                let mut env = AlfworldEnv::from_game_file(game).expect("loads");
                env.reset()
            })
        });
        let mut env = AlfworldEnv::from_game_file(&game).expect("loads");
        group.bench_function(BenchmarkId::new("reset", &family), |b| b.iter(|| env.reset()));
        let plan = env.walkthrough().to_vec();
        group.throughput(Throughput::Elements(plan.len() as u64));
        group.bench_function(BenchmarkId::new("walkthrough_steps", &family), |b| {
            b.iter(|| {
                env.reset();
                for command in &plan {
                    env.step(command);
                }
                env.goal_reached()
            })
        });
        group.throughput(Throughput::Elements(1));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
