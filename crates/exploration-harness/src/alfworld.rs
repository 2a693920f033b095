//! The agent on ALFWorld, with the systematic explorer (a control of this project's, not the
//! paper's: Phase I's controller alone, no model) or a model's policy: explore until Ready, write ŝ0 as a PDDL problem of ALFWorld's own domain from
//! what was perceived (the hand-over, Eq. 4), plan it with the caller's Phase II, bind the plan
//! back to perceived names through β and run it open-loop in the environment, whose goal check
//! alone says whether the episode succeeded.
//!
//! Rules, each where it is implemented:
//! - the controller H (systematic): the places of the room listing, in its order, that are
//!   worth inspecting (F_str says their class can hold an object class the goal still lacks,
//!   where that class can be picked up at all,
//!   or the goal names their class and none of it was visited); each: `go to` it (`examine`
//!   where the agent already stands there), and `open` it when the observation says it is
//!   closed (the `goto` skill's follow-up, whoever chose it); the sweep ends when Ready holds
//!   or no such place is left;
//! - Ready(F, G) ([`ready`]): every object symbol of G has a distinct perceived instance of its
//!   class; every receptacle symbol of G a place of its class that ŝ0 can use: a visited one,
//!   or one the room listing names whose class F_str decides (never openable, or openable in
//!   every training game), as ŝ0 writes it. A place of a class whose instances disagree
//!   (cabinets, drawers) must be visited first: only then is it known to open or not. Before,
//!   every receptacle symbol waited for a visit, and SmolLM2 spent 52 of 55 steps opening
//!   cabinets while only the dining table, where the plan goes anyway, held Ready back;
//! - ŝ0 ([`write_problem`]): F_τ (perceived contents, open/closed, what is held) and F_str
//!   (class affordances and `canContain` of [`Ontology`]) over perceived names (`mug 2` is
//!   `mug_2`), one location per place (`loc_countertop_1`) and `loc_start`; G is the game's
//!   goal formula as written (class-level: it names types, never instances). A visited place
//!   is openable when an observation said it is open or closed; an unvisited one is used only
//!   when F_str decides its class (never openable, or openable and then taken as closed);
//! - β ([`Handover::binding`]): PDDL name → perceived name; plan steps are spelled by the
//!   game's grammar (`transition_model::Spelling::alfworld_with_names`) with those names
//!   (`take mug 2 from countertop 1`).
//! - Places that share a location (a drawer under a desk): the game answers a `go to` one of
//!   them from the other with "Nothing happens." ([`colocated`] learns it from R_t, Phase I's
//!   steps and the plan's); Phase I's `goto` then examines the place ([`Adapter::recover`]),
//!   ŝ0 gives the places one location, and a plan's move from a location to itself is not
//!   sent. Nothing else tells the agent which places share one: it never sees the game's
//!   admissible commands.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use grounding::ActionId;
use household_sim::{GoalAnnotation, JudgeAtom, NOTHING_HAPPENS, Observation};
use transition_model::Spelling;

use crate::episode::{Grounded, Handover, ground};
use crate::evidence::{Belief, Fact, perceive_alfworld};
use crate::goal::ClassGoal;
use crate::ontology::Ontology;
use crate::phase1::{Adapter, Record, Skill, Skills, StepRecord};

/// The perceived class of a name: `mug 2` → `mug`.
pub fn class_of(name: &str) -> &str {
    name.rsplit_once(' ').map_or(name, |(class, n)| if n.chars().all(|c| c.is_ascii_digit()) { class } else { name })
}

/// A PDDL name for a perceived one: `mug 2` → `mug_2`.
pub fn pddl_name(name: &str) -> String {
    name.replace(' ', "_")
}

