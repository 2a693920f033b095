//! The agent on VirtualHome: Phase I reads `VirtualhomeEnv`'s observations (the room, what is
//! held and in which hand, the rooms, and every visible node with its states, its ON/INSIDE
//! relations to visible nodes and whether it is close), and hands over a problem of the sound
//! domain (`household_sim::vh_pddl`) written from what was perceived.
//!
//! Rules, each where it is implemented:
//! - U's percepts ([`perceive_virtualhome`]), in the judge's vocabulary (`CLOSED(dishwasher
//!   (1000))`, `INSIDE(plate (1001), cabinet (5))`): a visible node's listed states hold and
//!   every other state does not (the observation lists all of them); its listed ON/INSIDE
//!   relations to visible nodes hold, and a relation F_t had to a node visible now but not listed
//!   no longer does; a visible node not held is in the room the agent stands in (`IN_ROOM`: the
//!   graph's direct INSIDE edge to a room is not always there); CLOSE to the
//!   character as the observation says, for every visible node, and not CLOSE for a node F_t
//!   had close that is out of sight now; what is held, and in which hand;
//!   whether the character sits or lies (`goto` then stands up first).
//!   Names are as perceived: class and the id the observation shows.
//! - K_t ([`VirtualhomeAdapter`]'s `skills`): `goto R` for rooms not yet entered; `open X` for a
//!   container (F_str: `can_open` and `containers`) the agent is close to and saw closed and not
//!   on (EAI's executor opens no appliance that is on, and no skill switches one off), not yet
//!   tried to open (a failed attempt would fail again); `close X`
//!   for one it opened, once; `goto X` for closed containers not on, not yet tried and not yet walked
//!   to (R_t: a place is inspected once; arriving at X the agent opens it, the skill's
//!   follow-up, and a walk back would show nothing new), those of a class G names first (the
//!   plan goes there anyway), then those of the current room. The places the task
//!   sentence names (F_str's names of a class: "living room" names `home_office`) come first:
//!   a goal container in a named room, the named rooms not yet entered, the other goal
//!   containers, the other containers in named rooms, then the rest in the order above; among containers, those of a class the
//!   sentence names ("a cup from the cupboard") first;
//!   `look` (walk up to the first object a model's
//!   hypothesis names, for a close view) when there is such a hypothesis and the agent is not
//!   close to that object already; `done`. Every skill but `look` and `done` thus has a target
//!   it can take at most once, so no choice of the model's can make Phase I circle. The sweep:
//!   open the closed container the agent is close to, else walk to a closed container of a
//!   class G names, else enter the next room, else walk to the next closed container.
//! - Ready: every object symbol of G has a distinct perceived instance of its class that G does
//!   not already describe: when G relates the symbol to no other object and the states G gives
//!   it all already hold of an instance (its relations to the character, the agent's pose, do not
//!   count), the task cannot be asking about
//!   it (a task asks for a change; EAI's goals are what the expert's run changed), so the agent
//!   looks on for another (`VirtualhomeAdapter::already_done`). Where the task sentence names
//!   rooms, the instance must be in one of them until every named room has been entered: the
//!   instruction says where the task is done, and EAI's judge names the instances there. Where
//!   it names no room but names other objects (classes of context: "watching TV from sofa"),
//!   the instance must be in a room where one of them was seen until every room has been
//!   entered: the instruction says what the task is done among.
//! - ŝ0: the perceived scene as a scene graph (perceived nodes; class properties from F_str, the
//!   affordances of EAI's `properties_data.json`; perceived states and relations; a character
//!   node of its own, since the agent never sees its id), with G's symbols bound (β) to distinct
//!   perceived instances of their classes (those G does not already describe first, then those
//!   in a room the task sentence names, then those in the room where the most classes of context
//!   were seen, then the lowest id), written by `vh_pddl::problem`,
//!   which adds what the bound objects are inside. For an action goal (a group of alternative
//!   verbs), every perceived object whose class has an affordance a verb of the group needs
//!   joins the problem, unless an object G binds already has one (for a verb of one object: not
//!   POUR). When G has the
//!   left hand hold something and says nothing of the right, the grabbable objects seen in that
//!   object's room join it too: GRAB fills the right hand first.
//! - Plan steps are the executor's script lines with the perceived ids
//!   (`VhProblem::script_line`).

use std::collections::{BTreeMap, BTreeSet};

use grounding::ActionId;
use household_sim::vh_pddl::{self, SOUND_DOMAIN, VhProblem};
use household_sim::{JudgeAtom, Observation, VhNodeState as NodeState, VirtualhomeTask};
use serde_json::{Value, json};
use transition_model::Spelling;

