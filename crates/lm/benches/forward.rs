//! Criterion benches of the local forward pass: prefill (a short prompt, and one as long as a
//! VirtualHome Phase I prompt, where attention is most of the time), one decode step, and a
//! sibling branch after a shared prefix. On the fetched SmolLM2 file when it is in the model cache (see
//! `cargo xtask fetch-model`), else on the tiny random-weight model, so that the bench always runs.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use lm::tiny::{TinySpec, write_tiny_gguf};
use lm::{LanguageModel, LocalModel};

fn model_path() -> (PathBuf, &'static str) {
    let smollm2 = lm::default_model_path();
    if smollm2.is_file() {
        return (smollm2, "smollm2");
    }
    let tiny = std::env::temp_dir().join(format!("lm-bench-tiny-{}.gguf", std::process::id()));
    write_tiny_gguf(&tiny, &TinySpec { context_length: 2048, ..TinySpec::default() }).expect("tiny model");
    (tiny, "tiny")
}

fn forward(c: &mut Criterion) {
    let (path, name) = model_path();
    let mut model = LocalModel::load(&path).expect("model loads");
    let text = "Your task is to: put a clean mug in the coffeemachine. You see a cabinet 1, a fridge 1 and a sinkbasin 1. ";
    let base = model.encode(text).expect("encodes");
    let prefix: Vec<u32> = base.iter().copied().cycle().take(128).collect();

    c.bench_function(&format!("{name}/prefill_128"), |b| {
        b.iter(|| {
            model.clear_cache();
            black_box(model.next_logprobs(&prefix).expect("runs"));
        })
    });
    // A Phase I prompt on VirtualHome is 1,000 to 1,600 tokens (the room's objects listed).
    let long: Vec<u32> = base.iter().copied().cycle().take(1024).collect();
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    group.bench_function("prefill_1024", |b| {
        b.iter(|| {
            model.clear_cache();
            black_box(model.next_logprobs(&long).expect("runs"));
        })
    });
    group.finish();
    let mut decode = prefix.clone();
    model.next_logprobs(&decode).expect("runs");
    decode.push(base[0]);
    let mut step = 0usize;
    c.bench_function(&format!("{name}/sibling_of_1_after_128"), |b| {
        b.iter(|| {
            // A different last token each time: the cache rewinds by one and runs one token.
            step += 1;
            *decode.last_mut().expect("nonempty") = base[step % base.len()];
            black_box(model.next_logprobs(&decode).expect("runs"));
        })
    });
    if path.starts_with(std::env::temp_dir()) {
        std::fs::remove_file(&path).ok();
    }
}

criterion_group!(benches, forward);
criterion_main!(benches);