/// Ready(F, G).
pub fn ready(goal: &ClassGoal, belief: &Belief, ontology: &Ontology) -> bool {
    let objects: Vec<String> = belief
        .facts()
        .into_iter()
        .filter(|f| f.predicate == "inReceptacle" && f.holds)
        .map(|f| f.args[0].clone())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let mut needed: BTreeMap<&str, usize> = BTreeMap::new();
    for s in &goal.symbols {
        match (s.kind.as_str(), &s.class) {
            ("object", Some(class)) => *needed.entry(class.as_str()).or_default() += 1,
            ("receptacle", Some(class)) if !belief.places.iter().any(|p| class_of(p) == class && usable(ontology, belief, p)) => {
                return false;
            }
            _ => {}
        }
    }
    needed.into_iter().all(|(class, n)| objects.iter().filter(|o| class_of(o) == class).count() >= n)
}

/// Whether ŝ0 can use `place` ([`write_problem`]): it was visited (its openness is known), or
/// F_str decides whether its class opens.
fn usable(ontology: &Ontology, belief: &Belief, place: &str) -> bool {
    belief.holds("visited", &[place]) == Some(true) || ontology.openness_decided(class_of(place))
}

/// Whether the sweep should inspect `place`: its class can hold (F_str's `canContain`) an
/// object class the goal still lacks an instance of (any place, for a class that cannot be
/// picked up), or it is of a receptacle class the goal
/// names and no place of that class has been visited yet.
fn worth_inspecting(goal: &ClassGoal, ontology: &Ontology, belief: &Belief, place: &str) -> bool {
    let class = class_of(place);
    let found: Vec<String> =
        belief.facts().into_iter().filter(|f| f.predicate == "inReceptacle" && f.holds).map(|f| f.args[0].clone()).collect();
    let mut needed: BTreeMap<&str, usize> = BTreeMap::new();
    for s in &goal.symbols {
        match (s.kind.as_str(), s.class.as_deref()) {
            ("object", Some(c)) => *needed.entry(c).or_default() += 1,
            ("receptacle", Some(c))
                if c == class && !belief.places.iter().any(|p| class_of(p) == c && belief.holds("visited", &[p]) == Some(true)) =>
            {
                return true;
            }
            _ => {}
        }
    }
    needed.into_iter().any(|(c, n)| {
        let have = found.iter().filter(|o| class_of(o) == c).collect::<BTreeSet<_>>().len();
        // `canContain` speaks of what can be put somewhere: an object class that cannot be
        // picked up (a desk lamp) may stand on any place.
        let movable = ontology.affordances.get(c).is_some_and(|a| a.contains("pickupable"));
        have < n && (!movable || ontology.can_contain.contains(&(class.to_string(), c.to_string())))
    })
}

/// The place an executed step leaves the agent at: the target of a `go to`, or of an `examine`
/// (the agent sends `examine` only for places).
fn place_reached(step: &StepRecord) -> Option<&str> {
    step.command.strip_prefix("go to ").or_else(|| step.command.strip_prefix("examine ")).filter(|_| step.executed)
}

/// The places R_t shows to share a location, each mapped to its group's first name (sorted);
/// places in no group are absent. A `go to p` the game answered "Nothing happens." while the
/// agent stood at q puts p and q in one group: ALFWorld executes a `go to` every listed place
/// but those at the agent's own location.
pub fn colocated(steps: &[StepRecord]) -> BTreeMap<String, String> {
    let mut groups: Vec<BTreeSet<String>> = Vec::new();
    let mut at: Option<&str> = None;
    for step in steps {
        if step.executed {
            at = place_reached(step).or(at);
            continue;
        }
        let (Some(p), Some(q)) = (step.command.strip_prefix("go to "), at) else { continue };
        if p == q || step.observation.trim() != NOTHING_HAPPENS {
            continue;
        }
        let mut joined: BTreeSet<String> = [p.to_string(), q.to_string()].into();
        groups.retain(|g| {
            let touches = g.contains(p) || g.contains(q);
            if touches {
                joined.extend(g.iter().cloned());
            }
            !touches
        });
        groups.push(joined);
    }
    let mut out = BTreeMap::new();
    for group in groups {
        let first = group.first().cloned().unwrap_or_default();
        out.extend(group.into_iter().map(|p| (p, first.clone())));
    }
    out
}

