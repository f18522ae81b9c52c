//! Named parameters that live outside the tape, and the handles modules keep to them.
//!
//! A module holds [`ParamId`]s, never values. Each step, [`ParamStore::var`] copies a parameter
//! onto the tape as a leaf (one memcpy into a pooled buffer); after backward, the tape's
//! [`param_grads`](crate::Tape::param_grads) are keyed by the same ids, and an optimiser updates the
//! store in place. Frozen parameters are recorded as constants: no gradient, no update.

use crate::{Float, Tape, Tensor, Var};

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
        ParamStore { entries: Vec::new() }
    }

    /// Adds a trainable parameter. Names are hierarchical (`"cortex.unet.down1.conv0"`) and must
    /// be unique; a duplicate panics.
    #[track_caller]
    pub fn add(&mut self, name: impl Into<String>, init: Tensor<T>) -> ParamId {
        let name = name.into();
        assert!(self.find(&name).is_none(), "ParamStore::add: duplicate name {name:?}");
        self.entries.push(Entry { name, value: init, trainable: true });
        ParamId(self.entries.len() as u32 - 1)
    }

    /// The id of the parameter called `name`.
    pub fn find(&self, name: &str) -> Option<ParamId> {
        self.entries.iter().position(|e| e.name == name).map(|i| ParamId(i as u32))
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
