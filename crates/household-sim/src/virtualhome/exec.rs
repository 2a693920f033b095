//! The evolving graph's actions: each VirtualHome script action's preconditions and effects,
//! as `virtualhome_eval/simulation/evolving_graph/execution.py` (eai-eval 1.0.5) defines them,
//! applied to a [`SceneGraph`] in place.
//!
//! The executor runs with instance selection on, so a line's object is the node with the
//! line's id whatever class name the line spells. A failing precondition changes nothing.
//! Where the executor reads the first element of a Python set (the node a grabbed object
//! rested on when it rests on several; a node inside several containers), this picks the
//! lowest node id: the executor's choice there depends on set iteration order.

use rustc_hash::FxHashMap;

use super::graph::{NodeIx, NodeState, Property, Relation, SceneGraph};

/// The actions of EAI's executor (`scripts.Action`), with the number of objects each takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Action {
    /// `[CLOSE] <obj>`: an OPEN node that can be opened becomes CLOSED; the character must be close to it.
    Close,
    /// `[DRINK] <obj>`: changes nothing; the character must hold the node, which must be drinkable or a recipient.
    Drink,
    /// `[FIND] <obj>`: as `WALK`, except for a node already close, a body part, or a node ON the character: then
    /// the character must be close to it (or it fails), and its FACING edges are dropped.
    Find,
    /// `[WALK] <obj>`: the character moves into the node's room and, unless the node is that room, close to the node
    /// and its non-room containers; also close to what the node rests ON and, if it can be opened, what is inside it.
    /// What the character holds stays close to it, with an INSIDE edge to the room the character walked from (as
    /// the evolving graph leaves it). Fails while sitting or lying.
    Walk,
    /// `[GRAB] <obj>`: a close, grabbable node not inside a closed one goes into a free hand (right first); what it
    /// rested on is remembered for `PUTOBJBACK`.
    Grab,
    /// `[LOOKAT] <obj>`, also spelled `LOOKAT_MEDIUM`: changes nothing; the character must face the node, or face a node
    /// that faces it.
    LookAt,
    /// `[LOOKAT_SHORT] <obj>`: as `LOOKAT`.
    LookAtShort,
    /// `[LOOKAT_LONG] <obj>`: as `LOOKAT`.
    LookAtLong,
    /// `[OPEN] <obj>`: a CLOSED node that can be opened and is not ON becomes OPEN; the character must be close to it
    /// with a free hand.
    Open,
    /// `[POINTAT] <obj>`: changes nothing; the character must face the node, or face a node
    /// that faces it.
    PointAt,
    /// `[PUTBACK] <obj> <surface>`: the held first node leaves the hand and is ON the second, which must be close.
    PutBack,
    /// `[PUTIN] <obj> <container>`: the held first node leaves the hand and is INSIDE the second, which must be close
    /// and, if it can be opened, OPEN.
    PutIn,
    /// `[PUTOBJBACK] <obj>`: the held node goes back, with the same relation, to where `GRAB` took it from.
    PutObjBack,
    /// `[RUN] <obj>`: as `WALK`.
    Run,
    /// `[SIT] <obj>`: the character, not yet sitting, sits ON a close, sittable node with a seat free
    /// ([`World::has_seat`]) and faces what the node faces.
    Sit,
    /// `[STANDUP]`: the character stops sitting or lying; fails when it does neither.
    StandUp,
    /// `[SWITCHOFF] <obj>`: an ON node with a switch becomes OFF; the character must be close to it.
    SwitchOff,
    /// `[SWITCHON] <obj>`: an OFF node with a switch that is not PLUGGED_OUT becomes ON; the character must be close to it.
    SwitchOn,
    /// `[TOUCH] <obj>`: changes nothing; the node must be close and not inside a closed node.
    Touch,
    /// `[TURNTO] <obj>`: the character faces the node and nothing else; no precondition.
    TurnTo,
    /// `[WATCH] <obj>`: changes nothing; the node must be lookable, in the character's room, faced by the character
    /// (directly, while sitting or lying, unless it is a `computer`) and not inside a closed node.
    Watch,
    /// `[WIPE] <obj>`: a close node becomes CLEAN (no longer DIRTY); the character must hold something.
    Wipe,
    /// `[PUTON] <obj>`: the character puts on held clothes: they leave the hand and are ON the character.
    PutOn,
    /// `[PUTOFF] <obj>`: clothes ON the character lose that edge.
    PutOff,
    /// `[GREET] <obj>`: changes nothing; the node must be a person.
    Greet,
    /// `[DROP] <obj>`: the held node leaves the hand and is INSIDE the character's room.
    Drop,
    /// `[READ] <obj>`: changes nothing; the character must hold the node, which must be readable.
    Read,
    /// `[LIE] <obj>`: the character, not yet lying, lies ON a close, lieable node with room free ([`World::has_seat`]).
    Lie,
    /// `[POUR] <obj> <recipient>`: the held pourable or drinkable first node is INSIDE the close recipient; held `water`
    /// also leaves the hand.
    Pour,
    /// `[TYPE] <obj>`: changes nothing; the node must be close and a `keyboard` or have a switch.
    Type,
    /// `[PUSH] <obj>`: changes nothing; the node must be close, not inside a closed node, and movable as EAI's
    /// `check_movable` reads it ([`Property::Movable`]), and the character must have a free hand.
    Push,
    /// `[PULL] <obj>`: as `PUSH`.
    Pull,
    /// `[MOVE] <obj>`: as `PUSH`.
    Move,
    /// `[WASH] <obj>`: a close node becomes CLEAN (no longer DIRTY).
    Wash,
    /// `[RINSE] <obj>`: as `WASH`.
    Rinse,
    /// `[SCRUB] <obj>`: as `WASH`.
    Scrub,
    /// `[SQUEEZE] <obj>`: changes nothing; the node must be close and clothes or of a squeezable class (`soap`,
    /// `sponge`, `towel`, ...), and the character must have a free hand.
    Squeeze,
    /// `[PLUGIN] <obj>`: a PLUGGED_OUT node with a plug becomes PLUGGED_IN; the character must be close with a free hand.
    PlugIn,
    /// `[PLUGOUT] <obj>`: a PLUGGED_IN node with a plug becomes PLUGGED_OUT; the character must be close with a free hand.
    PlugOut,
    /// `[CUT] <obj>`: changes nothing; the node must be close, eatable and cuttable, and the character must hold a
    /// knife (a class whose name contains `knife`) and have a free hand.
    Cut,
    /// `[EAT] <obj>`: changes nothing; the node must be close and eatable, or have something eatable ON it.
    Eat,
    /// `[SLEEP]`: changes nothing; the character must sit or lie.
    Sleep,
    /// `[WAKEUP]`: as `SLEEP`.
    WakeUp,
    /// `[RELEASE] <obj>`: as `DROP`.
    Release,
}

