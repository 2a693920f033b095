//! JSON replies: the first JSON object in a reply's text, checked against a JSON schema (the
//! keywords reply formats and servers' schema-constrained decoding use: `type`, `enum`,
//! `const`, `properties`, `patternProperties`, `required`, `additionalProperties`,
//! `minProperties`/`maxProperties`, `items`, `prefixItems`, `contains`, `minItems`/`maxItems`,
//! `uniqueItems`, `minLength`/`maxLength`, `pattern`, `minimum`/`maximum`,
//! `exclusiveMinimum`/`exclusiveMaximum`, `multipleOf`, `anyOf`/`oneOf`/`allOf`/`not`, and
//! `$ref` within the schema; other keywords, `format` among them, are annotations here), and
//! [`chat_json`]: one request, and at most one repair turn that quotes what was wrong.

use serde_json::{Map, Value};

use crate::client::ChatModel;
use crate::error::{ChatError, ChatErrorKind};
use crate::message::Message;
use crate::reply::{ChatReply, Usage};
use crate::request::ChatRequest;

/// A JSON reply that satisfies the schema.
#[derive(Debug, Clone, PartialEq)]
pub struct JsonReply {
    /// The first JSON object of the reply's text, which satisfies the schema.
    pub value: Value,
    /// The reply the value was read from.
    pub reply: ChatReply,
    /// Summed over both turns when a repair turn was needed.
    pub usage: Usage,
    /// Whether the value came from the repair turn.
    pub repaired: bool,
}

/// Asks `model` for a JSON object satisfying `request.json_schema` (any object when it has
/// none). When the reply holds none, one repair turn shows the model its reply and the error;
/// a second failure is [`ChatErrorKind::InvalidJson`].
pub fn chat_json(model: &mut dyn ChatModel, request: &ChatRequest) -> Result<JsonReply, ChatError> {
    let schema = request.json_schema.clone().unwrap_or_else(|| serde_json::json!({ "type": "object" }));
    check_schema(&schema).map_err(|e| ChatError {
        kind: ChatErrorKind::BadInput(e),
        url: model.endpoint(),
        attempts: 0,
        elapsed: Default::default(),
    })?;
    let started = std::time::Instant::now();
    let first = model.chat(request)?;
    let mut usage = first.usage;
    let error = match read_json(&first.text, &schema) {
        Ok(value) => return Ok(JsonReply { value, reply: first, usage, repaired: false }),
        Err(error) => error,
    };
    let mut repair = request.clone();
    repair.messages.push(Message::assistant(first.text.clone()));
    repair.messages.push(Message::user(format!(
        "Your reply could not be used: {error}. Reply again with only one JSON object that satisfies this JSON schema, and nothing else:\n{schema}"
    )));
    let second = model.chat(&repair)?;
    usage.add(&second.usage);
    match read_json(&second.text, &schema) {
        Ok(value) => Ok(JsonReply { value, reply: second, usage, repaired: true }),
        Err(error) => Err(ChatError {
            kind: ChatErrorKind::InvalidJson { error, reply: second.text.chars().take(500).collect() },
            url: model.endpoint(),
            attempts: first.attempts + second.attempts,
            elapsed: started.elapsed(),
        }),
    }
}

/// The first JSON object in `text` (prose, code fences and all around it), checked against
/// `schema`; the error says what is wrong, for the repair turn.
pub fn read_json(text: &str, schema: &Value) -> Result<Value, String> {
    let value = first_object(text)?;
    validate(&value, schema, "$")?;
    Ok(value)
}

/// The first `{` in `text` that starts a complete JSON object, parsed.
pub fn first_object(text: &str) -> Result<Value, String> {
    let mut first_error = None;
    for (start, _) in text.match_indices('{') {
        let mut values = serde_json::Deserializer::from_str(&text[start..]).into_iter::<Value>();
        match values.next() {
            Some(Ok(value @ Value::Object(_))) => return Ok(value),
            Some(Err(e)) if first_error.is_none() => first_error = Some(format!("invalid JSON at byte {start}: {e}")),
            _ => {}
        }
    }
    Err(first_error.unwrap_or_else(|| "no JSON object in the reply".to_string()))
}

