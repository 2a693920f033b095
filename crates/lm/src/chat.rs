//! Chat templates: the Jinja text in `tokenizer.chat_template`, rendered with minijinja and
//! Python string methods (`.strip()`, `.startswith()`, ...) as Hugging Face templates use them.

use crate::error::LmError;
use minijinja::{Environment, Error as JinjaError, ErrorKind, Value, context};

/// A compiled chat template.
#[derive(Debug, Clone)]
pub struct ChatTemplate {
    environment: Environment<'static>,
}

const NAME: &str = "chat_template";

fn raise_exception(message: String) -> Result<String, JinjaError> {
    Err(JinjaError::new(ErrorKind::InvalidOperation, message))
}

impl ChatTemplate {
    /// Compiles `source`; a syntax error is `LmError::ChatTemplate` with minijinja's message.
    pub fn new(source: &str) -> Result<Self, LmError> {
        let mut environment = Environment::new();
        environment.set_unknown_method_callback(minijinja_contrib::pycompat::unknown_method_callback);
        environment.add_function("raise_exception", raise_exception);
        environment.add_template_owned(NAME, source.to_string()).map_err(|e| LmError::ChatTemplate(describe(&e)))?;
        Ok(ChatTemplate { environment })
    }

    /// Renders `(role, content)` messages with the assistant's turn opened
    /// (`add_generation_prompt = true`).
    pub fn render(&self, messages: &[(&str, &str)], bos_token: &str, eos_token: &str) -> Result<String, LmError> {
        self.render_with(messages, bos_token, eos_token, &serde_json::Map::new())
    }

    /// [`ChatTemplate::render`] with `kwargs` as further template variables, as vLLM and
    /// llama-server pass a request's `chat_template_kwargs` (Qwen3's `enable_thinking`); the
    /// variables above take precedence over a key of the same name.
    pub fn render_with(
        &self,
        messages: &[(&str, &str)],
        bos_token: &str,
        eos_token: &str,
        kwargs: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<String, LmError> {
        let messages: Vec<Value> = messages.iter().map(|&(role, content)| context! { role, content }).collect();
        let template = self.environment.get_template(NAME).map_err(|e| LmError::ChatTemplate(describe(&e)))?;
        template
            .render(context! { messages, add_generation_prompt => true, bos_token, eos_token, ..Value::from(object(kwargs)) })
            .map_err(|e| LmError::ChatTemplate(describe(&e)))
    }
}

/// A JSON object as template variables (written out: minijinja's serde bridge is a feature this
/// workspace does not build).
fn object(map: &serde_json::Map<String, serde_json::Value>) -> std::collections::BTreeMap<String, Value> {
    map.iter().map(|(key, value)| (key.clone(), json(value))).collect()
}

fn json(value: &serde_json::Value) -> Value {
    match value {
        serde_json::Value::Null => Value::from(()),
        serde_json::Value::Bool(b) => Value::from(*b),
        serde_json::Value::Number(n) => n.as_i64().map(Value::from).unwrap_or_else(|| Value::from(n.as_f64().unwrap_or(f64::NAN))),
        serde_json::Value::String(s) => Value::from(s.as_str()),
        serde_json::Value::Array(items) => Value::from(items.iter().map(json).collect::<Vec<_>>()),
        serde_json::Value::Object(map) => Value::from(object(map)),
    }
}

fn describe(error: &JinjaError) -> String {
    let mut text = error.to_string();
    let mut source = std::error::Error::source(error);
    while let Some(inner) = source {
        text.push_str(": ");
        text.push_str(&inner.to_string());
        source = inner.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SmolLM2-135M-Instruct's template, as its GGUF stores it.
    const SMOLLM2: &str = "{% for message in messages %}{% if loop.first and messages[0]['role'] != 'system' %}{{ '<|im_start|>system\nYou are a helpful AI assistant named SmolLM, trained by Hugging Face<|im_end|>\n' }}{% endif %}{{'<|im_start|>' + message['role'] + '\n' + message['content'] + '<|im_end|>' + '\n'}}{% endfor %}{% if add_generation_prompt %}{{ '<|im_start|>assistant\n' }}{% endif %}";

    #[test]
    fn smollm2_template_renders_chatml() {
        let template = ChatTemplate::new(SMOLLM2).expect("compiles");
        let text = template.render(&[("system", "Plan."), ("user", "Make tea.")], "", "").expect("renders");
        assert_eq!(text, "<|im_start|>system\nPlan.<|im_end|>\n<|im_start|>user\nMake tea.<|im_end|>\n<|im_start|>assistant\n");
    }

    #[test]
    fn python_string_methods_and_raise_exception_work() {
        let template = ChatTemplate::new(
            "{% for m in messages %}{% if m.role not in ['system', 'user'] %}{{ raise_exception('bad role') }}{% endif %}[{{ m.content.strip() }}]{% endfor %}",
        )
        .expect("compiles");
        assert_eq!(template.render(&[("system", "  a "), ("user", "b\n")], "", "").expect("renders"), "[a][b]");
        let error = template.render(&[("tool", "x")], "", "").expect_err("raises");
        assert!(matches!(&error, LmError::ChatTemplate(m) if m.contains("bad role")), "{error}");
    }

    #[test]
    fn a_syntax_error_is_a_typed_error() {
        assert!(matches!(ChatTemplate::new("{% for m in messages %}"), Err(LmError::ChatTemplate(_))));
    }
}
