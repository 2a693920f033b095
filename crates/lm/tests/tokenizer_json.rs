//! `Tokenizer::from_tokenizer_json` on the Qwen3 tokenizer the project ships
//! (`fixtures/tokenizers/qwen3/`): ids equal to the `tokenizers` crate's on the same file, token
//! bytes equal to token-constraint's independent reading of it, special tokens and chat prompt
//! from the `tokenizer_config.json` beside it, the uniform backend over it; and typed errors for
//! malformed or unsupported files, on hand-written tokenizer files.

mod common;

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use common::TempDir;
use lm::{BpeParts, LanguageModel, LmError, Logprobs, PreTokenizer, TokenId, TokenKind, Tokenizer, UniformModel};

fn qwen3_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/tokenizers/qwen3")
}

fn qwen3() -> &'static Tokenizer {
    static QWEN3: OnceLock<Tokenizer> = OnceLock::new();
    QWEN3.get_or_init(|| Tokenizer::from_tokenizer_json(&qwen3_dir().join("tokenizer.json")).expect("the Qwen3 tokenizer loads"))
}

/// The `tokenizers` crate reading the same file, as the reference.
fn reference() -> &'static tokenizers::Tokenizer {
    static REFERENCE: OnceLock<tokenizers::Tokenizer> = OnceLock::new();
    REFERENCE.get_or_init(|| tokenizers::Tokenizer::from_file(qwen3_dir().join("tokenizer.json")).expect("the reference loads"))
}

fn reference_ids(text: &str) -> Vec<TokenId> {
    reference().encode(text, false).expect("the reference encodes").get_ids().to_vec()
}

/// A few hundred texts: ALFWorld commands, PDDL, numbers, white space runs, contractions,
/// accented / CJK / emoji text, spelled special tokens.
fn texts() -> Vec<String> {
    let objects = ["apple 1", "mug 2", "soapbottle 3", "butterknife 1", "cd 2", "creditcard 1", "desklamp 1", "peppershaker 12"];
    let receptacles = ["countertop 1", "fridge 1", "cabinet 10", "sinkbasin 1", "microwave 1", "drawer 3", "shelf 2", "garbagecan 1"];
    let mut texts = Vec::new();
    for r in receptacles {
        for verb in ["go to", "open", "close", "examine"] {
            texts.push(format!("{verb} {r}\n"));
        }
    }
    for (i, o) in objects.iter().enumerate() {
        for r in receptacles.iter().skip(i % 3).step_by(2) {
            texts.push(format!("take {o} from {r}\n"));
            texts.push(format!("move {o} to {r}\n"));
            texts.push(format!("> put {o} in/on {r}"));
        }
        for verb in ["heat", "cool", "clean"] {
            texts.push(format!("{verb} {o} with {}\n", receptacles[i]));
        }
        texts.push(format!("use {o}\n"));
        texts.extend(receptacles.iter().map(|r| format!("go to {r}\ntake {o} from {r}\n")));
    }
    texts.extend(["look\n", "inventory\n", "go to countertop 1\ntake apple 1 from countertop 1\n"].map(String::from));
    let pddl = [
        "(define (domain alfred)",
        "  (:requirements :adl :typing)",
        "    :parameters (?a - agent ?l - location ?o - object ?r - receptacle)",
        "    :precondition (and (atLocation ?a ?l) (receptacleAtLocation ?r ?l) (not (opened ?r)))",
        "    :effect (and (holds ?a ?o) (not (inReceptacle ?o ?r)) (increase (total-cost) 1))",
        "(:init (at-robby rooma) (free left) (ball ball1) (= (road-length city-loc-1 city-loc-2) 22))",
        "(gotolocation agent1 loc_bar__minus_7__bar__4__bar__0__bar__45 loc_bar__minus_5__bar__9__bar__3__bar__60)",
        "(pickupobjectinreceptacle agent1 apple_bar__minus_00_dot_47 countertop1)",
        "; a comment\n\t(:goal (and (on b1 b2)))",
    ];
    texts.extend(pddl.iter().map(|s| format!("{s}\n")));
    let mixed = [
        "",
        " ",
        "  ",
        "\n",
        "\n\n",
        " \n",
        "\t\t",
        "   \n\n   x",
        "a  b   c    d",
        "line\r\nbreak\r\n",
        "trailing   ",
        "0",
        "7",
        "42",
        "123",
        "1234567890",
        "3.14159",
        "-17",
        "1,000,000",
        "v1.2.3",
        "0x1F",
        "2024-05-17T12:00:00Z",
        "I'm",
        "you're",
        "we've",
        "they'll",
        "he'd",
        "it's",
        "DON'T",
        "She'S",
        "O'Neil's",
        "'ſ",
        "'ſtraße",
        "'K",
        "'ſ'S",
        "café",
        "naïve résumé",
        "Ångström",
        "e\u{301}",
        "ﬁne",
        "Straße",
        "İstanbul",
        "Ελληνικά",
        "русский текст",
        "日本語のテキスト",
        "中文文本，标点。",
        "한국어",
        "हिन्दी",
        "العربية",
        "🙂🍎",
        "👩‍👩‍👧",
        "𝔘𝔫𝔦𝔠𝔬𝔡𝔢",
        "\u{a0}nbsp",
        "\u{200b}zwsp",
        "fn main() { println!(\"hi\"); }",
        "{\"action\": \"go to\", \"target\": 1}",
        "<html><body>x</body></html>",
        "<|im_start|>user\nMake tea.<|im_end|>\n<|im_start|>assistant\n",
        "<think>\n\n</think>\n\n",
        "<|endoftext|>",
        "<tool_call>{}</tool_call>",
        "a<|im_end|>b",
        "<|im_start|",
        "</s>",
        "<s>",
        "<|unknown|>",
    ];
    texts.extend(mixed.iter().map(|s| s.to_string()));
    texts
}

