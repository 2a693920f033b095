//! The text ⇄ token-id map of a GGUF model, built from its metadata: byte-level BPE (the
//! `tokenizers` crate's BPE model over `tokenizer.ggml.tokens` and `tokenizer.ggml.merges`), the
//! pre-tokenizer that `tokenizer.ggml.pre` names (llama.cpp's table), special tokens from
//! `tokenizer.ggml.token_type`, and the chat template from `tokenizer.chat_template`.

use std::path::Path;

use tokenizers::models::bpe::{BPE, Vocab};
use tokenizers::normalizers::unicode::NFC;
use tokenizers::pre_tokenizers::PreTokenizerWrapper;
use tokenizers::pre_tokenizers::byte_level::ByteLevel;
use tokenizers::pre_tokenizers::digits::Digits;
use tokenizers::pre_tokenizers::sequence::Sequence;
use tokenizers::pre_tokenizers::split::{Split, SplitPattern};
use tokenizers::tokenizer::SplitDelimiterBehavior;
use tokenizers::{AddedToken, Tokenizer as HfTokenizer};

use crate::chat::ChatTemplate;
use crate::error::LmError;
use crate::gguf::{GgufFile, Metadata};
use crate::vocabulary::{TokenId, TokenKind, Vocabulary, byte_level_decode, char_to_byte_map};

/// Llama 3's split: contractions, letters with one leading non-letter, numbers of 1-3 digits,
/// punctuation runs, newlines, spaces (llama.cpp `LLAMA_VOCAB_PRE_TYPE_LLAMA3`).
const REGEX_LLAMA3: &str = r"(?:'[sS]|'[tT]|'[rR][eE]|'[vV][eE]|'[mM]|'[lL][lL]|'[dD])|[^\r\n\p{L}\p{N}]?\p{L}+|\p{N}{1,3}| ?[^\s\p{L}\p{N}]+[\r\n]*|\s*[\r\n]+|\s+(?!\S)|\s+";
/// Qwen2's split: as Llama 3's, but every digit alone (llama.cpp `LLAMA_VOCAB_PRE_TYPE_QWEN2`).
const REGEX_QWEN2: &str = r"(?:'[sS]|'[tT]|'[rR][eE]|'[vV][eE]|'[mM]|'[lL][lL]|'[dD])|[^\r\n\p{L}\p{N}]?\p{L}+|\p{N}| ?[^\s\p{L}\p{N}]+[\r\n]*|\s*[\r\n]+|\s+(?!\S)|\s+";

/// How text is cut into words before BPE, by the value of `tokenizer.ggml.pre`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PreTokenizer {
    /// GPT-2's regex, no prefix space (`gpt2`, `default`; also when the key is absent).
    Gpt2,
    /// Every digit alone, then GPT-2's regex (`smollm`, `starcoder`, `refact`, ...).
    DigitsThenGpt2,
    /// Llama 3's regex (`llama-bpe`, `llama3`, `smaug-bpe`).
    Llama3,
    /// NFC, then Qwen2's regex (`qwen2`, `qwen35`, `deepseek-r1-qwen`).
    Qwen2,
}

impl PreTokenizer {
    /// The pre-tokenizer `tokenizer.ggml.pre` names; `None` for one this crate does not know.
    pub fn from_gguf_name(name: &str) -> Option<Self> {
        Some(match name {
            "gpt2" | "default" | "gpt-2" | "olmo" | "jais" => PreTokenizer::Gpt2,
            "smollm" | "starcoder" | "refact" | "command-r" | "codeshell" | "exaone" | "minerva-7b" => PreTokenizer::DigitsThenGpt2,
            "llama-bpe" | "llama3" | "smaug-bpe" | "lfm2" => PreTokenizer::Llama3,
            "qwen2" | "qwen35" | "deepseek-r1-qwen" | "megrez" => PreTokenizer::Qwen2,
            _ => return None,
        })
    }

