//! Reading GGUF files: the header through candle's reader, and typed metadata look-ups that
//! name the key on every failure.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use candle_core::quantized::gguf_file::{Content, Value};

use crate::error::{LmError, candle_message};

/// An open GGUF file: its header (metadata + tensor table) and a reader for the weights.
#[derive(Debug)]
pub struct GgufFile {
    /// The header: metadata, and the tensor table (names, shapes, types, offsets).
    pub content: Content,
    /// The open file, from which the tensors' data are read.
    pub reader: BufReader<File>,
}

impl GgufFile {
    /// Opens `path` and reads the header; a file that is not GGUF is `MalformedGguf`.
    pub fn open(path: &Path) -> Result<Self, LmError> {
        let file = File::open(path).map_err(|source| LmError::Io { path: path.to_path_buf(), source })?;
        let mut reader = BufReader::new(file);
        let content =
            Content::read(&mut reader).map_err(|e| LmError::MalformedGguf(format!("{}: {}", path.display(), candle_message(&e))))?;
        Ok(GgufFile { content, reader })
    }
}

fn describe(value: &Value) -> String {
    match value {
        Value::String(s) => format!("string {:?}", truncate(s, 40)),
        Value::Array(items) => format!("array of {} item(s)", items.len()),
        other => format!("{other:?}"),
    }
}

fn truncate(s: &str, max: usize) -> &str {
    match s.char_indices().nth(max) {
        Some((end, _)) => &s[..end],
        None => s,
    }
}

/// Typed access to GGUF metadata.
#[derive(Debug, Clone, Copy)]
pub struct Metadata<'a> {
    content: &'a Content,
}

impl<'a> Metadata<'a> {
    /// Typed access to `content`'s metadata.
    pub fn new(content: &'a Content) -> Self {
        Metadata { content }
    }

