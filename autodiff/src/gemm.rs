//! Row-major GEMM on faer, the one place that turns our contiguous buffers into faer views.
//!
//! Every matmul and convolution in the crate goes through [`Float::gemm`](crate::Float::gemm).
//! A row-major `m×k` slice is viewed as a faer `MatRef` with row stride `k` and column stride 1;
//! a transposed operand is the same memory read as column-major. faer picks its SIMD kernel.
//!
//! [`MatView`] generalises this to any row and column stride into a slice (overlapping rows
//! included), which lets a convolution multiply shifted windows of a padded image directly,
//! without building a column matrix ([`Float::gemm_view`](crate::Float::gemm_view)).

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use std::sync::atomic::{AtomicUsize, Ordering};

/// 0 = let faer use rayon's global pool, 1 = sequential; other n = rayon with n threads.
static GEMM_THREADS: AtomicUsize = AtomicUsize::new(0);

/// Sets how many threads one GEMM may use (0: rayon's pool size, 1: sequential).
///
/// Ops that already run in parallel across the batch call GEMM sequentially inside each task;
/// this knob only affects GEMMs issued from the top level.
pub fn set_gemm_threads(n: usize) {
    GEMM_THREADS.store(n, Ordering::Relaxed);
}

/// The faer parallelism for a GEMM of `flops` multiply-adds issued from the top level.
pub fn parallelism(flops: usize) -> Par {
    // Below ~64k multiply-adds threading costs more than it gains.
    if flops < (1 << 16) || rayon::current_thread_index().is_some() {
        return Par::Seq;
    }
    match GEMM_THREADS.load(Ordering::Relaxed) {
        1 => Par::Seq,
        0 => Par::rayon(0),
        n => Par::rayon(n),
    }
}

/// A read-only `rows × cols` matrix inside a slice: element `(i, j)` is
/// `data[offset + i·row_stride + j·col_stride]`. Strides may be anything, so rows may overlap
/// (a sliding window). The constructor checks that every element lies inside `data`.
#[derive(Clone, Copy, Debug)]
pub struct MatView<'a, T> {
    data: &'a [T],
    offset: usize,
    rows: usize,
    cols: usize,
    row_stride: usize,
    col_stride: usize,
}

impl<'a, T> MatView<'a, T> {
    /// A strided view; panics when an element would fall outside `data`.
    #[track_caller]
    pub fn new(
        data: &'a [T],
        offset: usize,
        rows: usize,
        cols: usize,
        row_stride: usize,
        col_stride: usize,
    ) -> Self {
        if rows > 0 && cols > 0 {
            let last = offset + (rows - 1) * row_stride + (cols - 1) * col_stride;
            assert!(
                last < data.len(),
                "MatView: {rows}×{cols} at offset {offset}, strides ({row_stride}, {col_stride}) \
                 reaches element {last} of a slice of {}",
                data.len()
            );
        }
        MatView {
            data,
            offset,
            rows,
            cols,
            row_stride,
            col_stride,
        }
    }

    /// A contiguous row-major `rows × cols` matrix.
    #[track_caller]
    pub fn row_major(data: &'a [T], rows: usize, cols: usize) -> Self {
        assert_eq!(
            data.len(),
            rows * cols,
            "MatView::row_major: {} elements, want {rows}×{cols}",
            data.len()
        );
        Self::new(data, 0, rows, cols, cols, 1)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    fn faer(&self) -> MatRef<'a, T> {
        // SAFETY: `new` checked that every addressed element lies inside `data`, which is
        // borrowed for 'a; strides fit in isize because the addresses do.
        unsafe {
            MatRef::from_raw_parts(
                self.data.as_ptr().add(self.offset),
                self.rows,
                self.cols,
                self.row_stride as isize,
                self.col_stride as isize,
            )
        }
    }
}

/// Panics unless the output of `op` holds `m×n` elements.
#[track_caller]
fn assert_dst_len(op: &str, len: usize, m: usize, n: usize) {
    assert_eq!(len, m * n, "{op}: dst has {len} elements, want {m}×{n}");
}

/// faer's accumulation mode: add into the output, or replace it.
fn accum(accumulate: bool) -> Accum {
    if accumulate {
        Accum::Add
    } else {
        Accum::Replace
    }
}

/// `dst[m×n] (=|+=) alpha · a · b` for strided views `a (m×k)`, `b (k×n)`; `dst` is contiguous
/// row-major.
pub(crate) fn gemm_view_impl<T>(
    dst: &mut [T],
    accumulate: bool,
    a: MatView<'_, T>,
    b: MatView<'_, T>,
    alpha: T,
) where
    T: faer::traits::ComplexField + Copy,
{
    let (m, k, n) = (a.rows, a.cols, b.cols);
    assert_eq!(
        b.rows, k,
        "gemm_view: lhs {m}×{k} and rhs {}×{n} do not fit",
        b.rows
    );
    assert_dst_len("gemm_view", dst.len(), m, n);
    if m == 0 || n == 0 {
        return;
    }
    let out = MatMut::from_row_major_slice_mut(dst, m, n);
    matmul(
        out,
        accum(accumulate),
        a.faer(),
        b.faer(),
        alpha,
        parallelism(m * n * k),
    );
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn gemm_impl<T>(
    dst: &mut [T],
    accumulate: bool,
    a: &[T],
    a_transposed: bool,
    b: &[T],
    b_transposed: bool,
    m: usize,
    n: usize,
    k: usize,
    alpha: T,
) where
    T: faer::traits::ComplexField + Copy,
{
    assert_dst_len("gemm", dst.len(), m, n);
    assert_eq!(
        a.len(),
        m * k,
        "gemm: lhs has {} elements, want {m}×{k}",
        a.len()
    );
    assert_eq!(
        b.len(),
        k * n,
        "gemm: rhs has {} elements, want {k}×{n}",
        b.len()
    );
    if m == 0 || n == 0 {
        return;
    }
    let lhs = if a_transposed {
        MatRef::from_column_major_slice(a, m, k)
    } else {
        MatRef::from_row_major_slice(a, m, k)
    };
    let rhs = if b_transposed {
        MatRef::from_column_major_slice(b, k, n)
    } else {
        MatRef::from_row_major_slice(b, k, n)
    };
    let out = MatMut::from_row_major_slice_mut(dst, m, n);
    matmul(
        out,
        accum(accumulate),
        lhs,
        rhs,
        alpha,
        parallelism(m * n * k),
    );
}
