//! The syntax tree of PDDL domains and problems.
//!
//! Names are stored lowercased (PDDL is case-insensitive, as in Fast Downward); variables
//! are stored without their `?`. Every node that a diagnostic may point at carries a
//! [`Span`]; spans never take part in equality (see [`Span`]).

use crate::diagnostic::Span;

/// A name with where it was written. The parser lowercases names (PDDL is case-insensitive);
/// [`Name::new`] keeps the text as given, so a tree built in code with capitals prints text
/// that parses back to the lowercased tree.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Name {
    /// The name, lowercased when parsed; a variable's without its `?`.
    pub text: String,
    /// Where it was written; the default (empty) span for names built in code.
    pub span: Span,
}

impl Name {
    /// A name with `text` exactly as given (not lowercased) and the default span.
    pub fn new(text: impl Into<String>) -> Name {
        Name { text: text.into(), span: Span::default() }
    }

    /// The text, as stored (lowercased when parsed).
    pub fn as_str(&self) -> &str {
        &self.text
    }
}

/// A type annotation after `-`: one type, or `(either t1 t2 ...)`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Type {
    /// One type, such as `- location`.
    Named(Name),
    /// `(either t1 t2 ...)`: any of the listed types; never empty when parsed.
    Either(Vec<Name>),
}

impl Type {
    /// The named types this annotation admits.
    pub fn names(&self) -> &[Name] {
        match self {
            Type::Named(name) => std::slice::from_ref(name),
            Type::Either(names) => names,
        }
    }
}

/// An entry of a typed list: a type, constant, object or variable (without `?`) and its
/// type; `None` when no type was written (then it is `object`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct TypedName {
    /// The declared name; a variable's without its `?`.
    pub name: Name,
    /// The type written after `-` (for an entry of `:types`, its parent type); `None` when none was written.
    pub ty: Option<Type>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// An argument of an atom or function term.
pub enum Term {
    /// `?x`, stored as `x`.
    Variable(Name),
    /// A constant or object name.
    Constant(Name),
}

impl Term {
    /// The name, a variable's without its `?`.
    pub fn name(&self) -> &Name {
        match self {
            Term::Variable(name) | Term::Constant(name) => name,
        }
    }
}

/// `(predicate t1 ... tn)`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Atom {
    /// The predicate's name.
    pub predicate: Name,
    /// The arguments, in order.
    pub args: Vec<Term>,
    /// The whole parenthesized atom.
    pub span: Span,
}

/// A goal description (precondition, effect condition or goal).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Condition {
    /// `(p t1 ... tn)`.
    Atom(Atom),
    /// `(= t1 t2)`.
    Equals(Term, Term, Span),
    /// `(not CONDITION)`.
    Not(Box<Condition>, Span),
    /// `(and ...)`; the empty precondition `()` reads as `(and)`.
    And(Vec<Condition>, Span),
    /// `(or ...)`; `(or)` is false.
    Or(Vec<Condition>, Span),
    /// `(imply A B)`: `B` holds wherever `A` does.
    Imply(Box<Condition>, Box<Condition>, Span),
    /// `(exists (?x - t ...) BODY)`: the bound variables (without `?`) and the body.
    Exists(Vec<TypedName>, Box<Condition>, Span),
    /// `(forall (?x - t ...) BODY)`: the bound variables (without `?`) and the body.
    Forall(Vec<TypedName>, Box<Condition>, Span),
}

impl Condition {
    /// Where the whole condition was written.
    pub fn span(&self) -> Span {
        match self {
            Condition::Atom(atom) => atom.span,
            Condition::Equals(_, _, span)
            | Condition::Not(_, span)
            | Condition::And(_, span)
            | Condition::Or(_, span)
            | Condition::Imply(_, _, span)
            | Condition::Exists(_, _, span)
            | Condition::Forall(_, _, span) => *span,
        }
    }
}

/// `(f t1 ... tn)` in a numeric position.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FunctionTerm {
    /// The function's name, such as `total-cost`.
    pub function: Name,
    /// The arguments, in order.
    pub args: Vec<Term>,
    /// The whole parenthesized term.
    pub span: Span,
}

/// A number as written; `value` is its parsed value.
#[derive(Debug, Clone, PartialEq)]
pub struct Number {
    /// The value; finite when parsed (`inf` and `nan` are refused).
    pub value: f64,
    /// Where the number was written.
    pub span: Span,
}

