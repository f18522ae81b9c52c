//! Reading and writing named tensors as [safetensors](https://huggingface.co/docs/safetensors):
//! an 8-byte little-endian header length, a JSON header (`name → dtype, shape, offsets`, plus a
//! string-to-string `__metadata__`), then the raw little-endian data. PyTorch
//! (`safetensors.torch.load_file`) and NumPy (`safetensors.numpy.load_file`) open these files.
//!
//! - Tensors are written with the dtype of the tape's float (`F32` or `F64`). Reading accepts
//!   both and converts to the requested float (f32 → f64 is exact; f64 → f32 rounds). Same-dtype
//!   round trips are bit-exact.
//! - Writes are streamed (`write`: no copy of the tensors is made) and atomic
//!   ([`atomic_io::write_via`]): the bytes go to a temporary file in the same directory,
//!   synced, then renamed over the target, so a crash never leaves a half-written checkpoint.
//! - Every error names the file, and the tensor when one is involved.

mod write;

pub use write::write_safetensors;

use crate::tensor::MAX_RANK;
use crate::{Float, Shape, Tensor};
use safetensors::tensor::{Dtype, SafeTensors, TensorView};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What went wrong reading or writing a safetensors file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SafetensorsError {
    /// The file could not be read, written or renamed.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The bytes are not a valid safetensors file (truncated, bad header, bad offsets).
    #[error("{path}: not a valid safetensors file: {reason}")]
    Format { path: PathBuf, reason: String },
    /// A tensor has a dtype other than F32/F64.
    #[error("{path}: tensor {name:?} has dtype {dtype}, expected F32 or F64")]
    Dtype {
        path: PathBuf,
        name: String,
        dtype: String,
    },
    /// A tensor has more axes than a [`Shape`] holds.
    #[error("{path}: tensor {name:?} has rank {rank}, at most {MAX_RANK} is supported")]
    Rank {
        path: PathBuf,
        name: String,
        rank: usize,
    },
    /// A tensor's shape differs from the parameter it should load into.
    #[error("{path}: tensor {name:?} has shape {found:?}, expected {expected:?}")]
    Shape {
        path: PathBuf,
        name: String,
        found: Vec<usize>,
        expected: Vec<usize>,
    },
    /// A tensor that should be in the file is not.
    #[error("{path}: tensor {name:?} is missing")]
    Missing { path: PathBuf, name: String },
    /// The file holds a tensor nothing asked for.
    #[error("{path}: unexpected tensor {name:?}")]
    Unexpected { path: PathBuf, name: String },
    /// A metadata entry is missing or cannot be parsed.
    #[error("{path}: metadata {key:?}: {reason}")]
    Metadata {
        path: PathBuf,
        key: String,
        reason: String,
    },
}

