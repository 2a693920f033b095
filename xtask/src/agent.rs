//! `cargo xtask agent (--game G | --benchmark B --task ID)`: the paper's agent on one task.
//! Phase I with the chosen explorer (`systematic`, or a chat model: `smollm2`, a GGUF path,
//! `openai:URL`), ŝ0 handed over as a PDDL problem, Phase II with the chosen planner
//! (constrained MCTS by default, every mode and option of `plan --planner mcts`; or `astar`),
//! the plan executed open-loop (or `--closed-loop`); the environment's own goal check is the
//! verdict. Exit 0 won, 1 not won, 2 bad input.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use exploration_harness::alfworld::AlfworldAdapter;
use exploration_harness::chat_planner::{ChatPlannerConfig, plan_by_chat};
use exploration_harness::chat_policy::ChatPolicy;
use exploration_harness::virtualhome::VirtualhomeAdapter;
use exploration_harness::{
    ClassGoal, Episode, EpisodeConfig, Frontier, Grounded, Handing, Ontology, PhaseTwo, PlanFit, Policy, RunError, Systematic, parse_goal,
    plan_fit, run_episode,
};
use heuristics::search::SearchStatus;
use household_sim::{AlfworldEnv, Environment, Judge, VirtualhomeEnv};
use lm::{LanguageModel, LocalChat, LocalModel};
use mcts::prompt::planning_prompt;
use mcts::{DecodeError, Decoder};
use serde_json::json;
use vlm_client::{CachedChat, ChatClient, ChatModel};

use crate::input::InputError;
use crate::model_spec::{ModelSpec, Request};
use crate::phase2::{DecodeArgs, LmArgs, load_lm};

