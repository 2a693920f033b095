//! What a conversation holds: messages of text and image parts. Images are PNG or JPEG bytes,
//! recognised by their signature, decoded whole once (so a truncated or corrupt picture is
//! refused here, not by the server) and sent as base64 `data:` URLs.

use std::io::Cursor;

use base64::Engine;
use serde_json::{Value, json};

use crate::error::ChatErrorKind;

/// Who speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Instructions that frame the conversation.
    System,
    /// The person or program asking.
    User,
    /// The model (its earlier replies, quoted back).
    Assistant,
}

impl Role {
    /// The role's name in the API: `system`, `user` or `assistant`.
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
    /// PNG, sent as `image/png`.
    Png,
    /// JPEG, sent as `image/jpeg`.
    Jpeg,
}

impl ImageFormat {
    fn name(self) -> &'static str {
        match self {
            ImageFormat::Png => "PNG",
            ImageFormat::Jpeg => "JPEG",
        }
    }

    fn codec(self) -> image::ImageFormat {
        match self {
            ImageFormat::Png => image::ImageFormat::Png,
            ImageFormat::Jpeg => image::ImageFormat::Jpeg,
        }
    }
}

/// An encoded image, checked to be a whole PNG or JPEG (it decodes), with its size.
#[derive(Clone, PartialEq, Eq)]
pub struct Image {
    format: ImageFormat,
    width: u32,
    height: u32,
    bytes: Vec<u8>,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Image({:?}, {}x{}, {} bytes)", self.format, self.width, self.height, self.bytes.len())
    }
}

impl Image {
    /// The most pixels a picture may have: Pillow's `2 * Image.MAX_IMAGE_PIXELS` (Pillow 13),
    /// past which `Image.open` raises `DecompressionBombError`.
    pub const MAX_PIXELS: u64 = 2 * 89_478_485;

