//! F_str (paper Eq. 4): the fixed, class-level ontology shared by every task of a benchmark,
//! added to the facts Phase I establishes when the grounded problem is written. It is derived
//! once, by the functions here, from a benchmark's training split or its published constants,
//! never from the task being solved, and its output is committed (`fixtures/ontology/`);
//! `tests/ontology.rs` derives it again and requires the committed files to match.
//!
//! - ALFWorld ([`alfworld_from_problems`], over the `valid_train` games): a class has an
//!   affordance (`openable`, `heatable`, `pickupable`, ...: the static unary predicates of the
//!   games' initial states) when every instance of that class in the split has it; classes
//!   whose instances disagree are listed with the affordances they share and the ones only some
//!   instances have. `canContain` pairs (receptacle class, object class) are the union over the
//!   split (ALFWorld writes them between class constants).
//! - VirtualHome ([`virtualhome_from_properties`], over EAI's published `properties_data.json`):
//!   a class's affordances are its property list, lower-cased (`grabbable`, `can_open`, ...);
//!   [`Ontology::add_equivalences`] adds the evolving graph's published
//!   `class_name_equivalence.json` (a script's class name → the simulator's names for the same
//!   class: `living_room` and `home_office` → `livingroom`, `dining_room` → `kitchen`), which
//!   [`Ontology::sentence_names`] reads a task sentence's places with.

use std::collections::{BTreeMap, BTreeSet};

/// Static unary predicates of ALFWorld's initial states that are class affordances.
pub const ALFWORLD_AFFORDANCES: &[&str] =
    &["pickupable", "openable", "cleanable", "coolable", "heatable", "sliceable", "toggleable", "isreceptacleobject"];

/// A benchmark's class-level ontology.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Ontology {
    /// class → the affordances every instance of it has.
    pub affordances: BTreeMap<String, BTreeSet<String>>,
    /// (receptacle class, object class) pairs: the object can be put in or on the receptacle.
    pub can_contain: BTreeSet<(String, String)>,
    /// class → affordances only some of its instances have (left out of `affordances`).
    pub disagreements: BTreeMap<String, BTreeSet<String>>,
    /// name → other names of the same class (VirtualHome: `class_name_equivalence.json`). Two
    /// names mean the same class when they are equal or this lists a name for both.
    pub same_as: BTreeMap<String, BTreeSet<String>>,
}

impl Ontology {
    /// Whether every instance of `class` agrees on being openable or not, so that a place of it
    /// can be planned with before it is seen.
    pub fn openness_decided(&self, class: &str) -> bool {
        !self.disagreements.get(class).is_some_and(|a| a.contains("openable"))
    }

    /// Adds the equivalences of a `{name: [other name, ...]}` JSON object (the evolving graph's
    /// `class_name_equivalence.json`) to [`Ontology::same_as`]; names are lower-cased.
    pub fn add_equivalences(&mut self, json: &str, origin: &str) -> Result<(), OntologyError> {
        for (name, others) in string_lists(json, origin, "name")? {
            self.same_as.entry(name.to_ascii_lowercase()).or_default().extend(others);
        }
        Ok(())
    }

    /// Whether two names mean the same class: equal, or [`Ontology::same_as`] lists a name
    /// for both (`home_office` and `living_room` are both `livingroom`).
    pub fn same_class(&self, a: &str, b: &str) -> bool {
        let names = |x: &str| -> BTreeSet<String> {
            let mut out: BTreeSet<String> = self.same_as.get(x).cloned().unwrap_or_default();
            out.insert(x.to_string());
            out
        };
        a == b || !names(a).is_disjoint(&names(b))
    }

    /// Whether the task sentence names `class` (the class of a place the agent perceived, read
    /// against the instruction it was given). The rule: lower-case the sentence and split it
    /// into words of letters; a term is a word or two adjacent words joined by `_` or by
    /// nothing (`living room` → `living_room`, `livingroom`). The sentence names `class` when
    /// a term means the same class ([`Ontology::same_class`]), or a word is the class's head
    /// noun (its last `_` part: `office` for `home_office`) and no other name this ontology
    /// knows has that head (`room` heads `dining_room` and `living_room`, so it names neither).
    pub fn sentence_names(&self, sentence: &str, class: &str) -> bool {
        self.names(&SentenceTerms::new(sentence), class)
    }