#[derive(Debug, clap::Args)]
pub struct AgentArgs {
    #[command(flatten)]
    which: crate::env::TaskArgs,
    /// Phase II's planner: `mcts` (the `--mode` of `--lm`, constrained MCTS by default) or
    /// `astar` (A* with LM-cut, the symbolic control).
    #[arg(long, default_value = "mcts", value_parser = ["mcts", "astar"])]
    planner: String,
    #[command(flatten)]
    episode: EpisodeArgs,
    /// Write every command the engine was given, one a line, as the engine takes it (the
    /// episode's engine script: ALFWorld's commands as sent, VirtualHome's script lines with the
    /// scene's ids): an ALFWorld episode replays in the real engine with
    /// `../shared/anchors/alfworld_replay.py GAME FILE`, a VirtualHome one with `cargo xtask env
    /// --commands FILE`.
    #[arg(long)]
    commands_out: Option<PathBuf>,
    /// Write the whole episode record as JSON (Phase I decisions, ŝ0, β, the plan, each step).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Print the episode record as one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// How an episode runs, for `agent` and `eval`: Phase I's policy, Phase II's model and
/// decoding, the step budget, the search time, open or closed loop.
#[derive(Debug, Clone, clap::Args)]
pub struct EpisodeArgs {
    /// Phase I's policy: `systematic` (the fixed sweep, no model), `smollm2` (the local default
    /// model, decoding under the reply's schema), a GGUF path, or `openai:URL` (a served chat
    /// model; `--served-model` names it). For `eval --agent direct`: the direct agent's chat
    /// model.
    #[arg(long, default_value = "systematic", value_parser = crate::model_spec::explorer)]
    pub explorer: ModelSpec,
    #[command(flatten)]
    pub lm: LmArgs,
    #[command(flatten)]
    pub decode: DecodeArgs,
    #[command(flatten)]
    pub chat: ChatPlannerArgs,
    /// Environment steps for the whole episode [default: the paper's, 55 ALFWorld, 20 VirtualHome].
    #[arg(long, value_parser = crate::input::at_least_one::<usize>)]
    pub budget: Option<usize>,
    /// Seconds of search for Phase II (the paper's 250 s per task, Appendix A.4; 60 s before
    /// HARNESS_VERSION 9).
    #[arg(long, default_value = "250", value_parser = crate::input::positive_seconds)]
    pub time_limit: f64,
    /// Phase I offers a model explorer at most this many `goto` skills at a time, the
    /// controller's most promising places (those it would sweep next); the others come back as
    /// those are inspected. 0 offers every unvisited place, as the paper's K_t (which omits only
    /// places inspected or not yet grounded). Not for the systematic explorer, which takes the
    /// first place either way.
    #[arg(long, default_value_t = 3)]
    pub frontier: usize,
    /// Beyond the paper: the frontier narrows by one place each time the model passes over
    /// the controller's first place for another, down to that place alone, and widens back
    /// once the model takes it (`true`); or stays `--frontier` wide (`false`, as before
    /// HARNESS_VERSION 8). Not for the systematic explorer.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub narrowing: bool,
    /// Beyond the paper: when a plan step is not executed, hand over again and replan.
    #[arg(long)]
    pub closed_loop: bool,
    /// Beyond the paper: when a goal fact about an instance the hand-over bound can never hold
    /// (an unplugged computer without a plug, to be turned on), set that instance aside and
    /// resume Phase I with the steps left (`true`), or stop at the first Ready as the paper does
    /// (`false`).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub reexplore: bool,
    /// With A* in Phase II (`agent --planner astar`, `eval --agent planner`): search states up to
    /// interchangeable objects, as `plan --symmetries` does. Plans as short as without it, often
    /// after far fewer expansions where the goal names several alike objects (five plates for
    /// the dishwasher); a plan may name other objects among alike ones, so it is part of the
    /// run's configuration.
    #[arg(long)]
    pub symmetries: bool,
    /// Keep Phase I's model replies in this file (JSON lines, keyed by the model file's digest
    /// or the server and served model, and the whole request): a request asked again is
    /// answered from it. Runs of Phase II conditions that share an explorer then plan from the
    /// same Phase I without recomputing it (`phase1_usage.cached_calls` counts the replayed
    /// replies; their tokens are the ones generated first). Not part of the run's configuration:
    /// it changes the time a run takes, not what it finds. Kept outside `eval`'s `--out` folder.
    #[arg(long, value_name = "FILE")]
    pub chat_cache: Option<PathBuf>,
}

impl EpisodeArgs {
    /// `--frontier` as [`EpisodeConfig::frontier`]: `None` for 0 (every place), and for the
    /// systematic explorer, which takes the controller's first place whatever it is offered
    /// (its records, K_t included, stay as they were).
    pub fn frontier(&self) -> Option<Frontier> {
        (self.frontier > 0 && self.explorer != ModelSpec::Systematic)
            .then_some(Frontier { width: self.frontier, narrowing: self.narrowing })
    }

