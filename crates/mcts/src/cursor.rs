//! Where a token sequence stands in the plan: one type for constrained and unconstrained
//! decoding, so that greedy decoding, sampling and MCTS share every step.

use grounding::ActionId;
use token_constraint::{PlanConstraint, PlanLanguages, PlanStep, TokenId, Vocabulary};
use transition_model::{State, TransitionModel};

use crate::canonical::{CanonicalCursor, CanonicalLanguages, CanonicalStep};

/// The per-state languages a cursor steps through: byte-level (every tokenization of an
/// allowed text) and, once made, canonical (one token sequence per text).
#[derive(Debug)]
pub struct Languages<'m> {
    /// The byte-level languages; their spelling also parses unconstrained text.
    pub bytes: PlanLanguages<'m>,
    /// The canonical languages, once the task's action texts have been encoded.
    pub canonical: Option<CanonicalLanguages<'m>>,
}

/// Lines longer than this (in bytes) without a line break end an unconstrained plan as invalid.
pub const MAX_LINE_BYTES: usize = 256;

/// What one token did to the plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// Inside an action (or inside white space between actions).
    Partial,
    /// At least one action completed and was applied.
    Action,
    /// The plan ended (end of sequence, or the end marker `DONE`).
    End,
    /// Unconstrained decoding wrote a line that names no action applicable in the current
    /// state (or no action at all); the text is the offending line.
    Invalid(String),
}

/// The decoding position: the symbolic state, the partial action, the plan so far.
#[derive(Debug, Clone)]
pub enum Cursor {
    /// Every token must extend some tokenization of an applicable action's text.
    Constrained(PlanConstraint),
    /// Every token must extend the canonical tokenization of an applicable action's text
    /// (paper Eq. 7 with `tok(a)` the tokenizer's encoding).
    Canonical(CanonicalCursor),
    /// Any token; the text is parsed into actions at each line break.
    Free(FreeText),
}

/// Unconstrained text: the current line and the actions parsed so far.
#[derive(Debug, Clone)]
pub struct FreeText {
    state: State,
    line: Vec<u8>,
    plan: Vec<ActionId>,
    finished: bool,
}

impl Cursor {
    /// A byte-level constrained cursor at the start of a plan in `state`; an error where
    /// `state`'s action texts cannot make a language.
    pub fn constrained(languages: &mut PlanLanguages<'_>, state: State) -> Result<Cursor, token_constraint::LanguageError> {
        Ok(Cursor::Constrained(PlanConstraint::new(languages, state)?))
    }

    /// A canonical constrained cursor at the start of a plan in `state`.
    pub fn canonical(languages: &mut CanonicalLanguages<'_>, state: State) -> Cursor {
        Cursor::Canonical(CanonicalCursor::new(languages, state))
    }

    /// An unconstrained cursor at the start of a plan in `state`.
    pub fn free(state: State) -> Cursor {
        Cursor::Free(FreeText { state, line: Vec::new(), plan: Vec::new(), finished: false })
    }

    /// The state after the plan's actions.
    pub fn state(&self) -> &State {
        match self {
            Cursor::Constrained(c) => c.state(),
            Cursor::Canonical(c) => c.state(),
            Cursor::Free(f) => &f.state,
        }
    }

    /// The actions completed and applied so far, in order.
    pub fn plan(&self) -> &[ActionId] {
        match self {
            Cursor::Constrained(c) => c.plan(),
            Cursor::Canonical(c) => c.plan(),
            Cursor::Free(f) => &f.plan,
        }
    }

    /// Whether tokens are masked (byte-level or canonical).
    pub fn is_constrained(&self) -> bool {
        !matches!(self, Cursor::Free(_))
    }

    /// At the start of an action: nothing of the next action written yet.
    pub fn at_boundary(&self) -> bool {
        match self {
            Cursor::Constrained(c) => c.matcher().at_boundary(),
            Cursor::Canonical(c) => c.at_boundary(),
            Cursor::Free(f) => f.line.iter().all(u8::is_ascii_whitespace),
        }
    }

    /// The allowed next tokens, or `None` when every token is (unconstrained decoding).
    pub fn allowed(&self, vocab: &Vocabulary, out: &mut Vec<TokenId>) -> Option<()> {
        match self {
            Cursor::Canonical(c) => {
                c.allowed(vocab.eos(), out);
                Some(())
            }
            Cursor::Constrained(c) => {
                c.allowed(vocab, out);
                Some(())
            }
            Cursor::Free(_) => None,
        }
    }