use crate::episode::{Grounded, Handing, Handover, ground};
use crate::evidence::{Belief, Fact, Percept};
use crate::goal::ClassGoal;
use crate::ontology::Ontology;
use crate::phase1::{Adapter, Exploration, Record, Skill, Skills, StepRecord};

/// The character's name in F_t (F_t never names it by its node id, which only the executor's
/// failure messages show: `character (1) is not close to ...`).
pub const ME: &str = "character";

/// `IN_ROOM(x, r)`: x was seen while the agent stood in room r (visible nodes are those
/// transitively inside the agent's room). Not the graph's direct INSIDE edge, which an object
/// put into a container no longer has to its room; the judge's `IN_ROOM` is the executor's
/// `room_of`.
pub const IN_ROOM: &str = "IN_ROOM";

/// `plate (1001)` → (`plate`, 1001).
pub fn split_name(name: &str) -> Option<(&str, u32)> {
    let (class, rest) = name.rsplit_once(" (")?;
    Some((class, rest.strip_suffix(')')?.parse().ok()?))
}

/// The class of a perceived name (`plate (1001)` → `plate`; anything else as it is).
pub fn class_of(name: &str) -> &str {
    split_name(name).map_or(name, |(c, _)| c)
}

/// A relation's target: the character (clothes it wears are ON it) is [`ME`], whatever id the
/// observation shows for it.
fn me_or(target: &str) -> String {
    if class_of(target) == "character" { ME.to_string() } else { target.to_string() }
}

/// One `- name: parts` line of the observation: name, states, (relation, target), close.
type SeenNode = (String, Vec<String>, Vec<(String, String)>, bool);

/// What one observation states: (rooms listed, percepts). See the module documentation.
pub fn perceive_virtualhome(text: &str, step: usize, belief: &Belief) -> (Vec<String>, Vec<Percept>) {
    let mut rooms = Vec::new();
    let mut out = Vec::new();
    let mut fact = |predicate: &str, args: &[&str], holds: bool| out.push(Percept { fact: Fact::new(predicate, args, holds), step });
    let mut here: Option<String> = None;
    let mut held: Vec<String> = Vec::new();
    let mut seen: Vec<SeenNode> = Vec::new();
    let mut listing = false;
    let (mut sitting, mut lying) = (false, false);
    for line in text.lines() {
        let line = line.trim();
        if line == "You are sitting." {
            sitting = true;
        } else if line == "You are lying." {
            lying = true;
        } else if let Some(room) = line.strip_prefix("You are in the ").and_then(|r| r.strip_suffix('.')) {
            here = Some(room.to_string());
        } else if let Some(rest) = line.strip_prefix("You hold: ").and_then(|r| r.strip_suffix('.')) {
            for item in rest.split(", ").filter(|i| *i != "nothing") {
                let (name, hand) = match item.rsplit_once(" in the ") {
                    Some((name, "right hand")) => (name, "HOLDS_RH"),
                    Some((name, "left hand")) => (name, "HOLDS_LH"),
                    _ => (item, "HOLDS_RH"),
                };
                fact(hand, &[ME, name], true);
                held.push(name.to_string());
            }
        } else if let Some(rest) = line.strip_prefix("Rooms: ").and_then(|r| r.strip_suffix('.')) {
            rooms.extend(rest.split(", ").map(str::to_string));
        } else if line == "You see:" {
            listing = true;
        } else if let Some(item) = line.strip_prefix("- ").filter(|_| listing) {
            let (name, parts) = item.split_once(": ").unwrap_or((item, ""));
            let mut states = Vec::new();
            let mut relations = Vec::new();
            let mut close = false;
            for part in parts.split("; ").filter(|p| !p.is_empty()) {
                if part == "close to you" {
                    close = true;
                } else if let Some(t) = part.strip_prefix("on ") {
                    relations.push(("ON".to_string(), me_or(t)));
                } else if let Some(t) = part.strip_prefix("inside ") {
                    relations.push(("INSIDE".to_string(), me_or(t)));
                } else {
                    states.extend(part.split(", ").map(str::to_string));
                }
            }
            seen.push((name.to_string(), states, relations, close));
        }
    }
    // Every observation says whether the character sits or lies (a line only when it does).
    if here.is_some() {
        fact("SITTING", &[ME], sitting);
        fact("LYING", &[ME], lying);
    }
    let visible: BTreeSet<&str> = seen.iter().map(|(n, ..)| n.as_str()).collect();
    let prior: Vec<Fact> = belief.facts().into_iter().filter(|f| f.holds && f.args.len() == 2).collect();
    if let Some(room) = &here {
        fact("INSIDE", &[ME, room], true);
        for r in rooms.iter().filter(|r| *r != room) {
            fact("INSIDE", &[ME, r], false);
        }
    }
    for (name, states, relations, close) in &seen {
        for state in NodeState::ALL {
            fact(state.as_str(), &[name], states.iter().any(|s| s == state.as_str()));
        }
        for (relation, target) in relations {
            fact(relation, &[name, target], true);
        }
        // A relation F_t had to a node visible now that the observation no longer lists.
        for f in prior.iter().filter(|f| f.args[0] == *name) {
            if matches!(f.predicate.as_str(), "ON" | "INSIDE")
                && visible.contains(f.args[1].as_str())
                && !relations.iter().any(|(r, t)| *r == f.predicate && *t == f.args[1])
            {
                fact(&f.predicate, &[name, &f.args[1]], false);
            }
        }
        if let Some(room) = &here
            && !held.contains(name)
        {
            fact(IN_ROOM, &[name, room], true);
        }
        fact("CLOSE", &[ME, name], *close);
    }
    // Close to something F_t said the agent was close to, now out of sight (another room).
    if here.is_some() {
        for f in prior.iter().filter(|f| f.predicate == "CLOSE" && f.args[0] == ME && !visible.contains(f.args[1].as_str())) {
            if !held.contains(&f.args[1]) {
                fact("CLOSE", &[ME, &f.args[1]], false);
            }
        }
    }
    // Something F_t said was held and no longer is.
    for f in prior.iter().filter(|f| f.predicate == "HOLDS_RH" || f.predicate == "HOLDS_LH") {
        if !held.contains(&f.args[1]) {
            fact(&f.predicate, &[ME, &f.args[1]], false);
        }
    }
    (rooms, out)
}

