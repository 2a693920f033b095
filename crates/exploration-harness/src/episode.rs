//! One episode of the paper's agent (Fig. 1): Phase I ([`crate::phase1::explore`]), the
//! hand-over (Eq. 4: ŝ0 as a PDDL problem and β), Phase II (the caller's planner on ŝ0's
//! transition model: constrained MCTS, any other mode, or A*), the plan bound back through β and
//! run open-loop in the environment, whose own goal check is the verdict. The open-loop pass
//! sends every step of the plan, in order, whatever the environment answers (the paper's "single
//! open-loop pass": Phase II gets no feedback, and the engines go on after a refused command:
//! TextWorld answers "Nothing happens.", a refused EAI line leaves the graph as it was); a
//! refused step is the episode's failure unless a later step wins it. The episode ends where the
//! benchmark's engine ends it ([`household_sim::Environment::done`]: an ALFWorld game once won,
//! the rest of the plan then not sent) or at the step budget.
//!
//! The driver is the evaluation side: it takes an environment that is also a [`Judge`], hands
//! the agent's parts only `&mut dyn Environment`, and after Phase I asks the judge for the
//! hidden state to score F_τ (precision and recall) and attribute a failure (paper §5.3):
//! - `representation`: Phase I's state is wrong or short: a positive fact of F_τ about a goal class
//!   is false in the hidden state (precision < 1), or some goal object has no correctly located
//!   instance in F_τ (recall < 1); or exploration left fewer steps of the budget than the first
//!   plan needs: none at all, fewer than a plan Phase II returned though told the steps left (A*'s
//!   plan), or Phase II found no plan and A* proves that no plan of ŝ0 fits in the steps left
//!   (`no_plan_fits`, with LM-cut checked by its admissible form); or no hand-over could be made
//!   from F_τ (a goal symbol with no instance to bind: Phase I spent the budget, or ended early, or
//!   re-exploration set the only one seen aside);
//! - `search`: the state is right but Phase II returned no plan within its budget;
//! - `grounding`: the state is right, yet a plan step was not executed by the environment
//!   (binding or domain semantics) and the steps after it did not reach the goal;
//! - `goal`: every step executed and the goal check still fails.
//!
//! Precision is over F_τ's positive facts (in the judge's vocabulary) whose first argument is an
//! instance of a goal class; recall is the fraction of the goal's object symbols (a class,
//! counted as often as the goal names it) for which F_τ locates that many distinct instances of
//! the class correctly.
//!
//! `closed_loop` (beyond the paper): when a plan step is not executed, the rest of the plan is
//! not sent; the observations of the plan's steps have been read into F all along, and the
//! agent hands over again from there and replans, within the same step budget.
//!
//! `reexplore` (beyond the paper): a hand-over whose ŝ0 cannot reach the goal because a goal
//! fact about a bound instance can never hold ([`unreachable_goal_instances`]: grounding keeps
//! every fact some sequence of actions can make true, so a goal fact it does not know is
//! false for ever) sets those instances aside ([`crate::phase1::Record::set_aside`]) and Phase
//! I resumes with the steps left (only before any plan step), its feedback naming them, until
//! Ready binds other instances.
//! In VirtualHome, a class-level goal "turn on the computer" met first by a computer that is
//! unplugged and has no plug (the scene's other computer is the one that can be turned on)
//! otherwise ends in a dead end that no planner can leave. The judge is not consulted: ŝ0,
//! F_str and the domain decide.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use grounding::ActionId;
use household_sim::{Environment, Judge, JudgeAtom};
use serde::Serialize;
use transition_model::{Spelling, TransitionModel};

use crate::evidence::Fact;
use crate::goal::ClassGoal;
use crate::phase1::{Adapter, Decision, Exploration, Frontier, Policy, PolicyUsage, RunError, StepRecord, explore, resume};

/// ŝ0 and β.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Handover {
    /// ŝ0 as PDDL problem text, objects named by their PDDL names.
    pub problem: String,
    /// PDDL object name → the name the agent perceived.
    pub binding: BTreeMap<String, String>,
}

