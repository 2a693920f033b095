//! The text ⇄ token-id map of a model, from one of two sources.
//!
//! - GGUF metadata: byte-level BPE (the `tokenizers` crate's BPE model over
//!   `tokenizer.ggml.tokens` and `tokenizer.ggml.merges`), the pre-tokenizer that
//!   `tokenizer.ggml.pre` names (llama.cpp's table), special tokens from
//!   `tokenizer.ggml.token_type`, and the chat template from `tokenizer.chat_template`.
//! - A Hugging Face `tokenizer.json` (byte-level BPE only), loaded as it is by the `tokenizers`
//!   crate, so that encoding is exactly the reference's; the special tokens and chat template come
//!   from the `tokenizer_config.json` beside it. No model file is needed (the uniform backend).

use std::path::Path;
use std::str::FromStr;

use serde::Deserialize;
use tokenizers::models::ModelWrapper;
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
/// Llama 3's split as its `tokenizer.json` spells it (contractions case-insensitive by `(?i:)`).
const REGEX_LLAMA3_HF: &str =
    r"(?i:'s|'t|'re|'ve|'m|'ll|'d)|[^\r\n\p{L}\p{N}]?\p{L}+|\p{N}{1,3}| ?[^\s\p{L}\p{N}]+[\r\n]*|\s*[\r\n]+|\s+(?!\S)|\s+";
/// Qwen2's (and Qwen2.5's, Qwen3's) split as its `tokenizer.json` spells it.
const REGEX_QWEN2_HF: &str =
    r"(?i:'s|'t|'re|'ve|'m|'ll|'d)|[^\r\n\p{L}\p{N}]?\p{L}+|\p{N}| ?[^\s\p{L}\p{N}]+[\r\n]*|\s*[\r\n]+|\s+(?!\S)|\s+";

/// End-of-sequence and end-of-turn tokens by name, for a `tokenizer.json` whose
/// `tokenizer_config.json` does not name its `eos_token`: the first one present as a special
/// token is the EOS. Every one present as a special token stops a generation. Qwen and SmolLM2
/// (`<|im_end|>`, `<|endoftext|>`), Llama 3 (`<|eot_id|>`, `<|end_of_text|>`, `<|eom_id|>`),
/// Llama 2 and Mistral (`</s>`), Phi-3 (`<|end|>`), Gemma (`<end_of_turn>`, `<eos>`).
pub const COMMON_STOP_TOKENS: &[&str] =
    &["<|im_end|>", "<|eot_id|>", "<|endoftext|>", "<|end_of_text|>", "<|eom_id|>", "</s>", "<|end|>", "<end_of_turn>", "<eos>"];
/// Beginning-of-sequence tokens by name, for a `tokenizer.json` without a `tokenizer_config.json`
/// (Llama 3, Llama 2, Gemma, Yi); Qwen has none.
pub const COMMON_BOS_TOKENS: &[&str] = &["<|begin_of_text|>", "<s>", "<bos>", "<|startoftext|>"];

