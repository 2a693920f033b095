//! Phase II from the command line: `cargo xtask plan --planner mcts ...` on one task, and
//! `cargo xtask phase2` on a benchmark set (per-task JSONL records and a summary), with full
//! observability: the problem's own initial state is ŝ0.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use benchmark_data::{Benchmark, Extra, TaskFiles};
use lm::{LanguageModel, OpenAiConfig, OpenAiModel, ServerDialect, Tokenizer, UniformModel};
use mcts::prompt::{PromptOptions, Relevance, planning_prompt};
use mcts::{
    Backup, Clock, DecodeConfig, Decoder, MctsConfig, ModeName, Normalization, Outcome, SamplingConfig, Strategy, Tokenization, ValueConfig,
};
use serde::{Deserialize, Serialize};
use token_constraint::EndPolicy;
use transition_model::{Spelling, TransitionModel};

use eval_harness::records::RecordFile;

use crate::input::{self, InputError};
use crate::model_spec::ModelSpec;

/// The options of [`LmArgs`] that serve Phase I's model too (`--served-model` names a served
/// explorer, and the server options apply to every served model): not Phase II's alone, so not
/// passed over by an agent that decodes no plan.
pub const SHARED_WITH_PHASE_ONE: [&str; 4] = ["served_model", "api_key_env", "server_timeout", "server_retries"];

/// Which language model writes the plan.
#[derive(Debug, Clone, clap::Args, Serialize)]
pub struct LmArgs {
    /// `uniform` (every allowed token equally likely, over the Qwen3 tokenizer in fixtures/),
    /// `smollm2` (the default model; `cargo xtask fetch-model` first), `openai:URL` (an
    /// OpenAI-compatible completions server), or a path to a GGUF file.
    #[arg(long, default_value = "uniform", value_parser = crate::model_spec::language_model)]
    pub lm: ModelSpec,
    /// Tokenizer for `uniform` and `openai:` (a `tokenizer.json`, or a GGUF file)
    /// [default: fixtures/tokenizers/qwen3/tokenizer.json].
    #[arg(long)]
    pub tokenizer: Option<PathBuf>,
    /// The model name an `openai:` server serves.
    #[arg(long, default_value = "default")]
    pub served_model: String,
    /// What an `openai:` server understands: `vllm` (server-side `allowed_token_ids`, tokens
    /// named by id) or `generic` (llama.cpp's `llama-server`, Ollama: top-k logprobs only,
    /// renormalised here).
    #[arg(long, default_value = "vllm", value_parser = input::choice::<ServerDialect>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub server_dialect: ServerDialect,
    /// How every served model of the run is asked (this one, and a served `--explorer` or
    /// `--chat-planner`); not part of the configuration.
    #[command(flatten)]
    #[serde(skip)]
    pub server: crate::model_spec::ServerArgs,
}

