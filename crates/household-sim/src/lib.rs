//! Household environments that hide the true state and judge success as the benchmarks' own
//! engines do.
//!
//! An agent sees an [`Environment`]: it resets, sends command text, reads
//! [`Observation`]s and [`Event`]s, and may ask whether the goal holds (the engine's own
//! check, which ends an episode as the benchmark ends it). The hidden state is for the
//! [`Judge`] trait, which evaluation uses after an episode (failure attribution, precision and
//! recall of beliefs) and which no agent is handed.
//!
//! The types keep an agent apart by what it is handed, not by what they can do: the concrete
//! environments also serve tools, tests and judges, and offer what those need:
//! - [`AlfworldEnv::task`] and [`AlfworldEnv::walkthrough`]: the grounded task and the
//!   expert's plan;
//! - the public fields of [`VirtualhomeTask`]: the scene graph and the goal's node ids;
//! - [`VirtualhomeEnv::with_id_scope`]`(`[`IdScope::Any`]`)`: instance-level script lines
//!   (`[WALK] <fridge> (289)`) executed for any node id, seen or not, for replays and parity
//!   with EAI's executor, the scene's ids throughout. By default ([`IdScope::Perceived`]) the
//!   environment names nodes by ids of its own, not EAI's, which tell how a task was built
//!   ([`VirtualhomeEnv`], **Ids**; [`Judge::engine_script`] gives EAI's back), and a line may
//!   name only a node an observation has shown since the reset, so an agent cannot probe ids
//!   through [`Environment::step`].
//!
//! `exploration-harness` keeps the rule on its side too: its Phase I policies choose among the
//! skills the controller offers, and its direct policy refuses an instance-level line before it
//! reaches the environment.
//!
//! An ALFWorld game from `fixtures/`, played with its expert's walkthrough:
//!
//! ```
//! use household_sim::{AlfworldEnv, Environment};
//! let game = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
//!     .join("../../fixtures/alfworld/valid_seen/look_at_obj_in_light-AlarmClock-None-DeskLamp-323")
//!     .join("trial_T20190909_044715_250790/game.tw-pddl");
//! let mut env = AlfworldEnv::from_game_file(&game)?;
//! let first = env.reset();
//! assert!(first.text.contains("Your task is to: look at alarmclock under the desklamp."));
//! // A command the engine cannot carry out changes nothing, and still counts as a step.
//! let refused = env.step("take the moon");
//! assert!(!refused.event.executed());
//! assert_eq!(refused.observation.text, household_sim::NOTHING_HAPPENS);
//! for command in env.walkthrough().to_vec() {
//!     assert!(env.step(&command).event.executed(), "{command}");
//! }
//! assert!(env.goal_reached());
//! assert_eq!(env.steps_taken(), 1 + env.walkthrough().len());
//! # Ok::<(), household_sim::EnvError>(())
//! ```

mod alfworld;
mod env;
mod error;
mod python_random;
mod virtualhome;

pub use alfworld::{AlfworldEnv, NOTHING_HAPPENS, TASK_TYPES};
pub use env::{EngineLine, Environment, Event, GoalAnnotation, Image, Judge, JudgeAtom, Observation, StepResult};
pub use error::EnvError;
pub use python_random::PythonRandom;
pub use virtualhome::pddl as vh_pddl;
pub use virtualhome::{
    Action as VhAction, IdScope, NodeIx as VhNodeIx, NodeState as VhNodeState, Property as VhProperty, PropertySet as VhPropertySet,
    Relation as VhRelation, RelationSet as VhRelationSet, SceneGraph, SceneNode, ScriptLine, StateSet as VhStateSet, VhGoal,
    VirtualhomeEnv, VirtualhomeError, VirtualhomeTask, World as VhWorld, bind as vh_bind, class_level_goal as vh_class_level_goal,
    shown_ids as vh_shown_ids, visible_nodes as vh_visible_nodes,
};