/// How text is cut into words before BPE, by the value of `tokenizer.ggml.pre` or the
/// `pre_tokenizer` section of a `tokenizer.json`.
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

    /// The pre-tokenizer a `tokenizer.json`'s `pre_tokenizer` section spells: `ByteLevel` with
    /// GPT-2's regex; `Digits` (each alone) then that; or a `Split` by Llama 3's or Qwen2's regex
    /// (either spelling of the contractions), isolating the matches, then `ByteLevel` without a
    /// regex. No prefix space in any. `None` for anything else.
    fn from_tokenizer_json(section: Option<&PreTokenizerWrapper>) -> Option<Self> {
        use PreTokenizerWrapper as Pre;
        let byte_level = |b: &ByteLevel, use_regex: bool| !b.add_prefix_space && b.use_regex == use_regex;
        match section? {
            Pre::ByteLevel(b) if byte_level(b, true) => Some(PreTokenizer::Gpt2),
            Pre::Sequence(sequence) => match sequence.as_ref() {
                [Pre::Digits(digits), Pre::ByteLevel(b)] if digits.individual_digits && byte_level(b, true) => {
                    Some(PreTokenizer::DigitsThenGpt2)
                }
                [Pre::Split(split), Pre::ByteLevel(b)]
                    if byte_level(b, false) && split.behavior == SplitDelimiterBehavior::Isolated && !split.invert =>
                {
                    match &split.pattern {
                        SplitPattern::Regex(r) if r == REGEX_LLAMA3 || r == REGEX_LLAMA3_HF => Some(PreTokenizer::Llama3),
                        SplitPattern::Regex(r) if r == REGEX_QWEN2 || r == REGEX_QWEN2_HF => Some(PreTokenizer::Qwen2),
                        _ => None,
                    }
                }
                _ => None,
            },
            _ => None,
        }
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
    pre_tokenizer: PreTokenizer,
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
    /// The kind of each of `tokens`, in the same order.
    pub kinds: Vec<TokenKind>,
    /// How text is cut into words before BPE.
    pub pre_tokenizer: PreTokenizer,
    /// The end-of-sequence token; it also ends a generation.
    pub eos: TokenId,
    /// The beginning-of-sequence token, where the model has one.
    pub bos: Option<TokenId>,
    /// Further tokens that end a generation (end of turn).
    pub stop: Vec<TokenId>,
    /// Whether [`Tokenizer::encode_prompt`] puts `bos` in front.
    pub add_bos: bool,
    /// The chat template's Jinja source, where there is one.
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
        Ok(Tokenizer { inner, vocabulary, pre_tokenizer, chat_template, add_bos })
    }

    /// The Hugging Face `tokenizer.json` at `path` (byte-level BPE), with the special tokens and
    /// chat template of the `tokenizer_config.json` beside it when there is one, else of a
    /// `chat_template.jinja` beside it. See [`Tokenizer::from_tokenizer_json_str`].
    pub fn from_tokenizer_json(path: &Path) -> Result<Self, LmError> {
        let read = |p: &Path| std::fs::read_to_string(p).map_err(|source| LmError::Io { path: p.to_path_buf(), source });
        let json = read(path)?;
        let config_path = path.with_file_name("tokenizer_config.json");
        let mut config = if config_path.is_file() { Some(TokenizerConfig::parse(&read(&config_path)?, &config_path)?) } else { None };
        let template_path = path.with_file_name("chat_template.jinja");
        if config.as_ref().is_none_or(|c| c.chat_template.is_none()) && template_path.is_file() {
            config.get_or_insert_default().chat_template = Some(read(&template_path)?);
        }
        Self::from_tokenizer_json_parts(&json, path, config, &config_path)
    }

    /// The tokenizer in the text of a Hugging Face `tokenizer.json`, and of its
    /// `tokenizer_config.json` where there is one.
    ///
    /// Only byte-level BPE is built (`model.type = BPE`, no byte fallback, no subword affixes,
    /// a `pre_tokenizer` that [`PreTokenizer`] names). The file is loaded by the `tokenizers`
    /// crate as it is (normalizer, regex, added tokens), so `encode` gives the reference's ids.
    /// Added tokens marked `special` are [`TokenKind::Control`], the others
    /// [`TokenKind::UserDefined`]; both are matched whole in the input. The config gives
    /// `eos_token`, `bos_token`, `add_bos_token` and `chat_template`; without one, the EOS is the
    /// first of [`COMMON_STOP_TOKENS`] present as a special token, and the BOS the first of
    /// [`COMMON_BOS_TOKENS`]. Every special token of [`COMMON_STOP_TOKENS`] also stops a
    /// generation (Qwen3: `<|im_end|>`, then `<|endoftext|>`). Without `add_bos_token`, a BOS is
    /// added where the file's post-processor adds one (Llama 3). Errors name `tokenizer.json` or
    /// `tokenizer_config.json` as the file.
    pub fn from_tokenizer_json_str(tokenizer_json: &str, tokenizer_config_json: Option<&str>) -> Result<Self, LmError> {
        let config_path = Path::new("tokenizer_config.json");
        let config = tokenizer_config_json.map(|text| TokenizerConfig::parse(text, config_path)).transpose()?;
        Self::from_tokenizer_json_parts(tokenizer_json, Path::new("tokenizer.json"), config, config_path)
    }

    fn from_tokenizer_json_parts(json: &str, path: &Path, config: Option<TokenizerConfig>, config_path: &Path) -> Result<Self, LmError> {
        let inner = HfTokenizer::from_str(json).map_err(|e| json_error(path, &*e))?;
        let ModelWrapper::BPE(bpe) = inner.get_model() else {
            let value = match inner.get_model() {
                ModelWrapper::BPE(_) => "BPE",
                ModelWrapper::WordPiece(_) => "WordPiece",
                ModelWrapper::WordLevel(_) => "WordLevel",
                ModelWrapper::Unigram(_) => "Unigram",
            };
            return Err(LmError::UnsupportedTokenizer {
                key: "model.type",
                value: value.to_string(),
                hint: "only byte-level BPE is supported, as in Llama 3, SmolLM and Qwen models",
            });
        };
        check_byte_level_bpe(bpe)?;
        let pre_tokenizer = PreTokenizer::from_tokenizer_json(inner.get_pre_tokenizer()).ok_or_else(|| {
            let section = serde_json::to_string(&inner.get_pre_tokenizer()).unwrap_or_default();
            LmError::UnsupportedTokenizer {
                key: "pre_tokenizer",
                value: abbreviate(&section, 300),
                hint: "known: ByteLevel (GPT-2), Digits then ByteLevel (SmolLM2), Split by Llama 3's or Qwen2's regex then ByteLevel",
            }
        })?;

        let model_vocab = bpe.get_vocab();
        let added = inner.get_added_tokens_decoder();
        // The `tokenizers` crate numbers added tokens itself, after the model's vocabulary, and
        // only warns where the file says otherwise; ids that differ from the file's would not be
        // the model's, so they are an error here.
        let declared: AddedTokensSection = serde_json::from_str(json).map_err(|e| json_error(path, &e))?;
        for token in &declared.added_tokens {
            let id = inner.token_to_id(&token.content);
            if id != Some(token.id) {
                return Err(LmError::BadTokenizerFile {
                    path: path.to_path_buf(),
                    message: format!(
                        "`added_tokens` gives {:?} the id {}, but it is numbered {} (added tokens must follow the vocabulary without gaps)",
                        token.content,
                        token.id,
                        id.map_or("nothing".to_string(), |id| id.to_string())
                    ),
                });
            }
        }
        let size = model_vocab.values().chain(added.keys()).map(|&id| id as usize + 1).max().unwrap_or(0);
        // Holes are allowed, but not a vocabulary mostly of holes: one absurd id (4e9) would
        // otherwise allocate tables for billions of tokens before anything else is checked.
        let tokens = model_vocab.len() + added.len();
        if size > 2 * tokens + 1024 {
            let (text, id) = model_vocab
                .iter()
                .map(|(t, &id)| (t.clone(), id))
                .chain(added.iter().map(|(&id, t)| (t.content.clone(), id)))
                .max_by_key(|&(_, id)| id)
                .unwrap_or_default();
            return Err(LmError::BadTokenizerFile {
                path: path.to_path_buf(),
                message: format!("token {text:?} has the id {id}, far beyond the file's {tokens} tokens"),
            });
        }
        // Ids no token has (holes in some files) stay empty `Unused` tokens: never text, never allowed.
        let mut bytes = vec![Vec::new(); size];
        let mut kinds = vec![TokenKind::Unused; size];
        let char_to_byte = char_to_byte_map();
        for (text, &id) in &model_vocab {
            bytes[id as usize] = byte_level_decode(text, &char_to_byte).ok_or_else(|| LmError::BadTokenizerFile {
                path: path.to_path_buf(),
                message: format!("`model.vocab` token {id} ({text:?}) has a character outside the byte-level alphabet"),
            })?;
            kinds[id as usize] = TokenKind::Normal;
        }
        for (&id, token) in &added {
            bytes[id as usize] = token.content.as_bytes().to_vec();
            kinds[id as usize] = if token.special { TokenKind::Control } else { TokenKind::UserDefined };
        }

        let special_id = |name: &str| inner.token_to_id(name).filter(|&id| kinds[id as usize] == TokenKind::Control);
        let named_id = |name: &str, key: &str| {
            inner.token_to_id(name).ok_or_else(|| LmError::BadTokenizerFile {
                path: config_path.to_path_buf(),
                message: format!("`{key}` {name:?} is not in the vocabulary"),
            })
        };
        let stop: Vec<TokenId> = COMMON_STOP_TOKENS.iter().filter_map(|name| special_id(name)).collect();
        let eos = match config.as_ref().and_then(|c| c.eos_token.as_ref()) {
            Some(name) => named_id(name.content(), "eos_token")?,
            None => *stop.first().ok_or_else(|| LmError::BadTokenizerFile {
                path: path.to_path_buf(),
                message: format!(
                    "no end-of-sequence token: no `eos_token` in a tokenizer_config.json, and none of {COMMON_STOP_TOKENS:?} is a special token"
                ),
            })?,
        };
        let bos = match &config {
            Some(config) => config.bos_token.as_ref().map(|name| named_id(name.content(), "bos_token")).transpose()?,
            None => COMMON_BOS_TOKENS.iter().find_map(|name| special_id(name)),
        };
        let add_bos = match config.as_ref().and_then(|c| c.add_bos_token) {
            Some(add_bos) => add_bos,
            // Ask the post-processor (Llama 3's `TemplateProcessing` puts `<|begin_of_text|>` first).
            None => bos.is_some_and(|bos| inner.encode_fast("", true).is_ok_and(|e| e.get_ids().first() == Some(&bos))),
        };
        let chat_template = config.and_then(|c| c.chat_template).map(|source| ChatTemplate::new(&source)).transpose()?;
        let vocabulary = Vocabulary::new(bytes, kinds, eos, bos, &stop)?;
        Ok(Tokenizer { inner, vocabulary, pre_tokenizer, chat_template, add_bos })
    }

    /// Each token id's bytes and kind, and the special ids.
    pub fn vocabulary(&self) -> &Vocabulary {
        &self.vocabulary
    }

    /// How text is cut into words before BPE.
    pub fn pre_tokenizer(&self) -> PreTokenizer {
        self.pre_tokenizer
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

    /// The chat template, where the GGUF file or `tokenizer_config.json` has one (or one was set).
    pub fn chat_template(&self) -> Option<&ChatTemplate> {
        self.chat_template.as_ref()
    }

    /// Replaces the chat template (for a served model whose template is known otherwise).
    pub fn set_chat_template(&mut self, template: Option<ChatTemplate>) {
        self.chat_template = template;
    }

    /// The prompt text for a system message and a user message, rendered by the model's chat
    /// template with the generation prompt (the assistant's turn) opened, thinking off
    /// (`enable_thinking = false`, which templates without a thinking mode ignore): the paper's
    /// setting for every condition but the thinking ones (Appendix, decoding settings).
    pub fn chat_prompt(&self, system: &str, user: &str) -> Result<String, LmError> {
        let template = self.chat_template.as_ref().ok_or(LmError::NoChatTemplate)?;
        let bos = self.vocabulary.bos().and_then(|id| self.vocabulary.token_bytes(id)).map(|b| String::from_utf8_lossy(b).into_owned());
        let eos = self.vocabulary.token_bytes(self.vocabulary.eos()).map(|b| String::from_utf8_lossy(b).into_owned());
        let mut kwargs = serde_json::Map::new();
        kwargs.insert("enable_thinking".into(), serde_json::Value::Bool(false));
        template.render_with(&[("system", system), ("user", user)], bos.as_deref().unwrap_or(""), eos.as_deref().unwrap_or(""), &kwargs)
    }
}