/// How the plan is decoded (defaults: the paper's, Appendix A.4 and Table 6).
#[derive(Debug, Clone, clap::Args, Serialize)]
pub struct DecodeArgs {
    /// The Phase II condition.
    #[arg(long, default_value = "constrained-mcts", value_parser = input::choice::<ModeName>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub mode: ModeName,
    /// MCTS simulations at most.
    #[arg(long, value_parser = input::at_least_one::<u64>)]
    pub simulations: Option<u64>,
    /// What `--time-limit` is read on: `wall` (elapsed time, the paper's) or `cpu` (the
    /// processor time this process uses, all its threads: a search beside other work gets the
    /// same work done in its limit, so its verdict does not depend on the machine's load).
    /// Applies to Phase II's search and the A* planner, not to Phase I or a served model's
    /// waits, which use no processor time here.
    #[arg(long, default_value = "wall", value_parser = input::clock())]
    #[serde(skip_serializing_if = "Clock::is_wall", serialize_with = "input::serialize_name")]
    pub clock: Clock,
    /// Next-token distributions requested from the model, at most.
    #[arg(long, value_parser = input::at_least_one::<u64>)]
    pub model_calls: Option<u64>,
    /// Tokens of one plan at most.
    #[arg(long, default_value_t = 512, value_parser = input::at_least_one::<usize>)]
    pub max_tokens: usize,
    /// Actions of one plan at most.
    #[arg(long, default_value_t = 64, value_parser = input::at_least_one::<usize>)]
    pub max_actions: usize,
    /// MCTS: children per node.
    #[arg(long, default_value_t = 16, value_parser = input::at_least_one::<usize>)]
    pub width: usize,
    /// MCTS: exploration constant (finite, at least 0).
    #[arg(long, default_value_t = 2.5, value_parser = input::number_in(0.0, false, 1e9))]
    pub exploration: f64,
    /// MCTS: base constant (finite, above 0).
    #[arg(long, default_value_t = 10.0, value_parser = input::number_in(0.0, true, 1e12))]
    pub base: f64,
    /// MCTS: a node's value is the best of the values backed up through it, or their mean.
    #[arg(long, default_value = "max", value_parser = input::choice::<Backup>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub backup: Backup,
    /// MCTS: normalise Q over the children of each node (`siblings`) or over the whole tree.
    #[arg(long, default_value = "siblings", value_parser = input::choice::<Normalization>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub normalization: Normalization,
    /// MCTS: keep prefixes whose state another prefix reached first with no more actions
    /// (by default they are closed; cycles are closed either way).
    #[arg(long)]
    pub keep_transpositions: bool,
    /// MCTS: mix the prior with the uniform over each node's kept children by this weight,
    /// `(1 − ε)·p + ε/k` (0: the model's prior alone, as the paper).
    #[arg(long, default_value_t = 0.0, value_parser = input::number_in(0.0, false, 1.0))]
    pub prior_mix: f64,
    /// MCTS: renormalise each node's prior over its open children in PUCB (`true`), or keep
    /// closed children's share of it as the paper's Eq. 9 is written (`false`).
    #[arg(long, default_value_t = false, action = clap::ArgAction::Set)]
    pub renormalize_prior: bool,
    /// Value: weights of h_FF, LM-cut and the remaining plan cost in h (paper Appendix A.4;
    /// `1,1,0` is faster with the uniform prior, see `mcts::value`).
    #[arg(long, default_value = "1,1,1", value_parser = parse_weights)]
    pub weights: (f64, f64, f64),
    /// Value: expansions of each remaining-plan-cost search.
    #[arg(long, default_value_t = 200)]
    pub remaining_expansions: u64,
    /// Value: penalty λ per action (finite, at least 0).
    #[arg(long, default_value_t = 0.1, value_parser = input::number_in(0.0, false, 1e9))]
    pub lambda: f64,
    /// Sampling: temperature (0 is greedy).
    #[arg(long, default_value_t = 1.0, value_parser = input::number_in(0.0, false, 1e6))]
    pub temperature: f64,
    /// Sampling: nucleus mass, in (0, 1].
    #[arg(long, default_value_t = 0.95, value_parser = input::number_in(0.0, true, 1.0))]
    pub top_p: f64,
    /// Sampling: keep the k most likely tokens (0: no cut-off).
    #[arg(long, default_value_t = 20)]
    pub top_k: usize,
    /// Sampling: seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Constrained modes: `canonical` (the tokenizer's encoding of each action, one token path
    /// per action) or `any` (every tokenization of an allowed text).
    #[arg(long, default_value = "canonical", value_parser = input::choice::<Tokenization>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub tokenization: Tokenization,
    /// Prompt: show every true fact instead of those relevant to the goal.
    #[arg(long)]
    pub all_facts: bool,
    /// Constrained modes: where the plan may end: `anywhere` (at every action boundary; the
    /// plan is judged afterwards) or `at-goal` (only where the goal holds or no action applies).
    #[arg(long, default_value = "anywhere", value_parser = input::choice::<EndPolicy>())]
    #[serde(serialize_with = "input::serialize_name")]
    pub end: EndPolicy,
}

