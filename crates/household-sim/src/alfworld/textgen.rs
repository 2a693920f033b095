//! TextWorld's context-sensitive grammar (`textworld/envs/pddl/textgen`): how the engine
//! turns a rule such as `"You arrive at {r.name}. #examineReceptacle.feedback#"` into text.
//!
//! **Parsing** a right-hand side follows `textgen.ebnf` as TatSu runs it: a sequence of
//! symbols, each the first that matches of `[ {...} ]` (a list), `{expr | query}` (a
//! conditional), `#name#` (a nonterminal) and a literal (`"..."` or the longest text free of
//! `;|"<>[]#{}`). Parsing stops silently where no symbol matches (TatSu's `{Symbol}+` without
//! an end anchor), so text after a stray `}` is dropped as the engine drops it. Before a
//! symbol, at the start of the text or of a line, TatSu's end-of-line comment pattern
//! `^(//.*|\s*)\n?` eats blank space and `//` lines; tabs are white space everywhere.
//!
//! **Deriving** a nonterminal takes the first production whose condition (a conjunctive
//! query over the fact store, under the current bindings) has an assignment; a conditional
//! yields its expression once per assignment of its query (or once, without one); a list
//! shows those results as `a`, `a#list_last_separator#b` or `a#list_separator#b...`, and
//! `#list_empty#` when there are none; an expression is Python over the bound entities
//! (`o.name`, `o.indefinite + ' ' + o.name`, `r.name or r.id`), of which this module
//! evaluates names, attributes, string literals, `+` and `or`.

use super::facts::{Entity, FactStore, Mapping, Placeholder, Predicates, Query};
use super::names::EntityInfo;

#[derive(Debug, Clone)]
pub(crate) enum Symbol {
    Terminal(String),
    Nonterminal(String),
    Conditional { expression: Box<Symbol>, given: Option<Query> },
    List(Box<Symbol>),
    Eval(Expr),
}

/// A Python expression over bound entities.
#[derive(Debug, Clone)]
pub(crate) enum Expr {
    Str(String),
    Var(String),
    Attr(String, String),
    Concat(Vec<Expr>),
    Or(Vec<Expr>),
}

/// The bindings a symbol is derived under: placeholders (for queries) and variable names
/// (for expressions), as TextWorld's context `mapping` and `variables`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Context {
    pub mapping: Mapping,
    pub variables: Vec<(String, Entity)>,
}

impl Context {
    fn bind_all(&mut self, mapping: Mapping) {
        for (placeholder, entity) in &mapping {
            match self.variables.iter_mut().find(|(n, _)| *n == placeholder.name) {
                Some(slot) => slot.1 = *entity,
                None => self.variables.push((placeholder.name.clone(), *entity)),
            }
        }
        self.mapping = mapping;
    }

    pub(crate) fn bind(&mut self, placeholder: Placeholder, entity: Entity) {
        let name = placeholder.name.clone();
        match self.mapping.iter_mut().find(|(p, _)| *p == placeholder) {
            Some(slot) => slot.1 = entity,
            None => self.mapping.push((placeholder, entity)),
        }
        match self.variables.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = entity,
            None => self.variables.push((name, entity)),
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Production {
    pub condition: Option<Query>,
    pub rhs: Vec<Symbol>,
}

/// The merged grammar: symbol name → productions in order.
#[derive(Debug, Clone, Default)]
pub(crate) struct Grammar {
    pub rules: Vec<(String, Vec<Production>)>,
}

/// Where deriving failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum DeriveError {
    UnknownSymbol(String),
    NoProduction(String),
    UnboundName(String),
    BadExpression(String),
}

impl std::fmt::Display for DeriveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DeriveError::UnknownSymbol(s) => write!(f, "the grammar has no symbol `#{s}#`"),
            DeriveError::NoProduction(s) => write!(f, "no production of `#{s}#` applies"),
            DeriveError::UnboundName(s) => write!(f, "the expression names `{s}`, which nothing binds"),
            DeriveError::BadExpression(s) => write!(f, "cannot evaluate `{s}`"),
        }
    }
}

