//! VirtualHome as the Embodied Agent Interface (EAI) runs it: a task's scene graph, executed
//! as the evolving graph executes script lines, seen as VirtualHome's `get_visible_nodes`
//! shows it, and judged on every node, edge and action goal.
//!
//! Commands are either instance-level script lines (`[WALK] <plate> (1001)`: by default only
//! for nodes an observation has shown, every node for replay and parity, see [`IdScope`]) or
//! class-level verbs (`grab plate`, `putin plate dishwasher`) that the adapter binds to
//! instances by [`bind`]'s rule. An agent is shown ids of the environment's own, not EAI's
//! ([`VirtualhomeEnv`], **Ids**).

mod exec;
mod graph;
pub mod pddl;

use std::fmt::Write as _;
use std::io::Read as _;
use std::path::Path;

use serde::Deserialize;

use crate::env::{EngineLine, Environment, Event, GoalAnnotation, Judge, JudgeAtom, Observation, StepResult};

pub use exec::{Action, ScriptLine, World};
pub use graph::{NodeIx, NodeState, Property, PropertySet, Relation, RelationSet, SceneGraph, SceneNode, StateSet};

/// What can go wrong loading a VirtualHome task.
#[derive(Debug, thiserror::Error)]
pub enum VirtualhomeError {
    /// The task file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The task file.
        path: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is not a task file: bad gzip data, not UTF-8, not JSON, or JSON without the
    /// task file's fields.
    #[error("{origin}: not valid task JSON: {message}")]
    Json {
        /// The task file (or the `origin` given to [`VirtualhomeTask::from_json`]).
        origin: String,
        /// What is wrong, with `serde_json`'s line and column where it gives them.
        message: String,
    },
    /// The task file parses but its content is wrong: an unknown state, property or relation,
    /// an edge or goal naming a node the scene lacks, no `character` node, or a `task_id` that
    /// is not the file's name.
    #[error("{origin}: field `{field}`: {message}")]
    BadGraph {
        /// The task file (or the `origin` given to [`VirtualhomeTask::from_json`]).
        origin: String,
        /// Where in the JSON: `nodes[3].states[0]`, `edges[7].to_id`, `vh_goal.goal[1].id`, `task_id`, ...
        field: String,
        /// What is wrong there.
        message: String,
    },
}

/// A goal of EAI's `vh_goal`: a node state, an edge, or a group of alternative actions
/// (`"WATCH|LOOKAT"`) that must appear, in order, among the executed lines.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VhGoal {
    /// The node must have the state.
    State {
        /// The node's VirtualHome id.
        node: u32,
        /// The class the goal names, as written (empty when the goal gives none); not checked against the node.
        class_name: String,
        /// The state that must hold.
        state: NodeState,
    },
    /// The edge must be in the graph.
    Edge {
        /// The source node's VirtualHome id.
        from: u32,
        /// The edge label.
        relation: Relation,
        /// The target node's VirtualHome id.
        to: u32,
    },
    /// One of the actions must have been executed after the previous action goal's match.
    Action {
        /// The alternatives as EAI writes them, separated by `|` (`"WATCH|LOOKAT"`); matched
        /// upper-cased with spaces removed.
        options: String,
    },
}

/// One EAI VirtualHome task: its initial scene graph and its goal.
#[derive(Debug, Clone)]
pub struct VirtualhomeTask {
    /// EAI's task id; [`VirtualhomeTask::load`] requires a file named `*.json.gz` or `*.json`
    /// to be named for it (`<task_id>.json.gz`, `<task_id>.json`).
    pub task_id: String,
    /// EAI's task category ("Wash dishes with dishwasher").
    pub task_name: String,
    /// The program's description line ("Wash a plate using the dishwasher in the kitchen.").
    pub description: String,
    /// The initial scene and its acting character; [`Environment::reset`] starts from a copy.
    pub init: World,
    /// The goals in `vh_goal`'s order (node and edge goals, then action goals), each once.
    pub goals: Vec<VhGoal>,
    /// `vh_goal` as EAI writes it (with node ids: for the judge and records, never for an
    /// agent; the goal annotation is [`class_level_goal`]).
    pub goal_json: String,
    /// Script lines that reach the goal, where the task file has them (`reference_program`:
    /// the rearrangement set's; EAI's task files carry none).
    pub reference_program: Vec<String>,
}

#[derive(Deserialize)]
struct TaskFile {
    task_id: String,
    task_name: String,
    #[serde(default)]
    description: String,
    vh_goal: serde_json::Value,
    init_graph: graph::JsonGraph,
    #[serde(default)]
    reference_program: Vec<String>,
}

