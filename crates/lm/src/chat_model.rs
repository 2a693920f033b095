//! [`LocalChat`]: a [`LocalModel`] behind `vlm-client`'s chat interface, for text observations
//! (Phase I on the default model, with no server). The messages go through the model's chat
//! template; a reply with a JSON schema is decoded under that schema by llguidance, which masks
//! every step to the tokens that keep the text a prefix of a schema-valid JSON value, so even
//! SmolLM2-135M answers with valid JSON and one of the listed options.
//!
//! Decoding is greedy at temperature 0 (or unset), else sampled with the request's seed,
//! top-k and top-p, over the tokens the mask allows. The JSON is written compactly
//! (`{"a": 1, "b": 2}`, no free white space: llguidance's `whitespace_flexible` off unless the
//! schema's own `x-guidance` says otherwise), so that a small model cannot pad forever.

use std::sync::Arc;
use std::time::Instant;

use llguidance::api::TopLevelGrammar;
use llguidance::toktrie::{ApproximateTokEnv, TokEnv, TokRxInfo, TokTrie};
use llguidance::{Matcher, ParserFactory};
use serde_json::{Value, json};
use vlm_client::{ChatError, ChatErrorKind, ChatModel, ChatReply, ChatRequest, JsonMode, Usage};

use crate::error::LmError;
use crate::local::LocalModel;
use crate::model::LanguageModel;
use crate::vocabulary::TokenId;

/// Reply length when the request sets no `max_tokens`.
const DEFAULT_MAX_TOKENS: u32 = 256;

/// A local model as a chat model (text only).
pub struct LocalChat {
    model: LocalModel,
    factory: ParserFactory,
    name: String,
    usage: Usage,
    /// Append a token the schema forces without running the model (see [`LocalChat::set_fast_forward`]).
    fast_forward: bool,
}

impl std::fmt::Debug for LocalChat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocalChat").field("name", &self.name).field("usage", &self.usage).finish_non_exhaustive()
    }
}

impl LocalChat {
    /// Wraps `model` (which must have a chat template); `name` shows in errors (`local:NAME`).
    pub fn new(model: LocalModel, name: &str) -> Result<LocalChat, LmError> {
        if model.tokenizer().chat_template().is_none() {
            return Err(LmError::NoChatTemplate);
        }
        let vocabulary = model.vocabulary();
        // llguidance's token trie: control tokens carry its marker byte, so that no text spells them.
        let words: Vec<Vec<u8>> = vocabulary
            .iter()
            .map(
                |(id, bytes)| {
                    if vocabulary.is_special(id) { [&[TokTrie::SPECIAL_TOKEN_MARKER][..], bytes].concat() } else { bytes.to_vec() }
                },
            )
            .collect();
        let trie = TokTrie::from(&TokRxInfo::new(words.len() as u32, vocabulary.eos()), &words);
        let environment: TokEnv = Arc::new(ApproximateTokEnv::new(trie));
        let mut factory = ParserFactory::new_simple(&environment).map_err(|e| LmError::Tokenizer(format!("llguidance: {e}")))?;
        factory.quiet();
        Ok(LocalChat { model, factory, name: name.to_string(), usage: Usage::default(), fast_forward: true })
    }

    /// The model that answers (its prefix cache and usage counters included).
    pub fn model(&self) -> &LocalModel {
        &self.model
    }

    /// Whether a token the JSON schema forces (the mask allows that one token only) is appended
    /// without a forward pass; the next step that has a choice prefills the forced tokens in one
    /// batch, and a reply that ends in forced tokens never runs the model for them. The reply is
    /// the same either way (a single allowed token is chosen whatever its logit, greedy or
    /// sampled); only the time differs. On by default; off, every token runs the model.
    pub fn set_fast_forward(&mut self, on: bool) {
        self.fast_forward = on;
    }

