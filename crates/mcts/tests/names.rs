//! The command-line names of the decoder's options (and of the surface languages plans are
//! written in, and of where a plan may end): each parses back to its enum, and a name that is none of them is refused with
//! the names there are (`mcts::UnknownName`, the planning stack's one error for this).

use mcts::{Backup, ModeName, Normalization, Tokenization, UnknownName};
use strum::VariantNames;
use transition_model::SurfaceLanguage;

/// Every name parses to a value whose name is the name given; `bad` is refused, naming `what`.
fn names<T>(what: &str, bad: &str)
where
    T: VariantNames + std::str::FromStr<Err = UnknownName> + Into<&'static str>,
{
    for &name in T::VARIANTS {
        let value: T = name.parse().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(value.into(), name);
    }
    let error = bad.parse::<T>().err().unwrap_or_else(|| panic!("`{bad}` is not a {what}"));
    assert_eq!(error.to_string(), format!("`{bad}` is not a {what}: the {what}s are {}", T::VARIANTS.join(", ")));
    assert_eq!((error.what, error.given.as_str(), error.valid), (what, bad, T::VARIANTS));
}

#[test]
fn every_option_name_parses_and_others_are_refused_with_the_list() {
    names::<ModeName>("mode", "mcts");
    names::<Tokenization>("tokenization", "bpe");
    names::<Normalization>("normalization", "none");
    names::<Backup>("backup", "Max");
    names::<SurfaceLanguage>("surface language", "textworld");
    names::<token_constraint::EndPolicy>("end policy", "at_goal");
    let error = "unconstrained_mcts".parse::<ModeName>().expect_err("kebab case");
    assert!(error.to_string().contains("constrained-mcts, constrained-greedy"), "{error}");
}