const ACTIONS: &[(Action, &str, usize)] = &[
    (Action::Close, "CLOSE", 1),
    (Action::Drink, "DRINK", 1),
    (Action::Find, "FIND", 1),
    (Action::Walk, "WALK", 1),
    (Action::Grab, "GRAB", 1),
    (Action::LookAt, "LOOKAT", 1),
    (Action::LookAtShort, "LOOKAT_SHORT", 1),
    (Action::LookAt, "LOOKAT_MEDIUM", 1),
    (Action::LookAtLong, "LOOKAT_LONG", 1),
    (Action::Open, "OPEN", 1),
    (Action::PointAt, "POINTAT", 1),
    (Action::PutBack, "PUTBACK", 2),
    (Action::PutIn, "PUTIN", 2),
    (Action::PutObjBack, "PUTOBJBACK", 1),
    (Action::Run, "RUN", 1),
    (Action::Sit, "SIT", 1),
    (Action::StandUp, "STANDUP", 0),
    (Action::SwitchOff, "SWITCHOFF", 1),
    (Action::SwitchOn, "SWITCHON", 1),
    (Action::Touch, "TOUCH", 1),
    (Action::TurnTo, "TURNTO", 1),
    (Action::Watch, "WATCH", 1),
    (Action::Wipe, "WIPE", 1),
    (Action::PutOn, "PUTON", 1),
    (Action::PutOff, "PUTOFF", 1),
    (Action::Greet, "GREET", 1),
    (Action::Drop, "DROP", 1),
    (Action::Read, "READ", 1),
    (Action::Lie, "LIE", 1),
    (Action::Pour, "POUR", 2),
    (Action::Type, "TYPE", 1),
    (Action::Push, "PUSH", 1),
    (Action::Pull, "PULL", 1),
    (Action::Move, "MOVE", 1),
    (Action::Wash, "WASH", 1),
    (Action::Rinse, "RINSE", 1),
    (Action::Scrub, "SCRUB", 1),
    (Action::Squeeze, "SQUEEZE", 1),
    (Action::PlugIn, "PLUGIN", 1),
    (Action::PlugOut, "PLUGOUT", 1),
    (Action::Cut, "CUT", 1),
    (Action::Eat, "EAT", 1),
    (Action::Sleep, "SLEEP", 0),
    (Action::WakeUp, "WAKEUP", 0),
    (Action::Release, "RELEASE", 1),
];

