//! Errors loading an environment: each names the file and, where there is one, the line and
//! column or the field.

use std::path::PathBuf;

/// Why an ALFWorld game could not be loaded ([`crate::AlfworldEnv::from_game_file`],
/// [`crate::AlfworldEnv::from_game_json`]).
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The game file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The `game.tw-pddl` file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The game file holds a byte that is not UTF-8.
    #[error("{}:{line}:{column}: not UTF-8 text (byte 0x{byte:02x})", path.display())]
    NotUtf8 {
        /// The `game.tw-pddl` file.
        path: PathBuf,
        /// 1-based line of the byte.
        line: usize,
        /// 1-based column of the byte, in characters.
        column: usize,
        /// The byte.
        byte: u8,
    },
    /// The game file is not valid JSON.
    #[error("{path}:{line}:{column}: not valid JSON: {message}")]
    Json {
        /// The game's name in errors (the file path, or the `source` given to `from_game_json`).
        path: String,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// `serde_json`'s message.
        message: String,
    },
    /// A field the game needs (`pddl_domain`, `pddl_problem`, `grammar`) is missing or is not a string.
    #[error("{path}: the game has no string field `{key}`")]
    MissingKey {
        /// The game's name in errors.
        path: String,
        /// The field's JSON key.
        key: String,
    },
    /// A field that is present has the wrong type (a `walkthrough` that is not a list of strings).
    #[error("{path}: the game's `{key}` field is not {expected}")]
    BadField {
        /// The game's name in errors.
        path: String,
        /// The field's JSON key.
        key: String,
        /// What the field should have been, e.g. `a list of strings`.
        expected: String,
    },
    /// The domain or problem does not parse, or names something it does not declare.
    #[error("{path}: the `{field}` field is not valid PDDL:\n{diagnostics}")]
    Pddl {
        /// The game's name in errors.
        path: String,
        /// `pddl_domain` or `pddl_problem`: the field of the first error.
        field: String,
        /// The rendered diagnostics, one or more lines, each at its line and column in its field.
        diagnostics: String,
    },
    /// The PDDL parses and checks but cannot be grounded.
    /// `message` names the game file, its field and the line and column there.
    #[error("cannot ground the game's PDDL: {message}")]
    Grounding {
        /// The game's name in errors.
        path: String,
        /// The grounder's rendered error.
        message: String,
    },
    /// The TextWorld grammar does not parse, or a part of it does not read: a template, a
    /// production, a symbol named but not defined. At the place in the grammar text: the error
    /// itself, or for a part, its `action` block or the key of its symbol.
    #[error("{path}: the `grammar` field, line {line}, column {column}: {message}")]
    Grammar {
        /// The game's name in errors.
        path: String,
        /// 1-based line in the grammar text.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The TextWorld grammar lacks what has no place in it: an `action` block for one of the
    /// domain's actions, or the `intro` symbol every game starts from.
    #[error("{path}: the `grammar` field: {message}")]
    GrammarIncomplete {
        /// The game's name in errors.
        path: String,
        /// What is missing.
        message: String,
    },
}
