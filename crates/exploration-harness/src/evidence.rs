//! The evidence update U (paper Eq. 3) and what it reads: facts the environment stated.
//!
//! A [`Percept`] is a fact read off an observation by a perceiver (for ALFWorld,
//! [`perceive_alfworld`]), with the step that showed it. [`Belief::admit`] is U:
//! - rule 1: only percepts enter the established facts F_t; a model's proposal never does
//!   ([`Belief::propose`] keeps it as a hypothesis, which may steer the next inspection);
//! - rule 2: a later percept about the same atom replaces an earlier one (the fridge was closed,
//!   then opened), so F_t is the latest word of the environment on each atom;
//! - rule 3: a percept confirming a hypothesis removes it from the hypotheses.
//!
//! Facts name things as the agent perceived them (`mug 2`, `countertop 1`), never by a hidden
//! identifier.

use std::collections::{BTreeMap, BTreeSet};

/// A ground literal over perceived names: `inReceptacle(mug 2, countertop 1)`, or its negation.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Fact {
    /// The predicate as the perceiver writes it (`inReceptacle`, `opened`, `INSIDE`).
    pub predicate: String,
    /// The arguments, each a perceived name (`mug 2`, `plate (1001)`).
    pub args: Vec<String>,
    /// `false`: the environment said the atom does not hold (`The fridge 1 is closed.`).
    pub holds: bool,
}

impl Fact {
    /// `predicate` over `args`; `holds` false for the atom's negation.
    pub fn new(predicate: &str, args: &[&str], holds: bool) -> Fact {
        Fact { predicate: predicate.to_string(), args: args.iter().map(|a| a.to_string()).collect(), holds }
    }

    /// The atom, whether it holds or not.
    pub fn atom(&self) -> (&str, &[String]) {
        (&self.predicate, &self.args)
    }
}

/// A fact an observation stated, and at which step (0: the reset).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Percept {
    /// What the observation stated.
    pub fact: Fact,
    /// The environment step whose observation stated it (0: the reset's).
    pub step: usize,
}

/// F_t, the hypotheses and the places seen so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Belief {
    /// atom → (holds, the step whose observation said so).
    facts: BTreeMap<(String, Vec<String>), (bool, usize)>,
    hypotheses: BTreeSet<Fact>,
    /// Receptacles and other places the environment listed, in the order it listed them.
    pub places: Vec<String>,
}

impl Belief {
    /// U: admits the environment's percepts (rules 1-3 of the module documentation).
    pub fn admit(&mut self, percepts: &[Percept]) {
        for p in percepts {
            let key = (p.fact.predicate.clone(), p.fact.args.clone());
            self.facts.insert(key, (p.fact.holds, p.step));
            self.hypotheses.remove(&p.fact);
        }
    }

    /// A model's proposed facts: kept as hypotheses unless F_t already decides them; never
    /// admitted.
    pub fn propose(&mut self, facts: &[Fact]) {
        for f in facts {
            if !self.facts.contains_key(&(f.predicate.clone(), f.args.clone())) {
                self.hypotheses.insert(f.clone());
            }
        }
    }

    /// Adds places the environment listed (each once).
    pub fn add_places(&mut self, places: &[String]) {
        for p in places {
            if !self.places.contains(p) {
                self.places.push(p.clone());
            }
        }
    }

    /// F_t: every established fact, true and false ones, sorted.
    pub fn facts(&self) -> Vec<Fact> {
        self.facts.iter().map(|((predicate, args), &(holds, _))| Fact { predicate: predicate.clone(), args: args.clone(), holds }).collect()
    }

    /// Whether F_t says the atom holds (`Some(true)`), does not (`Some(false)`), or is silent.
    pub fn holds(&self, predicate: &str, args: &[&str]) -> Option<bool> {
        let key = (predicate.to_string(), args.iter().map(|a| a.to_string()).collect::<Vec<_>>());
        self.facts.get(&key).map(|&(holds, _)| holds)
    }

    /// The hypotheses, sorted: proposals F_t did not decide when they were made, less those a
    /// percept has since confirmed (one that a percept contradicts stays).
    pub fn hypotheses(&self) -> impl Iterator<Item = &Fact> {
        self.hypotheses.iter()
    }
}