    fn build(self) -> Result<PreTokenizerWrapper, LmError> {
        let split = |regex: &str| {
            Split::new(SplitPattern::Regex(regex.to_string()), SplitDelimiterBehavior::Isolated, false)
                .map_err(|e| LmError::Tokenizer(format!("pre-tokenizer regex: {e}")))
        };
        Ok(match self {
            PreTokenizer::Gpt2 => ByteLevel::new(false, true, true).into(),
            PreTokenizer::DigitsThenGpt2 => Sequence::new(vec![Digits::new(true).into(), ByteLevel::new(false, true, true).into()]).into(),
            PreTokenizer::Llama3 => Sequence::new(vec![split(REGEX_LLAMA3)?.into(), ByteLevel::new(false, true, false).into()]).into(),
            PreTokenizer::Qwen2 => Sequence::new(vec![split(REGEX_QWEN2)?.into(), ByteLevel::new(false, true, false).into()]).into(),
        })
    }
}

/// Text ⇄ token ids, the vocabulary, and the chat template of one model.
#[derive(Debug, Clone)]
pub struct Tokenizer {
    inner: HfTokenizer,
    vocabulary: Vocabulary,
    chat_template: Option<ChatTemplate>,
    add_bos: bool,
}

/// The parts of a byte-level BPE tokenizer, as a GGUF file stores them.
#[derive(Debug, Clone)]
pub struct BpeParts<'a> {
    /// Byte-level spellings (`Ġthe`), or the literal text of control / user-defined tokens.
    pub tokens: Vec<&'a str>,
    /// `"left right"` merge rules, highest priority first.
    pub merges: Vec<&'a str>,
    pub kinds: Vec<TokenKind>,
    pub pre_tokenizer: PreTokenizer,
    pub eos: TokenId,
    pub bos: Option<TokenId>,
    /// Further tokens that end a generation (end of turn).
    pub stop: Vec<TokenId>,
    pub add_bos: bool,
    pub chat_template: Option<&'a str>,
}

impl Tokenizer {
    /// The tokenizer of the GGUF file at `path` (the header only is read).
    pub fn from_gguf_file(path: &Path) -> Result<Self, LmError> {
        let file = GgufFile::open(path)?;
        Self::from_gguf(&Metadata::new(&file.content))
    }

    /// The tokenizer in GGUF metadata. Only `tokenizer.ggml.model = gpt2` (byte-level BPE) is built.
    pub fn from_gguf(metadata: &Metadata<'_>) -> Result<Self, LmError> {
        let model = metadata.string("tokenizer.ggml.model")?;
        if model != "gpt2" {
            return Err(LmError::UnsupportedTokenizer {
                key: "tokenizer.ggml.model",
                value: model.to_string(),
                hint: "only byte-level BPE (`gpt2`) is supported, as in Llama 3, SmolLM and Qwen models",
            });
        }
        let tokens = metadata.string_array("tokenizer.ggml.tokens")?;
        let merges = metadata.string_array("tokenizer.ggml.merges")?;
        let kinds = match metadata.get("tokenizer.ggml.token_type") {
            None => vec![TokenKind::Normal; tokens.len()],
            Some(_) => {
                let codes = metadata.integer_array("tokenizer.ggml.token_type")?;
                if codes.len() != tokens.len() {
                    return Err(LmError::BadMetadata {
                        key: "tokenizer.ggml.token_type".into(),
                        expected: "one type per token",
                        found: format!("{} types for {} tokens", codes.len(), tokens.len()),
                    });
                }
                codes
                    .iter()
                    .enumerate()
                    .map(|(i, &code)| {
                        TokenKind::from_gguf_code(code).ok_or_else(|| LmError::BadMetadata {
                            key: format!("tokenizer.ggml.token_type[{i}]"),
                            expected: "a token type 1-6",
                            found: code.to_string(),
                        })
                    })
                    .collect::<Result<_, _>>()?
            }
        };
        let pre_name = metadata.optional_string("tokenizer.ggml.pre")?.unwrap_or("gpt2");
        let pre_tokenizer = PreTokenizer::from_gguf_name(pre_name).ok_or_else(|| LmError::UnsupportedTokenizer {
            key: "tokenizer.ggml.pre",
            value: pre_name.to_string(),
            hint: "known: gpt2, smollm, starcoder, llama-bpe, qwen2 and their aliases",
        })?;
        let id = |key: &str| -> Result<Option<TokenId>, LmError> {
            match metadata.get(key) {
                None => Ok(None),
                Some(_) => {
                    let n = metadata.integer(key)?;
                    u32::try_from(n).map(Some).map_err(|_| LmError::BadMetadata {
                        key: key.to_string(),
                        expected: "a token id",
                        found: n.to_string(),
                    })
                }
            }
        };
        let eos =
            id("tokenizer.ggml.eos_token_id")?.ok_or_else(|| LmError::MissingMetadata { key: "tokenizer.ggml.eos_token_id".into() })?;
        let bos = id("tokenizer.ggml.bos_token_id")?;
        let stop: Vec<TokenId> = [id("tokenizer.ggml.eot_token_id")?, id("tokenizer.ggml.eom_token_id")?].into_iter().flatten().collect();
        let add_bos = metadata.bool_or("tokenizer.ggml.add_bos_token", false)?;
        let chat_template = metadata.optional_string("tokenizer.chat_template")?;
        Self::from_parts(BpeParts { tokens, merges, kinds, pre_tokenizer, eos, bos, stop, add_bos, chat_template })
    }

