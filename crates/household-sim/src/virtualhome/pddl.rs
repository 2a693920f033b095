//! A PDDL problem of the sound VirtualHome domain (`fixtures/virtualhome-eai/virtualhome-sound.pddl`,
//! [`SOUND_DOMAIN`]) written from a task's scene graph, and the way back from its plans to the
//! executor's script lines.
//!
//! The domain is sound only for problems written by [`problem`]: every predicate the domain reads
//! negatively (states, INSIDE between objects, the hands) is written exactly for the problem's
//! objects, and the object set is closed under direct non-room INSIDE targets, so that "not
//! inside a closed container" means the same in the problem as in the graph. Predicates read
//! only positively (the character's CLOSE and FACING edges, CLOSE and ON between objects, the
//! rooms of fixed objects) may say less than the graph, never more.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use super::{NodeIx, NodeState, Property, Relation, VhGoal, VirtualhomeTask, World};

/// The sound VirtualHome domain, as shipped in `fixtures/virtualhome-eai/`.
pub const SOUND_DOMAIN: &str = include_str!("../../../../fixtures/virtualhome-eai/virtualhome-sound.pddl");

/// Action-goal names the domain can produce (the verb of a script line it writes), with the
/// `kind` constant its action adds to the goal-step chain.
const KINDS: &[(&str, &str)] = &[
    ("GRAB", "k_grab"),
    ("WATCH", "k_watch"),
    ("LOOKAT", "k_lookat"),
    ("DRINK", "k_drink"),
    ("READ", "k_read"),
    ("TOUCH", "k_touch"),
    ("PUSH", "k_push"),
    ("TYPE", "k_type"),
    ("WASH", "k_wash"),
    ("WIPE", "k_wipe"),
    ("SLEEP", "k_sleep"),
    ("POUR", "k_pour"),
    ("SWITCHOFF", "k_switchoff"),
];

/// Domain action → (script verb, how many of its object arguments the script line keeps).
const VERBS: &[(&str, &str, usize)] = &[
    ("walk_towards", "WALK", 1),
    ("walk_into", "WALK", 1),
    ("grab", "GRAB", 1),
    ("open", "OPEN", 1),
    ("close", "CLOSE", 1),
    ("put_on", "PUTBACK", 2),
    ("put_inside", "PUTIN", 2),
    ("put_on_character", "PUTON", 1),
    ("switch_on", "SWITCHON", 1),
    ("switch_off", "SWITCHOFF", 1),
    ("plug_in", "PLUGIN", 1),
    ("plug_out", "PLUGOUT", 1),
    ("sit", "SIT", 1),
    ("lie", "LIE", 1),
    ("standup", "STANDUP", 0),
    ("turn_to", "TURNTO", 1),
    ("look_at", "LOOKAT", 1),
    ("watch", "WATCH", 1),
    ("drink", "DRINK", 1),
    ("read", "READ", 1),
    ("touch", "TOUCH", 1),
    ("push", "PUSH", 1),
    ("type", "TYPE", 1),
    ("wash", "WASH", 1),
    ("wipe", "WIPE", 1),
    ("pour", "POUR", 2),
    ("sleep", "SLEEP", 0),
];

/// Categories of the building itself (walls, floors, ceilings): no action changes them, so a
/// class of EAI's problem brings them in only when the goal names them.
const STRUCTURE: &[&str] = &["Walls", "Floor", "Floors", "Ceiling"];

/// The name of the character object in every problem.
pub const CHARACTER: &str = "character";

/// A problem written for the sound domain, and its binding of PDDL names to graph nodes.
#[derive(Debug, Clone)]
pub struct VhProblem {
    /// The problem file's text.
    pub text: String,
    /// PDDL object name → scene-graph node id, every object of the problem (the character too).
    pub objects: BTreeMap<String, u32>,
}

/// Why a task's goal cannot be written for the sound domain.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("task {task}: goal {goal} has no counterpart in the sound domain")]
pub struct UnexpressibleGoal {
    /// The task's id ([`VirtualhomeTask::task_id`]).
    pub task: String,
    /// The goal in words: `plate (1001) is CLEAN`, `plate (1001) INSIDE dishwasher (1000)`, `action WATCH|LOOKAT`.
    pub goal: String,
}