/// Writes ŝ0 (F_τ ∪ F_str, and G as the game's goal formula) as a problem of ALFWorld's domain,
/// over perceived names; `at`: the place the agent stands at (else `loc_start`); `shared`:
/// places known to share a location ([`colocated`]), which get one.
pub fn write_problem(
    belief: &Belief,
    ontology: &Ontology,
    goal_formula: &str,
    at: Option<&str>,
    shared: &BTreeMap<String, String>,
) -> Handover {
    let location = |place: &str| format!("loc_{}", pddl_name(shared.get(place).map_or(place, String::as_str)));
    let mut binding = BTreeMap::new();
    let facts = belief.facts();
    let mut objects: BTreeSet<String> = BTreeSet::new();
    for f in &facts {
        if f.predicate == "inReceptacle" || f.predicate == "holds" {
            objects.insert(f.args[0].clone());
        }
    }
    // Type constants: receptacle classes (places, the first of canContain) are rtype, the rest otype.
    let mut rtypes: BTreeSet<String> = ontology.can_contain.iter().map(|(r, _)| r.clone()).collect();
    rtypes.extend(belief.places.iter().map(|p| class_of(p).to_string()));
    rtypes.extend(["sinkbasin", "microwave", "fridge"].map(String::from));
    let mut otypes: BTreeSet<String> = ontology.can_contain.iter().map(|(_, o)| o.clone()).collect();
    otypes.extend(objects.iter().map(|o| class_of(o).to_string()));
    otypes.extend(["knife", "butterknife"].map(String::from));
    let lower = goal_formula.to_ascii_lowercase();
    for (predicate, set) in [("objecttype", &mut otypes), ("receptacletype", &mut rtypes)] {
        for part in lower.split(&format!("({predicate} ")).skip(1) {
            if let Some(constant) = part.split(|c: char| c == ')' || c.is_whitespace()).nth(1) {
                set.insert(constant.trim_end_matches("type").to_string());
            }
        }
    }
    otypes.retain(|o| !rtypes.contains(o));

    let mut text = String::new();
    let _ = writeln!(text, "; ŝ0 written by exploration-harness from what the agent perceived.");
    let _ = writeln!(text, "(define (problem grounded)\n  (:domain alfred)\n  (:objects\n    agent1 - agent\n    loc_start - location");
    // Places the plan may use: visited ones (their openness is known: stated closed or open,
    // or never said, so not openable), and unvisited ones whose class F_str decides: never
    // openable, or openable in every training game (then closed until seen open). Unvisited
    // places of a class whose instances disagree (cabinets, drawers) are left out.
    let openable_class = |class: &str| ontology.affordances.get(class).is_some_and(|a| a.contains("openable"));
    let visited = |p: &str| belief.holds("visited", &[p]) == Some(true);
    let places: Vec<&String> = belief.places.iter().filter(|p| usable(ontology, belief, p)).collect();
    let mut locations = BTreeSet::new();
    for p in &places {
        let name = pddl_name(p);
        binding.insert(name.clone(), p.to_string());
        let _ = writeln!(text, "    {name} - receptacle");
        let loc = location(p);
        if locations.insert(loc.clone()) {
            let _ = writeln!(text, "    {loc} - location");
        }
    }
    for o in &objects {
        let name = pddl_name(o);
        binding.insert(name.clone(), o.clone());
        let _ = writeln!(text, "    {name} - object");
    }
    for t in &rtypes {
        let _ = writeln!(text, "    {t}type - rtype");
    }
    for t in &otypes {
        let _ = writeln!(text, "    {t}type - otype");
    }
    let _ = writeln!(text, "  )\n  (:init");
    let start = at.map_or_else(|| "loc_start".to_string(), location);
    let _ = writeln!(text, "    (atLocation agent1 {start})");
    let affordances = |class: &str| ontology.affordances.get(class).cloned().unwrap_or_default();
    for p in &places {
        let name = pddl_name(p);
        let class = class_of(p);
        let _ = writeln!(text, "    (receptacleAtLocation {name} {})\n    (receptacleType {name} {class}type)", location(p));
        if belief.holds("opened", &[p]).is_some() || (!visited(p) && openable_class(class)) {
            let _ = writeln!(text, "    (openable {name})");
        }
        if belief.holds("opened", &[p]) == Some(true) {
            let _ = writeln!(text, "    (opened {name})");
        }
    }
    for f in facts.iter().filter(|f| f.holds) {
        match f.predicate.as_str() {
            "inReceptacle" => {
                let (o, r) = (pddl_name(&f.args[0]), pddl_name(&f.args[1]));
                let _ = writeln!(text, "    (inReceptacle {o} {r})\n    (objectAtLocation {o} {})", location(&f.args[1]));
            }
            "holds" => {
                let _ = writeln!(text, "    (holds agent1 {})\n    (holdsAny agent1)", pddl_name(&f.args[0]));
            }
            "isToggled" | "isHot" | "isCool" | "isClean" => {
                let _ = writeln!(text, "    ({} {})", f.predicate, pddl_name(&f.args[0]));
            }
            _ => {}
        }
    }
    for o in &objects {
        let class = class_of(o);
        let _ = writeln!(text, "    (objectType {} {class}type)", pddl_name(o));
        for a in affordances(class) {
            if a != "openable" {
                let _ = writeln!(text, "    ({a} {})", pddl_name(o));
            }
        }
    }
    for (r, o) in &ontology.can_contain {
        if rtypes.contains(r) && otypes.contains(o) {
            let _ = writeln!(text, "    (canContain {r}type {o}type)");
        }
    }
    let _ = writeln!(text, "  )\n  (:goal {goal_formula})\n)");
    Handover { problem: text, binding }
}