/// What one ALFWorld observation states, read by a fixed grammar of TextWorld's ALFWorld
/// sentences (those `alfred.twl2` writes): the places of the room listing, and facts:
/// - `On the R, you see A, B, and C.` / `In it, you see ...` after arriving at or opening R:
///   `inReceptacle(A, R)` ...;
/// - `The R is closed.` / `The R is open.`: `opened(R)` false / true; `You open the R.` /
///   `You close the R.` likewise;
/// - `You pick up the O from the R.`: `holds(O)`, `inReceptacle(O, R)` false;
/// - `You put the O in/on the R.`: `inReceptacle(O, R)`, `holds(O)` false;
/// - `You turn on the O.`: `isToggled(O)`; `You heat/cool/clean the O using the R.`:
///   `isHot(O)` / `isCool(O)` / `isClean(O)`.
///
/// - `You arrive at R.`, `On the R, you see ...`, `The R is closed/open.`: `visited(R)` (the
///   agent has looked at R from where it stands).
///
/// Anything else (`Nothing happens.`) states no fact.
pub fn perceive_alfworld(observation: &str, step: usize) -> (Vec<String>, Vec<Percept>) {
    let mut places = Vec::new();
    let mut percepts = Vec::new();
    let mut fact = |predicate: &str, args: &[&str], holds: bool| percepts.push(Percept { fact: Fact::new(predicate, args, holds), step });
    let mut current: Option<String> = None;
    for sentence in sentences(observation) {
        let s = sentence.as_str();
        if let Some(rest) = s.strip_prefix("Looking quickly around you, you see ") {
            places.extend(list(rest));
        } else if let Some(r) = s.strip_prefix("You arrive at ") {
            fact("visited", &[r], true);
            current = Some(r.to_string());
        } else if let Some(rest) = s.strip_prefix("On the ").and_then(|r| r.split_once(", you see ")) {
            let (r, items) = rest;
            fact("visited", &[r], true);
            for item in list(items) {
                fact("inReceptacle", &[&item, r], true);
            }
        } else if let Some(items) = s.strip_prefix("In it, you see ") {
            if let Some(r) = &current {
                for item in list(items) {
                    fact("inReceptacle", &[&item, r], true);
                }
            }
        } else if let Some(r) = s.strip_prefix("The ").and_then(|r| r.strip_suffix(" is closed")) {
            fact("visited", &[r], true);
            fact("opened", &[r], false);
            current = Some(r.to_string());
        } else if let Some(r) = s.strip_prefix("The ").and_then(|r| r.strip_suffix(" is open")) {
            fact("visited", &[r], true);
            fact("opened", &[r], true);
            current = Some(r.to_string());
        } else if let Some(r) = s.strip_prefix("You open the ") {
            fact("opened", &[r], true);
            current = Some(r.to_string());
        } else if let Some(r) = s.strip_prefix("You close the ") {
            fact("opened", &[r], false);
        } else if let Some((o, r)) = s.strip_prefix("You pick up the ").and_then(|r| r.split_once(" from the ")) {
            fact("holds", &[o], true);
            fact("inReceptacle", &[o, r], false);
        } else if let Some((o, r)) = s.strip_prefix("You put the ").and_then(|r| r.split_once(" in/on the ")) {
            fact("inReceptacle", &[o, r], true);
            fact("holds", &[o], false);
        } else if let Some(o) = s.strip_prefix("You turn on the ") {
            fact("isToggled", &[o], true);
        } else {
            for (verb, predicate) in [("You heat the ", "isHot"), ("You cool the ", "isCool"), ("You clean the ", "isClean")] {
                if let Some((o, _)) = s.strip_prefix(verb).and_then(|r| r.split_once(" using the ")) {
                    fact(predicate, &[o], true);
                }
            }
        }
    }
    (places, percepts)
}

/// The observation's sentences, without their final `.`, split at `. ` and new lines.
fn sentences(observation: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in observation.lines() {
        let mut rest = line.trim();
        while !rest.is_empty() {
            let (sentence, tail) = match rest.find(". ") {
                Some(i) => (&rest[..i], &rest[i + 2..]),
                None => (rest.strip_suffix('.').unwrap_or(rest), ""),
            };
            out.push(sentence.trim().to_string());
            rest = tail.trim();
        }
    }
    out
}

/// `a mug 2, a bread 1, and a apple 3` → the names; `nothing` → none.
fn list(text: &str) -> Vec<String> {
    let text = text.trim().trim_end_matches('.');
    if text == "nothing" {
        return Vec::new();
    }
    text.split(", ")
        .map(|item| item.trim().trim_start_matches("and ").trim())
        .map(|item| item.strip_prefix("a ").or_else(|| item.strip_prefix("an ")).unwrap_or(item).to_string())
        .filter(|item| !item.is_empty())
        .collect()
}

impl std::fmt::Display for Fact {
    /// `inReceptacle(mug 2, countertop 1)`, `not opened(fridge 1)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.holds {
            write!(f, "not ")?;
        }
        write!(f, "{}({})", self.predicate, self.args.join(", "))
    }
}

impl Fact {
    /// Reads [`Fact`]'s `Display` form back; `None` for anything else.
    pub fn parse(text: &str) -> Option<Fact> {
        let text = text.trim();
        let (holds, rest) = match text.strip_prefix("not ") {
            Some(rest) => (false, rest.trim()),
            None => (true, text),
        };
        let (predicate, args) = rest.strip_suffix(')')?.split_once('(')?;
        let predicate = predicate.trim();
        if predicate.is_empty() || predicate.contains(char::is_whitespace) {
            return None;
        }
        let args: Vec<String> = args.split(',').map(|a| a.trim().to_string()).filter(|a| !a.is_empty()).collect();
        Some(Fact { predicate: predicate.to_string(), args, holds })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { rng_seed: proptest::test_runner::RngSeed::Fixed(3), failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))), ..proptest::prelude::ProptestConfig::default() })]
        /// Facts read back as written (names with spaces and parentheses included).
        #[test]
        fn facts_read_back_as_written(predicate in "[A-Za-z_]{1,12}", args in proptest::collection::vec("[a-z_]{1,8}( [0-9]{1,3}| \\([0-9]{1,4}\\))?", 0..3), holds: bool) {
            let fact = Fact { predicate, args, holds };
            proptest::prop_assert_eq!(Fact::parse(&fact.to_string()), Some(fact));
        }
    }
}