    /// The episode's settings; `default_budget` is the benchmark's interaction limit
    /// (Appendix A.1: 55 ALFWorld, 20 VirtualHome) where `--budget` is not given.
    pub fn config(&self, default_budget: usize) -> EpisodeConfig {
        EpisodeConfig {
            budget: self.budget.unwrap_or(default_budget),
            closed_loop: self.closed_loop,
            frontier: self.frontier(),
            reexplore: self.reexplore,
        }
    }
}

/// Phase I's policy, named as `--explorer` names it: `systematic` or a chat model, behind the
/// reply file `cache` when one is given.
pub fn explorer(spec: &ModelSpec, lm: &LmArgs, cache: Option<&std::path::Path>) -> anyhow::Result<Box<dyn Policy>> {
    if *spec == ModelSpec::Systematic {
        if let Some(file) = cache {
            return Err(InputError(format!(
                "--chat-cache {}: keeps the replies of a Phase I chat model (--explorer smollm2, a GGUF path, openai:URL); the systematic explorer asks none",
                file.display()
            ))
            .into());
        }
        return Ok(Box::new(Systematic));
    }
    // A damaged reply file is named before any model is loaded or server asked.
    cache.map(CachedChat::check).transpose().map_err(|e| InputError(e.to_string()))?;
    let served_model = lm.served_model.as_str();
    let mut model = chat_model(spec, lm, Request::Chat)?;
    if let Some(file) = cache {
        // What names the model's answers: the file's digest for a local model, the server and
        // the served model's name otherwise.
        let identity = match spec.url() {
            // With what the server lists: another model behind the same URL and name is
            // asked again, not answered with the first one's replies.
            Some(url) => {
                format!("{url} served-model:{served_model} serves:{}", crate::model_spec::served_identity(url, served_model, &lm.server)?)
            }
            None => {
                let path = crate::lm::resolve_spec(spec)?;
                format!("{spec} sha256:{}", crate::pypi::sha256_remembered(&path)?)
            }
        };
        model = Box::new(CachedChat::open(model, &identity, file).map_err(|e| InputError(e.to_string()))?);
    }
    Ok(Box::new(ChatPolicy::new(model, &spec.to_string())))
}

/// A chat model by name: `openai:URL` (a served model, `lm.served_model` names it, asked for
/// `request` as `lm.server` says), `smollm2` (the local default model) or a GGUF path, through
/// `LocalChat`. An unknown name is bad input.
pub fn chat_model(spec: &ModelSpec, lm: &LmArgs, request: Request) -> anyhow::Result<Box<dyn ChatModel>> {
    if let Some(url) = spec.url() {
        // The key's variable is named as the other commands name it; the client's refusal
        // (made before any request) says what, not after how many attempts.
        lm.server.api_key()?;
        let config = lm.server.chat_config(url, &lm.served_model, request);
        return Ok(Box::new(ChatClient::new(config).map_err(|e| InputError(format!("{url}: {}", e.kind)))?));
    }
    let path = crate::lm::resolve_spec(spec)?;
    let model = LocalModel::load(&path).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
    Ok(Box::new(LocalChat::new(model, &spec.to_string()).map_err(|e| InputError(format!("{}: {e}", path.display())))?))
}

/// Phase II by a chat model without the constraint (`exploration_harness::chat_planner`): the
/// paper's unconstrained thinking condition, or unconstrained greedy through a chat endpoint.
#[derive(Debug, Clone, Default, clap::Args, serde::Serialize)]
pub struct ChatPlannerArgs {
    /// Phase II by this chat model, writing the plan as free text from the same planning prompt,
    /// instead of `--lm`'s decoder: `smollm2`, a GGUF path, or `openai:URL` (`--served-model`
    /// names it).
    #[arg(long, value_parser = crate::model_spec::chat_model)]
    pub chat_planner: Option<ModelSpec>,
    /// With `--chat-planner`: thinking on, at most 32,768 tokens, the paper's two thinking
    /// conditions: `--thinking` at temperature zero (its main tables), `--thinking recommended`
    /// with the recommended sampling of its appendix (temperature 1.0, top-p 0.95, top-k 20,
    /// seed `--seed`; run `--seeds 0,42,1738`). Thinking is asked for through the request's
    /// `chat_template_kwargs` (`enable_thinking`), which vLLM and llama-server (its Jinja
    /// templates, on by default) apply. Without `--thinking`: greedy, 512 tokens, thinking off
    /// (the unconstrained greedy condition through a chat endpoint).
    #[arg(long, requires = "chat_planner", num_args = 0..=1, default_missing_value = "temperature-zero", value_name = "SAMPLING")]
    pub thinking: Option<Thinking>,
}

/// How a thinking Phase II decodes (the paper's table of decoding settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Thinking {
    /// Temperature zero: "Qwen thinking, main paper".
    TemperatureZero,
    /// Temperature 1.0, top-p 0.95, top-k 20, seeded: "Qwen thinking, supplementary".
    Recommended,
}