    /// A tokenizer from its parts; checks that every merge and special id is consistent.
    pub fn from_parts(parts: BpeParts<'_>) -> Result<Self, LmError> {
        let BpeParts { tokens, merges, kinds, pre_tokenizer, eos, bos, stop, add_bos, chat_template } = parts;
        if kinds.len() != tokens.len() {
            return Err(LmError::Tokenizer(format!("{} token kinds for {} tokens", kinds.len(), tokens.len())));
        }
        let char_to_byte = char_to_byte_map();
        let mut bytes = Vec::with_capacity(tokens.len());
        for (i, (token, kind)) in tokens.iter().zip(&kinds).enumerate() {
            let b = match kind {
                TokenKind::Control | TokenKind::UserDefined | TokenKind::Unknown | TokenKind::Unused => token.as_bytes().to_vec(),
                TokenKind::Byte => parse_byte_token(token).map(|b| vec![b]).ok_or_else(|| LmError::BadMetadata {
                    key: format!("tokenizer.ggml.tokens[{i}]"),
                    expected: "a byte token `<0xNN>`",
                    found: (*token).to_string(),
                })?,
                TokenKind::Normal => byte_level_decode(token, &char_to_byte).ok_or_else(|| LmError::BadMetadata {
                    key: format!("tokenizer.ggml.tokens[{i}]"),
                    expected: "a byte-level BPE piece",
                    found: (*token).to_string(),
                })?,
            };
            bytes.push(b);
        }
        let vocabulary = Vocabulary::new(bytes, kinds.clone(), eos, bos, &stop)?;

        let vocab: Vocab = tokens.iter().enumerate().map(|(i, t)| ((*t).to_string(), i as u32)).collect();
        let mut merge_pairs = Vec::with_capacity(merges.len());
        for (i, merge) in merges.iter().enumerate() {
            let (left, right) = merge.split_once(' ').ok_or_else(|| LmError::BadMetadata {
                key: format!("tokenizer.ggml.merges[{i}]"),
                expected: "two pieces separated by a space",
                found: (*merge).to_string(),
            })?;
            merge_pairs.push((left.to_string(), right.to_string()));
        }
        let bpe = BPE::builder()
            .vocab_and_merges(vocab, merge_pairs)
            .build()
            .map_err(|e| LmError::Tokenizer(format!("BPE from `tokenizer.ggml.tokens`/`merges`: {e}")))?;
        let mut inner = HfTokenizer::new(bpe);
        if pre_tokenizer == PreTokenizer::Qwen2 {
            inner.with_normalizer(Some(NFC)).map_err(|e| LmError::Tokenizer(e.to_string()))?;
        }
        inner.with_pre_tokenizer(Some(pre_tokenizer.build()?));
        // Control and user-defined tokens are matched whole in the input, before BPE.
        let whole = |wanted: TokenKind, special: bool| -> Vec<AddedToken> {
            tokens
                .iter()
                .zip(&kinds)
                .filter(|(_, kind)| **kind == wanted)
                .map(|(token, _)| AddedToken::from((*token).to_string(), special).normalized(false))
                .collect()
        };
        inner.add_special_tokens(whole(TokenKind::Control, true)).map_err(|e| LmError::Tokenizer(e.to_string()))?;
        inner.add_tokens(whole(TokenKind::UserDefined, false)).map_err(|e| LmError::Tokenizer(e.to_string()))?;
        let chat_template = chat_template.map(ChatTemplate::new).transpose()?;
        Ok(Tokenizer { inner, vocabulary, chat_template, add_bos })
    }