/// Affordances (F_str, lower case) an action verb of EAI's action goals needs of its object.
const VERB_AFFORDANCES: &[(&str, &[&str])] = &[
    ("WATCH", &["lookable"]),
    ("LOOKAT", &["lookable"]),
    ("READ", &["readable"]),
    ("DRINK", &["drinkable", "recipient"]),
    ("TYPE", &["has_switch"]),
    ("SWITCHON", &["has_switch"]),
    ("SWITCHOFF", &["has_switch"]),
    ("GRAB", &["grabbable"]),
    ("TOUCH", &["grabbable"]),
    ("PUSH", &["movable"]),
    ("WASH", &["grabbable"]),
    ("WIPE", &["grabbable"]),
    ("POUR", &["pourable", "recipient"]),
    ("SLEEP", &["lieable"]),
];

/// VirtualHome's side of Phase I and of the hand-over (module documentation).
pub struct VirtualhomeAdapter {
    /// F_str: VirtualHome's class-level ontology (EAI's properties, with the class-name
    /// equivalences the task sentence is read with).
    pub ontology: Ontology,
    /// The sound VirtualHome domain (`household_sim::vh_pddl::SOUND_DOMAIN`), parsed.
    pub domain: pddl_syntax::Domain,
    /// The last hand-over's problem and perceived task (for binding plan steps back).
    last: Option<(VhProblem, VirtualhomeTask)>,
    /// Rooms the agent has stood in.
    entered: BTreeSet<String>,
    /// The task sentence and the classes of context it names ([`Self::context_classes`]).
    context: std::cell::OnceCell<(String, BTreeSet<String>)>,
}

impl std::fmt::Debug for VirtualhomeAdapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VirtualhomeAdapter").field("entered", &self.entered).finish_non_exhaustive()
    }
}

impl VirtualhomeAdapter {
    /// An adapter with nothing perceived yet. Errors when the sound domain does not parse.
    pub fn new(ontology: Ontology) -> Result<VirtualhomeAdapter, String> {
        let domain = pddl_syntax::parse_domain(SOUND_DOMAIN).map_err(|e| format!("the sound VirtualHome domain: {e:?}"))?;
        Ok(VirtualhomeAdapter { ontology, domain, last: None, entered: BTreeSet::new(), context: std::cell::OnceCell::new() })
    }

    fn has(&self, name: &str, affordance: &str) -> bool {
        self.ontology.affordances.get(class_of(name)).is_some_and(|a| a.contains(affordance))
    }

    /// Perceived instances (not rooms, not the character), by name.
    fn instances(belief: &Belief) -> BTreeSet<String> {
        let rooms: BTreeSet<&String> = belief.places.iter().collect();
        belief
            .facts()
            .into_iter()
            .filter(|f| f.predicate == "CLOSE" || f.predicate.starts_with("HOLDS"))
            .filter_map(|f| f.args.get(1).cloned())
            .filter(|n| !rooms.contains(n))
            .collect()
    }

    fn room_now(belief: &Belief) -> Option<String> {
        belief.places.iter().find(|r| belief.holds("INSIDE", &[ME, r]) == Some(true)).cloned()
    }

