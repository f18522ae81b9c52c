//! Scratch buffers of the conv kernels: vectors borrowed from a process-wide stash and
//! returned on drop, so that kernels running on rayon workers reuse the same (already touched)
//! pages every step instead of allocating per call (on this project's VMs, freed memory
//! touched again costs page faults).

use crate::tensor::{align_slack, aligned_start};
use crate::Float;
use std::any::Any;
use std::sync::Mutex;

/// The stash: vectors of any float type, at most [`STASH_MAX`] (more are freed on drop).
static STASH: Mutex<Vec<Box<dyn Any + Send>>> = Mutex::new(Vec::new());
const STASH_MAX: usize = 64;

/// A scratch vector borrowed from the stash; returned on drop. Contents are unspecified
/// unless taken with [`Scratch::zeroed`]. The slice starts on a 64-byte boundary (its vector
/// is [`align_slack`] elements longer; see [`crate::Tensor`]), so the strips the kernels read
/// whole vectors from are cache-line aligned like the tensors.
pub(crate) struct Scratch<T: Float> {
    buf: Vec<T>,
    start: usize,
    len: usize,
}

impl<T: Float> Scratch<T> {
    /// A scratch slice of `len` elements with unspecified contents.
    pub fn take(len: usize) -> Self {
        if len == 0 {
            return Scratch {
                buf: Vec::new(),
                start: 0,
                len,
            };
        }
        let want = len + align_slack::<T>();
        let mut stash = STASH.lock().unwrap_or_else(|e| e.into_inner());
        let mut best: Option<(usize, usize)> = None;
        for (i, b) in stash.iter().enumerate() {
            if let Some(v) = b.downcast_ref::<Vec<T>>() {
                if v.len() >= want && best.is_none_or(|(_, l)| v.len() < l) {
                    best = Some((i, v.len()));
                }
            }
        }
        let buf = match best {
            Some((i, _)) => *stash
                .swap_remove(i)
                .downcast::<Vec<T>>()
                .expect("type checked"),
            None => vec![T::zero(); want],
        };
        let start = aligned_start(&buf, len);
        Scratch { buf, start, len }
    }

    /// A scratch slice of `len` zeros.
    pub fn zeroed(len: usize) -> Self {
        let mut s = Self::take(len);
        s.fill(T::zero());
        s
    }
}

impl<T: Float> std::ops::Deref for Scratch<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl<T: Float> std::ops::DerefMut for Scratch<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

impl<T: Float> Drop for Scratch<T> {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.buf);
        if buf.is_empty() {
            return;
        }
        let mut stash = STASH.lock().unwrap_or_else(|e| e.into_inner());
        if stash.len() < STASH_MAX {
            stash.push(Box::new(buf));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scratch slices start on a cache line, also when the stash hands back a longer buffer.
    #[test]
    fn scratch_slices_are_cache_line_aligned() {
        for len in [1, 15, 4096, 100_003, 7] {
            let a = Scratch::<f32>::take(len);
            let b = Scratch::<f64>::zeroed(len);
            assert_eq!((a.len(), b.len()), (len, len));
            assert!(b.iter().all(|&v| v == 0.0));
            for p in [a.as_ptr() as usize, b.as_ptr() as usize] {
                assert!(p.is_multiple_of(64), "scratch of {len} at {p:#x}");
            }
        }
    }
}