    /// The prompt's token ids: the messages through the chat template, the assistant's turn open.
    fn prompt(&self, request: &ChatRequest) -> Result<Vec<TokenId>, ChatErrorKind> {
        let tokenizer = self.model.tokenizer();
        let template = tokenizer.chat_template().ok_or_else(|| ChatErrorKind::Model(LmError::NoChatTemplate.to_string()))?;
        let vocabulary = tokenizer.vocabulary();
        let spelled = |id: Option<TokenId>| {
            id.and_then(|id| vocabulary.token_bytes(id)).map(|b| String::from_utf8_lossy(b).into_owned()).unwrap_or_default()
        };
        let texts: Vec<(&str, String)> = request.messages.iter().map(|m| (m.role.as_str(), m.joined_text())).collect();
        let pairs: Vec<(&str, &str)> = texts.iter().map(|(role, text)| (*role, text.as_str())).collect();
        // The request's `chat_template_kwargs` reach the template, as a server passes them.
        let kwargs = request.chat_template_kwargs.clone().unwrap_or_default();
        let text = template
            .render_with(&pairs, &spelled(vocabulary.bos()), &spelled(Some(vocabulary.eos())), &kwargs)
            .map_err(|e| ChatErrorKind::Model(e.to_string()))?;
        tokenizer.encode_prompt(&text).map_err(|e| ChatErrorKind::Model(e.to_string()))
    }

    /// A matcher for `schema`, compact unless the schema asks otherwise.
    fn matcher(&self, schema: &Value) -> Result<Matcher, ChatErrorKind> {
        let mut schema = schema.clone();
        if let Some(object) = schema.as_object_mut()
            && !object.contains_key("x-guidance")
        {
            object.insert("x-guidance".into(), json!({ "whitespace_flexible": false, "item_separator": ", ", "key_separator": ": " }));
        }
        let matcher = Matcher::new(self.factory.create_parser(TopLevelGrammar::from_json_schema(schema)));
        match matcher.get_error() {
            Some(e) => Err(ChatErrorKind::BadInput(format!("llguidance cannot use the JSON schema: {e}"))),
            None => Ok(matcher),
        }
    }
}

fn llg_error(error: impl std::fmt::Display) -> ChatErrorKind {
    ChatErrorKind::Model(format!("llguidance: {error}"))
}

/// splitmix64: the sampler's random numbers, from the request's seed.
#[derive(Debug)]
struct Random(u64);