/// Phase II as `--planner`, `--lm`, `--chat-planner` and the decoding options say.
pub struct PhaseTwoRunner {
    planner: String,
    chat: Option<(Box<dyn ChatModel>, ChatPlannerConfig)>,
    lm: Option<Box<dyn LanguageModel>>,
    vocab: Option<Arc<token_constraint::Vocabulary>>,
    decode: DecodeArgs,
    time_limit: f64,
    /// A* over states up to interchangeable objects (`--symmetries`).
    symmetries: bool,
}

impl PhaseTwoRunner {
    /// Phase II by `planner` (`mcts` or `astar`) with the episode's Phase II settings.
    pub fn new(planner: &str, episode: &EpisodeArgs) -> anyhow::Result<PhaseTwoRunner> {
        let EpisodeArgs { lm, decode, chat, time_limit, symmetries, .. } = episode;
        let (time_limit, symmetries) = (*time_limit, *symmetries);
        if symmetries && planner != "astar" {
            return Err(InputError(format!("--symmetries is a setting of --planner astar, not --planner {planner}")).into());
        }
        // A* decodes no plan: Phase II's model and decoding settings (but the clock) would be
        // passed over.
        if planner == "astar" {
            let mut given = crate::input::given::<LmArgs>(&crate::phase2::SHARED_WITH_PHASE_ONE);
            given.extend(crate::input::given::<DecodeArgs>(&["clock"]));
            if let Some(error) = crate::input::settings_of(&given, "--planner mcts, not --planner astar") {
                return Err(error.into());
            }
        }
        if let Some(name) = &chat.chat_planner {
            if planner != "mcts" {
                return Err(InputError(format!("--chat-planner plans in place of the decoder, not with --planner {planner}")).into());
            }
            let mut config = match chat.thinking {
                None => ChatPlannerConfig::greedy(),
                Some(Thinking::TemperatureZero) => ChatPlannerConfig::thinking(),
                Some(Thinking::Recommended) => ChatPlannerConfig::thinking_recommended(decode.seed),
            };
            config.prompt = decode.prompt_options();
            let request = if chat.thinking.is_some() { Request::ThinkingChat } else { Request::Chat };
            let chat = Some((chat_model(name, lm, request)?, config));
            return Ok(PhaseTwoRunner {
                planner: "chat".into(),
                chat,
                lm: None,
                vocab: None,
                decode: decode.clone(),
                time_limit,
                symmetries,
            });
        }
        let (model, vocab) = if planner == "mcts" {
            decode.config(time_limit)?;
            let model = load_lm(lm)?;
            let vocab = Arc::new(mcts::constraint_vocabulary(model.vocabulary()).context("the model's vocabulary")?);
            (Some(model), Some(vocab))
        } else {
            (None, None)
        };
        Ok(PhaseTwoRunner { planner: planner.to_string(), chat: None, lm: model, vocab, decode: decode.clone(), time_limit, symmetries })
    }

