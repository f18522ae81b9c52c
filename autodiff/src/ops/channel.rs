//! Ops along the channel axis (axis 1) of tensors of rank ≥ 2: `(B, C, …)`.
//!
//! - `concat(&[x₀, x₁, …])`: inputs `(B, Cᵢ, …)` with equal other axes → `(B, ΣCᵢ, …)`.
//! - `slice(x, start, len)`: `(B, C, …)` → `(B, len, …)`, channels `start..start+len`.
//! - `add_channel_bias(x, b)`: `x (B, C, …)`, `b (C,)` → `x + b[c]`.
//! - `channel_dot(v, c)`: `v (B, N, …)`, `c (1|B, N, …)` → `(B, 1, …)`, `Σₙ vₙ·cₙ` per pixel
//!   (the C bucket's sampling, authors' code, docs/references.md#c-bucket).
//! - `channel_outer(p, c)`: `p (B, 1, …)`, `c (1|B, N, …)` → `(B, N, …)`, `p·cₙ` per pixel
//!   (the C bucket's injection).
//! - `normalize_channels(x, eps)`: `x / (‖x‖₂ + eps)` with the norm over axis 1 per pixel
//!   (official C normalisation, eps = 1e-5). At `‖x‖ = 0` the norm's subgradient 0 is used.
//!
//! A leading axis of 1 on `c` broadcasts over the batch; its gradient sums over the batch.
//! Layout: every op sees `(outer, C, inner)` with `inner` = product of axes 2.., row-major.
//!
//! `concat` and `add_channel_bias` (the U-Net's) run at memory speed: parallel over blocks of
//! images or planes, each output written once, and an input gradient that no other op has
//! touched yet is written in one pass instead of zero-filled and added to
//! ([`GradSlots::target`]).

use crate::op::write_or_add;
use crate::ops::reduce::lane_sum;
use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

mod per_pixel;

pub use per_pixel::{ChannelDot, ChannelOuter, NormalizeChannels};

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &[
    "concat",
    "slice",
    "add_channel_bias",
    "channel_dot",
    "channel_outer",
    "normalize_channels",
];

/// Elements per parallel task, at least, for the memory-bound ops here (concat,
/// add_channel_bias): below this rayon's overhead dominates.
const MIN_TASK_ELEMS: usize = 1 << 15;

/// How many `len`-element units make one parallel task of at least [`MIN_TASK_ELEMS`].
fn units_per_task(len: usize) -> usize {
    (MIN_TASK_ELEMS / len.max(1)).max(1)
}

/// `(outer, channels, inner)` of a rank ≥ 2 shape; panics naming `op`.
#[track_caller]
fn split(s: Shape, op: &str) -> (usize, usize, usize) {
    assert!(
        s.rank() >= 2,
        "{op}: expected rank ≥ 2 (B, C, …), got {s:?}"
    );
    (s.dim(0), s.dim(1), s.dims()[2..].iter().product())
}

/// Same shape as `s` with axis 1 set to `c`.
fn with_channels(s: Shape, c: usize) -> Shape {
    let mut d = [0usize; crate::tensor::MAX_RANK];
    d[..s.rank()].copy_from_slice(s.dims());
    d[1] = c;
    Shape::new(&d[..s.rank()])
}

/// Concatenation along axis 1.
#[derive(Debug, Default)]
pub struct Concat;

impl<T: Float> Op<T> for Concat {
    fn name(&self) -> &'static str {
        "concat"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert!(!inputs.is_empty(), "concat: needs at least one input");
        let first = inputs[0].shape();
        let mut c = 0;
        for t in inputs {
            let s = t.shape();
            assert!(
                s.rank() == first.rank()
                    && s.rank() >= 2
                    && with_channels(s, 0) == with_channels(first, 0),
                "concat: shapes {first:?} and {s:?} differ outside axis 1"
            );
            c += s.dim(1);
        }
        with_channels(first, c)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, ctot, inner) = split(out.shape(), "concat");
        let n = ctot * inner;
        if n == 0 {
            return;
        }
        // Parallel over groups of images; each image's channel blocks are copied in order.
        out.data_mut()
            .par_chunks_mut(n * units_per_task(n))
            .enumerate()
            .for_each(|(k, ys)| {
                let b0 = k * units_per_task(n);
                for (db, y) in ys.chunks_exact_mut(n).enumerate() {
                    let mut c0 = 0;
                    for t in inputs {
                        let m = t.dims()[1] * inner;
                        y[c0..c0 + m].copy_from_slice(&t.data()[(b0 + db) * m..][..m]);
                        c0 += m;
                    }
                }
            });
    }
    fn overwrites_output(&self) -> bool {
        true
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (_, ctot, inner) = split(cx.dy.shape(), "concat");
        let (dy, n) = (cx.dy.data(), ctot * inner);
        let mut c0 = 0;
        for (i, t) in cx.inputs.iter().enumerate() {
            let m = t.dims()[1] * inner;
            if let (Some(g), true) = (dx.target(i), m > 0) {
                // One pass: copy into a fresh gradient, add into an existing one.
                let (g, acc) = g.into_parts();
                let per = units_per_task(m);
                g.par_chunks_mut(m * per).enumerate().for_each(|(k, gs)| {
                    for (db, gb) in gs.chunks_exact_mut(m).enumerate() {
                        let b = k * per + db;
                        write_or_add(gb, &dy[b * n + c0..][..m], acc);
                    }
                });
            }
            c0 += m;
        }
    }
}

