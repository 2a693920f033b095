//! Helpers shared by the integration tests: tiny model files in a per-test temporary folder,
//! and GGUF rewriting for malformed-input tests.

#![allow(dead_code)]

use std::io::Cursor;
use std::path::{Path, PathBuf};

use candle_core::Device;
use candle_core::quantized::QTensor;
use candle_core::quantized::gguf_file::{self, Content, Value};
use lm::tiny::{TinySpec, tiny_gguf_bytes};

/// A temporary folder of its own, removed when dropped (also when the test fails).
pub struct TempDir(tempfile::TempDir);

impl TempDir {
    pub fn new(name: &str) -> Self {
        TempDir(tempfile::Builder::new().prefix(&format!("lm-test-{name}-")).tempdir().expect("temp dir"))
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }
}

/// Writes the tiny model of `spec` to `dir/name` and returns the path.
pub fn tiny_file(dir: &TempDir, name: &str, spec: &TinySpec) -> PathBuf {
    let path = dir.file(name);
    std::fs::write(&path, tiny_gguf_bytes(spec).expect("tiny model")).expect("write");
    path
}

/// The metadata and tensors of a GGUF file, editable and writable again.
pub struct Parts {
    pub metadata: Vec<(String, Value)>,
    pub tensors: Vec<(String, QTensor)>,
}

pub fn read_parts(bytes: &[u8]) -> Parts {
    let mut cursor = Cursor::new(bytes);
    let content = Content::read(&mut cursor).expect("valid GGUF");
    let mut metadata: Vec<(String, Value)> = content.metadata.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    metadata.sort_by(|a, b| a.0.cmp(&b.0));
    let mut names: Vec<String> = content.tensor_infos.keys().cloned().collect();
    names.sort();
    let tensors = names.into_iter().map(|n| (n.clone(), content.tensor(&mut cursor, &n, &Device::Cpu).expect("tensor"))).collect();
    Parts { metadata, tensors }
}

pub fn write_parts(path: &Path, parts: &Parts) {
    let metadata: Vec<(&str, &Value)> = parts.metadata.iter().map(|(k, v)| (k.as_str(), v)).collect();
    let tensors: Vec<(&str, &QTensor)> = parts.tensors.iter().map(|(k, t)| (k.as_str(), t)).collect();
    let mut out = Cursor::new(Vec::new());
    gguf_file::write(&mut out, &metadata, &tensors).expect("write GGUF");
    std::fs::write(path, out.into_inner()).expect("write file");
}

/// Largest absolute difference between two equally long vectors.
pub fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

/// The default model file in the model cache; it must have been fetched.
pub fn model_path() -> PathBuf {
    let path = lm::default_model_path();
    assert!(path.is_file(), "{} is missing: run `cargo xtask fetch-model` before the real-model tests", path.display());
    path
}