    /// Phase II on `grounded`: a search that ends without a plan (a budget, a bound, a proof
    /// that none exists, a prompt past the model's context) is an outcome, `no_plan`; `Err` is
    /// for what stops the run (a model that cannot be reached, a bad setting, an internal error).
    pub fn plan(&mut self, grounded: &Grounded) -> Result<PhaseTwo, RunError> {
        let model = &grounded.model;
        if let Some((chat, config)) = self.chat.as_mut() {
            return plan_by_chat(chat.as_mut(), grounded, config);
        }
        if self.planner == "astar" {
            let mut config = heuristics::search::SearchConfig::new(heuristics::search::Algorithm::AStar);
            config.time_limit = Some(Duration::from_secs_f64(self.time_limit));
            config.clock = self.decode.clock;
            config.symmetries = self.symmetries;
            // Unit costs: a plan's cost is its length, and no longer plan can finish in the
            // steps the episode has left (as MCTS's action bound).
            if model.task().has_unit_costs() {
                config.max_cost = Some(grounded.steps_left as u64);
            }
            // `symmetries` named only where it is on: other records stay as they were.
            let mut detail = json!({"planner": "astar"});
            if self.symmetries {
                detail["symmetries"] = json!(true);
            }
            let actions = match heuristics::search::bounded_plan(model, &config) {
                Ok(actions) => actions,
                Err(status @ (SearchStatus::OverBound | SearchStatus::OutOfBudget | SearchStatus::Unsolvable)) => {
                    let why = match status {
                        SearchStatus::Unsolvable => "the hand-over has no plan".to_string(),
                        SearchStatus::OverBound => format!("no plan within {} steps", grounded.steps_left),
                        _ => status.to_string(),
                    };
                    let why = format!("{}: {why}", status.name());
                    detail["stop"] = json!(status.name());
                    return Ok(PhaseTwo { no_plan: Some(why), detail, ..PhaseTwo::default() });
                }
                Err(status) => return Err(RunError(format!("A* returned {status:?} without a plan"))),
            };
            return Ok(PhaseTwo { actions, detail, ..PhaseTwo::default() });
        }
        let (Some(lm), Some(vocab)) = (self.lm.as_mut(), self.vocab.as_ref()) else { return Err(RunError("no language model".into())) };
        let initial = model.initial_state();
        let mut config = self.decode.config(self.time_limit).map_err(|e| RunError(e.to_string()))?;
        // N_plan: no plan longer than the episode's steps left (each action sends at most one
        // command), so the search goes on past a goal plan that could not finish.
        config.budget.max_actions = config.budget.max_actions.min(grounded.steps_left);
        // Constrained MCTS returns only plans the transition model accepts, of at most
        // `max_actions` actions. Where none reaches the goal, the search would spend its whole
        // budget to find that out: say so at once. First admissible LM-cut at ŝ0 (the household
        // domains have conditional effects, where plain LM-cut may overestimate; with unit costs a
        // cost bounds the length; one evaluation): a bound above `max_actions` proves it (EAI
        // 826_1: sixteen objects to put on the dishwasher, LM-cut 20 against the 17 steps the
        // sweep's Phase I leaves). Then A* within `max_actions` (`plan_fit`, its proof checked with
        // admissible LM-cut), on a budget of expansions (`FIT_PRECHECK_EXPANSIONS`) and a twentieth
        // of the search's time (at most 3 s): it proves it where LM-cut underestimates (SmolLM2's
        // Phase I on EAI 229_1 and 650_2 left 7 and 9 steps for plans of 8 and 11, and each search
        // spent its 60 s; the proof takes 0.04 and 0.02 s). A proof that needs more is not waited
        // for (419_2: 17 steps left for a plan of 18 in a scene of many objects, about 9 s of A*),
        // and the search runs. Where A* finds a plan, it is not used: Phase II is the search.
        // Neither check changes a verdict: the search could not have found a plan that finishes.
        if config.mode.constrained && matches!(config.mode.strategy, mcts::Strategy::Mcts(_)) && model.task().has_unit_costs() {
            use heuristics::Heuristic;
            let max_actions = config.budget.max_actions;
            let no_plan = |why: String, detail: serde_json::Value| PhaseTwo { no_plan: Some(why), detail, ..PhaseTwo::default() };
            let mode = self.decode.mode.to_string();
            if let Some(bound) = heuristics::LmCut::admissible(model).evaluate(&initial)
                && bound as usize > max_actions
            {
                return Ok(no_plan(
                    format!("over-bound: no plan within {max_actions} actions (LM-cut: at least {bound})"),
                    json!({"planner": "mcts", "mode": mode, "stop": "over-bound", "lower_bound": bound, "max_actions": max_actions}),
                ));
            }
            let started = heuristics::search::Stopwatch::start(config.budget.clock);
            let check_time = Duration::from_secs_f64(self.time_limit / 20.0).min(FIT_PRECHECK_TIME);
            if plan_fit(model, max_actions, FIT_PRECHECK_EXPANSIONS, Some(check_time), config.budget.clock) == PlanFit::NoneFits {
                return Ok(no_plan(
                    format!("over-bound: no plan within {max_actions} actions (A* with LM-cut)"),
                    json!({"planner": "mcts", "mode": mode, "stop": "over-bound", "proved_by": "astar", "max_actions": max_actions}),
                ));
            }
            // `--time-limit` is Phase II's in all: the check's time comes off the search's.
            config.budget.time_limit = config.budget.time_limit.map(|w| w.saturating_sub(started.elapsed()));
        }
        let prompt = planning_prompt(model, &grounded.spelling, &initial, &self.decode.prompt_options());
        let text = prompt.render(lm.as_ref()).map_err(|e| RunError(format!("rendering the prompt: {e}")))?;
        let tokens = lm.tokenizer().encode_prompt(&text).map_err(|e| RunError(format!("tokenizing the prompt: {e}")))?;
        let mut decoder =
            Decoder::with_end_policy(model, &grounded.spelling, Arc::clone(vocab), self.decode.value(), self.decode.end_policy());
        let outcome = match decoder.decode(lm.as_mut(), &tokens, &initial, &config) {
            Ok(outcome) => outcome,
            Err(e) => {
                // The sequence (ŝ0's prompt and the plan so far) does not fit the model's
                // context, or a server refused the request for itself: this model cannot plan
                // this task, an outcome (the search's tree is lost). Anything else stops the run.
                let stop = match &e {
                    DecodeError::Model(lm::LmError::ContextOverflow { .. }) => "context-overflow",
                    DecodeError::Model(lm::LmError::Http(http)) if http.kind.is_refusal() => "refused",
                    _ => return Err(RunError(format!("decoding: {e}"))),
                };
                return Ok(PhaseTwo {
                    no_plan: Some(format!("{stop}: {e}")),
                    detail: json!({"planner": "mcts", "mode": self.decode.mode.to_string(), "stop": stop, "prompt_tokens": tokens.len()}),
                    ..PhaseTwo::default()
                });
            }
        };
        let detail = json!({
            "planner": "mcts", "mode": outcome.mode, "stop": outcome.stop, "valid": outcome.valid, "solved": outcome.solved,
            "invalid": outcome.invalid.as_ref().map(|i| format!("step {}: {:?}", i.step + 1, i.text)),
            "lines": outcome.lines, "simulations": outcome.stats.simulations, "nodes": outcome.stats.nodes,
            "prompt_tokens": tokens.len(), "millis": outcome.stats.millis,
        });
        // No plan: the search ended (its budget, an exhausted tree, no applicable action)
        // without a plan that reaches the goal. Its best partial plan (kept in `lines`) is not
        // sent: the transition model says it ends short of the goal, so running it would only
        // spend steps and pass a search failure off as the goal's. A model that ended the plan
        // at once wrote an empty plan, which is its DONE.
        let no_plan = (!outcome.solved && outcome.stop.searched_out()).then(|| outcome.stop.to_string());
        let invalid_step = outcome.invalid.as_ref().map(|i| i.text.clone());
        Ok(PhaseTwo {
            actions: if no_plan.is_some() { Vec::new() } else { outcome.plan },
            model_calls: outcome.stats.usage.forward_calls,
            generated_tokens: outcome.stats.usage.tokens_generated,
            detail,
            search_tree: outcome.tree,
            no_plan,
            invalid_step,
        })
    }
}