const TYPES: [&str; 7] = ["object", "array", "string", "number", "integer", "boolean", "null"];

/// Checks that `schema` is a JSON schema this module can apply: an object (or `true`/`false`)
/// whose keywords have the right shapes, recursively; its root allows an object (the reply is
/// read as one, [`first_object`]); every `$ref` points within it (`#/...`) at something there,
/// and no chain of references comes back to where it started without a value in between (it
/// would never end); every `pattern` is a regular expression.
pub fn check_schema(schema: &Value) -> Result<(), String> {
    let mut references = Vec::new();
    check_schema_at(schema, "#", schema, &mut references)?;
    let mut acyclic = std::collections::BTreeSet::new();
    for (at, pointer) in references {
        check_no_reference_cycle(&pointer, schema, &mut vec![at], &mut acyclic)?;
    }
    if let Some(kind) = schema.get("type") {
        let names: Vec<&Value> = match kind {
            Value::Array(names) => names.iter().collect(),
            single => vec![single],
        };
        if !names.iter().any(|n| n.as_str() == Some("object")) {
            return Err(format!("#/type: {kind}, but the reply is read as a JSON object: the root must allow \"object\""));
        }
    }
    Ok(())
}

/// The keywords whose value is one schema, applied to the same value or (`items`, ...) to parts of it.
const SUBSCHEMA: [&str; 4] = ["items", "additionalProperties", "not", "contains"];
/// The keywords whose value is a non-empty array of schemas.
const SUBSCHEMAS: [&str; 4] = ["anyOf", "oneOf", "allOf", "prefixItems"];
/// The keywords whose value is an object of schemas.
const SCHEMA_MAPS: [&str; 4] = ["$defs", "definitions", "properties", "patternProperties"];

/// Checks one schema and those inside it; collects where each `$ref` is and where it points.
fn check_schema_at(schema: &Value, at: &str, root: &Value, references: &mut Vec<(String, String)>) -> Result<(), String> {
    let object = match schema {
        Value::Bool(_) => return Ok(()),
        Value::Object(object) => object,
        other => return Err(format!("{at}: a schema must be an object or a boolean, found {other}")),
    };
    if let Some(reference) = object.get("$ref") {
        let target = reference.as_str().and_then(|r| r.strip_prefix('#'));
        match target {
            Some(pointer) if root.pointer(pointer).is_some() => references.push((at.to_string(), pointer.to_string())),
            Some(_) => return Err(format!("{at}/$ref: {reference} points at nothing in the schema")),
            None => return Err(format!("{at}/$ref: {reference}: only references within the schema (\"#/...\") are accepted")),
        }
    }
    for key in SCHEMA_MAPS {
        if let Some(subs) = object.get(key) {
            let subs = subs.as_object().ok_or_else(|| format!("{at}/{key}: expected an object"))?;
            for (name, sub) in subs {
                if key == "patternProperties" {
                    regex(name).map_err(|e| format!("{at}/{key}: {name:?} is not a regular expression: {e}"))?;
                }
                check_schema_at(sub, &format!("{at}/{key}/{}", escape_pointer(name)), root, references)?;
            }
        }
    }
    if let Some(kind) = object.get("type") {
        let names: Vec<&Value> = match kind {
            Value::Array(names) => names.iter().collect(),
            single => vec![single],
        };
        for name in names {
            if !name.as_str().is_some_and(|n| TYPES.contains(&n)) {
                return Err(format!("{at}/type: unknown type {name} (expected one of {})", TYPES.join(", ")));
            }
        }
    }
    if let Some(required) = object.get("required")
        && !required.as_array().is_some_and(|r| r.iter().all(Value::is_string))
    {
        return Err(format!("{at}/required: expected an array of property names"));
    }
    if let Some(values) = object.get("enum")
        && !values.is_array()
    {
        return Err(format!("{at}/enum: expected an array"));
    }
    for key in SUBSCHEMA {
        if let Some(sub) = object.get(key) {
            check_schema_at(sub, &format!("{at}/{key}"), root, references)?;
        }
    }
    for key in SUBSCHEMAS {
        if let Some(subs) = object.get(key) {
            let subs = subs.as_array().filter(|s| !s.is_empty()).ok_or_else(|| format!("{at}/{key}: expected a non-empty array"))?;
            for (i, sub) in subs.iter().enumerate() {
                check_schema_at(sub, &format!("{at}/{key}/{i}"), root, references)?;
            }
        }
    }
    for key in ["minItems", "maxItems", "minLength", "maxLength", "minProperties", "maxProperties"] {
        if object.get(key).is_some_and(|v| v.as_u64().is_none()) {
            return Err(format!("{at}/{key}: expected a non-negative integer"));
        }
    }
    for key in ["minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"] {
        if object.get(key).is_some_and(|v| !v.is_number()) {
            return Err(format!("{at}/{key}: expected a number"));
        }
    }
    if object.get("multipleOf").is_some_and(|v| !v.as_f64().is_some_and(|m| m > 0.0)) {
        return Err(format!("{at}/multipleOf: expected a number above 0"));
    }
    if object.get("uniqueItems").is_some_and(|v| !v.is_boolean()) {
        return Err(format!("{at}/uniqueItems: expected true or false"));
    }
    if let Some(pattern) = object.get("pattern") {
        let text = pattern.as_str().ok_or_else(|| format!("{at}/pattern: expected a string"))?;
        regex(text).map_err(|e| format!("{at}/pattern: {pattern} is not a regular expression: {e}"))?;
    }
    Ok(())
}