/// Writes the problem of `task` for [`SOUND_DOMAIN`]. Objects: the goal's nodes, every
/// instance of `classes` (e.g. the classes of EAI's own problem file for the task) but walls,
/// floors and ceilings, what the
/// character holds, every room, and, until nothing changes, the non-room nodes these are
/// directly INSIDE. Instances of a class that occurs once are named by the class; otherwise
/// `class_1`, `class_2`, ... in id order.
pub fn problem(task: &VirtualhomeTask, classes: &[&str]) -> Result<VhProblem, UnexpressibleGoal> {
    let world = &task.init;
    let g = &world.graph;
    let c = world.character;
    let mut chosen: BTreeSet<NodeIx> = BTreeSet::new();
    for goal in &task.goals {
        match goal {
            VhGoal::State { node, .. } => chosen.extend(g.index_of(*node)),
            VhGoal::Edge { from, to, .. } => chosen.extend([*from, *to].iter().filter_map(|id| g.index_of(*id))),
            VhGoal::Action { .. } => {}
        }
    }
    chosen.extend(g.indices().filter(|&ix| {
        let node = g.node(ix);
        node.is_room() || (classes.contains(&node.class_name.as_str()) && !STRUCTURE.contains(&node.category.as_str()))
    }));
    chosen.extend(world.held());
    loop {
        let more: Vec<NodeIx> = chosen
            .iter()
            .flat_map(|&ix| g.targets(ix, Relation::Inside))
            .filter(|&t| !g.node(t).is_room() && !chosen.contains(&t))
            .collect();
        if more.is_empty() {
            break;
        }
        chosen.extend(more);
    }
    chosen.remove(&c);

    let names = object_names(world, &chosen);
    let name = |ix: NodeIx| -> &str { if ix == c { CHARACTER } else { &names[&ix] } };
    let room = |ix: NodeIx| g.node(ix).is_room();
    let grabbable =
        |ix: NodeIx| g.node(ix).properties.contains(Property::Grabbable) || matches!(g.node(ix).class_name.as_str(), "water" | "child");

    let mut init: Vec<String> = Vec::new();
    let mut fact = |pred: &str, args: &[&str]| init.push(format!("({pred} {})", args.join(" ")));
    for &ix in &chosen {
        let node = g.node(ix);
        let n = name(ix);
        let class = node.class_name.as_str();
        let has = |p: Property| node.properties.contains(p);
        if room(ix) {
            fact("room", &[n]);
        } else if world.room_of(ix).is_some() {
            fact("located", &[n]);
        }
        for (p, pred) in [
            (Property::CanOpen, "can_open"),
            (Property::HasSwitch, "has_switch"),
            (Property::HasPlug, "has_plug"),
            (Property::Lookable, "lookable"),
            (Property::Readable, "readable"),
            (Property::Drinkable, "drinkable"),
            (Property::Recipient, "recipient"),
            (Property::Pourable, "pourable"),
            (Property::Sittable, "sittable"),
            (Property::Lieable, "lieable"),
            (Property::Clothes, "clothes"),
        ] {
            if has(p) {
                fact(pred, &[n]);
            }
        }
        if grabbable(ix) {
            fact("grabbable", &[n]);
        }
        if class == "water" {
            fact("water", &[n]);
        }
        if has(Property::Recipient) || matches!(class, "hands_both" | "sponge" | "face") {
            fact("pour_target", &[n]);
        }
        if class == "keyboard" || has(Property::HasSwitch) {
            fact("typeable", &[n]);
        }
        if has(Property::Sittable) && world.has_seat(ix, false) {
            fact("sit_free", &[n]);
        }
        if has(Property::Lieable) && world.has_seat(ix, true) {
            fact("lie_free", &[n]);
        }
        for state in node.states.iter() {
            if let Some(pred) = state_predicate(state) {
                fact(pred, &[n]);
            }
        }
        if let Some(r) = fixed_room(world, ix) {
            fact("inside_room", &[n, name(r)]);
        }
    }
    let cs = g.node(c).states;
    if cs.contains(NodeState::Sitting) {
        fact("sitting", &[CHARACTER]);
    }
    if cs.contains(NodeState::Lying) {
        fact("lying", &[CHARACTER]);
    }
    if let Some(r) = world.room_of(c) {
        fact("inside", &[CHARACTER, name(r)]);
    }
    for (from, relation, to) in g.all_edges() {
        let known = |ix: NodeIx| ix == c || chosen.contains(&ix);
        if !known(from) || !known(to) || from == to || room(from) || room(to) {
            continue;
        }
        let (a, b) = (name(from), name(to));
        match (from == c, to == c, relation) {
            (true, _, Relation::Close) => fact("next_to", &[a, b]),
            (true, _, Relation::Facing) => fact("facing", &[a, b]),
            (true, _, Relation::HoldsRh) => fact("holds_rh", &[a, b]),
            (true, _, Relation::HoldsLh) => fact("holds_lh", &[a, b]),
            (true, _, Relation::On) => fact("ontop", &[a, b]),
            (false, true, Relation::On) => fact("on_char", &[a, b]),
            (false, false, Relation::On) => fact("obj_ontop", &[a, b]),
            (false, false, Relation::Inside) => fact("obj_inside", &[a, b]),
            (false, false, Relation::Close) => fact("obj_next_to", &[a, b]),
            (false, false, Relation::Facing) if !grabbable(from) && !grabbable(to) => fact("obj_facing", &[a, b]),
            _ => {}
        }
    }
    if !g.targets(c, Relation::HoldsRh).is_empty() {
        fact("rh_busy", &[CHARACTER]);
    }
    if !g.targets(c, Relation::HoldsLh).is_empty() {
        fact("lh_busy", &[CHARACTER]);
    }

    // Action goals: a chain of steps s0 → s1 → ...; step i accepts the kinds of its group's
    // options. EAI's check takes, for each group in turn, the first option (in the group's
    // order) found anywhere after the previous match; so a group followed by others accepts
    // only its first option this domain can produce (options before it never occur in its
    // plans), and the last group accepts any.
    let groups: Vec<&str> =
        task.goals.iter().filter_map(|g| if let VhGoal::Action { options } = g { Some(options.as_str()) } else { None }).collect();
    for i in 0..groups.len() {
        fact("step_next", &[&format!("s{i}"), &format!("s{}", i + 1)]);
        let kinds = groups[i].split('|').filter_map(|o| {
            let o = o.to_uppercase().replace(' ', "");
            KINDS.iter().find(|(verb, _)| *verb == o).map(|(_, k)| *k)
        });
        let kinds: Vec<&str> = if i + 1 == groups.len() { kinds.collect() } else { kinds.take(1).collect() };
        for k in kinds {
            fact("step_accepts", &[&format!("s{i}"), k]);
        }
    }
    fact("step_now", &["s0"]);

    let mut goal: Vec<String> = Vec::new();
    for gl in &task.goals {
        let unexpressible = || UnexpressibleGoal { task: task.task_id.clone(), goal: describe(task, gl) };
        match gl {
            VhGoal::State { node, state, .. } => {
                let ix = g.index_of(*node).ok_or_else(unexpressible)?;
                let pred = if ix == c {
                    match state {
                        NodeState::Sitting => "sitting",
                        NodeState::Lying => "lying",
                        _ => return Err(unexpressible()),
                    }
                } else {
                    state_predicate(*state).ok_or_else(unexpressible)?
                };
                goal.push(format!("({pred} {})", name(ix)));
            }
            VhGoal::Edge { from, relation, to } => {
                let (f, t) = (g.index_of(*from).ok_or_else(unexpressible)?, g.index_of(*to).ok_or_else(unexpressible)?);
                let atom = match (f == c, t == c, room(t), relation) {
                    (true, false, true, Relation::Inside) => ("inside", f, t),
                    (_, _, true, _) => return Err(unexpressible()),
                    (true, false, false, Relation::Close) => ("next_to", f, t),
                    (false, true, false, Relation::Close) => ("next_to", t, f),
                    (true, false, false, Relation::Facing) => ("facing", f, t),
                    (true, false, false, Relation::HoldsRh) => ("holds_rh", f, t),
                    (true, false, false, Relation::HoldsLh) => ("holds_lh", f, t),
                    (true, false, false, Relation::On) => ("ontop", f, t),
                    (false, true, false, Relation::On) => ("on_char", f, t),
                    (false, false, false, Relation::On) => ("obj_ontop", f, t),
                    (false, false, false, Relation::Inside) => ("obj_inside", f, t),
                    (false, false, false, Relation::Close) => ("obj_next_to", f, t),
                    _ => return Err(unexpressible()),
                };
                goal.push(format!("({} {} {})", atom.0, name(atom.1), name(atom.2)));
            }
            VhGoal::Action { .. } => {}
        }
    }
    if !groups.is_empty() {
        goal.push(format!("(step_now s{})", groups.len()));
    }
    goal.dedup();

    let mut text = String::new();
    let _ = writeln!(text, "; Written by household-sim from EAI task {} ({}).", task.task_id, task.task_name);
    let _ = writeln!(text, "(define (problem vh-{})\n    (:domain virtualhome-sound)\n    (:objects", task.task_id.replace(' ', "_"));
    let _ = writeln!(text, "        {CHARACTER} - character");
    for &ix in &chosen {
        let _ = writeln!(text, "        {} - object", name(ix));
    }
    let steps: Vec<String> = (0..=groups.len()).map(|i| format!("s{i}")).collect();
    let _ = writeln!(text, "        {} - step\n    )\n    (:init", steps.join(" "));
    for f in &init {
        let _ = writeln!(text, "        {f}");
    }
    let _ = writeln!(text, "    )\n    (:goal (and");
    for a in &goal {
        let _ = writeln!(text, "        {a}");
    }
    let _ = writeln!(text, "    ))\n)");

    let mut objects: BTreeMap<String, u32> = chosen.iter().map(|&ix| (names[&ix].clone(), g.node(ix).id)).collect();
    objects.insert(CHARACTER.to_string(), g.node(c).id);
    Ok(VhProblem { text, objects })
}

