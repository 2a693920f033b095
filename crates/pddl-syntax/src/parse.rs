//! From s-expressions to the syntax tree, collecting every diagnostic on the way.
//!
//! Each reader returns `None` for a form it cannot read, after reporting why; the caller
//! drops that form and goes on, so one run finds every independent error.

use crate::ast::*;
use crate::diagnostic::{Diagnostic, DiagnosticKind, Span};
use crate::sexpr::{self, SExpr};

/// Requirements whose constructs this crate reads.
const SUPPORTED_REQUIREMENTS: &[&str] = &[
    "strips",
    "typing",
    "negative-preconditions",
    "disjunctive-preconditions",
    "equality",
    "existential-preconditions",
    "universal-preconditions",
    "quantified-preconditions",
    "conditional-effects",
    "adl",
    "action-costs",
];

/// Requirements that exist in PDDL but whose constructs are outside the supported fragment.
const UNSUPPORTED_REQUIREMENTS: &[&str] = &[
    "numeric-fluents",
    "fluents",
    "object-fluents",
    "durative-actions",
    "duration-inequalities",
    "continuous-effects",
    "derived-predicates",
    "timed-initial-literals",
    "preferences",
    "constraints",
];

/// Reads a domain, returning what could be read and every diagnostic found.
pub fn parse_domain_recovering(source: &str) -> (Option<Domain>, Vec<Diagnostic>) {
    let mut reader = Reader { diagnostics: Vec::new() };
    let domain = reader.read_definition(source, "domain").and_then(|(name, sections, span)| reader.domain(name, sections, span));
    (domain, reader.diagnostics)
}

/// Reads a problem, returning what could be read and every diagnostic found.
pub fn parse_problem_recovering(source: &str) -> (Option<Problem>, Vec<Diagnostic>) {
    let mut reader = Reader { diagnostics: Vec::new() };
    let problem = reader.read_definition(source, "problem").and_then(|(name, sections, span)| reader.problem(name, sections, span));
    (problem, reader.diagnostics)
}

struct Reader {
    diagnostics: Vec<Diagnostic>,
}

impl Reader {
    fn error(&mut self, kind: DiagnosticKind, span: Span, message: impl Into<String>) {
        self.diagnostics.push(Diagnostic::error(kind, span, message));
    }

    fn warning(&mut self, kind: DiagnosticKind, span: Span, message: impl Into<String>) {
        self.diagnostics.push(Diagnostic::warning(kind, span, message));
    }

    fn unexpected(&mut self, form: &SExpr, expected: &str) {
        self.error(DiagnosticKind::UnexpectedForm, form.span(), format!("expected {expected}, found {}", form.describe()));
    }

    /// `(define (KIND name) sections...)`: returns the name and the section forms.
    fn read_definition(&mut self, source: &str, kind: &str) -> Option<(Name, Vec<SExpr>, Span)> {
        let forms = sexpr::read(source, &mut self.diagnostics);
        let mut forms = forms.into_iter();
        let Some(first) = forms.next() else {
            self.error(
                DiagnosticKind::ExpectedDefine,
                Span::new(0, source.len()),
                format!("the input holds no PDDL: expected `(define ({kind} NAME) ...)`"),
            );
            return None;
        };
        for extra in forms {
            self.error(
                DiagnosticKind::TrailingInput,
                extra.span(),
                format!("{} follows the end of the `(define ...)` form: a file holds one {kind}", extra.describe()),
            );
        }
        let span = first.span();
        let items = match first {
            SExpr::List(items, _) if matches!(items.first(), Some(SExpr::Word(w, _)) if w == "define") => items,
            other => {
                self.error(
                    DiagnosticKind::ExpectedDefine,
                    other.span(),
                    format!("expected `(define ({kind} NAME) ...)`, found {}", other.describe()),
                );
                return None;
            }
        };
        let mut items = items.into_iter().skip(1);
        let header = items.next();
        let name = match &header {
            Some(SExpr::List(h, _)) if h.len() == 2 && h[0].as_word() == Some(kind) => self.name(&h[1], &format!("the {kind}'s name")),
            Some(other) => {
                self.error(
                    DiagnosticKind::ExpectedDefine,
                    other.span(),
                    format!("expected `({kind} NAME)` after `define`, found {}", other.describe()),
                );
                None
            }
            None => {
                self.error(DiagnosticKind::ExpectedDefine, span, format!("`(define)` is empty: expected `({kind} NAME)`"));
                None
            }
        }?;
        Some((name, items.collect(), span))
    }