    /// The targets of R_t's executed commands with this script verb (`[OPEN] `, `[WALK] `).
    fn targets(record: &Record, verb: &str) -> BTreeSet<String> {
        record.steps.iter().filter(|s| s.executed).filter_map(|s| s.command.strip_prefix(verb).map(script_name)).collect()
    }

    /// The targets of R_t's commands with this script verb, executed or not: an attempt that
    /// failed (a freezer that is on does not open) would fail again, so it is not offered again.
    fn attempted(record: &Record, verb: &str) -> BTreeSet<String> {
        record.steps.iter().filter_map(|s| s.command.strip_prefix(verb).map(script_name)).collect()
    }

    /// The object `look` walks up to: the first perceived instance a hypothesis names.
    fn look_target(belief: &Belief) -> Option<String> {
        let instances = Self::instances(belief);
        belief.hypotheses().flat_map(|h| h.args.iter()).find(|a| instances.contains(*a)).cloned()
    }

    /// A container (F_str) seen closed and not on: EAI's executor refuses to open an appliance
    /// that is on ("is still on"), and Phase I has no skill that switches one off, so one seen
    /// on is no place to inspect.
    fn openable(&self, x: &str, belief: &Belief) -> bool {
        self.has(x, "can_open")
            && self.has(x, "containers")
            && belief.holds("CLOSED", &[x]) == Some(true)
            && belief.holds("ON", &[x]) != Some(true)
    }

    /// Containers seen closed (and not on) that Phase I has not tried to open, with whether
    /// they are in the room now.
    fn closed_containers(&self, belief: &Belief, record: &Record) -> Vec<(String, bool)> {
        let opened = Self::attempted(record, "[OPEN] ");
        let room = Self::room_now(belief);
        let mut out: Vec<(String, bool)> = Self::instances(belief)
            .into_iter()
            .filter(|x| self.openable(x, belief) && !opened.contains(x))
            .map(|x| {
                let in_room = room.as_ref().is_some_and(|r| belief.holds(IN_ROOM, &[&x, r]) == Some(true));
                (x, in_room)
            })
            .collect();
        out.sort_by_key(|(x, in_room)| (!in_room, split_name(x).map_or(u32::MAX, |(_, id)| id)));
        out
    }

    /// Whether `x` already is what G asks of `symbol`: G relates the symbol to no other object,
    /// G gives it states, and every one of them already holds of `x` in F_t. Its relations to
    /// the character (FACING, HOLDS) do not count: they are the agent's pose, which acting
    /// changes anyway.
    fn already_done(goal: &ClassGoal, symbol: &str, x: &str, belief: &Belief) -> bool {
        let me: BTreeSet<&str> = goal.symbols.iter().filter(|s| s.kind == "character").map(|s| s.name.as_str()).collect();
        let own: Vec<_> = goal.literals.iter().filter(|l| l.args.iter().any(|a| a == symbol)).collect();
        let states: Vec<_> = own.iter().filter(|l| l.args.len() == 1).collect();
        // A symbol G relates to another object (a dishwasher things go into) is not decided here.
        !states.is_empty()
            && own.iter().all(|l| l.args.iter().all(|a| a == symbol || me.contains(a.as_str())))
            && states.iter().all(|l| belief.holds(&l.predicate.to_ascii_uppercase(), &[x]) == Some(!l.negated))
    }

    /// The perceived rooms the task sentence names ([`Ontology::sentence_names`]: "go to the
    /// living room" names `home_office`, by the benchmark's own table of names).
    fn named_rooms(&self, goal: &ClassGoal, belief: &Belief) -> BTreeSet<String> {
        belief.places.iter().filter(|r| self.ontology.sentence_names(&goal.sentence, class_of(r))).cloned().collect()
    }

    /// The classes of context the task sentence names: F_str's classes it names
    /// ([`Ontology::sentence_classes`]) other than body parts and G's own classes under any of
    /// their names ("the pot" names `pot` and, by EAI's table, `sauce_pan`; "watching TV from
    /// the sofa" names the sofa). Read once per sentence.
    fn context_classes(&self, goal: &ClassGoal) -> BTreeSet<String> {
        let compute = || {
            let own = self.objects_to_find(goal);
            let mut classes = self.ontology.sentence_classes(&goal.sentence);
            classes.retain(|c| !own.iter().any(|o| self.ontology.same_class(o, c)) && !self.has(c, "body_part"));
            classes
        };
        let (sentence, classes) = self.context.get_or_init(|| (goal.sentence.clone(), compute()));
        if *sentence == goal.sentence { classes.clone() } else { compute() }
    }