#[test]
fn the_qwen3_fixture_loads_with_its_special_tokens() {
    let tokenizer = qwen3();
    let vocabulary = tokenizer.vocabulary();
    assert_eq!(vocabulary.len(), 151_669);
    assert_eq!(tokenizer.pre_tokenizer(), PreTokenizer::Qwen2);
    let id = |text: &str| reference().token_to_id(text).expect("in the vocabulary");
    assert_eq!((id("<|endoftext|>"), id("<|im_start|>"), id("<|im_end|>")), (151_643, 151_644, 151_645));
    assert_eq!(vocabulary.eos(), 151_645, "tokenizer_config.json's eos_token, <|im_end|>");
    assert_eq!(vocabulary.stop_tokens(), &[151_645, 151_643]);
    assert_eq!(vocabulary.bos(), None);
    assert_eq!(tokenizer.encode_prompt("hi").expect("encodes"), tokenizer.encode("hi").expect("encodes"), "no BOS");
    assert_eq!(vocabulary.kind(151_644), Some(TokenKind::Control));
    assert_eq!(vocabulary.kind(id("<think>")), Some(TokenKind::UserDefined));
    assert_eq!(vocabulary.kind(id("Ġthe")), Some(TokenKind::Normal));
    assert_eq!(vocabulary.token_bytes(id("Ġthe")), Some(&b" the"[..]));
    assert_eq!(vocabulary.token_bytes(id("Ċ")), Some(&b"\n"[..]));
    assert_eq!(vocabulary.token_bytes(151_667), Some(&b"<think>"[..]));
    // Qwen's ordinary `</s>` piece is text, not an end of sequence.
    assert!(!vocabulary.is_stop(id("</s>")) && !vocabulary.is_special(id("</s>")));
}

#[test]
fn encoding_equals_the_tokenizers_crate_and_decodes_back() {
    let tokenizer = qwen3();
    let texts = texts();
    assert!(texts.len() >= 290, "{} texts", texts.len());
    for text in &texts {
        let ids = tokenizer.encode(text).expect("encodes");
        assert_eq!(ids, reference_ids(text), "{text:?}");
        // Decoding gives the normalized (NFC) text: `e\u{301}` comes back as `é`.
        let decoded = reference().decode(&ids, false).expect("the reference decodes");
        assert_eq!(tokenizer.decode(&ids).expect("in range"), decoded.as_bytes(), "{text:?}");
    }
    let pieces: Vec<String> = tokenizer
        .encode("go to countertop 1\n")
        .expect("encodes")
        .iter()
        .map(|&id| tokenizer.decode_lossy(&[id]).expect("in range"))
        .collect();
    assert_eq!(pieces, ["go", " to", " countert", "op", " ", "1", "\n"]);
}