impl Action {
    /// The action named `name` (`WALK`, `putin`), as `Action[name.upper()]`.
    pub fn parse(name: &str) -> Option<Action> {
        let upper = name.to_ascii_uppercase();
        ACTIONS.iter().find(|(_, text, _)| *text == upper).map(|(a, _, _)| *a)
    }

    /// The executor's name (`PUTIN`).
    pub fn name(self) -> &'static str {
        ACTIONS.iter().find(|(a, _, _)| *a == self).map(|(_, text, _)| *text).unwrap_or("UNKNOWN")
    }

    /// How many objects the action takes.
    pub fn arity(self) -> usize {
        ACTIONS.iter().find(|(a, _, _)| *a == self).map(|(_, _, n)| *n).unwrap_or(1)
    }

    /// Every action name the executor knows, in its declaration order.
    pub fn all_names() -> impl Iterator<Item = &'static str> {
        ACTIONS.iter().map(|(_, text, _)| *text)
    }
}

/// One parsed script line: `[PUTIN] <plate> (1001) <dishwasher> (1000)`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScriptLine {
    /// The action; `objects` must hold exactly its [`Action::arity`] entries.
    pub action: Action,
    /// `(name, id)` per object, the name lower-cased with spaces as `_` (as the executor).
    pub objects: Vec<(String, u32)>,
}

/// `[ACTION] <name> (id) ...`, as EAI's executor reads a line.
impl std::fmt::Display for ScriptLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{}]", self.action.name())?;
        for (name, id) in &self.objects {
            write!(f, " <{name}> ({id})")?;
        }
        Ok(())
    }
}

impl ScriptLine {
    /// An object's name as a script line reads it: lower-cased, spaces as `_` (as the executor).
    pub(crate) fn object_name(name: &str) -> String {
        name.to_lowercase().replace(' ', "_")
    }

    /// Parses a script line as `scripts.parse_script_line` does: `[ACTION]` then
    /// `<name> (id)` pairs; the number of pairs must be the action's arity.
    pub fn parse(line: &str) -> Result<ScriptLine, String> {
        let line = line.trim();
        let rest = line.strip_prefix('[').ok_or_else(|| "Cannot parse action".to_string())?;
        let end = rest.find(']').ok_or_else(|| "Cannot parse action".to_string())?;
        let name = &rest[..end];
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err("Cannot parse action".to_string());
        }
        let action = Action::parse(name).ok_or_else(|| format!("Unknown action \"{}\"", name.to_ascii_uppercase()))?;
        let mut objects = Vec::new();
        let mut rest = &rest[end + 1..];
        while let Some(open) = rest.find('<') {
            let after = &rest[open + 1..];
            let Some(close) = after.find('>') else { break };
            let object = &after[..close];
            let tail = after[close + 1..].trim_start();
            let Some(paren) = tail.strip_prefix('(') else {
                rest = &after[close + 1..];
                continue;
            };
            let Some(end_paren) = paren.find(')') else { break };
            let id_text = paren[..end_paren].trim();
            let id: u32 = id_text.parse().map_err(|_| format!("invalid object id {id_text:?} for <{object}>"))?;
            objects.push((ScriptLine::object_name(object), id));
            rest = &paren[end_paren + 1..];
        }
        let line = ScriptLine { action, objects };
        line.check_arity()?;
        Ok(line)
    }

    /// This line with each id replaced by `map(id)` (an id `map` does not know stays).
    pub fn map_ids(&self, map: impl Fn(u32) -> Option<u32>) -> ScriptLine {
        let objects = self.objects.iter().map(|(name, id)| (name.clone(), map(*id).unwrap_or(*id))).collect();
        ScriptLine { action: self.action, objects }
    }

    /// The executor's message when the number of objects is not the action's arity.
    fn check_arity(&self) -> Result<(), String> {
        let (got, expected) = (self.objects.len(), self.action.arity());
        if got == expected {
            return Ok(());
        }
        Err(format!("Wrong number of parameters for \"{}\". Got {got}, expected {expected}", self.action.name()))
    }
}

/// The hidden world: the scene graph, the acting character, and what the executor
/// remembers about grabbed objects (`executor_data[(GRAB, id)]`: where it rested).
#[derive(Debug, Clone)]
pub struct World {
    /// The scene, changed in place by [`World::execute`].
    pub graph: SceneGraph,
    /// The acting character's node.
    pub character: NodeIx,
    /// Per node grabbed from a node other than a room: the node it rested on and the relation (ON,
    /// INSIDE or CLOSE), which `PUTOBJBACK` restores. A node in here cannot be grabbed again; `PUTON`
    /// and pouring water take a node out of the hand without removing its entry.
    pub grabbed_from: FxHashMap<NodeIx, (NodeIx, Relation)>,
}

