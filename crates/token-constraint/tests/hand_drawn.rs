//! A vocabulary small enough to check every mask by eye: prefixes that are actions of their
//! own (`cab 1` / `cab 10`), a token that ends at the separator, one that runs past it, the
//! end marker split over tokens, end of sequence, and a special token whose text would match.

use std::sync::Arc;

use token_constraint::{LanguageBuilder, LanguageConfig, Matcher, Step, Token, TokenError, Vocabulary};

const WORDS: &[&str] = &[
    "go",      // 0
    " cab",    // 1
    " 1",      // 2
    "0",       // 3
    "\n",      // 4
    "1\n",     // 5: ends exactly at the separator
    "\ngo",    // 6: runs past the separator into the next action
    "DO",      // 7
    "NE",      // 8
    "DONE",    // 9
    "g",       // 10
    "o cab 1", // 11
    "x",       // 12
    " ",       // 13
    "cab",     // 14
    "1",       // 15
];
const EOS: u32 = 16;
const SPECIAL_GO: u32 = 17;

fn vocab() -> Vocabulary {
    let mut tokens: Vec<Token> = WORDS.iter().map(|w| Token { bytes: w.as_bytes().to_vec(), special: false }).collect();
    tokens.push(Token { bytes: b"</s>".to_vec(), special: true });
    tokens.push(Token { bytes: b"go".to_vec(), special: true });
    Vocabulary::new(tokens, &[EOS]).unwrap()
}

fn matcher(end_after: bool) -> Matcher {
    let mut builder = LanguageBuilder::new(LanguageConfig::default());
    assert_eq!(builder.push(b"go cab 1", end_after), Ok(0));
    assert_eq!(builder.push(b"go cab 10", end_after), Ok(1));
    Matcher::new(Arc::new(builder.build()))
}

fn mask(m: &Matcher, v: &Vocabulary) -> Vec<u32> {
    let mask = m.mask(v);
    let mut sparse = Vec::new();
    m.allowed(v, &mut sparse);
    sparse.sort_unstable();
    assert_eq!(sparse, mask.iter().collect::<Vec<_>>(), "the sparse list and the bitset agree");
    for t in 0..v.len() as u32 {
        assert_eq!(m.is_allowed(v, t), mask.contains(t), "is_allowed agrees with the mask for token {t}");
    }
    mask.iter().collect()
}

#[test]
fn masks_along_one_action_are_what_the_eye_expects() {
    let v = vocab();
    let mut m = matcher(false);
    // Boundary: "go", "g", "DO", "DONE", EOS; not the special token spelled "go", not "\ngo".
    assert_eq!(mask(&m, &v), vec![0, 7, 9, 10, EOS]);
    assert_eq!(m.advance(&v, 10), Ok(Step::Partial));
    // After "g": "o cab 1" only.
    assert_eq!(mask(&m, &v), vec![11]);
    assert_eq!(m.advance(&v, 11), Ok(Step::Partial));
    assert_eq!(m.prefix(), b"go cab 1");
    // "go cab 1" is a complete text (of choice 0) and a prefix of choice 1: "0", "\n", "1\n"? no:
    // "1\n" would make "go cab 11\n". EOS is not allowed: end_after is false.
    assert_eq!(mask(&m, &v), vec![3, 4]);
    assert_eq!(m.advance(&v, 3), Ok(Step::Partial));
    assert_eq!(mask(&m, &v), vec![4]);
    assert_eq!(m.advance(&v, 4), Ok(Step::Action(1)));
    // Completed: nothing is allowed until the next state's language is entered.
    assert_eq!(mask(&m, &v), Vec::<u32>::new());
    assert_eq!(m.advance(&v, 0), Err(TokenError::AwaitingLanguage));
}

