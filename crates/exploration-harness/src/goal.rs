//! The goal parser: a fixed, rule-based reading of a benchmark's own goal annotation
//! ([`household_sim::GoalAnnotation`]) as G at class level: symbols with a class where the goal
//! names one, and a conjunction of literals over them. It never sees, and never produces, an
//! instance identifier.
//!
//! Rules, by benchmark:
//! - ALFWorld (`formula` is the game's PDDL goal): a conjunction under nested `exists`. Each
//!   quantified variable is a symbol of its PDDL type (object, receptacle, agent, location);
//!   `(objectType ?v XType)` and `(receptacleType ?v XType)` give it the class `x` (lower case,
//!   as ALFWorld's text writes classes: `coffeemachine`) and are not
//!   kept as literals; every other atom is a literal, `(not (= ?a ?b))` is `distinct(a, b)`.
//!   A variable bound again in a later `exists` gets the suffix `_2`, `_3`, ... A constant other
//!   than a `...Type` class, or a disjunction, implication or `forall`, is an error.
//! - VirtualHome (`formula` is `household_sim::vh_class_level_goal`'s JSON): one symbol per class
//!   named by a node goal or an edge goal, shared by every goal that names the class, except that
//!   an edge goal repeated k times stands for k instances of its `from` class (`plate`,
//!   `plate_2`), and a node goal repeated k times for k instances of its class ("turn on the
//!   lights": `on(light)`, `on(light_2)`; the k-th repeat of a state goes to the k-th instance,
//!   so each instance keeps all its states); the acting character is the symbol `character`. A
//!   node goal `{class, state}` is the literal `state(class)` in lower case
//!   (`closed(dishwasher)`); an edge goal is
//!   `relation(from, to)` (`inside(plate, dishwasher)`); `actions` are kept in order, each a set
//!   of alternatives (`WATCH|LOOKAT`).

use std::fmt;

use household_sim::GoalAnnotation;
use pddl_syntax::{Condition, Term};

/// A goal variable: the agent must find (or be) an instance for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Symbol {
    /// Unique within the goal: ALFWorld's variable without its `?` (`o`, `o_2`), VirtualHome's
    /// class (`plate`, `plate_2`).
    pub name: String,
    /// The PDDL type (`object`, `receptacle`, ...) or, in VirtualHome, `object`/`character`.
    pub kind: String,
    /// The class the goal names (`mug`, `coffeemachine`, `dishwasher`), if any.
    pub class: Option<String>,
}

/// One literal of the goal's conjunction, over symbols.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClassLiteral {
    /// ALFWorld: the PDDL predicate, lowercased as the PDDL parser stores names (`inreceptacle`),
    /// or `distinct`;
    /// VirtualHome: the state or relation in lower case (`closed`, `inside`).
    pub predicate: String,
    /// The arguments, each a [`Symbol::name`].
    pub args: Vec<String>,
    /// The literal is negated (ALFWorld's `(not ...)`; never in VirtualHome).
    pub negated: bool,
}

/// G at class level.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClassGoal {
    /// The annotation's benchmark (`alfworld`, `virtualhome-eai`, ...).
    pub benchmark: String,
    /// The task family (ALFWorld task type, EAI category, rearrangement family).
    pub family: String,
    /// The goal's variables, in the order the annotation first names them.
    pub symbols: Vec<Symbol>,
    /// The conjunction, in the annotation's order (ALFWorld: a repeated atom once).
    pub literals: Vec<ClassLiteral>,
    /// VirtualHome's required actions, in order, each `|`-separated alternatives.
    pub actions: Vec<String>,
    /// The task sentence as the benchmark states it to the agent, kept as it is (VirtualHome's
    /// adapter reads the places it names: [`crate::Ontology::sentence_names`]).
    pub sentence: String,
}

/// Why a goal annotation cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GoalError {
    /// The formula is not what its benchmark writes (not PDDL or JSON, a field missing, a
    /// variable unbound or used as a class), or the benchmark is unknown.
    #[error("{benchmark} goal: {message}")]
    Unreadable {
        /// The annotation's benchmark.
        benchmark: String,
        /// What could not be read.
        message: String,
    },
    /// An ALFWorld goal uses a construct other than a conjunction of literals under `exists`.
    #[error("{benchmark} goal: `{construct}` is not a conjunction of literals under `exists`")]
    Unsupported {
        /// The annotation's benchmark.
        benchmark: String,
        /// The construct: `or`, `imply`, `forall`, `=` outside `not`, or `not` of a non-atom.
        construct: String,
    },
    /// The goal names an instance: an ALFWorld constant that is not a `...Type` class, or a
    /// VirtualHome entry with an `id`, `from_id` or `to_id`.
    #[error("{benchmark} goal: `{name}` names an instance, not a class")]
    Instance {
        /// The annotation's benchmark.
        benchmark: String,
        /// The constant, or the VirtualHome key.
        name: String,
    },
}

