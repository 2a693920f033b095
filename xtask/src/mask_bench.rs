//! `cargo xtask bench mask`: next-token masks over Qwen3's vocabulary for the allowed
//! languages of real ALFWorld and VirtualHome states, ours beside llguidance in one run.
//!
//! Workload: the states along the expert plans of every `--every`-th ALFWorld valid_seen
//! game and EAI VirtualHome problem with a gold plan. In each state, every applicable
//! action is written in its canonical Qwen3 tokenization followed by the separator, and a
//! mask is computed at every position `u` before each of its tokens.
//!
//! Ours: the state's language is built (uncached, as on a first visit) and each mask is a
//! full bitset over the vocabulary (`Matcher::fill_mask`). llguidance: the same constraint
//! as a Lark grammar of alternatives, `start: (action "\n"? | "DONE")?`, compiled once per
//! state (`ParserFactory::create_parser`, the factory and token trie built once, like our
//! vocabulary trie), each mask from `Matcher::compute_mask`, tokens consumed with
//! `consume_token` and undone with `rollback` between actions. llguidance reads the
//! tokenizer file with its own `tokenizer.json` support, so the two vocabularies are read
//! independently; the run checks they agree byte for byte and that the two masks agree at
//! every position (EOS aside: llguidance has one EOS token, we allow both of Qwen3's).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, bail};
use benchmark_data::{Benchmark, Extra, TaskFiles};
use llguidance::api::TopLevelGrammar;
use llguidance::toktrie::{ApproximateTokEnv, TokEnv, TokRxInfo, TokTrie};
use llguidance::{Matcher as LlgMatcher, ParserFactory};
use serde_json::json;
use token_constraint::{Matcher, PlanLanguages, StateLanguage, TokenMask, Vocabulary};
use tokenizers::Tokenizer;
use transition_model::{Spelling, State, TransitionModel};

/// One state of the workload: its language and, per action, the canonical token ids.
struct Workload {
    benchmark: &'static str,
    language: Arc<StateLanguage>,
    actions: Vec<Vec<u32>>,
    build_ns: f64,
}

fn task_model(files: &TaskFiles) -> anyhow::Result<(TransitionModel, Spelling, Vec<String>)> {
    let domain = pddl_syntax::parse_domain(&files.domain).map_err(|_| anyhow::anyhow!("{}: domain does not parse", files.id))?;
    let problem = pddl_syntax::parse_problem(&files.problem).map_err(|_| anyhow::anyhow!("{}: problem does not parse", files.id))?;
    let model = TransitionModel::new(grounding::ground(&domain, &problem)?);
    let (spelling, plan) = match &files.extra {
        Extra::Alfworld(game) => (Spelling::alfworld(model.task(), &game.grammar)?, game.walkthrough.clone()),
        Extra::Virtualhome { gold_plan: Some(plan), .. } => {
            let verbs = Spelling::virtualhome(model.task());
            let valid = model.validate_text(&Spelling::pddl(model.task()), plan).map_err(|e| anyhow::anyhow!(e.describe(model.task())))?;
            let plan = valid.actions.iter().filter_map(|&a| verbs.spell(a).map(str::to_string)).collect();
            (verbs, plan)
        }
        _ => bail!("{}: no plan to walk", files.id),
    };
    Ok((model, spelling, plan))
}

fn workloads(tokenizer: &Tokenizer, every: usize) -> anyhow::Result<Vec<Workload>> {
    let mut out = Vec::new();
    for (benchmark, name) in [(Benchmark::AlfworldSeen, "alfworld"), (Benchmark::VirtualhomeEai, "virtualhome")] {
        for files in benchmark_data::load(benchmark)?
            .iter()
            .filter(|f| !matches!(f.extra, Extra::Virtualhome { gold_plan: None, .. }))
            .step_by(every)
        {
            let (model, spelling, plan) = task_model(files)?;
            let states: Vec<State> = model.states_along(&spelling, &plan).map_err(|e| anyhow::anyhow!(e.describe(model.task())))?;
            let mut languages = PlanLanguages::new(&model, &spelling);
            for state in &states {
                let start = Instant::now();
                let built = languages.build(state)?;
                let build_ns = start.elapsed().as_nanos() as f64;
                let language = Arc::new(built);
                let mut actions = Vec::new();
                for choice in 0..language.language.choices() as u32 {
                    let text = format!("{}\n", String::from_utf8_lossy(language.language.text(choice)));
                    let ids = tokenizer.encode(text.as_str(), false).map_err(|e| anyhow::anyhow!("{e}"))?.get_ids().to_vec();
                    actions.push(ids);
                }
                out.push(Workload { benchmark: name, language, actions, build_ns });
            }
        }
    }
    Ok(out)
}