/// A* expansions the check before constrained MCTS may spend (`PhaseTwoRunner::plan`): an
/// exhausted budget proves nothing, and the search runs.
const FIT_PRECHECK_EXPANSIONS: u64 = 20_000;

/// The check's time: at most a twentieth of the search's and at most this. On the EAI sweep
/// (all 342 hand-overs, one thread, idle) it adds 55 s of Phase II time to 73 s, changing no
/// plan; unbounded it took 90 s on 783_1 alone (a hand-over of many plates, where A* with LM-cut
/// is slow and MCTS with the uniform prior needs 5 s).
const FIT_PRECHECK_TIME: Duration = Duration::from_secs(3);

/// The benchmark's F_str.
pub fn ontology(benchmark: &str) -> anyhow::Result<Ontology> {
    let path = benchmark_data::fixtures_dir().join(format!("ontology/{benchmark}.txt"));
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(Ontology::from_text(&text, &path.display().to_string()).map_err(|e| InputError(e.to_string()))?)
}

/// An ALFWorld game (`game.tw-pddl` or its folder) and its goal at class level.
pub fn alfworld_env(game: &std::path::Path) -> anyhow::Result<(AlfworldEnv, ClassGoal)> {
    let game = if game.is_dir() { game.join("game.tw-pddl") } else { game.to_path_buf() };
    let env = AlfworldEnv::from_game_file(&game).map_err(|e| InputError(e.to_string()))?;
    let goal = parse_goal(env.goal()).map_err(|e| InputError(e.to_string()))?;
    Ok((env, goal))
}

