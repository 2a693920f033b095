//! Phase I of the paper's agent (§3.1) and the whole episode: from the benchmark's own goal
//! annotation and what the environment shows, a grounded initial state for Phase II, the plan
//! bound back and executed, judged by the environment.
//!
//! - [`goal`]: the fixed, rule-based parse of each benchmark's goal annotation into G at class
//!   level (never an instance identifier);
//! - [`ontology`]: F_str, the fixed class-level ontology of each benchmark (committed in
//!   `fixtures/ontology/`);
//! - [`evidence`]: F_t and the evidence update U, with ALFWorld's perceiver;
//! - [`phase1`]: the skills, the controller H (through a benchmark [`phase1::Adapter`]), the
//!   policy f_φ ([`phase1::Policy`]: [`phase1::Systematic`], [`chat_policy::ChatPolicy`]) and
//!   the exploration loop with Ready and the stop;
//! - [`episode`]: the hand-over (Eq. 4), Phase II through the caller's planner, open-loop (or
//!   closed-loop) execution, and the per-episode record with precision, recall and failure
//!   attribution from the judge;
//! - [`alfworld`], [`virtualhome`]: the two benchmarks' adapters;
//! - [`direct`]: the direct interactive policy baseline (one class-level action per turn from a
//!   chat model, the environment's feedback, no harness), with its own episode record.
//!
//! One ALFWorld episode: the systematic explorer in Phase I, A* with LM-cut as Phase II (any
//! planner from the grounded problem fits there: constrained MCTS, a chat model, ...).
//!
//! ```
//! use exploration_harness::{EpisodeConfig, Grounded, Ontology, PhaseTwo, Systematic, parse_goal, run_episode};
//! use exploration_harness::alfworld::AlfworldAdapter;
//! use household_sim::{AlfworldEnv, Environment};
//! let fixtures = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
//! let read = |file: &str| std::fs::read_to_string(fixtures.join(file)).unwrap();
//! let domain = pddl_syntax::parse_domain(&read("alfworld/alfred.pddl")).unwrap();
//! let ontology = Ontology::from_text(&read("ontology/alfworld.txt"), "alfworld.txt").unwrap();
//! let game = fixtures.join("alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323")
//!     .join("trial_T20190909_044715_250790/game.tw-pddl");
//!
//! let mut env = AlfworldEnv::from_game_file(&game).unwrap();
//! // The goal at class level, from the benchmark's own annotation: no instance identifier.
//! let goal = parse_goal(env.goal()).unwrap();
//! let mut adapter = AlfworldAdapter::new(ontology, domain, read("alfworld/alfred.twl2"), env.goal());
//! let mut planner = |grounded: &Grounded| {
//!     Ok(match heuristics::search::optimal_plan_expanding(&grounded.model, 1_000_000) {
//!         Ok(actions) => PhaseTwo { actions, ..PhaseTwo::default() },
//!         Err(status) => PhaseTwo { no_plan: Some(status.name().to_string()), ..PhaseTwo::default() },
//!     })
//! };
//! // ALFWorld's budget of 55 steps, the plan executed open-loop.
//! let episode = run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(55), &mut planner).unwrap();
//! assert!(episode.success, "{:?}", episode.failure);
//! println!("Phase I: {} steps, stopped at {}; plan: {:?}", episode.phase1_steps, episode.phase1_stop, episode.plan);
//! // Every belief Phase I handed over held in the hidden state (the judge's view).
//! assert_eq!(episode.precision, Some(1.0));
//! ```