// ---------------------------------------------------------------------------------------
// Parsing

struct Parser<'a> {
    text: &'a str,
    predicates: &'a Predicates,
}

fn is_python_space(c: char) -> bool {
    c.is_whitespace() || ('\u{1c}'..='\u{1f}').contains(&c)
}

impl Parser<'_> {
    /// TatSu's `next_token`: end-of-line comments at line starts, then tabs, until nothing moves.
    fn skip(&self, mut pos: usize) -> usize {
        loop {
            let start = pos;
            let at_line_start = pos == 0 || self.text.as_bytes()[pos - 1] == b'\n';
            if at_line_start {
                let rest = &self.text[pos..];
                let eaten = if rest.starts_with("//") {
                    let line = rest.find('\n').unwrap_or(rest.len());
                    line + usize::from(rest[line..].starts_with('\n'))
                } else {
                    let spaces = rest.len() - rest.trim_start_matches(is_python_space).len();
                    spaces + usize::from(rest[spaces..].starts_with('\n'))
                };
                pos += eaten;
            }
            let rest = &self.text[pos..];
            pos += rest.len() - rest.trim_start_matches('\t').len();
            if pos == start {
                return pos;
            }
        }
    }

    fn token(&self, pos: usize, token: &str) -> Option<usize> {
        let pos = self.skip(pos);
        self.text[pos..].starts_with(token).then_some(pos + token.len())
    }

    /// The longest run of characters allowed by `allowed`, at `pos`.
    fn run(&self, pos: usize, allowed: impl Fn(char) -> bool) -> usize {
        let rest = &self.text[pos..];
        pos + rest.find(|c: char| !allowed(c)).unwrap_or(rest.len())
    }

    fn symbols(&self, mut pos: usize) -> Result<Vec<Symbol>, String> {
        let mut out = Vec::new();
        while let Some((symbol, next)) = self.symbol(pos)? {
            if next == pos {
                break;
            }
            out.push(symbol);
            pos = next;
        }
        Ok(out)
    }

    fn symbol(&self, pos: usize) -> Result<Option<(Symbol, usize)>, String> {
        if let Some(found) = self.list(pos)? {
            return Ok(Some(found));
        }
        if let Some(found) = self.conditional(pos)? {
            return Ok(Some(found));
        }
        if let Some(found) = self.nonterminal(pos) {
            return Ok(Some(found));
        }
        Ok(self.terminal(pos))
    }

    fn list(&self, pos: usize) -> Result<Option<(Symbol, usize)>, String> {
        let Some(pos) = self.token(pos, "[") else { return Ok(None) };
        let Some((inner, pos)) = self.conditional(pos)? else { return Ok(None) };
        let Some(pos) = self.token(pos, "]") else { return Ok(None) };
        Ok(Some((Symbol::List(Box::new(inner)), pos)))
    }

    fn conditional(&self, pos: usize) -> Result<Option<(Symbol, usize)>, String> {
        let Some(pos) = self.token(pos, "{") else { return Ok(None) };
        let (expression, mut pos) = match self.nonterminal(pos) {
            Some(found) => found,
            None => {
                let start = self.skip(pos);
                let end = self.run(start, |c| !matches!(c, '|' | '[' | ']' | '{' | '}' | '\n' | '<' | '>'));
                if end == start {
                    return Ok(None);
                }
                let statement = &self.text[start..end];
                (Symbol::Eval(parse_expr(statement)?), end)
            }
        };
        let mut given = None;
        // `[?"\s*\|\s*" given:given]`
        let rest = &self.text[pos..];
        let after_space = pos + rest.len() - rest.trim_start_matches(is_python_space).len();
        if self.text[after_space..].starts_with('|') {
            let rest = &self.text[after_space + 1..];
            let start = self.skip(after_space + 1 + rest.len() - rest.trim_start_matches(is_python_space).len());
            let end = self.run(start, |c| !matches!(c, ';' | '|' | '{' | '}' | '\n' | '[' | ']' | '#'));
            if end > start {
                let query = Query::parse(&self.text[start..end], self.predicates)
                    .map_err(|e| format!("in the query `{}`: {e}", &self.text[start..end]))?;
                given = Some(query);
                pos = end;
            }
        }
        let Some(pos) = self.token(pos, "}") else { return Ok(None) };
        Ok(Some((Symbol::Conditional { expression: Box::new(expression), given }, pos)))
    }

    fn nonterminal(&self, pos: usize) -> Option<(Symbol, usize)> {
        let pos = self.token(pos, "#")?;
        let start = self.skip(pos);
        let end = self.run(start, |c| c.is_alphanumeric() || c == '_' || is_python_space(c) || "()/!<>-,.".contains(c));
        if end == start {
            return None;
        }
        let close = self.token(end, "#")?;
        Some((Symbol::Nonterminal(self.text[start..end].to_string()), close))
    }

    fn terminal(&self, pos: usize) -> Option<(Symbol, usize)> {
        let literal = |c: char| !matches!(c, ';' | '|' | '"' | '<' | '>' | '[' | ']' | '#' | '{' | '}');
        let start = self.skip(pos);
        if let Some(open) = self.token(start, "\"") {
            let end = self.run(open, literal);
            if let Some(close) = self.token(end, "\"") {
                return Some((Symbol::Terminal(self.text[open..end].replace("\\n", "\n")), close));
            }
        }
        let end = self.run(start, literal);
        (end > start).then(|| (Symbol::Terminal(self.text[start..end].replace("\\n", "\n")), end))
    }
}