/// token-constraint builds its byte vocabulary from the same file with its own copy of the
/// byte-level alphabet; every id must spell the same bytes and agree on what is special.
#[test]
fn token_bytes_equal_token_constraints_reading_of_the_file() {
    let (theirs, _) = token_constraint::hf::vocabulary_from_file(&qwen3_dir().join("tokenizer.json")).expect("token-constraint reads it");
    let ours = qwen3().vocabulary();
    assert_eq!(ours.len(), theirs.len());
    for (id, bytes) in ours.iter() {
        assert_eq!(bytes, theirs.token_bytes(id), "token {id}");
        assert_eq!(ours.is_special(id), theirs.is_special(id), "token {id}");
    }
    let mut their_eos = theirs.eos().to_vec();
    let mut our_stop = ours.stop_tokens().to_vec();
    their_eos.sort_unstable();
    our_stop.sort_unstable();
    assert_eq!(our_stop, their_eos);
}

/// The GGUF route (`tokenizer.ggml.pre = qwen2`: llama.cpp's spelling of the regex, NFC, control
/// tokens matched whole) over the same vocabulary and merges gives the same ids.
#[test]
fn the_gguf_route_with_the_qwen2_pre_tokenizer_agrees_on_the_same_vocabulary() {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(qwen3_dir().join("tokenizer.json")).expect("reads")).expect("JSON");
    let merges: Vec<String> = json["model"]["merges"]
        .as_array()
        .expect("merges")
        .iter()
        .map(|m| m.as_array().expect("pair").iter().map(|p| p.as_str().expect("piece")).collect::<Vec<_>>().join(" "))
        .collect();
    let size = reference().get_vocab_size(true);
    let tokens: Vec<String> = (0..size as u32).map(|id| reference().id_to_token(id).expect("no holes")).collect();
    let kinds = qwen3().vocabulary();
    let parts = BpeParts {
        tokens: tokens.iter().map(String::as_str).collect(),
        merges: merges.iter().map(String::as_str).collect(),
        kinds: (0..size as u32).map(|id| kinds.kind(id).expect("in range")).collect(),
        pre_tokenizer: PreTokenizer::Qwen2,
        eos: 151_645,
        bos: None,
        stop: vec![151_643],
        add_bos: false,
        chat_template: None,
    };
    let gguf_route = Tokenizer::from_parts(parts).expect("builds");
    assert_eq!(gguf_route.vocabulary(), qwen3().vocabulary());
    for text in texts() {
        assert_eq!(gguf_route.encode(&text).expect("encodes"), reference_ids(&text), "{text:?}");
    }
}

/// Qwen3's template adds an empty `<think>\n\n</think>\n\n` to the generation prompt only when
/// `enable_thinking` is false. `chat_prompt` renders thinking off (the paper's setting for every
/// condition but the thinking ones); `render` without variables leaves it undefined, so the
/// assistant turn is opened bare (thinking mode, as `transformers` renders it by default), and
/// `render_with` passes a request's `chat_template_kwargs` as a server does.
#[test]
fn the_chat_prompt_is_chatml_with_the_assistant_turn_opened_and_thinking_off() {
    let prompt = qwen3().chat_prompt("You are a household robot.", "Put a clean mug in the coffee machine.").expect("renders");
    let bare = "<|im_start|>system\nYou are a household robot.<|im_end|>\n<|im_start|>user\nPut a clean mug in the coffee machine.<|im_end|>\n<|im_start|>assistant\n";
    assert_eq!(prompt, format!("{bare}<think>\n\n</think>\n\n"));
    let template = qwen3().chat_template().expect("the config has one");
    let pair = [("system", "You are a household robot."), ("user", "Put a clean mug in the coffee machine.")];
    assert_eq!(template.render(&pair, "", "<|im_end|>").expect("renders"), bare);
    let mut on = serde_json::Map::new();
    on.insert("enable_thinking".into(), serde_json::Value::Bool(true));
    assert_eq!(template.render_with(&pair, "", "<|im_end|>", &on).expect("renders"), bare);
    let ids = qwen3().encode(&prompt).expect("encodes");
    assert_eq!(ids.first(), Some(&151_644));
    assert_eq!(ids.iter().filter(|&&id| id == 151_645).count(), 2);

    // The template's history branch (`namespace`, `messages[::-1]`, `.split('</think>')`,
    // `.lstrip('\n')`): an earlier assistant turn loses its reasoning. The expected text is what
    // Python's jinja2 3.1.6 renders, as `transformers` sets it up (trim_blocks, lstrip_blocks).
    let template = qwen3().chat_template().expect("the config has one");
    let messages = [("system", "S"), ("user", "U1"), ("assistant", "<think>\nr\n</think>\n\nA1"), ("user", "U2")];
    assert_eq!(
        template.render(&messages, "", "<|im_end|>").expect("renders"),
        "<|im_start|>system\nS<|im_end|>\n<|im_start|>user\nU1<|im_end|>\n<|im_start|>assistant\nA1<|im_end|>\n<|im_start|>user\nU2<|im_end|>\n<|im_start|>assistant\n"
    );
}

