//! Dense row-major tensors of rank 0–6: the values and gradients a tape owns.
//!
//! Layout: contiguous, row-major (last axis fastest), like NumPy and PyTorch. Images are
//! `(batch, channels, height, width)`; complex data keeps real and imaginary parts in a trailing
//! axis of length 2. A [`Shape`] is `Copy` and never allocates.

use crate::Float;
use std::fmt;

/// The largest rank a [`Shape`] can hold.
pub const MAX_RANK: usize = 6;

/// The extent of each axis, outermost first. Rank 0 is a scalar with one element.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Shape {
    dims: [usize; MAX_RANK],
    rank: u8,
}

impl Shape {
    /// A shape from its axis lengths. Panics when `dims.len() > MAX_RANK`.
    #[track_caller]
    pub fn new(dims: &[usize]) -> Self {
        assert!(
            dims.len() <= MAX_RANK,
            "Shape: rank {} exceeds {MAX_RANK}",
            dims.len()
        );
        let mut d = [1; MAX_RANK];
        d[..dims.len()].copy_from_slice(dims);
        Shape {
            dims: d,
            rank: dims.len() as u8,
        }
    }

    /// The rank-0 shape of a scalar.
    pub fn scalar() -> Self {
        Shape::new(&[])
    }

    /// Axis lengths, outermost first.
    pub fn dims(&self) -> &[usize] {
        &self.dims[..self.rank as usize]
    }

    /// Number of axes.
    pub fn rank(&self) -> usize {
        self.rank as usize
    }

    /// Number of elements (1 for a scalar).
    pub fn numel(&self) -> usize {
        self.dims().iter().product()
    }

    /// Length of axis `axis`; panics with the shape when out of range.
    #[track_caller]
    pub fn dim(&self, axis: usize) -> usize {
        assert!(
            axis < self.rank(),
            "Shape: axis {axis} out of range for {self:?}"
        );
        self.dims[axis]
    }

    /// `(b, c, h, w)` of a rank-4 image shape; panics naming `op` otherwise.
    #[track_caller]
    pub fn bchw(&self, op: &str) -> (usize, usize, usize, usize) {
        assert!(
            self.rank() == 4,
            "{op}: expected a (B, C, H, W) tensor, got {self:?}"
        );
        (self.dims[0], self.dims[1], self.dims[2], self.dims[3])
    }
}

impl fmt::Debug for Shape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "(")?;
        for (i, d) in self.dims().iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{d}")?;
        }
        if self.rank() == 1 {
            write!(f, ",")?;
        }
        write!(f, ")")
    }
}

impl From<&[usize]> for Shape {
    fn from(d: &[usize]) -> Self {
        Shape::new(d)
    }
}

impl<const N: usize> From<[usize; N]> for Shape {
    fn from(d: [usize; N]) -> Self {
        Shape::new(&d)
    }
}

/// Where the tape's buffers start: on a 64-byte boundary, a cache line and the width of an
/// AVX-512 register, so that whole-vector loads and stores along a row split no cache line
/// where the row itself is aligned (PyTorch's CPU allocator aligns to 64 bytes for the same
/// reason). The system allocator places large blocks 16 bytes past a page boundary.
pub(crate) const ALIGN_BYTES: usize = 64;

/// Extra elements a buffer needs so that an aligned run of `n` fits inside it.
pub(crate) fn align_slack<T>() -> usize {
    ALIGN_BYTES / std::mem::size_of::<T>().max(1)
}

/// Index of the first element of `buf` that lies on an [`ALIGN_BYTES`] boundary, when an
/// aligned run of `n` elements fits in `buf` from there; else `0` (the run is then unaligned,
/// which is correct, only slower).
pub(crate) fn aligned_start<T>(buf: &[T], n: usize) -> usize {
    match buf.as_ptr().align_offset(ALIGN_BYTES) {
        off if off <= buf.len() && buf.len() - off >= n => off,
        _ => 0,
    }
}

/// A dense row-major tensor that owns its buffer.
///
/// The elements are `buf[start..start + numel]`: tensors made by the tape's
/// [`BufferPool`](crate::BufferPool) sit in a slightly longer buffer so that they start on an
/// `ALIGN_BYTES` (64-byte) boundary; every other constructor has `start == 0` and no extra elements.
pub struct Tensor<T> {
    shape: Shape,
    buf: Vec<T>,
    start: usize,
}

impl<T: Clone> Clone for Tensor<T> {
    fn clone(&self) -> Self {
        Tensor {
            shape: self.shape,
            buf: self.data().to_vec(),
            start: 0,
        }
    }
}

impl<T: PartialEq> PartialEq for Tensor<T> {
    fn eq(&self, other: &Self) -> bool {
        self.shape == other.shape && self.data() == other.data()
    }
}

impl<T: Float> Tensor<T> {
    /// All zeros.
    pub fn zeros(shape: impl Into<Shape>) -> Self {
        let shape = shape.into();
        Tensor {
            shape,
            buf: vec![T::zero(); shape.numel()],
            start: 0,
        }
    }

