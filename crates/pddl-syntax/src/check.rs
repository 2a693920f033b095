//! Name resolution: every predicate, function, type, object and variable that a domain or
//! problem uses is declared, with the right number of arguments.
//!
//! Argument *types* of action bodies are not checked against predicate signatures, as in Fast
//! Downward: the ALFWorld domain applies `(checked ?a)` to an agent although `checked` is
//! declared over receptacles, and planners accept it (types only restrict what parameters
//! range over). A problem's ground atoms (`:init`, the goal) are checked, as a warning: an
//! object of another type in a goal atom makes a goal no typed action reaches, which is
//! otherwise only found by a search that fails.
//! Constants used in a domain's actions may be declared by the problem (ALFWorld's
//! `SinkType`), so they are checked when a problem is given.

use std::collections::{BTreeMap, BTreeSet};

use crate::ast::*;
use crate::diagnostic::{Diagnostic, DiagnosticKind, Span};

/// Diagnostics from [`check`], by the file they point into.
#[derive(Debug, Default, Clone)]
pub struct CheckReport {
    /// Findings on the domain (declarations, action bodies); spans point into the domain text.
    pub domain: Vec<Diagnostic>,
    /// Findings of the problem pass; spans point into the problem text. (A constant of the domain's
    /// actions that neither file declares is a domain finding, found once a problem is given.)
    pub problem: Vec<Diagnostic>,
}

impl CheckReport {
    /// Whether either list holds an error-level diagnostic.
    pub fn has_errors(&self) -> bool {
        self.domain.iter().chain(&self.problem).any(Diagnostic::is_error)
    }
}

/// Checks a domain, and a problem against it when one is given.
pub fn check(domain: &Domain, problem: Option<&Problem>) -> CheckReport {
    let mut report = CheckReport::default();
    // Constants in action bodies are resolved in the problem pass, where objects are known.
    let mut checker = Checker::new(domain, None, &mut report.domain);
    checker.declarations();
    for action in &domain.actions {
        checker.action(action);
    }
    if let Some(problem) = problem {
        let mut checker = Checker::new(domain, Some(problem), &mut report.problem);
        checker.problem(problem);
        // Constants of the domain's actions unknown to both files are errors in the domain text.
        Checker::new(domain, Some(problem), &mut report.domain).action_constants();
    }
    report
}

struct Checker<'a> {
    domain: &'a Domain,
    /// Whether constants outside the domain's `:constants` can be resolved (a problem is known).
    objects_known: bool,
    types: BTreeSet<&'a str>,
    predicates: BTreeMap<&'a str, usize>,
    functions: BTreeMap<&'a str, usize>,
    objects: BTreeSet<&'a str>,
    /// Variables in scope, innermost last.
    variables: Vec<&'a str>,
    /// Each declared type's parents (`object` has none).
    parents: BTreeMap<&'a str, Vec<&'a str>>,
    /// Each predicate's parameters.
    signatures: BTreeMap<&'a str, &'a [TypedName]>,
    /// The declared types of each constant and object (`object` when none is written).
    object_types: BTreeMap<&'a str, Vec<&'a str>>,
    /// Whether atoms are ground atoms of the problem (`:init`, goal), whose arguments' types are
    /// checked.
    ground: bool,
    out: &'a mut Vec<Diagnostic>,
}

/// The type names an entry of a typed list declares (`object` when none is written).
fn type_names(entry: &TypedName) -> Vec<&str> {
    entry.ty.as_ref().map_or_else(|| vec!["object"], |ty| ty.names().iter().map(Name::as_str).collect())
}

