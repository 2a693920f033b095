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
    pub text: String,
    pub span: Span,
}

impl Name {
    pub fn new(text: impl Into<String>) -> Name {
        Name { text: text.into(), span: Span::default() }
    }

    pub fn as_str(&self) -> &str {
        &self.text
    }
}

/// A type annotation after `-`: one type, or `(either t1 t2 ...)`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Type {
    Named(Name),
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
    pub name: Name,
    pub ty: Option<Type>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Term {
    /// `?x`, stored as `x`.
    Variable(Name),
    Constant(Name),
}

impl Term {
    pub fn name(&self) -> &Name {
        match self {
            Term::Variable(name) | Term::Constant(name) => name,
        }
    }
}

/// `(predicate t1 ... tn)`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Atom {
    pub predicate: Name,
    pub args: Vec<Term>,
    pub span: Span,
}

/// A goal description (precondition, effect condition or goal).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Condition {
    Atom(Atom),
    /// `(= t1 t2)`.
    Equals(Term, Term, Span),
    Not(Box<Condition>, Span),
    /// `(and ...)`; the empty precondition `()` reads as `(and)`.
    And(Vec<Condition>, Span),
    Or(Vec<Condition>, Span),
    Imply(Box<Condition>, Box<Condition>, Span),
    Exists(Vec<TypedName>, Box<Condition>, Span),
    Forall(Vec<TypedName>, Box<Condition>, Span),
}

impl Condition {
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
    pub function: Name,
    pub args: Vec<Term>,
    pub span: Span,
}

/// A number as written; `value` is its parsed value.
#[derive(Debug, Clone, PartialEq)]
pub struct Number {
    pub value: f64,
    pub span: Span,
}

impl Eq for Number {}
impl std::hash::Hash for Number {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.value.to_bits().hash(state);
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum NumericExpr {
    Number(Number),
    Function(FunctionTerm),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Effect {
    /// `(and ...)`; the empty effect `()` reads as `(and)`.
    And(Vec<Effect>, Span),
    Add(Atom),
    Delete(Atom, Span),
    Forall(Vec<TypedName>, Box<Effect>, Span),
    When(Condition, Box<Effect>, Span),
    /// `(increase (f ...) expr)`: only `total-cost` is meaningful to planning (`:action-costs`).
    Increase(FunctionTerm, NumericExpr, Span),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PredicateDecl {
    pub name: Name,
    pub params: Vec<TypedName>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FunctionDecl {
    pub name: Name,
    pub params: Vec<TypedName>,
    /// `- number` when written.
    pub ty: Option<Type>,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Action {
    pub name: Name,
    pub params: Vec<TypedName>,
    pub precondition: Option<Condition>,
    pub effect: Option<Effect>,
    pub span: Span,
}

/// A requirement flag such as `:strips`, stored without its colon.
pub type Requirement = Name;

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Domain {
    pub name: Name,
    pub requirements: Vec<Requirement>,
    /// `(:types ...)`: each declared type with its parent.
    pub types: Vec<TypedName>,
    pub constants: Vec<TypedName>,
    pub predicates: Vec<PredicateDecl>,
    pub functions: Vec<FunctionDecl>,
    pub actions: Vec<Action>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum InitElement {
    Atom(Atom),
    /// `(= (f o1 ... on) value)`.
    Assign(FunctionTerm, Number, Span),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Optimization {
    Minimize,
    Maximize,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Metric {
    pub optimization: Optimization,
    pub expr: NumericExpr,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Problem {
    pub name: Name,
    pub domain: Name,
    pub requirements: Vec<Requirement>,
    pub objects: Vec<TypedName>,
    pub init: Vec<InitElement>,
    pub goal: Option<Condition>,
    pub metric: Option<Metric>,
    pub span: Span,
}