    fn domain(&mut self, name: Name, sections: Vec<SExpr>, span: Span) -> Option<Domain> {
        let mut domain = Domain {
            name,
            requirements: Vec::new(),
            types: Vec::new(),
            constants: Vec::new(),
            predicates: Vec::new(),
            functions: Vec::new(),
            actions: Vec::new(),
            span,
        };
        for section in &sections {
            let Some((keyword, body)) = self.section(section) else { continue };
            match keyword {
                ":requirements" => domain.requirements.extend(self.requirements(body)),
                ":types" => domain.types.extend(self.typed_list(body, false)),
                ":constants" => domain.constants.extend(self.typed_list(body, false)),
                ":predicates" => {
                    for declaration in body {
                        if let Some((name, params)) = self.signature(declaration, "a predicate declaration `(name ?x - type ...)`") {
                            domain.predicates.push(PredicateDecl { name, params });
                        }
                    }
                }
                ":functions" => domain.functions.extend(self.functions(body)),
                ":action" => {
                    if let Some(action) = self.action(section, body) {
                        domain.actions.push(action);
                    }
                }
                ":derived" | ":durative-action" | ":constraints" => self.error(
                    DiagnosticKind::Unsupported,
                    section.span(),
                    format!("`{keyword}` is outside the supported PDDL fragment (STRIPS, ADL, action costs)"),
                ),
                _ => self.error(
                    DiagnosticKind::UnknownSection,
                    section.span(),
                    format!(
                        "unknown domain section `{keyword}`: expected one of :requirements, :types, :constants, :predicates, :functions, :action"
                    ),
                ),
            }
        }
        Some(domain)
    }

    fn problem(&mut self, name: Name, sections: Vec<SExpr>, span: Span) -> Option<Problem> {
        let mut domain_name = None;
        let mut problem = Problem {
            name,
            domain: Name::new(""),
            requirements: Vec::new(),
            objects: Vec::new(),
            init: Vec::new(),
            goal: None,
            metric: None,
            span,
        };
        let mut seen: Vec<&str> = Vec::new();
        for section in &sections {
            let Some((keyword, body)) = self.section(section) else { continue };
            // One of each: a second `:domain`, `:goal` or `:metric` would silently replace the first.
            if matches!(keyword, ":domain" | ":goal" | ":metric") {
                if seen.contains(&keyword) {
                    self.error(DiagnosticKind::Duplicate, section.span(), format!("the problem has a second `({keyword}` section"));
                    continue;
                }
                seen.push(keyword);
            }
            match keyword {
                ":domain" => match body {
                    [word] => domain_name = self.name(word, "the domain's name"),
                    _ => self.error(DiagnosticKind::UnexpectedForm, section.span(), "expected `(:domain NAME)`"),
                },
                ":requirements" => problem.requirements.extend(self.requirements(body)),
                ":objects" => problem.objects.extend(self.typed_list(body, false)),
                ":init" => {
                    for element in body {
                        if let Some(element) = self.init_element(element) {
                            problem.init.push(element);
                        }
                    }
                }
                ":goal" => match body {
                    [goal] => problem.goal = self.condition(goal),
                    _ => self.error(DiagnosticKind::UnexpectedForm, section.span(), "expected `(:goal CONDITION)` with one condition"),
                },
                ":metric" => problem.metric = self.metric(section, body),
                ":constraints" => {
                    self.error(DiagnosticKind::Unsupported, section.span(), "`:constraints` is outside the supported PDDL fragment")
                }
                _ => self.error(
                    DiagnosticKind::UnknownSection,
                    section.span(),
                    format!("unknown problem section `{keyword}`: expected one of :domain, :requirements, :objects, :init, :goal, :metric"),
                ),
            }
        }
        match domain_name {
            Some(name) => problem.domain = name,
            None => self.error(DiagnosticKind::UnexpectedForm, span, "the problem has no `(:domain NAME)` section"),
        }
        if problem.goal.is_none() && !self.diagnostics.iter().any(|d| d.is_error()) {
            self.error(DiagnosticKind::UnexpectedForm, span, "the problem has no `(:goal ...)` section");
        }
        Some(problem)
    }