/// ŝ0 grounded: the problem, its transition model, and how its actions are spelled for Phase
/// II's prompt (perceived names, never a hidden identifier).
pub struct Grounded {
    /// ŝ0's text and β.
    pub handover: Handover,
    /// ŝ0 grounded in the benchmark's domain; plans are actions of its task.
    pub model: TransitionModel,
    /// How each grounded action is written for the model, in perceived names.
    pub spelling: Spelling,
    /// N_plan: the environment steps the episode has left for the plan (its budget less the
    /// steps already taken; Appendix A.1, N_exp + N_plan is the budget). [`run_episode`] sets it
    /// before Phase II; a planner should not return a longer plan, which could not finish.
    pub steps_left: usize,
}

impl Grounded {
    /// A hand-over with no step limit yet ([`run_episode`] sets [`Grounded::steps_left`]).
    pub fn new(handover: Handover, model: TransitionModel, spelling: Spelling) -> Grounded {
        Grounded { handover, model, spelling, steps_left: usize::MAX }
    }
}

impl std::fmt::Debug for Grounded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Grounded").field("handover", &self.handover).finish_non_exhaustive()
    }
}

/// A benchmark's hand-over and plan binding (the Phase I side is [`Adapter`]).
pub trait Handing: Adapter {
    /// Writes ŝ0 = F_τ ∪ F_str and grounds it in the benchmark's domain.
    fn handover(&mut self, goal: &ClassGoal, exploration: &Exploration, steps: &[StepRecord]) -> Result<Grounded, String>;
    /// The environment command of a plan action, through β; `None`: nothing to send (a step
    /// that only looks, or a move to where the agent already stands).
    fn command(&self, grounded: &Grounded, action: ActionId) -> Result<Option<String>, String>;
    /// A fact of F_t in the judge's vocabulary, where it has one.
    fn judge_view(&self, fact: &Fact) -> Option<JudgeAtom>;
    /// The class of a perceived instance name (`mug 2` → `mug`, `plate (1001)` → `plate`).
    fn class_of<'a>(&self, name: &'a str) -> &'a str;
    /// Whether a judge atom (predicate in lower case) places its first argument, for recall.
    fn locates(&self, atom: &JudgeAtom) -> bool;
}

/// What Phase II returned.
#[derive(Debug, Clone, Default)]
pub struct PhaseTwo {
    /// The plan, actions of [`Grounded::model`]'s task in order; empty with `no_plan`.
    pub actions: Vec<ActionId>,
    /// Model calls the planner made (chat requests, or a local model's forward passes; 0 for
    /// A*).
    pub model_calls: u64,
    /// Tokens the model generated, as the planner counts them (0 for A*).
    pub generated_tokens: u64,
    /// Anything the planner wants kept in the record (its stop reason, search figures).
    pub detail: serde_json::Value,
    /// The top of the search tree, from a planner that searches one (MCTS).
    pub search_tree: Option<mcts::TreeSummary>,
    /// Set when the planner ended without a plan (why: a search's stop, `WallClock`), with
    /// `actions` empty: the episode keeps this attempt's model calls, tokens, detail and tree,
    /// which an `Err` would lose. `Err` ([`RunError`]) is for a planner that could not run.
    pub no_plan: Option<String>,
    /// Set when the plan as written went on past `actions` with a step that is not applicable
    /// (an unconstrained decoder's, or a chat planner's): `actions` is the applicable prefix,
    /// sent as usual; the step after it could not be grounded, so the episode ends there, a
    /// grounding failure, unless the prefix already reached the goal.
    pub invalid_step: Option<String>,
}

/// Phase II: a planner on the grounded problem. A planner that ran and found no plan returns
/// [`PhaseTwo::no_plan`]; `Err` is for one that could not run (its model unreachable, a
/// setting it refuses), which ends the run rather than the episode ([`RunError`]).
pub type Planner<'a> = dyn FnMut(&Grounded) -> Result<PhaseTwo, RunError> + 'a;

/// The terminal failure class (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Attribution {
    /// Phase I's state was wrong or short, or exploration left too few steps for a plan.
    Representation,
    /// The state was right, but Phase II returned no plan.
    Search,
    /// The state was right, but a plan step was not executed and the steps after it did not
    /// reach the goal.
    Grounding,
    /// Every plan step executed, and the goal check still fails.
    Goal,
}

