//! [`BufferPool`]: reusable tensor buffers keyed by length, shared by a tape's values and
//! gradients and by the ops' backward passes (through [`GradSlots`](crate::GradSlots)).

use crate::{Float, Shape, Tensor};
use std::collections::HashMap;

/// Reusable buffers keyed by tensor length. Buffers handed out by [`BufferPool::zeros`] are
/// zeroed. Every tensor the pool makes starts on a 64-byte boundary (its buffer is a few
/// elements longer than the tensor; see [`Tensor`]), and tensors put back keep their buffer.
#[derive(Default)]
pub struct BufferPool<T> {
    free: HashMap<usize, Vec<Vec<T>>>,
    /// Buffers allocated fresh because the pool had none of that length (for benchmarks/tests).
    pub fresh_allocations: usize,
}

impl<T: Float> BufferPool<T> {
    /// A tensor of `shape` in a recycled buffer (contents stale), or in a fresh one of zeros.
    fn recycled(&mut self, shape: Shape) -> (Tensor<T>, bool) {
        let n = shape.numel();
        match self.free.get_mut(&n).and_then(|v| v.pop()) {
            Some(buf) => (Tensor::in_buffer(shape, buf), true),
            None => {
                self.fresh_allocations += 1;
                let buf = vec![T::zero(); n + crate::tensor::align_slack::<T>()];
                (Tensor::in_buffer(shape, buf), false)
            }
        }
    }

    /// A zeroed tensor of `shape`, reusing a buffer of the same length when one is free.
    pub fn zeros(&mut self, shape: Shape) -> Tensor<T> {
        let (mut t, stale) = self.recycled(shape);
        if stale {
            t.fill_zero();
        }
        t
    }

    /// A tensor of `shape` whose contents are unspecified (stale values of a recycled buffer, or
    /// zeros when freshly allocated): for callers that overwrite every element.
    pub fn uninit(&mut self, shape: Shape) -> Tensor<T> {
        self.recycled(shape).0
    }

    /// A tensor of `shape` holding a copy of `data`.
    #[track_caller]
    pub fn copy_of(&mut self, shape: Shape, data: &[T]) -> Tensor<T> {
        assert_eq!(
            shape.numel(),
            data.len(),
            "BufferPool::copy_of: {shape:?} vs {} values",
            data.len()
        );
        let mut t = self.recycled(shape).0;
        t.data_mut().copy_from_slice(data);
        t
    }

    /// Returns a tensor's buffer for reuse.
    pub fn put(&mut self, t: Tensor<T>) {
        let n = t.numel();
        let buf = t.into_buffer();
        if n > 0 {
            self.free.entry(n).or_default().push(buf);
        }
    }
}
