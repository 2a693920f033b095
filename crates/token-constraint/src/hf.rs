//! Hugging Face adapter (feature `hf`): a `tokenizer.json` to the byte [`Vocabulary`].
//!
//! Token strings in a tokenizer file are not bytes. Byte-level BPE (GPT-2, Llama 3, Qwen,
//! SmolLM2) writes each byte as one printable character (`Ġ` for a space, `Ċ` for a line
//! feed, …); SentencePiece-style files (Llama 2, Mistral) write `▁` for a space and
//! `<0x0A>` for a byte fallback token. The decoder section of the file says which; added
//! tokens are literal text either way. The byte-level alphabet is the fixed table GPT-2
//! published; the `tokenizers` crate keeps its copy private, so it is rebuilt here.

use std::path::Path;

use tokenizers::DecoderWrapper;
/// The `tokenizers` crate's tokenizer, which [`load_tokenizer`] and [`vocabulary_from_file`]
/// return: re-exported so that a user can name it without depending on `tokenizers` itself.
pub use tokenizers::Tokenizer;

use crate::TokenId;
use crate::vocab::{Token, Vocabulary, VocabularyError};

/// Names of end-of-sequence tokens in common chat models; in [`vocabulary_from_file`], those the
/// tokenizer has as added special tokens are its end of sequence: Qwen/SmolLM2 (`<|im_end|>`, `<|endoftext|>`), Llama 2 (`</s>`),
/// Llama 3 (`<|eot_id|>`, `<|end_of_text|>`).
pub const COMMON_EOS: &[&str] = &["<|im_end|>", "<|endoftext|>", "</s>", "<|eot_id|>", "<|end_of_text|>"];