/// An ALFWorld game and its adapter.
pub fn alfworld(game: &std::path::Path) -> anyhow::Result<(AlfworldEnv, AlfworldAdapter, ClassGoal)> {
    let (env, goal) = alfworld_env(game)?;
    let fixtures = benchmark_data::fixtures_dir();
    let domain_text = std::fs::read_to_string(fixtures.join("alfworld/alfred.pddl")).context("ALFWorld's domain")?;
    let domain = pddl_syntax::parse_domain(&domain_text).map_err(|e| anyhow::anyhow!("alfred.pddl: {e:?}"))?;
    let grammar = std::fs::read_to_string(fixtures.join("alfworld/alfred.twl2")).context("ALFWorld's grammar")?;
    let adapter = AlfworldAdapter::new(ontology("alfworld")?, domain, grammar, env.goal());
    Ok((env, adapter, goal))
}

/// A VirtualHome task and its goal at class level.
pub fn virtualhome_env(benchmark: &str, task: &str, task_dir: Option<&std::path::Path>) -> anyhow::Result<(VirtualhomeEnv, ClassGoal)> {
    let loaded = crate::env_virtualhome::load_task(benchmark, task, task_dir).map_err(|e| InputError(e.to_string()))?;
    let env = VirtualhomeEnv::new(loaded, benchmark);
    let goal = parse_goal(env.goal()).map_err(|e| InputError(e.to_string()))?;
    Ok((env, goal))
}

/// A VirtualHome task and its adapter.
pub fn virtualhome(
    benchmark: &str,
    task: &str,
    task_dir: Option<&std::path::Path>,
) -> anyhow::Result<(VirtualhomeEnv, VirtualhomeAdapter, ClassGoal)> {
    let (env, goal) = virtualhome_env(benchmark, task, task_dir)?;
    let adapter = VirtualhomeAdapter::new(ontology("virtualhome")?).map_err(anyhow::Error::msg)?;
    Ok((env, adapter, goal))
}

/// One episode on any environment.
pub fn episode<E: Environment + Judge>(
    env: &mut E,
    adapter: &mut dyn Handing,
    policy: &mut dyn Policy,
    goal: &ClassGoal,
    config: EpisodeConfig,
    phase2: &mut PhaseTwoRunner,
) -> Result<Episode, RunError> {
    let mut planner = |g: &Grounded| phase2.plan(g);
    run_episode(env, adapter, policy, goal, config, &mut planner)
}

