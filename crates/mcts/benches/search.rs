//! Token-level MCTS with the uniform prior over the Qwen3 tokenizer (no model cost) on real
//! ALFWorld and VirtualHome tasks from fixtures/: a fixed number of simulations per
//! iteration, without early stop, with the default value (h_FF + LM-cut; `mcts::value` says
//! why not the remaining plan cost) and with h_FF alone (the search's own cost). Each iteration starts a fresh decoder,
//! so heuristic values are computed, not cached from the previous iteration; the decoder's
//! one-time encoding of the task's action texts (`Decoder::prepare`) is outside the timing.
//!
//! No reference system runs beside it: no registry carries a token-level MCTS decoder under a
//! planning constraint to compare with (PPL-MCTS and the LLM-planning searches are research
//! code on GitHub; `mctx` on PyPI is batched MuZero search over a learned model in JAX, which
//! cannot call a PDDL transition model). Its costly parts are compared where they have one:
//! masks beside llguidance (`cargo xtask bench mask`), the value's heuristics beside Fast
//! Downward and pyperplan (`cargo xtask bench plan`, `bench heuristic`), the model's forward
//! pass beside llama.cpp (`cargo xtask bench lm`).
#![allow(missing_docs, reason = "criterion_group! defines a public function that cannot carry a doc comment")]

use std::sync::Arc;

use benchmark_data::{Benchmark, Extra};
use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use lm::{LanguageModel, Tokenizer, UniformModel};
use mcts::{DecodeConfig, Decoder, Mode, ValueConfig};
use transition_model::{Spelling, TransitionModel};

const SIMULATIONS: u64 = 1000;

fn tasks(benchmark: Benchmark, count: usize) -> Vec<(String, TransitionModel, Extra)> {
    let mut all = benchmark_data::load(benchmark).expect("fixtures");
    all.sort_by(|a, b| a.id.cmp(&b.id));
    let step = all.len() / count;
    all.iter()
        .step_by(step)
        .take(count)
        .map(|files| {
            let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
            let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
            (files.id.clone(), TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds")), files.extra.clone())
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let tokenizer =
        Tokenizer::from_tokenizer_json(&benchmark_data::fixtures_dir().join("tokenizers/qwen3/tokenizer.json")).expect("tokenizer");
    let tokenizer = Arc::new(tokenizer);
    let mut lm = UniformModel::new(Arc::clone(&tokenizer));
    // The same tokenizer, for the set-up closure (the timed one holds `lm`).
    let encoder = UniformModel::new(tokenizer);
    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).expect("vocabulary"));
    let prompt = lm.encode("Plan:\n").expect("encodes");
    let mut group = c.benchmark_group("constrained-mcts-uniform");
    group.sample_size(10);
    group.throughput(Throughput::Elements(SIMULATIONS));
    let mut all = tasks(Benchmark::AlfworldSeen, 2);
    all.extend(tasks(Benchmark::VirtualhomeEai, 4));
    for (id, model, extra) in &all {
        let spelling = match extra {
            Extra::Alfworld(game) => Spelling::alfworld(model.task(), &game.grammar).expect("grammar"),
            _ => Spelling::virtualhome(model.task()),
        };
        let short: String = id.split('/').next().unwrap_or(id).chars().take(40).collect();
        for (label, value) in
            [("mix", ValueConfig::default()), ("ff", ValueConfig { lmcut: 0.0, remaining: 0.0, ..ValueConfig::default() })]
        {
            let mut config = DecodeConfig::new(Mode::from_name("constrained-mcts").expect("mode"));
            config.stop_at_goal = false;
            config.budget.simulations = Some(SIMULATIONS);
            config.budget.time_limit = None;
            // The throughput counts SIMULATIONS per iteration: a task whose tree is exhausted
            // sooner (small VirtualHome tasks, with transpositions closed) would inflate it.
            let trial = Decoder::new(model, &spelling, Arc::clone(&vocab), value.clone())
                .decode(&mut lm, &prompt, &model.initial_state(), &config)
                .expect("decodes");
            if trial.stats.simulations < SIMULATIONS {
                eprintln!("{short}/{label}: tree exhausted after {} simulations; skipped", trial.stats.simulations);
                continue;
            }
            group.bench_function(format!("{short}/{label}"), |b| {
                b.iter_batched(
                    || {
                        let mut decoder = Decoder::new(model, &spelling, Arc::clone(&vocab), value.clone());
                        decoder.prepare(&encoder).expect("encodes the task's action texts");
                        decoder
                    },
                    |mut decoder| decoder.decode(&mut lm, &prompt, &model.initial_state(), &config).expect("decodes"),
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
