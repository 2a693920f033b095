//! The per-layer key/value cache: one flat `positions × kv_dim` buffer per layer for keys and
//! one for values, so that appending is `extend` and rewinding to any length is `truncate`.

/// Keys and values of every layer for positions `0..len()`.
#[derive(Debug, Clone)]
pub struct KvCache {
    layers: Vec<LayerCache>,
    kv_dim: usize,
    len: usize,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct LayerCache {
    keys: Vec<f32>,
    values: Vec<f32>,
}

impl LayerCache {
    pub(crate) fn append(&mut self, keys: &[f32], values: &[f32]) {
        self.keys.extend_from_slice(keys);
        self.values.extend_from_slice(values);
    }

    pub(crate) fn keys(&self) -> &[f32] {
        &self.keys
    }

    pub(crate) fn values(&self) -> &[f32] {
        &self.values
    }
}

impl KvCache {
    pub(crate) fn new(layers: usize, kv_dim: usize) -> Self {
        KvCache { layers: vec![LayerCache::default(); layers], kv_dim, len: 0 }
    }

    /// Positions held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no position is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Forgets every position from `len` on (no-op if `len >= self.len()`); the kept positions'
    /// keys and values are untouched, so a sibling branch continues from them.
    pub fn truncate(&mut self, len: usize) {
        if len >= self.len {
            return;
        }
        for layer in &mut self.layers {
            layer.keys.truncate(len * self.kv_dim);
            layer.values.truncate(len * self.kv_dim);
        }
        self.len = len;
    }

    /// Forgets every position (the buffers keep their capacity).
    pub fn clear(&mut self) {
        self.truncate(0);
    }

    /// Bytes held by keys and values.
    pub fn memory_bytes(&self) -> usize {
        self.layers.iter().map(|l| (l.keys.len() + l.values.len()) * std::mem::size_of::<f32>()).sum()
    }

    pub(crate) fn layers_mut(&mut self) -> impl Iterator<Item = &mut LayerCache> {
        self.layers.iter_mut()
    }

    /// Drops whatever a failed forward pass appended after `len` in some layers.
    pub(crate) fn rollback(&mut self, len: usize) {
        for layer in &mut self.layers {
            layer.keys.truncate(len * self.kv_dim);
            layer.values.truncate(len * self.kv_dim);
        }
        self.len = len;
    }

    /// Floats of one position's keys and values over all layers ([`KvCache::copy_position`]).
    pub fn position_len(&self) -> usize {
        self.layers.len() * 2 * self.kv_dim
    }

    /// Appends position `pos`'s keys and values, layer by layer (keys, then values), to `out`.
    pub fn copy_position(&self, pos: usize, out: &mut Vec<f32>) {
        let range = pos * self.kv_dim..(pos + 1) * self.kv_dim;
        for layer in &self.layers {
            out.extend_from_slice(&layer.keys[range.clone()]);
            out.extend_from_slice(&layer.values[range.clone()]);
        }
    }

    /// Appends one position from a row laid out as [`KvCache::copy_position`] writes it.
    pub fn push_position(&mut self, row: &[f32]) {
        debug_assert_eq!(row.len(), self.position_len());
        for (layer, chunk) in self.layers.iter_mut().zip(row.chunks_exact(2 * self.kv_dim)) {
            let (keys, values) = chunk.split_at(self.kv_dim);
            layer.append(keys, values);
        }
        self.len += 1;
    }

    /// Called by the forward pass once every layer has appended the new positions.
    pub(crate) fn set_len(&mut self, len: usize) {
        debug_assert!(self.layers.iter().all(|l| l.keys.len() == len * self.kv_dim));
        self.len = len;
    }
}