/// Parses a right-hand side (`symbols` in textgen.ebnf).
pub(crate) fn parse_symbols(text: &str, predicates: &Predicates) -> Result<Vec<Symbol>, String> {
    Parser { text, predicates }.symbols(0)
}

fn parse_expr(text: &str) -> Result<Expr, String> {
    let bad = || format!("unsupported expression `{}`", text.trim());
    let mut alternatives = Vec::new();
    for alternative in split_outside_quotes(text, " or ") {
        let mut parts = Vec::new();
        for part in split_outside_quotes(&alternative, "+") {
            let part = part.trim();
            let quoted = |q: char| part.len() >= 2 && part.starts_with(q) && part.ends_with(q);
            if quoted('\'') || quoted('"') {
                parts.push(Expr::Str(part[1..part.len() - 1].to_string()));
            } else if let Some((var, attr)) = part.split_once('.') {
                if !is_identifier(var) || !is_identifier(attr) {
                    return Err(bad());
                }
                parts.push(Expr::Attr(var.to_string(), attr.to_string()));
            } else if is_identifier(part) {
                parts.push(Expr::Var(part.to_string()));
            } else {
                return Err(bad());
            }
        }
        alternatives.push(if parts.len() == 1 { parts.pop().expect("one") } else { Expr::Concat(parts) });
    }
    Ok(if alternatives.len() == 1 { alternatives.pop().expect("one") } else { Expr::Or(alternatives) })
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_alphabetic() || c == '_') && chars.all(|c| c.is_alphanumeric() || c == '_')
}

fn split_outside_quotes(text: &str, separator: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut current = String::new();
    let mut quote: Option<char> = None;
    let mut i = 0;
    while i < text.len() {
        let c = text[i..].chars().next().expect("in bounds");
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '\'' || c == '"' => quote = Some(c),
            None if text[i..].starts_with(separator) => {
                out.push(std::mem::take(&mut current));
                i += separator.len();
                continue;
            }
            None => {}
        }
        current.push(c);
        i += c.len_utf8();
    }
    out.push(current);
    out
}

