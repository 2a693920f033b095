//! The Phase II planning prompt (paper §3.2 and the appendix figure "Example VirtualHome
//! Phase-II planning prompt"): an intro paragraph, `Actions:` (the action reference, one line
//! per action form, then the end marker), `Initial state:` (one literal per line), `Goal:`, the
//! closing instruction and `Plan:`. The constrained and unconstrained decoders share it.
//!
//! **Messages.** [`PlanningPrompt::system`] is the intro paragraph (who the model is, what the
//! world is) and [`PlanningPrompt::user`] everything from `Actions:` to `Plan:`, so that the
//! figure's text reads top to bottom across the two messages. The system message is never
//! empty: chat templates render an empty one as an empty system turn (SmolLM2's would
//! otherwise insert its own default persona), which is not "no system message".
//! [`PlanningPrompt::render`] applies the model's chat template with the assistant's turn
//! opened; nothing is appended, so the plan starts right after the assistant header and the
//! first token is already an action's first token.
//!
//! **Names.** The model writes the plan in the spelling the constraint uses, so the prompt
//! names objects the way that spelling does, never by a PDDL id the agent could not have
//! perceived ([`transition_model::ObjectNames`], beside the spellings):
//! - ALFWorld ([`transition_model::alfworld::display_names`]): `apple 1`, `countertop 2`. The
//!   agent argument is left out (`holds apple 1`, `holdsany`). A location is named by the
//!   receptacles standing at it (`atlocation drawer 1 and drawer 2`); a location without a
//!   receptacle (the agent's start) has no name.
//! - VirtualHome (EAI): objects already are class names (`wineglass`, `kitchen`); the
//!   `character` argument is left out (`holds_rh wineglass`), as the spelling leaves it out of
//!   actions.
//! - PDDL: object names as they are.
//!
//! A fact with an argument that has no name is not shown (ALFWorld's type constants such as
//! `AppleType` in `objecttype`/`receptacletype`/`cancontain`, receptacle-less locations), and
//! neither is ALFWorld's `receptacleatlocation`, which the location names already say.
//!
//! **Goal.** Written at class level, as the paper's goal parser does ("only goal classes and
//! relations, not instance identities"): ALFWorld's `apple 1` becomes `apple`, so the one
//! disjunct per binding that grounding makes of an `exists` goal collapses again. Each
//! disjunct becomes a multiset of lines (a literal per line, `not ...` for a negative one; a
//! clause is its distinct alternatives joined by ` or `); identical disjuncts merge. One
//! disjunct left: its lines. Several: the lines common to all, then `one of:` and one `- `
//! line per alternative (its remaining lines joined by `, `).
//!
//! **Relevance** ([`relevant_facts`], [`Relevance`]; the analysis is
//! [`grounding::relevance`]). When planning from a full benchmark
//! problem the prompt shows only what bears on the goal; the transition model keeps the full
//! state. Shown: the start state's true fluent facts that backward relevance finds within
//! [`DEFAULT_RELEVANCE_DEPTH`] regression steps of the goal, and the static facts all of whose
//! objects are mentioned by those facts, by the goal, or by the first regression step (see
//! [`relevant_facts`] for the rule). Measured on the initial states (prompt = both messages):
//!
//! | set | relevance | lines mean / max | characters mean / max | true fluents shown |
//! |---|---|---|---|---|
//! | ALFWorld valid_seen (140) | `All` | 188.9 / 349 | 5939 / 10297 | 100% |
//! | | `Backward { depth: 2 }` | 38.9 / 73 | 1890 / 2634 | 6.4% |
//! | EAI VirtualHome (338) | `All` | 60.3 / 240 | 2030 / 6758 | 100% |
//! | | `Backward { depth: 2 }` | 39.1 / 84 | 1506 / 3041 | 45.5% |
//!
//! In ALFWorld depth 2 is the least that shows where the goal objects are; depth 3 adds the
//! places of objects the agent might have to put down first (42.4 lines mean, 117 max), and
//! from depth 4 the closure covers half the state (142 lines mean) and stops growing. About
//! 25 lines of every prompt are the fixed text and the action reference. For IPC puzzles,
//! where every fact of the state matters, use [`Relevance::All`] or an unbounded depth:
//! depth 2 hides, in Blocksworld, the blocks the goal does not mention.