impl VirtualhomeTask {
    /// Reads a task file (`fixtures/virtualhome-eai/graphs/<id>.json.gz`, or the same JSON
    /// uncompressed): `{task_id, task_name, description, vh_goal, init_graph}` and, optionally,
    /// `reference_program`.
    pub fn load(path: &Path) -> Result<VirtualhomeTask, VirtualhomeError> {
        let origin = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| VirtualhomeError::Io { path: origin.clone(), source })?;
        let gzipped = bytes.starts_with(&[0x1f, 0x8b]);
        let bytes = if gzipped {
            let mut text = Vec::new();
            flate2::read::GzDecoder::new(&bytes[..])
                .read_to_end(&mut text)
                .map_err(|e| VirtualhomeError::Json { origin: origin.clone(), message: format!("bad gzip data: {e}") })?;
            text
        } else {
            bytes
        };
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let before = std::str::from_utf8(&e.as_bytes()[..at]).unwrap_or_default();
            let (line, column) = pddl_syntax::line_column(before, at);
            VirtualhomeError::Json { origin: origin.clone(), message: format!("not UTF-8 text at line {line}, column {column}") }
        })?;
        let task = VirtualhomeTask::from_json(&text, &origin).map_err(|e| match e {
            // Read as JSON for want of gzip's signature: say both, for a `.gz` file.
            VirtualhomeError::Json { origin, message } if !gzipped && origin.ends_with(".gz") => {
                VirtualhomeError::Json { origin, message: format!("neither gzip data (no gzip signature) nor JSON: {message}") }
            }
            other => other,
        })?;
        // A task file is named by its task: another id inside is a file renamed or mixed up.
        if let Some(stem) = path.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(".json.gz").or(n.strip_suffix(".json")))
            && stem != task.task_id
        {
            return Err(VirtualhomeError::BadGraph {
                origin,
                field: "task_id".into(),
                message: format!("`{}`, but the file is named for task `{stem}`", task.task_id),
            });
        }
        Ok(task)
    }

    /// Parses a task file's JSON; `origin` names it in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<VirtualhomeTask, VirtualhomeError> {
        let file: TaskFile =
            serde_json::from_str(text).map_err(|e| VirtualhomeError::Json { origin: origin.to_string(), message: e.to_string() })?;
        let graph = SceneGraph::from_json(file.init_graph, origin)?;
        let bad =
            |field: &str, message: String| VirtualhomeError::BadGraph { origin: origin.to_string(), field: field.to_string(), message };
        let goals = parse_goals(&file.vh_goal, &graph).map_err(|(field, message)| bad(&field, message))?;
        let init = World::new(graph).ok_or_else(|| bad("init_graph.nodes", "no node of class `character`".to_string()))?;
        Ok(VirtualhomeTask {
            task_id: file.task_id,
            task_name: file.task_name,
            description: file.description,
            init,
            goals,
            goal_json: file.vh_goal.to_string(),
            reference_program: file.reference_program,
        })
    }
}

fn parse_goals(value: &serde_json::Value, graph: &SceneGraph) -> Result<Vec<VhGoal>, (String, String)> {
    let mut goals = Vec::new();
    let list = value.get("goal").and_then(|g| g.as_array()).ok_or(("vh_goal.goal".to_string(), "missing or not a list".to_string()))?;
    let id_of = |v: Option<&serde_json::Value>, field: String| -> Result<u32, (String, String)> {
        let id = v.and_then(|v| v.as_u64()).ok_or((field.clone(), "missing or not a node id".to_string()))?;
        let id = u32::try_from(id).map_err(|_| (field.clone(), format!("{id} is not a node id")))?;
        match graph.index_of(id) {
            Some(_) => Ok(id),
            None => Err((field, format!("no node with id {id} in the scene"))),
        }
    };
    for (i, g) in list.iter().enumerate() {
        let goal = if let Some(state) = g.get("state") {
            let field = format!("vh_goal.goal[{i}].state");
            let state = state.as_str().and_then(NodeState::parse).ok_or((field, format!("unknown state {state}")))?;
            let node = id_of(g.get("id"), format!("vh_goal.goal[{i}].id"))?;
            let class_name = g.get("class_name").and_then(|c| c.as_str()).unwrap_or_default().to_string();
            VhGoal::State { node, class_name, state }
        } else if let Some(relation) = g.get("relation_type") {
            let field = format!("vh_goal.goal[{i}].relation_type");
            let relation = relation.as_str().and_then(Relation::parse).ok_or((field, format!("unknown relation {relation}")))?;
            let from = id_of(g.get("from_id"), format!("vh_goal.goal[{i}].from_id"))?;
            let to = id_of(g.get("to_id"), format!("vh_goal.goal[{i}].to_id"))?;
            VhGoal::Edge { from, relation, to }
        } else {
            return Err((format!("vh_goal.goal[{i}]"), "neither a node goal (state) nor an edge goal (relation_type)".to_string()));
        };
        if !goals.contains(&goal) {
            goals.push(goal);
        }
    }
    if let Some(actions) = value.get("actions") {
        let actions = actions.as_array().ok_or(("vh_goal.actions".to_string(), "not a list".to_string()))?;
        for (i, a) in actions.iter().enumerate() {
            let options = a.as_str().ok_or((format!("vh_goal.actions[{i}]"), "not a string".to_string()))?.to_string();
            let goal = VhGoal::Action { options };
            if !goals.contains(&goal) {
                goals.push(goal);
            }
        }
    }
    Ok(goals)
}

