//! Named parameters that live outside the tape, and the handles modules keep to them.
//!
//! A module holds [`ParamId`]s, never values. Each step, [`ParamStore::var`] copies a parameter
//! onto the tape as a leaf (one memcpy into a pooled buffer); after backward, the tape's
//! [`param_grads`](crate::Tape::param_grads) are keyed by the same ids, and an optimiser updates the
//! store in place. Frozen parameters are recorded as constants: no gradient, no update.
//!
//! Checkpoints are safetensors files ([`ParamStore::save_safetensors`]): one tensor per
//! parameter, keyed by its name, in the store's float type. Two reserved metadata keys record
//! what the format cannot: `autodiff.params` (the names in insertion order, a JSON array, so ids
//! survive a round trip) and `autodiff.frozen` (the frozen names). Everything else in the
//! metadata is the caller's.

mod io;

pub use io::{read_safetensors, write_safetensors, Loaded, SafetensorsError};

use crate::{Float, Tape, Tensor, Var};
use std::collections::BTreeMap;
use std::path::Path;

/// Metadata key holding the parameter names in insertion order (a JSON array).
pub const ORDER_KEY: &str = "autodiff.params";
/// Metadata key holding the names of frozen parameters (a JSON array).
pub const FROZEN_KEY: &str = "autodiff.frozen";

/// Handle to one parameter of a [`ParamStore`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParamId(pub u32);

struct Entry<T> {
    name: String,
    value: Tensor<T>,
    trainable: bool,
}

/// Named, freezable parameters, in insertion order.
pub struct ParamStore<T: Float = f32> {
    entries: Vec<Entry<T>>,
}

impl<T: Float> Default for ParamStore<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Float> ParamStore<T> {
    /// An empty store.
    pub fn new() -> Self {
        ParamStore {
            entries: Vec::new(),
        }
    }

    /// Adds a trainable parameter. Names are hierarchical (`"cortex.unet.down1.conv0"`) and must
    /// be unique; a duplicate panics.
    #[track_caller]
    pub fn add(&mut self, name: impl Into<String>, init: Tensor<T>) -> ParamId {
        let name = name.into();
        assert!(
            self.find(&name).is_none(),
            "ParamStore::add: duplicate name {name:?}"
        );
        self.entries.push(Entry {
            name,
            value: init,
            trainable: true,
        });
        ParamId(self.entries.len() as u32 - 1)
    }

    /// The id of the parameter called `name`.
    pub fn find(&self, name: &str) -> Option<ParamId> {
        self.entries
            .iter()
            .position(|e| e.name == name)
            .map(|i| ParamId(i as u32))
    }

    /// Number of parameters (tensors, not scalars).
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Total number of scalars over all parameters.
    pub fn numel(&self) -> usize {
        self.entries.iter().map(|e| e.value.numel()).sum()
    }

    /// All ids, in insertion order.
    pub fn ids(&self) -> impl Iterator<Item = ParamId> + '_ {
        (0..self.entries.len() as u32).map(ParamId)
    }

    /// The name of `id`.
    pub fn name(&self, id: ParamId) -> &str {
        &self.entries[id.0 as usize].name
    }

    /// The value of `id`.
    pub fn get(&self, id: ParamId) -> &Tensor<T> {
        &self.entries[id.0 as usize].value
    }

    /// The value of `id`, mutable (optimisers, re-normalisation, loading).
    pub fn get_mut(&mut self, id: ParamId) -> &mut Tensor<T> {
        &mut self.entries[id.0 as usize].value
    }

    /// Whether `id` receives updates.
    pub fn is_trainable(&self, id: ParamId) -> bool {
        self.entries[id.0 as usize].trainable
    }

    /// Stops `id` from receiving gradients and updates.
    pub fn freeze(&mut self, id: ParamId) {
        self.entries[id.0 as usize].trainable = false;
    }

    /// Lets `id` receive gradients and updates again.
    pub fn unfreeze(&mut self, id: ParamId) {
        self.entries[id.0 as usize].trainable = true;
    }

    /// Records parameter `id` on `tape` (a gradient leaf when trainable, else a constant).
    pub fn var(&self, tape: &mut Tape<T>, id: ParamId) -> Var {
        let e = &self.entries[id.0 as usize];
        tape.param_leaf(id, &e.value, e.trainable)
    }
}

impl<T: Float> ParamStore<T> {
    /// Writes every parameter to `path` (atomically), with the caller's `metadata` plus the
    /// reserved keys [`ORDER_KEY`] and [`FROZEN_KEY`].
    pub fn save_safetensors(
        &self,
        path: impl AsRef<Path>,
        metadata: &BTreeMap<String, String>,
    ) -> Result<(), SafetensorsError> {
        let mut meta = metadata.clone();
        let names: Vec<&str> = self.entries.iter().map(|e| e.name.as_str()).collect();
        let frozen: Vec<&str> = self
            .entries
            .iter()
            .filter(|e| !e.trainable)
            .map(|e| e.name.as_str())
            .collect();
        meta.insert(
            ORDER_KEY.into(),
            serde_json::to_string(&names).expect("names serialise"),
        );
        meta.insert(
            FROZEN_KEY.into(),
            serde_json::to_string(&frozen).expect("names serialise"),
        );
        let tensors: Vec<(&str, &Tensor<T>)> = self
            .entries
            .iter()
            .map(|e| (e.name.as_str(), &e.value))
            .collect();
        write_safetensors(path.as_ref(), &tensors, &meta)
    }