impl DecodeArgs {
    /// The decoding settings, with `time_limit` seconds per task (on `--clock`).
    pub fn config(&self, time_limit: f64) -> anyhow::Result<DecodeConfig> {
        let mut mode = self.mode.mode();
        match &mut mode.strategy {
            Strategy::Mcts(mcts) => {
                *mcts = MctsConfig {
                    width: self.width,
                    exploration: self.exploration,
                    base: self.base,
                    prune_transpositions: !self.keep_transpositions,
                    backup: self.backup,
                    normalization: self.normalization,
                    prior_mix: self.prior_mix,
                    renormalize_prior: self.renormalize_prior,
                    ..MctsConfig::default()
                };
            }
            Strategy::Sample(sampling) => {
                *sampling = SamplingConfig {
                    temperature: self.temperature,
                    top_p: self.top_p,
                    top_k: (self.top_k > 0).then_some(self.top_k),
                    seed: self.seed,
                };
            }
            Strategy::Greedy => {}
        }
        let mut config = DecodeConfig::new(mode);
        config.budget.simulations = self.simulations;
        config.budget.time_limit = Some(input::seconds(time_limit)?);
        config.budget.clock = self.clock;
        config.budget.model_calls = self.model_calls;
        config.budget.max_tokens = self.max_tokens;
        config.budget.max_actions = self.max_actions;
        config.tokenization = self.tokenization;
        Ok(config)
    }

    pub fn end_policy(&self) -> EndPolicy {
        self.end
    }

    pub fn value(&self) -> ValueConfig {
        let (ff, lmcut, remaining) = self.weights;
        ValueConfig {
            ff,
            lmcut,
            remaining,
            remaining_expansions: self.remaining_expansions,
            length_penalty: self.lambda,
            ..ValueConfig::default()
        }
    }

    /// The settings that differ from the defaults and change what a run finds, as a name
    /// part (`-end-at-goal-mix-0.25-weights-1-1-1`, empty for the defaults): records of
    /// different settings go to different files, so a run never resumes another's.
    pub fn variant(&self) -> String {
        let mut parts = Vec::new();
        if self.end != EndPolicy::Anywhere {
            parts.push(format!("end-{}", <&str>::from(self.end)));
        }
        if self.prior_mix != MctsConfig::default().prior_mix {
            parts.push(format!("mix-{}", self.prior_mix));
        }
        if self.renormalize_prior != MctsConfig::default().renormalize_prior {
            parts.push(format!("renormalize-{}", self.renormalize_prior));
        }
        let value = ValueConfig::default();
        if self.weights != (value.ff, value.lmcut, value.remaining) {
            let (ff, lmcut, remaining) = self.weights;
            parts.push(format!("weights-{ff}-{lmcut}-{remaining}"));
        }
        parts.iter().map(|p| format!("-{p}")).collect()
    }

    pub fn prompt_options(&self) -> PromptOptions {
        let mut options = PromptOptions::default();
        if self.all_facts {
            options.relevance = Relevance::All;
        }
        options
    }
}

fn parse_weights(text: &str) -> Result<(f64, f64, f64), String> {
    let parts: Vec<f64> =
        text.split(',').map(|p| p.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| format!("{text:?}: {e}"))?;
    match parts[..] {
        [ff, lmcut, remaining] if parts.iter().all(|w| w.is_finite() && *w >= 0.0) => Ok((ff, lmcut, remaining)),
        _ => Err(format!("{text:?}: give three non-negative weights, `FF,LMCUT,REMAINING`")),
    }
}

fn default_tokenizer() -> PathBuf {
    benchmark_data::fixtures_dir().join("tokenizers/qwen3/tokenizer.json")
}