/// Parses `annotation` by its benchmark's rule (see the module documentation).
pub fn parse_goal(annotation: &GoalAnnotation) -> Result<ClassGoal, GoalError> {
    let mut goal = ClassGoal {
        benchmark: annotation.benchmark.clone(),
        family: annotation.family.clone(),
        symbols: Vec::new(),
        literals: Vec::new(),
        actions: Vec::new(),
        sentence: annotation.sentence.clone(),
    };
    if annotation.benchmark.starts_with("alfworld") {
        parse_alfworld(annotation, &mut goal)?;
    } else if annotation.benchmark.starts_with("virtualhome") {
        parse_virtualhome(annotation, &mut goal)?;
    } else {
        return Err(GoalError::Unreadable { benchmark: annotation.benchmark.clone(), message: "unknown benchmark".into() });
    }
    Ok(goal)
}

fn parse_alfworld(annotation: &GoalAnnotation, goal: &mut ClassGoal) -> Result<(), GoalError> {
    let benchmark = annotation.benchmark.clone();
    let text = format!("(define (problem goal) (:domain alfred) (:goal {}))", annotation.formula);
    let problem =
        pddl_syntax::parse_problem(&text).map_err(|e| GoalError::Unreadable { benchmark: benchmark.clone(), message: e.to_string() })?;
    let condition = problem.goal.ok_or_else(|| GoalError::Unreadable { benchmark: benchmark.clone(), message: "no goal".into() })?;
    let mut scope: Vec<(String, String)> = Vec::new();
    walk(&condition, goal, &mut scope, &benchmark)?;
    Ok(())
}

/// Walks a conjunction under `exists`; `scope` maps each variable in scope to its symbol.
fn walk(condition: &Condition, goal: &mut ClassGoal, scope: &mut Vec<(String, String)>, benchmark: &str) -> Result<(), GoalError> {
    let unsupported = |construct: &str| GoalError::Unsupported { benchmark: benchmark.to_string(), construct: construct.to_string() };
    match condition {
        Condition::And(parts, _) => {
            for part in parts {
                walk(part, goal, scope, benchmark)?;
            }
            Ok(())
        }
        Condition::Exists(variables, body, _) => {
            let depth = scope.len();
            for variable in variables {
                let base = variable.name.text.clone();
                let mut name = base.clone();
                let mut k = 1;
                while goal.symbols.iter().any(|s| s.name == name) {
                    k += 1;
                    name = format!("{base}_{k}");
                }
                let kind = variable
                    .ty
                    .as_ref()
                    .map_or_else(|| "object".to_string(), |t| t.names().iter().map(|n| n.text.as_str()).collect::<Vec<_>>().join("|"));
                goal.symbols.push(Symbol { name: name.clone(), kind, class: None });
                scope.push((base, name));
            }
            walk(body, goal, scope, benchmark)?;
            scope.truncate(depth);
            Ok(())
        }
        Condition::Atom(atom) => literal(&atom.predicate.text, &atom.args, false, goal, scope, benchmark),
        Condition::Not(inner, _) => match inner.as_ref() {
            Condition::Atom(atom) => literal(&atom.predicate.text, &atom.args, true, goal, scope, benchmark),
            Condition::Equals(a, b, _) => {
                let args = vec![symbol_of(a, scope, benchmark)?, symbol_of(b, scope, benchmark)?];
                goal.literals.push(ClassLiteral { predicate: "distinct".into(), args, negated: false });
                Ok(())
            }
            _ => Err(unsupported("not")),
        },
        Condition::Equals(..) => Err(unsupported("=")),
        Condition::Or(..) => Err(unsupported("or")),
        Condition::Imply(..) => Err(unsupported("imply")),
        Condition::Forall(..) => Err(unsupported("forall")),
    }
}

fn symbol_of(term: &Term, scope: &[(String, String)], benchmark: &str) -> Result<String, GoalError> {
    match term {
        Term::Variable(name) => scope
            .iter()
            .rev()
            .find(|(variable, _)| *variable == name.text)
            .map(|(_, symbol)| symbol.clone())
            .ok_or_else(|| GoalError::Unreadable { benchmark: benchmark.to_string(), message: format!("?{} is not bound", name.text) }),
        Term::Constant(name) => Err(GoalError::Instance { benchmark: benchmark.to_string(), name: name.text.clone() }),
    }
}