/// Everything recorded about one episode.
#[derive(Debug, Clone, Serialize)]
pub struct Episode {
    /// The environment's own goal check at the end.
    pub success: bool,
    /// Why Phase I stopped (`goal`, `ready`, `done`, `budget`, `refusals`, `policy error: ...`).
    pub phase1_stop: String,
    /// Environment steps Phase I took, re-exploration included.
    pub phase1_steps: usize,
    /// Phase I's decisions, re-exploration included.
    pub decisions: Vec<Decision>,
    /// Every environment step, Phase I's and the plan's.
    pub steps: Vec<StepRecord>,
    /// The last hand-over; `None` when none could be made.
    pub handover: Option<Handover>,
    /// The plan as sent (perceived names), of the last hand-over.
    pub plan: Vec<String>,
    /// Hand-overs made (1 open-loop; more when `closed_loop` replanned or `reexplore` set
    /// instances aside).
    pub handovers: usize,
    /// The perceived instances hand-overs set aside (`reexplore`), in order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub set_aside: Vec<String>,
    /// What went wrong (`step 3 not executed: ...`, `no plan: ...`, `goal not reached`): the first
    /// failure of an open-loop run, the last pass's of a closed-loop one (each replanning pass
    /// replaces it); `None` on success.
    pub failure: Option<String>,
    /// Phase II's planner returned no plan (it ended without one, or could not run); not set
    /// when the hand-over itself failed.
    pub no_plan: bool,
    /// The plan went on with a step that could not be grounded ([`PhaseTwo::invalid_step`]).
    pub plan_invalid: bool,
    /// The step budget ended the episode: Phase I spent it before a plan could take a step (or
    /// before it could hand over), or a plan still had steps to send when it ran out, one that
    /// could not be grounded included. Not set when the agent ended on its own (a plan sent to
    /// its end, even on the budget's last step).
    pub budget_spent: bool,
    /// The failure class (module documentation); `None` on success.
    pub attribution: Option<Attribution>,
    /// Precision of F_τ against the hidden state, in [0, 1], as of Phase I's last stop; `None`
    /// when F_τ holds no positive fact (in the judge's vocabulary) about an instance of a goal
    /// class.
    pub precision: Option<f64>,
    /// Recall of the goal's objects in F_τ, in [0, 1], as of Phase I's last stop; `None` when
    /// the goal has no `object` symbol with a class.
    pub recall: Option<f64>,
    /// What Phase I's policy spent in this episode.
    pub phase1_usage: PolicyUsage,
    /// Phase II's model calls, summed over the hand-overs.
    pub phase2_calls: u64,
    /// Phase II's generated tokens, summed over the hand-overs.
    pub phase2_tokens: u64,
    /// [`PhaseTwo::detail`] of the last planner call; null when there was none.
    pub phase2_detail: serde_json::Value,
    /// The top of Phase II's search tree, of the last hand-over's search, whether or not it
    /// found a plan (`None` for planners that build no tree: A*, greedy decoding, sampling, a
    /// chat model).
    pub search_tree: Option<mcts::TreeSummary>,
    /// Wall-clock milliseconds in Phase I, the reset and any re-exploration included.
    pub phase1_ms: f64,
    /// Wall-clock milliseconds writing and grounding the hand-overs and running Phase II's
    /// planner, summed.
    pub phase2_ms: f64,
    /// Wall-clock milliseconds sending the plans' steps, summed.
    pub execute_ms: f64,
    /// The episode as the benchmark's own engine takes it, to replay there (the judge's
    /// [`household_sim::Judge::engine_script`]; evaluation only: no part of the agent sees it).
    pub engine_script: Vec<household_sim::EngineLine>,
}