pub fn run(args: AgentArgs) -> anyhow::Result<ExitCode> {
    for (path, option) in [(&args.commands_out, "--commands-out"), (&args.trace, "--trace")] {
        path.as_deref().map(|path| crate::input::file_to_write(path, option)).transpose()?;
    }
    let phase_two = match (&args.episode.chat.chat_planner, args.planner.as_str()) {
        (Some(planner), _) => Some(planner),
        (None, "mcts") => Some(&args.episode.lm.lm),
        (None, _) => None,
    };
    crate::model_spec::ServerArgs::check(&[Some(&args.episode.explorer), phase_two].into_iter().flatten().collect::<Vec<_>>())?;
    let mut policy = explorer(&args.episode.explorer, &args.episode.lm, args.episode.chat_cache.as_deref())?;
    let mut phase2 = PhaseTwoRunner::new(&args.planner, &args.episode)?;
    let (ep, name) = if let Some(game) = &args.which.game {
        let (mut env, mut adapter, goal) = alfworld(game)?;
        // `eval` refuses this set for agents with Phase I; one game is for looking at, so a warning.
        let train = benchmark_data::fixtures_dir().join("alfworld/valid_train");
        if let (Ok(game), Ok(train)) = (std::fs::canonicalize(game), std::fs::canonicalize(train))
            && game.starts_with(train)
        {
            eprintln!(
                "warning: {}: a valid_train game, the set ALFWorld's F_str is derived from (fixtures/ontology/alfworld.txt): Phase I knows facts of its own problem file",
                game.display()
            );
        }
        let config = args.episode.config(55);
        (episode(&mut env, &mut adapter, policy.as_mut(), &goal, config, &mut phase2)?, game.display().to_string())
    } else {
        let (benchmark, task) = (args.which.benchmark.as_deref().unwrap_or_default(), args.which.task.as_deref().unwrap_or_default());
        let (mut env, mut adapter, goal) = virtualhome(benchmark, task, args.which.task_dir.as_deref())?;
        let config = args.episode.config(20);
        (episode(&mut env, &mut adapter, policy.as_mut(), &goal, config, &mut phase2)?, format!("{benchmark}/{task}"))
    };
    if let Some(path) = &args.commands_out {
        let text: String = ep.engine_script.iter().map(|line| format!("{}\n", line.line)).collect();
        crate::input::write_output(path, "--commands-out", text)?;
    }
    // Who planned: a chat planner in place of the decoder, or `--planner` (with `--lm`).
    let (planner, lm) = match &args.episode.chat.chat_planner {
        Some(chat) => ("chat".to_string(), json!(chat)),
        None => (args.planner.clone(), json!(args.episode.lm.lm)),
    };
    let record = json!({"task": name, "explorer": args.episode.explorer, "planner": planner, "lm": lm, "episode": ep});
    if let Some(path) = &args.trace {
        crate::input::write_output(path, "--trace", serde_json::to_string_pretty(&record)?)?;
    }
    if args.json {
        println!("{record}");
    } else {
        print_episode(&ep);
    }
    Ok(if ep.success { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// The episode as a person reads it.
fn print_episode(ep: &Episode) {
    println!("Phase I ({} steps, stopped: {}):", ep.phase1_steps, ep.phase1_stop);
    for d in &ep.decisions {
        println!("  {} -> {}", d.skill, d.outcome);
        for &i in &d.steps {
            println!("    > {}: {}", ep.steps[i].command, ep.steps[i].observation.lines().next().unwrap_or(""));
        }
        for f in &d.admitted {
            println!("    + {f}");
        }
        for f in &d.refused {
            println!("    - {f} (proposed, no evidence)");
        }
    }
    for x in &ep.set_aside {
        println!("  set aside: {x} (a goal fact about it can never hold in the hand-over; Phase I went on)");
    }
    if let Some(h) = &ep.handover {
        println!("Grounded problem:\n{}", h.problem);
    }
    println!("Plan ({} steps):", ep.plan.len());
    for s in ep.steps.iter().filter(|s| s.phase == "plan") {
        println!("  {} -> {}", s.command, if s.executed { "executed" } else { "not executed" });
    }
    println!(
        "{} (precision {:?}, recall {:?}, attribution {:?})",
        if ep.success { "won".to_string() } else { format!("not won: {}", ep.failure.as_deref().unwrap_or("?")) },
        ep.precision,
        ep.recall,
        ep.attribution
    );
}