/// Schemas of ALFWorld's domain that change nothing in the game (they only look): a plan step
/// of one is not sent.
const LOOKING: &[&str] = &["look", "inventory", "examinereceptacle", "examineobject", "help"];

/// ALFWorld's side of Phase I and of the hand-over.
///
/// - K_t: `open X` when the agent stands at X, an observation said X is closed and Phase I has
///   not opened X before; `close X` when it stands at X, X is open and Phase I has not closed X
///   before (what is inside was seen: opening again shows nothing new); `goto X` for every
///   listed place not yet visited, those
///   worth inspecting first (F_str says their class can hold an object class the goal still
///   lacks, or the goal names their class and none was visited; among them places F_str says
///   are never openable first, since they show their contents in one step), then places the
///   model's hypotheses name, then the rest in the room listing's order; `look` where the agent
///   stands at a place it has not examined; `done`. No skill but `done` can thus target the same
///   place twice, and no choice of a model's makes Phase I circle.
/// - The sweep: `open` the place it stands at if closed, else the first place worth inspecting.
/// - Commands: `goto X` is `go to X`, then `examine X` if the game answered "Nothing happens."
///   (the agent stands at X's location already: [`colocated`]); `look` is `examine X` of the
///   place it stands at (another view: ALFWorld's text states a place's contents in full, so the
///   temporary pickup that tests a hypothesis elsewhere is never needed here).
pub struct AlfworldAdapter {
    /// F_str: ALFWorld's class-level ontology (affordances, `canContain` pairs).
    pub ontology: Ontology,
    /// The ALFWorld domain (`alfred.pddl`) that ŝ0 is written and grounded in.
    pub domain: pddl_syntax::Domain,
    /// The game's command grammar (`alfred.twl2`).
    pub grammar: String,
    /// The game's goal formula (class level: it names types, never instances).
    pub formula: String,
}