/// The task's goal in EAI's `vh_goal` notation at class level, as the agent may be told it:
/// node goals `{"class_name": C, "state": S}`, edge goals `{"from": C1, "relation_type": R,
/// "to": C2}` (the acting character is `character`), then `"actions"`; no node id. Two goals
/// that differ only in their instances stay two entries (two plates on the table).
pub fn class_level_goal(task: &VirtualhomeTask) -> String {
    let g = &task.init.graph;
    let class = |id: u32| g.index_of(id).map_or("?", |ix| g.node(ix).class_name.as_str());
    let quote = |s: &str| serde_json::Value::String(s.to_string()).to_string();
    let mut goals = Vec::new();
    let mut actions = Vec::new();
    for goal in &task.goals {
        match goal {
            VhGoal::State { node, state, .. } => {
                goals.push(format!("{{\"class_name\": {}, \"state\": {}}}", quote(class(*node)), quote(state.as_str())));
            }
            VhGoal::Edge { from, relation, to } => goals.push(format!(
                "{{\"from\": {}, \"relation_type\": {}, \"to\": {}}}",
                quote(class(*from)),
                quote(relation.as_str()),
                quote(class(*to))
            )),
            VhGoal::Action { options } => actions.push(quote(options)),
        }
    }
    format!("{{\"goal\": [{}], \"actions\": [{}]}}", goals.join(", "), actions.join(", "))
}

/// The nodes the agent sees, by VirtualHome's `get_visible_nodes`: every node transitively
/// INSIDE the character's room that is not directly INSIDE a non-room node lacking the
/// state OPEN, every room, and what the character holds. Sorted by index. (Where a node is
/// INSIDE several nodes, EAI's rule reads one of them, depending on edge order; this reads
/// all of them, so a node inside any closed container is hidden.)
pub fn visible_nodes(world: &World) -> Vec<NodeIx> {
    visible_given(world, &world.graph.targets_of_all(Relation::Inside))
}

/// [`visible_nodes`], given every node's INSIDE targets (`targets_of_all(Inside)`).
fn visible_given(world: &World, inside: &[Vec<NodeIx>]) -> Vec<NodeIx> {
    let g = &world.graph;
    let mut contents: Vec<Vec<NodeIx>> = vec![Vec::new(); g.len()];
    for (ix, targets) in inside.iter().enumerate() {
        for &t in targets {
            contents[t as usize].push(ix as NodeIx);
        }
    }
    let mut seen = vec![false; g.len()];
    let hidden = |ix: NodeIx| inside[ix as usize].iter().any(|&p| !g.node(p).is_room() && !g.node(p).states.contains(NodeState::Open));
    for &room in &inside[world.character as usize] {
        let mut frontier = contents[room as usize].clone();
        while let Some(ix) = frontier.pop() {
            if seen[ix as usize] {
                continue;
            }
            seen[ix as usize] = true;
            frontier.extend_from_slice(&contents[ix as usize]);
        }
    }
    let mut out: Vec<NodeIx> = g.indices().filter(|&ix| seen[ix as usize] && !hidden(ix)).collect();
    out.extend(g.indices().filter(|&ix| g.node(ix).is_room()));
    out.extend(world.held());
    out.sort_unstable();
    out.dedup();
    out
}

/// Actions whose first object the character must hold: a class-level command binds it
/// to a held instance first.
const HELD_FIRST: &[Action] = &[
    Action::PutBack,
    Action::PutIn,
    Action::PutObjBack,
    Action::Pour,
    Action::Drop,
    Action::Release,
    Action::PutOn,
    Action::Read,
    Action::Drink,
];

