//! The TextWorld logic document (`.twl2`) an ALFWorld game carries in its `grammar` field:
//! `grammar :: """{json}""";` blocks and `action Name { template :: "..."; feedback ::
//! "..."; [pddl :: """..."""]; [grammar :: """{json}"""]; }` blocks, read as TextWorld's
//! TatSu grammar (`textworld/envs/pddl/logic/logic.ebnf`) reads them: `#` starts a comment
//! to the end of the line between tokens; a quoted string has no escapes; a triple-quoted
//! block is the shortest text up to the next `"""`.
//!
//! The JSON blocks are merged into one object in document order, a later key replacing an
//! earlier one (Python's `dict.update`); in an action's block, lines whose first non-blank
//! character is `#` are dropped before parsing, as TextWorld drops them.

use serde_json::Value;

/// One `action` block.
#[derive(Debug, Clone)]
pub(crate) struct ActionText {
    /// Lowercased, as TextWorld keys actions.
    pub name: String,
    /// Byte offset of the block's `action` keyword in the document.
    pub offset: usize,
    pub template: String,
    pub feedback: String,
}

/// One production: `{"condition": "...", "rhs": "..."}`.
#[derive(Debug, Clone)]
pub(crate) struct RuleText {
    pub condition: String,
    pub rhs: String,
    /// Byte offset in the document of the symbol's key (`"name"`) in the grammar block that gave
    /// this production, or of the block where the key is not written plainly.
    pub offset: usize,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct Document {
    pub actions: Vec<ActionText>,
    /// Symbol name → productions, in the order the merged JSON object lists them.
    pub rules: Vec<(String, Vec<RuleText>)>,
}

/// A position in the document, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextPosition {
    pub line: usize,
    pub column: usize,
}

pub(crate) fn position(text: &str, offset: usize) -> TextPosition {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    TextPosition { line, column }
}

#[derive(Debug, Clone)]
pub(crate) struct DocError {
    pub offset: usize,
    pub message: String,
}

struct Cursor<'a> {
    text: &'a str,
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn skip(&mut self) {
        loop {
            let rest = &self.text[self.pos..];
            let trimmed = rest.trim_start();
            self.pos += rest.len() - trimmed.len();
            if trimmed.starts_with('#') {
                self.pos += trimmed.find('\n').unwrap_or(trimmed.len());
            } else {
                return;
            }
        }
    }

    fn error(&self, message: impl Into<String>) -> DocError {
        DocError { offset: self.pos, message: message.into() }
    }

    fn eat(&mut self, token: &str) -> bool {
        self.skip();
        if self.text[self.pos..].starts_with(token) {
            self.pos += token.len();
            true
        } else {
            false
        }
    }

    fn expect(&mut self, token: &str, what: &str) -> Result<(), DocError> {
        if self.eat(token) { Ok(()) } else { Err(self.error(format!("expected `{token}` {what}"))) }
    }

    fn name(&mut self) -> Result<&'a str, DocError> {
        self.skip();
        let rest = &self.text[self.pos..];
        let len = rest.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == '/' || c == '-')).unwrap_or(rest.len());
        if len == 0 {
            return Err(self.error("expected a name"));
        }
        self.pos += len;
        Ok(&rest[..len])
    }

    /// `"..."` (no escapes) or `"""..."""`; returns the text between the quotes.
    fn string(&mut self, triple: bool) -> Result<&'a str, DocError> {
        self.skip();
        let quote = if triple { "\"\"\"" } else { "\"" };
        if !self.text[self.pos..].starts_with(quote) {
            return Err(self.error(if triple { "expected a `\"\"\"` block" } else { "expected a quoted string" }));
        }
        let start = self.pos + quote.len();
        let end = self.text[start..].find(quote).map(|e| start + e).ok_or_else(|| self.error("unterminated string"))?;
        self.pos = end + quote.len();
        Ok(&self.text[start..end])
    }
}

/// Python's `textwrap.dedent`: removes the longest common leading white space of the
/// lines that are not blank.
fn dedent(text: &str) -> String {
    let margin = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| &l[..l.len() - l.trim_start_matches([' ', '\t']).len()])
        .reduce(|a, b| {
            let common = a.bytes().zip(b.bytes()).take_while(|(x, y)| x == y).count();
            &a[..common]
        })
        .unwrap_or("");
    text.split('\n')
        .map(|l| if l.trim().is_empty() { l.trim_start_matches([' ', '\t']) } else { l.strip_prefix(margin).unwrap_or(l) })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Merges one grammar block: `json` is its text as parsed, `raw` its text as written, starting