/// Refuses a chain of references that comes back to a schema on it without a value in between:
/// the schema at `pointer` and the schemas it applies to the same value (`$ref`, `allOf`,
/// `anyOf`, `oneOf`, `not`), followed until each ends. `chain` holds where the chain came from;
/// `acyclic`, the targets already followed to their ends (a depth-first search: a target from
/// which no chain comes back cannot lie on a cycle found later).
fn check_no_reference_cycle(
    pointer: &str,
    root: &Value,
    chain: &mut Vec<String>,
    acyclic: &mut std::collections::BTreeSet<String>,
) -> Result<(), String> {
    if acyclic.contains(pointer) {
        return Ok(());
    }
    let here = format!("#{pointer}");
    if let Some(start) = chain.iter().position(|p| *p == here) {
        let cycle: Vec<&str> = chain[start..].iter().map(String::as_str).collect();
        return Err(format!(
            "{}/$ref: the references {} -> {here} come back without a value in between",
            chain[chain.len() - 1],
            cycle.join(" -> ")
        ));
    }
    chain.push(here);
    let mut same_value = vec![(pointer.to_string(), root.pointer(pointer))];
    while let Some((at, schema)) = same_value.pop() {
        let Some(object) = schema.and_then(Value::as_object) else { continue };
        if let Some(next) = object.get("$ref").and_then(Value::as_str).and_then(|r| r.strip_prefix('#'))
            && root.pointer(next).is_some()
        {
            let depth = chain.len();
            if at != pointer {
                chain.push(format!("#{at}"));
            }
            check_no_reference_cycle(next, root, chain, acyclic)?;
            chain.truncate(depth);
        }
        for key in ["allOf", "anyOf", "oneOf"] {
            for (i, sub) in object.get(key).and_then(Value::as_array).into_iter().flatten().enumerate() {
                same_value.push((format!("{at}/{key}/{i}"), Some(sub)));
            }
        }
        if let Some(sub) = object.get("not") {
            same_value.push((format!("{at}/not"), Some(sub)));
        }
    }
    chain.pop();
    acyclic.insert(pointer.to_string());
    Ok(())
}

/// A JSON pointer's token for a property name (RFC 6901: `~` and `/` escaped).
fn escape_pointer(name: &str) -> String {
    name.replace('~', "~0").replace('/', "~1")
}

