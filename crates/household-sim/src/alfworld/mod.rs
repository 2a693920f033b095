//! ALFWorld's text engine (TextWorld 1.7.0's PDDL backend with alfworld 0.4.2's wrappers),
//! step for step, without Python.
//!
//! One game (`game.tw-pddl`) holds the PDDL domain and problem, the TextWorld logic document
//! (command templates, feedback rules, the grammar) and the expert walkthrough. The engine:
//! - keeps the planning state as Fast Downward does (here a `transition_model::State`): it
//!   decides which actions are applicable and whether the goal holds;
//! - keeps TextWorld's fact store beside it (see `facts.rs`), which the grammar reads;
//! - lists as admissible every applicable operator that Fast Downward's translator keeps
//!   (an operator whose every effect its precondition already implies is dropped, so
//!   `go to` the place the agent stands is not admissible), once per operator name, each
//!   spelled through its command template, sorted and without duplicates;
//! - executes a command only if it equals (after Python's `strip`) one of those spellings,
//!   else answers "Nothing happens." and changes nothing;
//! - answers an executed command with the action's feedback rule, derived after the effects.

mod facts;
mod names;
mod textgen;
mod twl;

use std::path::Path;

use grounding::{ActionId, FactId, ObjectId, Task};
use rustc_hash::FxHashSet;
use smallvec::SmallVec;
use transition_model::{State, TransitionModel};

use crate::env::{EngineLine, Environment, Event, GoalAnnotation, Judge, JudgeAtom, Observation, StepResult};
use crate::error::EnvError;
use facts::{Args, Entity, FactStore, Placeholder, Predicates};
use names::EntityInfo;
use textgen::{Context, Grammar, Production, Symbol, World};

/// The answer to a command the engine cannot execute.
pub const NOTHING_HAPPENS: &str = "Nothing happens.";

/// The six ALFWorld task types, as game folder names begin.
pub const TASK_TYPES: [&str; 6] = [
    "pick_and_place_simple",
    "look_at_obj_in_light",
    "pick_clean_then_place_in_recep",
    "pick_heat_then_place_in_recep",
    "pick_cool_then_place_in_recep",
    "pick_two_obj_and_place",
];

/// Per action schema: how TextWorld spells and answers it.
#[derive(Debug, Clone)]
struct SchemaText {
    template: Vec<Symbol>,
    feedback: Vec<Symbol>,
    /// The schema's parameters as placeholders (name, type), in order.
    params: Vec<Placeholder>,
    /// Whether the template reads only facts no action changes, so one spelling per action
    /// holds for the whole episode.
    template_is_static: bool,
    /// Byte offset of the schema's `action` block in the grammar, for errors.
    offset: usize,
}

/// An effect atom of a Fast Downward operator, as TextWorld applies it: `set` is added to
/// the fact store and `clear` removed.
#[derive(Debug, Clone, PartialEq, Eq)]
struct EffectAtom {
    set: u32,
    clear: u32,
    args: Args,
}

/// ALFWorld's text environment for one game.
#[derive(Debug, Clone)]
pub struct AlfworldEnv {
    model: TransitionModel,
    entities: Vec<EntityInfo>,
    object_entity: Vec<Entity>,
    /// Per fluent fact: the predicate ids of `p` and `not_p`, and the arguments.
    fact_atoms: Vec<(u32, u32, Args)>,
    grammar: Grammar,
    schemas: Vec<SchemaText>,
    intro: Vec<Symbol>,
    initial_facts: FactStore,
    goal: GoalAnnotation,
    walkthrough: Vec<String>,
    /// Lazily computed per action: the operator's effect atoms in Fast Downward's order
    /// (empty: the translator drops the operator).
    effects: Vec<Option<Box<[EffectAtom]>>>,
    spellings: Vec<Option<Box<str>>>,
    // The episode.
    state: State,
    facts: FactStore,
    /// TextWorld's `_valid_commands`: one entry per applicable operator name, in action order.
    valid: Vec<(Box<str>, ActionId)>,
    admissible: Vec<String>,
    steps: usize,
    /// Every command since the reset with whether it executed ([`Judge::engine_script`]).
    script: Vec<EngineLine>,
    /// The last observation's text: TextWorld's answer to every command once the game is won.
    last: String,
    scratch: Vec<ActionId>,
}