    /// Room → how many of the `context` classes have an instance seen in it: the objects a
    /// sentence places the task among ("from the sofa") say which of two televisions it means.
    fn context_rooms(context: &BTreeSet<String>, belief: &Belief) -> BTreeMap<String, usize> {
        if context.is_empty() {
            return BTreeMap::new();
        }
        let mut classes: BTreeMap<String, BTreeSet<&String>> = BTreeMap::new();
        for y in Self::instances(belief) {
            let Some(class) = context.get(class_of(&y)) else { continue };
            for r in belief.places.iter().filter(|r| belief.holds(IN_ROOM, &[&y, r]) == Some(true)) {
                classes.entry(r.clone()).or_default().insert(class);
            }
        }
        classes.into_iter().map(|(r, c)| (r, c.len())).collect()
    }

    /// The [`Self::context_rooms`] count of the room `x` is (a place) or was seen in.
    fn context_score(x: &str, rooms: &BTreeMap<String, usize>, belief: &Belief) -> usize {
        let room = if belief.places.iter().any(|r| r == x) {
            Some(x)
        } else {
            belief.places.iter().find(|r| belief.holds(IN_ROOM, &[x, r]) == Some(true)).map(String::as_str)
        };
        room.and_then(|r| rooms.get(r)).copied().unwrap_or(0)
    }

    /// Whether `x` is one of `rooms` or was seen in one of them.
    fn in_rooms(x: &str, rooms: &BTreeSet<String>, belief: &Belief) -> bool {
        rooms.contains(x) || rooms.iter().any(|r| belief.holds(IN_ROOM, &[x, r]) == Some(true))
    }

    /// Symbol → the perceived instance β binds it to: a distinct instance of the symbol's class
    /// and not in `set_aside` (a hand-over proved the goal unreachable with it: [`Record::set_aside`]),
    /// one G does not already describe ([`Self::already_done`]) first, then one in a room the
    /// task sentence names ([`Self::named_rooms`]: the instruction says where the task is done),
    /// then one in the room with the most classes of context the sentence names
    /// ([`Self::context_classes`], [`Self::context_rooms`]: the things it says the task is done
    /// among), then the lowest id; and whether every symbol found such an instance and, unless
    /// every named room has been entered, found it in a named room, and, where the sentence
    /// names no room, unless every room has been entered, found it where some class of context
    /// was seen (Ready; with named rooms the sweep would open their containers first, looking
    /// for context a container may hide).
    fn bind(&self, goal: &ClassGoal, belief: &Belief, set_aside: &BTreeSet<String>) -> (BTreeMap<String, String>, bool) {
        let named = self.named_rooms(goal, belief);
        let context = self.context_classes(goal);
        let context_rooms = Self::context_rooms(&context, belief);
        let mut instances: Vec<String> = Self::instances(belief).into_iter().filter(|x| !set_aside.contains(x)).collect();
        instances.extend(belief.places.iter().filter(|x| !set_aside.contains(*x)).cloned());
        instances.sort_by_cached_key(|x| {
            let score = Self::context_score(x, &context_rooms, belief);
            (!Self::in_rooms(x, &named, belief), std::cmp::Reverse(score), split_name(x).map_or(u32::MAX, |(_, id)| id))
        });
        let named_entered = named.iter().all(|r| self.entered.contains(r));
        let all_entered = belief.places.iter().all(|r| self.entered.contains(r));
        let mut taken = BTreeSet::new();
        let mut out = BTreeMap::new();
        let mut ready = true;
        for s in &goal.symbols {
            if s.kind == "character" {
                out.insert(s.name.clone(), ME.to_string());
                continue;
            }
            let Some(class) = &s.class else { continue };
            let free: Vec<&String> = instances.iter().filter(|x| class_of(x) == class && !taken.contains(*x)).collect();
            let pick = match free.iter().find(|x| !Self::already_done(goal, &s.name, x, belief)) {
                Some(x) => {
                    ready &= named_entered || Self::in_rooms(x, &named, belief);
                    ready &= !named.is_empty() || all_entered || context.is_empty() || Self::context_score(x, &context_rooms, belief) > 0;
                    Some(*x)
                }
                None => {
                    ready = false;
                    free.first().copied()
                }
            };
            if let Some(x) = pick {
                taken.insert(x.clone());
                out.insert(s.name.clone(), x.clone());
            }
        }
        (out, ready)
    }
}

/// `<plate> (1001)` (a script line's argument) → `plate (1001)`.
fn script_name(arg: &str) -> String {
    arg.trim().replacen('<', "", 1).replacen('>', "", 1)
}

impl Adapter for VirtualhomeAdapter {
    fn observe(&mut self, observation: &Observation, step: usize, belief: &mut Belief) {
        let (rooms, percepts) = perceive_virtualhome(&observation.text, step, belief);
        belief.add_places(&rooms);
        belief.admit(&percepts);
        self.entered.extend(Self::room_now(belief));
    }

