//! Writing named tensors as safetensors, streamed: the header is built from the shapes, then
//! each tensor's little-endian bytes go out through one buffered writer. A write holds that
//! buffer (1 MiB) and a small block of converted values, never a copy of the tensors — Adam's
//! two moments alone are a gigabyte at the top of `cortex.p.hidden`'s range.
//!
//! The bytes are those of the `safetensors` crate's `serialize` with the JSON header's keys
//! sorted (the crate writes `__metadata__` from a hash map, in a different order each run): the
//! tensors' data in name order from offset 0 (one dtype a file), the header
//! `{"__metadata__": {…}, name: {"data_offsets": [begin, end], "dtype", "shape"}, …}` (no
//! `__metadata__` when there is none) padded with spaces to a multiple of 8 bytes, after its
//! length as a little-endian u64. Tested against the crate's own serialisation.

use super::{SafetensorsError, Tensor};
use crate::Float;
use serde_json::{json, Map, Value};
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Values converted to bytes at a time.
const BLOCK_VALUES: usize = 16 * 1024;

/// Whether `T` is written as F64 (else F32), and its bytes a value.
fn wide<T: Float>() -> (bool, usize) {
    match T::DTYPE == "f64" {
        true => (true, 8),
        false => (false, 4),
    }
}

/// Writes `tensors` (name, value) and string `metadata` to `path`, atomically
/// ([`atomic_io::write_via`]).
pub fn write_safetensors<T: Float>(
    path: &Path,
    tensors: &[(&str, &Tensor<T>)],
    metadata: &BTreeMap<String, String>,
) -> Result<(), SafetensorsError> {
    let mut order: Vec<(&str, &Tensor<T>)> = tensors.to_vec();
    order.sort_by(|a, b| a.0.cmp(b.0));
    if let Some(w) = order.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(SafetensorsError::Format {
            path: path.to_path_buf(),
            reason: format!("tensor {:?} is named twice", w[0].0),
        });
    }
    let header = header(&order, metadata);
    atomic_io::write_via(path, |tmp| {
        let io = |source| SafetensorsError::Io {
            path: tmp.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(tmp).map_err(io)?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        out.write_all(&header).map_err(io)?;
        let (wide, size) = wide::<T>();
        let mut block = Vec::with_capacity(BLOCK_VALUES * size);
        for (_, t) in &order {
            for values in t.data().chunks(BLOCK_VALUES) {
                block.clear();
                for x in values {
                    match wide {
                        true => block.extend_from_slice(&x.as_f64().to_le_bytes()),
                        false => block.extend_from_slice(&(x.as_f64() as f32).to_le_bytes()),
                    }
                }
                out.write_all(&block).map_err(io)?;
            }
        }
        out.flush().map_err(io)
    })
}

/// The header's length (u64, little-endian) and its JSON, padded to a multiple of 8 bytes.
fn header<T: Float>(order: &[(&str, &Tensor<T>)], metadata: &BTreeMap<String, String>) -> Vec<u8> {
    let (wide, size) = wide::<T>();
    let dtype = if wide { "F64" } else { "F32" };
    let mut map = Map::new();
    if !metadata.is_empty() {
        let meta = metadata
            .iter()
            .map(|(k, v)| (k.clone(), Value::String(v.clone())))
            .collect();
        map.insert("__metadata__".into(), Value::Object(meta));
    }
    let mut offset = 0;
    for (name, t) in order {
        let end = offset + t.numel() * size;
        let info = json!({"dtype": dtype, "shape": t.dims(), "data_offsets": [offset, end]});
        map.insert(name.to_string(), info);
        offset = end;
    }
    let mut text = Value::Object(map).to_string();
    while !text.len().is_multiple_of(8) {
        text.push(' ');
    }
    let mut out = Vec::with_capacity(8 + text.len());
    out.extend_from_slice(&(text.len() as u64).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out
}
