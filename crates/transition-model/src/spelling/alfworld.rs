//! ALFWorld's TextWorld commands: each game's grammar templates filled with the display
//! names ALFWorld gives objects.
//!
//! **Templates.** The grammar holds `action Name { template :: "take {o} from {r}"; ... }`
//! per action schema; a placeholder names a schema parameter (lowercased, without `?`). The
//! list form `go to [{r.name | receptacleatlocation(r:receptacle, lend:location)}]` is read
//! as `{r}`: its query only restates the action's precondition, so it yields exactly `r`.
//!
//! **Display names** (ALFWorld's `Demangler`, as run by its text environment without
//! shuffling). The entities are the objects that occur in the problem's `:init`. An id such
//! as `alarmclock_bar__minus_02_dot_48_bar_...` has the class key `alarmclock` (the text
//! before the first `_bar_`, plus `basin` when the id contains `basin`, so that
//! `sink_bar_..._bar_sinkbasin` is a `sinkbasin`). Within a key, entities are numbered
//! `n, n-1, ..., 1` in ascending byte order of their ids: the smallest id is `alarmclock n`,
//! the largest `alarmclock 1`. Ids without `_bar_` (agents, type constants) are never
//! spelled. Checked against all 340 walkthroughs in `fixtures/` (`tests/real_plans.rs`).

use grounding::{ObjectId, Task};
use rustc_hash::FxHashMap;

use super::{Spelling, SpellingError, SurfaceLanguage};

/// One piece of a template: literal text or a parameter index.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Piece {
    Text(String),
    Param(usize),
}

/// The `template :: "..."` of every `action Name { ... }` block, by lowercased action name.
pub fn templates(grammar: &str) -> Result<FxHashMap<String, String>, SpellingError> {
    let mut out = FxHashMap::default();
    let mut rest = grammar;
    let mut offset = 0;
    while let Some(at) = find_action_block(rest) {
        let block = &rest[at..];
        let header_end =
            block.find('{').ok_or(SpellingError::MalformedGrammar { offset: offset + at, message: "`action` without `{`".into() })?;
        let name = block["action".len()..header_end].trim().to_lowercase();
        let body = &block[header_end..];
        if let Some(t) = body.find("template") {
            let after = &body[t..];
            let open = after.find('"').ok_or(SpellingError::MalformedGrammar {
                offset: offset + at + header_end + t,
                message: "template without a quoted text".into(),
            })?;
            let close = after[open + 1..].find('"').ok_or(SpellingError::MalformedGrammar {
                offset: offset + at + header_end + t,
                message: "unterminated template text".into(),
            })?;
            out.insert(name, after[open + 1..open + 1 + close].to_string());
        }
        let consumed = at + header_end + 1;
        offset += consumed;
        rest = &rest[consumed..];
    }
    Ok(out)
}

/// The next `action NAME {` at the start of a line.
fn find_action_block(text: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(at) = text[from..].find("action ") {
        let at = from + at;
        let line_start = text[..at].rfind('\n').map_or(0, |p| p + 1);
        if text[line_start..at].trim().is_empty() {
            return Some(at);
        }
        from = at + 1;
    }
    None
}

fn compile(action: &str, template: &str, params: &[String]) -> Result<Vec<Piece>, SpellingError> {
    let mut pieces = Vec::new();
    let mut text = String::new();
    let mut chars = template.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        match c {
            '[' | ']' => {}
            '{' => {
                let end = template[i..]
                    .find('}')
                    .map(|e| i + e)
                    .ok_or_else(|| SpellingError::UnclosedPlaceholder { action: action.to_string(), offset: i })?;
                let inner = &template[i + 1..end];
                let placeholder: String =
                    inner.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>().to_lowercase();
                let index = params
                    .iter()
                    .position(|p| *p == placeholder)
                    .ok_or_else(|| SpellingError::UnknownPlaceholder { action: action.to_string(), placeholder: placeholder.clone() })?;
                if !text.is_empty() {
                    pieces.push(Piece::Text(std::mem::take(&mut text)));
                }
                pieces.push(Piece::Param(index));
                while chars.peek().is_some_and(|&(j, _)| j <= end) {
                    chars.next();
                }
            }
            _ => text.push(c),
        }
    }
    if !text.is_empty() {
        pieces.push(Piece::Text(text));
    }
    Ok(pieces)
}

/// ALFWorld display names (`desk 1`), for every object that has one.
pub fn display_names(task: &Task) -> Vec<Option<String>> {
    let mut in_init = vec![false; task.objects.len()];
    let init_atoms = task.init.iter().map(|&f| task.fact(f)).chain(&task.static_facts);
    for atom in init_atoms {
        for arg in &atom.args {
            in_init[arg.index()] = true;
        }
    }
    let key = |id: &str| -> Option<String> {
        let (prefix, _) = id.split_once("_bar_")?;
        Some(if id.contains("basin") { format!("{prefix}basin") } else { prefix.to_string() })
    };
    let mut entities: Vec<(ObjectId, &str)> =
        task.objects.iter().enumerate().filter(|(i, _)| in_init[*i]).map(|(i, o)| (ObjectId::from_index(i), o.name.as_str())).collect();
    entities.sort_by(|a, b| a.1.as_bytes().cmp(b.1.as_bytes()));
    let mut remaining: FxHashMap<String, usize> = FxHashMap::default();
    for (_, id) in &entities {
        if let Some(k) = key(id) {
            *remaining.entry(k).or_default() += 1;
        }
    }
    let mut names = vec![None; task.objects.len()];
    for (object, id) in entities {
        if let Some(k) = key(id) {
            let number = remaining.get_mut(&k).map(|n| {
                let current = *n;
                *n -= 1;
                current
            });
            if let Some(number) = number {
                names[object.index()] = Some(format!("{k} {number}"));
            }
        }
    }
    names
}

impl Spelling {
    /// TextWorld commands from the game's grammar (`game.tw-pddl`'s `grammar` field), objects
    /// written by ALFWorld's display names ([`display_names`]).
    pub fn alfworld(task: &Task, grammar: &str) -> Result<Spelling, SpellingError> {
        Spelling::alfworld_with_names(task, grammar, display_names(task))
    }

    /// TextWorld commands from the game's grammar, objects written by `names` (indexed by
    /// object; an action with an unnamed object, `None` or past the end of `names`, has no
    /// spelling). An agent whose problem names objects as it perceived them passes those names.
    pub fn alfworld_with_names(task: &Task, grammar: &str, names: Vec<Option<String>>) -> Result<Spelling, SpellingError> {
        let templates = templates(grammar)?;
        let mut compiled = Vec::with_capacity(task.schemas.len());
        for schema in &task.schemas {
            let template = templates.get(&schema.name).ok_or_else(|| SpellingError::MissingTemplate(schema.name.clone()))?;
            compiled.push(compile(&schema.name, template, &schema.params)?);
        }
        let mut spelling = Spelling::from_fn(task, SurfaceLanguage::Alfworld, |id| {
            let action = task.action(id);
            let mut out = String::new();
            for piece in &compiled[action.schema.index()] {
                match piece {
                    Piece::Text(text) => out.push_str(text),
                    Piece::Param(index) => out.push_str(names.get(action.args[*index].index())?.as_deref()?),
                }
            }
            Some(out)
        });
        spelling.object_names = Some(names);
        Ok(spelling)
    }
}