    fn skills(&self, goal: &ClassGoal, belief: &Belief, record: &Record) -> Skills {
        let mut list = Vec::new();
        let mut sweep = None;
        let closed = self.closed_containers(belief, record);
        for (x, _) in closed.iter().filter(|(x, _)| belief.holds("CLOSE", &[ME, x]) == Some(true)) {
            sweep.get_or_insert(list.len());
            list.push(Skill::Open(x.clone()));
        }
        let opened = Self::targets(record, "[OPEN] ");
        let closed_before = Self::attempted(record, "[CLOSE] ");
        for x in opened.iter().filter(|x| {
            belief.holds("OPEN", &[x]) == Some(true) && belief.holds("CLOSE", &[ME, x]) == Some(true) && !closed_before.contains(*x)
        }) {
            list.push(Skill::Close(x.clone()));
        }
        let walked = Self::attempted(record, "[WALK] ");
        let goal_classes = self.objects_to_find(goal);
        let named_rooms = self.named_rooms(goal, belief);
        let here = |x: &&String| Self::in_rooms(x, &named_rooms, belief);
        let (goal_containers, others): (Vec<&String>, Vec<&String>) = closed
            .iter()
            .map(|(x, _)| x)
            .filter(|x| belief.holds("CLOSE", &[ME, x]) != Some(true) && !walked.contains(*x))
            .partition(|x| goal_classes.iter().any(|c| c == class_of(x)));
        let (goal_containers_named, goal_containers_elsewhere): (Vec<&String>, Vec<&String>) = goal_containers.into_iter().partition(here);
        let (mut others_named, mut others_elsewhere): (Vec<&String>, Vec<&String>) = others.into_iter().partition(here);
        // A container whose class the sentence names ("a cup from the cupboard") first.
        for list in [&mut others_named, &mut others_elsewhere] {
            list.sort_by_cached_key(|x| !self.ontology.sentence_names(&goal.sentence, class_of(x)));
        }
        let (rooms_named, rooms_other): (Vec<&String>, Vec<&String>) =
            belief.places.iter().filter(|r| !self.entered.contains(*r)).partition(|r| named_rooms.contains(*r));
        // A closed container of a class G names first (the plan goes there anyway), those in a
        // room the task sentence names before the named rooms, the others after them (one
        // seen where no room is known yet may be in one); what is in the named rooms before
        // the other rooms and theirs.
        for x in goal_containers_named
            .into_iter()
            .chain(rooms_named)
            .chain(goal_containers_elsewhere)
            .chain(others_named)
            .chain(rooms_other)
            .chain(others_elsewhere)
        {
            sweep.get_or_insert(list.len());
            list.push(Skill::Goto(x.clone()));
        }
        if Self::look_target(belief).is_some_and(|x| belief.holds("CLOSE", &[ME, &x]) != Some(true)) {
            list.push(Skill::Look);
        }
        list.push(Skill::Done);
        Skills { list, sweep }
    }

    fn commands(&self, skill: &Skill, _goal: &ClassGoal, belief: &Belief, _record: &Record) -> Vec<String> {
        let line = |verb: &str, x: &str| match split_name(x) {
            Some((class, id)) => format!("[{verb}] <{class}> ({id})"),
            None => format!("{} {x}", verb.to_lowercase()),
        };
        // A sitting or lying character cannot walk: it stands up first.
        let seated = belief.holds("SITTING", &[ME]) == Some(true) || belief.holds("LYING", &[ME]) == Some(true);
        let walk = |x: &str| if seated { vec!["[STANDUP]".to_string(), line("WALK", x)] } else { vec![line("WALK", x)] };
        match skill {
            Skill::Goto(x) => walk(x),
            Skill::Open(x) => vec![line("OPEN", x)],
            Skill::Close(x) => vec![line("CLOSE", x)],
            Skill::Look => Self::look_target(belief).map(|x| walk(&x)).unwrap_or_default(),
            Skill::Done => Vec::new(),
        }
    }

    /// Arriving at a closed container not yet opened: open it.
    fn follow_up(&self, skill: &Skill, belief: &Belief, record: &Record) -> Option<String> {
        let Skill::Goto(x) = skill else { return None };
        let (class, id) = split_name(x)?;
        (belief.holds("CLOSE", &[ME, x]) == Some(true) && self.openable(x, belief) && !Self::attempted(record, "[OPEN] ").contains(x))
            .then(|| format!("[OPEN] <{class}> ({id})"))
    }

    fn ready(&self, goal: &ClassGoal, belief: &Belief, record: &Record) -> bool {
        self.bind(goal, belief, &record.set_aside).1
    }

