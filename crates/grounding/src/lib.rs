//! Grounding: a PDDL domain and problem become a [`Task`] of interned facts and actions,
//! the way Fast Downward's translator does it.
//!
//! 1. **Types are compiled away**: each parameter and quantified variable ranges over the
//!    objects of its type (and subtypes; `either` is a union).
//! 2. **Relaxed reachability on the lifted task**: starting from the initial atoms, action
//!    schemas are *joined* against the atoms reached so far (never by enumerating argument
//!    tuples), negative conditions assumed satisfiable, until nothing new is reached. Only
//!    the instances found are grounded.
//! 3. **Instantiation**: quantifiers are expanded over objects (an `exists` only over
//!    bindings that can satisfy its body), atoms that no reachable action changes are
//!    evaluated against the initial state and disappear, and each formula becomes a
//!    disjunction of [`Condition`]s — conjunctions of literals plus clauses. A precondition
//!    with several disjuncts becomes several actions with the same name (Fast Downward
//!    splits disjunctions the same way); conditional effects keep their conditions.
//! 4. **Exact relaxed reachability on the ground task** drops what is still unreachable,
//!    facts that no remaining action changes become constants, ids are made dense.
//!
//! The goal may be any formula. It is represented as a [`Goal`]: a disjunction of
//! [`Condition`]s. ALFWorld's `(exists (?o ?r ...) (and ...))` goals become one disjunct
//! per binding that static facts and reachability allow.
//!
//! ```
//! let domain = pddl_syntax::parse_domain("(define (domain d) (:predicates (at ?x) (road ?x ?y))
//!     (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x)))))").unwrap();
//! let problem = pddl_syntax::parse_problem("(define (problem p) (:domain d) (:objects a b c)
//!     (:init (at a) (road a b) (road b a)) (:goal (at b)))").unwrap();
//! let task = grounding::ground(&domain, &problem).unwrap();
//! assert_eq!(task.actions.len(), 2); // go a b, go b a; nothing reaches c
//! assert_eq!(task.facts.len(), 2); // (at a), (at b); `road` is static
//! ```

mod ids;
mod instantiate;
mod join;
mod lifted;
mod prune;
mod reach;
pub mod relevance;
mod task;

pub use ids::{ActionId, FactId, ObjectId, PredicateId, SchemaId};
pub use reach::MAX_INSTANCES;
pub use task::{Action, Atom, Condition, ConditionalEffect, Cost, Goal, Literal, Object, Predicate, Schema, Task};

use pddl_syntax::{Diagnostic, Span, check};

/// Which of the two files an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PddlFile {
    /// The domain text, `(define (domain ...) ...)`.
    Domain,
    /// The problem text, `(define (problem ...) ...)`.
    Problem,
}

/// Why [`ground`] refused a domain and problem.
#[derive(Debug, thiserror::Error)]
pub enum GroundingError {
    /// The domain or problem does not check (unknown names, wrong arity, ...).
    #[error("the PDDL does not check: {}", first_message(.domain, .problem))]
    Invalid {
        /// [`pddl_syntax::CheckReport::domain`]: every diagnostic on the domain, warnings included.
        domain: Vec<Diagnostic>,
        /// [`pddl_syntax::CheckReport::problem`]: every diagnostic of the problem pass, warnings
        /// included.
        problem: Vec<Diagnostic>,
    },
    /// A name that does not resolve; [`check`] rejects these first, so this is a guard.
    #[error("{0} is not declared")]
    Unresolved(String),
    /// A construct of the domain outside the fragment, at `span` in the domain.
    #[error("unsupported: {message}")]
    Unsupported {
        /// What is unsupported, naming the action.
        message: String,
        /// The offending `(increase ...)` effect in the domain.
        span: Span,
    },
    /// At `span` in `file`: an action's precondition or the condition of one of its conditional
    /// effects (domain), or the goal (problem).
    #[error("{what} splits into more than 4096 alternatives; simplify its disjunctions")]
    TooManyAlternatives {
        /// The action instance, as `action (name a b)`, or `the goal`.
        what: String,
        /// [`PddlFile::Domain`] for an action, [`PddlFile::Problem`] for the goal.
        file: PddlFile,
        /// The whole `(:action ...)` form, or the goal's condition.
        span: Span,
    },
    /// An action with more reachable instances than grounding makes
    /// ([`MAX_INSTANCES`]); `span` is the action in the domain.
    #[error("action `{action}` has more than {limit} reachable instances: give its parameters types, or preconditions that bind them")]
    TooLarge {
        /// The action's name.
        action: String,
        /// The limit it passed.
        limit: usize,
        /// The whole `(:action ...)` form.
        span: Span,
    },
    /// `term` is the cost term as instantiated; `span` is where the domain writes it.
    #[error("{action}: its cost {term} has no value in the problem's `:init`")]
    MissingCost {
        /// The action instance, as `action (name a b)` with the problem's object names.
        action: String,
        /// The function term with its arguments bound, as `(f a b)`.
        term: String,
        /// Where the domain writes the term.
        span: Span,
    },
    /// At `span` in `file`: the first term that makes the cost invalid (a value in the
    /// problem's `:init`, or a number in the domain).
    #[error("{action}: cost {value} is not a whole number from 0 to 4294967295")]
    InvalidCost {
        /// The action instance, as `action (name a b)` with the problem's object names.
        action: String,
        /// The instance's total cost: the sum of all its `(increase (total-cost) ...)` terms.
        value: f64,
        /// Which file `span` points into.
        file: PddlFile,
        /// The first negative or fractional term, or, when only the sum is bad (above `u32::MAX`),
        /// the first term.
        span: Span,
    },
}