fn python_strip(text: &str) -> &str {
    text.trim_matches(|c: char| c.is_whitespace() || ('\u{1c}'..='\u{1f}').contains(&c))
}

/// The domain as Fast Downward's lexer reads it. It splits words only at brackets and white
/// space, so in ALFWorld's `(exists (?l - location, ?r - receptacle) ...)` the type of `?l` is
/// `location,`: a type no object has, which makes that disjunct of `examineObject`'s
/// precondition false, and only a held object can be examined in the engine (its admissible
/// lists never offer `examine` for an object in a receptacle). `pddl-syntax` reads `,` as white
/// space, so each `word,` outside comments becomes `word__comma`, declared as a type of its
/// own that no object has, which grounds as Fast Downward's translator grounds the original.
fn fast_downward_commas(domain: &str) -> String {
    let mut added: Vec<String> = Vec::new();
    let mut out = String::with_capacity(domain.len());
    for (i, line) in domain.split('\n').enumerate() {
        if i > 0 {
            out.push('\n');
        }
        let (code, comment) = line.split_at(line.find(';').unwrap_or(line.len()));
        let mut rest = code;
        while let Some(at) = rest.find(',') {
            let word_start = rest[..at].rfind(|c: char| c.is_whitespace() || c == '(' || c == ')').map_or(0, |p| p + 1);
            let word = &rest[word_start..at];
            out.push_str(&rest[..at]);
            if !word.is_empty() && !word.starts_with('?') {
                out.push_str("__comma");
                let name = format!("{}__comma", word.to_ascii_lowercase());
                if !added.contains(&name) {
                    added.push(name);
                }
            } else {
                out.push(',');
            }
            rest = &rest[at + 1..];
        }
        out.push_str(rest);
        out.push_str(comment);
    }
    if added.is_empty() {
        return domain.to_string();
    }
    match out.to_ascii_lowercase().find("(:types") {
        Some(at) => out.insert_str(at + "(:types".len(), &format!(" {}", added.join(" "))),
        None => return domain.to_string(),
    }
    out
}

/// The `(:goal ...)` form of a problem text, as written.
fn goal_text(problem: &str) -> String {
    let lower = problem.to_ascii_lowercase();
    let Some(start) = lower.find("(:goal") else { return String::new() };
    let mut depth = 0usize;
    for (i, c) in problem[start..].char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    let inner = problem[start + "(:goal".len()..start + i].trim();
                    return inner.split_whitespace().collect::<Vec<_>>().join(" ");
                }
            }
            _ => {}
        }
    }
    String::new()
}