/// A schema's `pattern`, compiled. Written for ECMA-262 regular expressions, which `fancy-regex`
/// (already in the tree through `tokenizers`) reads with their lookaround and backreferences;
/// a pattern matches anywhere in the string unless it anchors itself, as JSON Schema has it.
fn regex(pattern: &str) -> Result<fancy_regex::Regex, String> {
    fancy_regex::Regex::new(pattern).map_err(|e| e.to_string())
}

fn type_matches(value: &Value, name: &str) -> bool {
    match name {
        "object" => value.is_object(),
        "array" => value.is_array(),
        "string" => value.is_string(),
        "number" => value.is_number(),
        "integer" => value.as_i64().is_some() || value.as_u64().is_some() || value.as_f64().is_some_and(|f| f.fract() == 0.0),
        "boolean" => value.is_boolean(),
        "null" => value.is_null(),
        _ => false,
    }
}

/// Checks `value` against `schema`; the error names the place (`$.skill`) and the rule.
/// References (`$ref`, within `schema`) are followed; a schema [`check_schema`] refuses may
/// give an error here instead of an answer.
///
/// Written here rather than taken from a JSON Schema crate: the messages are the repair turn's
/// words to the model (`$.skill: "Fly" is not one of ...`), recorded in episodes, and the
/// keywords are the ones reply formats and servers' schema-constrained decoding use.
pub fn validate(value: &Value, schema: &Value, at: &str) -> Result<(), String> {
    Validator { root: schema }.check(value, schema, at, 0)
}

/// References followed in a row without a value in between, past which a schema that
/// [`check_schema`] did not see is taken to loop.
const MAX_REFERENCE_CHAIN: usize = 64;

struct Validator<'a> {
    root: &'a Value,
}

