//! The pretty-printer: a syntax tree back to PDDL text that parses to the same tree.

use std::fmt::{self, Display, Formatter, Write};

use crate::ast::*;

impl Display for Name {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl Display for Type {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Type::Named(name) => write!(f, "{name}"),
            Type::Either(names) => {
                f.write_str("(either")?;
                for name in names {
                    write!(f, " {name}")?;
                }
                f.write_str(")")
            }
        }
    }
}

impl Display for Term {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Term::Variable(name) => write!(f, "?{name}"),
            Term::Constant(name) => write!(f, "{name}"),
        }
    }
}

fn write_head_and_args(f: &mut Formatter<'_>, head: &Name, args: &[Term]) -> fmt::Result {
    write!(f, "({head}")?;
    for arg in args {
        write!(f, " {arg}")?;
    }
    f.write_str(")")
}

impl Display for Atom {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write_head_and_args(f, &self.predicate, &self.args)
    }
}

impl Display for FunctionTerm {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write_head_and_args(f, &self.function, &self.args)
    }
}

impl Display for Number {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        // `f64`'s Display is the shortest text that parses back to the same value.
        write!(f, "{}", self.value)
    }
}

impl Display for NumericExpr {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            NumericExpr::Number(number) => write!(f, "{number}"),
            NumericExpr::Function(term) => write!(f, "{term}"),
        }
    }
}

/// A typed list, grouping consecutive entries of one type: `a b - t c`.
struct TypedList<'a> {
    entries: &'a [TypedName],
    variables: bool,
}

impl Display for TypedList<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        // Untyped entries must come where no `- type` follows them, so every run of entries
        // is closed by its type (or, if untyped, by a typed run or the end).
        let mut first = true;
        for (i, entry) in self.entries.iter().enumerate() {
            if !first {
                f.write_char(' ')?;
            }
            first = false;
            if self.variables {
                f.write_char('?')?;
            }
            write!(f, "{}", entry.name)?;
            let next_type = self.entries.get(i + 1).map(|next| &next.ty);
            if let Some(ty) = &entry.ty
                && next_type != Some(&entry.ty)
            {
                write!(f, " - {ty}")?;
            }
        }
        Ok(())
    }
}

fn typed_list(entries: &[TypedName], variables: bool) -> TypedList<'_> {
    TypedList { entries, variables }
}

impl Display for Condition {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Condition::Atom(atom) => write!(f, "{atom}"),
            Condition::Equals(a, b, _) => write!(f, "(= {a} {b})"),
            Condition::Not(inner, _) => write!(f, "(not {inner})"),
            Condition::And(parts, _) | Condition::Or(parts, _) => {
                f.write_str(if matches!(self, Condition::And(..)) { "(and" } else { "(or" })?;
                for part in parts {
                    write!(f, " {part}")?;
                }
                f.write_str(")")
            }
            Condition::Imply(a, b, _) => write!(f, "(imply {a} {b})"),
            Condition::Exists(variables, body, _) => write!(f, "(exists ({}) {body})", typed_list(variables, true)),
            Condition::Forall(variables, body, _) => write!(f, "(forall ({}) {body})", typed_list(variables, true)),
        }
    }
}

impl Display for Effect {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Effect::And(parts, _) => {
                f.write_str("(and")?;
                for part in parts {
                    write!(f, " {part}")?;
                }
                f.write_str(")")
            }
            Effect::Add(atom) => write!(f, "{atom}"),
            Effect::Delete(atom, _) => write!(f, "(not {atom})"),
            Effect::Forall(variables, body, _) => write!(f, "(forall ({}) {body})", typed_list(variables, true)),
            Effect::When(condition, body, _) => write!(f, "(when {condition} {body})"),
            Effect::Increase(function, value, _) => write!(f, "(increase {function} {value})"),
        }
    }
}

impl Display for Domain {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(f, "(define (domain {})", self.name)?;
        if !self.requirements.is_empty() {
            f.write_str("  (:requirements")?;
            for requirement in &self.requirements {
                write!(f, " :{requirement}")?;
            }
            f.write_str(")\n")?;
        }
        if !self.types.is_empty() {
            writeln!(f, "  (:types {})", typed_list(&self.types, false))?;
        }
        if !self.constants.is_empty() {
            writeln!(f, "  (:constants {})", typed_list(&self.constants, false))?;
        }
        if !self.predicates.is_empty() {
            f.write_str("  (:predicates")?;
            for predicate in &self.predicates {
                f.write_str("\n    (")?;
                write!(f, "{}", predicate.name)?;
                if !predicate.params.is_empty() {
                    write!(f, " {}", typed_list(&predicate.params, true))?;
                }
                f.write_char(')')?;
            }
            f.write_str(")\n")?;
        }
        if !self.functions.is_empty() {
            f.write_str("  (:functions")?;
            for (i, function) in self.functions.iter().enumerate() {
                f.write_str("\n    (")?;
                write!(f, "{}", function.name)?;
                if !function.params.is_empty() {
                    write!(f, " {}", typed_list(&function.params, true))?;
                }
                f.write_char(')')?;
                let next_type = self.functions.get(i + 1).map(|next| &next.ty);
                if let Some(ty) = &function.ty
                    && next_type != Some(&function.ty)
                {
                    write!(f, " - {ty}")?;
                }
            }
            f.write_str(")\n")?;
        }
        for action in &self.actions {
            writeln!(f, "  (:action {}", action.name)?;
            writeln!(f, "    :parameters ({})", typed_list(&action.params, true))?;
            if let Some(precondition) = &action.precondition {
                writeln!(f, "    :precondition {precondition}")?;
            }
            if let Some(effect) = &action.effect {
                writeln!(f, "    :effect {effect}")?;
            }
            f.write_str("  )\n")?;
        }
        f.write_str(")\n")
    }
}

impl Display for Problem {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(f, "(define (problem {})", self.name)?;
        writeln!(f, "  (:domain {})", self.domain)?;
        if !self.requirements.is_empty() {
            f.write_str("  (:requirements")?;
            for requirement in &self.requirements {
                write!(f, " :{requirement}")?;
            }
            f.write_str(")\n")?;
        }
        if !self.objects.is_empty() {
            writeln!(f, "  (:objects {})", typed_list(&self.objects, false))?;
        }
        f.write_str("  (:init")?;
        for element in &self.init {
            match element {
                InitElement::Atom(atom) => write!(f, "\n    {atom}")?,
                InitElement::Assign(function, value, _) => write!(f, "\n    (= {function} {value})")?,
            }
        }
        f.write_str(")\n")?;
        if let Some(goal) = &self.goal {
            writeln!(f, "  (:goal {goal})")?;
        }
        if let Some(metric) = &self.metric {
            let direction = match metric.optimization {
                Optimization::Minimize => "minimize",
                Optimization::Maximize => "maximize",
            };
            writeln!(f, "  (:metric {direction} {})", metric.expr)?;
        }
        f.write_str(")\n")
    }
}