    /// Every element equal to `value`.
    pub fn full(shape: impl Into<Shape>, value: T) -> Self {
        let shape = shape.into();
        Tensor {
            shape,
            buf: vec![value; shape.numel()],
            start: 0,
        }
    }

    /// A scalar (rank 0).
    pub fn scalar(value: T) -> Self {
        Tensor {
            shape: Shape::scalar(),
            buf: vec![value],
            start: 0,
        }
    }

    /// Wraps `data`; panics when its length does not match `shape`.
    #[track_caller]
    pub fn from_vec(shape: impl Into<Shape>, data: Vec<T>) -> Self {
        let shape = shape.into();
        assert_eq!(
            data.len(),
            shape.numel(),
            "Tensor::from_vec: {} values for shape {shape:?}",
            data.len()
        );
        Tensor {
            shape,
            buf: data,
            start: 0,
        }
    }

    /// Element `i` (row-major flat index) is `f(i)`.
    pub fn from_fn(shape: impl Into<Shape>, f: impl FnMut(usize) -> T) -> Self {
        let shape = shape.into();
        Tensor {
            shape,
            buf: (0..shape.numel()).map(f).collect(),
            start: 0,
        }
    }

    /// Converts element-wise to another float type (f32 ↔ f64).
    pub fn cast<U: Float>(&self) -> Tensor<U> {
        Tensor {
            shape: self.shape,
            buf: self.data().iter().map(|&x| U::of(x.as_f64())).collect(),
            start: 0,
        }
    }

    /// The single value of a one-element tensor; panics otherwise.
    #[track_caller]
    pub fn item(&self) -> T {
        assert_eq!(
            self.numel(),
            1,
            "Tensor::item: tensor of shape {:?}",
            self.shape
        );
        self.data()[0]
    }

    /// Sets every element to zero without reallocating.
    pub fn fill_zero(&mut self) {
        self.data_mut().fill(T::zero());
    }

    /// Sum of squares, in f64.
    pub fn sum_sq(&self) -> f64 {
        self.data().iter().map(|&x| x.as_f64() * x.as_f64()).sum()
    }

    /// Largest absolute element-wise difference to `other` (same shape), in f64.
    #[track_caller]
    pub fn max_abs_diff(&self, other: &Tensor<T>) -> f64 {
        assert_eq!(self.shape, other.shape, "max_abs_diff: shapes differ");
        self.data()
            .iter()
            .zip(other.data())
            .map(|(a, b)| (a.as_f64() - b.as_f64()).abs())
            .fold(0.0, f64::max)
    }
}

impl<T> Tensor<T> {
    /// The shape.
    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// Axis lengths.
    pub fn dims(&self) -> &[usize] {
        self.shape.dims()
    }

    /// Number of elements.
    pub fn numel(&self) -> usize {
        self.shape.numel()
    }

    /// The row-major buffer.
    pub fn data(&self) -> &[T] {
        &self.buf[self.start..self.start + self.shape.numel()]
    }

    /// The row-major buffer, mutable.
    pub fn data_mut(&mut self) -> &mut [T] {
        let n = self.shape.numel();
        &mut self.buf[self.start..self.start + n]
    }

    /// Gives up the buffer: the `Vec` a tensor was made from is returned as it was; a pooled
    /// (aligned) tensor's elements are first moved to the front of its buffer (a copy within
    /// it, no allocation).
    pub fn into_vec(self) -> Vec<T> {
        let (n, start, mut buf) = (self.shape.numel(), self.start, self.buf);
        if start > 0 {
            buf.drain(..start);
        }
        buf.truncate(n);
        buf
    }

    /// Same buffer, new shape with the same number of elements.
    #[track_caller]
    pub fn reshape(mut self, shape: impl Into<Shape>) -> Self {
        let shape = shape.into();
        assert_eq!(
            shape.numel(),
            self.numel(),
            "Tensor::reshape: {:?} cannot become {shape:?}",
            self.shape
        );
        self.shape = shape;
        self
    }

    /// A tensor of `shape` in `buf` (at least `shape.numel()` elements; contents kept), from
    /// its first [`ALIGN_BYTES`]-aligned element when it has room for that: used by the tape's
    /// pool, which makes buffers [`align_slack`] elements longer than the tensors they hold.
    pub(crate) fn in_buffer(shape: Shape, buf: Vec<T>) -> Self {
        let n = shape.numel();
        debug_assert!(buf.len() >= n);
        let start = aligned_start(&buf, n);
        Tensor { shape, buf, start }
    }

    /// Gives up the whole buffer, extra elements included (for the pool; see
    /// [`Tensor::in_buffer`]).
    pub(crate) fn into_buffer(self) -> Vec<T> {
        self.buf
    }
}

impl<T: fmt::Debug> fmt::Debug for Tensor<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const SHOWN: usize = 8;
        write!(f, "Tensor{:?} [", self.shape)?;
        for (i, x) in self.data().iter().take(SHOWN).enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{x:?}")?;
        }
        if self.data().len() > SHOWN {
            write!(f, ", … {} more", self.data().len() - SHOWN)?;
        }
        write!(f, "]")
    }
}