/// at byte `start` of the document (`at` is the block's opening `"""`, for errors).
fn merge_json(rules: &mut Vec<(String, Vec<RuleText>)>, json: &str, raw: &str, start: usize, at: usize) -> Result<(), DocError> {
    let value: Value = serde_json::from_str(json).map_err(|e| DocError {
        offset: at,
        message: format!("grammar block is not valid JSON (its line {}, column {}): {e}", e.line(), e.column()),
    })?;
    let Value::Object(map) = value else {
        return Err(DocError { offset: at, message: "grammar block is not a JSON object".into() });
    };
    for (name, productions) in map {
        let Value::Array(list) = productions else {
            return Err(DocError { offset: at, message: format!("grammar symbol `{name}` is not a list of productions") });
        };
        let key_at = key_offset(raw, &name).map_or(at, |i| start + i);
        let mut parsed = Vec::with_capacity(list.len());
        for production in list {
            let rhs = production
                .get("rhs")
                .and_then(Value::as_str)
                .ok_or_else(|| DocError { offset: at, message: format!("a production of `{name}` has no string `rhs`") })?;
            let condition = match production.get("condition") {
                None | Some(Value::Null) => String::new(),
                Some(Value::String(c)) => c.clone(),
                Some(_) => {
                    return Err(DocError { offset: at, message: format!("a production of `{name}` has a non-string `condition`") });
                }
            };
            parsed.push(RuleText { condition, rhs: rhs.to_string(), offset: key_at });
        }
        match rules.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = parsed,
            None => rules.push((name, parsed)),
        }
    }
    Ok(())
}

/// Where `raw` writes `"name"` as a key (a `:` follows) on a line that is not a `#` comment.
fn key_offset(raw: &str, name: &str) -> Option<usize> {
    let quoted = format!("\"{name}\"");
    raw.match_indices(&quoted).map(|(i, _)| i).find(|&i| {
        let line_start = raw[..i].rfind('\n').map_or(0, |n| n + 1);
        raw[i + quoted.len()..].trim_start().starts_with(':') && !raw[line_start..i].trim_start().starts_with('#')
    })
}

pub(crate) fn parse(text: &str) -> Result<Document, DocError> {
    let mut cursor = Cursor { text, pos: 0 };
    let mut doc = Document::default();
    loop {
        cursor.skip();
        if cursor.pos >= text.len() {
            return Ok(doc);
        }
        if cursor.eat("grammar") {
            cursor.expect("::", "after `grammar`")?;
            cursor.skip();
            let at = cursor.pos;
            let code = cursor.string(true)?;
            cursor.expect(";", "after the grammar block")?;
            merge_json(&mut doc.rules, &dedent(code), code, at + 3, at)?;
        } else if cursor.eat("action") {
            let offset = cursor.pos - "action".len();
            let name = cursor.name()?.to_lowercase();
            cursor.expect("{", "after the action's name")?;
            let (mut template, mut feedback) = (None, None);
            loop {
                if cursor.eat("}") {
                    break;
                }
                let part = cursor.name()?;
                cursor.expect("::", &format!("after `{part}`"))?;
                match part {
                    "template" => template = Some(cursor.string(false)?.to_string()),
                    "feedback" => feedback = Some(cursor.string(false)?.to_string()),
                    "pddl" => {
                        cursor.string(true)?;
                    }
                    "grammar" => {
                        cursor.skip();
                        let at = cursor.pos;
                        let code = cursor.string(true)?;
                        let kept: Vec<&str> = code.split('\n').filter(|l| !l.trim_start().starts_with('#')).collect();
                        merge_json(&mut doc.rules, &dedent(&kept.join("\n")), code, at + 3, at)?;
                    }
                    other => return Err(cursor.error(format!("unknown part `{other}` in action `{name}`"))),
                }
                cursor.expect(";", &format!("after the `{part}` of action `{name}`"))?;
            }
            let missing = |what: &str| DocError { offset: cursor.pos, message: format!("action `{name}` has no {what}") };
            let template = template.ok_or_else(|| missing("template"))?;
            let feedback = feedback.ok_or_else(|| missing("feedback"))?;
            doc.actions.push(ActionText { name, offset, template, feedback });
        } else {
            return Err(cursor.error("expected `grammar ::` or `action`"));
        }
    }
}