/// The adapter's binding rule for a class-level command: among the visible instances of
/// `class_name`, one the character holds when the action needs a held object (first object
/// of put, pour, drop, read, drink), else one the character is close to, else the lowest id;
/// a grab never binds to an instance already held.
/// `None`: no instance of that class is visible from this pose.
pub fn bind(world: &World, action: Action, position: usize, class_name: &str) -> Option<NodeIx> {
    let visible = visible_nodes(world);
    let held = world.held();
    // Grabbing what is already in hand would fail: a grab binds to the other instances.
    let candidates: Vec<NodeIx> = visible
        .into_iter()
        .filter(|&ix| world.graph.node(ix).class_name == class_name && !(action == Action::Grab && held.contains(&ix)))
        .collect();
    let by_id = |ixs: &mut Vec<NodeIx>| ixs.sort_by_key(|&ix| world.graph.node(ix).id);
    let mut held_ones: Vec<NodeIx> = candidates.iter().copied().filter(|ix| held.contains(ix)).collect();
    by_id(&mut held_ones);
    if position == 0 && HELD_FIRST.contains(&action) && !held_ones.is_empty() {
        return held_ones.first().copied();
    }
    let mut close: Vec<NodeIx> = candidates.iter().copied().filter(|&ix| world.close_to(ix)).collect();
    by_id(&mut close);
    if let Some(&ix) = close.first() {
        return Some(ix);
    }
    let mut all = candidates;
    by_id(&mut all);
    all.first().copied()
}

/// Which node ids an instance-level script line (`[WALK] <fridge> (289)`) sent to
/// [`VirtualhomeEnv`] may name.
///
/// ```
/// use household_sim::{Environment, IdScope, Judge, VirtualhomeEnv, VirtualhomeTask};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai/graphs/201_1.json.gz");
/// // As an agent's environment: the character starts in the home office.
/// let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(&path)?, "virtualhome-eai");
/// env.reset();
/// // The agent's ids are not the scene's (the dining room is 201 in the scene).
/// let shown = |env: &VirtualhomeEnv, class: &str| env.visible_objects().into_iter().find(|(_, c)| c == class).map(|(id, _)| id);
/// let dining_room = shown(&env, "dining_room").expect("every room is listed");
/// assert_ne!(dining_room, 201);
/// assert_eq!(shown(&env, "dishwasher"), None, "not seen yet");
/// assert!(env.step(&format!("[WALK] <dining_room> ({dining_room})")).event.executed());
/// let dishwasher = shown(&env, "dishwasher").expect("in view now");
/// assert!(env.step(&format!("[WALK] <dishwasher> ({dishwasher})")).event.executed());
/// // What EAI's executor is given names the scene's ids.
/// assert_eq!(env.engine_script()[1].line, "[WALK] <dishwasher> (1000)");
/// // As EAI's executor, for a replay of the gold program.
/// let mut replay = VirtualhomeEnv::new(VirtualhomeTask::load(&path)?, "virtualhome-eai").with_id_scope(IdScope::Any);
/// replay.reset();
/// assert!(replay.step("[WALK] <dishwasher> (1000)").event.executed());
/// # Ok::<(), household_sim::VirtualhomeError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum IdScope {
    /// Only ids the environment has shown since the reset, each with the class it was shown
    /// with (an observation lists `fridge (17)`), never the character: what an agent may
    /// name. The ids are the environment's own, not the scene's ([`VirtualhomeEnv`], **Ids**).
    /// Until an observation (a reset's or a step's) has shown a node, it is not
    /// nameable. Any other line is refused, as not executed, before it is grounded, so it
    /// changes nothing and is not in [`Judge::engine_script`]. Class-level commands (`walk
    /// fridge`) bind to visible instances either way. The default.
    #[default]
    Perceived,
    /// Every node id of the scene, the scene's own ids, as EAI's executor takes them: for
    /// replays of recorded or gold programs and parity with the executor, never for an agent.
    Any,
}

/// The ids an agent's environment shows for a task of `count` nodes ([`VirtualhomeEnv`],
/// **Ids**): node index `ix` is shown as `ids[ix]`, a permutation of 1..=`count` drawn by a
/// Fisher-Yates shuffle from a generator seeded with the FNV-1a hash of `task_id`.
pub fn shown_ids(task_id: &str, count: usize) -> Vec<u32> {
    let seed = task_id.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
    let mut random = crate::python_random::PythonRandom::new(seed);
    let mut ids: Vec<u32> = (1..=count as u32).collect();
    for i in (1..ids.len()).rev() {
        ids.swap(i, random.choice_index(i + 1));
    }
    ids
}