    /// Writes `token`. In constrained decoding the token must be allowed (the caller took it
    /// from [`Cursor::allowed`]); a refused token is an internal error.
    pub fn advance(
        &mut self,
        model: &TransitionModel,
        languages: &mut Languages<'_>,
        vocab: &Vocabulary,
        token: TokenId,
    ) -> Result<Event, token_constraint::PlanTokenError> {
        match self {
            Cursor::Canonical(c) => {
                let canonical = languages.canonical.as_mut().expect("a canonical cursor is made from canonical languages");
                match c.advance(canonical, token) {
                    Some(CanonicalStep::Partial) => Ok(Event::Partial),
                    Some(CanonicalStep::Action) => Ok(Event::Action),
                    Some(CanonicalStep::End) => Ok(Event::End),
                    None => Err(token_constraint::TokenError::NotAllowed {
                        token,
                        text: String::from_utf8_lossy(vocab.token_bytes(token)).into_owned(),
                        prefix: String::new(),
                    }
                    .into()),
                }
            }
            Cursor::Constrained(c) => Ok(match c.advance(&mut languages.bytes, vocab, token)? {
                PlanStep::Partial => Event::Partial,
                PlanStep::Action { .. } => Event::Action,
                PlanStep::End { .. } => Event::End,
            }),
            Cursor::Free(f) => Ok(f.advance(model, languages.bytes.spelling(), vocab, token)),
        }
    }
}

impl FreeText {
    fn advance(&mut self, model: &TransitionModel, spelling: &transition_model::Spelling, vocab: &Vocabulary, token: TokenId) -> Event {
        if self.finished {
            return Event::Invalid("text after the end of the plan".into());
        }
        if vocab.is_eos(token) {
            self.finished = true;
            let line = std::mem::take(&mut self.line);
            return match self.finish_line(model, spelling, &line) {
                Some(Event::Invalid(text)) => Event::Invalid(text),
                _ => Event::End,
            };
        }
        if vocab.is_special(token) {
            return Event::Invalid(String::from_utf8_lossy(vocab.token_bytes(token)).into_owned());
        }
        let mut event = Event::Partial;
        for &byte in vocab.token_bytes(token) {
            if byte != b'\n' {
                self.line.push(byte);
                if self.line.len() > MAX_LINE_BYTES {
                    return Event::Invalid(String::from_utf8_lossy(&self.line).into_owned());
                }
                continue;
            }
            let line = std::mem::take(&mut self.line);
            match self.finish_line(model, spelling, &line) {
                None => {}
                Some(Event::Action) => event = Event::Action,
                Some(end_or_invalid) => {
                    self.finished = true;
                    return end_or_invalid;
                }
            }
        }
        event
    }

    /// Parses one complete line: `None` for a blank line, `End` for `DONE`, `Action` when it
    /// names an applicable action (applied), else `Invalid`.
    fn finish_line(&mut self, model: &TransitionModel, spelling: &transition_model::Spelling, line: &[u8]) -> Option<Event> {
        let text = String::from_utf8_lossy(line);
        let text = strip_list_marker(text.trim());
        if text.is_empty() {
            return None;
        }
        if text.eq_ignore_ascii_case("done") {
            return Some(Event::End);
        }
        let Some(&action) = spelling.parse(text).iter().find(|&&a| model.is_applicable(&self.state, a)) else {
            return Some(Event::Invalid(text.to_string()));
        };
        self.state = model.apply(&self.state, action);
        self.plan.push(action);
        Some(Event::Action)
    }
}

/// Drops a leading list marker (`3.`, `3)`, `-`, `*`): a parser for free text should not fail
/// a model for numbering its plan.
fn strip_list_marker(text: &str) -> &str {
    let digits = text.bytes().take_while(u8::is_ascii_digit).count();
    let rest = &text[digits..];
    if digits > 0 && (rest.starts_with('.') || rest.starts_with(')')) {
        return rest[1..].trim_start();
    }
    if let Some(rest) = text.strip_prefix("- ").or_else(|| text.strip_prefix("* ")) {
        return rest.trim_start();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::strip_list_marker;

    #[test]
    fn list_markers_are_dropped() {
        assert_eq!(strip_list_marker("3. go to desk 1"), "go to desk 1");
        assert_eq!(strip_list_marker("12) open fridge 1"), "open fridge 1");
        assert_eq!(strip_list_marker("- walk kitchen"), "walk kitchen");
        assert_eq!(strip_list_marker("walk kitchen"), "walk kitchen");
        assert_eq!(strip_list_marker("3 apples"), "3 apples");
    }
}