    /// The image in `bytes`: PNG or JPEG by its signature, then decoded whole (the pixels are
    /// dropped; the bytes are what is sent), a JPEG to its end-of-image marker. Anything else,
    /// a file that does not decode (truncated, corrupt), or one of more than [`Image::MAX_PIXELS`]
    /// pixels (checked from the header, before decoding), is [`ChatErrorKind::BadInput`]
    /// naming the decoder's complaint or the size.
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
        let refuse =
            |why: String| ChatErrorKind::BadInput(format!("a {} image that does not decode ({} bytes): {why}", format.name(), bytes.len()));
        // The size first, from the header: a picture of more pixels than Pillow opens (the
        // servers' reader: `DecompressionBombError`) is refused before anything is decoded.
        let reader = || image::ImageReader::with_format(Cursor::new(&bytes), format.codec());
        let (width, height) = reader().into_dimensions().map_err(|e| refuse(e.to_string()))?;
        let pixels = u64::from(width.max(1)) * u64::from(height.max(1));
        if pixels > Image::MAX_PIXELS {
            return Err(ChatErrorKind::BadInput(format!(
                "a {width}x{height} {} image: {pixels} pixels, more than the {} that Pillow (which servers read pictures with) opens",
                format.name(),
                Image::MAX_PIXELS
            )));
        }
        let decoded = reader().decode().map_err(|e| refuse(e.to_string()))?;
        if format == ImageFormat::Jpeg && !jpeg_reaches_eoi(&bytes) {
            return Err(refuse("it is cut short: no end-of-image marker after its last scan".to_string()));
        }
        Ok(Image { format, width: decoded.width(), height: decoded.height(), bytes })
    }

    /// Encodes 8-bit RGB pixels (`width * height * 3` bytes, rows top to bottom), for an
    /// environment that renders frames: PNG is lossless, JPEG at quality 90.
    pub fn encode_rgb8(format: ImageFormat, width: u32, height: u32, rgb: &[u8]) -> Result<Image, ChatErrorKind> {
        let expected = u64::from(width) * u64::from(height) * 3;
        if width == 0 || height == 0 || rgb.len() as u64 != expected {
            return Err(ChatErrorKind::BadInput(format!(
                "{width}x{height} RGB pixels need {expected} bytes, not {} (and a size of at least 1x1)",
                rgb.len()
            )));
        }
        let mut bytes = Vec::new();
        let encoded = match format {
            ImageFormat::Png => image::ImageEncoder::write_image(
                image::codecs::png::PngEncoder::new(Cursor::new(&mut bytes)),
                rgb,
                width,
                height,
                image::ExtendedColorType::Rgb8,
            ),
            ImageFormat::Jpeg => image::ImageEncoder::write_image(
                image::codecs::jpeg::JpegEncoder::new_with_quality(Cursor::new(&mut bytes), 90),
                rgb,
                width,
                height,
                image::ExtendedColorType::Rgb8,
            ),
        };
        encoded.map_err(|e| ChatErrorKind::BadInput(format!("cannot encode a {width}x{height} {}: {e}", format.name())))?;
        Ok(Image { format, width, height, bytes })
    }

    /// PNG or JPEG, as the bytes' signature says.
    pub fn format(&self) -> ImageFormat {
        self.format
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The encoded file, as it is sent (not the pixels).
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

/// Whether a JPEG reaches its end-of-image marker after its last scan (bytes after the marker,
/// as some cameras append, are allowed). It walks the segments from SOI: each marker's length
/// skips its segment, and a scan's entropy-coded data runs to the next marker that is neither
/// a stuffed `FF 00` nor a restart marker, so an EXIF thumbnail's own SOS and EOI, inside an
/// APP1 segment, are skipped.
///
/// Written here because image's JPEG decoder (zune-jpeg) is lenient by design: it fills a scan
/// cut short with grey, as browsers do, and its strict mode would also refuse files that libjpeg
/// and browsers read (stray bytes between segments). Pillow (libjpeg), which servers load
/// pictures with, refuses a JPEG without its end marker, as this check does; on a PNG the png
/// decoder here is the stricter, wanting the checksums after the pixel data, which Pillow reads
/// without (`tools/image_cut_check.py` compares the two on cut files).
fn jpeg_reaches_eoi(bytes: &[u8]) -> bool {
    let mut at = 2; // past SOI
    while at + 1 < bytes.len() {
        if bytes[at] != 0xff {
            // Stray bytes between segments: skipped to the next marker, as libjpeg does (with
            // a warning).
            at += 1;
            continue;
        }
        let marker = bytes[at + 1];
        at += 2;
        match marker {
            0xd9 => return true,
            // Fill bytes before a marker, and markers without a segment.
            0xff => at -= 1,
            0x01 | 0xd0..=0xd7 => {}
            _ => {
                let Some(length) = bytes.get(at..at + 2).map(|l| usize::from(u16::from_be_bytes([l[0], l[1]]))) else {
                    return false;
                };
                at += length;
                if marker == 0xda {
                    // The scan's data: up to the next real marker.
                    while at + 1 < bytes.len() {
                        if bytes[at] == 0xff && !matches!(bytes[at + 1], 0x00 | 0xd0..=0xd7) {
                            break;
                        }
                        at += 1;
                    }
                }
            }
        }
    }
    false
}

/// One part of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Part {
    /// Text.
    Text(String),
    /// A picture, sent as a base64 `data:` URL.
    Image(Image),
}

/// One message of a conversation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// Who speaks.
    pub role: Role,
    /// The content, in order; one text part alone is sent as a plain string ([`Message::to_json`]).
    pub parts: Vec<Part>,
}

impl Message {
    /// A message of one text part.
    pub fn text(role: Role, text: impl Into<String>) -> Message {
        Message { role, parts: vec![Part::Text(text.into())] }
    }

    /// A [`Role::System`] message of one text part.
    pub fn system(text: impl Into<String>) -> Message {
        Message::text(Role::System, text)
    }

    /// A [`Role::User`] message of one text part.
    pub fn user(text: impl Into<String>) -> Message {
        Message::text(Role::User, text)
    }

    /// A [`Role::Assistant`] message of one text part.
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

    /// The number of image parts.
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

    /// A 3x2 picture with every pixel different.
    fn pixels() -> Vec<u8> {
        (0u8..18).map(|i| i.wrapping_mul(37)).collect()
    }

