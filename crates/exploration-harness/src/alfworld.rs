//! The agent on ALFWorld, with the systematic explorer (the paper's model-free control for
//! Phase I): explore until Ready, write ŝ0 as a PDDL problem of ALFWorld's own domain from
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
//!   closed; the sweep ends when Ready holds or no such place is left;
//! - Ready(F, G) ([`ready`]): every object symbol of G has a distinct perceived instance of its
//!   class, every receptacle symbol with a class a visited place of that class;
//! - ŝ0 ([`write_problem`]): F_τ (perceived contents, open/closed, what is held) and F_str
//!   (class affordances and `canContain` of [`Ontology`]) over perceived names (`mug 2` is
//!   `mug_2`), one location per place (`loc_countertop_1`) and `loc_start`; G is the game's
//!   goal formula as written (class-level: it names types, never instances). A visited place
//!   is openable when an observation said it is open or closed; an unvisited one is used only
//!   when F_str decides its class (never openable, or openable and then taken as closed);
//! - β ([`Handover::binding`]): PDDL name → perceived name; plan steps are spelled by the
//!   game's grammar (`transition_model::Spelling::alfworld_with_names`) with those names
//!   (`take mug 2 from countertop 1`); a `go to` the game does not
//!   list among its admissible commands (the agent already stands at that place's location) is
//!   skipped.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use grounding::ActionId;
use household_sim::{Environment, Event};
use transition_model::{Spelling, TransitionModel};

use crate::evidence::{Belief, perceive_alfworld};
use crate::goal::ClassGoal;
use crate::ontology::Ontology;

/// The perceived class of a name: `mug 2` → `mug`.
pub fn class_of(name: &str) -> &str {
    name.rsplit_once(' ').map_or(name, |(class, n)| if n.chars().all(|c| c.is_ascii_digit()) { class } else { name })
}

/// A PDDL name for a perceived one: `mug 2` → `mug_2`.
pub fn pddl_name(name: &str) -> String {
    name.replace(' ', "_")
}

/// Ready(F, G).
pub fn ready(goal: &ClassGoal, belief: &Belief) -> bool {
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
            ("receptacle", Some(class))
                if !belief.places.iter().any(|p| class_of(p) == class && belief.holds("visited", &[p]) == Some(true)) =>
            {
                return false;
            }
            _ => {}
        }
    }
    needed.into_iter().all(|(class, n)| objects.iter().filter(|o| class_of(o) == class).count() >= n)
}

/// One environment step of an episode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StepRecord {
    pub phase: &'static str,
    pub command: String,
    pub executed: bool,
    pub observation: String,
}

/// ŝ0 and β.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Handover {
    pub problem: String,
    /// PDDL object name → the name the agent perceived.
    pub binding: BTreeMap<String, String>,
}

/// An episode's outcome.
#[derive(Debug, Clone)]
pub struct Episode {
    pub success: bool,
    pub phase1_steps: usize,
    pub plan: Vec<String>,
    pub steps: Vec<StepRecord>,
    pub handover: Option<Handover>,
    /// Why it failed, when it did: `not ready`, `no plan: ...`, `step K not executed: ...`,
    /// `goal not reached`.
    pub failure: Option<String>,
}