use grounding::relevance::Closure;
pub use grounding::relevance::RelevantFacts;
use grounding::{Atom, FactId, ObjectId, Task};
use transition_model::{ObjectNames, Spelling, State, SurfaceLanguage, TransitionModel, natural_order};

/// Regression steps of the default backward relevance ([`Relevance::default`]). Two is the
/// least that keeps, in ALFWorld, where the goal objects are and whether their receptacles
/// are open (goal `inreceptacle o r` ← `putobject` needs `holds o` ← `pickupobject` needs
/// `inreceptacle o r'`, `opened r'`), and in VirtualHome what the agent must stand next to.
pub const DEFAULT_RELEVANCE_DEPTH: usize = 2;

/// Which prompt text to write: the world's intro paragraph, how objects are named, the
/// action descriptions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PromptStyle {
    /// ALFWorld: its intro, objects as `apple 1`, the agent argument left out.
    Alfworld,
    /// VirtualHome (EAI): its intro, objects by class name, the `character` argument left out.
    Virtualhome,
    /// A plain PDDL task: object names as they are.
    Pddl,
}

impl From<SurfaceLanguage> for PromptStyle {
    fn from(language: SurfaceLanguage) -> PromptStyle {
        match language {
            SurfaceLanguage::Alfworld => PromptStyle::Alfworld,
            SurfaceLanguage::Virtualhome => PromptStyle::Virtualhome,
            SurfaceLanguage::Pddl => PromptStyle::Pddl,
        }
    }
}

/// Which true facts of the start state the prompt shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Relevance {
    /// Every true fluent fact and every nameable static fact (ALFWorld's
    /// `receptacleatlocation` aside).
    All,
    /// The facts [`relevant_facts`] finds within `depth` regression steps of the goal, and the
    /// static facts about the objects they mention (see [`relevant_facts`]). The closure stops
    /// early at its fixpoint, so `usize::MAX` is the unbounded closure.
    Backward {
        /// Regression steps from the goal.
        depth: usize,
    },
}

impl Default for Relevance {
    fn default() -> Relevance {
        Relevance::Backward { depth: DEFAULT_RELEVANCE_DEPTH }
    }
}

/// How to build a [`PlanningPrompt`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PromptOptions {
    /// Which true facts of the start state are shown.
    pub relevance: Relevance,
    /// The text that ends a plan, listed after the action forms (the paper's `DONE`); `None`
    /// when plans end with the end-of-sequence token only. Must be the constraint's
    /// [`token_constraint::LanguageConfig::end_marker`].
    pub end_marker: Option<String>,
}

impl Default for PromptOptions {
    fn default() -> PromptOptions {
        let end_marker = token_constraint::LanguageConfig::default().end_marker.and_then(|m| String::from_utf8(m).ok());
        PromptOptions { relevance: Relevance::default(), end_marker }
    }
}

/// A planning prompt as two chat messages (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlanningPrompt {
    /// The intro paragraph.
    pub system: String,
    /// `Actions:` ... `Plan:`.
    pub user: String,
}

impl PlanningPrompt {
    /// The prompt text by the model's chat template, the assistant's turn opened: the plan's
    /// first token comes right after it. Give [`Decoder::decode`](crate::Decoder::decode) its
    /// tokens by `model.tokenizer().encode_prompt(..)`, which puts BOS in front where the model
    /// wants one (`encode` does not).
    #[cfg(feature = "decoder")]
    pub fn render(&self, model: &dyn lm::LanguageModel) -> Result<String, lm::LmError> {
        model.chat_prompt(&self.system, &self.user)
    }

    /// Both messages as one plain text (system, blank line, user), for logs and for models
    /// without a chat template.
    pub fn text(&self) -> String {
        format!("{}\n\n{}", self.system, self.user)
    }
}

/// The Phase II prompt for planning from `state` (the grounded start state ŝ0) in `model`,
/// for plans written in `spelling`'s surface language.
pub fn planning_prompt(model: &TransitionModel, spelling: &Spelling, state: &State, options: &PromptOptions) -> PlanningPrompt {
    let task = model.task();
    let style = PromptStyle::from(spelling.language());
    let names = ObjectNames::for_spelling(task, spelling);
    let relevant = match options.relevance {
        Relevance::All => None,
        Relevance::Backward { depth } => Some(relevant_facts(task, depth)),
    };

    let mut user = String::from("Actions:\n");
    for form in action_forms(task, spelling, style, &names) {
        user.push_str(&form);
        user.push('\n');
    }
    if let Some(marker) = &options.end_marker {
        user.push_str(marker);
        user.push('\n');
    }
    user.push_str("\nInitial state:\n");
    let state_lines = state_lines(task, &names, state, relevant.as_ref());
    push_lines(&mut user, &state_lines);
    user.push_str("\nGoal:\n");
    push_lines(&mut user, &goal_lines(task, &names));
    user.push('\n');
    user.push_str(closing(style));
    user.push_str("\n\nPlan:");
    PlanningPrompt { system: intro(style).to_string(), user }
}

