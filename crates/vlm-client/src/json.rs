//! JSON replies: the first JSON object in a reply's text, checked against a JSON schema (the
//! keywords a reply format needs: `type`, `enum`, `const`, `properties`, `required`,
//! `additionalProperties`, `items`, `minItems`/`maxItems`, `minLength`/`maxLength`,
//! `minimum`/`maximum`, `anyOf`/`oneOf`/`allOf`), and [`chat_json`]: one request, and at most
//! one repair turn that quotes what was wrong.

use serde_json::{Map, Value};

use crate::client::ChatModel;
use crate::error::{ChatError, ChatErrorKind};
use crate::message::Message;
use crate::reply::{ChatReply, Usage};
use crate::request::ChatRequest;

/// A JSON reply that satisfies the schema.
#[derive(Debug, Clone, PartialEq)]
pub struct JsonReply {
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
            elapsed: Default::default(),
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
/// read as one, [`first_object`]); every `$ref` points within it (`#/...`) at something there
/// (a server that decodes under the schema follows it; [`validate`] checks the core keywords
/// and does not).
pub fn check_schema(schema: &Value) -> Result<(), String> {
    check_schema_at(schema, "#", schema)?;
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

fn check_schema_at(schema: &Value, at: &str, root: &Value) -> Result<(), String> {
    let object = match schema {
        Value::Bool(_) => return Ok(()),
        Value::Object(object) => object,
        other => return Err(format!("{at}: a schema must be an object or a boolean, found {other}")),
    };
    if let Some(reference) = object.get("$ref") {
        let target = reference.as_str().and_then(|r| r.strip_prefix('#'));
        match target {
            Some(pointer) if root.pointer(pointer).is_some() => {}
            Some(_) => return Err(format!("{at}/$ref: {reference} points at nothing in the schema")),
            None => return Err(format!("{at}/$ref: {reference}: only references within the schema (\"#/...\") are accepted")),
        }
    }
    for key in ["$defs", "definitions"] {
        if let Some(defs) = object.get(key) {
            let defs = defs.as_object().ok_or_else(|| format!("{at}/{key}: expected an object"))?;
            for (name, sub) in defs {
                check_schema_at(sub, &format!("{at}/{key}/{name}"), root)?;
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
    if let Some(properties) = object.get("properties") {
        let properties = properties.as_object().ok_or_else(|| format!("{at}/properties: expected an object"))?;
        for (name, sub) in properties {
            check_schema_at(sub, &format!("{at}/properties/{name}"), root)?;
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
    for key in ["items", "additionalProperties"] {
        if let Some(sub) = object.get(key) {
            check_schema_at(sub, &format!("{at}/{key}"), root)?;
        }
    }
    for key in ["anyOf", "oneOf", "allOf"] {
        if let Some(subs) = object.get(key) {
            let subs = subs.as_array().filter(|s| !s.is_empty()).ok_or_else(|| format!("{at}/{key}: expected a non-empty array"))?;
            for (i, sub) in subs.iter().enumerate() {
                check_schema_at(sub, &format!("{at}/{key}/{i}"), root)?;
            }
        }
    }
    for key in ["minItems", "maxItems", "minLength", "maxLength"] {
        if object.get(key).is_some_and(|v| v.as_u64().is_none()) {
            return Err(format!("{at}/{key}: expected a non-negative integer"));
        }
    }
    for key in ["minimum", "maximum"] {
        if object.get(key).is_some_and(|v| !v.is_number()) {
            return Err(format!("{at}/{key}: expected a number"));
        }
    }
    Ok(())
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
pub fn validate(value: &Value, schema: &Value, at: &str) -> Result<(), String> {
    let object = match schema {
        Value::Bool(true) => return Ok(()),
        Value::Bool(false) => return Err(format!("{at}: no value is allowed here")),
        Value::Object(object) => object,
        _ => return Err(format!("{at}: the schema is not an object")),
    };
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
        Value::Object(map) => validate_object(map, object, at)?,
        Value::Array(items) => {
            let count = items.len() as u64;
            if object.get("minItems").and_then(Value::as_u64).is_some_and(|n| count < n) {
                return Err(format!("{at}: {count} items, fewer than minItems"));
            }
            if object.get("maxItems").and_then(Value::as_u64).is_some_and(|n| count > n) {
                return Err(format!("{at}: {count} items, more than maxItems"));
            }
            if let Some(item_schema) = object.get("items") {
                for (i, item) in items.iter().enumerate() {
                    validate(item, item_schema, &format!("{at}[{i}]"))?;
                }
            }
        }
        Value::String(text) => {
            let length = text.chars().count() as u64;
            if object.get("minLength").and_then(Value::as_u64).is_some_and(|n| length < n) {
                return Err(format!("{at}: string shorter than minLength"));
            }
            if object.get("maxLength").and_then(Value::as_u64).is_some_and(|n| length > n) {
                return Err(format!("{at}: string longer than maxLength"));
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
        }
        _ => {}
    }
    if let Some(subs) = object.get("allOf").and_then(Value::as_array) {
        subs.iter().try_for_each(|s| validate(value, s, at))?;
    }
    if let Some(subs) = object.get("anyOf").and_then(Value::as_array)
        && !subs.iter().any(|s| validate(value, s, at).is_ok())
    {
        return Err(format!("{at}: matches none of anyOf"));
    }
    if let Some(subs) = object.get("oneOf").and_then(Value::as_array) {
        let matching = subs.iter().filter(|s| validate(value, s, at).is_ok()).count();
        if matching != 1 {
            return Err(format!("{at}: matches {matching} of oneOf, not exactly one"));
        }
    }
    Ok(())
}

fn validate_object(map: &Map<String, Value>, schema: &Map<String, Value>, at: &str) -> Result<(), String> {
    for name in schema.get("required").and_then(Value::as_array).into_iter().flatten().filter_map(Value::as_str) {
        if !map.contains_key(name) {
            return Err(format!("{at}: missing required property `{name}`"));
        }
    }
    let properties = schema.get("properties").and_then(Value::as_object);
    for (name, item) in map {
        let place = format!("{at}.{name}");
        match (properties.and_then(|p| p.get(name)), schema.get("additionalProperties")) {
            (Some(sub), _) => validate(item, sub, &place)?,
            (None, Some(Value::Bool(false))) => return Err(format!("{at}: property `{name}` is not allowed")),
            (None, Some(extra)) => validate(item, extra, &place)?,
            (None, None) => {}
        }
    }
    Ok(())
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