/// Settings of one episode.
#[derive(Debug, Clone, Copy)]
pub struct EpisodeConfig {
    /// Environment steps for the whole episode (ALFWorld 55, VirtualHome 20).
    pub budget: usize,
    /// Replan from the belief after a refused plan step (module documentation).
    pub closed_loop: bool,
    /// How Phase I offers places to a model ([`crate::phase1::Frontier`]); `None`: every
    /// unvisited place.
    pub frontier: Option<Frontier>,
    /// Set aside the instances that make ŝ0's goal unreachable and resume Phase I (module
    /// documentation).
    pub reexplore: bool,
}

impl EpisodeConfig {
    /// The paper's episode: `budget` steps, open loop, every unvisited place offered, Phase I
    /// once.
    pub fn open_loop(budget: usize) -> EpisodeConfig {
        EpisodeConfig { budget, closed_loop: false, frontier: None, reexplore: false }
    }
}

/// Runs one episode (module documentation).
pub fn run_episode<E: Environment + Judge>(
    env: &mut E,
    adapter: &mut dyn Handing,
    policy: &mut dyn Policy,
    goal: &ClassGoal,
    config: EpisodeConfig,
    plan: &mut Planner<'_>,
) -> Result<Episode, RunError> {
    let start = Instant::now();
    let first = env.reset();
    // A policy's usage is summed over its life; a harness reuses one policy across episodes.
    let usage_before = policy.usage();
    let exploration = explore(env, adapter, policy, goal, &first, config.budget, config.frontier)?;
    let phase1_ms = start.elapsed().as_secs_f64() * 1e3;
    let (precision, recall) = score(adapter, goal, &exploration, &env.hidden_atoms());
    let mut episode = Episode {
        success: false,
        phase1_stop: exploration.stop.clone(),
        phase1_steps: exploration.record.steps.len(),
        decisions: exploration.record.decisions.clone(),
        steps: exploration.record.steps.clone(),
        handover: None,
        plan: Vec::new(),
        handovers: 0,
        set_aside: Vec::new(),
        failure: None,
        no_plan: false,
        plan_invalid: false,
        budget_spent: false,
        attribution: None,
        precision,
        recall,
        phase1_usage: policy.usage().since(&usage_before),
        phase2_calls: 0,
        phase2_tokens: 0,
        phase2_detail: serde_json::Value::Null,
        search_tree: None,
        phase1_ms,
        phase2_ms: 0.0,
        execute_ms: 0.0,
        engine_script: Vec::new(),
    };
    let mut exploration = exploration;
    // The hand-over itself failed (no ŝ0): Phase I's state is insufficient (`representation`).
    let mut no_handover = false;
    // Phase I left no step for a plan.
    let mut explored_out = false;
    let mut not_executed = false;
    loop {
        // The engine has ended the episode (ALFWorld's game, won by Phase I's steps or an
        // earlier plan's).
        if env.done() {
            break;
        }
        episode.handovers += 1;
        // No plan has taken a step yet: a plan that does not fit is exploration's doing.
        let first_plan = episode.steps.len() == exploration.record.steps.len();
        let t = Instant::now();
        let grounded = match adapter.handover(goal, &exploration, &episode.steps) {
            Ok(g) => Grounded { steps_left: config.budget.saturating_sub(episode.steps.len()), ..g },
            Err(e) => {
                episode.failure = Some(e);
                no_handover = true;
                // Phase I ran out of steps before it could hand over.
                episode.budget_spent = exploration.stop == "budget";
                break;
            }
        };
        episode.handover = Some(grounded.handover.clone());
        // Only before any plan step, so that Phase I's steps stay the episode's first ones
        // (`Decision::steps` index both).
        if config.reexplore && first_plan && grounded.steps_left > 0 {
            let refuted: Vec<String> =
                unreachable_goal_instances(&grounded).into_iter().filter(|x| !exploration.record.set_aside.contains(x)).collect();
            if !refuted.is_empty() {
                episode.phase2_ms += t.elapsed().as_secs_f64() * 1e3;
                let t = Instant::now();
                exploration.record.set_aside.extend(refuted.iter().cloned());
                episode.set_aside.extend(refuted.iter().cloned());
                let feedback = format!(
                    "The goal cannot be reached with {}: the harness set {} aside; find another.",
                    refuted.join(", "),
                    if refuted.len() == 1 { "it" } else { "them" }
                );
                let before = exploration.record.steps.len();
                exploration = resume(env, adapter, policy, goal, exploration, &feedback, config.budget, config.frontier)?;
                episode.steps.extend(exploration.record.steps[before..].iter().cloned());
                episode.phase1_steps = exploration.record.steps.len();
                episode.phase1_stop = exploration.stop.clone();
                episode.decisions = exploration.record.decisions.clone();
                episode.phase1_usage = policy.usage().since(&usage_before);
                (episode.precision, episode.recall) = score(adapter, goal, &exploration, &env.hidden_atoms());
                episode.phase1_ms += t.elapsed().as_secs_f64() * 1e3;
                continue;
            }
        }
        if grounded.steps_left == 0 {
            // Phase I spent the budget: no plan could take a step.
            episode.failure = Some("step budget spent before Phase II".into());
            episode.budget_spent = true;
            // With closed-loop replanning, earlier plans spent steps too.
            explored_out = first_plan;
            break;
        }
        let phase2 = plan(&grounded)?;
        episode.phase2_ms += t.elapsed().as_secs_f64() * 1e3;
        episode.phase2_calls += phase2.model_calls;
        episode.phase2_tokens += phase2.generated_tokens;
        episode.phase2_detail = phase2.detail.clone();
        episode.search_tree = phase2.search_tree.clone();
        if let Some(why) = &phase2.no_plan {
            episode.failure = Some(format!("no plan: {why}"));
            episode.no_plan = true;
            // No plan of ŝ0 fits in the steps Phase I left: exploration spent them.
            explored_out = first_plan && no_plan_fits(&grounded.model, grounded.steps_left);
            break;
        }
        let t = Instant::now();
        episode.plan.clear();
        not_executed = false;
        // The pass stopped before the plan's end: a step with no command, or a refusal that
        // closed loop replans from.
        let mut cut = false;
        for &action in &phase2.actions {
            let command = match adapter.command(&grounded, action) {
                Ok(Some(c)) => c,
                Ok(None) => continue,
                Err(e) => {
                    if !not_executed {
                        episode.failure = Some(e);
                    }
                    not_executed = true;
                    cut = true;
                    break;
                }
            };
            episode.plan.push(command.clone());
            if episode.steps.len() >= config.budget {
                // The plan needs more steps than exploration left (planners are told how many);
                // after a refused step, that refusal is the earlier cause.
                episode.budget_spent = true;
                if !not_executed {
                    episode.failure = Some("step budget spent".into());
                    explored_out = first_plan;
                }
                break;
            }
            let result = env.step(&command);
            let step = episode.steps.len() + 1;
            adapter.observe(&result.observation, step, &mut exploration.belief);
            let executed = result.event.executed();
            episode.steps.push(StepRecord {
                phase: "plan",
                command: command.clone(),
                executed,
                observation: result.observation.text.clone(),
            });
            exploration.observation = result.observation;
            if !executed {
                // The first refusal is the episode's failure unless a later step wins it.
                if !not_executed {
                    episode.failure = Some(format!("step {} not executed: {command}", episode.steps.len()));
                    not_executed = true;
                }
                // Closed loop replans from here; the open-loop pass sends the rest regardless.
                if config.closed_loop {
                    cut = true;
                    break;
                }
            }
            // The rest of the plan is not sent where the engine has ended the episode (ALFWorld's
            // game once won); EAI's executor runs the whole script and judges its end.
            if env.done() {
                break;
            }
        }
        episode.plan_invalid = false;
        if phase2.invalid_step.is_some() && !cut && !env.done() && episode.steps.len() >= config.budget {
            // The plan had a step left (one that could not be grounded) when the budget ran out.
            episode.budget_spent = true;
        }
        if let Some(step) = phase2.invalid_step.as_ref().filter(|_| !cut && episode.steps.len() < config.budget && !env.done()) {
            if !not_executed {
                episode.failure = Some(format!("plan step {} cannot be grounded: {step}", episode.plan.len() + 1));
            }
            episode.plan_invalid = true;
            not_executed = true;
        }
        episode.execute_ms += t.elapsed().as_secs_f64() * 1e3;
        if !(not_executed && config.closed_loop && episode.steps.len() < config.budget) || env.done() {
            break;
        }
    }
    episode.success = env.goal_reached();
    episode.engine_script = env.engine_script();
    if episode.success {
        episode.failure = None;
    } else {
        if episode.failure.is_none() {
            episode.failure = Some("goal not reached".into());
        }
        let accurate = episode.precision.is_none_or(|p| p >= 1.0) && episode.recall.is_none_or(|r| r >= 1.0);
        // No hand-over: Phase I's facts, right as they are, do not make a problem the domain
        // grounds (an object the goal needs was never found), an insufficient state (§5.3).
        episode.attribution = Some(if !accurate || explored_out || no_handover {
            Attribution::Representation
        } else if episode.no_plan {
            Attribution::Search
        } else if not_executed {
            Attribution::Grounding
        } else {
            Attribution::Goal
        });
    }
    Ok(episode)
}

