//! [`ParamGrads`]: one gradient-like tensor per parameter, what a learning rule hands to an
//! optimiser.
//!
//! Sign convention: an entry is `∂L/∂θ` (or whatever a rule uses in its place); optimisers
//! *subtract* it. Buffers are kept across steps: [`ParamGrads::clear`] only marks entries empty,
//! and the next [`ParamGrads::accumulate`] copies into the old buffer, so a training loop does
//! not allocate after its first step.

use crate::{Float, ParamId, Tape, Tensor};
use std::collections::BTreeMap;

struct Slot<T> {
    grad: Tensor<T>,
    live: bool,
}

/// Gradients keyed by [`ParamId`], in id order.
pub struct ParamGrads<T: Float = f32> {
    slots: BTreeMap<ParamId, Slot<T>>,
}

impl<T: Float> Default for ParamGrads<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Float> ParamGrads<T> {
    /// No gradients.
    pub fn new() -> Self {
        ParamGrads {
            slots: BTreeMap::new(),
        }
    }

    /// The parameter gradients of the tape's last backward (a parameter recorded twice gets
    /// the sum of both leaves' gradients).
    pub fn from_tape(tape: &Tape<T>) -> Self {
        let mut g = Self::new();
        g.fill_from_tape(tape);
        g
    }

    /// Replaces the contents with the tape's parameter gradients, reusing buffers.
    pub fn fill_from_tape(&mut self, tape: &Tape<T>) {
        self.clear();
        for (id, g) in tape.param_grads() {
            self.accumulate(id, g);
        }
    }

    /// Marks every entry empty (buffers are kept for reuse).
    pub fn clear(&mut self) {
        self.slots.values_mut().for_each(|s| s.live = false);
    }

    /// Adds `g` to the entry of `id` (copying into a kept buffer when the entry is empty).
    #[track_caller]
    pub fn accumulate(&mut self, id: ParamId, g: &Tensor<T>) {
        match self.slots.get_mut(&id) {
            Some(s) if s.live => {
                assert_eq!(
                    s.grad.shape(),
                    g.shape(),
                    "ParamGrads::accumulate: {id:?} shape"
                );
                s.grad
                    .data_mut()
                    .iter_mut()
                    .zip(g.data())
                    .for_each(|(a, &b)| *a += b);
            }
            Some(s) if s.grad.shape() == g.shape() => {
                s.grad.data_mut().copy_from_slice(g.data());
                s.live = true;
            }
            _ => {
                self.slots.insert(
                    id,
                    Slot {
                        grad: g.clone(),
                        live: true,
                    },
                );
            }
        }
    }

    /// Sets the entry of `id` to `g`.
    pub fn insert(&mut self, id: ParamId, g: Tensor<T>) {
        self.slots.insert(
            id,
            Slot {
                grad: g,
                live: true,
            },
        );
    }

    /// Empties the entry of `id`; the optimiser then skips it.
    pub fn remove(&mut self, id: ParamId) {
        if let Some(s) = self.slots.get_mut(&id) {
            s.live = false;
        }
    }

    /// The gradient of `id`, if present.
    pub fn get(&self, id: ParamId) -> Option<&Tensor<T>> {
        self.slots.get(&id).filter(|s| s.live).map(|s| &s.grad)
    }

    /// The gradient of `id`, mutable (scaling, clipping, masking).
    pub fn get_mut(&mut self, id: ParamId) -> Option<&mut Tensor<T>> {
        self.slots
            .get_mut(&id)
            .filter(|s| s.live)
            .map(|s| &mut s.grad)
    }

    /// `(id, gradient)` of every present entry, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (ParamId, &Tensor<T>)> {
        self.slots
            .iter()
            .filter(|(_, s)| s.live)
            .map(|(&id, s)| (id, &s.grad))
    }

    /// Number of present entries.
    pub fn len(&self) -> usize {
        self.slots.values().filter(|s| s.live).count()
    }

    /// True when no entry is present.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Multiplies every present entry by `c`.
    pub fn scale(&mut self, c: f64) {
        let c = T::of(c);
        for s in self.slots.values_mut().filter(|s| s.live) {
            s.grad.data_mut().iter_mut().for_each(|v| *v *= c);
        }
    }

    /// `√(Σ‖g‖²)` over all present entries, in f64.
    pub fn global_norm(&self) -> f64 {
        self.iter().map(|(_, g)| g.sum_sq()).sum::<f64>().sqrt()
    }

    /// Scales all entries so the global norm is at most `max_norm`; returns the norm before.
    pub fn clip_global_norm(&mut self, max_norm: f64) -> f64 {
        let n = self.global_norm();
        if n > max_norm && n > 0.0 {
            self.scale(max_norm / n);
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accumulate_reuses_and_sums() {
        let mut g = ParamGrads::<f32>::new();
        let id = ParamId(3);
        g.accumulate(id, &Tensor::full([2], 1.0));
        g.accumulate(id, &Tensor::full([2], 2.0));
        assert_eq!(g.get(id).unwrap().data(), &[3.0, 3.0]);
        let ptr = g.get(id).unwrap().data().as_ptr();
        g.clear();
        assert!(g.get(id).is_none() && g.is_empty());
        g.accumulate(id, &Tensor::full([2], 5.0));
        assert_eq!(g.get(id).unwrap().data(), &[5.0, 5.0]);
        assert_eq!(g.get(id).unwrap().data().as_ptr(), ptr, "buffer reused");
    }

    #[test]
    fn clipping_bounds_the_global_norm() {
        let mut g = ParamGrads::<f64>::new();
        g.insert(ParamId(0), Tensor::from_vec([2], vec![3.0, 0.0]));
        g.insert(ParamId(1), Tensor::from_vec([1], vec![4.0]));
        assert_eq!(g.clip_global_norm(1.0), 5.0);
        assert!((g.global_norm() - 1.0).abs() < 1e-12);
        assert!((g.get(ParamId(1)).unwrap().data()[0] - 0.8).abs() < 1e-12);
    }
}
