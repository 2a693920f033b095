//! Lexing and the s-expression layer: text → nested lists of words, with spans.
//!
//! PDDL is Lisp-shaped, so the parser first builds the bracket structure and then reads
//! PDDL constructs off it. Bracket errors are recovered here (an unclosed list is closed at
//! the end of input, a stray `)` is skipped), so the second stage always sees a tree.
//! Words are lowercased: PDDL names are case-insensitive. `;` starts a comment that runs to
//! the end of the line; `,` is read as white space (ALFWorld writes `(?l - location, ?r - receptacle)`).

use crate::diagnostic::{Diagnostic, DiagnosticKind, Span};

#[derive(Debug, Clone)]
pub(crate) enum SExpr {
    Word(String, Span),
    List(Vec<SExpr>, Span),
}

impl SExpr {
    pub(crate) fn span(&self) -> Span {
        match self {
            SExpr::Word(_, span) | SExpr::List(_, span) => *span,
        }
    }

    pub(crate) fn as_word(&self) -> Option<&str> {
        match self {
            SExpr::Word(word, _) => Some(word),
            SExpr::List(..) => None,
        }
    }

    pub(crate) fn as_list(&self) -> Option<&[SExpr]> {
        match self {
            SExpr::List(items, _) => Some(items),
            SExpr::Word(..) => None,
        }
    }

    /// The head word of a list such as `(and ...)`, if it has one.
    pub(crate) fn head(&self) -> Option<&str> {
        self.as_list().and_then(|items| items.first()).and_then(SExpr::as_word)
    }

    /// A short description for messages: the word, or `(head ...)`.
    pub(crate) fn describe(&self) -> String {
        match self {
            // Control characters (a NUL byte read as "found ``") are shown escaped.
            SExpr::Word(word, _) => format!("`{}`", word.escape_debug()),
            SExpr::List(items, _) => match items.first() {
                Some(SExpr::Word(head, _)) => format!("`({} ...)`", head.escape_debug()),
                Some(SExpr::List(..)) => "a list of lists".to_string(),
                None => "`()`".to_string(),
            },
        }
    }
}

fn is_delimiter(byte: u8) -> bool {
    matches!(byte, b'(' | b')' | b';' | b',') || byte.is_ascii_whitespace()
}

/// Lists nested deeper than this are reported and left out. Reading is iterative, but what
/// reads the tree (lowering, checking, grounding, dropping it) recurses once per level, and a
/// hostile or broken file of 100,000 `(` would overflow the stack there. PDDL in the wild nests
/// a few dozen levels at most.
pub const MAX_DEPTH: usize = 256;

/// Reads every top-level s-expression in `source`.
pub(crate) fn read(source: &str, diagnostics: &mut Vec<Diagnostic>) -> Vec<SExpr> {
    let bytes = source.as_bytes();
    // Stack of open lists: (items, position of the `(`).
    let mut stack: Vec<(Vec<SExpr>, usize)> = Vec::new();
    let mut top: Vec<SExpr> = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let byte = bytes[i];
        match byte {
            b';' => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'(' if stack.len() >= MAX_DEPTH => {
                // Skip the list to its `)` (or the end), reporting it once.
                diagnostics.push(Diagnostic::error(
                    DiagnosticKind::InvalidToken,
                    Span::new(i, i + 1),
                    format!("lists nested more than {MAX_DEPTH} deep: this one is left out"),
                ));
                let mut depth = 0usize;
                while i < bytes.len() {
                    match bytes[i] {
                        b';' => {
                            while i < bytes.len() && bytes[i] != b'\n' {
                                i += 1;
                            }
                            continue;
                        }
                        b'(' => depth += 1,
                        b')' => {
                            depth -= 1;
                            if depth == 0 {
                                i += 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                    i += 1;
                }
            }
            b'(' => {
                stack.push((Vec::new(), i));
                i += 1;
            }
            b')' => {
                match stack.pop() {
                    Some((items, start)) => {
                        let list = SExpr::List(items, Span::new(start, i + 1));
                        match stack.last_mut() {
                            Some((parent, _)) => parent.push(list),
                            None => top.push(list),
                        }
                    }
                    None => diagnostics.push(Diagnostic::error(
                        DiagnosticKind::UnmatchedCloseParen,
                        Span::new(i, i + 1),
                        "`)` closes nothing: remove it, or add the `(` it was meant to close",
                    )),
                }
                i += 1;
            }
            _ if byte == b',' || byte.is_ascii_whitespace() => i += 1,
            _ => {
                let start = i;
                while i < bytes.len() && !is_delimiter(bytes[i]) {
                    i += 1;
                }
                // Keep multi-byte characters whole: `is_delimiter` only matches ASCII.
                let text = &source[start..i];
                let word = SExpr::Word(text.to_lowercase(), Span::new(start, i));
                match stack.last_mut() {
                    Some((parent, _)) => parent.push(word),
                    None => top.push(word),
                }
            }
        }
    }
    // Close what the input left open, innermost first, reporting each.
    while let Some((items, start)) = stack.pop() {
        let opened = match items.first() {
            Some(SExpr::Word(word, _)) => format!("`({word} ...`"),
            _ => "`(`".to_string(),
        };
        diagnostics.push(Diagnostic::error(
            DiagnosticKind::UnclosedParen,
            Span::new(start, start + 1),
            format!("{opened} opened here is never closed: the input ends first (is the file truncated?)"),
        ));
        let list = SExpr::List(items, Span::new(start, bytes.len()));
        match stack.last_mut() {
            Some((parent, _)) => parent.push(list),
            None => top.push(list),
        }
    }
    top
}