    pub fn vocabulary(&self) -> &Vocabulary {
        &self.vocabulary
    }

    /// The token ids of `text`. Spelled control tokens (`<|im_start|>`) become their ids, as
    /// chat prompts need; no BOS is added (see [`Tokenizer::encode_prompt`]).
    pub fn encode(&self, text: &str) -> Result<Vec<TokenId>, LmError> {
        let encoding = self.inner.encode_fast(text, false).map_err(|e| LmError::Tokenizer(e.to_string()))?;
        Ok(encoding.get_ids().to_vec())
    }

    /// As [`Tokenizer::encode`], with the BOS token in front where the model asks for one
    /// (`tokenizer.ggml.add_bos_token`) and the text does not start with it already.
    pub fn encode_prompt(&self, text: &str) -> Result<Vec<TokenId>, LmError> {
        let mut ids = self.encode(text)?;
        if self.add_bos
            && let Some(bos) = self.vocabulary.bos()
            && ids.first() != Some(&bos)
        {
            ids.insert(0, bos);
        }
        Ok(ids)
    }

    /// The bytes of `ids` (control tokens spell themselves).
    pub fn decode(&self, ids: &[TokenId]) -> Result<Vec<u8>, LmError> {
        self.vocabulary.decode(ids)
    }

    /// The text of `ids`, with invalid UTF-8 (a character cut between tokens) replaced.
    pub fn decode_lossy(&self, ids: &[TokenId]) -> Result<String, LmError> {
        Ok(String::from_utf8_lossy(&self.decode(ids)?).into_owned())
    }

    pub fn chat_template(&self) -> Option<&ChatTemplate> {
        self.chat_template.as_ref()
    }

    /// Replaces the chat template (for a served model whose template is known otherwise).
    pub fn set_chat_template(&mut self, template: Option<ChatTemplate>) {
        self.chat_template = template;
    }

    /// The prompt text for a system message and a user message, rendered by the model's chat
    /// template with the generation prompt (the assistant's turn) opened.
    pub fn chat_prompt(&self, system: &str, user: &str) -> Result<String, LmError> {
        let template = self.chat_template.as_ref().ok_or(LmError::NoChatTemplate)?;
        let bos = self.vocabulary.bos().and_then(|id| self.vocabulary.token_bytes(id)).map(|b| String::from_utf8_lossy(b).into_owned());
        let eos = self.vocabulary.token_bytes(self.vocabulary.eos()).map(|b| String::from_utf8_lossy(b).into_owned());
        template.render(&[("system", system), ("user", user)], bos.as_deref().unwrap_or(""), eos.as_deref().unwrap_or(""))
    }
}

fn parse_byte_token(token: &str) -> Option<u8> {
    let hex = token.strip_prefix("<0x")?.strip_suffix('>')?;
    if hex.len() != 2 {
        return None;
    }
    u8::from_str_radix(hex, 16).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_tokens_parse_only_in_their_exact_form() {
        assert_eq!(parse_byte_token("<0x0A>"), Some(10));
        assert_eq!(parse_byte_token("<0xff>"), Some(255));
        assert_eq!(parse_byte_token("<0x1>"), None);
        assert_eq!(parse_byte_token("0x0A"), None);
    }

    #[test]
    fn every_pre_tokenizer_name_in_the_table_builds() {
        for name in ["gpt2", "smollm", "llama-bpe", "qwen2"] {
            let pre = PreTokenizer::from_gguf_name(name).expect("known");
            assert!(pre.build().is_ok(), "{name}");
        }
        assert_eq!(PreTokenizer::from_gguf_name("tekken"), None);
    }
}