impl std::fmt::Debug for AlfworldAdapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AlfworldAdapter").field("formula", &self.formula).finish_non_exhaustive()
    }
}

impl AlfworldAdapter {
    /// An adapter for one game: `grammar` is the game's `alfred.twl2`, and only the goal
    /// formula of `annotation` is kept.
    pub fn new(ontology: Ontology, domain: pddl_syntax::Domain, grammar: String, annotation: &GoalAnnotation) -> AlfworldAdapter {
        AlfworldAdapter { ontology, domain, grammar, formula: annotation.formula.clone() }
    }

    /// The place the agent stands at: where the last step that moved it left it.
    fn at(steps: &[StepRecord]) -> Option<String> {
        steps.iter().rev().find_map(place_reached).map(str::to_string)
    }
}

/// Whether R_t holds `command`, executed or not: what failed once would fail again.
fn tried(record: &Record, command: &str) -> bool {
    record.steps.iter().any(|s| s.command == command)
}

impl Adapter for AlfworldAdapter {
    fn observe(&mut self, observation: &Observation, step: usize, belief: &mut Belief) {
        let (places, percepts) = perceive_alfworld(&observation.text, step);
        belief.add_places(&places);
        belief.admit(&percepts);
    }

    fn skills(&self, goal: &ClassGoal, belief: &Belief, record: &Record) -> Skills {
        let mut list = Vec::new();
        let mut sweep = None;
        let at = Self::at(&record.steps);
        let sent = |command: String| tried(record, &command);
        if let Some(p) = &at {
            match belief.holds("opened", &[p]) {
                Some(false) if !sent(format!("open {p}")) => {
                    sweep = Some(list.len());
                    list.push(Skill::Open(p.clone()));
                }
                Some(true) if !sent(format!("close {p}")) => list.push(Skill::Close(p.clone())),
                _ => {}
            }
        }
        let unvisited: Vec<&String> = belief.places.iter().filter(|p| belief.holds("visited", &[p]) != Some(true)).collect();
        let hinted: BTreeSet<&str> =
            belief.hypotheses().filter(|f| f.predicate == "inReceptacle" && f.args.len() == 2).map(|f| f.args[1].as_str()).collect();
        let (mut worth, rest): (Vec<&String>, Vec<&String>) =
            unvisited.into_iter().partition(|p| worth_inspecting(goal, &self.ontology, belief, p));
        // Cheap looks first: a place F_str says is never openable shows its contents on arrival
        // (one step); an openable one, or one of a class whose instances disagree, may take two.
        let may_open = |p: &str| {
            let class = class_of(p);
            self.ontology.affordances.get(class).is_some_and(|a| a.contains("openable")) || !self.ontology.openness_decided(class)
        };
        worth.sort_by_key(|p| may_open(p));
        let (hint, rest): (Vec<&String>, Vec<&String>) = rest.into_iter().partition(|p| hinted.contains(p.as_str()));
        if sweep.is_none() && !worth.is_empty() {
            sweep = Some(list.len());
        }
        list.extend(worth.into_iter().chain(hint).chain(rest).map(|p| Skill::Goto(p.clone())));
        if at.as_ref().is_some_and(|p| !sent(format!("examine {p}"))) {
            list.push(Skill::Look);
        }
        list.push(Skill::Done);
        Skills { list, sweep }
    }

    fn commands(&self, skill: &Skill, _goal: &ClassGoal, _belief: &Belief, record: &Record) -> Vec<String> {
        match skill {
            Skill::Goto(p) => vec![format!("go to {p}")],
            Skill::Open(p) => vec![format!("open {p}")],
            Skill::Close(p) => vec![format!("close {p}")],
            Skill::Look => Self::at(&record.steps).map(|p| vec![format!("examine {p}")]).unwrap_or_default(),
            Skill::Done => Vec::new(),
        }
    }