fn literal(
    predicate: &str,
    args: &[Term],
    negated: bool,
    goal: &mut ClassGoal,
    scope: &[(String, String)],
    benchmark: &str,
) -> Result<(), GoalError> {
    // `(objectType ?o MugType)`: the symbol's class.
    if !negated && (predicate.eq_ignore_ascii_case("objectType") || predicate.eq_ignore_ascii_case("receptacleType")) && args.len() == 2 {
        let symbol = symbol_of(&args[0], scope, benchmark)?;
        let class = match &args[1] {
            Term::Constant(c) if c.text.to_ascii_lowercase().ends_with("type") && c.text.len() > 4 => {
                c.text[..c.text.len() - 4].to_ascii_lowercase()
            }
            Term::Constant(c) => return Err(GoalError::Instance { benchmark: benchmark.to_string(), name: c.text.clone() }),
            Term::Variable(v) => {
                return Err(GoalError::Unreadable {
                    benchmark: benchmark.to_string(),
                    message: format!("the class of ?{} is a variable", v.text),
                });
            }
        };
        if let Some(s) = goal.symbols.iter_mut().find(|s| s.name == symbol) {
            s.class = Some(class);
        }
        return Ok(());
    }
    let args = args.iter().map(|a| symbol_of(a, scope, benchmark)).collect::<Result<Vec<_>, _>>()?;
    let literal = ClassLiteral { predicate: predicate.to_string(), args, negated };
    if !goal.literals.contains(&literal) {
        goal.literals.push(literal);
    }
    Ok(())
}

fn parse_virtualhome(annotation: &GoalAnnotation, goal: &mut ClassGoal) -> Result<(), GoalError> {
    let benchmark = annotation.benchmark.clone();
    let bad = |message: String| GoalError::Unreadable { benchmark: benchmark.clone(), message };
    let value: serde_json::Value = serde_json::from_str(&annotation.formula).map_err(|e| bad(format!("not JSON: {e}")))?;
    let entries = value["goal"].as_array().ok_or_else(|| bad("no `goal` list".into()))?;
    for key in ["id", "from_id", "to_id"] {
        if entries.iter().any(|e| e.get(key).is_some()) {
            return Err(GoalError::Instance { benchmark: benchmark.clone(), name: key.to_string() });
        }
    }
    let text = |e: &serde_json::Value, key: &str| -> Result<String, GoalError> {
        e[key].as_str().map(str::to_string).ok_or_else(|| bad(format!("an entry without a `{key}` string: {e}")))
    };
    // The shared symbol of a class: created on first mention.
    fn shared(goal: &mut ClassGoal, class: &str) -> String {
        if let Some(s) = goal.symbols.iter().find(|s| s.class.as_deref() == Some(class) && s.name == class) {
            return s.name.clone();
        }
        let kind = if class == "character" { "character" } else { "object" };
        goal.symbols.push(Symbol { name: class.to_string(), kind: kind.to_string(), class: Some(class.to_string()) });
        class.to_string()
    }
    // The k-th instance of a class (k from 0): the shared symbol, then `class_2`, `class_3`, ...
    fn nth(goal: &mut ClassGoal, class: &str, k: usize) -> String {
        if k == 0 {
            return shared(goal, class);
        }
        let name = format!("{class}_{}", k + 1);
        if !goal.symbols.iter().any(|s| s.name == name) {
            goal.symbols.push(Symbol { name: name.clone(), kind: "object".into(), class: Some(class.to_string()) });
        }
        name
    }
    let mut seen_states: Vec<(String, String)> = Vec::new();
    let mut seen_edges: Vec<(String, String, String)> = Vec::new();
    for entry in entries {
        if entry.get("state").is_some() {
            let (class, state) = (text(entry, "class_name")?, text(entry, "state")?);
            let key = (class.clone(), state.clone());
            let repeat = seen_states.iter().filter(|e| **e == key).count();
            seen_states.push(key);
            let symbol = nth(goal, &class, repeat);
            goal.literals.push(ClassLiteral { predicate: state.to_lowercase(), args: vec![symbol], negated: false });
        } else {
            let (from, relation, to) = (text(entry, "from")?, text(entry, "relation_type")?, text(entry, "to")?);
            let key = (from.clone(), relation.clone(), to.clone());
            let repeat = seen_edges.iter().filter(|e| **e == key).count();
            seen_edges.push(key);
            let from_symbol = nth(goal, &from, repeat);
            let to_symbol = shared(goal, &to);
            goal.literals.push(ClassLiteral { predicate: relation.to_lowercase(), args: vec![from_symbol, to_symbol], negated: false });
        }
    }
    if let Some(actions) = value["actions"].as_array() {
        for a in actions {
            goal.actions.push(a.as_str().ok_or_else(|| bad(format!("an action that is not a string: {a}")))?.to_string());
        }
    }
    Ok(())
}

impl fmt::Display for ClassGoal {
    /// `o: object mug, r: receptacle coffeemachine | isclean(o), inreceptacle(o, r)`, then
    /// `| actions: WATCH|LOOKAT` where there are actions.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let symbols: Vec<String> = self
            .symbols
            .iter()
            .map(|s| format!("{}: {}{}", s.name, s.kind, s.class.as_ref().map_or(String::new(), |c| format!(" {c}"))))
            .collect();
        let literals: Vec<String> = self
            .literals
            .iter()
            .map(|l| format!("{}{}({})", if l.negated { "not " } else { "" }, l.predicate, l.args.join(", ")))
            .collect();
        write!(f, "{} | {}", symbols.join(", "), literals.join(", "))?;
        if !self.actions.is_empty() {
            write!(f, " | actions: {}", self.actions.join(", "))?;
        }
        Ok(())
    }
}