    /// A PNG whose header claims `width` x `height` (its IHDR rewritten, with a correct CRC; the
    /// pixel data stays that of a 3x2 RGB picture), in grayscale when `gray` (a decoder then
    /// reserves one byte a pixel, not three: 179 MB, not 537, for the largest size let through).
    fn png_claiming(width: u32, height: u32, gray: bool) -> Vec<u8> {
        let mut png = Image::encode_rgb8(ImageFormat::Png, 3, 2, &pixels()).unwrap().bytes().to_vec();
        // Signature (8), IHDR length (4), "IHDR" (4), width (4), height (4), 5 more, CRC (4).
        png[16..20].copy_from_slice(&width.to_be_bytes());
        png[20..24].copy_from_slice(&height.to_be_bytes());
        if gray {
            png[25] = 0;
        }
        let crc = crc32fast::hash(&png[12..29]);
        png[29..33].copy_from_slice(&crc.to_be_bytes());
        png
    }

    /// Past Pillow's limit (178,956,970 pixels) a picture is refused from its header, saying its
    /// size; at the limit it is decoded (and this one fails there: its data is 3x2).
    #[test]
    fn a_picture_of_more_pixels_than_pillow_opens_is_refused_by_its_size() {
        assert_eq!(Image::MAX_PIXELS, 178_956_970);
        let over = Image::from_bytes(png_claiming(13_377, 13_378, true)).unwrap_err();
        assert!(matches!(&over, ChatErrorKind::BadInput(m) if m.contains("13377x13378") && m.contains("178957506 pixels")), "{over}");
        let at = Image::from_bytes(png_claiming(13_377, 13_377, true)).unwrap_err();
        assert!(matches!(&at, ChatErrorKind::BadInput(m) if m.contains("does not decode")), "{at}");
        assert!(Image::from_bytes(png_claiming(3, 2, false)).is_ok(), "the rewritten header itself is sound");
    }

    #[test]
    fn images_are_decoded_whole_and_their_size_kept() {
        for format in [ImageFormat::Png, ImageFormat::Jpeg] {
            let encoded = Image::encode_rgb8(format, 3, 2, &pixels()).unwrap();
            let read = Image::from_bytes(encoded.bytes().to_vec()).unwrap();
            assert_eq!((read.format(), read.width(), read.height()), (format, 3, 2));
            assert_eq!(read, encoded);
            // Cut anywhere past its signature, the file is refused, naming the format: no byte
            // of the pixel data, their checksums or a JPEG's end marker may be missing (the png
            // decoder reads a PNG cut inside its last four bytes, IEND's CRC, as Pillow does).
            let whole = encoded.bytes();
            let end = if format == ImageFormat::Png { whole.len() - 4 } else { whole.len() };
            for cut in 9..end {
                match Image::from_bytes(whole[..cut].to_vec()) {
                    Err(ChatErrorKind::BadInput(m)) => assert!(m.contains("image that does not decode"), "{format:?} cut at {cut}: {m}"),
                    other => panic!("{format:?} cut at {cut}: {other:?}"),
                }
            }
        }
        // PNG's chunks carry CRCs: one flipped byte in the image data is caught.
        let png = Image::encode_rgb8(ImageFormat::Png, 3, 2, &pixels()).unwrap();
        let idat = png.bytes().windows(4).position(|w| w == b"IDAT").unwrap();
        let mut corrupt = png.bytes().to_vec();
        corrupt[idat + 6] ^= 0x55;
        assert!(matches!(Image::from_bytes(corrupt), Err(ChatErrorKind::BadInput(m)) if m.contains("PNG")));
        assert!(format!("{png:?}").starts_with("Image(Png, 3x2, "));
    }