impl Validator<'_> {
    /// `chain`: references followed since the last step into a part of the value.
    fn check(&self, value: &Value, schema: &Value, at: &str, chain: usize) -> Result<(), String> {
        let object = match schema {
            Value::Bool(true) => return Ok(()),
            Value::Bool(false) => return Err(format!("{at}: no value is allowed here")),
            Value::Object(object) => object,
            _ => return Err(format!("{at}: the schema is not an object")),
        };
        if let Some(reference) = object.get("$ref") {
            let target = reference.as_str().and_then(|r| r.strip_prefix('#')).and_then(|p| self.root.pointer(p));
            match target {
                _ if chain >= MAX_REFERENCE_CHAIN => return Err(format!("{at}: the schema's references loop at {reference}")),
                Some(target) => self.check(value, target, at, chain + 1)?,
                None => return Err(format!("{at}: the schema's {reference} points at nothing in it")),
            }
        }
        if let Some(kind) = object.get("type") {
            let names: Vec<&str> = match kind {
                Value::Array(names) => names.iter().filter_map(Value::as_str).collect(),
                single => single.as_str().into_iter().collect(),
            };
            if !names.iter().any(|n| type_matches(value, n)) {
                return Err(format!("{at}: expected {}, found {value}", names.join(" or ")));
            }
        }
        if let Some(values) = object.get("enum").and_then(Value::as_array)
            && !values.contains(value)
        {
            let listed: Vec<String> = values.iter().map(Value::to_string).collect();
            return Err(format!("{at}: {value} is not one of {}", listed.join(", ")));
        }
        if let Some(expected) = object.get("const")
            && expected != value
        {
            return Err(format!("{at}: expected {expected}, found {value}"));
        }
        match value {
            Value::Object(map) => self.check_object(map, object, at)?,
            Value::Array(items) => self.check_array(items, object, at)?,
            Value::String(text) => {
                let length = text.chars().count() as u64;
                if object.get("minLength").and_then(Value::as_u64).is_some_and(|n| length < n) {
                    return Err(format!("{at}: string shorter than minLength"));
                }
                if object.get("maxLength").and_then(Value::as_u64).is_some_and(|n| length > n) {
                    return Err(format!("{at}: string longer than maxLength"));
                }
                if let Some(pattern) = object.get("pattern").and_then(Value::as_str) {
                    let matched = regex(pattern).and_then(|r| r.is_match(text).map_err(|e| e.to_string()));
                    match matched {
                        Ok(true) => {}
                        Ok(false) => return Err(format!("{at}: {value} does not match the pattern {pattern:?}")),
                        Err(e) => return Err(format!("{at}: the pattern {pattern:?} could not be applied: {e}")),
                    }
                }
            }
            Value::Number(number) => {
                let x = number.as_f64().unwrap_or(f64::NAN);
                if object.get("minimum").and_then(Value::as_f64).is_some_and(|m| x < m) {
                    return Err(format!("{at}: {x} is below the minimum"));
                }
                if object.get("maximum").and_then(Value::as_f64).is_some_and(|m| x > m) {
                    return Err(format!("{at}: {x} is above the maximum"));
                }
                if object.get("exclusiveMinimum").and_then(Value::as_f64).is_some_and(|m| x <= m) {
                    return Err(format!("{at}: {x} is not above the exclusive minimum"));
                }
                if object.get("exclusiveMaximum").and_then(Value::as_f64).is_some_and(|m| x >= m) {
                    return Err(format!("{at}: {x} is not below the exclusive maximum"));
                }
                if let Some(m) = object.get("multipleOf").and_then(Value::as_f64)
                    && !is_multiple(x, m)
                {
                    return Err(format!("{at}: {x} is not a multiple of {m}"));
                }
            }
            _ => {}
        }
        if let Some(subs) = object.get("allOf").and_then(Value::as_array) {
            subs.iter().try_for_each(|s| self.check(value, s, at, chain))?;
        }
        if let Some(subs) = object.get("anyOf").and_then(Value::as_array)
            && !subs.iter().any(|s| self.check(value, s, at, chain).is_ok())
        {
            return Err(format!("{at}: matches none of anyOf"));
        }
        if let Some(subs) = object.get("oneOf").and_then(Value::as_array) {
            let matching = subs.iter().filter(|s| self.check(value, s, at, chain).is_ok()).count();
            if matching != 1 {
                return Err(format!("{at}: matches {matching} of oneOf, not exactly one"));
            }
        }
        if let Some(sub) = object.get("not")
            && self.check(value, sub, at, chain).is_ok()
        {
            return Err(format!("{at}: matches the schema under `not`"));
        }
        Ok(())
    }

    fn check_array(&self, items: &[Value], schema: &Map<String, Value>, at: &str) -> Result<(), String> {
        let count = items.len() as u64;
        if schema.get("minItems").and_then(Value::as_u64).is_some_and(|n| count < n) {
            return Err(format!("{at}: {count} items, fewer than minItems"));
        }
        if schema.get("maxItems").and_then(Value::as_u64).is_some_and(|n| count > n) {
            return Err(format!("{at}: {count} items, more than maxItems"));
        }
        // `prefixItems` for the first items, `items` for the rest (JSON Schema 2020-12).
        let prefix = schema.get("prefixItems").and_then(Value::as_array).map_or(&[][..], Vec::as_slice);
        for (i, item) in items.iter().enumerate() {
            if let Some(item_schema) = prefix.get(i).or_else(|| schema.get("items")) {
                self.check(item, item_schema, &format!("{at}[{i}]"), 0)?;
            }
        }
        if let Some(contains) = schema.get("contains")
            && !items.iter().enumerate().any(|(i, item)| self.check(item, contains, &format!("{at}[{i}]"), 0).is_ok())
        {
            return Err(format!("{at}: no item matches `contains`"));
        }
        if schema.get("uniqueItems").and_then(Value::as_bool) == Some(true)
            && let Some((i, j)) = (0..items.len()).flat_map(|j| (0..j).map(move |i| (i, j))).find(|&(i, j)| items[i] == items[j])
        {
            return Err(format!("{at}: items {i} and {j} are equal, but uniqueItems"));
        }
        Ok(())
    }

    fn check_object(&self, map: &Map<String, Value>, schema: &Map<String, Value>, at: &str) -> Result<(), String> {
        for name in schema.get("required").and_then(Value::as_array).into_iter().flatten().filter_map(Value::as_str) {
            if !map.contains_key(name) {
                return Err(format!("{at}: missing required property `{name}`"));
            }
        }
        let count = map.len() as u64;
        if schema.get("minProperties").and_then(Value::as_u64).is_some_and(|n| count < n) {
            return Err(format!("{at}: {count} properties, fewer than minProperties"));
        }
        if schema.get("maxProperties").and_then(Value::as_u64).is_some_and(|n| count > n) {
            return Err(format!("{at}: {count} properties, more than maxProperties"));
        }
        let properties = schema.get("properties").and_then(Value::as_object);
        let mut patterns = Vec::new();
        for (pattern, sub) in schema.get("patternProperties").and_then(Value::as_object).into_iter().flatten() {
            patterns.push((regex(pattern).map_err(|e| format!("{at}: the pattern {pattern:?} could not be applied: {e}"))?, sub));
        }
        for (name, item) in map {
            let place = format!("{at}.{name}");
            let mut matched = false;
            for (pattern, sub) in &patterns {
                if pattern.is_match(name).map_err(|e| format!("{place}: the pattern {:?} could not be applied: {e}", pattern.as_str()))? {
                    matched = true;
                    self.check(item, sub, &place, 0)?;
                }
            }
            match (properties.and_then(|p| p.get(name)), schema.get("additionalProperties")) {
                (Some(sub), _) => self.check(item, sub, &place, 0)?,
                _ if matched => {}
                (None, Some(Value::Bool(false))) => return Err(format!("{at}: property `{name}` is not allowed")),
                (None, Some(extra)) => self.check(item, extra, &place, 0)?,
                (None, None) => {}
            }
        }
        Ok(())
    }
}