    /// A new store from a safetensors file, with the caller's metadata (reserved keys removed).
    /// Parameters keep the order and frozen flags recorded by [`ParamStore::save_safetensors`];
    /// a file written elsewhere (PyTorch) loads in name order, all trainable.
    pub fn load_safetensors(
        path: impl AsRef<Path>,
    ) -> Result<(ParamStore<T>, BTreeMap<String, String>), SafetensorsError> {
        let path = path.as_ref();
        let Loaded {
            mut tensors,
            mut metadata,
        } = read_safetensors::<T>(path)?;
        let list = |meta: &mut BTreeMap<String, String>,
                    key: &str|
         -> Result<Option<Vec<String>>, SafetensorsError> {
            meta.remove(key)
                .map(|v| serde_json::from_str(&v))
                .transpose()
                .map_err(|e| SafetensorsError::Metadata {
                    path: path.into(),
                    key: key.into(),
                    reason: e.to_string(),
                })
        };
        let order =
            list(&mut metadata, ORDER_KEY)?.unwrap_or_else(|| tensors.keys().cloned().collect());
        let frozen = list(&mut metadata, FROZEN_KEY)?.unwrap_or_default();
        let mut store = ParamStore::new();
        for name in order {
            let value = tensors
                .remove(&name)
                .ok_or_else(|| SafetensorsError::Missing {
                    path: path.into(),
                    name: name.clone(),
                })?;
            let id = store.add(name.clone(), value);
            if frozen.contains(&name) {
                store.freeze(id);
            }
        }
        if let Some(name) = tensors.into_keys().next() {
            return Err(SafetensorsError::Unexpected {
                path: path.into(),
                name,
            });
        }
        Ok((store, metadata))
    }

    /// Overwrites every parameter's value from a safetensors file (names must match one to
    /// one, shapes exactly); frozen flags are left as they are. Returns the caller's metadata.
    /// On error the store is unchanged.
    pub fn load_into(
        &mut self,
        path: impl AsRef<Path>,
    ) -> Result<BTreeMap<String, String>, SafetensorsError> {
        let path = path.as_ref();
        let Loaded {
            mut tensors,
            mut metadata,
        } = read_safetensors::<T>(path)?;
        for e in &self.entries {
            let t = tensors
                .get(&e.name)
                .ok_or_else(|| SafetensorsError::Missing {
                    path: path.into(),
                    name: e.name.clone(),
                })?;
            if t.shape() != e.value.shape() {
                return Err(SafetensorsError::Shape {
                    path: path.into(),
                    name: e.name.clone(),
                    found: t.dims().to_vec(),
                    expected: e.value.dims().to_vec(),
                });
            }
        }
        if let Some(name) = tensors.keys().find(|n| self.find(n).is_none()) {
            return Err(SafetensorsError::Unexpected {
                path: path.into(),
                name: name.clone(),
            });
        }
        for e in &mut self.entries {
            e.value = tensors.remove(&e.name).expect("checked above");
        }
        metadata.remove(ORDER_KEY);
        metadata.remove(FROZEN_KEY);
        Ok(metadata)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("autodiff-params-{}-{name}", std::process::id()))
    }

    fn store() -> ParamStore<f32> {
        let mut s = ParamStore::new();
        s.add(
            "z.last",
            Tensor::from_fn([3, 2], |i| (i as f32 * 0.7).sin() / 3.0),
        );
        let f = s.add("a.first", Tensor::from_vec([2], vec![f32::EPSILON, -1e-30]));
        s.add("m.bias", Tensor::scalar(0.1));
        s.freeze(f);
        s
    }

    #[test]
    fn save_load_round_trip_keeps_order_flags_and_bits() {
        let (s, p) = (store(), tmp("rt.safetensors"));
        let meta = BTreeMap::from([("note".to_string(), "x".to_string())]);
        s.save_safetensors(&p, &meta).unwrap();
        let (back, m) = ParamStore::<f32>::load_safetensors(&p).unwrap();
        assert_eq!(m, meta);
        assert_eq!(back.len(), s.len());
        for id in s.ids() {
            assert_eq!(back.name(id), s.name(id));
            assert_eq!(back.is_trainable(id), s.is_trainable(id));
            let bits = |t: &Tensor<f32>| t.data().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(back.get(id)), bits(s.get(id)));
        }
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn load_into_rejects_shape_mismatch_naming_file_and_tensor() {
        let (s, p) = (store(), tmp("shape.safetensors"));
        s.save_safetensors(&p, &BTreeMap::new()).unwrap();
        let mut other = ParamStore::<f32>::new();
        other.add("z.last", Tensor::zeros([2, 3]));
        other.add("a.first", Tensor::zeros([2]));
        other.add("m.bias", Tensor::zeros([]));
        let err = other.load_into(&p).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, SafetensorsError::Shape { .. }), "{text}");
        assert!(
            text.contains("shape.safetensors") && text.contains("\"z.last\""),
            "{text}"
        );
        assert!(
            other.get(ParamId(1)).data().iter().all(|&v| v == 0.0),
            "store unchanged on error"
        );
        let mut fewer = ParamStore::<f32>::new();
        fewer.add("z.last", Tensor::zeros([3, 2]));
        assert!(matches!(
            fewer.load_into(&p),
            Err(SafetensorsError::Unexpected { .. })
        ));
        std::fs::remove_file(&p).unwrap();
    }
}