/// Why a tokenizer file could not be turned into a vocabulary.
#[derive(Debug, thiserror::Error)]
pub enum HfError {
    /// The file could not be read or parsed as a `tokenizer.json`.
    #[error("{path}: cannot read the tokenizer: {message}")]
    Read {
        /// The tokenizer file, as given.
        path: String,
        /// The `tokenizers` library's error.
        message: String,
    },
    /// The decoder is neither byte-level nor SentencePiece (Metaspace, Replace or byte
    /// fallback), or there is none.
    #[error("{path}: decoder {decoder} is not supported (byte-level BPE and SentencePiece byte fallback are)")]
    UnsupportedDecoder {
        /// The tokenizer file, as given.
        path: String,
        /// `none`, or the first 60 characters of the decoder's debug form.
        decoder: String,
    },
    /// Under a byte-level decoder, a token's text has a character outside GPT-2's byte
    /// alphabet.
    #[error("{path}: token {id} ({text:?}) has a character outside the byte-level alphabet")]
    NotByteLevel {
        /// The tokenizer file, as given.
        path: String,
        /// The token.
        id: TokenId,
        /// Its text in the vocabulary.
        text: String,
    },
    /// None of the end-of-sequence names is an added special token of the tokenizer.
    #[error("{path}: no end-of-sequence token among {names:?}")]
    NoEos {
        /// The tokenizer file, as given.
        path: String,
        /// The names looked up.
        names: Vec<String>,
    },
    /// The tokens do not make a [`Vocabulary`].
    #[error("{path}: {source}")]
    Vocabulary {
        /// The tokenizer file, as given.
        path: String,
        /// Why.
        source: VocabularyError,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Decoding {
    ByteLevel,
    SentencePiece { byte_fallback: bool },
}

fn decoding(decoder: Option<&DecoderWrapper>) -> Result<Decoding, String> {
    fn scan(d: &DecoderWrapper, byte_level: &mut bool, metaspace: &mut bool, fallback: &mut bool) {
        match d {
            DecoderWrapper::ByteLevel(_) => *byte_level = true,
            DecoderWrapper::Metaspace(_) | DecoderWrapper::Replace(_) => *metaspace = true,
            DecoderWrapper::ByteFallback(_) => *fallback = true,
            DecoderWrapper::Sequence(seq) => seq.get_decoders().iter().for_each(|d| scan(d, byte_level, metaspace, fallback)),
            _ => {}
        }
    }
    let Some(decoder) = decoder else { return Err("none".into()) };
    let (mut byte_level, mut metaspace, mut fallback) = (false, false, false);
    scan(decoder, &mut byte_level, &mut metaspace, &mut fallback);
    if byte_level {
        Ok(Decoding::ByteLevel)
    } else if metaspace || fallback {
        Ok(Decoding::SentencePiece { byte_fallback: fallback })
    } else {
        Err(format!("{decoder:?}").chars().take(60).collect())
    }
}

/// GPT-2's byte-level alphabet, inverted: character → byte. Printable Latin-1 bytes stand
/// for themselves; the other 68 bytes map, in order, to U+0100 onwards.
fn byte_level_alphabet() -> rustc_hash::FxHashMap<char, u8> {
    let mut map = rustc_hash::FxHashMap::default();
    let mut next = 256u32;
    for b in 0u8..=255 {
        let printable = matches!(b, b'!'..=b'~' | 0xA1..=0xAC | 0xAE..=0xFF);
        let c = if printable {
            char::from(b)
        } else {
            let c = char::from_u32(next).expect("U+0100..U+0143 are characters");
            next += 1;
            c
        };
        map.insert(c, b);
    }
    map
}

/// Reads a `tokenizer.json`.
pub fn load_tokenizer(path: &Path) -> Result<Tokenizer, HfError> {
    Tokenizer::from_file(path).map_err(|e| HfError::Read { path: path.display().to_string(), message: e.to_string() })
}

/// The byte vocabulary of `tokenizer`; `eos` names the end-of-sequence tokens. Only names of
/// the tokenizer's added special tokens count (Qwen3's ordinary `</s>` does not end a
/// sequence); the others, and names absent from the vocabulary, are skipped; at least one must
/// remain ([`HfError::NoEos`]).
pub fn vocabulary(tokenizer: &Tokenizer, eos: &[&str], path: &Path) -> Result<Vocabulary, HfError> {
    let path_text = || path.display().to_string();
    let decoding = decoding(tokenizer.get_decoder()).map_err(|decoder| HfError::UnsupportedDecoder { path: path_text(), decoder })?;
    let added = tokenizer.get_added_tokens_decoder();
    let vocab = tokenizer.get_vocab(true);
    let len = vocab.values().map(|&id| id as usize + 1).max().unwrap_or(0);
    // Ids no string maps to (holes in some files) become empty special tokens: never allowed.
    let mut tokens = vec![Token { bytes: Vec::new(), special: true }; len];
    let alphabet = byte_level_alphabet();
    for (text, &id) in &vocab {
        let token = &mut tokens[id as usize];
        if let Some(added) = added.get(&id) {
            *token = Token { bytes: added.content.as_bytes().to_vec(), special: added.special };
            continue;
        }
        let bytes = match decoding {
            Decoding::ByteLevel => text
                .chars()
                .map(|c| alphabet.get(&c).copied())
                .collect::<Option<Vec<u8>>>()
                .ok_or_else(|| HfError::NotByteLevel { path: path_text(), id, text: text.clone() })?,
            Decoding::SentencePiece { byte_fallback } => {
                let hex = text.strip_prefix("<0x").and_then(|t| t.strip_suffix('>')).filter(|h| h.len() == 2);
                match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                    Some(b) if byte_fallback => vec![b],
                    _ => text.replace('\u{2581}', " ").into_bytes(),
                }
            }
        };
        *token = Token { bytes, special: false };
    }
    // Only added special tokens end a sequence: Qwen3's vocabulary also has an ordinary `</s>`.
    let eos_ids: Vec<TokenId> =
        eos.iter().filter_map(|name| tokenizer.token_to_id(name)).filter(|id| added.get(id).is_some_and(|a| a.special)).collect();
    if eos_ids.is_empty() {
        return Err(HfError::NoEos { path: path_text(), names: eos.iter().map(|s| s.to_string()).collect() });
    }
    Vocabulary::new(tokens, &eos_ids).map_err(|source| HfError::Vocabulary { path: path_text(), source })
}

/// Reads `path` and returns its byte vocabulary (end-of-sequence: [`COMMON_EOS`]) with the
/// tokenizer, whose `encode` gives canonical tokenizations.
pub fn vocabulary_from_file(path: &Path) -> Result<(Vocabulary, Tokenizer), HfError> {
    let tokenizer = load_tokenizer(path)?;
    let vocabulary = vocabulary(&tokenizer, COMMON_EOS, path)?;
    Ok((vocabulary, tokenizer))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_byte_level_alphabet_is_a_bijection_with_the_known_letters() {
        let alphabet = byte_level_alphabet();
        assert_eq!(alphabet.len(), 256);
        assert_eq!(alphabet[&'Ġ'], b' ');
        assert_eq!(alphabet[&'Ċ'], b'\n');
        assert_eq!(alphabet[&'ĉ'], b'\t');
        assert_eq!(alphabet[&'a'], b'a');
        assert_eq!(alphabet[&'Ā'], 0);
        let mut bytes: Vec<u8> = alphabet.values().copied().collect();
        bytes.sort_unstable();
        bytes.dedup();
        assert_eq!(bytes.len(), 256);
    }
}