fn tokenizer_at(path: &Path) -> anyhow::Result<Tokenizer> {
    let result =
        if path.extension().is_some_and(|e| e == "gguf") { Tokenizer::from_gguf_file(path) } else { Tokenizer::from_tokenizer_json(path) };
    // Named once: most of the tokenizer's errors name their file already.
    let tokenizer = result.map_err(|e| {
        let (shown, text) = (path.display().to_string(), e.to_string());
        InputError(if text.contains(&shown) { text } else { format!("{shown}: {text}") })
    })?;
    // Phase II's prompt is a chat: a `tokenizer.json` alone has no template (it is in the
    // `tokenizer_config.json` or `chat_template.jinja` beside it).
    if tokenizer.chat_template().is_none() {
        return Err(InputError(format!(
            "--tokenizer {}: no chat template (a `tokenizer_config.json` with `chat_template`, or a `chat_template.jinja`, beside a `tokenizer.json`); Phase II's prompt is a chat",
            path.display()
        ))
        .into());
    }
    Ok(tokenizer)
}

/// The model `args` names.
pub fn load_lm(args: &LmArgs) -> anyhow::Result<Box<dyn LanguageModel>> {
    let tokenizer_path = args.tokenizer.clone().unwrap_or_else(default_tokenizer);
    if args.lm == ModelSpec::Uniform {
        return Ok(Box::new(UniformModel::new(Arc::new(tokenizer_at(&tokenizer_path)?))));
    }
    if let Some(url) = args.lm.url() {
        let tokenizer = Arc::new(tokenizer_at(&tokenizer_path)?);
        let mut config = OpenAiConfig::new(url, &args.served_model);
        config.dialect = args.server_dialect;
        let policy = args.server.policy(crate::model_spec::Request::Completion);
        (config.timeout, config.max_retries) = (policy.timeout, policy.max_retries);
        config.api_key = args.server.api_key()?;
        let model = OpenAiModel::new(config, tokenizer).map_err(|e| InputError(format!("{url}: {e}")))?;
        return Ok(Box::new(model));
    }
    let path = crate::lm::resolve_spec(&args.lm)?;
    let model = lm::LocalModel::load(&path).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
    if model.tokenizer().chat_template().is_none() {
        return Err(InputError(format!(
            "{}: the model has no chat template (`tokenizer.chat_template`); Phase II's prompt is a chat",
            path.display()
        ))
        .into());
    }
    Ok(Box::new(model))
}

/// The surface language a benchmark's plans are written in.
pub fn spelling_for(files: &TaskFiles, model: &TransitionModel) -> anyhow::Result<Spelling> {
    Ok(match &files.extra {
        Extra::Alfworld(game) => {
            Spelling::alfworld(model.task(), &game.grammar).map_err(|e| InputError(format!("{}: {e}", files.problem_path.display())))?
        }
        Extra::Virtualhome { .. } => Spelling::virtualhome(model.task()),
        Extra::None => Spelling::pddl(model.task()),
    })
}

/// One task's result, as a JSONL record.
#[derive(Debug, Serialize, Deserialize)]
pub struct Record {
    pub benchmark: String,
    pub task: String,
    pub mode: String,
    pub lm: String,
    pub solved: bool,
    /// `false` when no plan exists: the delete relaxation cannot reach the goal from the
    /// initial state (h_max = ∞), a proof of unsolvability.
    #[serde(default = "yes")]
    pub solvable: bool,
    pub valid: bool,
    pub length: usize,
    pub cost: u64,
    pub stop: String,
    pub invalid: Option<String>,
    pub plan: Vec<String>,
    pub simulations: u64,
    pub nodes: u64,
    pub lm_calls: u64,
    pub generated_tokens: u64,
    /// Token positions the model computed (prompt and branch suffixes the prefix cache did
    /// not hold).
    #[serde(default)]
    pub prefilled_tokens: u64,
    pub forced_tokens: u64,
    pub decoded_tokens: u64,
    pub prompt_tokens: usize,
    pub heuristic_evaluations: u64,
    /// Decoding time (search), without grounding and prompt.
    pub millis: f64,
    /// Everything for this task: grounding, prompt, decoding.
    pub total_millis: f64,
    /// The run configuration's hash (`eval_harness::records::config_hash` of [`RunConfig`]):
    /// which settings made this record.
    #[serde(default)]
    pub config: String,
}

