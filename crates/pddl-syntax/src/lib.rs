//! PDDL text ⇄ syntax tree, with diagnostics a person can act on.
//!
//! The parser never gives up: [`parse_domain_recovering`] and [`parse_problem_recovering`]
//! return what they could read *and* every diagnostic, each with a byte [`Span`] that
//! [`Diagnostic::render`] turns into `file:line:column`. The strict [`parse_domain`] and
//! [`parse_problem`] wrap them and fail on the first error-level diagnostic. [`check`]
//! resolves names (predicates, functions, types, objects, variables) and arities. The
//! `Display` impls print a tree back as PDDL that parses to an equal tree (names lowercased, as
//! the parser writes them).
//!
//! Supported: `:strips`, `:typing` (with `either`), `:negative-preconditions`,
//! `:disjunctive-preconditions`, `:equality`, `:existential-preconditions`,
//! `:universal-preconditions`, `:conditional-effects`, `:adl`, `:action-costs`
//! (`(increase (total-cost) n)` and `:metric`), constants and comments. Names are
//! case-insensitive and stored lowercased, as in Fast Downward.
//!
//! ```
//! let domain = pddl_syntax::parse_domain(
//!     "(define (domain d) (:predicates (p ?x)) (:action a :parameters (?x) :precondition (p ?x) :effect (not (p ?x))))",
//! ).unwrap();
//! assert_eq!(domain.actions[0].name.as_str(), "a");
//! let reparsed = pddl_syntax::parse_domain(&domain.to_string()).unwrap();
//! assert_eq!(reparsed, domain);
//! ```

mod ast;
mod check;
mod diagnostic;
mod parse;
mod print;
mod sexpr;
pub use sexpr::MAX_DEPTH;

pub use ast::{
    Action, Atom, Condition, Domain, Effect, FunctionDecl, FunctionTerm, InitElement, Metric, Name, Number, NumericExpr, Optimization,
    PredicateDecl, Problem, Requirement, Term, Type, TypedName,
};
pub use check::{CheckReport, check};
pub use diagnostic::{Diagnostic, DiagnosticKind, ParseError, Severity, Span, line_column};
pub use parse::{parse_domain_recovering, parse_problem_recovering};

/// Parses a domain; fails if any error-level diagnostic was found.
pub fn parse_domain(source: &str) -> Result<Domain, ParseError> {
    strict(source, parse_domain_recovering(source))
}

/// Parses a problem; fails if any error-level diagnostic was found.
pub fn parse_problem(source: &str) -> Result<Problem, ParseError> {
    strict(source, parse_problem_recovering(source))
}

fn strict<T>(source: &str, (tree, diagnostics): (Option<T>, Vec<Diagnostic>)) -> Result<T, ParseError> {
    match tree {
        Some(tree) if !diagnostics.iter().any(Diagnostic::is_error) => Ok(tree),
        _ => Err(ParseError::new(diagnostics, source)),
    }
}