#[test]
fn the_uniform_model_over_qwen3_is_uniform_over_the_allowed_tokens() {
    let tokenizer = Arc::new(qwen3().clone());
    let mut model = UniformModel::new(Arc::clone(&tokenizer));
    let prompt = tokenizer.encode("go to countertop 1\n").expect("encodes");
    let allowed = tokenizer.encode(" take apple fridge").expect("encodes");
    let mut with_repeats = allowed.clone();
    with_repeats.push(allowed[0]);
    with_repeats.push(151_645);
    let prior = model.next_logprobs_among(&prompt, &with_repeats).expect("a prior");
    let mut expected = allowed.clone();
    expected.push(151_645);
    assert_eq!(prior.tokens, expected);
    for &logprob in &prior.logprobs {
        assert!((logprob - -(expected.len() as f32).ln()).abs() < 1e-6, "{logprob}");
    }
    assert_eq!(prior.estimated, 0);
    match model.next_logprobs(&prompt).expect("a distribution") {
        Logprobs::Dense(logprobs) => {
            assert_eq!(logprobs.len(), 151_669);
            assert!(logprobs.iter().all(|&l| (l - -(151_669f32).ln()).abs() < 1e-6));
        }
        other => panic!("expected a dense distribution, got {other:?}"),
    }
    assert!(matches!(model.next_logprobs_among(&prompt, &[151_669]), Err(LmError::TokenOutOfRange { id: 151_669, size: 151_669 })));
}

/// A hand-drawn byte-level BPE: the letters `a b c`, a space (`Ġ`), merges `a b` → `ab` and
/// `Ġ ab` → `Ġab`; added tokens `<|end|>` (special) and `<x>` (not special).
///
/// ```text
/// 0 a   1 b   2 c   3 Ġ   4 ab   5 Ġab   6 <|end|>   7 <x>
/// ```
fn tiny_json(merges: &str, pre_tokenizer: &str, model_type: &str) -> String {
    format!(
        r#"{{
  "version": "1.0",
  "added_tokens": [
    {{"id": 6, "content": "<|end|>", "single_word": false, "lstrip": false, "rstrip": false, "normalized": false, "special": true}},
    {{"id": 7, "content": "<x>", "single_word": false, "lstrip": false, "rstrip": false, "normalized": false, "special": false}}
  ],
  "normalizer": null,
  "pre_tokenizer": {pre_tokenizer},
  "post_processor": null,
  "decoder": {{"type": "ByteLevel", "add_prefix_space": false, "trim_offsets": false, "use_regex": false}},
  "model": {{
    "type": "{model_type}", "dropout": null, "unk_token": null, "continuing_subword_prefix": "", "end_of_word_suffix": "",
    "fuse_unk": false, "byte_fallback": false, "ignore_merges": false,
    "vocab": {{"a": 0, "b": 1, "c": 2, "Ġ": 3, "ab": 4, "Ġab": 5}},
    "merges": {merges}
  }}
}}"#
    )
}

const GPT2_PRE: &str = r#"{"type": "ByteLevel", "add_prefix_space": false, "trim_offsets": true, "use_regex": true}"#;