/// The perceived instances (through β) that a goal fact of ŝ0 names where that fact can never
/// hold: a positive ground atom of the goal's top-level conjunction that is neither a fluent
/// fact of the grounded task (grounding keeps only the facts some sequence of actions reaches)
/// nor a static fact true from the start. The agent itself (VirtualHome's `character`) is never set aside. Goals
/// stated over variables (ALFWorld's `exists`) name no instance and give none.
pub fn unreachable_goal_instances(grounded: &Grounded) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let Ok(problem) = pddl_syntax::parse_problem(&grounded.handover.problem) else { return out };
    let task = grounded.model.task();
    let mut atoms = Vec::new();
    let mut stack: Vec<&pddl_syntax::Condition> = problem.goal.iter().collect();
    while let Some(c) = stack.pop() {
        match c {
            pddl_syntax::Condition::And(parts, _) => stack.extend(parts),
            pddl_syntax::Condition::Atom(atom) => atoms.push(atom),
            _ => {}
        }
    }
    for atom in atoms {
        let constants: Option<Vec<&str>> = atom
            .args
            .iter()
            .map(|t| match t {
                pddl_syntax::Term::Constant(name) => Some(name.text.as_str()),
                pddl_syntax::Term::Variable(_) => None,
            })
            .collect();
        let Some(constants) = constants else { continue };
        let predicate = atom.predicate.text.to_lowercase();
        let Some(p) = task.predicates.iter().position(|q| q.name == predicate) else { continue };
        let Some(args) = constants.iter().map(|n| task.object_by_name(n)).collect::<Option<_>>() else { continue };
        let ground = grounding::Atom { predicate: grounding::PredicateId(p as u32), args };
        if task.facts.contains(&ground) || task.static_facts.contains(&ground) {
            continue;
        }
        for name in &constants {
            let perceived = grounded.handover.binding.get(&name.to_lowercase()).cloned().unwrap_or_else(|| (*name).to_string());
            if perceived != crate::virtualhome::ME {
                out.insert(perceived);
            }
        }
    }
    out
}