/// A VirtualHome task as an [`Environment`] (and a [`Judge`]).
///
/// **Ids.** An agent's environment ([`IdScope::Perceived`]) names nodes by ids of its own, not
/// by the scene's: EAI's ids say how a task was built (the scene's nodes are below 1000, the
/// objects a task adds from 1000, its distractors from 2000), so `plate (1001)` beside
/// `plate (301)` would tell the agent which plate the goal is about, which no picture shows.
/// The shown ids are a permutation of 1..=n over the task's n nodes, drawn from the task id
/// ([`shown_ids`]): the same for every episode of a task, independent of the scene's ids. They
/// are in everything the environment says (observations, the executor's messages, the judge's
/// atoms and unmet goals) and in the lines an agent sends; [`Judge::engine_script`] writes the
/// scene's ids back, so a replay in EAI's executor runs the same lines. [`IdScope::Any`] (replay,
/// parity) uses the scene's ids throughout.
#[derive(Debug, Clone)]
pub struct VirtualhomeEnv {
    task: VirtualhomeTask,
    /// By node index: the scene's ids (EAI's) and the ids an agent is shown ([`VirtualhomeEnv`],
    /// **Ids**); the graphs and goals carry the scope's.
    scene_ids: Vec<u32>,
    agent_ids: Vec<u32>,
    world: World,
    /// Every grounded line since the reset (instance level) with whether it executed: the
    /// executed ones for the action goals, all for [`Judge::engine_script`].
    script: Vec<EngineLine>,
    steps: usize,
    annotation: GoalAnnotation,
    scope: IdScope,
    /// By node index (the graph's nodes are fixed at load): shown in an observation since the
    /// reset (none when made, before any observation); the character is never nameable, though
    /// an observation can mention it.
    perceived: Vec<bool>,
}

impl VirtualhomeEnv {
    /// The environment of `task`, announced as `benchmark`'s ([`GoalAnnotation::benchmark`]):
    /// `virtualhome-eai` or `virtualhome-rearrange`, the names the agent's goal parser and the
    /// direct policy's action list read (`exploration_harness::parse_goal` refuses a name
    /// that does not start with `virtualhome`). It shows the agent's ids (**Ids** above), and
    /// instance-level lines may name only what it has shown ([`IdScope::Perceived`]); replays
    /// widen that, with the scene's ids, by [`Self::with_id_scope`].
    pub fn new(task: VirtualhomeTask, benchmark: &str) -> VirtualhomeEnv {
        let annotation = GoalAnnotation {
            benchmark: benchmark.to_string(),
            sentence: if task.description.is_empty() { task.task_name.clone() } else { task.description.clone() },
            formula: class_level_goal(&task),
            family: task.task_name.clone(),
        };
        let world = task.init.clone();
        let perceived = vec![false; world.graph.len()];
        let scene_ids: Vec<u32> = world.graph.indices().map(|ix| world.graph.node(ix).id).collect();
        let agent_ids = shown_ids(&task.task_id, scene_ids.len());
        let mut env =
            VirtualhomeEnv { task, world, scene_ids, agent_ids, script: Vec::new(), steps: 0, annotation, scope: IdScope::Any, perceived };
        env.set_scope(IdScope::default());
        env
    }

    /// Puts the ids of `scope` on the graphs (the task's and the current one) and the goals.
    fn set_scope(&mut self, scope: IdScope) {
        let ids = match scope {
            IdScope::Perceived => self.agent_ids.clone(),
            IdScope::Any => self.scene_ids.clone(),
        };
        let g = &self.task.init.graph;
        // Goal ids were checked against the scene when the task was loaded.
        let to = |id: u32| g.index_of(id).map_or(id, |ix| ids[ix as usize]);
        let goals: Vec<VhGoal> = self
            .task
            .goals
            .iter()
            .map(|goal| match goal {
                VhGoal::State { node, class_name, state } => {
                    VhGoal::State { node: to(*node), class_name: class_name.clone(), state: *state }
                }
                VhGoal::Edge { from, relation, to: target } => VhGoal::Edge { from: to(*from), relation: *relation, to: to(*target) },
                VhGoal::Action { options } => VhGoal::Action { options: options.clone() },
            })
            .collect();
        self.task.goals = goals;
        self.task.init.graph.relabel(&ids);
        self.world.graph.relabel(&ids);
        self.scope = scope;
    }

    /// `line` as EAI's executor takes it: the scene's ids ([`VirtualhomeEnv`], **Ids**).
    fn engine_line(&self, line: &ScriptLine) -> String {
        let g = &self.world.graph;
        line.map_ids(|id| g.index_of(id).map(|ix| self.scene_ids[ix as usize])).to_string()
    }

