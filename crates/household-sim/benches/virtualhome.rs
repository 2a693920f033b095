//! VirtualHome step speed: the 198 recorded parity programs (2,974 script lines on the 33
//! kitchen tasks) replayed in `VirtualhomeEnv` (each step renders the observation) and in the
//! executor alone (clone of the initial world included), per step; the evolving graph's own time on
//! the same lines comes from timing `tools/virtualhome_record.py`'s executor calls.
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use std::hint::black_box;
use std::io::Read as _;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use household_sim::{Environment, IdScope, ScriptLine, VirtualhomeEnv, VirtualhomeTask};

fn programs() -> Vec<(VirtualhomeTask, Vec<String>)> {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai");
    let bytes = std::fs::read(fixtures.join("parity/programs.jsonl.gz")).expect("recordings");
    let mut text = String::new();
    flate2::read::GzDecoder::new(&bytes[..]).read_to_string(&mut text).expect("gzip");
    let mut tasks: Vec<(String, VirtualhomeTask)> = Vec::new();
    let mut out = Vec::new();
    for line in text.lines() {
        let record: serde_json::Value = serde_json::from_str(line).expect("record");
        let id = record["task"].as_str().expect("task").to_string();
        if !tasks.iter().any(|(t, _)| *t == id) {
            let task = VirtualhomeTask::load(&fixtures.join(format!("graphs/{id}.json.gz"))).expect("task");
            tasks.push((id.clone(), task));
        }
        let task = tasks.iter().find(|(t, _)| *t == id).map(|(_, t)| t.clone()).expect("loaded");
        let lines = record["lines"].as_array().expect("lines").iter().map(|l| l.as_str().expect("line").to_string()).collect();
        out.push((task, lines));
    }
    out
}

fn bench(c: &mut Criterion) {
    let programs = programs();
    let steps: usize = programs.iter().map(|(_, lines)| lines.len()).sum();
    let parsed: Vec<(VirtualhomeTask, Vec<ScriptLine>)> = programs
        .iter()
        .map(|(task, lines)| (task.clone(), lines.iter().map(|l| ScriptLine::parse(l).expect("recorded line parses")).collect()))
        .collect();
    let mut envs: Vec<(VirtualhomeEnv, Vec<String>)> = programs
        .into_iter()
        .map(|(task, lines)| (VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any), lines))
        .collect();
    let mut group = c.benchmark_group("virtualhome");
    group.throughput(Throughput::Elements(steps as u64));
    group.sample_size(10);
    group.bench_function("replay-198-programs-steps", |b| {
        b.iter(|| {
            for (env, lines) in &mut envs {
                env.reset();
                for line in lines.iter() {
                    black_box(env.step(line).event.executed());
                }
            }
        })
    });
    // The executor alone (what the evolving graph's time measures): no observation text.
    group.bench_function("execute-198-programs-steps", |b| {
        b.iter(|| {
            for (task, lines) in &parsed {
                let mut world = task.init.clone();
                for line in lines {
                    black_box(world.execute(line).is_ok());
                }
            }
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
