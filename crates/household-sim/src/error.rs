//! Errors loading an environment: each names the file and, where there is one, the line and
//! column or the field.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}:{column}: not valid JSON: {message}")]
    Json { path: String, line: usize, column: usize, message: String },
    #[error("{path}: the game has no string field `{key}`")]
    MissingKey { path: String, key: String },
    #[error("{path}: the game's `{key}` field is not {expected}")]
    BadField { path: String, key: String, expected: String },
    #[error("{path}: the `{field}` field is not valid PDDL:\n{diagnostics}")]
    Pddl { path: String, field: String, diagnostics: String },
    /// `message` names the game file, its field and the line and column there.
    #[error("cannot ground the game's PDDL: {message}")]
    Grounding { path: String, message: String },
    #[error("{path}: the `grammar` field, line {line}, column {column}: {message}")]
    Grammar { path: String, line: usize, column: usize, message: String },
}