    /// `(:keyword body...)`.
    fn section<'a>(&mut self, form: &'a SExpr) -> Option<(&'a str, &'a [SExpr])> {
        match form {
            SExpr::List(items, _) => match items.first() {
                Some(SExpr::Word(keyword, _)) if keyword.starts_with(':') => Some((keyword.as_str(), &items[1..])),
                _ => {
                    self.unexpected(form, "a section such as `(:predicates ...)`");
                    None
                }
            },
            SExpr::Word(..) => {
                self.unexpected(form, "a section such as `(:predicates ...)`");
                None
            }
        }
    }

    fn requirements(&mut self, body: &[SExpr]) -> Vec<Requirement> {
        let mut requirements = Vec::new();
        for item in body {
            let Some(word) = item.as_word().and_then(|w| w.strip_prefix(':')) else {
                self.unexpected(item, "a requirement such as `:strips`");
                continue;
            };
            if UNSUPPORTED_REQUIREMENTS.contains(&word) {
                self.warning(
                    DiagnosticKind::Unsupported,
                    item.span(),
                    format!("requirement `:{word}` is outside the supported fragment; its constructs will be rejected where they appear"),
                );
            } else if !SUPPORTED_REQUIREMENTS.contains(&word) {
                self.error(DiagnosticKind::UnknownRequirement, item.span(), format!("`:{word}` is not a PDDL requirement"));
                continue;
            }
            requirements.push(Name { text: word.to_string(), span: item.span() });
        }
        requirements
    }

    /// A plain name: not a variable, keyword or list.
    fn name(&mut self, form: &SExpr, what: &str) -> Option<Name> {
        match form {
            SExpr::Word(word, span) if !word.starts_with('?') && !word.starts_with(':') && word != "-" => {
                Some(Name { text: word.clone(), span: *span })
            }
            _ => {
                self.unexpected(form, what);
                None
            }
        }
    }

    fn variable(&mut self, form: &SExpr) -> Option<Name> {
        match form {
            SExpr::Word(word, span) if word.starts_with('?') => {
                if word.len() == 1 {
                    self.error(DiagnosticKind::InvalidToken, *span, "`?` must be followed by a variable name");
                    return None;
                }
                Some(Name { text: word[1..].to_string(), span: *span })
            }
            _ => {
                self.unexpected(form, "a variable such as `?x`");
                None
            }
        }
    }

    fn ty(&mut self, form: &SExpr) -> Option<Type> {
        match form {
            SExpr::List(items, _) if form.head() == Some("either") => {
                let names: Vec<Name> = items[1..].iter().filter_map(|item| self.name(item, "a type name")).collect();
                if names.is_empty() {
                    self.unexpected(form, "at least one type in `(either ...)`");
                    return None;
                }
                Some(Type::Either(names))
            }
            _ => self.name(form, "a type name or `(either ...)` after `-`").map(Type::Named),
        }
    }

    /// `a b - t c - (either u v) d`: names (or variables) with the type after the next `-`.
    fn typed_list(&mut self, items: &[SExpr], variables: bool) -> Vec<TypedName> {
        let mut out: Vec<TypedName> = Vec::new();
        let mut untyped_from = 0;
        let mut i = 0;
        while i < items.len() {
            let item = &items[i];
            if item.as_word() == Some("-") {
                let Some(type_form) = items.get(i + 1) else {
                    self.error(DiagnosticKind::UnexpectedForm, item.span(), "`-` must be followed by a type");
                    break;
                };
                if untyped_from == out.len() {
                    self.error(DiagnosticKind::UnexpectedForm, item.span(), "`- type` must follow at least one name");
                }
                if let Some(ty) = self.ty(type_form) {
                    for entry in &mut out[untyped_from..] {
                        entry.ty = Some(ty.clone());
                    }
                }
                untyped_from = out.len();
                i += 2;
                continue;
            }
            let name = if variables { self.variable(item) } else { self.name(item, "a name") };
            if let Some(name) = name {
                out.push(TypedName { name, ty: None });
            }
            i += 1;
        }
        out
    }

    /// `(name ?x - t ...)` as in `:predicates` and `:functions`.
    fn signature(&mut self, form: &SExpr, what: &str) -> Option<(Name, Vec<TypedName>)> {
        match form {
            SExpr::List(items, _) if !items.is_empty() => {
                let name = self.name(&items[0], what)?;
                let params = self.typed_list(&items[1..], true);
                Some((name, params))
            }
            _ => {
                self.unexpected(form, what);
                None
            }
        }
    }

    fn functions(&mut self, body: &[SExpr]) -> Vec<FunctionDecl> {
        let mut out: Vec<FunctionDecl> = Vec::new();
        let mut untyped_from = 0;
        let mut i = 0;
        while i < body.len() {
            if body[i].as_word() == Some("-") {
                match body.get(i + 1).and_then(|form| self.ty(form)) {
                    Some(ty) => {
                        for declaration in &mut out[untyped_from..] {
                            declaration.ty = Some(ty.clone());
                        }
                    }
                    None if body.get(i + 1).is_none() => {
                        self.error(DiagnosticKind::UnexpectedForm, body[i].span(), "`-` must be followed by a type")
                    }
                    None => {}
                }
                untyped_from = out.len();
                i += 2;
                continue;
            }
            if let Some((name, params)) = self.signature(&body[i], "a function declaration `(name ?x ...)`") {
                out.push(FunctionDecl { name, params, ty: None });
            }
            i += 1;
        }
        out
    }

    fn action(&mut self, form: &SExpr, body: &[SExpr]) -> Option<Action> {
        let Some(name_form) = body.first() else {
            self.error(DiagnosticKind::UnexpectedForm, form.span(), "`(:action` must be followed by the action's name");
            return None;
        };
        let name = self.name(name_form, "the action's name")?;
        let mut action = Action { name, params: Vec::new(), precondition: None, effect: None, span: form.span() };
        let mut seen: Vec<&str> = Vec::new();
        let mut i = 1;
        while i < body.len() {
            let key = &body[i];
            let Some(value) = body.get(i + 1) else {
                self.error(DiagnosticKind::UnexpectedForm, key.span(), format!("{} has no value", key.describe()));
                break;
            };
            // Each key once: a second one would silently replace the first.
            if let Some(word) = key.as_word().filter(|w| matches!(*w, ":parameters" | ":precondition" | ":effect")) {
                if seen.contains(&word) {
                    self.error(DiagnosticKind::Duplicate, key.span(), format!("action `{}` has a second `{word}`", action.name));
                    i += 2;
                    continue;
                }
                seen.push(word);
            }
            match key.as_word() {
                Some(":parameters") => match value.as_list() {
                    Some(items) => action.params = self.typed_list(items, true),
                    None => self.unexpected(value, "a parameter list `(?x - type ...)`"),
                },
                Some(":precondition") => action.precondition = self.condition(value),
                Some(":effect") => action.effect = self.effect(value),
                _ => self.unexpected(key, "`:parameters`, `:precondition` or `:effect`"),
            }
            i += 2;
        }
        Some(action)
    }

    fn term(&mut self, form: &SExpr) -> Option<Term> {
        match form {
            SExpr::Word(word, _) if word.starts_with('?') => self.variable(form).map(Term::Variable),
            _ => self.name(form, "a variable or constant").map(Term::Constant),
        }
    }

    fn atom(&mut self, items: &[SExpr], span: Span) -> Option<Atom> {
        let predicate = self.name(&items[0], "a predicate name")?;
        let args: Option<Vec<Term>> = items[1..].iter().map(|item| self.term(item)).collect();
        Some(Atom { predicate, args: args?, span })
    }

    fn quantifier_variables(&mut self, form: Option<&SExpr>, span: Span, quantifier: &str) -> Option<Vec<TypedName>> {
        match form.and_then(SExpr::as_list) {
            Some(items) => Some(self.typed_list(items, true)),
            None => {
                self.error(DiagnosticKind::UnexpectedForm, span, format!("expected `({quantifier} (?x - type ...) BODY)`"));
                None
            }
        }
    }

    fn arguments<'a>(&mut self, items: &'a [SExpr], span: Span, count: usize, shape: &str) -> Option<&'a [SExpr]> {
        if items.len() == count + 1 {
            Some(&items[1..])
        } else {
            self.error(DiagnosticKind::UnexpectedForm, span, format!("expected `{shape}`"));
            None
        }
    }

    fn condition(&mut self, form: &SExpr) -> Option<Condition> {
        let SExpr::List(items, span) = form else {
            self.unexpected(form, "a condition in parentheses");
            return None;
        };
        let span = *span;
        let Some(head) = items.first() else { return Some(Condition::And(Vec::new(), span)) };
        match head.as_word() {
            Some("and") | Some("or") => {
                let parts: Vec<Condition> = items[1..].iter().filter_map(|item| self.condition(item)).collect();
                Some(if head.as_word() == Some("and") { Condition::And(parts, span) } else { Condition::Or(parts, span) })
            }
            Some("not") => {
                let [inner] = self.arguments(items, span, 1, "(not CONDITION)")? else { unreachable!() };
                Some(Condition::Not(Box::new(self.condition(inner)?), span))
            }
            Some("imply") => {
                let [a, b] = self.arguments(items, span, 2, "(imply CONDITION CONDITION)")? else { unreachable!() };
                let (a, b) = (self.condition(a), self.condition(b));
                Some(Condition::Imply(Box::new(a?), Box::new(b?), span))
            }
            Some(quantifier @ ("exists" | "forall")) => {
                let variables = self.quantifier_variables(items.get(1), span, quantifier)?;
                let [_, body] = self.arguments(items, span, 2, &format!("({quantifier} (?x - type ...) BODY)"))? else { unreachable!() };
                let body = Box::new(self.condition(body)?);
                Some(if quantifier == "exists" {
                    Condition::Exists(variables, body, span)
                } else {
                    Condition::Forall(variables, body, span)
                })
            }
            Some("=") => {
                let [a, b] = self.arguments(items, span, 2, "(= TERM TERM)")? else { unreachable!() };
                if a.as_list().is_some() || b.as_list().is_some() {
                    self.error(
                        DiagnosticKind::Unsupported,
                        span,
                        "numeric comparisons are outside the supported fragment (only `(= ?x ?y)` between objects)",
                    );
                    return None;
                }
                let (a, b) = (self.term(a), self.term(b));
                Some(Condition::Equals(a?, b?, span))
            }
            Some(op @ ("<" | ">" | "<=" | ">=")) => {
                self.error(DiagnosticKind::Unsupported, span, format!("numeric comparison `{op}` is outside the supported fragment"));
                None
            }
            Some(effect @ ("when" | "increase" | "decrease" | "assign" | "scale-up" | "scale-down")) => {
                self.error(
                    DiagnosticKind::UnexpectedForm,
                    span,
                    format!("`({effect} ...)` is an effect, not a condition: it goes in the action's `:effect`"),
                );
                None
            }
            Some(word) if word.starts_with(':') || word.starts_with('?') || word == "-" => {
                self.unexpected(form, "a condition");
                None
            }
            Some(_) => self.atom(items, span).map(Condition::Atom),
            None => {
                self.unexpected(form, "a condition");
                None
            }
        }
    }

    fn function_term(&mut self, form: &SExpr) -> Option<FunctionTerm> {
        match form {
            SExpr::List(items, span) if !items.is_empty() => {
                let function = self.name(&items[0], "a function name")?;
                let args: Option<Vec<Term>> = items[1..].iter().map(|item| self.term(item)).collect();
                Some(FunctionTerm { function, args: args?, span: *span })
            }
            _ => {
                self.unexpected(form, "a function term such as `(total-cost)`");
                None
            }
        }
    }

    fn number(&mut self, form: &SExpr) -> Option<Number> {
        match form {
            SExpr::Word(word, span) => match word.parse::<f64>() {
                Ok(value) if value.is_finite() => Some(Number { value, span: *span }),
                _ => {
                    self.error(DiagnosticKind::InvalidNumber, *span, format!("`{word}` is not a number"));
                    None
                }
            },
            SExpr::List(..) => {
                self.unexpected(form, "a number");
                None
            }
        }
    }

    fn numeric_expr(&mut self, form: &SExpr) -> Option<NumericExpr> {
        match form {
            SExpr::Word(..) => self.number(form).map(NumericExpr::Number),
            SExpr::List(items, span) => match items.first().and_then(SExpr::as_word) {
                Some("+" | "-" | "*" | "/") => {
                    self.error(
                        DiagnosticKind::Unsupported,
                        *span,
                        "arithmetic expressions are outside the supported fragment: use a number or a function term",
                    );
                    None
                }
                _ => self.function_term(form).map(NumericExpr::Function),
            },
        }
    }

    fn effect(&mut self, form: &SExpr) -> Option<Effect> {
        let SExpr::List(items, span) = form else {
            self.unexpected(form, "an effect in parentheses");
            return None;
        };
        let span = *span;
        let Some(head) = items.first() else { return Some(Effect::And(Vec::new(), span)) };
        match head.as_word() {
            Some("and") => Some(Effect::And(items[1..].iter().filter_map(|item| self.effect(item)).collect(), span)),
            Some("not") => {
                let [inner] = self.arguments(items, span, 1, "(not ATOM)")? else { unreachable!() };
                match inner {
                    SExpr::List(atom_items, atom_span)
                        if !atom_items.is_empty() && !matches!(inner.head(), Some("and" | "or" | "not" | "forall" | "exists" | "when")) =>
                    {
                        self.atom(atom_items, *atom_span).map(|atom| Effect::Delete(atom, span))
                    }
                    _ => {
                        self.unexpected(inner, "an atom after `not` in an effect");
                        None
                    }
                }
            }
            Some("forall") => {
                let variables = self.quantifier_variables(items.get(1), span, "forall")?;
                let [_, body] = self.arguments(items, span, 2, "(forall (?x - type ...) EFFECT)")? else { unreachable!() };
                Some(Effect::Forall(variables, Box::new(self.effect(body)?), span))
            }
            Some("when") => {
                let [condition, body] = self.arguments(items, span, 2, "(when CONDITION EFFECT)")? else { unreachable!() };
                let (condition, body) = (self.condition(condition), self.effect(body));
                Some(Effect::When(condition?, Box::new(body?), span))
            }
            Some("increase") => {
                let [function, value] = self.arguments(items, span, 2, "(increase (total-cost) VALUE)")? else { unreachable!() };
                let (function, value) = (self.function_term(function), self.numeric_expr(value));
                Some(Effect::Increase(function?, value?, span))
            }
            Some(op @ ("decrease" | "assign" | "scale-up" | "scale-down")) => {
                self.error(
                    DiagnosticKind::Unsupported,
                    span,
                    format!("`{op}` is outside the supported fragment (only `increase` of `total-cost`)"),
                );
                None
            }
            Some(condition @ ("or" | "exists" | "imply")) => {
                self.error(
                    DiagnosticKind::UnexpectedForm,
                    span,
                    format!("`({condition} ...)` is a condition, not an effect: an effect that depends on a condition is `(when CONDITION EFFECT)`"),
                );
                None
            }
            Some(word) if word.starts_with(':') || word.starts_with('?') || word == "-" => {
                self.unexpected(form, "an effect");
                None
            }
            Some(_) => self.atom(items, span).map(Effect::Add),
            None => {
                self.unexpected(form, "an effect");
                None
            }
        }
    }

    fn init_element(&mut self, form: &SExpr) -> Option<InitElement> {
        let SExpr::List(items, span) = form else {
            self.unexpected(form, "an initial fact in parentheses");
            return None;
        };
        let span = *span;
        match items.first().and_then(SExpr::as_word) {
            Some("=") => {
                let [function, value] = self.arguments(items, span, 2, "(= (function object ...) NUMBER)")? else { unreachable!() };
                let (function, value) = (self.function_term(function), self.number(value));
                let function = function?;
                if let Some(variable) = function.args.iter().find(|t| matches!(t, Term::Variable(_))) {
                    self.error(
                        DiagnosticKind::InvalidInit,
                        variable.name().span,
                        "`:init` holds ground facts only: replace the variable by an object",
                    );
                    return None;
                }
                Some(InitElement::Assign(function, value?, span))
            }
            Some("not") => {
                self.warning(
                    DiagnosticKind::InvalidInit,
                    span,
                    "negative literals in `:init` are redundant (what is not listed is false) and are ignored",
                );
                None
            }
            Some("at") if items.len() == 3 && items[1].as_word().is_some_and(|w| w.parse::<f64>().is_ok()) => {
                self.error(DiagnosticKind::Unsupported, span, "timed initial literals are outside the supported fragment");
                None
            }
            Some(_) => {
                let atom = self.atom(items, span)?;
                if let Some(variable) = atom.args.iter().find(|t| matches!(t, Term::Variable(_))) {
                    self.error(
                        DiagnosticKind::InvalidInit,
                        variable.name().span,
                        "`:init` holds ground facts only: replace the variable by an object",
                    );
                    return None;
                }
                Some(InitElement::Atom(atom))
            }
            None => {
                self.unexpected(form, "an initial fact such as `(at truck1 depot)`");
                None
            }
        }
    }

    fn metric(&mut self, section: &SExpr, body: &[SExpr]) -> Option<Metric> {
        let [direction, expr] = body else {
            self.error(DiagnosticKind::UnexpectedForm, section.span(), "expected `(:metric minimize (total-cost))`");
            return None;
        };
        let optimization = match direction.as_word() {
            Some("minimize") => Optimization::Minimize,
            Some("maximize") => Optimization::Maximize,
            _ => {
                self.unexpected(direction, "`minimize` or `maximize`");
                return None;
            }
        };
        let expr = self.numeric_expr(expr)?;
        Some(Metric { optimization, expr, span: section.span() })
    }
}