#[test]
fn a_tiny_tokenizer_reads_both_spellings_of_merges() {
    let string_merges = Tokenizer::from_tokenizer_json_str(&tiny_json(r#"["a b", "Ġ ab"]"#, GPT2_PRE, "BPE"), None).expect("loads");
    let pair_merges = Tokenizer::from_tokenizer_json_str(&tiny_json(r#"[["a", "b"], ["Ġ", "ab"]]"#, GPT2_PRE, "BPE"), None).expect("loads");
    for tokenizer in [&string_merges, &pair_merges] {
        assert_eq!(tokenizer.encode("ab ab c<|end|><x>").expect("encodes"), [4, 5, 3, 2, 6, 7]);
        let vocabulary = tokenizer.vocabulary();
        assert_eq!(vocabulary.len(), 8);
        assert_eq!(vocabulary.token_bytes(5), Some(&b" ab"[..]));
        assert_eq!((vocabulary.kind(6), vocabulary.token_bytes(6)), (Some(TokenKind::Control), Some(&b"<|end|>"[..])));
        assert_eq!(vocabulary.kind(7), Some(TokenKind::UserDefined));
        // No config: the EOS is a special token with a common name; no BOS.
        assert_eq!((vocabulary.eos(), vocabulary.bos()), (6, None));
        assert_eq!(tokenizer.pre_tokenizer(), PreTokenizer::Gpt2);
        assert!(matches!(tokenizer.chat_prompt("s", "u"), Err(LmError::NoChatTemplate)));
    }
    assert_eq!(string_merges.vocabulary(), pair_merges.vocabulary());
}

#[test]
fn a_config_gives_eos_bos_and_the_chat_template() {
    let config = r#"{"eos_token": {"content": "<x>", "lstrip": false}, "bos_token": "a", "add_bos_token": true,
        "chat_template": [{"name": "tool_use", "template": "no"}, {"name": "default", "template": "{{ bos_token }}{% for m in messages %}[{{ m.content }}]{% endfor %}"}]}"#;
    let tokenizer = Tokenizer::from_tokenizer_json_str(&tiny_json(r#"["a b"]"#, GPT2_PRE, "BPE"), Some(config)).expect("loads");
    assert_eq!((tokenizer.vocabulary().eos(), tokenizer.vocabulary().bos()), (7, Some(0)));
    assert_eq!(tokenizer.vocabulary().stop_tokens(), &[7, 6]);
    assert_eq!(tokenizer.encode_prompt("b").expect("encodes"), [0, 1]);
    assert_eq!(tokenizer.chat_prompt("s", "u").expect("renders"), "a[s][u]");

    let missing = Tokenizer::from_tokenizer_json_str(&tiny_json("[]", GPT2_PRE, "BPE"), Some(r#"{"eos_token": "<nope>"}"#));
    let error = missing.expect_err("an EOS outside the vocabulary");
    assert!(matches!(&error, LmError::BadTokenizerFile { .. }), "{error}");
    assert_eq!(error.to_string(), r#"tokenizer_config.json: `eos_token` "<nope>" is not in the vocabulary"#);
}

/// The `tokenizers` crate renumbers added tokens that do not follow the vocabulary; the file's
/// ids are the model's, so that is an error. A hole in the vocabulary itself is an empty
/// `Unused` token.
#[test]
fn ids_that_the_tokenizers_crate_would_renumber_are_an_error_and_holes_are_unused() {
    let gap = tiny_json(r#"["a b"]"#, GPT2_PRE, "BPE").replace(r#""id": 6"#, r#""id": 8"#).replace(r#""id": 7"#, r#""id": 9"#);
    let error = Tokenizer::from_tokenizer_json_str(&gap, None).expect_err("renumbered");
    assert_eq!(
        error.to_string(),
        r#"tokenizer.json: `added_tokens` gives "<|end|>" the id 8, but it is numbered 6 (added tokens must follow the vocabulary without gaps)"#
    );

    let hole = tiny_json(r#"["a b", "Ġ ab"]"#, GPT2_PRE, "BPE").replace(r#""Ġab": 5"#, r#""Ġab": 6"#);
    let (start, end) = (hole.find(r#""added_tokens": ["#).expect("added tokens"), hole.find(r#""normalizer""#).expect("normalizer"));
    let hole = format!("{}\"added_tokens\": [],\n  {}", &hole[..start], &hole[end..]);
    let tokenizer = Tokenizer::from_tokenizer_json_str(&hole, Some(r#"{"eos_token": "c"}"#)).expect("loads");
    let vocabulary = tokenizer.vocabulary();
    assert_eq!(vocabulary.len(), 7);
    assert_eq!((vocabulary.kind(5), vocabulary.token_bytes(5)), (Some(TokenKind::Unused), Some(&b""[..])));
    assert_eq!((vocabulary.eos(), vocabulary.stop_tokens()), (2, &[2][..]));
    assert_eq!(tokenizer.encode("ab ab").expect("encodes"), [4, 6]);
    assert_eq!(tokenizer.decode(&[4, 6]).expect("in range"), b"ab ab");

    // One absurd id is an error naming the token, not tables for four billion tokens.
    let absurd = hole.replace(r#""Ġab": 6"#, r#""Ġab": 4000000000"#);
    let error = Tokenizer::from_tokenizer_json_str(&absurd, Some(r#"{"eos_token": "c"}"#)).expect_err("absurd id");
    assert!(matches!(&error, LmError::BadTokenizerFile { .. }), "{error}");
    assert!(error.to_string().contains("4000000000") && error.to_string().contains(r#""Ġab""#), "{error}");
}

#[test]
fn malformed_json_names_the_file_and_the_line_and_column() {
    let dir = TempDir::new("tokenizer-json-malformed");
    let path = dir.file("tokenizer.json");
    std::fs::write(&path, "{\n  \"version\": \"1.0\",\n  \"model\": {\"type\": \"BPE\",,}\n}\n").expect("write");
    let error = Tokenizer::from_tokenizer_json(&path).expect_err("malformed");
    let LmError::MalformedJson { path: error_path, line, column, .. } = &error else { panic!("{error:?}") };
    assert_eq!((error_path, *line, *column), (&path, 3, 27));
    assert_eq!(error.to_string(), format!("{}:3:27: key must be a string", path.display()));

    // A good tokenizer.json beside a malformed config: the config is named.
    std::fs::write(&path, tiny_json(r#"["a b"]"#, GPT2_PRE, "BPE")).expect("write");
    std::fs::write(dir.file("tokenizer_config.json"), "{\"eos_token\": 3").expect("write");
    let error = Tokenizer::from_tokenizer_json(&path).expect_err("malformed config");
    assert!(matches!(&error, LmError::MalformedJson { path, line: 1, .. } if path.ends_with("tokenizer_config.json")), "{error}");

    let absent = dir.file("absent.json");
    assert!(matches!(Tokenizer::from_tokenizer_json(&absent), Err(LmError::Io { path, .. }) if path == absent));
}

#[test]
fn unsupported_tokenizers_are_typed_errors_naming_the_field() {
    let check = |json: String, expected_key: &str| {
        let error = Tokenizer::from_tokenizer_json_str(&json, None).expect_err("unsupported");
        assert!(matches!(&error, LmError::UnsupportedTokenizer { key, .. } if *key == expected_key), "{error}");
    };
    let whitespace = r#"{"type": "Whitespace"}"#;
    check(tiny_json(r#"["a b"]"#, whitespace, "BPE"), "pre_tokenizer");
    let other_regex = r#"{"type": "Sequence", "pretokenizers": [
        {"type": "Split", "pattern": {"Regex": "\\s+"}, "behavior": "Isolated", "invert": false},
        {"type": "ByteLevel", "add_prefix_space": false, "trim_offsets": false, "use_regex": false}]}"#;
    check(tiny_json(r#"["a b"]"#, other_regex, "BPE"), "pre_tokenizer");
    check(tiny_json(r#"["a b"]"#, "null", "BPE"), "pre_tokenizer");
    check(tiny_json(r#"["a b"]"#, GPT2_PRE, "BPE").replace(r#""byte_fallback": false"#, r#""byte_fallback": true"#), "model.byte_fallback");
    let word_level = r#"{"version": "1.0", "added_tokens": [], "normalizer": null, "pre_tokenizer": null, "post_processor": null,
        "decoder": null, "model": {"type": "WordLevel", "vocab": {"a": 0, "<unk>": 1}, "unk_token": "<unk>"}}"#;
    check(word_level.to_string(), "model.type");
}