/// Whether `x` is an integer multiple of `m`, up to the rounding of decimal fractions in
/// binary (`0.3` is a multiple of `0.1`).
fn is_multiple(x: f64, m: f64) -> bool {
    let quotient = x / m;
    (quotient - quotient.round()).abs() <= 1e-9 * quotient.abs().max(1.0)
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    fn skill_schema() -> Value {
        json!({
            "type": "object",
            "properties": {
                "skill": { "enum": ["Goto(fridge 1)", "Open(fridge 1)", "Done"] },
                "reason": { "type": "string", "maxLength": 40 },
                "confidence": { "type": "number", "minimum": 0, "maximum": 1 },
                "seen": { "type": "array", "items": { "type": "string" }, "maxItems": 2 }
            },
            "required": ["skill"],
            "additionalProperties": false
        })
    }

    #[test]
    fn the_first_object_is_read_out_of_prose() {
        let check = |text: &str, expected: Value| assert_eq!(first_object(text).unwrap(), expected, "{text}");
        check(r#"{"a": 1}"#, json!({"a": 1}));
        check("Sure! ```json\n{\"a\": {\"b\": [1, 2]}}\n``` and {\"c\": 3}", json!({"a": {"b": [1, 2]}}));
        check(r#"I think {not json} but {"a": "}"}"#, json!({"a": "}"}));
        assert_eq!(first_object("no braces"), Err("no JSON object in the reply".to_string()));
        let truncated = first_object(r#"{"skill": "Goto(fri"#).unwrap_err();
        assert!(truncated.starts_with("invalid JSON at byte 0: EOF"), "{truncated}");
    }

    #[test]
    fn values_are_checked_against_the_schema() {
        let schema = skill_schema();
        let check = |value: Value, expected: Result<(), &str>| {
            assert_eq!(validate(&value, &schema, "$"), expected.map_err(str::to_string), "{value}");
        };
        check(json!({"skill": "Done"}), Ok(()));
        check(json!({"skill": "Open(fridge 1)", "reason": "look inside", "confidence": 0.5, "seen": ["mug"]}), Ok(()));
        check(json!({"reason": "x"}), Err("$: missing required property `skill`"));
        check(json!({"skill": "Fly"}), Err(r#"$.skill: "Fly" is not one of "Goto(fridge 1)", "Open(fridge 1)", "Done""#));
        check(json!({"skill": "Done", "mood": 1}), Err("$: property `mood` is not allowed"));
        check(json!({"skill": "Done", "confidence": 2}), Err("$.confidence: 2 is above the maximum"));
        check(json!({"skill": "Done", "seen": ["a", 1]}), Err("$.seen[1]: expected string, found 1"));
        check(json!({"skill": "Done", "seen": ["a", "b", "c"]}), Err("$.seen: 3 items, more than maxItems"));
        check(json!(["Done"]), Err(r#"$: expected object, found ["Done"]"#));
        assert!(validate(&json!(3), &json!({"anyOf": [{"type": "string"}, {"type": "integer"}]}), "$").is_ok());
        assert!(validate(&json!(3), &json!({"oneOf": [{"type": "number"}, {"type": "integer"}]}), "$").is_err());
    }

    #[test]
    fn references_patterns_and_the_other_keywords_are_checked() {
        let check = |schema: &Value, value: Value, expected: Result<(), &str>| {
            assert_eq!(check_schema(schema), Ok(()), "{schema}");
            assert_eq!(validate(&value, schema, "$"), expected.map_err(str::to_string), "{value}");
        };
        // References are followed, also recursively through properties.
        let tree = json!({
            "type": "object",
            "properties": { "name": { "$ref": "#/$defs/name" }, "children": { "type": "array", "items": { "$ref": "#" } } },
            "$defs": { "name": { "type": "string", "pattern": "^[a-z]+ [0-9]+$" } }
        });
        check(&tree, json!({"name": "mug 1", "children": [{"name": "cup 2"}]}), Ok(()));
        check(
            &tree,
            json!({"name": "mug 1", "children": [{"name": "Cup"}]}),
            Err(r#"$.children[0].name: "Cup" does not match the pattern "^[a-z]+ [0-9]+$""#),
        );
        // A pattern matches anywhere unless anchored; lookaround is ECMA-262's.
        let word = json!({"type": "object", "properties": {"a": {"pattern": "mug(?! 2)"}}});
        check(&word, json!({"a": "a mug 1"}), Ok(()));
        check(&word, json!({"a": "mug 2"}), Err(r#"$.a: "mug 2" does not match the pattern "mug(?! 2)""#));
        let numbers = json!({"type": "object", "properties": {
            "p": {"exclusiveMinimum": 0, "exclusiveMaximum": 1},
            "step": {"multipleOf": 0.1},
            "odd": {"not": {"multipleOf": 2}}
        }});
        check(&numbers, json!({"p": 0.5, "step": 0.3, "odd": 3}), Ok(()));
        check(&numbers, json!({"p": 0}), Err("$.p: 0 is not above the exclusive minimum"));
        check(&numbers, json!({"p": 1}), Err("$.p: 1 is not below the exclusive maximum"));
        check(&numbers, json!({"step": 0.25}), Err("$.step: 0.25 is not a multiple of 0.1"));
        check(&numbers, json!({"odd": 4}), Err("$.odd: matches the schema under `not`"));
        let arrays = json!({"type": "object", "properties": {
            "pair": {"prefixItems": [{"type": "string"}, {"type": "integer"}], "items": false},
            "set": {"uniqueItems": true, "contains": {"const": "mug"}}
        }});
        check(&arrays, json!({"pair": ["a", 1], "set": ["cup", "mug"]}), Ok(()));
        check(&arrays, json!({"pair": [1]}), Err("$.pair[0]: expected string, found 1"));
        check(&arrays, json!({"pair": ["a", 1, 2]}), Err("$.pair[2]: no value is allowed here"));
        check(&arrays, json!({"set": ["mug", "cup", "mug"]}), Err("$.set: items 0 and 2 are equal, but uniqueItems"));
        check(&arrays, json!({"set": ["cup"]}), Err("$.set: no item matches `contains`"));
        let objects =
            json!({"type": "object", "patternProperties": {"^x-": {"type": "integer"}}, "additionalProperties": false, "maxProperties": 2});
        check(&objects, json!({"x-a": 1}), Ok(()));
        check(&objects, json!({"x-a": "1"}), Err(r#"$.x-a: expected integer, found "1""#));
        check(&objects, json!({"y": 1}), Err("$: property `y` is not allowed"));
        check(&objects, json!({"x-a": 1, "x-b": 2, "x-c": 3}), Err("$: 3 properties, more than maxProperties"));
    }

    #[test]
    fn references_that_loop_and_bad_patterns_are_refused_before_use() {
        let check = |schema: Value, error: &str| assert_eq!(check_schema(&schema), Err(error.to_string()), "{schema}");
        check(json!({"$ref": "#"}), "#/$ref: the references # -> # come back without a value in between");
        check(
            json!({"type": "object", "properties": {"a": {"$ref": "#/$defs/b"}}, "$defs": {"b": {"allOf": [{"$ref": "#/$defs/c"}]}, "c": {"$ref": "#/$defs/b"}}}),
            "#/$defs/b/allOf/0/$ref: the references #/$defs/c -> #/$defs/b -> #/$defs/b/allOf/0 -> #/$defs/c come back without a value in between",
        );
        check(
            json!({"type": "object", "properties": {"a": {"pattern": "(unclosed"}}}),
            "#/properties/a/pattern: \"(unclosed\" is not a regular expression: Parsing error at position 9: Opening parenthesis without closing parenthesis",
        );
        check(
            json!({"type": "object", "patternProperties": {"[": {}}}),
            "#/patternProperties: \"[\" is not a regular expression: Parsing error at position 1: Invalid character class",
        );
        check(json!({"type": "object", "properties": {"a": {"multipleOf": 0}}}), "#/properties/a/multipleOf: expected a number above 0");
        check(json!({"type": "object", "uniqueItems": "yes"}), "#/uniqueItems: expected true or false");
        // A loop through a value is a recursive schema, not a loop.
        assert_eq!(check_schema(&json!({"type": "object", "properties": {"next": {"$ref": "#"}}})), Ok(()));
        // A schema not checked first still ends: the validator stops a chain of references.
        let looping = json!({"$ref": "#"});
        assert_eq!(validate(&json!({}), &looping, "$"), Err(r##"$: the schema's references loop at "#""##.to_string()));
    }

    #[test]
    fn schemas_are_checked_before_use() {
        assert_eq!(check_schema(&skill_schema()), Ok(()));
        assert_eq!(check_schema(&json!(true)), Ok(()));
        let check = |schema: Value, error: &str| assert_eq!(check_schema(&schema), Err(error.to_string()));
        check(json!("object"), r#"#: a schema must be an object or a boolean, found "object""#);
        check(
            json!({"type": "dict"}),
            r#"#/type: unknown type "dict" (expected one of object, array, string, number, integer, boolean, null)"#,
        );
        check(
            json!({"properties": {"a": {"type": 3}}}),
            "#/properties/a/type: unknown type 3 (expected one of object, array, string, number, integer, boolean, null)",
        );
        check(json!({"required": "a"}), "#/required: expected an array of property names");
        check(json!({"anyOf": []}), "#/anyOf: expected a non-empty array");
        check(json!({"maxLength": -1}), "#/maxLength: expected a non-negative integer");
        check(json!({"type": "string"}), r#"#/type: "string", but the reply is read as a JSON object: the root must allow "object""#);
        // References within the schema, to something there.
        let referring = |to: &str| json!({"type": "object", "properties": {"skill": {"$ref": to}}, "$defs": {"skill": {"enum": ["Done"]}}});
        assert_eq!(check_schema(&referring("#/$defs/skill")), Ok(()));
        check(referring("#/definitions/skill"), r##"#/properties/skill/$ref: "#/definitions/skill" points at nothing in the schema"##);
        check(
            referring("other.json#/a"),
            r##"#/properties/skill/$ref: "other.json#/a": only references within the schema ("#/...") are accepted"##,
        );
    }
}