    #[test]
    fn the_jpeg_end_is_found_past_a_thumbnail_and_before_trailing_bytes() {
        let jpeg = Image::encode_rgb8(ImageFormat::Jpeg, 3, 2, &pixels()).unwrap();
        // An APP1 segment holding a thumbnail's own SOS and EOI, as EXIF does.
        let thumbnail = [0xff, 0xd8, 0xff, 0xda, 0x00, 0x02, 0x12, 0xff, 0xd9];
        let mut with_app1 = vec![0xff, 0xd8, 0xff, 0xe1, 0x00, 2 + thumbnail.len() as u8];
        with_app1.extend_from_slice(&thumbnail);
        with_app1.extend_from_slice(&jpeg.bytes()[2..]);
        let mut trailing = with_app1.clone();
        trailing.extend_from_slice(b"appended video");
        // Stray bytes after the APP1 segment, which libjpeg skips with a warning.
        let mut stray = with_app1.clone();
        stray.splice(6 + thumbnail.len()..6 + thumbnail.len(), [0x00, 0x42, 0x00]);
        for whole in [with_app1.clone(), trailing, stray] {
            assert_eq!(Image::from_bytes(whole).unwrap().width(), 3);
        }
        let cut = &with_app1[..with_app1.len() - 2];
        assert!(matches!(Image::from_bytes(cut.to_vec()), Err(ChatErrorKind::BadInput(m)) if m.contains("end-of-image")));
        let mut png = Image::encode_rgb8(ImageFormat::Png, 3, 2, &pixels()).unwrap().bytes().to_vec();
        png.extend_from_slice(b"after IEND");
        assert_eq!(Image::from_bytes(png).unwrap().height(), 2);
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            cases: 512,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x0069_6d61_6765),
            failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
            ..proptest::test_runner::Config::default()
        })]

        /// Any bytes after a PNG or JPEG signature, or a real image with bytes overwritten,
        /// give an image or bad input, never a panic; a JPEG that gets through reaches its end.
        #[test]
        fn arbitrary_bytes_are_an_image_or_bad_input(
            tail in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
            jpeg in proptest::prelude::any::<bool>(),
            at in 0usize..2000,
        ) {
            let format = if jpeg { ImageFormat::Jpeg } else { ImageFormat::Png };
            let real = Image::encode_rgb8(format, 3, 2, &pixels()).unwrap().bytes().to_vec();
            let signature: &[u8] = if jpeg { &[0xff, 0xd8, 0xff] } else { b"\x89PNG\r\n\x1a\n" };
            let mut overwritten = real.clone();
            let start = (at % real.len()).max(signature.len());
            for (i, b) in tail.iter().enumerate().filter(|(i, _)| start + i < real.len()) {
                overwritten[start + i] = *b;
            }
            for bytes in [[signature, &tail[..]].concat(), overwritten] {
                match Image::from_bytes(bytes.clone()) {
                    Ok(image) => proptest::prop_assert!(!jpeg || jpeg_reaches_eoi(image.bytes())),
                    Err(error) => proptest::prop_assert!(matches!(error, ChatErrorKind::BadInput(_))),
                }
            }
        }
    }

    #[test]
    fn what_is_not_png_or_jpeg_is_refused_by_its_signature() {
        let png = Image::encode_rgb8(ImageFormat::Png, 1, 1, &[255, 0, 0]).unwrap();
        assert!(png.data_url().starts_with("data:image/png;base64,iVBORw0KGgo"));
        for bad in [b"GIF89a".to_vec(), Vec::new(), b"\x89PNG".to_vec()] {
            assert!(matches!(Image::from_bytes(bad), Err(ChatErrorKind::BadInput(m)) if m.contains("not a PNG or JPEG")));
        }
        for (width, height, len) in [(0, 1, 0), (2, 2, 11)] {
            assert!(matches!(Image::encode_rgb8(ImageFormat::Png, width, height, &vec![0; len]), Err(ChatErrorKind::BadInput(_))));
        }
    }

    #[test]
    fn one_text_part_is_a_plain_string() {
        assert_eq!(Message::user("hi").to_json(), json!({ "role": "user", "content": "hi" }));
        let image = Image::encode_rgb8(ImageFormat::Jpeg, 1, 1, &[0, 0, 255]).unwrap();
        let with_image = Message::user("look").with_image(image.clone());
        assert_eq!(with_image.to_json()["content"][1]["image_url"]["url"], image.data_url());
        assert!(image.data_url().starts_with("data:image/jpeg;base64,/9j/"));
        assert_eq!(with_image.image_count(), 1);
        assert_eq!(with_image.joined_text(), "look");
    }
}