    /// Every class of this ontology ([`Ontology::affordances`]' keys) the task sentence names,
    /// the sentence read once: a term that means the same class, as in
    /// [`Ontology::sentence_names`], where two adjacent words that join into a name this
    /// ontology knows are that name alone, not also their words ("the coffee table" names
    /// `coffee_table` and its names, not `coffee`). A head noun alone names no class here:
    /// objects are named by their names, and a word such as "can" ("so that I can use it") is
    /// the head of `garbage_can`.
    pub fn sentence_classes(&self, sentence: &str) -> BTreeSet<String> {
        let known = self.known_names();
        let all = SentenceTerms::new(sentence);
        let mut terms = Vec::new();
        let mut i = 0;
        while i < all.words.len() {
            if let Some(next) = all.words.get(i + 1) {
                let joined = [format!("{}_{next}", all.words[i]), format!("{}{next}", all.words[i])];
                if joined.iter().any(|j| known.contains(j.as_str())) {
                    terms.extend(joined);
                    i += 2;
                    continue;
                }
            }
            terms.push(all.words[i].clone());
            i += 1;
        }
        self.affordances.keys().filter(|c| terms.iter().any(|t| self.same_class(t, c))).cloned().collect()
    }

    fn names(&self, sentence: &SentenceTerms, class: &str) -> bool {
        if sentence.terms.iter().any(|t| self.same_class(t, class)) {
            return true;
        }
        let head = class.rsplit('_').next().unwrap_or(class);
        head != class && sentence.words.iter().any(|w| w == head) && self.names_with_head(head) == 1
    }

    /// How many names this ontology knows (classes, names in `same_as`) have `head` as their
    /// last `_` part.
    fn names_with_head(&self, head: &str) -> usize {
        self.known_names().iter().filter(|n| n.rsplit('_').next() == Some(head)).count()
    }

    /// Every name this ontology knows: its classes and the names in `same_as`.
    fn known_names(&self) -> BTreeSet<&str> {
        let mut names: BTreeSet<&str> = self.affordances.keys().map(String::as_str).collect();
        for (name, others) in &self.same_as {
            names.insert(name);
            names.extend(others.iter().map(String::as_str));
        }
        names
    }
}

/// A sentence's words (lower case, letters only) and terms (the words, and each two adjacent
/// words joined by `_` and by nothing), as [`Ontology::sentence_names`] reads them.
struct SentenceTerms {
    words: Vec<String>,
    terms: Vec<String>,
}

impl SentenceTerms {
    fn new(sentence: &str) -> SentenceTerms {
        let lower = sentence.to_ascii_lowercase();
        let words: Vec<String> = lower.split(|c: char| !c.is_ascii_alphabetic()).filter(|w| !w.is_empty()).map(str::to_string).collect();
        let mut terms = words.clone();
        for pair in words.windows(2) {
            terms.push(format!("{}_{}", pair[0], pair[1]));
            terms.push(format!("{}{}", pair[0], pair[1]));
        }
        SentenceTerms { words, terms }
    }
}

/// Why an ontology cannot be derived.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct OntologyError {
    /// Where the fault is: the origin the caller gave, with `:line` (1-based) for
    /// [`Ontology::from_text`].
    pub origin: String,
    /// What is wrong there.
    pub message: String,
}

/// ALFWorld's ontology from problem files: `(origin, PDDL problem text)` pairs.
pub fn alfworld_from_problems<'a>(problems: impl IntoIterator<Item = (&'a str, &'a str)>) -> Result<Ontology, OntologyError> {
    // class → (instances seen, affordance → instances that have it)
    let mut seen: BTreeMap<String, (usize, BTreeMap<String, usize>)> = BTreeMap::new();
    let mut can_contain = BTreeSet::new();
    for (origin, text) in problems {
        let problem =
            pddl_syntax::parse_problem(text).map_err(|e| OntologyError { origin: origin.to_string(), message: e.render(origin, text) })?;
        let mut class_of: BTreeMap<String, String> = BTreeMap::new();
        let mut unary: Vec<(String, String)> = Vec::new();
        for element in &problem.init {
            let pddl_syntax::InitElement::Atom(atom) = element else { continue };
            let args: Vec<String> = atom.args.iter().map(|t| term_text(t).to_ascii_lowercase()).collect();
            let predicate = atom.predicate.text.to_ascii_lowercase();
            match (predicate.as_str(), args.as_slice()) {
                ("objecttype" | "receptacletype", [instance, class]) => {
                    class_of.insert(instance.clone(), class_name(class));
                }
                ("cancontain", [receptacle, object]) => {
                    can_contain.insert((class_name(receptacle), class_name(object)));
                }
                (p, [instance]) if ALFWORLD_AFFORDANCES.contains(&p) => unary.push((instance.clone(), p.to_string())),
                _ => {}
            }
        }
        for class in class_of.values() {
            seen.entry(class.clone()).or_default().0 += 1;
        }
        for (instance, predicate) in unary {
            let class = class_of.get(&instance).ok_or_else(|| OntologyError {
                origin: origin.to_string(),
                message: format!("`{instance}` has `{predicate}` but no objectType or receptacleType"),
            })?;
            *seen.entry(class.clone()).or_default().1.entry(predicate).or_default() += 1;
        }
    }
    let mut ontology = Ontology { can_contain, ..Ontology::default() };
    for (class, (instances, counts)) in seen {
        let all: BTreeSet<String> = counts.iter().filter(|(_, n)| **n == instances).map(|(p, _)| p.clone()).collect();
        let some: BTreeSet<String> = counts.iter().filter(|(_, n)| **n < instances).map(|(p, _)| p.clone()).collect();
        if !some.is_empty() {
            ontology.disagreements.insert(class.clone(), some);
        }
        ontology.affordances.insert(class, all);
    }
    Ok(ontology)
}