impl<'a> Checker<'a> {
    fn new(domain: &'a Domain, problem: Option<&'a Problem>, out: &'a mut Vec<Diagnostic>) -> Checker<'a> {
        let mut types: BTreeSet<&str> = BTreeSet::from(["object"]);
        for declared in &domain.types {
            types.insert(declared.name.as_str());
            if let Some(parent) = &declared.ty {
                types.extend(parent.names().iter().map(Name::as_str));
            }
        }
        let predicates = domain.predicates.iter().map(|p| (p.name.as_str(), p.params.len())).collect();
        let functions = domain.functions.iter().map(|f| (f.name.as_str(), f.params.len())).collect();
        let mut objects: BTreeSet<&str> = domain.constants.iter().map(|c| c.name.as_str()).collect();
        if let Some(problem) = problem {
            objects.extend(problem.objects.iter().map(|o| o.name.as_str()));
        }
        let mut parents: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for declared in &domain.types {
            parents.entry(declared.name.as_str()).or_default().extend(type_names(declared));
        }
        let signatures = domain.predicates.iter().map(|p| (p.name.as_str(), p.params.as_slice())).collect();
        let mut object_types: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for entry in domain.constants.iter().chain(problem.iter().flat_map(|p| &p.objects)) {
            object_types.entry(entry.name.as_str()).or_default().extend(type_names(entry));
        }
        Checker {
            domain,
            objects_known: problem.is_some(),
            types,
            predicates,
            functions,
            objects,
            variables: Vec::new(),
            parents,
            signatures,
            object_types,
            ground: false,
            out,
        }
    }

    /// Whether `ty` is `target` or one of its descendants (every type is an `object`).
    fn is_a(&self, ty: &str, target: &str) -> bool {
        let mut seen = BTreeSet::new();
        let mut stack = vec![ty];
        while let Some(t) = stack.pop() {
            if t == target || target == "object" {
                return true;
            }
            if seen.insert(t) {
                stack.extend(self.parents.get(t).into_iter().flatten().copied().filter(|p| *p != t));
            }
        }
        false
    }

    /// A ground atom's objects against the predicate's parameter types.
    fn argument_types(&mut self, atom: &Atom) {
        let Some(params) = self.signatures.get(atom.predicate.as_str()).copied() else { return };
        for (position, (arg, param)) in atom.args.iter().zip(params).enumerate() {
            let Term::Constant(name) = arg else { continue };
            let Some(has) = self.object_types.get(name.as_str()) else { continue };
            let wants = type_names(param);
            if has.iter().any(|t| wants.iter().any(|w| self.is_a(t, w))) {
                continue;
            }
            self.out.push(Diagnostic::warning(
                DiagnosticKind::TypeMismatch,
                name.span,
                format!(
                    "`{name}` ({}) is given to argument {} of `{}`, which takes {}: no typed action makes or uses this atom",
                    has.join(" or "),
                    position + 1,
                    atom.predicate,
                    wants.join(" or ")
                ),
            ));
        }
    }

    fn error(&mut self, kind: DiagnosticKind, span: Span, message: String) {
        self.out.push(Diagnostic::error(kind, span, message));
    }

    fn declarations(&mut self) {
        let domain = self.domain;
        for declared in domain.types.iter().chain(&domain.constants) {
            self.typed(declared);
        }
        let mut seen = BTreeSet::new();
        for predicate in &domain.predicates {
            if !seen.insert(predicate.name.as_str()) {
                self.error(DiagnosticKind::Duplicate, predicate.name.span, format!("predicate `{}` is declared twice", predicate.name));
            }
            self.parameters(&predicate.params, "predicate", &predicate.name);
        }
        let mut seen = BTreeSet::new();
        for function in &domain.functions {
            if !seen.insert(function.name.as_str()) {
                self.error(DiagnosticKind::Duplicate, function.name.span, format!("function `{}` is declared twice", function.name));
            }
            self.parameters(&function.params, "function", &function.name);
        }
        let mut seen = BTreeSet::new();
        for action in &domain.actions {
            if !seen.insert(action.name.as_str()) {
                self.error(DiagnosticKind::Duplicate, action.name.span, format!("action `{}` is declared twice", action.name));
            }
        }
    }

    fn parameters(&mut self, params: &[TypedName], owner: &str, owner_name: &Name) {
        let mut seen = BTreeSet::new();
        for param in params {
            if !seen.insert(param.name.as_str()) {
                self.error(
                    DiagnosticKind::Duplicate,
                    param.name.span,
                    format!("parameter `?{}` appears twice in {owner} `{owner_name}`", param.name),
                );
            }
            self.typed(param);
        }
    }

    fn typed(&mut self, entry: &TypedName) {
        let Some(ty) = &entry.ty else { return };
        for name in ty.names() {
            if !self.types.contains(name.as_str()) {
                let declared: Vec<&str> = self.types.iter().copied().collect();
                self.error(
                    DiagnosticKind::UnknownType,
                    name.span,
                    format!("type `{name}` is not declared in `(:types ...)`; declared types: {}", declared.join(", ")),
                );
            }
        }
    }

    fn action(&mut self, action: &'a Action) {
        self.parameters(&action.params, "action", &action.name);
        self.variables = action.params.iter().map(|p| p.name.as_str()).collect();
        if let Some(precondition) = &action.precondition {
            self.condition(precondition);
        }
        if let Some(effect) = &action.effect {
            self.effect(effect);
        }
        self.variables.clear();
    }

    fn term(&mut self, term: &Term) {
        match term {
            Term::Variable(name) => {
                if !self.variables.contains(&name.as_str()) {
                    self.error(
                        DiagnosticKind::UnknownVariable,
                        name.span,
                        if self.ground {
                            format!("variable `?{name}` is not bound by an enclosing `forall` or `exists` (the goal names objects)")
                        } else {
                            format!("variable `?{name}` is not a parameter of the action nor bound by an enclosing quantifier")
                        },
                    );
                }
            }
            Term::Constant(name) => {
                if self.objects_known && !self.objects.contains(name.as_str()) {
                    self.error(
                        DiagnosticKind::UnknownObject,
                        name.span,
                        format!("`{name}` is declared neither in the domain's `:constants` nor in the problem's `:objects`"),
                    );
                }
            }
        }
    }

    fn atom(&mut self, atom: &Atom) {
        match self.predicates.get(atom.predicate.as_str()) {
            None => self.error(
                DiagnosticKind::UnknownPredicate,
                atom.predicate.span,
                format!("predicate `{}` is not declared in `(:predicates ...)`", atom.predicate),
            ),
            Some(&arity) if arity != atom.args.len() => self.error(
                DiagnosticKind::ArityMismatch,
                atom.span,
                format!("predicate `{}` takes {arity} argument(s), but {} are given here", atom.predicate, atom.args.len()),
            ),
            Some(_) if self.ground => self.argument_types(atom),
            Some(_) => {}
        }
        for arg in &atom.args {
            self.term(arg);
        }
    }

    fn function_term(&mut self, term: &FunctionTerm) {
        match self.functions.get(term.function.as_str()) {
            None => self.error(
                DiagnosticKind::UnknownFunction,
                term.function.span,
                if term.function.as_str() == "total-cost" {
                    "function `total-cost` is not declared: add `(:functions (total-cost) - number)` to the domain".to_string()
                } else {
                    format!("function `{}` is not declared in `(:functions ...)`", term.function)
                },
            ),
            Some(&arity) if arity != term.args.len() => self.error(
                DiagnosticKind::ArityMismatch,
                term.span,
                format!("function `{}` takes {arity} argument(s), but {} are given here", term.function, term.args.len()),
            ),
            Some(_) => {}
        }
        for arg in &term.args {
            self.term(arg);
        }
    }

    fn quantified(&mut self, variables: &'a [TypedName], body: impl FnOnce(&mut Self)) {
        for variable in variables {
            self.typed(variable);
        }
        let depth = self.variables.len();
        self.variables.extend(variables.iter().map(|v| v.name.as_str()));
        body(self);
        self.variables.truncate(depth);
    }

    fn condition(&mut self, condition: &'a Condition) {
        match condition {
            Condition::Atom(atom) => self.atom(atom),
            Condition::Equals(a, b, _) => {
                self.term(a);
                self.term(b);
            }
            Condition::Not(inner, _) => self.condition(inner),
            Condition::And(parts, _) | Condition::Or(parts, _) => {
                for part in parts {
                    self.condition(part);
                }
            }
            Condition::Imply(a, b, _) => {
                self.condition(a);
                self.condition(b);
            }
            Condition::Exists(variables, body, _) | Condition::Forall(variables, body, _) => {
                self.quantified(variables, |checker| checker.condition(body));
            }
        }
    }

    fn effect(&mut self, effect: &'a Effect) {
        match effect {
            Effect::And(parts, _) => {
                for part in parts {
                    self.effect(part);
                }
            }
            Effect::Add(atom) | Effect::Delete(atom, _) => self.atom(atom),
            Effect::Forall(variables, body, _) => self.quantified(variables, |checker| checker.effect(body)),
            Effect::When(condition, body, _) => {
                self.condition(condition);
                self.effect(body);
            }
            Effect::Increase(function, value, span) => {
                self.function_term(function);
                if let NumericExpr::Function(term) = value {
                    self.function_term(term);
                    // Read as a fixed cost it was the initial value, however far the plan had
                    // come; the action-costs requirement forbids it (Fast Downward fails on it).
                    if term.function.as_str() == "total-cost" {
                        self.error(
                            DiagnosticKind::Unsupported,
                            *span,
                            "an action's cost cannot be `(total-cost)` itself: give a number or a function of the problem's `:init`"
                                .to_string(),
                        );
                    }
                }
            }
        }
    }

    fn problem(&mut self, problem: &'a Problem) {
        if problem.domain.as_str() != self.domain.name.as_str() && !problem.domain.as_str().is_empty() {
            self.out.push(Diagnostic::warning(
                DiagnosticKind::DomainMismatch,
                problem.domain.span,
                format!("the problem is for domain `{}`, but the domain given is `{}`", problem.domain, self.domain.name),
            ));
        }
        let mut seen: BTreeMap<&str, &Option<Type>> = self.domain.constants.iter().map(|c| (c.name.as_str(), &c.ty)).collect();
        for object in &problem.objects {
            self.typed(object);
            if let Some(previous) = seen.insert(object.name.as_str(), &object.ty) {
                if previous != &object.ty {
                    self.error(
                        DiagnosticKind::Duplicate,
                        object.name.span,
                        format!("object `{}` is declared twice, with different types", object.name),
                    );
                } else {
                    self.out.push(Diagnostic::warning(
                        DiagnosticKind::Duplicate,
                        object.name.span,
                        format!("object `{}` is declared twice", object.name),
                    ));
                }
            }
        }
        self.ground = true;
        // Each function value once: a second, different one was taken over the first in
        // silence (Fast Downward refuses the task, "conflicting assignment").
        let mut values: BTreeMap<(String, Vec<String>), f64> = BTreeMap::new();
        for element in &problem.init {
            match element {
                InitElement::Atom(atom) => self.atom(atom),
                InitElement::Assign(function, value, span) => {
                    self.function_term(function);
                    let key =
                        (function.function.as_str().to_string(), function.args.iter().map(|t| t.name().as_str().to_string()).collect());
                    if let Some(previous) = values.insert(key, value.value) {
                        let shown = format!(
                            "({}{})",
                            function.function,
                            function.args.iter().map(|t| format!(" {}", t.name())).collect::<String>()
                        );
                        if previous == value.value {
                            self.out.push(Diagnostic::warning(
                                DiagnosticKind::Duplicate,
                                *span,
                                format!("`{shown}` is given its value twice"),
                            ));
                        } else {
                            self.error(
                                DiagnosticKind::InvalidInit,
                                *span,
                                format!("`{shown}` is given two values, {previous} and then {}", value.value),
                            );
                        }
                    }
                }
            }
        }
        if let Some(goal) = &problem.goal {
            self.condition(goal);
        }
        self.ground = false;
        if let Some(Metric { optimization, expr, span }) = &problem.metric {
            if let NumericExpr::Function(term) = expr {
                self.function_term(term);
            }
            // Plans are searched for the least total cost: another metric was minimised as if
            // it were that one.
            let total_cost = matches!(expr, NumericExpr::Function(term) if term.function.as_str() == "total-cost" && term.args.is_empty());
            if *optimization == Optimization::Maximize || !total_cost {
                self.error(
                    DiagnosticKind::Unsupported,
                    *span,
                    "the supported metric is `(:metric minimize (total-cost))`: plans are searched for the least total cost".to_string(),
                );
            }
        }
    }

    /// The domain's action bodies may name the problem's objects (ALFWorld's `SinkType`): resolve
    /// them once the problem's objects are known. The diagnostics point into the domain text.
    fn action_constants(&mut self) {
        for action in &self.domain.actions {
            let mut constants = Vec::new();
            collect_action_constants(action, &mut constants);
            for name in constants {
                if !self.objects.contains(name.as_str()) {
                    self.error(
                        DiagnosticKind::UnknownObject,
                        name.span,
                        format!("action `{}` names `{name}`, which is declared neither in the domain's `:constants` nor in the problem's `:objects`", action.name),
                    );
                }
            }
        }
    }
}

fn collect_action_constants<'a>(action: &'a Action, out: &mut Vec<&'a Name>) {
    fn terms<'a>(args: &'a [Term], out: &mut Vec<&'a Name>) {
        out.extend(args.iter().filter_map(|t| match t {
            Term::Constant(name) => Some(name),
            Term::Variable(_) => None,
        }));
    }
    fn condition<'a>(c: &'a Condition, out: &mut Vec<&'a Name>) {
        match c {
            Condition::Atom(atom) => terms(&atom.args, out),
            Condition::Equals(a, b, _) => {
                terms(std::slice::from_ref(a), out);
                terms(std::slice::from_ref(b), out);
            }
            Condition::Not(inner, _) => condition(inner, out),
            Condition::And(parts, _) | Condition::Or(parts, _) => parts.iter().for_each(|p| condition(p, out)),
            Condition::Imply(a, b, _) => {
                condition(a, out);
                condition(b, out);
            }
            Condition::Exists(_, body, _) | Condition::Forall(_, body, _) => condition(body, out),
        }
    }
    fn effect<'a>(e: &'a Effect, out: &mut Vec<&'a Name>) {
        match e {
            Effect::And(parts, _) => parts.iter().for_each(|p| effect(p, out)),
            Effect::Add(atom) | Effect::Delete(atom, _) => terms(&atom.args, out),
            Effect::Forall(_, body, _) => effect(body, out),
            Effect::When(c, body, _) => {
                condition(c, out);
                effect(body, out);
            }
            Effect::Increase(function, value, _) => {
                terms(&function.args, out);
                if let NumericExpr::Function(term) = value {
                    terms(&term.args, out);
                }
            }
        }
    }
    if let Some(c) = &action.precondition {
        condition(c, out);
    }
    if let Some(e) = &action.effect {
        effect(e, out);
    }
}