impl Eq for Number {}
impl std::hash::Hash for Number {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        // `0.0 == -0.0`, so the two must hash alike (`+ 0.0` turns `-0.0` into `0.0`).
        (self.value + 0.0).to_bits().hash(state);
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A numeric value in `(increase ...)` or `:metric`: arithmetic such as `(+ a b)` is outside the
/// supported fragment.
pub enum NumericExpr {
    /// A literal number.
    Number(Number),
    /// A function's value, such as `(total-cost)`.
    Function(FunctionTerm),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// An action's effect.
pub enum Effect {
    /// `(and ...)`; the empty effect `()` reads as `(and)`.
    And(Vec<Effect>, Span),
    /// `(p t1 ... tn)`: makes the atom true.
    Add(Atom),
    /// `(not (p t1 ... tn))`: makes the atom false; the span covers the `(not ...)` form.
    Delete(Atom, Span),
    /// `(forall (?x - t ...) EFFECT)`: the effect for every binding of the variables (without `?`).
    Forall(Vec<TypedName>, Box<Effect>, Span),
    /// `(when CONDITION EFFECT)`: the effect applies only where the condition holds.
    When(Condition, Box<Effect>, Span),
    /// `(increase (f ...) expr)`: only `total-cost` is meaningful to planning (`:action-costs`).
    Increase(FunctionTerm, NumericExpr, Span),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A declaration in `:predicates`: `(name ?x - t ...)`.
pub struct PredicateDecl {
    /// The predicate's name.
    pub name: Name,
    /// The parameters (variables without `?`) and their types, in order.
    pub params: Vec<TypedName>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A declaration in `:functions`, such as `(total-cost) - number`.
pub struct FunctionDecl {
    /// The function's name.
    pub name: Name,
    /// The parameters (variables without `?`) and their types, in order.
    pub params: Vec<TypedName>,
    /// `- number` when written.
    pub ty: Option<Type>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// `(:action NAME :parameters (...) :precondition CONDITION :effect EFFECT)`.
pub struct Action {
    /// The action's name.
    pub name: Name,
    /// The parameters (variables without `?`) and their types, in order; empty when `:parameters` is
    /// not written.
    pub params: Vec<TypedName>,
    /// `None` when no `:precondition` was written (the action is always applicable), or, from a
    /// recovering parse, when it could not be read.
    pub precondition: Option<Condition>,
    /// `None` when no `:effect` was written, or, from a recovering parse, when it could not be read.
    pub effect: Option<Effect>,
    /// The whole `(:action ...)` form.
    pub span: Span,
}

/// A requirement flag such as `:strips`, stored without its colon.
pub type Requirement = Name;

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A domain: `(define (domain NAME) ...)`.
pub struct Domain {
    /// The name after `domain`.
    pub name: Name,
    /// `(:requirements ...)`, in the order written; unknown requirements are left out (each with an
    /// error).
    pub requirements: Vec<Requirement>,
    /// `(:types ...)`: each declared type with its parent.
    pub types: Vec<TypedName>,
    /// `(:constants ...)`: objects that every problem of the domain has, with their types.
    pub constants: Vec<TypedName>,
    /// `(:predicates ...)`, in the order written.
    pub predicates: Vec<PredicateDecl>,
    /// `(:functions ...)`, in the order written.
    pub functions: Vec<FunctionDecl>,
    /// The `(:action ...)` sections, in the order written.
    pub actions: Vec<Action>,
    /// The whole `(define ...)` form.
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A fact of a problem's `:init`.
pub enum InitElement {
    /// A ground atom that holds initially: every argument is a constant.
    Atom(Atom),
    /// `(= (f o1 ... on) value)`.
    Assign(FunctionTerm, Number, Span),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// Whether a `:metric` is to be made small or large.
pub enum Optimization {
    /// `minimize`: lower is better.
    Minimize,
    /// `maximize`: higher is better.
    Maximize,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// `(:metric minimize EXPR)` or `(:metric maximize EXPR)`.
pub struct Metric {
    /// Minimize or maximize.
    pub optimization: Optimization,
    /// The quantity optimized, usually `(total-cost)`.
    pub expr: NumericExpr,
    /// The whole `(:metric ...)` section.
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
/// A problem: `(define (problem NAME) (:domain DOMAIN) ...)`.
pub struct Problem {
    /// The name after `problem`.
    pub name: Name,
    /// The domain named in `(:domain ...)`; empty after a recovering parse that found no such section
    /// (which is an error).
    pub domain: Name,
    /// `(:requirements ...)`, in the order written; unknown requirements are left out (each with an
    /// error).
    pub requirements: Vec<Requirement>,
    /// `(:objects ...)`, with their types.
    pub objects: Vec<TypedName>,
    /// `(:init ...)`, in the order written; negative literals are left out (each with a warning).
    pub init: Vec<InitElement>,
    /// `(:goal ...)`: always `Some` after a strict parse; `None` from a recovering parse when the goal
    /// is missing or could not be read.
    pub goal: Option<Condition>,
    /// `(:metric ...)`; `None` when not written.
    pub metric: Option<Metric>,
    /// The whole `(define ...)` form.
    pub span: Span,
}