/// A* expansions [`no_plan_fits`] may spend: ample for a household task's ŝ0 (A* with LM-cut
/// proves the bound on ALFWorld's hand-overs in a few thousand), and a cap on the check's time.
const FIT_EXPANSIONS: u64 = 200_000;

/// What A* with LM-cut, bounded by a number of actions, proves of the plans of ŝ0
/// ([`heuristics::search::bounded_plan`]: the household domains have conditional effects, where
/// LM-cut may overestimate, so its `OverBound` is checked with admissible LM-cut).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanFit {
    /// A plan of this many actions, within the bound (optimal where LM-cut is admissible).
    Fits(usize),
    /// No plan within the bound: the space within it was searched, and states beyond it were
    /// cut off (plans may exist beyond the bound, or none at all).
    NoneFits,
    /// Nothing proved: the expansions ran out, ŝ0 has no plan at all and the search met no
    /// state beyond the bound (where it did, that is `NoneFits`), or the costs are not unit (a
    /// cost then says nothing of a length).
    Unknown,
}

/// A* with LM-cut, its proof checked ([`PlanFit`]), on ŝ0 for plans of at most `steps` actions,
/// within `max_expansions` and, where given, `time_limit` read on `clock` (without one, the same
/// answer on any machine, however loaded). Phase II's planner asks it before a search
/// ([`PlanFit::NoneFits`]: no search can find a plan that finishes), the episode after a failed one
/// (the attribution).
pub fn plan_fit(
    model: &transition_model::TransitionModel,
    steps: usize,
    max_expansions: u64,
    time_limit: Option<std::time::Duration>,
    clock: heuristics::search::Clock,
) -> PlanFit {
    if !model.task().has_unit_costs() {
        return PlanFit::Unknown;
    }
    let mut config = heuristics::search::SearchConfig::new(heuristics::search::Algorithm::AStar);
    config.max_cost = Some(steps as u64);
    config.max_expansions = Some(max_expansions);
    config.time_limit = time_limit;
    config.clock = clock;
    match heuristics::search::bounded_plan(model, &config) {
        Ok(plan) => PlanFit::Fits(plan.len()),
        // `OverBound`: no plan within the bound, and states beyond it. (`Unsolvable`, none
        // even there, is not the steps' fault.)
        Err(heuristics::search::SearchStatus::OverBound) => PlanFit::NoneFits,
        Err(_) => PlanFit::Unknown,
    }
}