/// Every nonterminal a symbol list names, for checking a grammar when it loads.
pub(crate) fn nonterminals<'a>(symbols: &'a [Symbol], out: &mut Vec<&'a str>) {
    for symbol in symbols {
        match symbol {
            Symbol::Nonterminal(name) => out.push(name),
            Symbol::Conditional { expression, .. } => nonterminals(std::slice::from_ref(expression), out),
            Symbol::List(inner) => {
                out.extend(["list_empty", "list_separator", "list_last_separator"]);
                nonterminals(std::slice::from_ref(inner), out);
            }
            Symbol::Terminal(_) | Symbol::Eval(_) => {}
        }
    }
}

// ---------------------------------------------------------------------------------------
// Deriving

enum Value<'a> {
    Str(String),
    Entity(&'a EntityInfo),
}

impl Value<'_> {
    fn into_string(self) -> String {
        match self {
            Value::Str(s) => s,
            Value::Entity(e) => e.name.clone(),
        }
    }

    fn truthy(&self) -> bool {
        match self {
            Value::Str(s) => !s.is_empty(),
            Value::Entity(_) => true,
        }
    }
}

/// What derivation reads: the grammar, the fact store and the entities.
pub(crate) struct World<'a> {
    pub grammar: &'a Grammar,
    pub facts: &'a FactStore,
    pub entities: &'a [EntityInfo],
}

