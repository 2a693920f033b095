//! Criterion benchmarks of the hot paths on real inputs: Qwen3's vocabulary (fixtures) and
//! the states along the expert plans of ALFWorld games and EAI VirtualHome problems.
//! `mask`: a full bitset at every position `u` of every applicable action's canonical
//! tokenization; `allowed`: the same as a sparse list; `language`: building a state's
//! language (a cache miss). llguidance on the same workload runs beside ours in
//! `cargo xtask bench mask` (one run, both sides).
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use std::hint::black_box;
use std::sync::Arc;

use benchmark_data::{Benchmark, Extra, load};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use token_constraint::hf::vocabulary_from_file;
use token_constraint::{Matcher, PlanLanguages, TokenMask};
use transition_model::{Spelling, State, TransitionModel};

struct Task {
    model: TransitionModel,
    spelling: Spelling,
    states: Vec<State>,
}

fn tasks(benchmark: Benchmark, every: usize) -> Vec<Task> {
    let mut out = Vec::new();
    for files in
        load(benchmark).expect("fixtures").iter().filter(|f| !matches!(f.extra, Extra::Virtualhome { gold_plan: None, .. })).step_by(every)
    {
        let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
        let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
        let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
        let (spelling, plan) = match &files.extra {
            Extra::Alfworld(game) => (Spelling::alfworld(model.task(), &game.grammar).expect("grammar"), game.walkthrough.clone()),
            Extra::Virtualhome { gold_plan: Some(plan), .. } => (Spelling::pddl(model.task()), plan.clone()),
            _ => continue,
        };
        let states = model.states_along(&spelling, &plan).expect("expert plan");
        // VirtualHome in its class-level verbs, the language of the paper's prompts.
        let spelling = if benchmark == Benchmark::VirtualhomeEai { Spelling::virtualhome(model.task()) } else { spelling };
        out.push(Task { model, spelling, states });
    }
    out
}

fn bench(c: &mut Criterion) {
    let path = benchmark_data::fixtures_dir().join("tokenizers/qwen3/tokenizer.json");
    let (vocab, tokenizer) = vocabulary_from_file(&path).expect("Qwen3 tokenizer");
    for (name, benchmark, every) in [("alfworld", Benchmark::AlfworldSeen, 10), ("virtualhome", Benchmark::VirtualhomeEai, 20)] {
        let tasks = tasks(benchmark, every);
        // Every (matcher at u) along every applicable action's canonical tokenization.
        let mut positions: Vec<Matcher> = Vec::new();
        let mut states = 0u64;
        for task in &tasks {
            let mut languages = PlanLanguages::new(&task.model, &task.spelling);
            for state in &task.states {
                states += 1;
                let language = languages.language(state).expect("language");
                for choice in 0..language.language.choices() as u32 {
                    let text = format!("{}\n", String::from_utf8_lossy(language.language.text(choice)));
                    let mut matcher = Matcher::new(Arc::clone(&language.language));
                    for &token in tokenizer.encode(text.as_str(), false).expect("encodes").get_ids() {
                        positions.push(matcher.clone());
                        matcher.advance(&vocab, token).expect("canonical token allowed");
                    }
                }
            }
        }
        let mut group = c.benchmark_group(format!("qwen3/{name}"));
        group.throughput(Throughput::Elements(positions.len() as u64));
        let mut mask = TokenMask::new(vocab.len());
        group.bench_function("mask", |b| {
            b.iter(|| {
                for m in &positions {
                    m.fill_mask(&vocab, &mut mask);
                    black_box(&mask);
                }
            })
        });
        let mut allowed = Vec::new();
        group.bench_function("allowed", |b| {
            b.iter(|| {
                for m in &positions {
                    m.allowed(&vocab, &mut allowed);
                    black_box(&allowed);
                }
            })
        });
        group.throughput(Throughput::Elements(states));
        group.bench_function("language", |b| {
            b.iter(|| {
                for task in &tasks {
                    let mut languages = PlanLanguages::new(&task.model, &task.spelling);
                    for state in &task.states {
                        black_box(languages.build(state).expect("language"));
                    }
                }
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = bench
}
criterion_main!(benches);