/// Whether A* with LM-cut, its proof checked ([`PlanFit`]), shows that ŝ0 has no plan of at
/// most `steps` actions.
fn no_plan_fits(model: &transition_model::TransitionModel, steps: usize) -> bool {
    plan_fit(model, steps, FIT_EXPANSIONS, None, heuristics::search::Clock::Wall) == PlanFit::NoneFits
}

/// Precision and recall of F_τ against the hidden state (module documentation); `None` where
/// the denominator is zero.
pub fn score(adapter: &dyn Handing, goal: &ClassGoal, exploration: &Exploration, truth: &[JudgeAtom]) -> (Option<f64>, Option<f64>) {
    // Predicates compare without case (ALFWorld's judge writes the domain's lower-case names).
    let norm = |a: &JudgeAtom| JudgeAtom { predicate: a.predicate.to_ascii_lowercase(), args: a.args.clone() };
    let truth: BTreeSet<JudgeAtom> = truth.iter().map(norm).collect();
    let mut wanted: BTreeMap<&str, usize> = BTreeMap::new();
    for s in goal.symbols.iter().filter(|s| s.kind == "object") {
        if let Some(c) = &s.class {
            *wanted.entry(c.as_str()).or_default() += 1;
        }
    }
    let believed: Vec<JudgeAtom> = exploration
        .belief
        .facts()
        .iter()
        .filter(|f| f.holds)
        .filter_map(|f| adapter.judge_view(f))
        .map(|a| norm(&a))
        .filter(|a| a.args.first().is_some_and(|x| wanted.contains_key(adapter.class_of(x))))
        .collect();
    let right: Vec<&JudgeAtom> = believed.iter().filter(|a| truth.contains(a)).collect();
    let precision = (!believed.is_empty()).then(|| right.len() as f64 / believed.len() as f64);
    let total: usize = wanted.values().sum();
    let found: usize = wanted
        .iter()
        .map(|(class, &n)| {
            let located: BTreeSet<&str> =
                right.iter().filter(|a| adapter.locates(a) && adapter.class_of(&a.args[0]) == *class).map(|a| a.args[0].as_str()).collect();
            located.len().min(n)
        })
        .sum();
    let recall = (total > 0).then(|| found as f64 / total as f64);
    (precision, recall)
}

/// ŝ0's text as a transition model of `domain`.
pub fn ground(domain: &pddl_syntax::Domain, problem: &str) -> Result<TransitionModel, String> {
    let parsed =
        pddl_syntax::parse_problem(problem).map_err(|e| format!("the grounded problem does not parse: {}", e.render("ŝ0", problem)))?;
    let task = grounding::ground(domain, &parsed).map_err(|e| format!("the grounded problem does not ground: {e}"))?;
    Ok(TransitionModel::new(task))
}