/// Why a line did not execute: the executor's own message.
pub type Failure = String;

const SIT_MAX: &[(&str, usize)] =
    &[("couch", 4), ("bed", 4), ("chair", 1), ("loveseat", 2), ("sofa", 4), ("toilet", 1), ("pianobench", 2), ("bench", 2)];
const LIE_MAX: &[(&str, usize)] = &[("couch", 2), ("bathtub", 2), ("bed", 3), ("loveseat", 2), ("sofa", 2), ("bench", 1)];
const SQUEEZABLE: &[&str] = &[
    "cleaning_solution",
    "tooth_paste",
    "shampoo",
    "food_peanut_butter",
    "dish_soap",
    "soap",
    "towel",
    "rag",
    "paper",
    "sponge",
    "food_lemon",
    "check",
];

impl World {
    /// The acting character: the `character` node with the lowest id (`char_index` 0).
    pub fn new(graph: SceneGraph) -> Option<World> {
        let character = graph.indices().filter(|&ix| graph.node(ix).class_name == "character").min_by_key(|&ix| graph.node(ix).id)?;
        Some(World { graph, character, grabbed_from: FxHashMap::default() })
    }

    fn label(&self, ix: NodeIx) -> String {
        self.graph.label(ix)
    }

    fn has_property(&self, ix: NodeIx, p: Property) -> bool {
        self.graph.node(ix).properties.contains(p)
    }

    fn has_state(&self, ix: NodeIx, s: NodeState) -> bool {
        self.graph.node(ix).states.contains(s)
    }

    /// `_get_room_node`: the node itself if a room; else the room among its INSIDE targets
    /// when there are several, or the first room up the chain of single INSIDE edges.
    pub fn room_of(&self, ix: NodeIx) -> Option<NodeIx> {
        let g = &self.graph;
        if g.node(ix).is_room() {
            return Some(ix);
        }
        let mut inside = g.targets(ix, Relation::Inside);
        if inside.len() > 1 {
            return inside.into_iter().find(|&n| g.node(n).is_room());
        }
        for _ in 0..g.len() {
            let &first = inside.first()?;
            if g.node(first).is_room() {
                return Some(first);
            }
            inside = g.targets(first, Relation::Inside);
        }
        None
    }

    /// `_is_character_close_to`: CLOSE to it, or CLOSE to something that is CLOSE to it or
    /// that it is ON.
    pub fn close_to(&self, ix: NodeIx) -> bool {
        let g = &self.graph;
        let c = self.character;
        g.has_edge(c, Relation::Close, ix)
            || g.targets(c, Relation::Close).into_iter().any(|n| g.has_edge(n, Relation::Close, ix) || g.has_edge(ix, Relation::On, n))
    }

    /// `_is_character_face_to`.
    fn face_to(&self, ix: NodeIx) -> bool {
        let g = &self.graph;
        let c = self.character;
        g.has_edge(c, Relation::Facing, ix) || g.targets(c, Relation::Facing).into_iter().any(|n| g.has_edge(n, Relation::Facing, ix))
    }

    /// `_is_inside`: INSIDE a closed node that is not a room.
    pub fn inside_closed(&self, ix: NodeIx) -> bool {
        self.graph.targets(ix, Relation::Inside).into_iter().any(|n| self.has_state(n, NodeState::Closed) && !self.graph.node(n).is_room())
    }

    fn free_hand(&self) -> Option<Relation> {
        let c = self.character;
        if self.graph.targets(c, Relation::HoldsRh).is_empty() {
            Some(Relation::HoldsRh)
        } else if self.graph.targets(c, Relation::HoldsLh).is_empty() {
            Some(Relation::HoldsLh)
        } else {
            None
        }
    }

    fn holds(&self, ix: NodeIx) -> bool {
        let c = self.character;
        self.graph.has_edge(c, Relation::HoldsRh, ix) || self.graph.has_edge(c, Relation::HoldsLh, ix)
    }

    /// What the character holds, left hand first (`_find_nodes_from([HOLDS_LH, HOLDS_RH])`).
    pub fn held(&self) -> Vec<NodeIx> {
        let mut out = self.graph.targets(self.character, Relation::HoldsLh);
        out.extend(self.graph.targets(self.character, Relation::HoldsRh));
        out
    }

    fn add_close(&mut self, a: NodeIx, b: NodeIx) {
        self.graph.add_edge(a, Relation::Close, b);
        self.graph.add_edge(b, Relation::Close, a);
    }