/// Channels `start..start+len` of axis 1.
#[derive(Debug)]
pub struct Slice {
    /// First channel kept.
    pub start: usize,
    /// Number of channels kept.
    pub len: usize,
}

impl<T: Float> Op<T> for Slice {
    fn name(&self) -> &'static str {
        "slice"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 1, "slice: takes one input");
        let s = inputs[0].shape();
        let (_, c, _) = split(s, "slice");
        assert!(
            self.start + self.len <= c,
            "slice: channels {}..{} out of range for input {s:?}",
            self.start,
            self.start + self.len
        );
        with_channels(s, self.len)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (outer, c, inner) = split(inputs[0].shape(), "slice");
        let n = self.len * inner;
        for b in 0..outer {
            out.data_mut()[b * n..][..n]
                .copy_from_slice(&inputs[0].data()[(b * c + self.start) * inner..][..n]);
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (outer, c, inner) = split(cx.inputs[0].shape(), "slice");
        let n = self.len * inner;
        if let Some(g) = dx.slot_data(0) {
            for b in 0..outer {
                let dst = &mut g[(b * c + self.start) * inner..][..n];
                for (a, &v) in dst.iter_mut().zip(&cx.dy.data()[b * n..][..n]) {
                    *a += v;
                }
            }
        }
    }
}

/// `x + b[c]` along axis 1.
#[derive(Debug, Default)]
pub struct AddChannelBias;

impl<T: Float> Op<T> for AddChannelBias {
    fn name(&self) -> &'static str {
        "add_channel_bias"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "add_channel_bias: takes (x, b)");
        let (xs, bs) = (inputs[0].shape(), inputs[1].shape());
        let (_, c, _) = split(xs, "add_channel_bias");
        assert!(
            bs.rank() == 1 && bs.dim(0) == c,
            "add_channel_bias: bias {bs:?} does not fit input {xs:?} (want ({c},))"
        );
        xs
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, c, inner) = split(inputs[0].shape(), "add_channel_bias");
        if inner * c == 0 {
            return;
        }
        let bias = inputs[1].data();
        let per = units_per_task(inner);
        out.data_mut()
            .par_chunks_mut(inner * per)
            .zip(inputs[0].data().par_chunks(inner * per))
            .enumerate()
            .for_each(|(k, (ys, xs))| {
                let planes = ys.chunks_exact_mut(inner).zip(xs.chunks_exact(inner));
                for (p, (y, x)) in planes.enumerate() {
                    let bk = bias[(k * per + p) % c];
                    for (o, &v) in y.iter_mut().zip(x) {
                        *o = v + bk;
                    }
                }
            });
    }
    fn overwrites_output(&self) -> bool {
        true
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (outer, c, inner) = split(cx.inputs[0].shape(), "add_channel_bias");
        let dy = cx.dy.data();
        if inner * c == 0 {
            return;
        }
        let per = units_per_task(inner);
        if let Some(g) = dx.target(0) {
            let (g, acc) = g.into_parts();
            g.par_chunks_mut(inner * per)
                .zip(dy.par_chunks(inner * per))
                .for_each(|(g, d)| write_or_add(g, d, acc));
        }
        if let Some(g) = dx.slot_data(1) {
            // Plane sums in parallel, then a fixed-order reduction over the batch.
            let mut sums = vec![T::zero(); outer * c];
            sums.par_chunks_mut(per)
                .zip(dy.par_chunks(inner * per))
                .for_each(|(s, d)| {
                    for (a, plane) in s.iter_mut().zip(d.chunks_exact(inner)) {
                        *a = lane_sum(plane);
                    }
                });
            for row in sums.chunks_exact(c) {
                g.iter_mut().zip(row).for_each(|(a, &v)| *a += v);
            }
        }
    }
}

impl<T: Float> Tape<T> {
    /// Concatenates `(B, Cᵢ, …)` tensors along axis 1. See [`Concat`].
    #[track_caller]
    pub fn concat(&mut self, xs: &[Var]) -> Var {
        self.apply(Concat, xs)
    }

    /// Channels `start..start+len` of `x (B, C, …)`. See [`Slice`].
    #[track_caller]
    pub fn slice(&mut self, x: Var, start: usize, len: usize) -> Var {
        self.apply(Slice { start, len }, &[x])
    }

    /// `x (B, C, …) + b (C,)` broadcast along axis 1. See [`AddChannelBias`].
    #[track_caller]
    pub fn add_channel_bias(&mut self, x: Var, b: Var) -> Var {
        self.apply(AddChannelBias, &[x, b])
    }

    /// Per-pixel `Σₙ vₙ·cₙ`: `v (B, N, …)`, `c (1|B, N, …)` → `(B, 1, …)`. See [`ChannelDot`].
    #[track_caller]
    pub fn channel_dot(&mut self, v: Var, c: Var) -> Var {
        self.apply(ChannelDot, &[v, c])
    }

    /// Per-pixel `p·cₙ`: `p (B, 1, …)`, `c (1|B, N, …)` → `(B, N, …)`. See [`ChannelOuter`].
    #[track_caller]
    pub fn channel_outer(&mut self, p: Var, c: Var) -> Var {
        self.apply(ChannelOuter, &[p, c])
    }

    /// `x / (‖x‖₂ + eps)`, norm over axis 1 per pixel. See [`NormalizeChannels`].
    #[track_caller]
    pub fn normalize_channels(&mut self, x: Var, eps: f64) -> Var {
        self.apply(NormalizeChannels { eps }, &[x])
    }
}

#[cfg(test)]
mod tests;