fn push_lines(out: &mut String, lines: &[String]) {
    if lines.is_empty() {
        out.push_str("none\n");
    }
    for line in lines {
        out.push_str(line);
        out.push('\n');
    }
}

fn intro(style: PromptStyle) -> &'static str {
    match style {
        // The paper's text, word for word.
        PromptStyle::Virtualhome => {
            "You control an embodied agent in a simulated household called VirtualHome. Output a sequence of actions that changes \
             the observable initial state into the goal state. An action takes effect only if all of its conditions already hold. \
             The agent cannot act on an object it is not close to."
        }
        PromptStyle::Alfworld => {
            "You control an embodied agent in a simulated household called ALFWorld, through text commands. Output a sequence of \
             actions that changes the observable initial state into the goal state. An action takes effect only if all of its \
             conditions already hold. The agent must go to a receptacle before it can act on it or on what is in it, a closed \
             receptacle must be opened first, and the agent holds at most one object. Objects are named by class and number \
             (apple 1); in the goal, a class name (apple) stands for any object of that class."
        }
        PromptStyle::Pddl => {
            "You are a planner for a classical planning task written in PDDL. Output a sequence of actions that changes the \
             initial state into the goal state. An action can be applied only if all of its preconditions hold in the current \
             state; it then adds and deletes the facts of its effects."
        }
    }
}

fn closing(style: PromptStyle) -> &'static str {
    match style {
        PromptStyle::Virtualhome => {
            "Each action should make progress toward the goal and respect preconditions. Output one action per line using class \
             names only, and stop immediately after the action that achieves the goal."
        }
        PromptStyle::Alfworld => {
            "Each action should make progress toward the goal and respect preconditions. Output one action per line using the \
             object names above, and stop immediately after the action that achieves the goal."
        }
        PromptStyle::Pddl => {
            "Each action should make progress toward the goal and respect preconditions. Output one action per line in the form \
             above, and stop immediately after the action that achieves the goal."
        }
    }
}

/// The facts within `depth` regression steps of the goal, by the literal closure of
/// [`grounding::relevance`] (an action enters through the literal it achieves).
/// [`planning_prompt`] shows a static fact when every object it names (agents aside) is
/// mentioned by a relevant fact true in the state, by a goal fact, or by a fact of step 1
/// (true or not: what the goal's achievers need, such as being at the microwave in ALFWorld).
pub fn relevant_facts(task: &Task, depth: usize) -> RelevantFacts {
    grounding::relevance::relevant_facts(task, Closure::Literals, Some(depth))
}

/// The `Initial state:` lines, in natural order: the true fluent facts that are relevant,
/// and the static facts all of whose objects are *mentioned*: named by a shown fluent fact, a
/// goal fact, or a fact of the first regression step (what the goal's achievers need, true or
/// not, e.g. being at the microwave). An ALFWorld location mentions the receptacles at it, and
/// a mentioned receptacle that no other line names gets `receptacle <name>`, so the model
/// knows the receptacles it must go to.
fn state_lines(task: &Task, names: &ObjectNames, state: &State, relevant: Option<&RelevantFacts>) -> Vec<String> {
    let shown: Vec<FactId> = state.facts().filter(|&f| relevant.is_none_or(|r| r.contains(f))).collect();
    let mut mentioned = vec![relevant.is_none(); task.objects.len()];
    let goal_facts = task.goal.disjuncts.iter().flat_map(|d| d.literals().chain(d.clauses.iter().flatten().copied()).map(|l| l.fact()));
    let first_step = relevant.into_iter().flat_map(|r| r.iter().filter(|&f| r.step(f).is_some_and(|s| s <= 1)));
    for fact in shown.iter().copied().chain(goal_facts).chain(first_step) {
        for arg in &task.fact(fact).args {
            mentioned[arg.index()] = true;
            for receptacle in &names.receptacles_at[arg.index()] {
                mentioned[receptacle.index()] = true;
            }
        }
    }
    let mut named = vec![false; task.objects.len()];
    let mut lines = Vec::new();
    let mut show = |atom: &Atom, lines: &mut Vec<String>| {
        if let Some(line) = names.atom_line(task, atom) {
            lines.push(line);
            for arg in &atom.args {
                named[arg.index()] = true;
                for receptacle in &names.receptacles_at[arg.index()] {
                    named[receptacle.index()] = true;
                }
            }
        }
    };
    for &fact in &shown {
        show(task.fact(fact), &mut lines);
    }
    for atom in &task.static_facts {
        if atom.args.iter().all(|a| names.omitted[a.index()] || mentioned[a.index()]) {
            show(atom, &mut lines);
        }
    }
    for (o, name) in names.instance.iter().enumerate() {
        if let Some(name) = name
            && names.receptacle[o]
            && mentioned[o]
            && !named[o]
        {
            lines.push(format!("receptacle {name}"));
        }
    }
    lines.sort_by(|a, b| natural_order(a, b));
    lines.dedup();
    lines
}