impl VhProblem {
    /// One plan step of the sound domain (`(put_inside character plate dishwasher)`, with or
    /// without parentheses, any case) as the executor's script line
    /// (`[PUTIN] <plate> (1001) <dishwasher> (1000)`), naming each object by its class.
    pub fn script_line(&self, world: &World, step: &str) -> Result<String, String> {
        let words: Vec<String> =
            step.trim().trim_start_matches('(').trim_end_matches(')').split_whitespace().map(str::to_lowercase).collect();
        let (action, args) = words.split_first().ok_or_else(|| "empty plan step".to_string())?;
        let &(_, verb, keep) =
            VERBS.iter().find(|(a, _, _)| a == action).ok_or_else(|| format!("`{action}` is not an action of the sound domain"))?;
        let mut line = format!("[{verb}]");
        for arg in args.iter().filter(|a| a.as_str() != CHARACTER).take(keep) {
            let id = *self.objects.get(arg.as_str()).ok_or_else(|| format!("`{arg}` is not an object of this problem"))?;
            let ix = world.graph.index_of(id).ok_or_else(|| format!("node {id} is not in the scene"))?;
            let _ = write!(line, " <{}> ({id})", world.graph.node(ix).class_name);
        }
        Ok(line)
    }
}

/// The domain predicate of a node state.
fn state_predicate(state: NodeState) -> Option<&'static str> {
    Some(match state {
        NodeState::Closed => "closed",
        NodeState::Open => "open",
        NodeState::On => "on",
        NodeState::Off => "off",
        NodeState::PluggedIn => "plugged_in",
        NodeState::PluggedOut => "plugged_out",
        NodeState::Clean => "clean",
        NodeState::Dirty => "dirty",
        NodeState::Sitting | NodeState::Lying => return None,
    })
}

