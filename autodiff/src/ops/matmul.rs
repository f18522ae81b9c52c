//! Matrix product on faer's GEMM, and the dense layer built on it.
//!
//! - [`Matmul`]: `y = a · b` for rank-2 `a (m, k)` and `b (k, n)` → `(m, n)`, all row-major.
//!   Backward, also through GEMM: `da += dy · bᵀ`, `db += aᵀ · dy`. Nothing is saved beyond the
//!   inputs the tape already owns.
//! - **Tall-skinny shapes** (the RealNVP flow on point sets: `x (rows, 16) @ W (16, 16)` with
//!   up to 524 288 rows) are planned by shape rather than handed to one faer call, which
//!   neither splits a long inner dimension nor divides a narrow tall output well:
//!   - small output (`m·n ≤ 4096`), long inner dimension (`k ≥ 4096`), e.g. the weight gradient
//!     `xᵀ·dy`: `k` is cut into `clamp(k / 1024, 1, 64)` equal chunks, each a sequential faer
//!     GEMM, summed pairwise in a fixed tree (results do not depend on the thread count);
//!   - tall output (`m ≥ 4096`) with `k, n ≤ 64`, e.g. `x·W` and `dy·Wᵀ`: independent blocks
//!     of about 2¹⁸ multiply-adds worth of rows, in parallel, one sequential GEMM each.
//!
//!   Inside an already parallel op (a rayon task) or on one thread every product is one faer
//!   call. The split-k path sums in a different order than faer, so f32 results differ from a
//!   single GEMM at rounding level only.
//! - **Weight convention:** rows are samples, so a layer is `x @ W` with `x (batch, in)` and
//!   `W (in, out)`: [`Op::weight_inputs`] is `[1]`, the right operand. Learning rules such as
//!   [`FeedbackAlignment`](crate::learn::FeedbackAlignment) swap that operand in the backward
//!   pass only, and only when it is a parameter. Put the weight on the right to make it visible
//!   to them.
//! - [`Tape::linear`] is `x @ w + b` with `b (n,)` broadcast over the rows (a composite of
//!   `matmul` and `add_broadcast`, not a separate op).
//!
//! Inner dimensions that disagree panic naming the op and both shapes.

use crate::gemm::MatView;
use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["matmul"];

/// `y = a · b`, `(m, k) @ (k, n) → (m, n)`; input 1 is the weight.
#[derive(Clone, Copy, Debug, Default)]
pub struct Matmul;

#[track_caller]
fn mkn<T: Float>(inputs: &[&Tensor<T>]) -> (usize, usize, usize) {
    assert_eq!(
        inputs.len(),
        2,
        "matmul: takes two inputs, got {}",
        inputs.len()
    );
    let (a, b) = (inputs[0].shape(), inputs[1].shape());
    assert!(
        a.rank() == 2 && b.rank() == 2 && a.dim(1) == b.dim(0),
        "matmul: lhs {a:?} and rhs {b:?} do not form (m, k) @ (k, n)"
    );
    (a.dim(0), a.dim(1), b.dim(1))
}

impl<T: Float> Op<T> for Matmul {
    fn name(&self) -> &'static str {
        "matmul"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let (m, _, n) = mkn(inputs);
        Shape::new(&[m, n])
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (m, k, n) = mkn(inputs);
        let a = Operand {
            data: inputs[0].data(),
            transposed: false,
        };
        let b = Operand {
            data: inputs[1].data(),
            transposed: false,
        };
        product(out.data_mut(), false, a, b, m, n, k);
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (m, k, n) = mkn(cx.inputs);
        let (a, b, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        let op = |data, transposed| Operand { data, transposed };
        if let Some(ga) = dx.slot_data(0) {
            // (m, n) @ (n, k): b read transposed.
            product(ga, true, op(dy, false), op(b, true), m, k, n);
        }
        if let Some(gb) = dx.slot_data(1) {
            // (k, m) @ (m, n): a read transposed.
            product(gb, true, op(a, true), op(dy, false), k, n, m);
        }
    }
    fn weight_inputs(&self) -> &'static [usize] {
        &[1]
    }
}

// ---------------------------------------------------------------------------------------------
// Shape-aware dispatch around `T::gemm`.
// ---------------------------------------------------------------------------------------------

/// Outputs with at most this many elements count as small for the split-k path
/// (the 16×16 weight gradient of a RealNVP coupling layer is 256).
const SMALL_OUTPUT: usize = 4096;
/// Inner dimensions at least this long are split across threads when the output is small.
const LONG_INNER: usize = 4096;
/// Shortest inner-dimension chunk a split-k task multiplies on its own.
const MIN_K_CHUNK: usize = 1024;
/// Most chunks the inner dimension is split into (bounds the tree depth and its stack use).
const MAX_K_CHUNKS: usize = 64;
/// Outputs with at least this many rows and inner and column dimensions of at most
/// `NARROW` are computed as independent row blocks in parallel.
const TALL_ROWS: usize = 4096;
/// Largest inner and column dimension of the row-block path.
const NARROW: usize = 64;
/// Multiply-adds per row block of the row-block path (tens of µs of work: far above rayon's
/// per-task cost, small enough to balance across threads).
const ROW_BLOCK_FLOPS: usize = 1 << 18;

/// One operand of a GEMM: a contiguous row-major buffer read as-is or transposed.
#[derive(Clone, Copy)]
struct Operand<'a, T> {
    data: &'a [T],
    transposed: bool,
}