impl Random {
    fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        x ^= x >> 31;
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The next token among `candidates` (token, logit): the likeliest at temperature 0, else a
/// draw from the tempered softmax cut to the top `top_k` and the nucleus `top_p`.
fn choose(
    mut candidates: Vec<(TokenId, f32)>,
    temperature: f64,
    top_k: Option<u32>,
    top_p: Option<f64>,
    random: &mut Random,
) -> Option<TokenId> {
    candidates.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    if temperature <= 0.0 || candidates.len() <= 1 {
        return candidates.first().map(|c| c.0);
    }
    if let Some(k) = top_k.filter(|&k| k > 0) {
        candidates.truncate(k as usize);
    }
    let best = f64::from(candidates.first()?.1);
    let weights: Vec<f64> = candidates.iter().map(|c| ((f64::from(c.1) - best) / temperature).exp()).collect();
    let total: f64 = weights.iter().sum();
    let mut kept = weights.len();
    if let Some(p) = top_p.filter(|&p| p < 1.0) {
        let mut mass = 0.0;
        kept = weights
            .iter()
            .position(|w| {
                mass += w / total;
                mass >= p
            })
            .map_or(weights.len(), |i| i + 1);
    }
    let kept_total: f64 = weights[..kept].iter().sum();
    let mut draw = random.next_unit() * kept_total;
    for (candidate, weight) in candidates.iter().zip(&weights[..kept]) {
        draw -= weight;
        if draw < 0.0 {
            return Some(candidate.0);
        }
    }
    candidates.get(kept - 1).map(|c| c.0)
}

impl LocalChat {
    /// One reply, errors as their kind (`chat` adds where, attempts and time).
    fn reply(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatErrorKind> {
        let images = request.image_count();
        if images > 0 {
            return Err(ChatErrorKind::BadInput(format!("{} reads text only; the request has {images} image(s)", self.endpoint())));
        }
        let prompt = self.prompt(request)?;
        let mut matcher = request.json_schema.as_ref().map(|schema| self.matcher(schema)).transpose()?;
        let sampling = &request.sampling;
        let temperature = sampling.temperature.unwrap_or(0.0);
        let mut random = Random(sampling.seed.unwrap_or(0));
        // No further than the model's context: the reply ends there, `length`, as a server's
        // does (the thinking condition asks for 32,768 tokens; SmolLM2's context holds 8,192).
        let context = self.model.weights().config().context_length;
        if prompt.len() >= context {
            return Err(ChatErrorKind::BadInput(format!(
                "the prompt is {} tokens; {} holds {context}, with room for a reply",
                prompt.len(),
                self.endpoint()
            )));
        }
        let max_tokens = (sampling.max_tokens.unwrap_or(DEFAULT_MAX_TOKENS) as usize).min(context.saturating_sub(prompt.len()));
        let vocabulary_size = self.model.vocabulary().len();
        let model_error = |e: LmError| ChatErrorKind::Model(e.to_string());
        let mut sequence = prompt.clone();
        let mut generated: Vec<TokenId> = Vec::new();
        let mut finish = "length";
        while generated.len() < max_tokens {
            if matcher.as_ref().is_some_and(Matcher::is_stopped) {
                finish = "stop";
                break;
            }
            let mask = matcher.as_mut().map(Matcher::compute_mask).transpose().map_err(llg_error)?;
            let forced = mask
                .as_ref()
                .filter(|m| self.fast_forward && m.num_set() == 1)
                .and_then(|m| m.first_bit_set())
                .and_then(|id| TokenId::try_from(id).ok())
                .filter(|&id| (id as usize) < vocabulary_size);
            let next = match forced {
                Some(id) => id,
                None => {
                    let logits = self.model.next_logits(&sequence).map_err(model_error)?;
                    let candidates: Vec<(TokenId, f32)> = logits[..vocabulary_size.min(logits.len())]
                        .iter()
                        .enumerate()
                        .map(|(id, &logit)| (id as TokenId, logit))
                        .filter(|&(id, _)| mask.as_ref().is_none_or(|m| m.is_allowed(id)))
                        .collect();
                    choose(candidates, temperature, sampling.top_k, sampling.top_p, &mut random)
                        .ok_or_else(|| ChatErrorKind::Model("the JSON schema allows no token here".into()))?
                }
            };
            let vocabulary = self.model.vocabulary();
            if vocabulary.is_stop(next) || next == vocabulary.eos() {
                finish = "stop";
                break;
            }
            if let Some(m) = matcher.as_mut() {
                m.consume_token(next).map_err(llg_error)?;
            }
            generated.push(next);
            sequence.push(next);
        }
        let text = self.model.tokenizer().decode_lossy(&generated).map_err(model_error)?;
        let usage = Usage {
            requests: 1,
            prompt_tokens: prompt.len() as u64,
            completion_tokens: generated.len() as u64,
            reasoning_tokens: None,
            images: 0,
        };
        self.usage.add(&usage);
        Ok(ChatReply {
            text,
            reasoning: None,
            finish_reason: Some(finish.to_string()),
            usage,
            json_mode: request.json_schema.as_ref().map(|_| JsonMode::Schema),
            attempts: 1,
            waited: std::time::Duration::ZERO,
            cached: false,
        })
    }
}

impl ChatModel for LocalChat {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let start = Instant::now();
        self.reply(request).map_err(|kind| ChatError { kind, url: self.endpoint(), attempts: 1, elapsed: start.elapsed() })
    }

    fn endpoint(&self) -> String {
        format!("local:{}", self.name)
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn greedy_takes_the_likeliest_and_sampling_follows_the_seed() {
        let candidates = vec![(3, 0.5), (7, 2.0), (9, 1.0)];
        let mut random = Random(1);
        assert_eq!(choose(candidates.clone(), 0.0, None, None, &mut random), Some(7));
        assert_eq!(choose(Vec::new(), 1.0, None, None, &mut random), None);
        // top_k = 1 is greedy at any temperature.
        assert_eq!(choose(candidates.clone(), 5.0, Some(1), None, &mut random), Some(7));
        // A tiny nucleus keeps only the likeliest.
        assert_eq!(choose(candidates.clone(), 1.0, None, Some(0.1), &mut random), Some(7));
        let draws = |seed| {
            let mut random = Random(seed);
            (0..50).map(|_| choose(candidates.clone(), 1.0, None, None, &mut random).unwrap()).collect::<Vec<_>>()
        };
        assert_eq!(draws(4), draws(4), "same seed, same draws");
        let seen = draws(4);
        assert!([3, 7, 9].iter().all(|t| seen.contains(t)), "every candidate is drawn at temperature 1: {seen:?}");
    }
}