impl AlfworldEnv {
    /// Loads `game.tw-pddl` (or the folder holding it). The task family is read from the
    /// game's folder name (`pick_and_place_simple-Book-None-Sofa-229/trial_...`) when it
    /// starts with one of [`TASK_TYPES`].
    pub fn from_game_file(path: &Path) -> Result<AlfworldEnv, EnvError> {
        let file = if path.is_dir() { path.join("game.tw-pddl") } else { path.to_path_buf() };
        let bytes = std::fs::read(&file).map_err(|source| EnvError::Io { path: file.clone(), source })?;
        // Without a byte-order mark, as `benchmark_data::read_text` reads the same files.
        let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").map(<[u8]>::to_vec).unwrap_or(bytes);
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let byte = e.as_bytes()[at];
            let (line, column) = pddl_syntax::line_column(&String::from_utf8_lossy(&e.as_bytes()[..at]), at);
            EnvError::NotUtf8 { path: file.clone(), line, column, byte }
        })?;
        let family = file
            .ancestors()
            .filter_map(|p| p.file_name()?.to_str())
            .find_map(|name| TASK_TYPES.iter().find(|t| name.starts_with(&format!("{t}-"))))
            .map_or("", |t| t);
        AlfworldEnv::from_game_json(&text, &file.display().to_string(), family)
    }

    /// Builds the environment from a game file's text; `source` names it in errors.
    pub fn from_game_json(text: &str, source: &str, family: &str) -> Result<AlfworldEnv, EnvError> {
        let json: serde_json::Value = serde_json::from_str(text).map_err(|e| EnvError::Json {
            path: source.into(),
            line: e.line(),
            column: e.column().max(1), // serde_json says 0 at the start of a line (an empty file)
            message: e.to_string(),
        })?;
        let field = |key: &str| -> Result<&str, EnvError> {
            json.get(key)
                .and_then(serde_json::Value::as_str)
                .ok_or_else(|| EnvError::MissingKey { path: source.into(), key: key.to_string() })
        };
        // A game may come without its expert's walkthrough (none is then played); one that is
        // there is a list of commands.
        let walkthrough: Vec<String> = match json.get("walkthrough") {
            None | Some(serde_json::Value::Null) => Vec::new(),
            Some(value) => value
                .as_array()
                .and_then(|steps| steps.iter().map(|s| s.as_str().map(str::to_string)).collect::<Option<Vec<String>>>())
                .ok_or_else(|| EnvError::BadField {
                    path: source.into(),
                    key: "walkthrough".into(),
                    expected: "a list of strings".into(),
                })?,
        };
        let domain_text = field("pddl_domain")?;
        let problem_text = field("pddl_problem")?;
        let grammar_text = field("grammar")?;
        let pddl = |field: &str, text: &str, e: pddl_syntax::ParseError| EnvError::Pddl {
            path: source.into(),
            field: field.to_string(),
            diagnostics: e.render(&format!("{source} ({field})"), text),
        };
        let domain_text = &fast_downward_commas(domain_text);
        let domain = pddl_syntax::parse_domain(domain_text).map_err(|e| pddl("pddl_domain", domain_text, e))?;
        let problem = pddl_syntax::parse_problem(problem_text).map_err(|e| pddl("pddl_problem", problem_text, e))?;
        let task = grounding::ground(&domain, &problem).map_err(|e| match e {
            // Names that do not check: each error at its line and column, in its field.
            grounding::GroundingError::Invalid { domain, problem } => {
                let errors = |field: &'static str, text: &str, all: Vec<pddl_syntax::Diagnostic>| {
                    all.into_iter()
                        .filter(|d| d.is_error())
                        .map(move |d| (field, d.render(&format!("{source} ({field})"), text)))
                        .collect::<Vec<_>>()
                };
                let mut lines = errors("pddl_domain", domain_text, domain);
                lines.extend(errors("pddl_problem", problem_text, problem));
                EnvError::Pddl {
                    path: source.into(),
                    field: lines.first().map_or("pddl_problem", |(field, _)| field).to_string(),
                    diagnostics: lines.into_iter().map(|(_, line)| line).collect::<Vec<_>>().join("\n"),
                }
            }
            other => EnvError::Grounding {
                path: source.into(),
                message: other
                    .render((&format!("{source} (pddl_domain)"), domain_text), (&format!("{source} (pddl_problem)"), problem_text)),
            },
        })?;
        let grammar_error = |offset: usize, message: String| {
            let at = twl::position(grammar_text, offset);
            EnvError::Grammar { path: source.into(), line: at.line, column: at.column, message }
        };
        let document = twl::parse(grammar_text).map_err(|e| grammar_error(e.offset, e.message))?;

        // Entities: every object, ranked by id; display names for those in the initial atoms.
        let mut ids: Vec<&str> = task.objects.iter().map(|o| o.name.as_str()).collect();
        let init_atoms: Vec<(&str, Vec<&str>)> = problem
            .init
            .iter()
            .filter_map(|e| match e {
                pddl_syntax::InitElement::Atom(atom) if atom.predicate.as_str() != "=" => {
                    Some((atom.predicate.as_str(), atom.args.iter().map(|t| t.name().as_str()).collect()))
                }
                _ => None,
            })
            .collect();
        ids.extend(init_atoms.iter().flat_map(|(_, args)| args.iter().copied()));
        ids.sort_unstable();
        ids.dedup();
        let in_init: FxHashSet<&str> = init_atoms.iter().flat_map(|(_, args)| args.iter().copied()).collect();
        let named: Vec<&str> = ids.iter().copied().filter(|id| in_init.contains(id)).collect();
        let mut display = names::demangle(&named).into_iter();
        let entities: Vec<EntityInfo> = ids
            .iter()
            .map(|id| EntityInfo {
                id: id.to_string(),
                name: if in_init.contains(id) { display.next().expect("one name per entity") } else { id.to_string() },
            })
            .collect();
        let rank = |id: &str| ids.binary_search(&id).expect("every id is ranked") as Entity;
        let object_entity: Vec<Entity> = task.objects.iter().map(|o| rank(&o.name)).collect();

        let mut predicates = Predicates::default();
        for p in &task.predicates {
            predicates.intern(&p.name);
            predicates.intern(&format!("not_{}", p.name));
        }
        for (p, _) in &init_atoms {
            predicates.intern(p);
        }
        let fact_atoms: Vec<(u32, u32, Args)> = task
            .facts
            .iter()
            .map(|atom| {
                let name = &task.predicates[atom.predicate.index()].name;
                let args = atom.args.iter().map(|o| object_entity[o.index()]).collect();
                (predicates.intern(name), predicates.intern(&format!("not_{name}")), args)
            })
            .collect();
        let changing: FxHashSet<String> = task
            .facts
            .iter()
            .flat_map(|atom| {
                let name = &task.predicates[atom.predicate.index()].name;
                [name.clone(), format!("not_{name}")]
            })
            .collect();

        let mut initial_facts = FactStore::new(predicates.len());
        for (p, args) in &init_atoms {
            let pred = predicates.get(p).expect("interned above");
            initial_facts.insert(pred, args.iter().map(|a| rank(a)).collect());
        }

        // The grammar, checked for unknown symbols now rather than mid-episode.
        // Errors found from here on are placed where the grammar writes what they are about: an
        // action's block, or the key of the symbol whose production it is.
        let parse = |text: &str, what: &str, offset: usize| {
            textgen::parse_symbols(text, &predicates).map_err(|e| grammar_error(offset, format!("{what}: {e}")))
        };
        let mut grammar = Grammar::default();
        for (name, rules) in &document.rules {
            let mut productions = Vec::with_capacity(rules.len());
            for rule in rules {
                let condition = if rule.condition.trim().is_empty() {
                    None
                } else {
                    Some(
                        facts::Query::parse(&rule.condition, &predicates)
                            .map_err(|e| grammar_error(rule.offset, format!("the condition of a `{name}` production: {e}")))?,
                    )
                };
                productions.push(Production { condition, rhs: parse(&rule.rhs, &format!("a `{name}` production"), rule.offset)? });
            }
            grammar.rules.push((name.clone(), productions));
        }
        let mut schemas = Vec::with_capacity(task.schemas.len());
        for schema in &task.schemas {
            let text = document.actions.iter().find(|a| a.name == schema.name).ok_or_else(|| EnvError::GrammarIncomplete {
                path: source.into(),
                message: format!("no `action {}` block for the domain's action `{}`", schema.name, schema.name),
            })?;
            let declared = domain.actions.iter().find(|a| a.name.as_str().eq_ignore_ascii_case(&schema.name));
            let params = schema
                .params
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    let ty = declared.and_then(|a| a.params.get(i)).and_then(|p| p.ty.as_ref()).map_or_else(
                        || "object".to_string(),
                        |t| match t {
                            pddl_syntax::Type::Named(n) => n.as_str().to_string(),
                            pddl_syntax::Type::Either(ns) => {
                                format!("(either {})", ns.iter().map(|n| n.as_str()).collect::<Vec<_>>().join(" "))
                            }
                        },
                    );
                    Placeholder { name: name.clone(), ty }
                })
                .collect();
            let template = parse(&text.template, &format!("the template of `{}`", text.name), text.offset)?;
            let feedback = parse(&text.feedback, &format!("the feedback of `{}`", text.name), text.offset)?;
            let template_is_static = reads_only_static(&template, &changing);
            schemas.push(SchemaText { template, feedback, params, template_is_static, offset: text.offset });
        }
        let intro = parse("#intro#", "the intro", 0)?;
        // Each symbol named, with where it is named: an action's block, a production's symbol
        // key, or nowhere in the grammar (the intro that every game starts from).
        let mut named_symbols: Vec<(String, Option<usize>)> = Vec::new();
        let mut name_all = |symbols: &[Symbol], offset: Option<usize>| {
            let mut names = Vec::new();
            textgen::nonterminals(symbols, &mut names);
            named_symbols.extend(names.into_iter().map(|name| (name.to_string(), offset)));
        };
        for schema in &schemas {
            name_all(&schema.template, Some(schema.offset));
            name_all(&schema.feedback, Some(schema.offset));
        }
        name_all(&intro, None);
        for ((_, productions), (_, texts)) in grammar.rules.iter().zip(&document.rules) {
            for (production, text) in productions.iter().zip(texts) {
                name_all(&production.rhs, Some(text.offset));
            }
        }
        for (name, offset) in named_symbols {
            if !grammar.rules.iter().any(|(n, p)| *n == name && !p.is_empty()) {
                let message = format!("the grammar names the symbol `#{name}#`, which it does not define");
                return Err(match offset {
                    Some(offset) => grammar_error(offset, message),
                    None => EnvError::GrammarIncomplete { path: source.into(), message },
                });
            }
        }

        let task_sentence = {
            let world = World { grammar: &grammar, facts: &initial_facts, entities: &entities };
            let task_symbol = parse("#task#", "the task sentence", 0)?;
            let text = world.derive(&task_symbol, &Context::default()).unwrap_or_default();
            text.strip_prefix("Your task is to: ").unwrap_or(&text).to_string()
        };
        let goal = GoalAnnotation {
            benchmark: "alfworld".into(),
            sentence: task_sentence,
            formula: goal_text(problem_text),
            family: family.to_string(),
        };
        let actions = task.actions.len();
        let model = TransitionModel::new(task);
        let state = model.initial_state();
        let mut env = AlfworldEnv {
            model,
            entities,
            object_entity,
            fact_atoms,
            grammar,
            schemas,
            intro,
            facts: initial_facts.clone(),
            initial_facts,
            goal,
            walkthrough,
            effects: vec![None; actions],
            spellings: vec![None; actions],
            state,
            valid: Vec::new(),
            admissible: Vec::new(),
            steps: 0,
            script: Vec::new(),
            last: String::new(),
            scratch: Vec::new(),
        };
        env.gather();
        Ok(env)
    }

    /// The game's expert walkthrough (TextWorld commands), empty when it has none: the expert
    /// baseline's plan, for tools and tests; agents get [`Environment`].
    pub fn walkthrough(&self) -> &[String] {
        &self.walkthrough
    }

    /// The grounded task the engine runs (for tools and tests; agents get [`Environment`]).
    pub fn task(&self) -> &Task {
        self.model.task()
    }

    fn context(&self, action: ActionId) -> Context {
        let action = self.model.task().action(action);
        let mut context = Context::default();
        for (placeholder, object) in self.schemas[action.schema.index()].params.iter().zip(&action.args) {
            context.bind(placeholder.clone(), self.object_entity[object.index()]);
        }
        context
    }

    fn world(&self) -> World<'_> {
        World { grammar: &self.grammar, facts: &self.facts, entities: &self.entities }
    }

    /// The operator's effect atoms as Fast Downward's translator leaves them: an add beats
    /// a delete of the same fact; an effect the precondition already implies is dropped;
    /// sorted by atom (predicate, then argument ids), the atom before its negation.
    fn effect_atoms(&mut self, id: ActionId) -> &[EffectAtom] {
        if self.effects[id.index()].is_none() {
            let task = self.model.task();
            let action = task.action(id);
            let mut list: Vec<(FactId, bool)> = Vec::new();
            let mut push = |adds: &[FactId], dels: &[FactId], unconditional: bool| {
                for &f in adds {
                    if !action.pre.pos.contains(&f) {
                        list.push((f, true));
                    }
                }
                for &f in dels {
                    if (unconditional && adds.contains(&f)) || action.pre.neg.contains(&f) {
                        continue;
                    }
                    list.push((f, false));
                }
            };
            push(&action.add, &action.del, true);
            for effect in &action.conditional {
                push(&effect.add, &effect.del, false);
            }
            let key = |f: FactId| {
                let atom = task.fact(f);
                let args: Vec<&str> = atom.args.iter().map(|o| task.objects[o.index()].name.as_str()).collect();
                (task.predicates[atom.predicate.index()].name.as_str(), args)
            };
            list.sort_by(|a, b| key(a.0).cmp(&key(b.0)).then(b.1.cmp(&a.1)));
            list.dedup();
            let atoms: Box<[EffectAtom]> = list
                .into_iter()
                .map(|(f, positive)| {
                    let (p, not_p, args) = &self.fact_atoms[f.index()];
                    let (set, clear) = if positive { (*p, *not_p) } else { (*not_p, *p) };
                    EffectAtom { set, clear, args: args.clone() }
                })
                .collect();
            self.effects[id.index()] = Some(atoms);
        }
        self.effects[id.index()].as_deref().expect("filled above")
    }

    fn spell(&mut self, id: ActionId) -> Result<Box<str>, textgen::DeriveError> {
        if let Some(text) = &self.spellings[id.index()] {
            return Ok(text.clone());
        }
        let schema = &self.schemas[self.model.task().action(id).schema.index()];
        let text: Box<str> = self.world().derive(&schema.template, &self.context(id))?.into();
        if schema.template_is_static {
            self.spellings[id.index()] = Some(text.clone());
        }
        Ok(text)
    }

    /// TextWorld's `_gather_infos`: the valid commands and the sorted admissible list.
    fn gather(&mut self) {
        let mut applicable = std::mem::take(&mut self.scratch);
        applicable.clear();
        self.model.applicable(&self.state, &mut applicable);
        self.valid.clear();
        let mut last_name: Option<(grounding::SchemaId, SmallVec<[ObjectId; 6]>)> = None;
        for &id in &applicable {
            if self.effect_atoms(id).is_empty() {
                continue;
            }
            let action = self.model.task().action(id);
            let name = (action.schema, action.args.clone());
            if last_name.as_ref() == Some(&name) {
                continue;
            }
            last_name = Some(name);
            // A template that cannot be derived makes the command unspellable; TextWorld would
            // raise. Such an action is left out rather than stopping the episode.
            if let Ok(text) = self.spell(id) {
                self.valid.push((text, id));
            }
        }
        self.scratch = applicable;
        let mut admissible: Vec<String> = self.valid.iter().map(|(t, _)| t.to_string()).collect();
        admissible.sort_unstable();
        admissible.dedup();
        self.admissible = admissible;
    }

    fn execute(&mut self, id: ActionId) -> String {
        self.state = self.model.apply(&self.state, id);
        let effects = self.effect_atoms(id).to_vec();
        for effect in &effects {
            self.facts.remove(effect.clear, &effect.args);
            self.facts.insert(effect.set, effect.args.clone());
        }
        let schema = self.model.task().action(id).schema.index();
        let context = self.context(id);
        let feedback = self.schemas[schema].feedback.clone();
        self.world().derive(&feedback, &context).unwrap_or_else(|e| format!("[grammar error: {e}]"))
    }

    /// The display name of an object (`desk 1`), or its id where ALFWorld gives none.
    fn object_name(&self, object: ObjectId) -> String {
        self.entities[self.object_entity[object.index()] as usize].name.trim_end().to_string()
    }

    fn describe_fact(&self, fact: FactId) -> JudgeAtom {
        let atom = self.model.task().fact(fact);
        JudgeAtom {
            predicate: self.model.task().predicates[atom.predicate.index()].name.clone(),
            args: atom.args.iter().map(|&o| self.object_name(o)).collect(),
        }
    }
}

