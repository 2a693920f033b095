//! Diagnostics: what went wrong, where (byte span → line:column), and how bad it is.

use std::fmt;

/// A byte range `start..end` in one source text.
///
/// Spans locate a node; they are not part of its meaning. Two spans therefore always
/// compare equal (and hash alike), so that syntax trees compare by what they say, not by
/// where it was written: `parse(print(tree)) == tree` is the pretty-printer's law. Compare
/// [`Span::range`] to compare locations.
#[derive(Debug, Clone, Copy, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: u32,
    /// Byte offset just past the last byte (exclusive).
    pub end: u32,
}

impl Span {
    /// The span `start..end` of byte offsets; offsets are stored as `u32`, so they must be below 4 GiB.
    pub fn new(start: usize, end: usize) -> Span {
        Span { start: start as u32, end: end as u32 }
    }

    /// The same bytes as a `usize` range, to slice the source with.
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span { start: self.start.min(other.start), end: self.end.max(other.end) }
    }
}

impl PartialEq for Span {
    fn eq(&self, _: &Span) -> bool {
        true
    }
}
impl Eq for Span {}
impl std::hash::Hash for Span {
    fn hash<H: std::hash::Hasher>(&self, _: &mut H) {}
}

/// How bad a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// Parsing goes on and the result is usable; worth showing (a construct ignored, a name
    /// that checks but looks wrong).
    Warning,
    /// The input is refused: parsing or checking fails.
    Error,
}

/// The kind of a diagnostic: stable, so tools and tests can match on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DiagnosticKind {
    /// A character sequence that is not PDDL (for example a lone `?`).
    InvalidToken,
    /// A `(` without its `)`: usually a truncated file.
    UnclosedParen,
    /// A `)` with no `(` to close.
    UnmatchedCloseParen,
    /// The file does not start with `(define (domain ...)` / `(define (problem ...)`.
    ExpectedDefine,
    /// Something other than what the grammar allows at this point.
    UnexpectedForm,
    /// Text after the closing parenthesis of `(define ...)`.
    TrailingInput,
    /// A section keyword this parser does not know (`(:foo ...)`).
    UnknownSection,
    /// A requirement that is not part of PDDL.
    UnknownRequirement,
    /// A PDDL feature outside the supported fragment (numeric fluents, durative actions, ...).
    Unsupported,
    /// A number that does not parse.
    InvalidNumber,
    /// Two declarations of one name (predicate, action, object, type, parameter).
    Duplicate,
    /// A predicate that is not declared in `:predicates`.
    UnknownPredicate,
    /// A function that is not declared in `:functions`.
    UnknownFunction,
    /// A type that is not declared in `:types`.
    UnknownType,
    /// A constant or object that is declared neither in `:constants` nor in `:objects`.
    UnknownObject,
    /// A variable that is not bound by the action's parameters or an enclosing quantifier.
    UnknownVariable,
    /// A predicate or function applied to the wrong number of arguments.
    ArityMismatch,
    /// A problem whose `(:domain ...)` names another domain.
    DomainMismatch,
    /// A literal in `:init` that is not ground or not positive.
    InvalidInit,
    /// A problem's object given to a predicate argument of a type it does not have (a
    /// warning: the atom is kept, but no typed action can make or use it).
    TypeMismatch,
}

impl DiagnosticKind {
    /// Short stable name, as printed in brackets after `error`.
    pub fn code(self) -> &'static str {
        match self {
            DiagnosticKind::InvalidToken => "invalid-token",
            DiagnosticKind::UnclosedParen => "unclosed-paren",
            DiagnosticKind::UnmatchedCloseParen => "unmatched-close-paren",
            DiagnosticKind::ExpectedDefine => "expected-define",
            DiagnosticKind::UnexpectedForm => "unexpected-form",
            DiagnosticKind::TrailingInput => "trailing-input",
            DiagnosticKind::UnknownSection => "unknown-section",
            DiagnosticKind::UnknownRequirement => "unknown-requirement",
            DiagnosticKind::Unsupported => "unsupported",
            DiagnosticKind::InvalidNumber => "invalid-number",
            DiagnosticKind::Duplicate => "duplicate",
            DiagnosticKind::UnknownPredicate => "unknown-predicate",
            DiagnosticKind::UnknownFunction => "unknown-function",
            DiagnosticKind::UnknownType => "unknown-type",
            DiagnosticKind::UnknownObject => "unknown-object",
            DiagnosticKind::UnknownVariable => "unknown-variable",
            DiagnosticKind::ArityMismatch => "arity-mismatch",
            DiagnosticKind::DomainMismatch => "domain-mismatch",
            DiagnosticKind::InvalidInit => "invalid-init",
            DiagnosticKind::TypeMismatch => "type-mismatch",
        }
    }
}