    /// `line` (a script line naming the scene's ids, as EAI's programs do) with the ids an agent
    /// is shown ([`Self::shown_id`]), for tools that play a program in an agent's environment;
    /// a line that does not parse is returned as it is, for the environment to refuse.
    /// An id the scene lacks becomes 0, which no node is shown as.
    pub fn with_shown_ids(&self, line: &str) -> String {
        ScriptLine::parse(line).map_or_else(|_| line.to_string(), |parsed| parsed.map_ids(|id| self.shown_id(id).or(Some(0))).to_string())
    }

    /// This environment with `scope` for the ids of instance-level lines: [`IdScope::Any`]
    /// to replay a program that names nodes the environment has not shown (EAI's gold
    /// programs walk to objects in other rooms by id). The scope also sets which ids the
    /// environment names nodes by, in what it says and what it takes: the scene's under
    /// [`IdScope::Any`], the agent's under [`IdScope::Perceived`].
    #[must_use]
    pub fn with_id_scope(mut self, scope: IdScope) -> VirtualhomeEnv {
        self.set_scope(scope);
        self
    }

    /// Which ids instance-level lines may name.
    pub fn id_scope(&self) -> IdScope {
        self.scope
    }

    /// Marks `visible` (what an observation shows) as perceived, the character left out (see
    /// [`IdScope::Perceived`]).
    fn mark(&mut self, visible: &[NodeIx]) {
        for &ix in visible {
            if ix != self.world.character {
                self.perceived[ix as usize] = true;
            }
        }
    }

    /// The id an agent is shown for the scene's node `scene_id` ([`VirtualhomeEnv`], **Ids**),
    /// whatever this environment's scope; `None` when the scene has no such node. For tools and
    /// tests: an agent is handed `&mut dyn Environment`, never this.
    pub fn shown_id(&self, scene_id: u32) -> Option<u32> {
        self.scene_ids.iter().position(|&id| id == scene_id).map(|ix| self.agent_ids[ix])
    }

    /// What the agent sees now as `(id, class_name)`, by id (the nodes the observation
    /// lists, rooms included, the character left out).
    pub fn visible_objects(&self) -> Vec<(u32, String)> {
        let g = &self.world.graph;
        let mut out: Vec<(u32, String)> = visible_nodes(&self.world)
            .into_iter()
            .filter(|&ix| ix != self.world.character)
            .map(|ix| (g.node(ix).id, g.node(ix).class_name.clone()))
            .collect();
        out.sort();
        out
    }

    /// The instance-level lines executed since the reset, with the scene's ids (as
    /// [`Judge::engine_script`] writes them).
    pub fn executed_lines(&self) -> Vec<&str> {
        self.script.iter().filter(|l| l.executed).map(|l| l.line.as_str()).collect()
    }

    /// The observation text: the room, whether the character sits or lies (a line only when it
    /// does), what the character holds, and every visible node
    /// with its states and its ON/INSIDE relations to visible nodes, one per line, by id (the
    /// scope's: an agent's are the environment's own, **Ids** above):
    ///
    /// ```text
    /// You are in the kitchen (41).
    /// You are sitting.
    /// You hold: plate (7) in the right hand.
    /// Rooms: kitchen (41), bathroom (96).
    /// You see:
    /// - plate (7): on kitchencounter (23); close to you
    /// - dishwasher (12): CLOSED, OFF; close to you
    /// ```
    pub fn observe(&self) -> String {
        self.render().0
    }

