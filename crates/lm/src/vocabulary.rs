//! The vocabulary a model speaks: token id → bytes, the kind of each token, and the
//! end-of-sequence and other special tokens. This is what `token-constraint` and `mcts` see.

use crate::error::LmError;

/// A token id: an index into the vocabulary.
pub type TokenId = u32;

/// What a vocabulary entry is, after `tokenizer.ggml.token_type` (llama.cpp's numbering).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TokenKind {
    /// Text: a byte-level BPE piece.
    Normal,
    /// The unknown token.
    Unknown,
    /// A control token (`<|im_start|>`, `<|endoftext|>`): never produced by encoding plain text.
    Control,
    /// A user-defined token, matched as a whole in the input (`<think>`).
    UserDefined,
    /// A reserved slot with no text.
    Unused,
    /// A single byte, spelled `<0xNN>`.
    Byte,
}

impl TokenKind {
    /// From llama.cpp's `llama_token_type` code (1 normal, 2 unknown, 3 control, 4 user defined,
    /// 5 unused, 6 byte); unknown codes are `None`.
    pub fn from_gguf_code(code: i64) -> Option<Self> {
        Some(match code {
            1 => TokenKind::Normal,
            2 => TokenKind::Unknown,
            3 => TokenKind::Control,
            4 => TokenKind::UserDefined,
            5 => TokenKind::Unused,
            6 => TokenKind::Byte,
            _ => return None,
        })
    }

    /// Tokens that are not text: MCTS and the token masks treat them apart.
    pub fn is_special(self) -> bool {
        matches!(self, TokenKind::Control | TokenKind::Unknown | TokenKind::Unused)
    }
}

/// Token id → bytes, kinds, and the special ids.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vocabulary {
    bytes: Vec<Box<[u8]>>,
    kinds: Vec<TokenKind>,
    eos: TokenId,
    bos: Option<TokenId>,
    stop: Vec<TokenId>,
}

impl Vocabulary {
    /// A vocabulary from each token's bytes and kind. `eos` ends a generation; `stop` are further
    /// tokens that end one (an end-of-turn token); both must be in range.
    pub fn new(bytes: Vec<Vec<u8>>, kinds: Vec<TokenKind>, eos: TokenId, bos: Option<TokenId>, stop: &[TokenId]) -> Result<Self, LmError> {
        if bytes.len() != kinds.len() {
            return Err(LmError::Tokenizer(format!("{} token texts but {} token kinds", bytes.len(), kinds.len())));
        }
        if bytes.is_empty() || bytes.len() > u32::MAX as usize {
            return Err(LmError::Tokenizer(format!("a vocabulary needs 1 to 2^32-1 tokens, not {}", bytes.len())));
        }
        let size = bytes.len();
        let check = |id: TokenId| if (id as usize) < size { Ok(id) } else { Err(LmError::TokenOutOfRange { id, size }) };
        check(eos)?;
        if let Some(bos) = bos {
            check(bos)?;
        }
        let mut all_stop = vec![eos];
        for &id in stop {
            check(id)?;
            if !all_stop.contains(&id) {
                all_stop.push(id);
            }
        }
        Ok(Vocabulary { bytes: bytes.into_iter().map(Vec::into_boxed_slice).collect(), kinds, eos, bos, stop: all_stop })
    }

    /// Tokens in the vocabulary: valid ids are `0..len()`.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Always `false`: [`Vocabulary::new`] refuses an empty vocabulary.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// The bytes a token stands for (a control token's bytes are its spelling, `<|im_end|>`).
    pub fn token_bytes(&self, id: TokenId) -> Option<&[u8]> {
        self.bytes.get(id as usize).map(|b| &b[..])
    }

    /// The token's kind; `None` for an id out of range.
    pub fn kind(&self, id: TokenId) -> Option<TokenKind> {
        self.kinds.get(id as usize).copied()
    }

    /// Whether the token is not text ([`TokenKind::is_special`]); `false` for an id out of range.
    pub fn is_special(&self, id: TokenId) -> bool {
        self.kind(id).is_some_and(TokenKind::is_special)
    }

    /// The end-of-sequence token (`tokenizer.ggml.eos_token_id`).
    pub fn eos(&self) -> TokenId {
        self.eos
    }

    /// The beginning-of-sequence token, where the model has one.
    pub fn bos(&self) -> Option<TokenId> {
        self.bos
    }

    /// Every token that ends a generation: `eos` first, then end-of-turn tokens.
    pub fn stop_tokens(&self) -> &[TokenId] {
        &self.stop
    }

    /// Whether the token ends a generation (one of [`Vocabulary::stop_tokens`]).
    pub fn is_stop(&self, id: TokenId) -> bool {
        self.stop.contains(&id)
    }

