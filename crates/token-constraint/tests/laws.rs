//! The laws on random small vocabularies and languages, against a brute-force oracle that
//! knows nothing of tries: the mask is exactly the set of tokens whose bytes keep `u` a
//! prefix of an allowed string (sound and complete), end of sequence is allowed only at a
//! boundary, every reachable `u` allows some token, and decoding only allowed tokens
//! completes an allowed action.

use std::sync::Arc;

use proptest::prelude::*;
use token_constraint::{LanguageBuilder, LanguageConfig, Matcher, Step, Token, Vocabulary};

const ALPHABET: &[u8] = b"ab \nDONE";

/// Every byte of the alphabet as a token (so every string can be written), random longer
/// tokens (some with the separator inside), an end-of-sequence token and a special token
/// whose text is an ordinary word.
fn vocabulary() -> impl Strategy<Value = (Vec<Token>, u32)> {
    prop::collection::vec(prop::collection::vec(prop::sample::select(ALPHABET.to_vec()), 2..6), 0..40).prop_map(|extra| {
        let mut tokens: Vec<Token> = ALPHABET.iter().map(|&b| Token { bytes: vec![b], special: false }).collect();
        tokens.extend(extra.into_iter().map(|bytes| Token { bytes, special: false }));
        tokens.push(Token { bytes: b"ab".to_vec(), special: true });
        tokens.push(Token { bytes: b"<eos>".to_vec(), special: true });
        let eos = tokens.len() as u32 - 1;
        (tokens, eos)
    })
}

/// Action texts over `a`, `b`, space (never the separator, never the end marker).
fn texts() -> impl Strategy<Value = Vec<(Vec<u8>, bool)>> {
    prop::collection::vec((prop::collection::vec(prop::sample::select(b"ab ".to_vec()), 1..7), any::<bool>()), 0..8)
}

struct Oracle {
    /// `text · separator` per distinct text, and the end marker when allowed.
    strings: Vec<Vec<u8>>,
    texts: Vec<(Vec<u8>, bool)>,
    end_here: bool,
}

impl Oracle {
    fn new(texts: &[(Vec<u8>, bool)], end_here: bool) -> Oracle {
        let mut distinct: Vec<(Vec<u8>, bool)> = Vec::new();
        for (t, e) in texts {
            match distinct.iter_mut().find(|(d, _)| d == t) {
                Some(d) => d.1 |= *e,
                None => distinct.push((t.clone(), *e)),
            }
        }
        let mut strings: Vec<Vec<u8>> = distinct.iter().map(|(t, _)| [t.as_slice(), b"\n"].concat()).collect();
        if end_here {
            strings.push(b"DONE".to_vec());
        }
        Oracle { strings, texts: distinct, end_here }
    }

    fn allows(&self, vocab: &Vocabulary, u: &[u8], token: u32) -> bool {
        if vocab.is_eos(token) {
            return (u.is_empty() && self.end_here) || self.texts.iter().any(|(t, e)| *e && t == u);
        }
        if vocab.is_special(token) || vocab.token_bytes(token).is_empty() {
            return false;
        }
        let extended = [u, vocab.token_bytes(token)].concat();
        self.strings.iter().any(|s| s.starts_with(&extended))
    }
}

fn build(texts: &[(Vec<u8>, bool)], end_here: bool) -> Matcher {
    let mut builder = LanguageBuilder::new(LanguageConfig::default());
    for (t, e) in texts {
        builder.push(t, *e).unwrap();
    }
    builder.end_here(end_here);
    Matcher::new(Arc::new(builder.build()))
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x746f_6b65_6e73),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    /// Along random tokenizations of every allowed string, the mask at each `u` equals the
    /// oracle's, is never empty, and the string completes with the right event.
    #[test]
    fn masks_are_exact_along_every_allowed_string(
        (tokens, eos) in vocabulary(), texts in texts(), end_here: bool, picks in prop::collection::vec(any::<prop::sample::Index>(), 64),
    ) {
        let vocab = Vocabulary::new(tokens, &[eos]).unwrap();
        let oracle = Oracle::new(&texts, end_here);
        let root = build(&texts, end_here);
        for (target, string) in oracle.strings.iter().enumerate() {
            let mut matcher = root.clone();
            let mut pick = picks.iter().cycle();
            loop {
                let u = matcher.prefix().to_vec();
                let mask = matcher.mask(&vocab);
                for t in 0..vocab.len() as u32 {
                    prop_assert_eq!(mask.contains(t), oracle.allows(&vocab, &u, t), "token {} at {:?}", t, String::from_utf8_lossy(&u));
                }
                prop_assert!(!mask.is_empty(), "a reachable u allows some token");
                // Walk towards `string` with a random token that stays on it.
                let on_path: Vec<u32> = mask.iter().filter(|&t| !vocab.is_special(t) && string.starts_with(&[u.as_slice(), vocab.token_bytes(t)].concat())).collect();
                prop_assert!(!on_path.is_empty(), "some token continues towards {:?}", String::from_utf8_lossy(string));
                let token = on_path[pick.next().unwrap().index(on_path.len())];
                match matcher.advance(&vocab, token).unwrap() {
                    Step::Partial => prop_assert!(matcher.prefix().len() < string.len()),
                    Step::Action(choice) => {
                        prop_assert!(target < oracle.texts.len());
                        prop_assert_eq!(matcher.language().text(choice), oracle.texts[target].0.as_slice());
                        prop_assert_eq!(matcher.prefix(), string.as_slice());
                        break;
                    }
                    Step::End => {
                        prop_assert!(end_here && string == b"DONE");
                        break;
                    }
                    Step::ActionThenEnd(_) => prop_assert!(false, "EOS is never picked on a path"),
                }
            }
        }
    }

    /// Decoding with random allowed tokens (EOS included) always ends in an allowed action
    /// or an allowed end; EOS fires only at a boundary.
    #[test]
    fn decoding_allowed_tokens_only_writes_allowed_actions(
        (tokens, eos) in vocabulary(), texts in texts(), end_here: bool, picks in prop::collection::vec(any::<prop::sample::Index>(), 1..64),
    ) {
        let vocab = Vocabulary::new(tokens, &[eos]).unwrap();
        let oracle = Oracle::new(&texts, end_here);
        let mut matcher = build(&texts, end_here);
        let mut allowed = Vec::new();
        for pick in picks {
            matcher.allowed(&vocab, &mut allowed);
            if allowed.is_empty() {
                prop_assert!(oracle.strings.is_empty() && !end_here, "only an empty language with no end allows nothing");
                break;
            }
            allowed.sort_unstable();
            let token = allowed[pick.index(allowed.len())];
            let before = matcher.prefix().to_vec();
            match matcher.advance(&vocab, token).unwrap() {
                Step::Partial => {}
                Step::Action(choice) => {
                    prop_assert_eq!([matcher.language().text(choice), b"\n"].concat(), matcher.prefix().to_vec());
                    break;
                }
                Step::ActionThenEnd(choice) => {
                    prop_assert_eq!(matcher.language().text(choice), before.as_slice());
                    prop_assert!(matcher.language().end_after(choice));
                    break;
                }
                Step::End => {
                    prop_assert!(end_here);
                    prop_assert!(before.is_empty() && vocab.is_eos(token) || matcher.prefix() == b"DONE");
                    break;
                }
            }
        }
    }
}
