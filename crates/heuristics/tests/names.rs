//! The command-line names of the heuristics, searches and clocks: each parses back to its
//! enum, and a name that is none of them is refused with the names there are.

use heuristics::search::{Algorithm, Clock};
use heuristics::{HeuristicName, UnknownName};
use strum::VariantNames;

/// Every name parses, and the parsed value's name is the name given.
fn round_trips<T>()
where
    T: VariantNames + std::str::FromStr<Err = UnknownName> + Into<&'static str>,
{
    for &name in T::VARIANTS {
        let value: T = name.parse().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(value.into(), name);
    }
}

#[test]
fn every_name_parses_back_to_itself() {
    round_trips::<HeuristicName>();
    round_trips::<Algorithm>();
    round_trips::<Clock>();
    assert_eq!(HeuristicName::VARIANTS, ["blind", "goalcount", "hmax", "hadd", "ff", "lmcut", "lmcut-admissible"]);
    assert_eq!(Algorithm::VARIANTS, ["astar", "gbfs", "lazy-gbfs"]);
    assert_eq!(Clock::VARIANTS, ["wall", "cpu"]);
}

#[test]
fn an_unknown_name_is_refused_with_the_names_there_are() {
    let error = "lm-cut".parse::<HeuristicName>().expect_err("not a heuristic");
    assert_eq!(
        error.to_string(),
        "`lm-cut` is not a heuristic: the heuristics are blind, goalcount, hmax, hadd, ff, lmcut, lmcut-admissible"
    );
    assert_eq!((error.what, error.given.as_str(), error.valid), ("heuristic", "lm-cut", HeuristicName::VARIANTS));

    let error = "a-star".parse::<Algorithm>().expect_err("not a search");
    assert_eq!(error.to_string(), "`a-star` is not a search algorithm: the search algorithms are astar, gbfs, lazy-gbfs");
    let error = "Wall".parse::<Clock>().expect_err("names are lower case");
    assert_eq!(error.to_string(), "`Wall` is not a clock: the clocks are wall, cpu");
    // The error is a std error, for `?` into `Box<dyn Error>` and `anyhow`.
    let boxed: Box<dyn std::error::Error + Send + Sync> = Box::new(error);
    assert!(boxed.to_string().starts_with("`Wall`"));
}