    /// A `go to X` the game answered "Nothing happens.": the agent stands at X's location
    /// already, and examining X shows it.
    fn recover(&self, skill: &Skill, record: &Record) -> Option<String> {
        let Skill::Goto(p) = skill else { return None };
        let last = record.steps.last()?;
        (!last.executed && last.command.strip_prefix("go to ") == Some(p.as_str()) && last.observation.trim() == NOTHING_HAPPENS)
            .then(|| format!("examine {p}"))
    }

    /// Arriving at a place seen closed, not yet opened: open it.
    fn follow_up(&self, skill: &Skill, belief: &Belief, record: &Record) -> Option<String> {
        let Skill::Goto(p) = skill else { return None };
        let open = format!("open {p}");
        (Self::at(&record.steps).as_ref() == Some(p) && belief.holds("opened", &[p]) == Some(false) && !tried(record, &open))
            .then_some(open)
    }

    /// ŝ0 states ALFWorld's goal over classes (`exists`), so no hand-over binds a goal symbol
    /// to one instance and none is ever set aside: the record does not enter.
    fn ready(&self, goal: &ClassGoal, belief: &Belief, _record: &Record) -> bool {
        ready(goal, belief, &self.ontology)
    }

    fn objects_to_find(&self, goal: &ClassGoal) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for s in &goal.symbols {
            if let Some(c) = &s.class {
                out.push(c.clone());
            }
        }
        out
    }

    /// The facts that hold, and the places said to be closed (`not opened(cabinet 10)`).
    fn belief_lines(&self, _goal: &ClassGoal, belief: &Belief) -> Vec<String> {
        belief.facts().iter().filter(|f| f.holds || f.predicate == "opened").map(Fact::to_string).collect()
    }
}

impl crate::episode::Handing for AlfworldAdapter {
    fn handover(
        &mut self,
        _goal: &ClassGoal,
        exploration: &crate::phase1::Exploration,
        steps: &[crate::phase1::StepRecord],
    ) -> Result<Grounded, String> {
        let at = Self::at(steps);
        let handover = write_problem(&exploration.belief, &self.ontology, &self.formula, at.as_deref(), &colocated(steps));
        let model = ground(&self.domain, &handover.problem)?;
        let names = model.task().objects.iter().map(|o| handover.binding.get(&o.name).cloned()).collect();
        let spelling = Spelling::alfworld_with_names(model.task(), &self.grammar, names).map_err(|e| format!("grammar: {e}"))?;
        Ok(Grounded::new(handover, model, spelling))
    }

    fn command(&self, grounded: &Grounded, action: ActionId) -> Result<Option<String>, String> {
        let task = grounded.model.task();
        let (schema, args) = (&task.schemas[task.action(action).schema.index()].name, &task.action(action).args);
        if LOOKING.contains(&schema.as_str()) {
            return Ok(None);
        }
        // A move from a location to itself (places ŝ0 puts at one location): the game would
        // answer "Nothing happens.", and the agent is there already.
        if schema == "gotolocation" && args.len() > 2 && args[1] == args[2] {
            return Ok(None);
        }
        let command = grounded
            .spelling
            .spell(action)
            .map(str::to_string)
            .ok_or_else(|| format!("cannot bind {} to perceived names", task.action_name(action)))?;
        Ok(Some(command))
    }

    fn judge_view(&self, fact: &Fact) -> Option<JudgeAtom> {
        match fact.predicate.as_str() {
            "inReceptacle" | "opened" | "isToggled" | "isHot" | "isCool" | "isClean" => {
                Some(JudgeAtom { predicate: fact.predicate.clone(), args: fact.args.clone() })
            }
            _ => None,
        }
    }

    fn class_of<'a>(&self, name: &'a str) -> &'a str {
        class_of(name)
    }

    fn locates(&self, atom: &JudgeAtom) -> bool {
        atom.predicate == "inreceptacle"
    }
}