    fn set_states(&mut self, ix: NodeIx, remove: &[NodeState], add: NodeState) {
        let states = &mut self.graph.node_mut(ix).states;
        for &s in remove {
            states.remove(s);
        }
        states.insert(add);
    }

    fn not_close(&self, ix: NodeIx) -> Failure {
        format!("{} is not close to {}", self.label(self.character), self.label(ix))
    }

    fn require_close(&self, ix: NodeIx) -> Result<(), Failure> {
        if self.close_to(ix) { Ok(()) } else { Err(self.not_close(ix)) }
    }

    fn require_holding(&self, ix: NodeIx) -> Result<(), Failure> {
        if self.holds(ix) { Ok(()) } else { Err(format!("{} is not holding {}", self.label(self.character), self.label(ix))) }
    }

    fn require_free_hand(&self) -> Result<Relation, Failure> {
        self.free_hand().ok_or_else(|| format!("{} does not have a free hand", self.label(self.character)))
    }

    fn require_not_inside(&self, ix: NodeIx) -> Result<(), Failure> {
        if self.inside_closed(ix) { Err(format!("{} is inside other closed thing", self.label(ix))) } else { Ok(()) }
    }

    fn sitting_or_lying(&self) -> bool {
        self.has_state(self.character, NodeState::Sitting) || self.has_state(self.character, NodeState::Lying)
    }

