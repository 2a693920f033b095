//! Shared by the decoder tests: tasks from fixtures/, the tiny model's tokenizer.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::Arc;

use benchmark_data::{Benchmark, Extra, TaskFiles};
use transition_model::{Spelling, TransitionModel};

/// A task with its transition model and the spelling its benchmark writes.
pub struct Loaded {
    pub id: String,
    pub model: TransitionModel,
    pub spelling: Spelling,
}

pub fn ground(domain: &str, problem: &str) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(problem).expect("problem parses");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

pub fn load(files: &TaskFiles) -> Loaded {
    let model = ground(&files.domain, &files.problem);
    let spelling = match &files.extra {
        Extra::Alfworld(game) => Spelling::alfworld(model.task(), &game.grammar).expect("grammar"),
        Extra::Virtualhome { .. } => Spelling::virtualhome(model.task()),
        Extra::None => Spelling::pddl(model.task()),
    };
    Loaded { id: files.id.clone(), model, spelling }
}

/// `count` tasks of `benchmark`, evenly spread over its sorted ids.
pub fn sample(benchmark: Benchmark, count: usize) -> Vec<Loaded> {
    let mut all = benchmark_data::load(benchmark).expect("fixtures load");
    all.sort_by(|a, b| a.id.cmp(&b.id));
    let step = (all.len() / count).max(1);
    all.iter().step_by(step).take(count).map(load).collect()
}

/// A temporary folder of its own, removed when dropped (also when the test fails).
pub struct TempDir(tempfile::TempDir);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        TempDir(tempfile::Builder::new().prefix(&format!("mcts-test-{name}-")).tempdir().expect("temp dir"))
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }
}

/// The tiny random-weight model (byte-level vocabulary of 274 tokens), with a context long
/// enough for short prompts and plans.
pub fn tiny_model(dir: &TempDir) -> lm::LocalModel {
    let path = dir.file("tiny.gguf");
    let spec = lm::tiny::TinySpec { context_length: 4096, ..lm::tiny::TinySpec::default() };
    lm::tiny::write_tiny_gguf(&path, &spec).expect("tiny model");
    lm::LocalModel::load(&path).expect("tiny model loads")
}

/// The uniform prior over the tiny model's vocabulary.
pub fn tiny_uniform(dir: &TempDir) -> lm::UniformModel {
    let path = dir.file("tiny-tokenizer.gguf");
    lm::tiny::write_tiny_gguf(&path, &lm::tiny::TinySpec::default()).expect("tiny model");
    lm::UniformModel::new(Arc::new(lm::Tokenizer::from_gguf_file(&path).expect("tokenizer")))
}

/// Replays `plan` from the initial state: every action applicable in turn.
pub fn applicable_in_turn(model: &TransitionModel, plan: &[grounding::ActionId]) -> bool {
    let mut state = model.initial_state();
    for &action in plan {
        if !model.is_applicable(&state, action) {
            return false;
        }
        state = model.apply(&state, action);
    }
    true
}