impl GroundingError {
    /// The file and span an error points at; `None` for [`GroundingError::Invalid`] (whose
    /// diagnostics carry their own spans) and [`GroundingError::Unresolved`].
    pub fn location(&self) -> Option<(PddlFile, Span)> {
        match self {
            GroundingError::Invalid { .. } | GroundingError::Unresolved(_) => None,
            GroundingError::Unsupported { span, .. } | GroundingError::MissingCost { span, .. } | GroundingError::TooLarge { span, .. } => {
                Some((PddlFile::Domain, *span))
            }
            GroundingError::TooManyAlternatives { file, span, .. } | GroundingError::InvalidCost { file, span, .. } => Some((*file, *span)),
        }
    }

    /// The error as `path:line:column: message` lines, each in the file it is about;
    /// `domain` and `problem` are `(path, source text)`.
    pub fn render(&self, domain: (&str, &str), problem: (&str, &str)) -> String {
        if let GroundingError::Invalid { domain: d, problem: p } = self {
            let lines = |(path, text): (&str, &str), all: &[Diagnostic]| {
                all.iter().filter(|d| d.is_error()).map(|d| d.render(path, text)).collect::<Vec<_>>()
            };
            let mut out: Vec<String> = Vec::new();
            // One line for the same error at the same place (a type every object of a list is
            // declared with is reported once per object).
            for line in lines(domain, d).into_iter().chain(lines(problem, p)) {
                if !out.contains(&line) {
                    out.push(line);
                }
            }
            return out.join("\n");
        }
        match self.location() {
            Some((file, span)) => {
                let (path, text) = if file == PddlFile::Domain { domain } else { problem };
                let (line, column) = pddl_syntax::line_column(text, span.start as usize);
                format!("{path}:{line}:{column}: {self}")
            }
            None => format!("{} with {}: {self}", domain.0, problem.0),
        }
    }
}

fn first_message(domain: &[Diagnostic], problem: &[Diagnostic]) -> String {
    domain.iter().chain(problem).find(|d| d.is_error()).map(|d| d.message.clone()).unwrap_or_default()
}

/// Grounds `problem` over `domain`. Both are name-checked first ([`pddl_syntax::check`]): its
/// errors are [`GroundingError::Invalid`]; its warnings (a problem naming another domain, an
/// atom no typed action makes or uses) are not returned here, so call `pddl_syntax::check`
/// yourself to show them, as `cargo xtask` does.
pub fn ground(domain: &pddl_syntax::Domain, problem: &pddl_syntax::Problem) -> Result<Task, GroundingError> {
    let report = check(domain, Some(problem));
    if report.has_errors() {
        return Err(GroundingError::Invalid { domain: report.domain, problem: report.problem });
    }
    let lifted = lifted::lift(domain, problem)?;
    let reachable = reach::reachable(&lifted)?;
    // Fluent atoms: reached and added by a reachable instance, or deleted by one.
    let mut fluent: Vec<(PredicateId, join::Tuple)> = reach::deleted_atoms(&lifted, &reachable);
    {
        let init: rustc_hash::FxHashSet<(PredicateId, &[ObjectId])> = lifted.init.iter().map(|(p, a)| (*p, a.as_slice())).collect();
        for (index, predicate) in lifted.predicates.iter().enumerate() {
            let predicate_id = PredicateId::from_index(index);
            let _ = predicate;
            for tuple in reachable.atoms.tuples(predicate_id) {
                if !init.contains(&(predicate_id, tuple.as_slice())) {
                    fluent.push((predicate_id, tuple.clone()));
                }
            }
        }
    }
    let instantiator = instantiate::Instantiator::new(&lifted, &reachable, fluent);
    let actions = instantiator.actions()?;
    let goal = instantiator.goal()?;
    let init = instantiator.init_facts();
    let mut static_facts = instantiator.static_facts();
    let pruned = prune::prune(instantiator.facts, actions, init, goal);
    static_facts.extend(pruned.now_static);
    static_facts.sort();
    Ok(Task {
        domain_name: domain.name.text.clone(),
        problem_name: problem.name.text.clone(),
        schemas: lifted.schemas.iter().map(|s| Schema { name: s.name.clone(), params: s.param_names.clone() }).collect(),
        objects: lifted.objects,
        predicates: lifted.predicates,
        facts: pruned.facts,
        actions: pruned.actions,
        init: pruned.init,
        goal: pruned.goal,
        static_facts,
        uses_costs: lifted.uses_costs,
    })
}
