//! Criterion benches of the local forward pass on real prompts: the prefill of Phase II's
//! prompt for EAI task 1004_2 and of the direct policy's first prompt on a rearrangement task
//! (the longer), as the workspace's snapshot tests pin them (`crates/mcts/tests/snapshots`,
//! `crates/exploration-harness/tests/snapshots`, so they change when the prompts do), through
//! the model's chat template; one decode step; and a sibling branch after a shared prefix. On
//! the fetched SmolLM2 file when it is in the model cache (see `cargo xtask fetch-model`), else
//! on the tiny random-weight model, so that the bench always runs (its name says which).
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use lm::tiny::{TinySpec, write_tiny_gguf};
use lm::{LanguageModel, LocalModel};

/// The text of an insta snapshot, past its header.
fn snapshot(relative: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(relative);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.splitn(3, "---\n").nth(2).unwrap_or_else(|| panic!("{}: no snapshot header", path.display())).to_string()
}

/// Phase II's prompt of EAI 1004_2 (`[system]` and `[user]` sections) and the direct policy's
/// first prompt of a rearrangement task (its system message, then the user's from the goal on),
/// as token ids
/// through `model`'s chat template.
fn real_prompts(model: &LocalModel) -> [(&'static str, Vec<u32>); 2] {
    let planning = snapshot("mcts/tests/snapshots/prompt__the_virtualhome_prompt_of_eai_1004_2.snap");
    let (system, user) = planning.trim_start_matches("[system]\n").split_once("\n[user]\n").expect("[system] and [user] sections");
    let direct = snapshot("exploration-harness/tests/snapshots/direct__the_first_prompt_of_a_rearrangement_task.snap");
    // The snapshot joins the system and user messages; the user's starts at the goal.
    let (direct_system, direct_user) = direct.split_once("\nGoal:").expect("the goal line");
    let encode = |system: &str, user: &str| model.encode(&model.chat_prompt(system, user).expect("renders")).expect("encodes");
    [("phase2_eai", encode(system.trim(), user.trim())), ("direct_rearrange", encode(direct_system, &format!("Goal:{direct_user}")))]
}

fn model_path() -> (PathBuf, &'static str) {
    let smollm2 = lm::default_model_path();
    if smollm2.is_file() {
        return (smollm2, "smollm2");
    }
    let tiny = std::env::temp_dir().join(format!("lm-bench-tiny-{}.gguf", std::process::id()));
    // Byte-level with few merges: the direct prompt is about 3,000 of its tokens.
    write_tiny_gguf(&tiny, &TinySpec { context_length: 8192, ..TinySpec::default() }).expect("tiny model");
    (tiny, "tiny")
}

fn forward(c: &mut Criterion) {
    let (path, name) = model_path();
    let mut model = LocalModel::load(&path).expect("model loads");
    let [(short_name, short), (long_name, long)] = real_prompts(&model);
    c.bench_function(&format!("{name}/prefill_{short_name}_{}", short.len()), |b| {
        b.iter(|| {
            model.clear_cache();
            black_box(model.next_logprobs(&short).expect("runs"));
        })
    });
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    group.bench_function(format!("prefill_{long_name}_{}", long.len()), |b| {
        b.iter(|| {
            model.clear_cache();
            black_box(model.next_logprobs(&long).expect("runs"));
        })
    });
    group.finish();
    // The branch: the Phase II prompt, then a different last token each time.
    let prefix = short.clone();
    let base = short;
    let mut decode = prefix.clone();
    model.next_logprobs(&decode).expect("runs");
    decode.push(base[0]);
    let mut step = 0usize;
    c.bench_function(&format!("{name}/sibling_of_1_after_{}", prefix.len()), |b| {
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