/// The ids a `tokenizer.json` gives its added tokens (the rest of the file is skipped).
#[derive(Debug, Deserialize)]
struct AddedTokensSection {
    #[serde(default)]
    added_tokens: Vec<DeclaredToken>,
}

#[derive(Debug, Deserialize)]
struct DeclaredToken {
    id: TokenId,
    content: String,
}

/// The fields of a `tokenizer_config.json` this crate reads; the rest is ignored.
#[derive(Debug, Default, Deserialize)]
struct TokenizerConfig {
    #[serde(default)]
    eos_token: Option<SpecialTokenName>,
    #[serde(default)]
    bos_token: Option<SpecialTokenName>,
    #[serde(default)]
    add_bos_token: Option<bool>,
    #[serde(default, deserialize_with = "chat_template_source")]
    chat_template: Option<String>,
}

/// A special token as a config names it: its text, or (older files) an `AddedToken` object.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum SpecialTokenName {
    Text(String),
    Object { content: String },
}

impl SpecialTokenName {
    fn content(&self) -> &str {
        match self {
            SpecialTokenName::Text(text) | SpecialTokenName::Object { content: text } => text,
        }
    }
}

/// `chat_template` is one template, or a list of `{name, template}` of which `default` is used
/// (the first where none is so named).
fn chat_template_source<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Option<String>, D::Error> {
    #[derive(Deserialize)]
    struct Named {
        name: String,
        template: String,
    }
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Source {
        One(String),
        Named(Vec<Named>),
    }
    Ok(match Option::<Source>::deserialize(deserializer)? {
        None => None,
        Some(Source::One(template)) => Some(template),
        Some(Source::Named(mut list)) => {
            let index = list.iter().position(|named| named.name == "default").unwrap_or(0);
            (index < list.len()).then(|| list.swap_remove(index).template)
        }
    })
}