impl World<'_> {
    pub(crate) fn derive(&self, symbols: &[Symbol], context: &Context) -> Result<String, DeriveError> {
        let mut out = String::new();
        for symbol in symbols {
            self.derive_symbol(symbol, context, &mut out)?;
        }
        Ok(out)
    }

    fn derive_symbol(&self, symbol: &Symbol, context: &Context, out: &mut String) -> Result<(), DeriveError> {
        match symbol {
            Symbol::Terminal(text) => out.push_str(text),
            Symbol::Nonterminal(name) => self.derive_nonterminal(name, context, out)?,
            Symbol::Eval(expr) => out.push_str(&self.eval(expr, context)?.into_string()),
            Symbol::Conditional { .. } => {
                for (expression, bound) in self.expand(symbol, context) {
                    self.derive_symbol(expression, &bound, out)?;
                }
            }
            Symbol::List(inner) => {
                let items = self.expand(inner, context);
                match items.len() {
                    0 => self.derive_nonterminal("list_empty", context, out)?,
                    n => {
                        for (i, (expression, bound)) in items.iter().enumerate() {
                            if i > 0 {
                                let separator = if i == n - 1 { "list_last_separator" } else { "list_separator" };
                                self.derive_nonterminal(separator, context, out)?;
                            }
                            self.derive_symbol(expression, bound, out)?;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// A conditional's expression once per assignment of its query, each under its bindings.
    fn expand<'s>(&self, symbol: &'s Symbol, context: &Context) -> Vec<(&'s Symbol, Context)> {
        match symbol {
            Symbol::Conditional { expression, given: Some(query) } => query
                .assignments(self.facts, &context.mapping)
                .into_iter()
                .map(|mapping| {
                    let mut bound = context.clone();
                    bound.bind_all(mapping);
                    (&**expression, bound)
                })
                .collect(),
            Symbol::Conditional { expression, given: None } => vec![(&**expression, context.clone())],
            other => vec![(other, context.clone())],
        }
    }

    fn derive_nonterminal(&self, name: &str, context: &Context, out: &mut String) -> Result<(), DeriveError> {
        let productions = self
            .grammar
            .rules
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, p)| p)
            .filter(|p| !p.is_empty())
            .ok_or_else(|| DeriveError::UnknownSymbol(name.to_string()))?;
        let production = productions
            .iter()
            .find(|p| p.condition.as_ref().is_none_or(|q| q.holds(self.facts, &context.mapping)))
            .ok_or_else(|| DeriveError::NoProduction(name.to_string()))?;
        for symbol in &production.rhs {
            self.derive_symbol(symbol, context, out)?;
        }
        Ok(())
    }

    fn eval(&self, expr: &Expr, context: &Context) -> Result<Value<'_>, DeriveError> {
        let entity = |name: &str| -> Result<&EntityInfo, DeriveError> {
            let (_, e) =
                context.variables.iter().rev().find(|(n, _)| n == name).ok_or_else(|| DeriveError::UnboundName(name.to_string()))?;
            Ok(&self.entities[*e as usize])
        };
        Ok(match expr {
            Expr::Str(s) => Value::Str(s.clone()),
            Expr::Var(name) => Value::Entity(entity(name)?),
            Expr::Attr(name, attr) => {
                let info = entity(name)?;
                Value::Str(match attr.as_str() {
                    "name" => info.name.clone(),
                    "id" => info.id.clone(),
                    "indefinite" => info.indefinite().to_string(),
                    "definite" => info.definite().to_string(),
                    other => return Err(DeriveError::BadExpression(format!("{name}.{other}"))),
                })
            }
            Expr::Concat(parts) => {
                let mut s = String::new();
                for part in parts {
                    match self.eval(part, context)? {
                        Value::Str(text) => s.push_str(&text),
                        Value::Entity(e) => {
                            return Err(DeriveError::BadExpression(format!("an entity ({}) added to text", e.id)));
                        }
                    }
                }
                Value::Str(s)
            }
            Expr::Or(alternatives) => {
                let mut last = Value::Str(String::new());
                for alternative in alternatives {
                    last = self.eval(alternative, context)?;
                    if last.truthy() {
                        break;
                    }
                }
                last
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Vec<Symbol> {
        let mut predicates = Predicates::default();
        predicates.intern("at");
        parse_symbols(text, &predicates).expect("parses")
    }

    fn terminals(symbols: &[Symbol]) -> Vec<String> {
        symbols
            .iter()
            .map(|s| match s {
                Symbol::Terminal(t) => format!("T{t:?}"),
                Symbol::Nonterminal(n) => format!("N{n}"),
                Symbol::Conditional { given, .. } => format!("C{}", given.is_some()),
                Symbol::List(_) => "L".into(),
                Symbol::Eval(_) => "E".into(),
            })
            .collect()
    }

    /// TatSu's end-of-line comment rule eats a leading newline (help's feedback starts with one).
    #[test]
    fn a_leading_newline_is_eaten_and_inner_ones_kept() {
        assert_eq!(terminals(&parse("\nAvailable commands:\n  look\n")), [r#"T"Available commands:\n  look\n""#]);
        assert_eq!(terminals(&parse("a\n\n#b#\n\n#c#")), [r#"T"a\n\n""#, "Nb", r#"T"\n\n""#, "Nc"]);
    }

    /// Parsing stops where no symbol matches: the text after a stray `}` is dropped.
    #[test]
    fn text_after_a_stray_brace_is_dropped() {
        assert_eq!(terminals(&parse("{o.name} (in {r.name})} tail")), ["Cfalse", r#"T" (in ""#, "Cfalse", r#"T")""#]);
    }

    #[test]
    fn lists_conditionals_and_expressions() {
        let symbols = parse("[{x.indefinite + ' ' + x.name | at(x:thing, l:place)}] and #y#");
        assert_eq!(terminals(&symbols), ["L", r#"T" and ""#, "Ny"]);
        let Symbol::List(inner) = &symbols[0] else { panic!("a list") };
        let Symbol::Conditional { expression, given: Some(query) } = &**inner else { panic!("a conditional with a query") };
        assert!(matches!(&**expression, Symbol::Eval(Expr::Concat(parts)) if parts.len() == 3));
        assert_eq!(query.placeholders.len(), 2);
        assert!(parse_expr("r.name or r.id").is_ok_and(|e| matches!(e, Expr::Or(v) if v.len() == 2)));
        assert!(parse_expr("os.system('x')").is_err());
    }
}