/// The version of what an episode does, for the records of evaluation runs: a configuration
/// names its records by every setting, and this names the behaviour behind the settings, so
/// records of an older agent are never resumed or merged into a newer one's. Bump it with every
/// change that alters an episode some existing configuration runs.
/// 1: up to 180974f; 2: the rooms the task sentence names come first (VirtualHome, 2c8a181);
/// 3: containers in named rooms before other rooms, action goals a bound object affords add no
/// other objects, turn_to never targets a goal step (aec1f60); 4: the objects the task sentence
/// names (VirtualHome's classes of context) decide between instances, and where it names no room,
/// Ready waits for an instance among them until every room has been entered (82ddd31); 5: a
/// head noun alone names no class of context; 6: a repeated VirtualHome node goal stands for
/// another instance of its class ("turn on the lights": two lights, not one); 7: constrained
/// MCTS is not run where LM-cut proves that no plan fits in the steps left (the same verdicts,
/// without the 60 s search); 8: the frontier a model explorer is offered narrows while the model
/// passes over the controller's first place (`phase1::Frontier`); 9: nor where A* with LM-cut,
/// within the steps left, proves it ([`plan_fit`], before the search; the same verdicts), and
/// Phase II's default time limit is the paper's 250 s (60 s before); 10: VirtualHome's Phase I
/// offers no closed appliance that is on as a place to open (EAI's executor refuses it); 11: the
/// episode ends the moment the environment's goal check holds, in Phase I or mid-plan (the rest
/// of the plan is not sent: ALFWorld's engine ends the game once won, and the replay of
/// version 10's planner records in TextWorld found a plan sent on past the win); 12: ALFWorld's
/// adapter no longer reads the game's admissible commands to tell that two places share a
/// location: it learns it from the game's "Nothing happens." to a `go to`, and ŝ0 gives such
/// places one location ([`alfworld::colocated`]); a failed hand-over is attributed to
/// `representation` (Phase I's state was insufficient), not `search`; 13: Phase I's prompt gives
/// VirtualHome an example fact in its own vocabulary (it showed ALFWorld's `inReceptacle`);
/// 14: a model that cannot be asked, or a planner that cannot run, stops the run instead of
/// being recorded as the agent's failure ([`RunError`]; A*'s proof that no plan exists and a
/// prompt past the model's context are no plan); Phase I and the direct policy ask for thinking
/// off, and Phase II's prompt is rendered thinking off (the paper's decoding settings; a
/// template without a thinking mode, SmolLM2's, renders as before); a skill the step budget
/// cuts short is `cut`, not `success`; 15: the episode ends where the benchmark's engine ends
/// it ([`household_sim::Environment::done`]): an ALFWorld game once won, as in 11, but no
/// VirtualHome episode, since EAI's executor runs a whole script and judges its end (11 ended
/// Phase I and the plan at the first line after which EAI's goal held, a bit of the hidden
/// state the agent cannot see; the direct policy still ends on success, as the paper has its
/// direct policies do); Phase I's usage counts requests as the direct policy's does (a repair
/// turn is a second call, a reply that could not be read is a call and its tokens count;
/// before, the first was one call and the second none); 16: the open-loop pass sends every
/// step of the plan whatever the environment answers, as the paper's "single open-loop pass"
/// and the engines do (TextWorld answers a refused command "Nothing happens." and takes the
/// next; a refused EAI line leaves the graph as it was); until 15 it stopped at the first
/// refused step, so a plan whose refused step changed nothing lost (ALFWorld's
/// `pick_cool_then_place_in_recep-Pan-None-StoveBurner-18` with SmolLM2: a `go to` a place
/// sharing the agent's location). Closed loop still replans at the first refusal; 17:
/// VirtualHome's environment shows the agent ids of its own, a permutation of the task's nodes
/// ([`household_sim::VirtualhomeEnv`], **Ids**), not EAI's, which tell the objects a task added
/// (from 1000) from the scene's, and which ordered the sweep and broke β's ties (lowest id); the
/// engine script keeps EAI's ids. The agent's terminal mechanism is the interaction limit only
/// where the budget cut the episode short ([`Episode::budget_spent`]; a plan sent to its end on
/// the budget's last step is the model's end, and a refused step before the budget ran out is
/// grounding). A search without a plan is recorded as `no plan: cpu-time`, its stop as it is
/// serialised, where it was `no plan: CpuTime: no plan`; 18: the proofs that no plan fits in the
/// steps left (the bound at ŝ0 before constrained MCTS, [`plan_fit`], the planner's A*) are checked
/// with admissible LM-cut ([`heuristics::LmCut::admissible`]): both household domains have
/// conditional effects, where LM-cut charged apart may overestimate, so a plan that fits could be
/// cut off (on every proof of version 17's VirtualHome records, the admissible one proves the
/// same); a Phase II that ends without a plan names its stop in one spelling, the search's
/// (`cpu-time`): `over-bound`, `out-of-budget`, `unsolvable`, `context-overflow`, `refused`,
/// `request-failed` (they were `OverBound`, `OutOfBudget`, ...), in the failure (`no plan:
/// over-bound: no plan within 3 actions ...`) and the detail's `stop`; A* out of its budget says so
/// (it said "no plan within N steps"); `eval` names EAI's task files by their content
/// (`task_files`), not by their folder (`task_dir`, a machine's path).
pub const HARNESS_VERSION: u32 = 18;

pub mod alfworld;
pub mod chat_planner;
pub mod chat_policy;
pub mod direct;
pub mod episode;
pub mod evidence;
pub mod goal;
pub mod ontology;
pub mod phase1;
pub mod virtualhome;

pub use direct::{DirectConfig, DirectEnd, DirectEpisode, DirectError, DirectStep, DirectUsage, run_direct};
pub use episode::{Attribution, Episode, EpisodeConfig, Grounded, Handing, Handover, PhaseTwo, PlanFit, plan_fit, run_episode};
pub use evidence::{Belief, Fact, Percept, perceive_alfworld};
pub use goal::{ClassGoal, ClassLiteral, GoalError, Symbol, parse_goal};
pub use ontology::{Ontology, OntologyError};
pub use phase1::{Adapter, Frontier, Policy, PolicyError, PolicyUsage, RunError, Skill, Skills, Systematic};