impl<'a, T> Operand<'a, T> {
    /// Rows `r0..r1` and columns `c0..c1` of the logical `rows × cols` matrix.
    fn view(
        &self,
        rows: usize,
        cols: usize,
        r: (usize, usize),
        c: (usize, usize),
    ) -> MatView<'a, T> {
        let (nr, nc) = (r.1 - r.0, c.1 - c.0);
        if self.transposed {
            // Stored (cols, rows) row-major: element (i, j) at j·rows + i.
            MatView::new(self.data, c.0 * rows + r.0, nr, nc, 1, rows)
        } else {
            MatView::new(self.data, r.0 * cols + c.0, nr, nc, cols, 1)
        }
    }
}

/// How a GEMM of a given shape is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Plan {
    /// One call to faer (which picks its own threading).
    Faer,
    /// Small output, long inner dimension: `k` split into `chunks` equal parts multiplied in
    /// parallel and summed pairwise in a fixed tree (the result does not depend on the thread
    /// count or on scheduling).
    SplitK { chunks: usize },
    /// Tall output with narrow `k` and `n`: blocks of `rows` output rows, one sequential GEMM each.
    RowBlocks { rows: usize },
}

fn plan(m: usize, n: usize, k: usize) -> Plan {
    if m * n <= SMALL_OUTPUT && k >= LONG_INNER {
        Plan::SplitK {
            chunks: (k / MIN_K_CHUNK).clamp(1, MAX_K_CHUNKS),
        }
    } else if m >= TALL_ROWS && k <= NARROW && n <= NARROW {
        Plan::RowBlocks {
            rows: (ROW_BLOCK_FLOPS / (k * n).max(1)).clamp(64, m),
        }
    } else {
        Plan::Faer
    }
}

/// `dst[m×n] (=|+=) a · b` for `a (m×k)` and `b (k×n)`, each possibly read transposed; the
/// plan follows the shape (see [`Plan`]).
#[allow(clippy::too_many_arguments)]
fn product<T: Float>(
    dst: &mut [T],
    accumulate: bool,
    a: Operand<'_, T>,
    b: Operand<'_, T>,
    m: usize,
    n: usize,
    k: usize,
) {
    assert_eq!(
        dst.len(),
        m * n,
        "matmul: output has {} elements, want {m}×{n}",
        dst.len()
    );
    // In a task of an op that is already parallel, or on one thread, keep faer's sequential GEMM.
    let nested = rayon::current_thread_index().is_some() || rayon::current_num_threads() == 1;
    let chosen = if nested || m == 0 || n == 0 || k == 0 {
        Plan::Faer
    } else {
        plan(m, n, k)
    };
    match chosen {
        Plan::Faer => T::gemm(
            dst,
            accumulate,
            a.data,
            a.transposed,
            b.data,
            b.transposed,
            m,
            n,
            k,
            T::one(),
        ),
        Plan::SplitK { chunks } => split_k(dst, accumulate, a, b, (m, n, k), (0, chunks), chunks),
        Plan::RowBlocks { rows } => {
            let rhs = b.view(k, n, (0, k), (0, n));
            dst.par_chunks_mut(rows * n)
                .enumerate()
                .for_each(|(blk, d)| {
                    let r0 = blk * rows;
                    let lhs = a.view(m, k, (r0, r0 + d.len() / n), (0, k));
                    T::gemm_view(d, accumulate, lhs, rhs, T::one());
                });
        }
    }
}

/// Chunks `c.0..c.1` of `k` split into `chunks` near-equal parts, into `dst`: the left half
/// goes into `dst`, the right half into a stack buffer added afterwards.
fn split_k<T: Float>(
    dst: &mut [T],
    accumulate: bool,
    a: Operand<'_, T>,
    b: Operand<'_, T>,
    (m, n, k): (usize, usize, usize),
    c: (usize, usize),
    chunks: usize,
) {
    let bound = |i: usize| i * k / chunks;
    if c.1 - c.0 == 1 {
        let ks = (bound(c.0), bound(c.1));
        let lhs = a.view(m, k, (0, m), ks);
        let rhs = b.view(k, n, ks, (0, n));
        T::gemm_view(dst, accumulate, lhs, rhs, T::one());
        return;
    }
    let mid = c.0 + (c.1 - c.0) / 2;
    let mut right_buf = [T::zero(); SMALL_OUTPUT];
    let right = &mut right_buf[..m * n];
    rayon::join(
        || split_k(dst, accumulate, a, b, (m, n, k), (c.0, mid), chunks),
        || split_k(right, false, a, b, (m, n, k), (mid, c.1), chunks),
    );
    for (d, &r) in dst.iter_mut().zip(right.iter()) {
        *d += r;
    }
}

impl<T: Float> Tape<T> {
    /// `a @ b` for `a (m, k)`, `b (k, n)`. The right operand counts as the weight.
    #[track_caller]
    pub fn matmul(&mut self, a: Var, b: Var) -> Var {
        self.apply(Matmul, &[a, b])
    }

    /// A dense layer `x @ w + b`: `x (batch, in)`, `w (in, out)`, `b (out,)` → `(batch, out)`.
    #[track_caller]
    pub fn linear(&mut self, x: Var, w: Var, b: Var) -> Var {
        let out = self.shape(w).dims().get(1).copied();
        let bias = self.shape(b);
        assert!(
            bias.rank() == 1 && Some(bias.dim(0)) == out,
            "linear: bias {bias:?} does not match weight {:?} (want (out,))",
            self.shape(w)
        );
        let y = self.matmul(x, w);
        self.add_broadcast(y, b)
    }
}

#[cfg(test)]
mod tests;