impl TokenizerConfig {
    fn parse(text: &str, path: &Path) -> Result<Self, LmError> {
        serde_json::from_str(text).map_err(|e| json_error(path, &e))
    }
}

/// `path:line:column: message` for a serde error, or the message alone for another.
fn json_error(path: &Path, error: &(dyn std::error::Error + 'static)) -> LmError {
    match error.downcast_ref::<serde_json::Error>() {
        Some(e) => {
            let message = e.to_string();
            let suffix = format!(" at line {} column {}", e.line(), e.column());
            let message = message.strip_suffix(&suffix).unwrap_or(&message).to_string();
            // serde_json says column 0 at the start of a line (an empty file): an editor's is 1.
            LmError::MalformedJson { path: path.to_path_buf(), line: e.line(), column: e.column().max(1), message }
        }
        None => LmError::BadTokenizerFile { path: path.to_path_buf(), message: error.to_string() },
    }
}

/// BPE whose pieces are plain byte-level strings: no byte fallback (`<0x0A>` pieces), no
/// continuing-subword prefix or end-of-word suffix, no dropout (encoding would be random).
fn check_byte_level_bpe(bpe: &BPE) -> Result<(), LmError> {
    let unsupported = |key, value: String, hint| Err(LmError::UnsupportedTokenizer { key, value, hint });
    if bpe.byte_fallback {
        return unsupported("model.byte_fallback", "true".into(), "SentencePiece-style byte fallback is not byte-level BPE");
    }
    if let Some(prefix) = bpe.continuing_subword_prefix.as_ref().filter(|p| !p.is_empty()) {
        return unsupported("model.continuing_subword_prefix", prefix.clone(), "byte-level BPE has no subword prefix");
    }
    if let Some(suffix) = bpe.end_of_word_suffix.as_ref().filter(|s| !s.is_empty()) {
        return unsupported("model.end_of_word_suffix", suffix.clone(), "byte-level BPE has no end-of-word suffix");
    }
    if let Some(dropout) = bpe.dropout.filter(|&p| p > 0.0) {
        return unsupported("model.dropout", dropout.to_string(), "BPE dropout makes encoding random");
    }
    Ok(())
}

/// The first `max` characters of `text`, with `…` where it was cut.
fn abbreviate(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_string(),
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

    #[test]
    fn tokenizer_json_pre_tokenizers_map_to_the_table() {
        use PreTokenizer::*;
        for pre in [Gpt2, DigitsThenGpt2, Llama3, Qwen2] {
            assert_eq!(PreTokenizer::from_tokenizer_json(Some(&pre.build().expect("builds"))), Some(pre), "{pre:?}");
        }
        let split = |regex: &str| -> PreTokenizerWrapper {
            Split::new(SplitPattern::Regex(regex.to_string()), SplitDelimiterBehavior::Isolated, false).expect("compiles").into()
        };
        let then_byte_level = |first: PreTokenizerWrapper, use_regex: bool| {
            Some(Sequence::new(vec![first, ByteLevel::new(false, false, use_regex).into()]).into())
        };
        let cases: [(Option<PreTokenizerWrapper>, Option<PreTokenizer>); 8] = [
            (then_byte_level(split(REGEX_LLAMA3_HF), false), Some(Llama3)),
            (then_byte_level(split(REGEX_QWEN2_HF), false), Some(Qwen2)),
            // A prefix space, GPT-2's regex after the split, digits in runs, another regex, none.
            (Some(ByteLevel::new(true, true, true).into()), None),
            (then_byte_level(split(REGEX_QWEN2_HF), true), None),
            (then_byte_level(Digits::new(false).into(), true), None),
            (then_byte_level(split(r"\s+"), false), None),
            (Some(split(REGEX_QWEN2_HF)), None),
            (None, None),
        ];
        for (section, expected) in cases {
            assert_eq!(PreTokenizer::from_tokenizer_json(section.as_ref()), expected, "{section:?}");
        }
    }
}