    /// Executes one line; on failure nothing changes and the executor's message comes back. A
    /// line built by hand with the wrong number of objects fails as [`ScriptLine::parse`]
    /// refuses it.
    pub fn execute(&mut self, line: &ScriptLine) -> Result<(), Failure> {
        line.check_arity()?;
        let mut nodes = Vec::with_capacity(line.objects.len());
        for (name, id) in &line.objects {
            match self.graph.index_of(*id) {
                Some(ix) => nodes.push(ix),
                None => return Err(format!("<{name}> ({id}) cannot be found")),
            }
        }
        let first = nodes.first().copied();
        let node = || first.expect("arity checked above");
        match line.action {
            Action::Walk | Action::Run => self.walk(node()),
            Action::Find => self.find(node()),
            Action::Grab => self.grab(node()),
            Action::Open => self.open(node(), false),
            Action::Close => self.open(node(), true),
            Action::PutBack => self.put(node(), nodes[1], Relation::On),
            Action::PutIn => self.put(node(), nodes[1], Relation::Inside),
            Action::PutObjBack => self.put_obj_back(node()),
            Action::SwitchOn => self.switch(node(), true),
            Action::SwitchOff => self.switch(node(), false),
            Action::Drink => {
                let n = node();
                if !self.has_property(n, Property::Drinkable) && !self.has_property(n, Property::Recipient) {
                    return Err(format!("{} is not drinkable or not recipient", self.label(n)));
                }
                self.require_holding(n)
            }
            Action::TurnTo => {
                let n = node();
                self.graph.remove_all(self.character, &[Relation::Facing], false);
                self.graph.add_edge(self.character, Relation::Facing, n);
                Ok(())
            }
            Action::LookAt | Action::LookAtShort | Action::LookAtLong | Action::PointAt => {
                let n = node();
                if self.face_to(n) { Ok(()) } else { Err(format!("{} does not face {}", self.label(self.character), self.label(n))) }
            }
            Action::Wipe => {
                let n = node();
                self.require_close(n)?;
                if self.held().is_empty() {
                    return Err(format!("{} does not hold anything in hands", self.label(self.character)));
                }
                self.set_states(n, &[NodeState::Dirty], NodeState::Clean);
                Ok(())
            }
            Action::PutOn => {
                let n = node();
                self.require_holding(n)?;
                if !self.has_property(n, Property::Clothes) {
                    return Err(format!("{} is not clothes", self.label(n)));
                }
                self.graph.add_edge(n, Relation::On, self.character);
                self.graph.remove_edge(self.character, Relation::HoldsLh, n);
                self.graph.remove_edge(self.character, Relation::HoldsRh, n);
                Ok(())
            }
            Action::PutOff => {
                let n = node();
                if !self.graph.has_edge(n, Relation::On, self.character) {
                    return Err(format!("{} is not on {}", self.label(n), self.label(self.character)));
                }
                if !self.has_property(n, Property::Clothes) {
                    return Err(format!("{} is not clothes", self.label(n)));
                }
                self.graph.remove_edge(n, Relation::On, self.character);
                Ok(())
            }
            Action::Greet => {
                let n = node();
                if self.has_property(n, Property::Person) { Ok(()) } else { Err(format!("{} is not person", self.label(n))) }
            }
            Action::Drop | Action::Release => {
                let n = node();
                self.require_holding(n)?;
                let room = self.room_of(self.character);
                self.graph.remove_edge(self.character, Relation::HoldsLh, n);
                self.graph.remove_edge(self.character, Relation::HoldsRh, n);
                if let Some(room) = room {
                    self.graph.add_edge(n, Relation::Inside, room);
                }
                self.grabbed_from.remove(&n);
                Ok(())
            }
            Action::Read => {
                let n = node();
                if !self.has_property(n, Property::Readable) {
                    return Err(format!("{} is not readable", self.label(n)));
                }
                self.require_holding(n)
            }
            Action::Touch => {
                let n = node();
                self.require_close(n)?;
                self.require_not_inside(n)
            }
            Action::Sit => self.sit_or_lie(node(), false),
            Action::Lie => self.sit_or_lie(node(), true),
            Action::StandUp => {
                if !self.sitting_or_lying() {
                    return Err(format!("{} is not sitting", self.label(self.character)));
                }
                let states = &mut self.graph.node_mut(self.character).states;
                states.remove(NodeState::Sitting);
                states.remove(NodeState::Lying);
                Ok(())
            }
            Action::Pour => self.pour(node(), nodes[1]),
            Action::Type => {
                let n = node();
                self.require_close(n)?;
                if self.graph.node(n).class_name == "keyboard" || self.has_property(n, Property::HasSwitch) {
                    Ok(())
                } else {
                    Err(format!("{} is not typeable", self.label(n)))
                }
            }
            Action::Watch => self.watch(node()),
            Action::Push | Action::Pull | Action::Move => {
                let n = node();
                let class = self.graph.node(n).class_name.as_str();
                if !self.has_property(n, Property::Movable)
                    && (line.action != Action::Push && class != "button")
                    && !matches!(class, "chair" | "curtain")
                {
                    return Err(format!("{} is not movable", self.label(n)));
                }
                self.require_close(n)?;
                self.require_not_inside(n)?;
                self.require_free_hand().map(|_| ())
            }
            Action::Wash | Action::Rinse | Action::Scrub => {
                let n = node();
                self.require_close(n)?;
                self.set_states(n, &[NodeState::Dirty], NodeState::Clean);
                Ok(())
            }
            Action::Squeeze => {
                let n = node();
                self.require_free_hand()?;
                self.require_close(n)?;
                if !self.has_property(n, Property::Clothes) && !SQUEEZABLE.contains(&self.graph.node(n).class_name.as_str()) {
                    return Err(format!("{} is not clothes", self.label(n)));
                }
                Ok(())
            }
            Action::PlugIn | Action::PlugOut => self.plug(node(), line.action == Action::PlugIn),
            Action::Cut => {
                let n = node();
                self.require_free_hand()?;
                self.require_close(n)?;
                if !self.has_property(n, Property::Eatable) || !self.has_property(n, Property::Cuttable) {
                    return Err(format!("{} is not cuttable", self.label(n)));
                }
                if !self.held().into_iter().any(|h| self.graph.node(h).class_name.contains("knife")) {
                    return Err(format!("{} is not holding a knife", self.label(self.character)));
                }
                Ok(())
            }
            Action::Eat => {
                let n = node();
                self.require_close(n)?;
                let eatable = self.has_property(n, Property::Eatable)
                    || self.graph.sources(n, Relation::On).into_iter().any(|s| self.has_property(s, Property::Eatable));
                if eatable { Ok(()) } else { Err(format!("{} is not eatable", self.label(n))) }
            }
            Action::Sleep | Action::WakeUp => {
                if self.sitting_or_lying() {
                    Ok(())
                } else {
                    Err(format!("{} is not lying or sitting", self.label(self.character)))
                }
            }
        }
    }

    fn walk(&mut self, node: NodeIx) -> Result<(), Failure> {
        let c = self.character;
        if self.sitting_or_lying() {
            return Err(format!("{} is sitting", self.label(c)));
        }
        let old_room = self.room_of(c).ok_or_else(|| format!("{} is in no room", self.label(c)))?;
        let node_room = self.room_of(node).ok_or_else(|| format!("{} is in no room", self.label(node)))?;
        let held = self.held();
        self.graph.remove_all(c, &[Relation::Inside, Relation::Close, Relation::Facing], true);
        self.graph.add_edge(c, Relation::Inside, node_room);
        if node_room != node {
            for container in self.graph.targets(node, Relation::Inside) {
                if !self.graph.node(container).is_room() {
                    self.add_close(c, container);
                }
            }
            for body in self.graph.indices().filter(|&ix| self.has_property(ix, Property::BodyPart)).collect::<Vec<_>>() {
                self.add_close(c, body);
            }
            self.add_close(c, node);
        }
        for &h in &held {
            self.graph.remove_all(h, &[Relation::Inside, Relation::Close, Relation::Facing], true);
        }
        for &h in &held {
            self.add_close(c, h);
            self.graph.add_edge(h, Relation::Inside, old_room);
        }
        if self.has_property(node, Property::CanOpen) {
            for inside in self.graph.sources(node, Relation::Inside) {
                self.add_close(c, inside);
            }
        }
        for surface in self.graph.targets(node, Relation::On) {
            self.add_close(c, surface);
        }
        Ok(())
    }

