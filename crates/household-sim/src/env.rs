//! The agent-side interface every household environment implements, and the judge-side
//! interface that evaluation alone uses.

use std::fmt;

/// A picture of what the agent sees, as encoded bytes (PNG or JPEG).
#[derive(Clone, PartialEq, Eq)]
pub struct Image {
    /// `image/png` or `image/jpeg`.
    pub mime: &'static str,
    /// The encoded file, as `mime` says.
    pub bytes: Vec<u8>,
}

impl fmt::Debug for Image {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Image({}, {} bytes)", self.mime, self.bytes.len())
    }
}

/// What the agent perceives after a reset or a step: the environment's text and, where the
/// environment renders one, a picture.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Observation {
    /// What the environment says, as its engine writes it.
    pub text: String,
    /// The rendered view, where the environment renders one; the environments of this crate render none.
    pub image: Option<Image>,
}

impl Observation {
    /// An observation with `text` and no image.
    pub fn text(text: impl Into<String>) -> Observation {
        Observation { text: text.into(), image: None }
    }
}

/// Whether the environment carried the command out. Either way the observation holds the
/// engine's own answer ("Nothing happens." in ALFWorld).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// The command named an action the engine could execute, and it did.
    Executed,
    /// The command was not executed; the state is unchanged. `reason` is the engine's answer.
    NotExecuted {
        /// The engine's answer ("Nothing happens." in ALFWorld; the executor's or the adapter's
        /// message in VirtualHome).
        reason: String,
    },
}

impl Event {
    /// Whether this is [`Event::Executed`].
    pub fn executed(&self) -> bool {
        matches!(self, Event::Executed)
    }
}

/// The result of one [`Environment::step`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StepResult {
    /// What the agent perceives after the command.
    pub observation: Observation,
    /// Whether the command was carried out.
    pub event: Event,
}

/// The task as the benchmark states it to the agent: a sentence, and the goal in the
/// benchmark's own notation (ALFWorld: the game's PDDL goal formula; VirtualHome: EAI's node,
/// edge and action goals). Class level in the benchmarks that are; a later goal parser turns
/// it into the planner's goal.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GoalAnnotation {
    /// The benchmark (`alfworld`, `virtualhome-eai`, ...).
    pub benchmark: String,
    /// The task sentence the agent is shown ("put a clean mug in coffeemachine.").
    pub sentence: String,
    /// The goal formula in the benchmark's notation.
    pub formula: String,
    /// The task family (ALFWorld's task type, an EAI category, a rearrangement family).
    pub family: String,
}

/// A partially observable household: the only view of the world an agent gets.
///
/// The true state stays inside; the agent sees observations and events, and whether the engine
/// has ended the episode ([`Environment::done`]), as the benchmark's engine tells its agents.
/// The goal check is the environment's own (the benchmark's engine decides success): an
/// episode is judged by it, and a harness the paper lets end on success (its direct policies)
/// may ask it; what is missing is the [`Judge`]'s.
pub trait Environment {
    /// Starts the episode over from the task's initial state; the first observation.
    fn reset(&mut self) -> Observation;
    /// Sends one command. A command the engine cannot execute changes nothing and returns
    /// [`Event::NotExecuted`] with the engine's answer; it still counts as a step.
    fn step(&mut self, command: &str) -> StepResult;
    /// Whether the task's goal holds now (the benchmark's own success check).
    fn goal_reached(&self) -> bool;
    /// Whether the engine has ended the episode, as it tells its agents: TextWorld ends an
    /// ALFWorld game once it is won (its `done`); EAI's VirtualHome executor runs every line
    /// of a script and ends none (it judges the final state). An agent's loop stops here. A
    /// command sent after it is not the benchmark's: an ended ALFWorld game answers it, as
    /// TextWorld does, with its last observation, and counts no step.
    fn done(&self) -> bool;
    /// Steps sent since the last reset.
    fn steps_taken(&self) -> usize;
    /// The task as the benchmark states it.
    fn goal(&self) -> &GoalAnnotation;
}

/// One true atom of the hidden state, with arguments spelled as the agent could perceive
/// them (ALFWorld display names such as `mug 1`; VirtualHome `class (id)`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JudgeAtom {
    /// The predicate: a PDDL predicate in ALFWorld; a node state, an edge relation or
    /// `IN_ROOM` in VirtualHome.
    pub predicate: String,
    /// The arguments in the predicate's order (ALFWorld `mug 1`, or the object's id where the game
    /// gives it no display name; VirtualHome `plate (1001)`).
    pub args: Vec<String>,
}

impl fmt::Display for JudgeAtom {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}", self.predicate)?;
        for arg in &self.args {
            write!(f, " {arg}")?;
        }
        write!(f, ")")
    }
}

/// One command of an episode as the benchmark's own engine takes it ([`Judge::engine_script`]).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct EngineLine {
    /// The command in the engine's language: ALFWorld's text command, VirtualHome's
    /// instance-level script line (`[GRAB] <plate> (1001)`).
    pub line: String,
    /// Whether this environment executed it (the engine must agree).
    pub executed: bool,
}

/// The hidden state, for evaluation only (failure attribution, precision and recall of
/// what an agent believed). Agents are handed `&mut dyn Environment`, never this.
pub trait Judge {
    /// Every true atom of the hidden state.
    fn hidden_atoms(&self) -> Vec<JudgeAtom>;
    /// The goal's parts that do not hold now, in words; empty when the goal holds.
    fn unmet_goals(&self) -> Vec<String>;
    /// The episode since the last reset as the benchmark's own engine would be given it, so
    /// that a record replays there (`tools/replay_records.py`): ALFWorld every command sent
    /// (TextWorld answers one it cannot execute itself, "Nothing happens."); VirtualHome the
    /// script line of every command that named an action and objects it could ground (EAI's
    /// adapter turns a class-level command into an instance-level line; a command with no
    /// line never reaches the executor), executed or refused by its preconditions, with EAI's
    /// node ids where the agent was shown the environment's own. Evaluation
    /// only: a grounded line names the instance the environment picked, which the agent may
    /// not have perceived.
    fn engine_script(&self) -> Vec<EngineLine>;
    /// The commands the engine lists as admissible now, where it computes such a list
    /// (ALFWorld's TextWorld does); `None` where it does not. For tools and tests: the paper
    /// shows its agents no such list, so it is not on [`Environment`].
    fn admissible_commands(&self) -> Option<Vec<String>>;
}