/// The `Goal:` lines (see the module docs).
fn goal_lines(task: &Task, names: &ObjectNames) -> Vec<String> {
    let mut disjuncts: Vec<Vec<String>> = Vec::new();
    for disjunct in &task.goal.disjuncts {
        let mut lines: Vec<String> = disjunct.literals().map(|l| names.class_literal_line(task, l)).collect();
        for clause in &disjunct.clauses {
            let mut alternatives: Vec<String> = Vec::new();
            for &literal in clause {
                let line = names.class_literal_line(task, literal);
                if !alternatives.contains(&line) {
                    alternatives.push(line);
                }
            }
            lines.push(alternatives.join(" or "));
        }
        lines.sort();
        if !disjuncts.contains(&lines) {
            disjuncts.push(lines);
        }
    }
    match disjuncts.as_slice() {
        [] => vec!["unreachable".to_string()],
        [only] => only.clone(),
        [first, rest @ ..] => {
            // Lines every disjunct has (as a multiset), then the alternatives.
            let mut common: Vec<String> = Vec::new();
            let mut remaining: Vec<Vec<String>> = disjuncts.clone();
            for line in first {
                if rest.iter().all(|d| d.contains(line)) && remaining.iter().all(|d| d.contains(line)) {
                    for d in &mut remaining {
                        let at = d.iter().position(|l| l == line).unwrap_or(0);
                        d.remove(at);
                    }
                    common.push(line.clone());
                }
            }
            let mut lines = common;
            lines.push("one of:".to_string());
            for alternative in remaining {
                lines.push(format!("- {}", if alternative.is_empty() { "nothing more".to_string() } else { alternative.join(", ") }));
            }
            lines
        }
    }
}

/// One schema's action form in the reference: placeholders, and what it does.
struct FormDoc {
    schema: &'static str,
    /// One placeholder per argument the spelling writes, in parameter order.
    placeholders: &'static [&'static str],
    description: &'static str,
}