/// Every setting that changes what a run records: the set, the model and every decoding
/// setting, the time limit. Its hash names the record file and is stored in every record, so
/// runs that differ in any setting never append to or resume from each other's records.
#[derive(Debug, Serialize)]
pub struct RunConfig<'a> {
    pub benchmark: &'a str,
    pub set: &'a str,
    pub lm: &'a LmArgs,
    pub decode: &'a DecodeArgs,
    pub time_limit: f64,
    /// The decoder and its value as `exploration_harness::HARNESS_VERSION` has them (it is
    /// raised where Phase II changes): records of an older decoder are another run's, never
    /// resumed into a newer one's.
    pub harness: u32,
    /// What an `openai:` server serves ([`crate::model_spec::served_entry`]); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub served: Option<serde_json::Value>,
    /// A run's whole task list (before `--limit`, which takes the first of them: a shorter run's
    /// records are a longer one's), as `eval` names it: another subset file of the same name is
    /// another run. Absent for one task (`plan --planner mcts`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tasks: Option<serde_json::Value>,
    /// The fixtures folder where `NSEA_FIXTURES` names one ([`crate::eval::fixtures_entry`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fixtures: Option<String>,
    /// The model's files (a GGUF, a tokenizer given by path) by content: another file at the
    /// same path is another model ([`crate::eval::files_entry`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub files_sha256: Option<serde_json::Value>,
}

impl<'a> RunConfig<'a> {
    /// The configuration of a run of `decode` with `lm` on `set` of `benchmark`, asking an
    /// `openai:` server what it serves.
    pub fn new(benchmark: &'a str, set: &'a str, lm: &'a LmArgs, decode: &'a DecodeArgs, time_limit: f64) -> anyhow::Result<Self> {
        let served = crate::model_spec::served_entry(&[(&lm.lm, &lm.served_model)], &lm.server)?;
        let mut loaded: Vec<PathBuf> = lm.tokenizer.iter().cloned().collect();
        if let ModelSpec::Gguf(path) = &lm.lm {
            loaded.insert(0, path.clone());
        }
        let files_sha256 = crate::eval::files_entry(&loaded)?;
        Ok(RunConfig {
            benchmark,
            set,
            lm,
            decode,
            time_limit,
            harness: exploration_harness::HARNESS_VERSION,
            served,
            tasks: None,
            fixtures: crate::eval::fixtures_entry(),
            files_sha256,
        })
    }

    /// The same, for a run over `ids`, its whole task list.
    pub fn with_tasks<'b>(mut self, ids: impl IntoIterator<Item = &'b str>) -> Self {
        let ids: Vec<&str> = ids.into_iter().collect();
        let digest = eval_harness::records::task_list_digest(ids.iter().copied());
        self.tasks = Some(serde_json::json!({"count": ids.len(), "ids_sha256": digest}));
        self
    }
}

fn yes() -> bool {
    true
}

/// Grounds, prompts and decodes one task.
pub fn solve(
    files: &TaskFiles,
    lm: &mut dyn LanguageModel,
    lm_name: &str,
    vocab: &Arc<token_constraint::Vocabulary>,
    args: &DecodeArgs,
    time_limit: f64,
) -> anyhow::Result<(Record, Outcome, TransitionModel)> {
    let start = Instant::now();
    let model = TransitionModel::new(input::ground(files)?);
    let spelling = spelling_for(files, &model)?;
    let initial = model.initial_state();
    let prompt = planning_prompt(&model, &spelling, &initial, &args.prompt_options());
    let text = prompt.render(lm).context("rendering the prompt")?;
    let tokens = lm.tokenizer().encode_prompt(&text).context("tokenizing the prompt")?;
    let config = args.config(time_limit)?;
    let outcome = {
        let mut decoder = Decoder::with_end_policy(&model, &spelling, Arc::clone(vocab), args.value(), args.end_policy());
        decoder.decode(lm, &tokens, &initial, &config).with_context(|| format!("decoding {}", files.id))?
    };
    let cost = transition_model::plan_cost(model.task(), &outcome.plan);
    let record = Record {
        benchmark: files.benchmark.name().to_string(),
        task: files.id.clone(),
        mode: outcome.mode.to_string(),
        lm: lm_name.to_string(),
        solved: outcome.solved,
        solvable: heuristics::Heuristic::evaluate(&mut heuristics::HMax::new(&model), &initial).is_some(),
        valid: outcome.valid,
        length: outcome.plan.len(),
        cost,
        stop: serde_json::to_value(outcome.stop)?.as_str().unwrap_or_default().to_string(),
        invalid: outcome.invalid.as_ref().map(|i| format!("step {}: {:?}", i.step + 1, i.text)),
        plan: outcome.lines.clone(),
        simulations: outcome.stats.simulations,
        nodes: outcome.stats.nodes,
        lm_calls: outcome.stats.usage.forward_calls,
        generated_tokens: outcome.stats.usage.tokens_generated,
        prefilled_tokens: outcome.stats.usage.tokens_prefilled,
        forced_tokens: outcome.stats.forced_tokens,
        decoded_tokens: outcome.stats.decoded_tokens,
        prompt_tokens: tokens.len(),
        heuristic_evaluations: outcome.stats.heuristic_evaluations,
        millis: outcome.stats.millis,
        total_millis: start.elapsed().as_secs_f64() * 1e3,
        config: String::new(),
    };
    Ok((record, outcome, model))
}