/// Whether deriving `symbols` reads only facts no action changes. A nonterminal's
/// productions may read anything, so a template that names one is not static.
fn reads_only_static(symbols: &[Symbol], changing: &FxHashSet<String>) -> bool {
    symbols.iter().all(|symbol| match symbol {
        Symbol::Conditional { expression, given } => {
            given.as_ref().is_none_or(|q| q.predicate_names.iter().all(|p| !changing.contains(p)))
                && reads_only_static(std::slice::from_ref(expression), changing)
        }
        Symbol::List(inner) => reads_only_static(std::slice::from_ref(inner), changing),
        Symbol::Nonterminal(_) => false,
        Symbol::Terminal(_) | Symbol::Eval(_) => true,
    })
}

impl Environment for AlfworldEnv {
    fn reset(&mut self) -> Observation {
        self.state = self.model.initial_state();
        self.facts = self.initial_facts.clone();
        self.steps = 0;
        self.script.clear();
        self.gather();
        let text = self.world().derive(&self.intro, &Context::default()).unwrap_or_else(|e| format!("[grammar error: {e}]"));
        self.last.clone_from(&text);
        Observation::text(text)
    }

    /// Once the game is won, TextWorld takes no command: it answers each with its last
    /// observation, counts no move and changes nothing (checked with TextWorld 1.7.0 on
    /// `look_at_obj_in_light-AlarmClock-None-DeskLamp-323`); so does this engine, and such a
    /// command is neither a step nor a line of the engine script.
    fn step(&mut self, command: &str) -> StepResult {
        if self.done() {
            return StepResult {
                observation: Observation::text(self.last.clone()),
                event: Event::NotExecuted { reason: "the game is won and over: the engine takes no command".into() },
            };
        }
        self.steps += 1;
        let sent = command;
        let command = python_strip(command);
        let found = self.valid.iter().find(|(text, _)| &**text == command).map(|&(_, id)| id);
        // As sent: the engine strips it as `python_strip` does.
        self.script.push(EngineLine { line: sent.to_string(), executed: found.is_some() });
        let Some(id) = found else {
            self.gather();
            NOTHING_HAPPENS.clone_into(&mut self.last);
            return StepResult {
                observation: Observation::text(NOTHING_HAPPENS),
                event: Event::NotExecuted { reason: NOTHING_HAPPENS.into() },
            };
        };
        let text = self.execute(id);
        self.gather();
        self.last.clone_from(&text);
        StepResult { observation: Observation::text(text), event: Event::Executed }
    }