#[test]
fn a_token_may_end_at_the_separator_but_not_run_past_it() {
    let v = vocab();
    let mut m = matcher(false);
    for t in [0, 1] {
        m.advance(&v, t).unwrap();
    }
    // After "go cab": " 1" only (" " then "1" is another tokenization: " " is allowed too).
    assert_eq!(mask(&m, &v), vec![2, 13]);
    m.advance(&v, 13).unwrap();
    // After "go cab ": "1" and "1\n" (which completes choice 0 in one token).
    assert_eq!(mask(&m, &v), vec![5, 15]);
    assert_eq!(m.advance(&v, 5), Ok(Step::Action(0)));

    let mut m = matcher(false);
    for t in [0, 1, 2] {
        m.advance(&v, t).unwrap();
    }
    // "\ngo" would complete "go cab 1" and start the next action in the same token.
    assert!(!m.is_allowed(&v, 6));
    assert!(matches!(m.advance(&v, 6), Err(TokenError::NotAllowed { token: 6, .. })));
    assert_eq!(m.prefix(), b"go cab 1", "a refused token changes nothing");
}

#[test]
fn end_of_sequence_only_at_a_boundary() {
    let v = vocab();
    let mut m = matcher(true);
    for t in [0, 1] {
        m.advance(&v, t).unwrap();
    }
    assert!(!mask(&m, &v).contains(&EOS), "not inside an action");
    m.advance(&v, 2).unwrap();
    // With end_after, EOS right after a complete text ends the plan with that action.
    assert_eq!(mask(&m, &v), vec![3, 4, EOS]);
    assert_eq!(m.advance(&v, EOS), Ok(Step::ActionThenEnd(0)));
    assert!(m.is_finished());
    assert_eq!(m.advance(&v, 0), Err(TokenError::Finished));
    assert!(mask(&m, &v).is_empty());

    let mut m = matcher(false);
    assert_eq!(m.advance(&v, 7), Ok(Step::Partial));
    assert_eq!(mask(&m, &v), vec![8]);
    assert_eq!(m.advance(&v, 8), Ok(Step::End));
    assert!(m.is_finished());
}

#[test]
fn no_end_where_the_language_forbids_it() {
    let v = vocab();
    let mut builder = LanguageBuilder::new(LanguageConfig::default());
    builder.push(b"go cab 1", false).unwrap();
    builder.end_here(false);
    let m = Matcher::new(Arc::new(builder.build()));
    assert_eq!(mask(&m, &v), vec![0, 10]);
    // Special tokens never match by their text; ids outside the vocabulary are refused.
    assert!(!m.is_allowed(&v, SPECIAL_GO));
    let mut m2 = m.clone();
    assert_eq!(m2.advance(&v, 99), Err(TokenError::UnknownToken { token: 99 }));
}

#[test]
fn bad_action_texts_are_refused_with_the_text() {
    let mut builder = LanguageBuilder::new(LanguageConfig::default());
    assert!(builder.push(b"", false).is_err());
    let error = builder.push(b"go\nthere", false).unwrap_err();
    assert_eq!(error.to_string(), "action text \"go\\nthere\" contains the separator \"\\n\"");
    let error = builder.push(b"DONE now", false).unwrap_err();
    assert_eq!(error.to_string(), "action text \"DONE now\" starts with the end marker \"DONE\"");
    assert_eq!(builder.push(b"x", false), Ok(0));
    assert_eq!(builder.push(b"x", true), Ok(0), "a repeated text keeps its id");
    assert!(builder.build().end_after(0), "and gains end_after");
}

/// An empty end marker is no end marker, for the builder's checks as for the masks: texts are
/// accepted (every text starts with the empty string), and at the boundary only the actions and
/// EOS are allowed, as with `None`.
#[test]
fn an_empty_end_marker_is_no_end_marker() {
    let v = vocab();
    for end_marker in [None, Some(Vec::new())] {
        let mut builder = LanguageBuilder::new(LanguageConfig { separator: b"\n".to_vec(), end_marker: end_marker.clone() });
        assert_eq!(builder.push(b"go cab 1", true), Ok(0), "{end_marker:?}");
        let m = Matcher::new(Arc::new(builder.build()));
        assert_eq!(mask(&m, &v), vec![0, 10, EOS], "{end_marker:?}");
    }
}