    /// The facts that hold about instances of the goal's classes, the containers' CLOSED and
    /// OPEN, and the room the agent is in (a scene shows hundreds of facts; the prompt's belief
    /// is what bears on the goal, as in the paper's example).
    fn belief_lines(&self, goal: &ClassGoal, belief: &Belief) -> Vec<String> {
        let classes = self.objects_to_find(goal);
        belief
            .facts()
            .iter()
            .filter(|f| f.holds)
            .filter(|f| {
                f.args.iter().any(|a| classes.iter().any(|c| c == class_of(a)))
                    || (matches!(f.predicate.as_str(), "CLOSED" | "OPEN") && self.has(&f.args[0], "containers"))
                    || (f.predicate == "INSIDE" && f.args[0] == ME)
            })
            .map(Fact::to_string)
            .collect()
    }

    fn objects_to_find(&self, goal: &ClassGoal) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for s in goal.symbols.iter().filter(|s| s.kind != "character") {
            if let Some(c) = &s.class
                && !out.contains(c)
            {
                out.push(c.clone());
            }
        }
        out
    }
}

impl Handing for VirtualhomeAdapter {
    fn handover(&mut self, goal: &ClassGoal, exploration: &Exploration, _steps: &[StepRecord]) -> Result<Grounded, String> {
        let belief = &exploration.belief;
        let (beta, _) = self.bind(goal, belief, &exploration.record.set_aside);
        let instances = Self::instances(belief);
        let mut names: BTreeSet<String> = instances.clone();
        names.extend(belief.places.iter().cloned());
        let used: BTreeSet<u32> = names.iter().filter_map(|n| split_name(n).map(|(_, id)| id)).collect();
        let me = (1..).find(|id| !used.contains(id)).unwrap_or(u32::MAX);
        let id_of = |name: &str| if name == ME { Some(me) } else { split_name(name).map(|(_, id)| id) };
        let me_states: Vec<&str> = ["SITTING", "LYING"].into_iter().filter(|s| belief.holds(s, &[ME]) == Some(true)).collect();
        let mut nodes = vec![json!({"id": me, "class_name": "character", "category": "Characters", "properties": [], "states": me_states})];
        for n in &names {
            let Some((class, id)) = split_name(n) else { continue };
            let room = belief.places.contains(n);
            let properties: Vec<String> =
                self.ontology.affordances.get(class).map(|a| a.iter().map(|p| p.to_ascii_uppercase()).collect()).unwrap_or_default();
            let states: Vec<&str> = NodeState::ALL.iter().map(|s| s.as_str()).filter(|s| belief.holds(s, &[n]) == Some(true)).collect();
            nodes.push(json!({"id": id, "class_name": class, "category": if room { "Rooms" } else { "" },
                "properties": if room { Vec::new() } else { properties }, "states": states}));
        }
        let mut edges = Vec::new();
        for f in belief.facts().iter().filter(|f| f.holds && f.args.len() == 2) {
            let (Some(a), Some(b)) = (id_of(&f.args[0]), id_of(&f.args[1])) else { continue };
            match f.predicate.as_str() {
                "ON" | "INSIDE" | "HOLDS_RH" | "HOLDS_LH" => edges.push(json!({"from_id": a, "relation_type": f.predicate, "to_id": b})),
                // The room a node was seen in, as the graph's room edge.
                IN_ROOM => edges.push(json!({"from_id": a, "relation_type": "INSIDE", "to_id": b})),
                "CLOSE" => {
                    edges.push(json!({"from_id": a, "relation_type": "CLOSE", "to_id": b}));
                    edges.push(json!({"from_id": b, "relation_type": "CLOSE", "to_id": a}));
                }
                _ => {}
            }
        }
        // G with β: node goals, edge goals, and the action groups in order.
        let bound = |symbol: &str| -> Result<(u32, String), String> {
            let name = beta.get(symbol).ok_or_else(|| format!("β: no perceived instance for the goal's `{symbol}`"))?;
            Ok((id_of(name).unwrap_or(me), if name == ME { "character".into() } else { class_of(name).to_string() }))
        };
        let mut goals = Vec::new();
        for l in &goal.literals {
            match l.args.as_slice() {
                [x] => {
                    let (id, class) = bound(x)?;
                    goals.push(json!({"id": id, "class_name": class, "state": l.predicate.to_ascii_uppercase()}));
                }
                [x, y] => {
                    let ((a, _), (b, _)) = (bound(x)?, bound(y)?);
                    goals.push(json!({"from_id": a, "relation_type": l.predicate.to_ascii_uppercase(), "to_id": b}));
                }
                _ => return Err(format!("goal literal {}({}) has no VirtualHome counterpart", l.predicate, l.args.join(", "))),
            }
        }
        let task_json = json!({
            "task_id": "perceived", "task_name": goal.family, "description": "",
            "vh_goal": {"goal": goals, "actions": goal.actions},
            "init_graph": {"nodes": nodes, "edges": edges},
        });
        let task = VirtualhomeTask::from_json(&task_json.to_string(), "the perceived scene").map_err(|e| e.to_string())?;
        // Action goals: the perceived objects whose class affords a verb of them, for each group
        // of alternatives that no object G binds already affords (a remote control G has the
        // agent hold can be touched; every movable object of the scene would ground a million
        // actions, EAI 188_1).
        let affords = |x: &str, verb: &str| {
            VERB_AFFORDANCES.iter().find(|(v, _)| *v == verb).is_none_or(|(_, needs)| needs.iter().any(|n| self.has(x, n)))
                || (verb == "TYPE" && class_of(x) == "keyboard")
        };
        let bound_objects: Vec<&String> = goal.symbols.iter().filter(|s| s.kind != "character").filter_map(|s| beta.get(&s.name)).collect();
        let mut classes: BTreeSet<String> = BTreeSet::new();
        for group in &goal.actions {
            let verbs: Vec<String> = group.split('|').map(|v| v.to_uppercase().replace(' ', "")).collect();
            // POUR takes two objects (what is poured, where to): one bound object is not enough.
            let known = |v: &String| v != "POUR" && VERB_AFFORDANCES.iter().any(|(verb, _)| verb == v);
            if verbs.iter().all(known) && bound_objects.iter().any(|x| verbs.iter().any(|v| affords(x, v))) {
                continue;
            }
            for x in instances.iter().filter(|x| verbs.iter().any(|v| affords(x, v))) {
                classes.insert(class_of(x).to_string());
            }
        }
        // G has the left hand hold something and says nothing of the right: GRAB fills the right
        // hand first, so a plan needs something else to hold there; the grabbable objects seen in
        // the room of the left hand's object join the problem.
        if !goal.literals.iter().any(|l| l.predicate == "holds_rh") {
            for l in goal.literals.iter().filter(|l| l.predicate == "holds_lh") {
                let Some(x) = l.args.get(1).and_then(|s| beta.get(s)) else { continue };
                let rooms: Vec<&String> = belief.places.iter().filter(|r| belief.holds(IN_ROOM, &[x, r]) == Some(true)).collect();
                for y in instances.iter().filter(|y| self.has(y, "grabbable")) {
                    if rooms.iter().any(|r| belief.holds(IN_ROOM, &[y, r]) == Some(true)) {
                        classes.insert(class_of(y).to_string());
                    }
                }
            }
        }
        let classes: Vec<&str> = classes.iter().map(String::as_str).collect();
        let problem = vh_pddl::problem(&task, &classes).map_err(|e| e.to_string())?;
        let model = ground(&self.domain, &problem.text)?;
        let spelling = Spelling::virtualhome(model.task());
        let by_id: BTreeMap<u32, &String> = names.iter().filter_map(|n| split_name(n).map(|(_, id)| (id, n))).collect();
        let binding = problem
            .objects
            .iter()
            .map(|(pddl, id)| {
                (pddl.clone(), if *id == me { ME.to_string() } else { by_id.get(id).map_or_else(|| id.to_string(), |n| (*n).clone()) })
            })
            .collect();
        let handover = Handover { problem: problem.text.clone(), binding };
        self.last = Some((problem, task));
        Ok(Grounded::new(handover, model, spelling))
    }

    fn command(&self, grounded: &Grounded, action: ActionId) -> Result<Option<String>, String> {
        let (problem, task) = self.last.as_ref().ok_or("no hand-over yet")?;
        problem.script_line(&task.init, &grounded.model.task().action_name(action)).map(Some)
    }

    fn judge_view(&self, fact: &Fact) -> Option<JudgeAtom> {
        (fact.args.first().is_some_and(|a| a != ME)).then(|| JudgeAtom { predicate: fact.predicate.clone(), args: fact.args.clone() })
    }

    fn class_of<'a>(&self, name: &'a str) -> &'a str {
        class_of(name)
    }

    fn locates(&self, atom: &JudgeAtom) -> bool {
        matches!(atom.predicate.as_str(), "inside" | "on" | "in_room") && atom.args.get(1).is_some_and(|t| !t.is_empty())
    }
}

/// The class-level goal's JSON value, for records.
pub fn goal_value(goal: &ClassGoal) -> Value {
    json!({"family": goal.family, "literals": goal.literals.iter().map(|l| format!("{}({})", l.predicate, l.args.join(", "))).collect::<Vec<_>>(), "actions": goal.actions})
}
