//! Row-major GEMM on faer, the one place that turns our contiguous buffers into faer views.
//!
//! Every matmul and convolution in the crate goes through [`Float::gemm`](crate::Float::gemm).
//! A row-major `m×k` slice is viewed as a faer `MatRef` with row stride `k` and column stride 1;
//! a transposed operand is the same memory read as column-major. faer picks its SIMD kernel.

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
    assert_eq!(dst.len(), m * n, "gemm: dst has {} elements, want {m}×{n}", dst.len());
    assert_eq!(a.len(), m * k, "gemm: lhs has {} elements, want {m}×{k}", a.len());
    assert_eq!(b.len(), k * n, "gemm: rhs has {} elements, want {k}×{n}", b.len());
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
    let accum = if accumulate { Accum::Add } else { Accum::Replace };
    matmul(out, accum, lhs, rhs, alpha, parallelism(m * n * k));
}