    /// [`Self::observe`]'s text and the nodes it shows.
    fn render(&self) -> (String, Vec<NodeIx>) {
        let w = &self.world;
        let g = &w.graph;
        let name = |ix: NodeIx| format!("{} ({})", g.node(ix).class_name, g.node(ix).id);
        let mut out = String::new();
        let rooms: Vec<String> = g.targets(w.character, Relation::Inside).into_iter().filter(|&r| g.node(r).is_room()).map(name).collect();
        let _ = writeln!(out, "You are in the {}.", if rooms.is_empty() { "nowhere".to_string() } else { rooms.join(", ") });
        for (state, words) in [(NodeState::Sitting, "You are sitting."), (NodeState::Lying, "You are lying.")] {
            if g.node(w.character).states.contains(state) {
                let _ = writeln!(out, "{words}");
            }
        }
        let hand = |ix: NodeIx| if g.has_edge(w.character, Relation::HoldsLh, ix) { "left" } else { "right" };
        let held: Vec<String> = w.held().into_iter().map(|ix| format!("{} in the {} hand", name(ix), hand(ix))).collect();
        let _ = writeln!(out, "You hold: {}.", if held.is_empty() { "nothing".to_string() } else { held.join(", ") });
        let inside = g.targets_of_all(Relation::Inside);
        let on = g.targets_of_all(Relation::On);
        let mut visible = visible_given(w, &inside);
        visible.sort_by_key(|&ix| g.node(ix).id);
        let all_rooms: Vec<String> = visible.iter().copied().filter(|&ix| g.node(ix).is_room()).map(name).collect();
        let _ = writeln!(out, "Rooms: {}.", all_rooms.join(", "));
        let _ = writeln!(out, "You see:");
        let is_visible = |ix: NodeIx| visible.binary_search_by_key(&g.node(ix).id, |&v| g.node(v).id).is_ok();
        for &ix in &visible {
            if g.node(ix).is_room() || ix == w.character {
                continue;
            }
            let mut parts = Vec::new();
            let states: Vec<&str> = g.node(ix).states.iter().map(NodeState::as_str).collect();
            if !states.is_empty() {
                parts.push(states.join(", "));
            }
            for (targets, word) in [(&on, "on"), (&inside, "inside")] {
                let mut targets = targets[ix as usize].clone();
                targets.sort_by_key(|&t| g.node(t).id);
                for t in targets {
                    if !g.node(t).is_room() && is_visible(t) {
                        parts.push(format!("{word} {}", name(t)));
                    }
                }
            }
            if g.has_edge(w.character, Relation::Close, ix) {
                parts.push("close to you".to_string());
            }
            if parts.is_empty() {
                let _ = writeln!(out, "- {}", name(ix));
            } else {
                let _ = writeln!(out, "- {}: {}", name(ix), parts.join("; "));
            }
        }
        (out, visible)
    }

    /// The observation text, after marking what it shows as perceived.
    fn observe_and_perceive(&mut self) -> String {
        let (text, visible) = self.render();
        self.mark(&visible);
        text
    }

    /// Turns a command into a script line: instance-level lines as they are; class-level
    /// `verb class [class]` bound by [`bind`].
    fn resolve(&self, command: &str) -> Result<(ScriptLine, String), String> {
        let command = command.trim();
        if command.starts_with('[') {
            let line = ScriptLine::parse(command)?;
            if self.scope == IdScope::Perceived {
                let g = &self.world.graph;
                for (class_name, id) in &line.objects {
                    let ix = g.index_of(*id);
                    if ix == Some(self.world.character) {
                        return Err(format!("the character ({id}) is not an object to name"));
                    }
                    // The class as the line's names are read.
                    let shown =
                        ix.is_some_and(|ix| self.perceived[ix as usize] && ScriptLine::object_name(&g.node(ix).class_name) == *class_name);
                    if !shown {
                        return Err(format!("no {class_name} ({id}) has been seen"));
                    }
                }
            }
            return Ok((line, command.to_string()));
        }
        let mut words = command.split_whitespace();
        let Some(verb) = words.next() else { return Err("empty command".to_string()) };
        let action = Action::parse(verb).ok_or_else(|| format!("unknown action {verb:?}"))?;
        let classes: Vec<String> = words.map(|w| w.to_lowercase()).collect();
        if classes.len() != action.arity() {
            return Err(format!("\"{}\" takes {} object(s), got {}", action.name(), action.arity(), classes.len()));
        }
        let mut objects = Vec::new();
        for (position, class_name) in classes.iter().enumerate() {
            let ix = bind(&self.world, action, position, class_name)
                .ok_or_else(|| format!("{class_name} could not be grounded from this pose"))?;
            objects.push((class_name.clone(), self.world.graph.node(ix).id));
        }
        let line = ScriptLine { action, objects };
        let text = line.to_string();
        Ok((line, text))
    }

    fn goal_holds(&self, goal: &VhGoal) -> bool {
        let g = &self.world.graph;
        match goal {
            VhGoal::State { node, state, .. } => g.index_of(*node).is_some_and(|ix| g.node(ix).states.contains(*state)),
            VhGoal::Edge { from, relation, to } => match (g.index_of(*from), g.index_of(*to)) {
                (Some(a), Some(b)) => g.has_edge(a, *relation, b),
                _ => false,
            },
            VhGoal::Action { .. } => true,
        }
    }

