//! Household environments that hide the true state and judge success as the benchmarks' own
//! engines do.
//!
//! An agent sees an [`Environment`]: it resets, sends command text, reads
//! [`Observation`]s and [`Event`]s, and may ask whether the goal holds. The hidden state is
//! reachable only through the [`Judge`] trait, which evaluation uses after an episode (failure
//! attribution, precision and recall of beliefs) and which no agent is handed.

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
    Action as VhAction, NodeIx as VhNodeIx, NodeState as VhNodeState, Property as VhProperty, Relation as VhRelation, SceneGraph,
    SceneNode, ScriptLine, VhGoal, VirtualhomeEnv, VirtualhomeError, VirtualhomeTask, World as VhWorld, bind as vh_bind,
    class_level_goal as vh_class_level_goal, visible_nodes as vh_visible_nodes,
};