    /// `(id, bytes)` for every token, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (TokenId, &[u8])> {
        self.bytes.iter().enumerate().map(|(i, b)| (i as TokenId, &b[..]))
    }

    /// The id of the one token whose bytes are `bytes`, preferring a text token over a special one.
    pub fn find(&self, bytes: &[u8]) -> Option<TokenId> {
        let mut special = None;
        for (id, b) in self.iter() {
            if b == bytes {
                if !self.is_special(id) {
                    return Some(id);
                }
                special.get_or_insert(id);
            }
        }
        special
    }

    /// Checks that `id` is in range.
    pub fn check(&self, id: TokenId) -> Result<(), LmError> {
        if (id as usize) < self.len() { Ok(()) } else { Err(LmError::TokenOutOfRange { id, size: self.len() }) }
    }

    /// The concatenated bytes of `ids` (out-of-range ids are an error).
    pub fn decode(&self, ids: &[TokenId]) -> Result<Vec<u8>, LmError> {
        let mut out = Vec::new();
        for &id in ids {
            self.check(id)?;
            out.extend_from_slice(&self.bytes[id as usize]);
        }
        Ok(out)
    }
}

/// GPT-2's byte-level alphabet: each byte is spelled by one printable character, so that BPE
/// pieces are strings. Bytes `!`..`~`, `¡`..`¬`, `®`..`ÿ` stand for themselves; the other 68
/// bytes (controls, space, DEL, NBSP, soft hyphen) take the characters from U+0100 on, in order.
pub fn byte_to_char_table() -> [char; 256] {
    let mut table = ['\0'; 256];
    let mut next = 256u32;
    for (byte, slot) in table.iter_mut().enumerate() {
        let b = byte as u32;
        let printable = (33..=126).contains(&b) || (161..=172).contains(&b) || (174..=255).contains(&b);
        *slot = if printable {
            char::from_u32(b).unwrap_or('\0')
        } else {
            let c = char::from_u32(next).unwrap_or('\0');
            next += 1;
            c
        };
    }
    table
}

/// The bytes a byte-level BPE piece spells, or `None` if it has a character outside the alphabet.
pub fn byte_level_decode(piece: &str, char_to_byte: &rustc_hash::FxHashMap<char, u8>) -> Option<Vec<u8>> {
    piece.chars().map(|c| char_to_byte.get(&c).copied()).collect()
}

/// The inverse of `byte_to_char_table` (GPT-2's byte-to-character table).
pub fn char_to_byte_map() -> rustc_hash::FxHashMap<char, u8> {
    byte_to_char_table().iter().enumerate().map(|(b, &c)| (c, b as u8)).collect()
}

/// The byte-level spelling of `bytes` (the inverse of [`byte_level_decode`]).
pub fn byte_level_encode(bytes: &[u8]) -> String {
    let table = byte_to_char_table();
    bytes.iter().map(|&b| table[b as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_byte_level_alphabet_is_a_bijection_with_gpt2_landmarks() {
        let table = byte_to_char_table();
        let map = char_to_byte_map();
        assert_eq!(map.len(), 256);
        assert_eq!(table[b' ' as usize], 'Ġ');
        assert_eq!(table[b'\n' as usize], 'Ċ');
        assert_eq!(table[b'a' as usize], 'a');
        assert_eq!(table[0], 'Ā');
        for b in 0..=255u8 {
            assert_eq!(byte_level_decode(&byte_level_encode(&[b]), &map), Some(vec![b]));
        }
        assert_eq!(byte_level_decode("x\u{3000}", &map), None);
    }

    #[test]
    fn vocabulary_checks_ids_and_collects_stop_tokens() {
        let bytes = vec![b"<eos>".to_vec(), b"a".to_vec(), b"<eot>".to_vec()];
        let kinds = vec![TokenKind::Control, TokenKind::Normal, TokenKind::Control];
        let vocab = Vocabulary::new(bytes.clone(), kinds.clone(), 0, None, &[2, 0]).expect("valid");
        assert_eq!(vocab.stop_tokens(), &[0, 2]);
        assert!(vocab.is_stop(2) && !vocab.is_stop(1));
        assert_eq!(vocab.decode(&[1, 1, 2]).expect("in range"), b"aa<eot>");
        assert!(matches!(vocab.decode(&[3]), Err(LmError::TokenOutOfRange { id: 3, size: 3 })));
        assert_eq!(vocab.find(b"a"), Some(1));
        assert!(matches!(Vocabulary::new(bytes, kinds, 7, None, &[]), Err(LmError::TokenOutOfRange { id: 7, .. })));
    }
}
