//! The error of a name that is none of an enum's command-line names, for the `FromStr` that
//! `strum` derives (`parse_err_ty`, `parse_err_fn`) on the planning stack's option enums: this
//! crate's [`crate::SurfaceLanguage`], `heuristics`' heuristic, search and clock names, `mcts`'
//! mode, tokenization, normalisation and backup names, `token-constraint`'s end policy.

/// A name that is none of an enum's command-line names: what was given, and the names there
/// are (`` `lm-cut` is not a heuristic: the heuristics are blind, goalcount, hmax, hadd, ff,
/// lmcut ``).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownName {
    /// What the enum names (`heuristic`, `search algorithm`, `surface language`).
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The names there are, in the enum's order.
    pub valid: &'static [&'static str],
}

impl UnknownName {
    /// `given`, which is none of `T`'s names; `what` names what a `T` is, in the singular.
    pub fn of<T: strum::VariantNames>(what: &'static str, given: &str) -> UnknownName {
        UnknownName { what, given: given.to_string(), valid: T::VARIANTS }
    }
}

impl std::fmt::Display for UnknownName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}` is not a {}: the {}s are {}", self.given, self.what, self.what, self.valid.join(", "))
    }
}

impl std::error::Error for UnknownName {}