/// `cargo xtask plan --planner mcts`.
/// Seconds per task by default (the paper's MCTS budget).
pub const DEFAULT_TIME_LIMIT: f64 = 250.0;

pub fn plan_one(
    files: &TaskFiles,
    lm_args: &LmArgs,
    args: &DecodeArgs,
    time_limit: f64,
    out: Option<&Path>,
    json: bool,
) -> anyhow::Result<ExitCode> {
    // The settings that make this plan, hashed as a run's records are (the task is the set),
    // asked of a server before the search, so that a server that cannot say loses no search.
    // The model's files (a tokenizer, a GGUF) are checked before a server is asked.
    crate::model_spec::ServerArgs::check(&[&lm_args.lm])?;
    let mut lm = load_lm(lm_args)?;
    let config = RunConfig::new(files.benchmark.name(), &files.id, lm_args, args, time_limit)?;
    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).context("the model's vocabulary")?);
    let (mut record, outcome, model) = solve(files, lm.as_mut(), &lm_args.lm.to_string(), &vocab, args, time_limit)?;
    record.config = eval_harness::records::config_hash(&config);
    // The plan is checked once more by the validator, from the text as written.
    let spelling = spelling_for(files, &model)?;
    let verdict = model.validate_text(&spelling, &outcome.lines);
    if outcome.solved && verdict.is_err() {
        anyhow::bail!(
            "internal error: a plan reported solved does not validate: {}",
            verdict.err().map(|e| e.describe(model.task())).unwrap_or_default()
        );
    }
    if let Some(out) = out {
        let mut text = outcome.lines.join("\n");
        text.push('\n');
        crate::input::write_output(out, "--out", text)?;
    }
    if json {
        println!("{}", serde_json::to_string(&record)?);
    } else {
        for line in &outcome.lines {
            println!("{line}");
        }
        let verdict = match (&outcome.invalid, outcome.solved) {
            (Some(invalid), _) => format!("invalid at step {}: {:?}", invalid.step + 1, invalid.text),
            (None, true) => "valid, reaches the goal".to_string(),
            (None, false) => "valid, does not reach the goal".to_string(),
        };
        eprintln!(
            "{verdict}; {} actions, stop: {}, {} simulations, {} lm calls, {} generated tokens, {:.1} ms",
            record.length, record.stop, record.simulations, record.lm_calls, record.generated_tokens, record.millis
        );
    }
    Ok(if outcome.solved { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

#[derive(Debug, clap::Args)]
pub struct Phase2Args {
    /// The benchmark set.
    #[arg(long, value_parser = input::choice::<Benchmark>())]
    benchmark: Benchmark,
    /// Run only the tasks of a subset file (`fixtures/subsets/<NAME>.txt`, or a path), e.g.
    /// `alfworld-seen-50`.
    #[arg(long)]
    subset: Option<String>,
    /// Run at most this many tasks.
    #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
    limit: Option<usize>,
    #[command(flatten)]
    lm: LmArgs,
    #[command(flatten)]
    decode: DecodeArgs,
    /// Seconds per task at most (the paper: 250).
    #[arg(long, default_value_t = DEFAULT_TIME_LIMIT, value_parser = crate::input::positive_seconds)]
    time_limit: f64,
    /// Folder for the records, `<benchmark>-<mode>[-<variant>]-<lm>-<hash>.jsonl` (named by the
    /// run's whole configuration, written beside as `.config.json`), and the summary.
    #[arg(long, default_value = "target/phase2")]
    out: PathBuf,
    /// Discard earlier records instead of resuming.
    #[arg(long)]
    fresh: bool,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

fn file_safe(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '.' { c } else { '_' }).collect()
}

/// `cargo xtask phase2`.
pub fn run(args: Phase2Args) -> anyhow::Result<ExitCode> {
    crate::input::folder_to_write(&args.out, "--out")?;
    crate::model_spec::ServerArgs::check(&[&args.lm.lm])?;
    let benchmark = args.benchmark;
    let all = match &args.subset {
        Some(subset) => benchmark_data::load_subset(benchmark, subset),
        None => benchmark_data::load(benchmark),
    }
    .map_err(|e| InputError(e.to_string()))?;
    let listed = match &args.subset {
        Some(subset) => format!("the subset {subset} lists none"),
        None => format!("no task files in {}", benchmark_data::fixtures_dir().display()),
    };
    let tasks = &all[..all.len().min(args.limit.unwrap_or(usize::MAX))];
    if tasks.is_empty() {
        return Err(InputError(format!("{}: no task to run ({listed})", benchmark.name())).into());
    }
    let lm_name = args.lm.lm.short_name();
    // A subset given as a path is named by its file stem (`/tmp/hard.txt` → `hard`).
    let set = match &args.subset {
        Some(subset) if subset.contains('/') || subset.ends_with(".txt") => {
            Path::new(subset).file_stem().map_or_else(|| subset.clone(), |s| s.to_string_lossy().into_owned())
        }
        Some(subset) => subset.clone(),
        None => args.benchmark.name().to_string(),
    };
    let variant = args.decode.variant();
    // The model's files (a tokenizer, a GGUF) are checked before a server is asked.
    let mut lm = load_lm(&args.lm)?;
    let config =
        RunConfig::new(args.benchmark.name(), &set, &args.lm, &args.decode, args.time_limit)?.with_tasks(all.iter().map(|t| t.id.as_str()));
    // Records in `<stem>-<hash>.jsonl`, the configuration beside them, appended whole and
    // resumed (eval_harness::records); a file of another configuration's records is refused.
    let stem = file_safe(&format!("{set}-{}{variant}-{lm_name}", args.decode.mode));
    let mut file = RecordFile::open(&args.out, &stem, &config, None, args.fresh)
        .and_then(|file| file.check_tasks(&all.iter().map(|t| t.id.as_str()).collect()).map(|()| file))
        .map_err(|e| InputError(e.to_string()))?;
    let path = file.path().to_path_buf();
    let hash = file.hash().to_string();
    let mut records: Vec<Record> = file
        .records()
        .iter()
        .map(|r| serde_json::from_value(serde_json::Value::Object(r.clone())))
        .collect::<Result<_, _>>()
        .map_err(|e| InputError(format!("{}: a record that is not a Phase II record: {e}", path.display())))?;
    file.settle()?;
    let done: BTreeSet<String> = records.iter().map(|r| r.task.clone()).collect();
    let todo: Vec<(usize, &TaskFiles)> = tasks.iter().enumerate().filter(|(_, t)| !done.contains(&t.id)).collect();

    let vocab = Arc::new(mcts::constraint_vocabulary(lm.vocabulary()).context("the model's vocabulary")?);
    let bar = input::progress_bar(format!("{set} {}", args.decode.mode), tasks.len());
    bar.set_position((tasks.len() - todo.len()) as u64);
    let mut solved = records.iter().filter(|r| r.solved).count();
    for (index, files) in todo {
        let (mut record, _, _) =
            solve(files, lm.as_mut(), &lm_name, &vocab, &args.decode, args.time_limit).with_context(|| format!("task {}", files.id))?;
        record.config.clone_from(&hash);
        file.append(index, &record)?;
        solved += usize::from(record.solved);
        records.push(record);
        bar.set_message(format!("solved {solved}"));
        bar.inc(1);
    }
    bar.finish_and_clear();

    // The summary beside the record file is the file's: every task it holds, those of an
    // earlier, longer run of the configuration included.
    let summary = summarize(&records, &set, &args.decode, &lm_name, &path);
    std::fs::write(path.with_extension("summary.json"), serde_json::to_string_pretty(&summary)? + "\n")?;
    if args.json {
        println!("{summary}");
    } else {
        println!(
            "{set} {} lm={lm_name}: solved {}/{} ({:.1}%; {:.1}% of the {} solvable), valid {:.1}%, mean generated tokens {:.1}, mean {:.0} ms, {:.0} simulations/s  records: {}",
            args.decode.mode,
            summary["solved"],
            summary["tasks"],
            summary["success_rate"].as_f64().unwrap_or(0.0) * 100.0,
            summary["success_rate_solvable"].as_f64().unwrap_or(0.0) * 100.0,
            summary["solvable"],
            summary["valid_rate"].as_f64().unwrap_or(0.0) * 100.0,
            summary["mean_generated_tokens"].as_f64().unwrap_or(0.0),
            summary["mean_millis"].as_f64().unwrap_or(0.0),
            summary["simulations_per_second"].as_f64().unwrap_or(0.0),
            path.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn summarize(records: &[Record], set: &str, decode: &DecodeArgs, lm: &str, path: &Path) -> serde_json::Value {
    let n = records.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Record) -> f64| records.iter().map(f).sum::<f64>() / n;
    let solved = records.iter().filter(|r| r.solved).count();
    let solvable = records.iter().filter(|r| r.solvable).count();
    let valid = records.iter().filter(|r| r.valid).count();
    let search_seconds: f64 = records.iter().map(|r| r.millis).sum::<f64>() / 1e3;
    let simulations: u64 = records.iter().map(|r| r.simulations).sum();
    let mut stops = std::collections::BTreeMap::<&str, usize>::new();
    for r in records {
        *stops.entry(r.stop.as_str()).or_default() += 1;
    }
    let solved_lengths: Vec<f64> = records.iter().filter(|r| r.solved).map(|r| r.length as f64).collect();
    serde_json::json!({
        "set": set, "mode": decode.mode, "end": decode.end.to_string(), "prior_mix": decode.prior_mix,
        "weights": [decode.weights.0, decode.weights.1, decode.weights.2], "lm": lm, "tasks": records.len(),
        "solved": solved, "success_rate": solved as f64 / n,
        "solvable": solvable, "success_rate_solvable": solved as f64 / solvable.max(1) as f64, "valid": valid, "valid_rate": valid as f64 / n,
        "mean_generated_tokens": mean(&|r| r.generated_tokens as f64),
        "mean_lm_calls": mean(&|r| r.lm_calls as f64),
        "mean_prefilled_tokens": mean(&|r| r.prefilled_tokens as f64),
        "mean_decoded_tokens": mean(&|r| r.decoded_tokens as f64),
        "mean_simulations": mean(&|r| r.simulations as f64),
        "mean_millis": mean(&|r| r.millis),
        "max_millis": records.iter().map(|r| r.millis).fold(0.0, f64::max),
        "mean_total_millis": mean(&|r| r.total_millis),
        "mean_solved_length": if solved_lengths.is_empty() { 0.0 } else { solved_lengths.iter().sum::<f64>() / solved_lengths.len() as f64 },
        "simulations_per_second": if search_seconds > 0.0 { simulations as f64 / search_seconds } else { 0.0 },
        "stops": stops,
        "records": path.display().to_string(),
    })
}