fn lark(language: &token_constraint::Language) -> String {
    let alternatives: Vec<String> = (0..language.choices() as u32)
        .map(|c| serde_json::to_string(&String::from_utf8_lossy(language.text(c))).expect("a string serialises"))
        .collect();
    format!("start: (action \"\\n\"? | \"DONE\")?\naction: {}\n", alternatives.join(" | "))
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

pub fn run(tokenizer_path: Option<PathBuf>, every: usize, no_reference: bool, json_out: bool) -> anyhow::Result<ExitCode> {
    let path = tokenizer_path.unwrap_or_else(|| benchmark_data::fixtures_dir().join("tokenizers/qwen3/tokenizer.json"));
    let (vocab, tokenizer): (Vocabulary, Tokenizer) = token_constraint::hf::vocabulary_from_file(&path)?;
    let work = workloads(&tokenizer, every)?;
    let positions: usize = work.iter().map(|w| w.actions.iter().map(Vec::len).sum::<usize>()).sum();
    eprintln!("{} states, {} masks each side, vocabulary {}", work.len(), positions, vocab.len());

    // Ours.
    let mut mask = TokenMask::new(vocab.len());
    let mut ours_ns = Vec::with_capacity(positions);
    let mut ours_state_ns = Vec::with_capacity(work.len());
    let mut ours_masks: Vec<Vec<u32>> = Vec::with_capacity(if no_reference { 0 } else { positions });
    for w in &work {
        let mut state_ns = w.build_ns;
        let root = Matcher::new(Arc::clone(&w.language.language));
        for tokens in &w.actions {
            let mut matcher = root.clone();
            for &token in tokens {
                let start = Instant::now();
                matcher.fill_mask(&vocab, &mut mask);
                let ns = start.elapsed().as_nanos() as f64;
                ours_ns.push(ns);
                state_ns += ns;
                if !no_reference {
                    ours_masks.push(mask.iter().filter(|&t| !vocab.is_special(t)).collect());
                }
                matcher.advance(&vocab, token).with_context(|| format!("{:?}: canonical token refused", w.benchmark))?;
            }
        }
        ours_state_ns.push(state_ns);
    }
    let ours_ns = sorted(ours_ns);
    let ours_state_raw = ours_state_ns.clone();
    let ours_state_ns = sorted(ours_state_ns);
    let build_ns = sorted(work.iter().map(|w| w.build_ns).collect());
    let mut report = json!({
        "vocab": vocab.len(),
        "states": work.len(),
        "masks": positions,
        "median_ns": percentile(&ours_ns, 0.5),
        "p99_ns": percentile(&ours_ns, 0.99),
        "max_ns": percentile(&ours_ns, 1.0),
        "mean_ns": ours_ns.iter().sum::<f64>() / ours_ns.len().max(1) as f64,
        "build_median_ns": percentile(&build_ns, 0.5),
        "per_state_median_us": percentile(&ours_state_ns, 0.5) / 1e3,
        "trie_nodes": vocab.trie().node_count(),
        "vocab_heap_bytes": vocab.heap_bytes(),
    });

    if !no_reference {
        let text = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
        let words = llguidance::token_bytes_from_tokenizer_json(&serde_json::from_str(&text)?)?;
        let vocab_agree = (0..vocab.len() as u32)
            .filter(|&t| !vocab.is_special(t))
            .all(|t| words.get(t as usize).is_some_and(|w| w == vocab.token_bytes(t)));
        let eos = *vocab.eos().last().context("an EOS token")?;
        let trie = TokTrie::from(&TokRxInfo::new(words.len() as u32, eos), &words);
        let env: TokEnv = Arc::new(ApproximateTokEnv::new(trie));
        let mut factory = ParserFactory::new_simple(&env)?;
        factory.quiet();
        let mut llg_ns = Vec::with_capacity(positions);
        let mut compile_ns = Vec::with_capacity(work.len());
        let mut llg_state_ns = Vec::with_capacity(work.len());
        let (mut agree, mut disagree) = (0usize, 0usize);
        let mut index = 0;
        for w in &work {
            let start = Instant::now();
            let grammar = TopLevelGrammar::from_lark(lark(&w.language.language));
            let mut matcher = LlgMatcher::new(factory.create_parser(grammar));
            let compiled = start.elapsed().as_nanos() as f64;
            if let Some(e) = matcher.get_error() {
                bail!("llguidance refused the grammar: {e}");
            }
            compile_ns.push(compiled);
            let mut state_ns = compiled;
            for tokens in &w.actions {
                for &token in tokens {
                    let start = Instant::now();
                    let m = matcher.compute_mask()?;
                    let ns = start.elapsed().as_nanos() as f64;
                    llg_ns.push(ns);
                    state_ns += ns;
                    let theirs: Vec<u32> = m.iter().filter(|&t| !vocab.is_special(t)).collect();
                    if theirs == ours_masks[index] {
                        agree += 1;
                    } else {
                        disagree += 1;
                    }
                    index += 1;
                    let start = Instant::now();
                    matcher.consume_token(token)?;
                    state_ns += start.elapsed().as_nanos() as f64;
                }
                let start = Instant::now();
                matcher.rollback(tokens.len())?;
                state_ns += start.elapsed().as_nanos() as f64;
            }
            llg_state_ns.push(state_ns);
        }
        let llg_ns = sorted(llg_ns);
        let compile_ns = sorted(compile_ns);
        let worst = llg_state_ns
            .iter()
            .zip(&ours_state_raw)
            .enumerate()
            .min_by(|a, b| (a.1.0 / a.1.1).total_cmp(&(b.1.0 / b.1.1)))
            .map(|(i, (l, o))| (i, *l, *o));
        if let Some((i, l, o)) = worst {
            eprintln!(
                "lowest per-state speed-up: state {i} ({}, {} actions, build {:.1} us): ours {:.1} us, llguidance {:.1} us",
                work[i].benchmark,
                work[i].actions.len(),
                work[i].build_ns / 1e3,
                o / 1e3,
                l / 1e3
            );
        }
        let ratios = sorted(llg_state_ns.iter().zip(&ours_state_raw).map(|(theirs, ours)| theirs / ours).collect());
        let llg_state_ns = sorted(llg_state_ns);
        let extra = json!({
            "llguidance_version": "1.9.1",
            "llguidance_median_ns": percentile(&llg_ns, 0.5),
            "llguidance_p99_ns": percentile(&llg_ns, 0.99),
            "llguidance_compile_median_us": percentile(&compile_ns, 0.5) / 1e3,
            "llguidance_per_state_median_us": percentile(&llg_state_ns, 0.5) / 1e3,
            "speedup_mask_median": percentile(&llg_ns, 0.5) / percentile(&ours_ns, 0.5),
            "speedup_per_state_median": percentile(&ratios, 0.5),
            "speedup_per_state_min": percentile(&ratios, 0.0),
            "masks_agree": agree,
            "masks_disagree": disagree,
            "vocab_bytes_agree": vocab_agree,
        });
        for (k, v) in extra.as_object().expect("an object") {
            report[k] = v.clone();
        }
    }
    if json_out {
        println!("{report}");
    } else {
        for (k, v) in report.as_object().expect("an object") {
            println!("{k:>32}: {v}");
        }
    }
    Ok(ExitCode::SUCCESS)
}