    fn find(&mut self, node: NodeIx) -> Result<(), Failure> {
        let c = self.character;
        let only_find = self.graph.has_edge(node, Relation::On, c) || self.has_property(node, Property::BodyPart) || self.close_to(node);
        if !only_find {
            return self.walk(node);
        }
        self.require_close(node)?;
        self.graph.remove_all(c, &[Relation::Facing], false);
        self.add_close(c, node);
        Ok(())
    }

    fn grab(&mut self, node: NodeIx) -> Result<(), Failure> {
        let c = self.character;
        let class = self.graph.node(node).class_name.as_str();
        if !self.has_property(node, Property::Grabbable) && !matches!(class, "water" | "child") {
            return Err(format!("{} is not grabbable", self.label(node)));
        }
        if self.grabbed_from.contains_key(&node) {
            return Err(format!("{} already grabbed", self.label(node)));
        }
        self.require_close(node)?;
        self.require_not_inside(node)?;
        let hand = self.require_free_hand()?;
        let room = self.room_of(c);
        let rested = [Relation::On, Relation::Inside, Relation::Close]
            .into_iter()
            .find_map(|r| self.graph.targets(node, r).into_iter().find(|&n| !self.graph.node(n).is_room()).map(|n| (n, r)));
        self.graph.remove_all(node, &[Relation::On, Relation::Inside, Relation::Close, Relation::HoldsLh, Relation::HoldsRh], true);
        self.add_close(c, node);
        self.graph.add_edge(c, hand, node);
        if let Some(room) = room {
            self.graph.add_edge(node, Relation::Inside, room);
        }
        if let Some((rest, relation)) = rested {
            self.add_close(c, rest);
            self.grabbed_from.insert(node, (rest, relation));
        }
        Ok(())
    }

    fn open(&mut self, node: NodeIx, close: bool) -> Result<(), Failure> {
        let class = self.graph.node(node).class_name.as_str();
        if !self.has_property(node, Property::CanOpen) && !matches!(class, "desk" | "window") {
            return Err(format!("{} can not be opened", self.label(node)));
        }
        self.require_close(node)?;
        if !close {
            self.require_free_hand()?;
        }
        let (from, to) = if close { (NodeState::Open, NodeState::Closed) } else { (NodeState::Closed, NodeState::Open) };
        if !self.has_state(node, from) {
            return Err(format!("{} is not {}", self.label(node), from.as_str().to_lowercase()));
        }
        if !close && self.has_state(node, NodeState::On) {
            return Err(format!("{} is still on", self.label(node)));
        }
        self.set_states(node, &[from], to);
        Ok(())
    }

    fn check_puttable(&self, src: NodeIx, dest: NodeIx, relation: Relation) -> Result<(), Failure> {
        self.require_holding(src)?;
        self.require_close(dest)?;
        if relation == Relation::Inside && self.has_property(dest, Property::CanOpen) && !self.has_state(dest, NodeState::Open) {
            return Err(format!("{} is not open or is not openable", self.label(dest)));
        }
        Ok(())
    }

    fn apply_put(&mut self, src: NodeIx, dest: NodeIx, relation: Relation) {
        let c = self.character;
        self.graph.remove_edge(c, Relation::HoldsLh, src);
        self.graph.remove_edge(c, Relation::HoldsRh, src);
        self.add_close(c, dest);
        self.add_close(src, dest);
        self.graph.add_edge(src, relation, dest);
        self.grabbed_from.remove(&src);
    }

    fn put(&mut self, src: NodeIx, dest: NodeIx, relation: Relation) -> Result<(), Failure> {
        self.check_puttable(src, dest, relation)?;
        self.apply_put(src, dest, relation);
        Ok(())
    }

    fn put_obj_back(&mut self, src: NodeIx) -> Result<(), Failure> {
        let Some(&(dest, relation)) = self.grabbed_from.get(&src) else {
            return Err(format!("{} not grabbed", self.label(src)));
        };
        self.check_puttable(src, dest, relation)?;
        self.apply_put(src, dest, relation);
        Ok(())
    }

