//! Action spelling, both ways: an action's surface text, and the actions a text names.
//!
//! A [`Spelling`] is a table built once per task: every grounded action gets at most one
//! text, and every text maps back to *all* actions spelled that way (actions split from one
//! disjunctive precondition share a name; ALFWorld's `go to desk 1` is one text for every
//! start location; VirtualHome's class-level names collapse instances). Texts are stored
//! normalised (lowercase, single spaces, trimmed), and [`Spelling::parse`] normalises its
//! input the same way, so the two directions agree by construction.
//!
//! Three surface languages: PDDL (`(pickupobject agent1 ...)`), ALFWorld's TextWorld
//! commands from the game's own grammar templates, and VirtualHome's class-level script
//! verbs from a table ([`virtualhome::VERBS`]).

pub mod alfworld;
mod names;
pub mod virtualhome;

pub use names::{ObjectNames, natural_order};

use grounding::{ActionId, Task};
use rustc_hash::FxHashMap;

/// Which surface language a [`Spelling`] writes (command-line names `pddl`, `alfworld`,
/// `virtualhome`: the variants', through `FromStr`, `Into<&str>` and
/// [`strum::VariantNames`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, strum::EnumString, strum::IntoStaticStr, strum::VariantNames, strum::VariantArray)]
#[strum(serialize_all = "lowercase", parse_err_ty = crate::UnknownName, parse_err_fn = SurfaceLanguage::unknown)]
pub enum SurfaceLanguage {
    /// PDDL action names, `(schema arg1 ... argn)`.
    Pddl,
    /// ALFWorld's TextWorld commands (`take apple 1 from desk 2`).
    Alfworld,
    /// VirtualHome's class-level script verbs (`putin wineglass dishwasher`).
    Virtualhome,
}

impl SurfaceLanguage {
    fn unknown(given: &str) -> crate::UnknownName {
        crate::UnknownName::of::<SurfaceLanguage>("surface language", given)
    }

    /// The command-line name: `pddl`, `alfworld` or `virtualhome`.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The language with command-line name `name` (exact, lowercase); `None` for any other text.
    pub fn from_name(name: &str) -> Option<SurfaceLanguage> {
        name.parse().ok()
    }
}

/// Why an ALFWorld spelling could not be built from a game's grammar.
#[derive(Debug, thiserror::Error)]
pub enum SpellingError {
    /// The grammar has no `template` for this action schema (its lowercased name).
    #[error("the ALFWorld grammar has no template for action `{0}`")]
    MissingTemplate(String),
    /// A template placeholder is not one of its schema's parameters.
    #[error("the ALFWorld template for `{action}` names `{{{placeholder}}}`, which is not a parameter of the action")]
    UnknownPlaceholder {
        /// The schema's lowercased name.
        action: String,
        /// The placeholder's name, lowercased, without braces.
        placeholder: String,
    },
    /// A template opens a placeholder `{` that it never closes.
    #[error("the ALFWorld template for `{action}` opens a placeholder at byte {offset} of its text and never closes it")]
    UnclosedPlaceholder {
        /// The schema's lowercased name.
        action: String,
        /// The byte offset of the `{` in the template's text.
        offset: usize,
    },
    /// The grammar's `action` blocks cannot be read.
    #[error("the ALFWorld grammar is malformed near byte {offset}: {message}")]
    MalformedGrammar {
        /// A byte offset into the grammar.
        offset: usize,
        /// What is wrong there.
        message: String,
    },
}

/// The spelling table of one task in one surface language.
#[derive(Debug, Clone)]
pub struct Spelling {
    language: SurfaceLanguage,
    texts: Vec<Option<Box<str>>>,
    by_text: FxHashMap<Box<str>, Vec<ActionId>>,
    /// The object names the commands were written with, where the spelling was built from
    /// given names ([`Spelling::alfworld_with_names`]: a grounded problem's objects named as the
    /// agent perceived them), so that prompts name objects as the commands do.
    object_names: Option<Vec<Option<String>>>,
}

/// Lowercase, trimmed, with runs of white space as one space.
pub fn normalize(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for word in text.split_whitespace() {
        if !out.is_empty() {
            out.push(' ');
        }
        out.extend(word.chars().flat_map(char::to_lowercase));
    }
    out
}

impl Spelling {
    /// Builds the table from a function giving each action's text (`None`: not expressible).
    pub fn from_fn(task: &Task, language: SurfaceLanguage, mut spell: impl FnMut(ActionId) -> Option<String>) -> Spelling {
        let mut texts = Vec::with_capacity(task.actions.len());
        let mut by_text: FxHashMap<Box<str>, Vec<ActionId>> = FxHashMap::default();
        for action in task.action_ids() {
            let text = spell(action).map(|t| normalize(&t).into_boxed_str());
            if let Some(text) = &text {
                by_text.entry(text.clone()).or_default().push(action);
            }
            texts.push(text);
        }
        Spelling { language, texts, by_text, object_names: None }
    }

    /// The object names this spelling was built with, when it was given them (see the field).
    pub fn object_names(&self) -> Option<&[Option<String>]> {
        self.object_names.as_deref()
    }

    /// PDDL: `(schema arg1 ... argn)`, as Fast Downward names operators.
    pub fn pddl(task: &Task) -> Spelling {
        Spelling::from_fn(task, SurfaceLanguage::Pddl, |a| Some(task.action_name(a)))
    }

    /// The surface language the texts are written in.
    pub fn language(&self) -> SurfaceLanguage {
        self.language
    }

    /// The action's text, if the language can express it.
    pub fn spell(&self, action: ActionId) -> Option<&str> {
        self.texts.get(action.index()).and_then(|t| t.as_deref())
    }

    /// Every action spelled `text` (after normalising it; PDDL texts may omit the
    /// parentheses). Empty if none.
    pub fn parse(&self, text: &str) -> &[ActionId] {
        let mut key = normalize(text);
        if self.language == SurfaceLanguage::Pddl {
            // Space inside the parentheses is no part of the action (`( pick b1 left )`), as
            // for VAL.
            key = key.replace("( ", "(").replace(" )", ")");
            if !key.starts_with('(') {
                key = format!("({key})");
            }
        }
        self.by_text.get(key.as_str()).map_or(&[], Vec::as_slice)
    }

    /// Every distinct text, with its actions, in no particular order.
    pub fn texts(&self) -> impl Iterator<Item = (&str, &[ActionId])> {
        self.by_text.iter().map(|(t, a)| (&**t, a.as_slice()))
    }
}
