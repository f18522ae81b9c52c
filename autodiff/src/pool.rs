//! [`BufferPool`]: reusable tensor buffers, shared by a tape's values and gradients and by the
//! ops' backward passes (through [`GradSlots`](crate::GradSlots)).
//!
//! Buffers are kept by **size class**: lengths up to [`EXACT_CLASSES_UP_TO`] are their own
//! class; longer ones are rounded up to the next of eight steps per octave (at most 12.5 %
//! more than asked). A tape of fixed shapes (a training step) reuses the same buffers step
//! after step, as with exact lengths; a tape whose shapes vary from call to call (CMF-SIM's
//! decodes on windows of different sizes) reuses buffers of nearby lengths instead of keeping
//! one list per exact length. [`BufferPool::trim`] bounds what an idle pool holds.

use crate::{Float, Shape, Tensor};
use std::collections::HashMap;

/// Lengths up to this many elements are classes of their own.
pub const EXACT_CLASSES_UP_TO: usize = 4096;

/// The size class a request of `n` elements is served from: the smallest class ≥ `n`.
pub fn class_of(n: usize) -> usize {
    if n <= EXACT_CLASSES_UP_TO {
        return n;
    }
    let step = octave_step(n);
    n.div_ceil(step) * step
}

/// The largest class ≤ `n` (a buffer with room for `n` elements serves every request of it).
fn class_below(n: usize) -> usize {
    if n <= EXACT_CLASSES_UP_TO {
        return n;
    }
    let step = octave_step(n);
    n / step * step
}

/// An eighth of the octave `[2^k, 2^(k+1))` that holds `n` (> 4096, so at least 512).
fn octave_step(n: usize) -> usize {
    let k = usize::BITS - 1 - n.leading_zeros();
    1 << (k - 3)
}

/// Reusable buffers keyed by size class (module docs). Buffers handed out by
/// [`BufferPool::zeros`] are zeroed. Every tensor the pool makes starts on a 64-byte boundary
/// (its buffer is a few elements longer than its class; see [`Tensor`]), and tensors put back
/// keep their buffer. Invariant: a buffer kept in class `c` has at least `c` elements, and
/// `c + align_slack` when it came from the pool (so that its tensors start aligned).
#[derive(Default)]
pub struct BufferPool<T> {
    free: HashMap<usize, Vec<Vec<T>>>,
    /// Elements held in `free`.
    free_elements: usize,
    /// Buffers allocated fresh because the pool had none of that class (for benchmarks/tests).
    pub fresh_allocations: usize,
}

impl<T: Float> BufferPool<T> {
    /// A tensor of `shape` in a recycled buffer (contents stale), or in a fresh one of zeros.
    fn recycled(&mut self, shape: Shape) -> (Tensor<T>, bool) {
        let class = class_of(shape.numel());
        match self.free.get_mut(&class).and_then(|v| v.pop()) {
            Some(buf) => {
                self.free_elements -= buf.len();
                (Tensor::in_buffer(shape, buf), true)
            }
            None => {
                self.fresh_allocations += 1;
                let buf = vec![T::zero(); class + crate::tensor::align_slack::<T>()];
                (Tensor::in_buffer(shape, buf), false)
            }
        }
    }

    /// A zeroed tensor of `shape`, reusing a buffer of its size class when one is free.
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

    /// Returns a tensor's buffer for reuse, in the largest class it has room for.
    pub fn put(&mut self, t: Tensor<T>) {
        if t.numel() == 0 {
            return;
        }
        let numel = t.numel();
        let buf = t.into_buffer();
        // A buffer with room to align its tensor keeps that room; one made outside the pool
        // (no slack) serves its class unaligned, which is correct, only slower.
        let room = buf.len().saturating_sub(crate::tensor::align_slack::<T>());
        let class = if room >= numel {
            class_below(room)
        } else {
            class_below(buf.len())
        };
        self.free_elements += buf.len();
        self.free.entry(class).or_default().push(buf);
    }

    /// Bytes the idle buffers hold.
    pub fn free_bytes(&self) -> usize {
        self.free_elements * std::mem::size_of::<T>()
    }

    /// Frees idle buffers, the largest classes first, until at most `max_bytes` are held.
    pub fn trim(&mut self, max_bytes: usize) {
        if self.free_bytes() <= max_bytes {
            return;
        }
        let mut classes: Vec<usize> = self.free.keys().copied().collect();
        classes.sort_unstable_by(|a, b| b.cmp(a));
        let limit = max_bytes / std::mem::size_of::<T>().max(1);
        for class in classes {
            let list = self.free.get_mut(&class).expect("a key of the map");
            while self.free_elements > limit {
                match list.pop() {
                    Some(buf) => self.free_elements -= buf.len(),
                    None => break,
                }
            }
            if list.is_empty() {
                self.free.remove(&class);
            }
            if self.free_elements <= limit {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_class_holds_every_length_up_to_it_within_an_eighth_of_an_octave() {
        for n in (1..=EXACT_CLASSES_UP_TO).chain((4097..300_000).step_by(37)) {
            let c = class_of(n);
            assert!(c >= n && c as f64 <= n as f64 * 1.125, "{n} → {c}");
            assert_eq!(class_of(c), c, "a class is its own class: {n} → {c}");
            assert_eq!(class_below(c), c, "{c}");
            assert!(class_below(n) <= n && class_of(class_below(n)) == class_below(n));
        }
        assert_eq!(class_of(4097), 4608);
        assert_eq!(class_of(8192), 8192);
        assert_eq!(class_of(8193), 9216);
    }

    #[test]
    fn nearby_lengths_share_buffers_and_a_put_buffer_serves_every_request_of_its_class() {
        let mut pool = BufferPool::<f32>::default();
        let a = pool.zeros(Shape::new(&[10_000]));
        pool.put(a);
        let b = pool.uninit(Shape::new(&[9_500]));
        assert_eq!(pool.fresh_allocations, 1, "9 500 and 10 000 share a class");
        assert_eq!(b.numel(), 9_500);
        pool.put(b);
        // A buffer made outside the pool (no slack) goes to a class it fully covers.
        pool.put(Tensor::from_vec([5_000], vec![1.0f32; 5_000]));
        let c = pool.zeros(Shape::new(&[4_600]));
        assert!(c.data().iter().all(|&x| x == 0.0) && c.numel() == 4_600);
        assert_eq!(pool.fresh_allocations, 1, "the 5 000 buffer served 4 600");
    }

    #[test]
    fn trim_frees_the_largest_idle_buffers_first_down_to_the_limit() {
        let mut pool = BufferPool::<f32>::default();
        let sizes = [100, 20_000, 50_000];
        let tensors: Vec<_> = sizes
            .iter()
            .map(|&n| pool.zeros(Shape::new(&[n])))
            .collect();
        tensors.into_iter().for_each(|t| pool.put(t));
        let held = pool.free_bytes();
        assert!(held >= 4 * 70_100, "{held}");
        pool.trim(held);
        assert_eq!(pool.free_bytes(), held, "nothing to free at the limit");
        pool.trim(4 * 30_000);
        assert!(pool.free_bytes() <= 4 * 30_000);
        let before = pool.fresh_allocations;
        let _small = pool.zeros(Shape::new(&[100]));
        let _mid = pool.zeros(Shape::new(&[20_000]));
        assert_eq!(
            pool.fresh_allocations, before,
            "the smaller buffers were kept"
        );
        pool.trim(0);
        assert_eq!(pool.free_bytes(), 0);
    }
}