/// VirtualHome's ontology from EAI's `properties_data.json` (`{class: [PROPERTY, ...]}`).
pub fn virtualhome_from_properties(json: &str, origin: &str) -> Result<Ontology, OntologyError> {
    Ok(Ontology { affordances: string_lists(json, origin, "property")?, ..Ontology::default() })
}

/// A `{key: [item, ...]}` JSON object (EAI's `properties_data.json`, the evolving graph's
/// `class_name_equivalence.json`), items lower-cased; errors name the key and call an item `what`.
fn string_lists(json: &str, origin: &str, what: &str) -> Result<BTreeMap<String, BTreeSet<String>>, OntologyError> {
    let bad = |message: String| OntologyError { origin: origin.to_string(), message };
    let value: serde_json::Value = serde_json::from_str(json).map_err(|e| bad(format!("not JSON: {e}")))?;
    let map = value.as_object().ok_or_else(|| bad(format!("not an object of {what} lists")))?;
    let mut out = BTreeMap::new();
    for (key, items) in map {
        let list = items.as_array().ok_or_else(|| bad(format!("`{key}`: not a list")))?;
        let set = list
            .iter()
            .map(|p| p.as_str().map(str::to_ascii_lowercase).ok_or_else(|| bad(format!("`{key}`: a {what} that is not a string"))))
            .collect::<Result<BTreeSet<_>, _>>()?;
        out.insert(key.clone(), set);
    }
    Ok(out)
}

impl Ontology {
    /// The committed form: one line per fact, sorted, `affordance CLASS A1 A2 ...`,
    /// `cancontain RECEPTACLE OBJECT`, `disagree CLASS A1 ...`, `same NAME OTHER1 ...`.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for (class, set) in &self.affordances {
            out.push_str(&format!("affordance {class}{}\n", set.iter().map(|a| format!(" {a}")).collect::<String>()));
        }
        for (receptacle, object) in &self.can_contain {
            out.push_str(&format!("cancontain {receptacle} {object}\n"));
        }
        for (class, set) in &self.disagreements {
            out.push_str(&format!("disagree {class}{}\n", set.iter().map(|a| format!(" {a}")).collect::<String>()));
        }
        for (name, set) in &self.same_as {
            out.push_str(&format!("same {name}{}\n", set.iter().map(|a| format!(" {a}")).collect::<String>()));
        }
        out
    }

    /// Reads [`Ontology::to_text`]'s form; errors name the line.
    pub fn from_text(text: &str, origin: &str) -> Result<Ontology, OntologyError> {
        let mut ontology = Ontology::default();
        for (n, line) in text.lines().enumerate() {
            let words: Vec<&str> = line.split_whitespace().collect();
            let bad = || OntologyError { origin: format!("{origin}:{}", n + 1), message: format!("cannot read `{line}`") };
            match words.as_slice() {
                [] => {}
                ["affordance", class, rest @ ..] => {
                    ontology.affordances.insert(class.to_string(), rest.iter().map(|s| s.to_string()).collect());
                }
                ["cancontain", receptacle, object] => {
                    ontology.can_contain.insert((receptacle.to_string(), object.to_string()));
                }
                ["disagree", class, rest @ ..] => {
                    ontology.disagreements.insert(class.to_string(), rest.iter().map(|s| s.to_string()).collect());
                }
                ["same", name, rest @ ..] => {
                    ontology.same_as.insert(name.to_string(), rest.iter().map(|s| s.to_string()).collect());
                }
                _ => return Err(bad()),
            }
        }
        Ok(ontology)
    }
}

fn term_text(term: &pddl_syntax::Term) -> &str {
    match term {
        pddl_syntax::Term::Variable(n) | pddl_syntax::Term::Constant(n) => &n.text,
    }
}

/// `MugType` / `mugtype` → `mug`.
fn class_name(constant: &str) -> String {
    let lower = constant.to_ascii_lowercase();
    lower.strip_suffix("type").filter(|s| !s.is_empty()).unwrap_or(&lower).to_string()
}