/// Phase I with the systematic explorer, within `budget` environment steps; returns the
/// belief and the steps taken. `first` is the reset's observation.
pub fn explore_systematic(
    env: &mut dyn Environment,
    goal: &ClassGoal,
    ontology: &Ontology,
    first: &str,
    budget: usize,
) -> (Belief, Vec<StepRecord>) {
    let mut belief = Belief::default();
    let (places, percepts) = perceive_alfworld(first, 0);
    belief.add_places(&places);
    belief.admit(&percepts);
    let mut steps = Vec::new();
    let mut inspected: BTreeSet<String> = BTreeSet::new();
    let act = |env: &mut dyn Environment, belief: &mut Belief, steps: &mut Vec<StepRecord>, command: String| {
        let result = env.step(&command);
        let (places, percepts) = perceive_alfworld(&result.observation.text, steps.len() + 1);
        belief.add_places(&places);
        belief.admit(&percepts);
        steps.push(StepRecord {
            phase: "explore",
            command,
            executed: matches!(result.event, Event::Executed),
            observation: result.observation.text,
        });
    };
    while steps.len() < budget && !ready(goal, &belief) {
        let Some(place) = belief.places.iter().find(|p| !inspected.contains(*p) && worth_inspecting(goal, ontology, &belief, p)).cloned()
        else {
            break;
        };
        inspected.insert(place.clone());
        // Look: where the agent already stands at the place's location, `go to` is not
        // admissible (it would answer "Nothing happens."); `examine` shows the place instead.
        let go = format!("go to {place}");
        let here = env.admissible_commands().is_some_and(|a| a.iter().any(|c| c.starts_with("go to ")) && !a.contains(&go));
        act(env, &mut belief, &mut steps, if here { format!("examine {place}") } else { go });
        if belief.holds("opened", &[&place]) == Some(false) && steps.len() < budget {
            act(env, &mut belief, &mut steps, format!("open {place}"));
        }
    }
    (belief, steps)
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

/// Writes ŝ0 (F_τ ∪ F_str, and G as the game's goal formula) as a problem of ALFWorld's domain.
pub fn write_problem(belief: &Belief, ontology: &Ontology, goal_formula: &str, at: Option<&str>) -> Handover {
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
    let disputed = |class: &str| ontology.disagreements.get(class).is_some_and(|a| a.contains("openable"));
    let visited = |p: &str| belief.holds("visited", &[p]) == Some(true);
    let places: Vec<&String> = belief.places.iter().filter(|p| visited(p) || !disputed(class_of(p))).collect();
    for p in &places {
        let name = pddl_name(p);
        binding.insert(name.clone(), p.to_string());
        let _ = writeln!(text, "    {name} - receptacle\n    loc_{name} - location");
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
    let start = at.map_or_else(|| "loc_start".to_string(), |p| format!("loc_{}", pddl_name(p)));
    let _ = writeln!(text, "    (atLocation agent1 {start})");
    let affordances = |class: &str| ontology.affordances.get(class).cloned().unwrap_or_default();
    for p in &places {
        let name = pddl_name(p);
        let class = class_of(p);
        let _ = writeln!(text, "    (receptacleAtLocation {name} loc_{name})\n    (receptacleType {name} {class}type)");
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
                let _ = writeln!(text, "    (inReceptacle {o} {r})\n    (objectAtLocation {o} loc_{r})");
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

/// One episode: systematic Phase I, the hand-over, ŝ0 grounded in ALFWorld's `domain`,
/// `plan` (Phase II on that transition model), the plan spelled by the game's `grammar` with
/// the names β gives back, and executed open-loop. `budget`: environment steps for the whole
/// episode (ALFWorld: 55).
pub fn run_episode(
    env: &mut dyn Environment,
    goal: &ClassGoal,
    ontology: &Ontology,
    domain: &pddl_syntax::Domain,
    grammar: &str,
    budget: usize,
    plan: &mut dyn FnMut(&TransitionModel) -> Result<Vec<ActionId>, String>,
) -> Episode {
    let formula = env.goal().formula.clone();
    let first = env.reset().text;
    let (belief, mut steps) = explore_systematic(env, goal, ontology, &first, budget);
    let phase1_steps = steps.len();
    let mut episode = Episode { success: false, phase1_steps, plan: Vec::new(), steps: Vec::new(), handover: None, failure: None };
    if !ready(goal, &belief) {
        episode.failure = Some("not ready: Phase I did not find every object the goal needs".into());
        episode.steps = steps;
        return episode;
    }
    let at = steps.iter().rev().find(|s| s.executed && s.command.starts_with("go to ")).map(|s| s.command["go to ".len()..].to_string());
    let handover = write_problem(&belief, ontology, &formula, at.as_deref());
    let planned = ground(domain, &handover.problem).and_then(|model| {
        let actions = plan(&model).map_err(|e| format!("no plan: {e}"))?;
        let names = model.task().objects.iter().map(|o| handover.binding.get(&o.name).cloned()).collect();
        let spelling = Spelling::alfworld_with_names(model.task(), grammar, names).map_err(|e| format!("grammar: {e}"))?;
        let task = model.task();
        actions
            .iter()
            .filter(|&&a| !LOOKING.contains(&task.schemas[task.action(a).schema.index()].name.as_str()))
            .map(|&a| {
                spelling.spell(a).map(str::to_string).ok_or_else(|| format!("cannot bind {} to perceived names", task.action_name(a)))
            })
            .collect::<Result<Vec<String>, String>>()
    });
    episode.handover = Some(handover);
    let commands = match planned {
        Ok(commands) => commands,
        Err(e) => {
            episode.failure = Some(e);
            episode.steps = steps;
            return episode;
        }
    };
    for command in commands {
        episode.plan.push(command.clone());
        // Places can share a location in ALFWorld (a drawer under a desk): `go to` the place
        // the agent already stands at is not among the game's admissible commands (it would
        // answer "Nothing happens."), and is skipped without spending a step.
        if command.starts_with("go to ")
            && env.admissible_commands().is_some_and(|a| a.iter().any(|c| c.starts_with("go to ")) && !a.contains(&command))
        {
            continue;
        }
        if steps.len() >= budget {
            episode.failure = Some("step budget spent".into());
            break;
        }
        let result = env.step(&command);
        let executed = matches!(result.event, Event::Executed);
        steps.push(StepRecord { phase: "plan", command: command.clone(), executed, observation: result.observation.text });
        if !executed {
            episode.failure = Some(format!("step {} not executed: {command}", steps.len()));
            break;
        }
    }
    episode.success = env.goal_reached();
    if !episode.success && episode.failure.is_none() {
        episode.failure = Some("goal not reached".into());
    }
    episode.steps = steps;
    episode
}

/// ŝ0 as a transition model of ALFWorld's domain.
fn ground(domain: &pddl_syntax::Domain, problem: &str) -> Result<TransitionModel, String> {
    let parsed = pddl_syntax::parse_problem(problem).map_err(|e| format!("the grounded problem does not parse: {e:?}"))?;
    let task = grounding::ground(domain, &parsed).map_err(|e| format!("the grounded problem does not ground: {e}"))?;
    Ok(TransitionModel::new(task))
}
