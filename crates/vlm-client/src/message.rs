//! What a conversation holds: messages of text and image parts. Images are PNG or JPEG bytes,
//! recognised by their signature and sent as base64 `data:` URLs.

use base64::Engine;
use serde_json::{Value, json};

use crate::error::ChatErrorKind;

/// Who speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    System,
    User,
    Assistant,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::System => "system",
            Role::User => "user",
            Role::Assistant => "assistant",
        }
    }
}

/// An image format the API carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Jpeg,
}

/// An encoded image, checked to be PNG or JPEG.
#[derive(Clone, PartialEq, Eq)]
pub struct Image {
    format: ImageFormat,
    bytes: Vec<u8>,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Image({:?}, {} bytes)", self.format, self.bytes.len())
    }
}

impl Image {
    /// The image in `bytes`, by its signature; anything else is [`ChatErrorKind::BadInput`].
    pub fn from_bytes(bytes: Vec<u8>) -> Result<Image, ChatErrorKind> {
        let format = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            ImageFormat::Png
        } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
            ImageFormat::Jpeg
        } else {
            let head: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
            return Err(ChatErrorKind::BadInput(format!(
                "not a PNG or JPEG image ({} bytes, starting {})",
                bytes.len(),
                if head.is_empty() { "empty".to_string() } else { head.join(" ") }
            )));
        };
        Ok(Image { format, bytes })
    }

    pub fn format(&self) -> ImageFormat {
        self.format
    }

    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// `data:image/png;base64,...`.
    pub fn data_url(&self) -> String {
        let mime = match self.format {
            ImageFormat::Png => "image/png",
            ImageFormat::Jpeg => "image/jpeg",
        };
        format!("data:{mime};base64,{}", base64::engine::general_purpose::STANDARD.encode(&self.bytes))
    }
}

/// One part of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Part {
    Text(String),
    Image(Image),
}

/// One message of a conversation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    pub role: Role,
    pub parts: Vec<Part>,
}

impl Message {
    pub fn text(role: Role, text: impl Into<String>) -> Message {
        Message { role, parts: vec![Part::Text(text.into())] }
    }

    pub fn system(text: impl Into<String>) -> Message {
        Message::text(Role::System, text)
    }

    pub fn user(text: impl Into<String>) -> Message {
        Message::text(Role::User, text)
    }

    pub fn assistant(text: impl Into<String>) -> Message {
        Message::text(Role::Assistant, text)
    }

    /// Adds an image part.
    pub fn with_image(mut self, image: Image) -> Message {
        self.parts.push(Part::Image(image));
        self
    }

    /// The message's text parts, joined by blank lines (what a text-only model reads).
    pub fn joined_text(&self) -> String {
        let texts: Vec<&str> = self
            .parts
            .iter()
            .filter_map(|p| match p {
                Part::Text(t) => Some(t.as_str()),
                Part::Image(_) => None,
            })
            .collect();
        texts.join("\n\n")
    }

    pub fn image_count(&self) -> usize {
        self.parts.iter().filter(|p| matches!(p, Part::Image(_))).count()
    }

    /// The API's form: a plain string when the message is one text part (what every server
    /// takes), else an array of `text` and `image_url` parts.
    pub fn to_json(&self) -> Value {
        let content = match self.parts.as_slice() {
            [Part::Text(text)] => json!(text),
            parts => Value::Array(
                parts
                    .iter()
                    .map(|p| match p {
                        Part::Text(text) => json!({ "type": "text", "text": text }),
                        Part::Image(image) => json!({ "type": "image_url", "image_url": { "url": image.data_url() } }),
                    })
                    .collect(),
            ),
        };
        json!({ "role": self.role.as_str(), "content": content })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_are_recognised_by_signature() {
        let png = Image::from_bytes(b"\x89PNG\r\n\x1a\nrest".to_vec()).unwrap();
        assert_eq!(png.format(), ImageFormat::Png);
        assert_eq!(png.data_url(), "data:image/png;base64,iVBORw0KGgpyZXN0");
        assert_eq!(Image::from_bytes(vec![0xff, 0xd8, 0xff, 0xe0]).unwrap().format(), ImageFormat::Jpeg);
        for bad in [b"GIF89a".to_vec(), Vec::new(), b"\x89PNG".to_vec()] {
            assert!(matches!(Image::from_bytes(bad), Err(ChatErrorKind::BadInput(_))));
        }
    }

    #[test]
    fn one_text_part_is_a_plain_string() {
        assert_eq!(Message::user("hi").to_json(), json!({ "role": "user", "content": "hi" }));
        let image = Image::from_bytes(vec![0xff, 0xd8, 0xff]).unwrap();
        let with_image = Message::user("look").with_image(image);
        assert_eq!(with_image.to_json()["content"][1]["image_url"]["url"], "data:image/jpeg;base64,/9j/");
        assert_eq!(with_image.image_count(), 1);
        assert_eq!(with_image.joined_text(), "look");
    }
}