/// The room of a node that can never move: not grabbable, and nothing grabbable on its chain
/// of INSIDE edges up to the room (what is grabbed, or walked with, loses its INSIDE edges).
fn fixed_room(world: &World, ix: NodeIx) -> Option<NodeIx> {
    let g = &world.graph;
    let grabbable =
        |n: NodeIx| g.node(n).properties.contains(Property::Grabbable) || matches!(g.node(n).class_name.as_str(), "water" | "child");
    if g.node(ix).is_room() {
        return None;
    }
    let room = world.room_of(ix)?;
    let mut stack = vec![ix];
    let mut seen = BTreeSet::new();
    while let Some(n) = stack.pop() {
        if !seen.insert(n) || n == room {
            continue;
        }
        if grabbable(n) {
            return None;
        }
        stack.extend(g.targets(n, Relation::Inside));
    }
    Some(room)
}

/// PDDL names: the class (lower case, non-alphanumerics as `_`) where the problem has one
/// instance of it, else `class_1`, `class_2`, ... by id; a name taken twice gets its id.
fn object_names(world: &World, chosen: &BTreeSet<NodeIx>) -> BTreeMap<NodeIx, String> {
    let g = &world.graph;
    let clean = |s: &str| -> String {
        let s: String = s.to_lowercase().chars().map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '_' }).collect();
        if s.starts_with(|ch: char| ch.is_ascii_alphabetic()) { s } else { format!("o_{s}") }
    };
    let mut by_class: BTreeMap<String, Vec<NodeIx>> = BTreeMap::new();
    for &ix in chosen {
        by_class.entry(clean(&g.node(ix).class_name)).or_default().push(ix);
    }
    let mut names = BTreeMap::new();
    let mut taken: BTreeSet<String> = [CHARACTER.to_string()].into_iter().chain(KINDS.iter().map(|(_, k)| k.to_string())).collect();
    for (class, mut nodes) in by_class {
        nodes.sort_by_key(|&ix| g.node(ix).id);
        let single = nodes.len() == 1;
        for (k, ix) in nodes.into_iter().enumerate() {
            let mut name = if single { class.clone() } else { format!("{class}_{}", k + 1) };
            if !taken.insert(name.clone()) {
                name = format!("{class}_id{}", g.node(ix).id);
                taken.insert(name.clone());
            }
            names.insert(ix, name);
        }
    }
    names
}

fn describe(task: &VirtualhomeTask, goal: &VhGoal) -> String {
    let g = &task.init.graph;
    let label = |id: u32| g.index_of(id).map_or_else(|| format!("? ({id})"), |ix| format!("{} ({id})", g.node(ix).class_name));
    match goal {
        VhGoal::State { node, state, .. } => format!("{} is {}", label(*node), state.as_str()),
        VhGoal::Edge { from, relation, to } => format!("{} {} {}", label(*from), relation.as_str(), label(*to)),
        VhGoal::Action { options } => format!("action {options}"),
    }
}