const fn doc(schema: &'static str, placeholders: &'static [&'static str], description: &'static str) -> FormDoc {
    FormDoc { schema, placeholders, description }
}

/// ALFWorld's `alfred.pddl` schemas (the forms themselves come from the game's templates).
const ALFWORLD_DOCS: &[FormDoc] = &[
    doc("look", &[], "look around where the agent stands"),
    doc("inventory", &[], "list what the agent holds"),
    doc("examinereceptacle", &["receptacle"], "look at a receptacle the agent is at"),
    doc("examineobject", &["object"], "look at a held object or one in an open receptacle the agent is at"),
    doc("gotolocation", &["receptacle"], "go to a receptacle"),
    doc("openobject", &["receptacle"], "open a closed receptacle the agent is at"),
    doc("closeobject", &["receptacle"], "close an open receptacle the agent is at"),
    doc("pickupobject", &["object", "receptacle"], "pick up an object from a receptacle the agent is at, hands empty"),
    doc("putobject", &["object", "receptacle"], "put the held object in or on a receptacle the agent is at"),
    doc("cleanobject", &["receptacle", "object"], "clean the held object with a sink basin the agent is at"),
    doc("heatobject", &["receptacle", "object"], "heat the held object with a microwave the agent is at"),
    doc("coolobject", &["receptacle", "object"], "cool the held object with a fridge the agent is at"),
    doc("toggleobject", &["object", "receptacle"], "switch on or off a device in a receptacle the agent is at"),
    doc("sliceobject", &["object", "knife"], "slice an object where the agent is with a held knife"),
    doc("help", &[], "list the commands"),
];

/// The EAI VirtualHome schemas of [`transition_model::virtualhome::VERBS`], the character
/// argument left out.
const VIRTUALHOME_DOCS: &[FormDoc] = &[
    doc("walk_towards", &["object"], "move close to an object"),
    doc("walk_into", &["room"], "enter a room"),
    doc("find", &["object"], "find a nearby object"),
    doc("sit", &["object"], "sit on a nearby object"),
    doc("standup", &[], "stand up after sitting or lying"),
    doc("grab", &["object"], "hold a nearby object (at most two, one per hand)"),
    doc("open", &["container"], "open a nearby closed container"),
    doc("close", &["container"], "close a nearby open container"),
    doc("put_on", &["object", "surface"], "place a held object on a nearby surface"),
    doc("put_on_character", &["clothes"], "put on held clothes"),
    doc("put_inside", &["object", "container"], "place a held object in a nearby open container"),
    doc("switch_on", &["device"], "switch on a nearby plugged-in device"),
    doc("switch_off", &["device"], "switch off a nearby device"),
    doc("drink", &["object"], "drink from a held object"),
    doc("turn_to", &["object"], "turn to face an object"),
    doc("look_at", &["object"], "look at an object the agent faces"),
    doc("wipe", &["object", "cloth"], "wipe a nearby object clean with a held cloth"),
    doc("drop", &["object", "room"], "drop a held object in the room"),
    doc("read", &["object"], "read a held object"),
    doc("touch", &["object"], "touch a held object"),
    doc("lie", &["object"], "lie on a nearby object"),
    doc("pour", &["object", "container"], "pour a held object into a nearby container"),
    doc("type", &["object"], "type on a nearby object"),
    doc("watch", &["object"], "watch an object the agent faces"),
    doc("move", &["object"], "move a nearby object"),
    doc("wash", &["object"], "wash a nearby object"),
    doc("squeeze", &["object"], "squeeze nearby clothes"),
    doc("plug_in", &["device"], "plug in a nearby device"),
    doc("plug_out", &["device"], "unplug a nearby device that is off"),
    doc("cut", &["object"], "cut a nearby food"),
    doc("eat", &["object"], "eat a nearby food"),
    doc("sleep", &["object"], "sleep while sitting or lying"),
    doc("wake_up", &["object"], "wake up while sitting or lying"),
];

/// The `Actions:` lines: for each schema with a spelled action, that action's text with every
/// argument's surface name replaced by a placeholder, then `: ` and a description. Forms come
/// from the spelling itself, so they are exactly what the constraint accepts; schemas the
/// spelling cannot write, with no reachable action, or whose only actions act on the agent
/// itself (VirtualHome's `putin <object> character`), are not listed. Identical forms merge.
fn action_forms(task: &Task, spelling: &Spelling, style: PromptStyle, names: &ObjectNames) -> Vec<String> {
    let docs = match style {
        PromptStyle::Alfworld => ALFWORLD_DOCS,
        PromptStyle::Virtualhome => VIRTUALHOME_DOCS,
        PromptStyle::Pddl => &[],
    };
    // The surface name the spelling writes for an object (ALFWorld never writes a location).
    let surface = |o: ObjectId| -> Option<String> {
        let object = &task.objects[o.index()];
        match style {
            _ if names.omitted[o.index()] => None,
            PromptStyle::Alfworld if object.types.iter().any(|t| t == "location") => None,
            PromptStyle::Alfworld => names.instance[o.index()].clone(),
            _ => Some(object.name.clone()),
        }
    };
    let mut forms: Vec<String> = Vec::new();
    // Per schema, the first spelled action that writes the most arguments, all distinct. An
    // action on the agent itself (an omitted object past the first argument: the VirtualHome
    // spelling leaves the character out wherever it stands, so `walk_towards character
    // character` is a bare `walk`) is no example of its schema's form.
    let mut representative: Vec<Option<(grounding::ActionId, (usize, bool))>> = vec![None; task.schemas.len()];
    for id in task.action_ids() {
        let action = task.action(id);
        if spelling.spell(id).is_none() || action.args.iter().skip(1).any(|a| names.omitted[a.index()]) {
            continue;
        }
        let written: Vec<String> = action.args.iter().filter_map(|&a| surface(a)).collect();
        let distinct = written.iter().enumerate().all(|(i, w)| !written[..i].contains(w));
        let score = (written.len(), distinct);
        let slot = &mut representative[action.schema.index()];
        if slot.is_none_or(|(_, best)| score > best) {
            *slot = Some((id, score));
        }
    }
    for (s, schema) in task.schemas.iter().enumerate() {
        let Some((id, _)) = representative[s] else { continue };
        let action = task.action(id);
        let text = spelling.spell(id).unwrap_or_default();
        let doc = docs.iter().find(|d| d.schema == schema.name);
        let mut words: Vec<String> = split_words(text);
        let mut written = 0;
        for (p, &arg) in action.args.iter().enumerate() {
            let Some(name) = surface(arg) else { continue };
            let placeholder = match doc.and_then(|d| d.placeholders.get(written)) {
                Some(p) => (*p).to_string(),
                None if style == PromptStyle::Alfworld => {
                    task.objects[arg.index()].types.first().cloned().unwrap_or_else(|| "object".into())
                }
                None => schema.params.get(p).cloned().unwrap_or_else(|| format!("arg{p}")),
            };
            written += 1;
            replace_words(&mut words, &split_words(&name), &format!("<{placeholder}>"));
        }
        let form = words.concat();
        let description = match (doc, style) {
            (Some(doc), _) => doc.description.to_string(),
            (None, PromptStyle::Pddl) => pddl_description(task, id),
            (None, _) => format!("the `{}` action", schema.name),
        };
        let line = format!("{form}: {description}");
        if !forms.iter().any(|f| f.split(": ").next() == Some(form.as_str())) {
            forms.push(line);
        }
    }
    forms
}

/// Text split into words and separators (white space, brackets), concatenation-preserving.
fn split_words(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut word = String::new();
    for c in text.chars() {
        if c.is_whitespace() || c == '(' || c == ')' {
            if !word.is_empty() {
                out.push(std::mem::take(&mut word));
            }
            out.push(c.to_string());
        } else {
            word.push(c);
        }
    }
    if !word.is_empty() {
        out.push(word);
    }
    out
}

/// Replaces the first whole-word occurrence of `name` (as split by [`split_words`]) in `words`.
fn replace_words(words: &mut Vec<String>, name: &[String], placeholder: &str) {
    if name.is_empty() || name.len() > words.len() {
        return;
    }
    if let Some(at) = (0..=words.len() - name.len()).find(|&i| words[i..i + name.len()] == *name) {
        words.splice(at..at + name.len(), [placeholder.to_string()]);
    }
}

/// A PDDL action's description from one grounded instance: its precondition and effects with
/// the arguments written as `<param>` (static preconditions were evaluated away by grounding,
/// so they are not listed).
fn pddl_description(task: &Task, id: grounding::ActionId) -> String {
    let action = task.action(id);
    let schema = &task.schemas[action.schema.index()];
    let name = |o: &ObjectId| match action.args.iter().position(|a| a == o) {
        Some(p) => format!("<{}>", schema.params.get(p).map_or("?", String::as_str)),
        None => task.objects[o.index()].name.clone(),
    };
    let fact = |f: FactId| {
        let atom = task.fact(f);
        let mut out = task.predicates[atom.predicate.index()].name.clone();
        for arg in &atom.args {
            out.push(' ');
            out.push_str(&name(arg));
        }
        out
    };
    let mut needs: Vec<String> = action.pre.pos.iter().map(|&f| fact(f)).collect();
    needs.extend(action.pre.neg.iter().map(|&f| format!("not {}", fact(f))));
    let mut effects: Vec<String> = action.add.iter().map(|&f| fact(f)).collect();
    effects.extend(action.del.iter().map(|&f| format!("not {}", fact(f))));
    let mut out = String::new();
    if !needs.is_empty() {
        out.push_str("needs ");
        out.push_str(&needs.join(", "));
    }
    if !effects.is_empty() {
        if !out.is_empty() {
            out.push_str("; ");
        }
        out.push_str("makes ");
        out.push_str(&effects.join(", "));
    }
    if !action.conditional.is_empty() {
        out.push_str(if out.is_empty() { "has conditional effects" } else { "; and conditional effects" });
    }
    if out.is_empty() { "no precondition or effect".to_string() } else { out }
}