    /// The raw value of `key`; `None` where it is absent.
    pub fn get(&self, key: &str) -> Option<&'a Value> {
        self.content.metadata.get(key)
    }

    fn required(&self, key: &str) -> Result<&'a Value, LmError> {
        self.get(key).ok_or_else(|| LmError::MissingMetadata { key: key.to_string() })
    }

    /// A non-negative integer of any width.
    pub fn integer(&self, key: &str) -> Result<u64, LmError> {
        let value = self.required(key)?;
        as_integer(value).ok_or_else(|| LmError::BadMetadata {
            key: key.to_string(),
            expected: "a non-negative integer",
            found: describe(value),
        })
    }

    /// As [`Self::integer`], or `default` where `key` is absent (a value of the wrong type is
    /// still an error).
    pub fn integer_or(&self, key: &str, default: u64) -> Result<u64, LmError> {
        if self.get(key).is_some() { self.integer(key) } else { Ok(default) }
    }

    /// A positive integer that fits a `usize` (dimensions, counts).
    pub fn dimension(&self, key: &str) -> Result<usize, LmError> {
        let n = self.integer(key)?;
        if n == 0 || n > u32::MAX as u64 {
            return Err(LmError::BadMetadata { key: key.to_string(), expected: "a positive dimension", found: n.to_string() });
        }
        Ok(n as usize)
    }

    /// As [`Self::dimension`], or `default` where `key` is absent (a bad value is still an error).
    pub fn dimension_or(&self, key: &str, default: usize) -> Result<usize, LmError> {
        if self.get(key).is_some() { self.dimension(key) } else { Ok(default) }
    }

    /// A finite number, stored as a float or a non-negative integer of any width; NaN, infinities
    /// and negative integers are [`LmError::BadMetadata`].
    pub fn float(&self, key: &str) -> Result<f64, LmError> {
        let value = self.required(key)?;
        let x = match value {
            Value::F32(x) => *x as f64,
            Value::F64(x) => *x,
            other => match as_integer(other) {
                Some(n) => n as f64,
                None => return Err(LmError::BadMetadata { key: key.to_string(), expected: "a number", found: describe(other) }),
            },
        };
        if !x.is_finite() {
            return Err(LmError::BadMetadata { key: key.to_string(), expected: "a finite number", found: x.to_string() });
        }
        Ok(x)
    }

    /// As [`Self::float`], or `default` where `key` is absent (a bad value is still an error).
    pub fn float_or(&self, key: &str, default: f64) -> Result<f64, LmError> {
        if self.get(key).is_some() { self.float(key) } else { Ok(default) }
    }

    /// A string; [`LmError::MissingMetadata`] where absent, [`LmError::BadMetadata`] for
    /// another type.
    pub fn string(&self, key: &str) -> Result<&'a str, LmError> {
        match self.required(key)? {
            Value::String(s) => Ok(s),
            other => Err(LmError::BadMetadata { key: key.to_string(), expected: "a string", found: describe(other) }),
        }
    }

    /// As [`Self::string`], or `None` where `key` is absent.
    pub fn optional_string(&self, key: &str) -> Result<Option<&'a str>, LmError> {
        if self.get(key).is_some() { self.string(key).map(Some) } else { Ok(None) }
    }

    /// A boolean, or `default` where `key` is absent; another type is [`LmError::BadMetadata`].
    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool, LmError> {
        match self.get(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(other) => Err(LmError::BadMetadata { key: key.to_string(), expected: "a boolean", found: describe(other) }),
        }
    }

    /// An array of strings; an item of another type is named `key[i]` in the error.
    pub fn string_array(&self, key: &str) -> Result<Vec<&'a str>, LmError> {
        let items = match self.required(key)? {
            Value::Array(items) => items,
            other => return Err(LmError::BadMetadata { key: key.to_string(), expected: "an array of strings", found: describe(other) }),
        };
        items
            .iter()
            .enumerate()
            .map(|(i, item)| match item {
                Value::String(s) => Ok(s.as_str()),
                other => Err(LmError::BadMetadata { key: format!("{key}[{i}]"), expected: "a string", found: describe(other) }),
            })
            .collect()
    }

    /// An array of integers of any width that fit an `i64`; an item that does not is named
    /// `key[i]` in the error.
    pub fn integer_array(&self, key: &str) -> Result<Vec<i64>, LmError> {
        let items = match self.required(key)? {
            Value::Array(items) => items,
            other => return Err(LmError::BadMetadata { key: key.to_string(), expected: "an array of integers", found: describe(other) }),
        };
        items
            .iter()
            .enumerate()
            .map(|(i, item)| {
                as_signed(item).ok_or_else(|| LmError::BadMetadata {
                    key: format!("{key}[{i}]"),
                    expected: "an integer",
                    found: describe(item),
                })
            })
            .collect()
    }

    /// The shape of the tensor `name`, in GGUF's order of dimensions reversed (rows first), as
    /// candle reports it; `None` where the file has no such tensor.
    pub fn tensor_shape(&self, name: &str) -> Option<Vec<usize>> {
        self.content.tensor_infos.get(name).map(|info| info.shape.dims().to_vec())
    }
}

fn as_integer(value: &Value) -> Option<u64> {
    match *value {
        Value::U8(n) => Some(n as u64),
        Value::U16(n) => Some(n as u64),
        Value::U32(n) => Some(n as u64),
        Value::U64(n) => Some(n),
        Value::I8(n) => u64::try_from(n).ok(),
        Value::I16(n) => u64::try_from(n).ok(),
        Value::I32(n) => u64::try_from(n).ok(),
        Value::I64(n) => u64::try_from(n).ok(),
        _ => None,
    }
}

fn as_signed(value: &Value) -> Option<i64> {
    match *value {
        Value::U8(n) => Some(n as i64),
        Value::U16(n) => Some(n as i64),
        Value::U32(n) => Some(n as i64),
        Value::U64(n) => i64::try_from(n).ok(),
        Value::I8(n) => Some(n as i64),
        Value::I16(n) => Some(n as i64),
        Value::I32(n) => Some(n as i64),
        Value::I64(n) => Some(n),
        _ => None,
    }
}