impl From<atomic_io::FileError> for SafetensorsError {
    fn from(e: atomic_io::FileError) -> Self {
        SafetensorsError::Io {
            path: e.path,
            source: e.source,
        }
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> SafetensorsError + '_ {
    move |source| SafetensorsError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Named tensors and the string metadata of a safetensors file.
pub struct Loaded<T> {
    /// Tensors by name.
    pub tensors: BTreeMap<String, Tensor<T>>,
    /// The `__metadata__` map (empty when absent).
    pub metadata: BTreeMap<String, String>,
}

/// Reads every tensor of `path`, converted to `T`.
pub fn read_safetensors<T: Float>(path: &Path) -> Result<Loaded<T>, SafetensorsError> {
    let buf = std::fs::read(path).map_err(io_err(path))?;
    let format = |e: safetensors::SafeTensorError| SafetensorsError::Format {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let (_, meta) = SafeTensors::read_metadata(&buf).map_err(format)?;
    let st = SafeTensors::deserialize(&buf).map_err(format)?;
    let mut tensors = BTreeMap::new();
    for (name, view) in st.iter() {
        tensors.insert(name.to_string(), from_view(path, name, &view)?);
    }
    let metadata = meta
        .metadata()
        .clone()
        .unwrap_or_default()
        .into_iter()
        .collect();
    Ok(Loaded { tensors, metadata })
}

fn from_view<T: Float>(
    path: &Path,
    name: &str,
    v: &TensorView<'_>,
) -> Result<Tensor<T>, SafetensorsError> {
    if v.shape().len() > MAX_RANK {
        return Err(SafetensorsError::Rank {
            path: path.into(),
            name: name.into(),
            rank: v.shape().len(),
        });
    }
    let shape = Shape::new(v.shape());
    let data: Vec<T> = match v.dtype() {
        Dtype::F32 => v
            .data()
            .chunks_exact(4)
            .map(|c| T::of(f32::from_le_bytes(c.try_into().unwrap()) as f64))
            .collect(),
        Dtype::F64 => v
            .data()
            .chunks_exact(8)
            .map(|c| T::of(f64::from_le_bytes(c.try_into().unwrap())))
            .collect(),
        other => {
            return Err(SafetensorsError::Dtype {
                path: path.into(),
                name: name.into(),
                dtype: format!("{other:?}"),
            })
        }
    };
    if data.len() != shape.numel() {
        return Err(SafetensorsError::Format {
            path: path.into(),
            reason: format!("tensor {name:?}: {} values for shape {shape:?}", data.len()),
        });
    }
    Ok(Tensor::from_vec(shape, data))
}

#[cfg(test)]
mod tests {
    use super::*;
    use safetensors::tensor::View;
    use std::borrow::Cow;
    use std::collections::HashMap;

    // The reference the streamed writer is tested against: the `safetensors` crate's own
    // serialisation of the tensors' bytes, with the header's keys sorted.
    /// Little-endian bytes of one tensor, in the file's dtype.
    struct Bytes {
        dtype: Dtype,
        shape: Vec<usize>,
        data: Vec<u8>,
    }

    impl View for &Bytes {
        fn dtype(&self) -> Dtype {
            self.dtype
        }
        fn shape(&self) -> &[usize] {
            &self.shape
        }
        fn data(&self) -> Cow<'_, [u8]> {
            Cow::Borrowed(&self.data)
        }
        fn data_len(&self) -> usize {
            self.data.len()
        }
    }

    fn to_bytes<T: Float>(t: &Tensor<T>) -> Bytes {
        let data = if T::DTYPE == "f64" {
            t.data()
                .iter()
                .flat_map(|x| x.as_f64().to_le_bytes())
                .collect()
        } else {
            t.data()
                .iter()
                .flat_map(|x| (x.as_f64() as f32).to_le_bytes())
                .collect()
        };
        let dtype = if T::DTYPE == "f64" {
            Dtype::F64
        } else {
            Dtype::F32
        };
        Bytes {
            dtype,
            shape: t.dims().to_vec(),
            data,
        }
    }

    /// Writes `tensors` (name, value) and string `metadata` to `path`, atomically.
    fn crate_bytes<T: Float>(
        tensors: &[(&str, &Tensor<T>)],
        metadata: &BTreeMap<String, String>,
    ) -> Vec<u8> {
        let bytes: Vec<(&str, Bytes)> = tensors.iter().map(|(n, t)| (*n, to_bytes(t))).collect();
        let info: HashMap<String, String> = metadata.clone().into_iter().collect();
        let buf = safetensors::tensor::serialize(
            bytes.iter().map(|(n, b)| (*n, b)),
            if info.is_empty() { None } else { Some(info) },
        )
        .expect("the crate serialises");
        canonical_header(buf).expect("the crate's header is JSON")
    }

    /// Rewrites the JSON header of serialised safetensors bytes with its keys sorted.
    fn canonical_header(buf: Vec<u8>) -> Result<Vec<u8>, String> {
        let n = buf
            .get(..8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")) as usize)
            .ok_or("shorter than its 8-byte header length")?;
        let header = buf.get(8..8 + n).ok_or("header longer than the file")?;
        let value: serde_json::Value =
            serde_json::from_slice(header).map_err(|e| format!("header: {e}"))?;
        let mut text = serde_json::to_string(&value).map_err(|e| format!("header: {e}"))?;
        while text.len() % 8 != 0 {
            text.push(' ');
        }
        let mut out = Vec::with_capacity(8 + text.len() + buf.len() - 8 - n);
        out.extend_from_slice(&(text.len() as u64).to_le_bytes());
        out.extend_from_slice(text.as_bytes());
        out.extend_from_slice(&buf[8 + n..]);
        Ok(out)
    }

    fn tmp(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("autodiff-io-{}-{name}", std::process::id()))
    }

    #[test]
    fn round_trip_is_bit_exact_and_converts_dtypes() {
        let p = tmp("rt.safetensors");
        let a = Tensor::from_vec([2, 2], vec![1.0f32, -0.0, f32::MIN_POSITIVE, 1.0 / 3.0]);
        let s = Tensor::scalar(std::f32::consts::PI);
        let meta = BTreeMap::from([("step".to_string(), "7".to_string())]);
        write_safetensors(&p, &[("a", &a), ("s", &s)], &meta).unwrap();
        let back = read_safetensors::<f32>(&p).unwrap();
        let bits = |t: &Tensor<f32>| t.data().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.tensors["a"]), bits(&a));
        assert_eq!(back.tensors["s"].shape(), Shape::scalar());
        assert_eq!(back.metadata, meta);
        let wide = read_safetensors::<f64>(&p).unwrap();
        assert_eq!(wide.tensors["a"].data()[3], (1.0f32 / 3.0) as f64);
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn truncated_file_is_a_format_error_naming_the_file() {
        let p = tmp("trunc.safetensors");
        write_safetensors(&p, &[("w", &Tensor::<f64>::zeros([3]))], &BTreeMap::new()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 5]).unwrap();
        let err = read_safetensors::<f64>(&p).err().expect("must fail");
        assert!(matches!(err, SafetensorsError::Format { .. }), "{err}");
        assert!(err.to_string().contains("trunc.safetensors"), "{err}");
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn the_same_tensors_and_metadata_give_the_same_bytes() {
        let t = Tensor::from_vec([2], vec![1.0f32, -2.0]);
        let meta: BTreeMap<String, String> = (0..12)
            .map(|i| (format!("key{i}"), i.to_string()))
            .collect();
        let (a, b) = (tmp("canon_a"), tmp("canon_b"));
        write_safetensors(&a, &[("t", &t), ("u", &t)], &meta).unwrap();
        write_safetensors(&b, &[("t", &t), ("u", &t)], &meta).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        let back = read_safetensors::<f32>(&a).unwrap();
        assert_eq!(back.metadata, meta);
        assert_eq!(back.tensors["u"].data(), t.data());
        let _ = std::fs::remove_file(a);
        let _ = std::fs::remove_file(b);
    }

    fn streamed_and_crate_bytes<T: Float>(
        shapes: &[Vec<usize>],
        names: &[String],
        metadata: &BTreeMap<String, String>,
        file: &str,
    ) -> (Vec<u8>, Vec<u8>) {
        let tensors: Vec<Tensor<T>> = shapes
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let n = s.iter().product::<usize>();
                let v = (0..n)
                    .map(|j| T::of((i * 31 + j) as f64 / 7.0 - 3.0))
                    .collect();
                Tensor::from_vec(Shape::new(s), v)
            })
            .collect();
        let named: Vec<(&str, &Tensor<T>)> =
            names.iter().map(|n| n.as_str()).zip(&tensors).collect();
        let p = tmp(file);
        write_safetensors(&p, &named, metadata).unwrap();
        let streamed = std::fs::read(&p).unwrap();
        std::fs::remove_file(&p).unwrap();
        (streamed, crate_bytes(&named, metadata))
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
        /// The streamed writer gives the crate's bytes, for any names (as a set), shapes (up
        /// to rank 3, empty ones included), metadata and dtype.
        #[test]
        fn the_streamed_file_is_the_crates_serialisation(
            shapes in proptest::collection::vec(proptest::collection::vec(0usize..5, 0..4), 1..6),
            names in proptest::collection::btree_set("[a-z_.]{1,8}", 6),
            metadata in proptest::collection::btree_map("[a-z]{1,6}", "[ -~]{0,10}", 0..4),
            wide in proptest::bool::ANY,
        ) {
            let names: Vec<String> = names.into_iter().rev().take(shapes.len()).collect();
            let (streamed, reference) = match wide {
                true => streamed_and_crate_bytes::<f64>(&shapes, &names, &metadata, "prop64"),
                false => streamed_and_crate_bytes::<f32>(&shapes, &names, &metadata, "prop32"),
            };
            proptest::prop_assert!(streamed == reference, "{} vs {} bytes", streamed.len(), reference.len());
        }
    }

    #[test]
    fn a_name_given_twice_is_refused_naming_the_file() {
        let p = tmp("twice.safetensors");
        let t = Tensor::from_vec([1], vec![1.0f32]);
        let err = write_safetensors(&p, &[("w", &t), ("w", &t)], &BTreeMap::new()).unwrap_err();
        assert!(
            err.to_string().contains("twice.safetensors") && err.to_string().contains("\"w\""),
            "{err}"
        );
        assert!(!p.exists());
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let err = read_safetensors::<f32>(Path::new("/nonexistent/x.safetensors"))
            .err()
            .unwrap();
        assert!(
            matches!(err, SafetensorsError::Io { .. })
                && err.to_string().contains("/nonexistent/x")
        );
    }
}