    /// The action goals not met, as EAI's `check_order_with_or_score` finds them: each
    /// group's options (upper-cased, spaces removed) searched in order in the executed lines
    /// joined by spaces; the first group not found and every later one are unmet.
    fn unmet_action_goals(&self) -> Vec<String> {
        let joined = self.executed_lines().join(" ");
        let mut start = 0;
        let mut unmet = Vec::new();
        for goal in &self.task.goals {
            let VhGoal::Action { options } = goal else { continue };
            if !unmet.is_empty() {
                unmet.push(options.clone());
                continue;
            }
            let found = options.split('|').find_map(|option| {
                let option = option.to_uppercase().replace(' ', "");
                joined.get(start..).and_then(|rest| rest.find(&option)).map(|at| start + at + option.len())
            });
            match found {
                Some(end) => start = end,
                None => unmet.push(options.clone()),
            }
        }
        unmet
    }
}

impl Environment for VirtualhomeEnv {
    fn reset(&mut self) -> Observation {
        self.world = self.task.init.clone();
        self.script.clear();
        self.steps = 0;
        self.perceived.fill(false);
        Observation::text(self.observe_and_perceive())
    }

    fn step(&mut self, command: &str) -> StepResult {
        self.steps += 1;
        let outcome = self.resolve(command).and_then(|(line, text)| {
            let engine = self.engine_line(&line);
            let executed = self.world.execute(&line);
            self.script.push(EngineLine { line: engine, executed: executed.is_ok() });
            executed.map(|()| text)
        });
        let now = self.observe_and_perceive();
        match outcome {
            Ok(text) => {
                let observation = Observation::text(format!("Executed {text}.\n{now}"));
                StepResult { observation, event: Event::Executed }
            }
            Err(reason) => {
                let observation = Observation::text(format!("Not executed: {reason}.\n{now}"));
                StepResult { observation, event: Event::NotExecuted { reason } }
            }
        }
    }

    fn goal_reached(&self) -> bool {
        // `unmet_goals` is empty, without spelling out what is unmet (an episode asks every step).
        self.task.goals.iter().all(|g| self.goal_holds(g)) && self.unmet_action_goals().is_empty()
    }

    /// EAI's executor runs every line of a script and judges the state at its end: no line
    /// ends the episode, not even one after which the goal holds.
    fn done(&self) -> bool {
        false
    }

    fn steps_taken(&self) -> usize {
        self.steps
    }

    fn goal(&self) -> &GoalAnnotation {
        &self.annotation
    }
}

impl Judge for VirtualhomeEnv {
    fn admissible_commands(&self) -> Option<Vec<String>> {
        None
    }

    fn hidden_atoms(&self) -> Vec<JudgeAtom> {
        let g = &self.world.graph;
        let name = |ix: NodeIx| format!("{} ({})", g.node(ix).class_name, g.node(ix).id);
        let mut atoms = Vec::new();
        for ix in g.indices() {
            for state in g.node(ix).states.iter() {
                atoms.push(JudgeAtom { predicate: state.as_str().to_string(), args: vec![name(ix)] });
            }
        }
        for (from, relation, to) in g.all_edges() {
            atoms.push(JudgeAtom { predicate: relation.as_str().to_string(), args: vec![name(from), name(to)] });
        }
        // The rooms each node is in: reached through INSIDE edges (as `get_visible_nodes` reads
        // them), which a direct INSIDE edge to the room does not always say.
        let inside = g.targets_of_all(Relation::Inside);
        for ix in g.indices().filter(|&ix| !g.node(ix).is_room() && ix != self.world.character) {
            let mut seen = vec![ix];
            let mut frontier = vec![ix];
            while let Some(n) = frontier.pop() {
                for &t in &inside[n as usize] {
                    if !seen.contains(&t) {
                        seen.push(t);
                        if g.node(t).is_room() {
                            atoms.push(JudgeAtom { predicate: "IN_ROOM".to_string(), args: vec![name(ix), name(t)] });
                        } else {
                            frontier.push(t);
                        }
                    }
                }
            }
        }
        atoms.sort();
        atoms
    }

    fn unmet_goals(&self) -> Vec<String> {
        let g = &self.world.graph;
        let name = |id: u32| g.index_of(id).map_or_else(|| format!("? ({id})"), |ix| format!("{} ({})", g.node(ix).class_name, id));
        let mut unmet = Vec::new();
        for goal in &self.task.goals {
            if self.goal_holds(goal) {
                continue;
            }
            match goal {
                VhGoal::State { node, state, .. } => unmet.push(format!("{} is {}", name(*node), state)),
                VhGoal::Edge { from, relation, to } => unmet.push(format!("{} {} {}", name(*from), relation, name(*to))),
                VhGoal::Action { .. } => {}
            }
        }
        unmet.extend(self.unmet_action_goals().into_iter().map(|a| format!("action {a} not done")));
        unmet
    }
    fn engine_script(&self) -> Vec<EngineLine> {
        self.script.clone()
    }
}