/// One finding, located by a byte span in the source it came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// What kind of fault, stable for matching.
    pub kind: DiagnosticKind,
    /// What is wrong, for a person, naming the names involved.
    pub message: String,
    /// Where in the source text (bytes); [`Diagnostic::render`] turns it into line and column.
    pub span: Span,
}

impl Diagnostic {
    /// An error-level diagnostic: the input is refused.
    pub fn error(kind: DiagnosticKind, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic { severity: Severity::Error, kind, message: message.into(), span }
    }

    /// A warning-level diagnostic: the result stays usable.
    pub fn warning(kind: DiagnosticKind, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic { severity: Severity::Warning, kind, message: message.into(), span }
    }

    /// Whether the severity is [`Severity::Error`].
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// `path:line:column: error[kind]: message`, with a 1-based line and column
    /// (columns count characters).
    pub fn render(&self, path: &str, source: &str) -> String {
        let (line, column) = line_column(source, self.span.start as usize);
        let severity = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        format!("{path}:{line}:{column}: {severity}[{}]: {}", self.kind.code(), self.message)
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at bytes {:?}: {}", self.kind.code(), self.span.range(), self.message)
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_column(source: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(source.len());
    let before = &source.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
    let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
    (line, column)
}

/// Strict parsing failed: every error found (there is at least one), plus the warnings.
///
/// Its `Display` names the first error with its line and column in the text that was parsed
/// (`2 error(s) in PDDL input; first at line 3, column 5: ...`); [`ParseError::render`] gives
/// every diagnostic with a file name.
#[derive(Debug, Clone)]
pub struct ParseError {
    /// Every diagnostic, errors and warnings, in the order the parser found them.
    pub diagnostics: Vec<Diagnostic>,
    /// Line and column (1-based) of the first error in the source, kept from the parse so
    /// that `Display` can say where without the text.
    first_at: Option<(usize, usize)>,
}

impl ParseError {
    /// The diagnostics of a failed parse of `source`.
    pub fn new(diagnostics: Vec<Diagnostic>, source: &str) -> ParseError {
        let first_at = diagnostics.iter().find(|d| d.is_error()).map(|d| line_column(source, d.span.start as usize));
        ParseError { diagnostics, first_at }
    }

    /// The error-level diagnostics, in the order found.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics.iter().filter(|d| d.is_error())
    }

    /// Every diagnostic rendered as `path:line:column: ...`, one a line: the errors first (what
    /// made the parse fail), then the warnings, each in source order, a line said twice once.
    pub fn render(&self, path: &str, source: &str) -> String {
        let (errors, warnings): (Vec<&Diagnostic>, Vec<&Diagnostic>) = self.diagnostics.iter().partition(|d| d.is_error());
        let mut lines: Vec<String> = Vec::new();
        for line in errors.into_iter().chain(warnings).map(|d| d.render(path, source)) {
            if !lines.contains(&line) {
                lines.push(line);
            }
        }
        lines.join("\n")
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} error(s) in PDDL input", self.errors().count())?;
        match (self.errors().next(), self.first_at) {
            (Some(first), Some((line, column))) => write!(f, "; first at line {line}, column {column}: {}", first.message),
            (Some(first), None) => write!(f, "; first: {}", first.message),
            (None, _) => Ok(()),
        }
    }
}

impl std::error::Error for ParseError {}