    fn goal_reached(&self) -> bool {
        self.model.is_goal(&self.state)
    }

    /// TextWorld ends a game once it is won (ALFWorld's games have no other end).
    fn done(&self) -> bool {
        self.goal_reached()
    }

    fn steps_taken(&self) -> usize {
        self.steps
    }

    fn goal(&self) -> &GoalAnnotation {
        &self.goal
    }
}

impl Judge for AlfworldEnv {
    fn admissible_commands(&self) -> Option<Vec<String>> {
        Some(self.admissible.clone())
    }

    fn hidden_atoms(&self) -> Vec<JudgeAtom> {
        let task = self.model.task();
        let mut atoms: Vec<JudgeAtom> = self.state.facts().map(|f| self.describe_fact(f)).collect();
        atoms.extend(task.static_facts.iter().map(|atom| JudgeAtom {
            predicate: task.predicates[atom.predicate.index()].name.clone(),
            args: atom.args.iter().map(|&o| self.object_name(o)).collect(),
        }));
        atoms.sort();
        atoms
    }

    fn unmet_goals(&self) -> Vec<String> {
        if self.goal_reached() {
            return Vec::new();
        }
        let unmet_of = |condition: &grounding::Condition| transition_model::unmet(condition, &self.state);
        let best = self.model.task().goal.disjuncts.iter().map(unmet_of).min_by_key(Vec::len);
        match best {
            None => vec!["the goal can never hold".into()],
            Some(unmet) => unmet.iter().map(|u| u.describe(self.model.task())).collect(),
        }
    }
    fn engine_script(&self) -> Vec<EngineLine> {
        self.script.clone()
    }
}