    fn switch(&mut self, node: NodeIx, on: bool) -> Result<(), Failure> {
        if !self.has_property(node, Property::HasSwitch) {
            return Err(format!("{} does not have a switch", self.label(node)));
        }
        self.require_close(node)?;
        let (from, to) = if on { (NodeState::Off, NodeState::On) } else { (NodeState::On, NodeState::Off) };
        if !self.has_state(node, from) {
            return Err(format!("{} is not {}", self.label(node), from.as_str().to_lowercase()));
        }
        if on && self.has_state(node, NodeState::PluggedOut) {
            return Err(format!("{} is unplugged", self.label(node)));
        }
        self.set_states(node, &[from], to);
        Ok(())
    }

    fn plug(&mut self, node: NodeIx, plug_in: bool) -> Result<(), Failure> {
        if !self.has_property(node, Property::HasPlug) {
            return Err(format!("{} does not have a plug", self.label(node)));
        }
        self.require_close(node)?;
        self.require_free_hand()?;
        let (from, to) =
            if plug_in { (NodeState::PluggedOut, NodeState::PluggedIn) } else { (NodeState::PluggedIn, NodeState::PluggedOut) };
        if !self.has_state(node, from) {
            return Err(format!("{} is not {}", self.label(node), from.as_str().to_lowercase()));
        }
        self.set_states(node, &[from], to);
        Ok(())
    }

    fn sit_or_lie(&mut self, node: NodeIx, lie: bool) -> Result<(), Failure> {
        let c = self.character;
        self.require_close(node)?;
        let (state, other, property) = if lie {
            (NodeState::Lying, NodeState::Sitting, Property::Lieable)
        } else {
            (NodeState::Sitting, NodeState::Lying, Property::Sittable)
        };
        if self.has_state(c, state) {
            return Err(format!("{} is {}", self.label(c), if lie { "lying" } else { "sitting" }));
        }
        if !self.has_property(node, property) {
            return Err(format!("{} is not {}", self.label(node), if lie { "lieable" } else { "sittable" }));
        }
        if !self.has_seat(node, lie) {
            return Err(format!("Too many things on {}", self.label(node)));
        }
        self.graph.add_edge(c, Relation::On, node);
        if !lie {
            for faced in self.graph.targets(node, Relation::Facing) {
                self.graph.add_edge(c, Relation::Facing, faced);
            }
        }
        self.set_states(c, &[other], state);
        Ok(())
    }

    /// Whether `node` has room for one more on it to sit (or lie): fewer nodes ON it than the
    /// executor's per-class limit (one for classes it does not list).
    pub fn has_seat(&self, node: NodeIx, lie: bool) -> bool {
        let table = if lie { LIE_MAX } else { SIT_MAX };
        let class = self.graph.node(node).class_name.as_str();
        let max = table.iter().find(|(name, _)| *name == class).map_or(1, |(_, n)| *n);
        self.graph.sources(node, Relation::On).len() < max
    }

    fn pour(&mut self, src: NodeIx, dest: NodeIx) -> Result<(), Failure> {
        if !self.has_property(src, Property::Pourable) && !self.has_property(src, Property::Drinkable) {
            return Err(format!("{} is not pourable or drinkable", self.label(src)));
        }
        if !self.has_property(dest, Property::Recipient)
            && !matches!(self.graph.node(dest).class_name.as_str(), "hands_both" | "sponge" | "face")
        {
            return Err(format!("{} is not recipient", self.label(dest)));
        }
        self.require_holding(src)?;
        self.require_close(dest)?;
        self.graph.add_edge(src, Relation::Inside, dest);
        if self.graph.node(src).class_name == "water" {
            self.graph.remove_edge(self.character, Relation::HoldsLh, src);
            self.graph.remove_edge(self.character, Relation::HoldsRh, src);
        }
        Ok(())
    }

    fn watch(&mut self, node: NodeIx) -> Result<(), Failure> {
        let c = self.character;
        if !self.has_property(node, Property::Lookable) {
            return Err(format!("{} is not lookable", self.label(node)));
        }
        if self.room_of(node).is_none() || self.room_of(node) != self.room_of(c) {
            return Err(format!("{} is not in the same room as {}", self.label(node), self.label(c)));
        }
        if !self.face_to(node) {
            return Err(format!("{} does not face {}", self.label(c), self.label(node)));
        }
        if self.graph.node(node).class_name != "computer" && self.sitting_or_lying() && !self.graph.has_edge(c, Relation::Facing, node) {
            return Err(format!("{} does not face {}", self.label(c), self.label(node)));
        }
        self.require_not_inside(node)
    }
}
