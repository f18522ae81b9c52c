//! Ops along the channel axis (axis 1) of tensors of rank ≥ 2: `(B, C, …)`.
//!
//! - `concat(&[x₀, x₁, …])`: inputs `(B, Cᵢ, …)` with equal other axes → `(B, ΣCᵢ, …)`.
//! - `slice(x, start, len)`: `(B, C, …)` → `(B, len, …)`, channels `start..start+len`.
//! - `add_channel_bias(x, b)`: `x (B, C, …)`, `b (C,)` → `x + b[c]`.
//! - `channel_dot(v, c)`: `v (B, N, …)`, `c (1|B, N, …)` → `(B, 1, …)`, `Σₙ vₙ·cₙ` per pixel
//!   (the C bucket's sampling, official §3.3).
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

use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

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

/// `dst = src` (`acc == false`) or `dst += src`.
#[inline]
fn write_or_add<T: Float>(dst: &mut [T], src: &[T], acc: bool) {
    if acc {
        dst.iter_mut().zip(src).for_each(|(a, &v)| *a += v);
    } else {
        dst.copy_from_slice(src);
    }
}

/// `Σ v`, with 8 independent partial sums so the loop vectorises.
fn sum<T: Float>(v: &[T]) -> T {
    let mut acc = [T::zero(); 8];
    let chunks = v.chunks_exact(8);
    let tail = chunks.remainder().iter().fold(T::zero(), |s, &x| s + x);
    for c in chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
    acc.iter().fold(tail, |s, &x| s + x)
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
                        *a = sum(plane);
                    }
                });
            for row in sums.chunks_exact(c) {
                g.iter_mut().zip(row).for_each(|(a, &v)| *a += v);
            }
        }
    }
}

/// Checks `(B, N, …)` against `(1|B, N, …)` and returns `(B, N, inner, c_is_batched)`.
#[track_caller]
fn pair_shapes(op: &str, v: Shape, c: Shape, v_channels_free: bool) -> (usize, usize, usize, bool) {
    let (b, nv, inner) = split(v, op);
    let (cb, n, cinner) = split(c, op);
    let rest_ok = v.rank() == c.rank() && v.dims()[2..] == c.dims()[2..];
    let n_ok = v_channels_free || nv == n;
    assert!(
        rest_ok && n_ok && (cb == b || cb == 1) && inner == cinner,
        "{op}: shapes {v:?} and {c:?} do not fit (want (B, N, …) and (1 or B, N, …))"
    );
    (b, n, inner, cb == b && b != 1)
}

/// Per-pixel dot product over channels: `(B, N, …) · (1|B, N, …) → (B, 1, …)`.
#[derive(Debug, Default)]
pub struct ChannelDot;

impl<T: Float> Op<T> for ChannelDot {
    fn name(&self) -> &'static str {
        "channel_dot"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "channel_dot: takes (v, c)");
        pair_shapes("channel_dot", inputs[0].shape(), inputs[1].shape(), false);
        with_channels(inputs[0].shape(), 1)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, n, inner, batched) =
            pair_shapes("channel_dot", inputs[0].shape(), inputs[1].shape(), false);
        let (v, c) = (inputs[0].data(), inputs[1].data());
        for (b, y) in out.data_mut().chunks_exact_mut(inner.max(1)).enumerate() {
            let cb = if batched { b } else { 0 };
            for k in 0..n {
                let (vr, cr) = (
                    &v[(b * n + k) * inner..][..inner],
                    &c[(cb * n + k) * inner..][..inner],
                );
                for ((o, &a), &w) in y.iter_mut().zip(vr).zip(cr) {
                    *o += a * w;
                }
            }
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (bn, n, inner, batched) = pair_shapes(
            "channel_dot",
            cx.inputs[0].shape(),
            cx.inputs[1].shape(),
            false,
        );
        let (v, c, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        for b in 0..bn {
            let cb = if batched { b } else { 0 };
            let d = &dy[b * inner..][..inner];
            for k in 0..n {
                let (vi, ci) = ((b * n + k) * inner, (cb * n + k) * inner);
                if let Some(g) = dx.slot_data(0) {
                    for ((a, &dd), &w) in g[vi..][..inner].iter_mut().zip(d).zip(&c[ci..][..inner])
                    {
                        *a += dd * w;
                    }
                }
                if let Some(g) = dx.slot_data(1) {
                    for ((a, &dd), &x) in g[ci..][..inner].iter_mut().zip(d).zip(&v[vi..][..inner])
                    {
                        *a += dd * x;
                    }
                }
            }
        }
    }
}

/// Per-pixel outer product with channels: `(B, 1, …) ⊗ (1|B, N, …) → (B, N, …)`.
#[derive(Debug, Default)]
pub struct ChannelOuter;

impl<T: Float> Op<T> for ChannelOuter {
    fn name(&self) -> &'static str {
        "channel_outer"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "channel_outer: takes (p, c)");
        let (p, c) = (inputs[0].shape(), inputs[1].shape());
        let (_, n, _, _) = pair_shapes("channel_outer", p, c, true);
        assert!(
            p.dim(1) == 1,
            "channel_outer: p {p:?} must have one channel (c is {c:?})"
        );
        with_channels(p, n)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, n, inner, batched) =
            pair_shapes("channel_outer", inputs[0].shape(), inputs[1].shape(), true);
        let (p, c) = (inputs[0].data(), inputs[1].data());
        for (bk, y) in out.data_mut().chunks_exact_mut(inner.max(1)).enumerate() {
            let (b, k) = (bk / n, bk % n);
            let cb = if batched { b } else { 0 };
            let (pr, cr) = (
                &p[b * inner..][..inner],
                &c[(cb * n + k) * inner..][..inner],
            );
            for ((o, &a), &w) in y.iter_mut().zip(pr).zip(cr) {
                *o = a * w;
            }
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (bn, n, inner, batched) = pair_shapes(
            "channel_outer",
            cx.inputs[0].shape(),
            cx.inputs[1].shape(),
            true,
        );
        let (p, c, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        for b in 0..bn {
            let cb = if batched { b } else { 0 };
            for k in 0..n {
                let (yi, ci) = ((b * n + k) * inner, (cb * n + k) * inner);
                let d = &dy[yi..][..inner];
                if let Some(g) = dx.slot_data(0) {
                    for ((a, &dd), &w) in g[b * inner..][..inner]
                        .iter_mut()
                        .zip(d)
                        .zip(&c[ci..][..inner])
                    {
                        *a += dd * w;
                    }
                }
                if let Some(g) = dx.slot_data(1) {
                    for ((a, &dd), &x) in g[ci..][..inner]
                        .iter_mut()
                        .zip(d)
                        .zip(&p[b * inner..][..inner])
                    {
                        *a += dd * x;
                    }
                }
            }
        }
    }
}

/// `x / (‖x‖₂ + eps)` with the norm over axis 1, per pixel.
#[derive(Debug)]
pub struct NormalizeChannels {
    /// Added to the norm before dividing (official: 1e-5, CortexModel C_Default).
    pub eps: f64,
}

impl<T: Float> Op<T> for NormalizeChannels {
    fn name(&self) -> &'static str {
        "normalize_channels"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 1, "normalize_channels: takes one input");
        split(inputs[0].shape(), "normalize_channels");
        inputs[0].shape()
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (outer, n, inner) = split(inputs[0].shape(), "normalize_channels");
        let (x, y) = (inputs[0].data(), out.data_mut());
        for b in 0..outer {
            for q in 0..inner {
                let at = |k: usize| (b * n + k) * inner + q;
                let s = (0..n).map(|k| x[at(k)] * x[at(k)]).sum::<T>().sqrt();
                let inv = T::one() / (s + T::of(self.eps));
                for k in 0..n {
                    y[at(k)] = x[at(k)] * inv;
                }
            }
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (outer, n, inner) = split(cx.inputs[0].shape(), "normalize_channels");
        let (x, dy) = (cx.inputs[0].data(), cx.dy.data());
        let Some(g) = dx.slot_data(0) else { return };
        for b in 0..outer {
            for q in 0..inner {
                let at = |k: usize| (b * n + k) * inner + q;
                let s = (0..n).map(|k| x[at(k)] * x[at(k)]).sum::<T>().sqrt();
                let d = s + T::of(self.eps);
                let dot = (0..n).map(|k| dy[at(k)] * x[at(k)]).sum::<T>();
                // ∂yₘ/∂xₖ = δₘₖ/d − xₘxₖ/(s·d²); the second term is 0 at s = 0.
                let coef = if s > T::zero() {
                    dot / (s * d * d)
                } else {
                    T::zero()
                };
                for k in 0..n {
                    g[at(k)] += dy[at(k)] / d - x[at(k)] * coef;
                }
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
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies as st, CheckConfig};
    use proptest::prelude::*;

    /// `(B, C, rest…)` dims of rank 2..=4 with the given channel count.
    fn dims_with(c: usize) -> impl Strategy<Value = Vec<usize>> {
        (1usize..=3, proptest::collection::vec(1usize..=4, 0..=2)).prop_map(move |(b, rest)| {
            let mut d = vec![b, c];
            d.extend(rest);
            d
        })
    }

    fn set_channels(d: &[usize], c: usize) -> Vec<usize> {
        let mut d = d.to_vec();
        d[1] = c;
        d
    }

    proptest! {
        #![proptest_config(st::config())]

        #[test]
        fn concat_and_slice_gradients(
            (a, b, c) in (1usize..=3).prop_flat_map(dims_with).prop_flat_map(|d| (
                st::tensor_of(d.clone()), st::tensor_of(set_channels(&d, 2)), st::tensor_of(set_channels(&d, 1)),
            )),
            start in 0usize..4, len in 1usize..4,
        ) {
            let r = check_gradients(|t, v| t.concat(v), &[a.clone(), b.clone(), c.clone()], &CheckConfig::default());
            prop_assert!(r.is_ok(), "concat {:?}: {}", a.shape(), r.unwrap_err());
            let total = a.dims()[1] + 3;
            let start = start.min(total - 1);
            let len = len.min(total - start);
            let r = check_gradients(|t, v| { let x = t.concat(v); t.slice(x, start, len) }, &[a, b, c], &CheckConfig::default());
            prop_assert!(r.is_ok(), "slice {start}+{len}: {}", r.unwrap_err());
        }

        #[test]
        fn add_channel_bias_gradients(
            (x, b) in (1usize..=4).prop_flat_map(|c| (dims_with(c).prop_flat_map(st::tensor_of), st::tensor_of(vec![c]))),
        ) {
            let r = check_gradients(|t, v| t.add_channel_bias(v[0], v[1]), &[x, b], &CheckConfig::default());
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }

        /// Inputs used twice: the later op's backward gets fresh gradient buffers (written
        /// over; NaN-filled under test, so a missed element fails), the earlier one adds.
        #[test]
        fn concat_and_bias_gradients_into_shared_inputs(
            (x, b) in (1usize..=3).prop_flat_map(|c| (dims_with(c).prop_flat_map(st::tensor_of), st::tensor_of(vec![c]))),
        ) {
            let r = check_gradients(
                |t, v| {
                    let y = t.add_channel_bias(v[0], v[1]);
                    let z = t.add_channel_bias(v[0], v[1]);
                    let yz = t.mul(y, z);
                    t.concat(&[v[0], yz, v[0]])
                },
                &[x.clone(), b],
                &CheckConfig::default(),
            );
            prop_assert!(r.is_ok(), "{:?}: {}", x.shape(), r.unwrap_err());
        }

        #[test]
        fn channel_dot_and_outer_gradients(
            (v, c, p) in (1usize..=4, any::<bool>()).prop_flat_map(|(n, bcast)| dims_with(n).prop_flat_map(move |d| {
                let mut cd = d.clone();
                if bcast { cd[0] = 1; }
                (st::tensor_of(d.clone()), st::tensor_of(cd), st::tensor_of(set_channels(&d, 1)))
            })),
        ) {
            let r = check_gradients(|t, x| t.channel_dot(x[0], x[1]), &[v.clone(), c.clone()], &CheckConfig::default());
            prop_assert!(r.is_ok(), "channel_dot {:?} {:?}: {}", v.shape(), c.shape(), r.unwrap_err());
            let r = check_gradients(|t, x| t.channel_outer(x[0], x[1]), &[p.clone(), c.clone()], &CheckConfig::default());
            prop_assert!(r.is_ok(), "channel_outer {:?} {:?}: {}", p.shape(), c.shape(), r.unwrap_err());
        }

        #[test]
        fn normalize_channels_gradients(
            x in (1usize..=4).prop_flat_map(dims_with).prop_flat_map(|d| st::tensor_away_from(d, 0.0, 0.2)),
            eps in prop_oneof![Just(1e-5), Just(0.3)],
        ) {
            let r = check_gradients(|t, v| t.normalize_channels(v[0], eps), &[x], &CheckConfig::default());
            prop_assert!(r.is_ok(), "eps {eps}: {}", r.unwrap_err());
        }
    }

    #[test]
    fn values_by_hand() {
        let mut t = Tape::<f64>::new();
        // v (1, 2, 1, 2), c broadcast (1, 2, 1, 2): dot = [1·5 + 3·7, 2·6 + 4·8].
        let v = t.constant(Tensor::from_vec([1, 2, 1, 2], vec![1., 2., 3., 4.]));
        let c = t.constant(Tensor::from_vec([1, 2, 1, 2], vec![5., 6., 7., 8.]));
        let d = t.channel_dot(v, c);
        assert_eq!(t.value(d).data(), &[26., 44.]);
        let o = t.channel_outer(d, c);
        assert_eq!(t.value(o).data(), &[130., 264., 182., 352.]);
        let x = t.constant(Tensor::from_vec([1, 2, 1, 1], vec![3., 4.]));
        let n = t.normalize_channels(x, 0.0);
        assert!(
            t.value(n)
                .max_abs_diff(&Tensor::from_vec([1, 2, 1, 1], vec![0.6, 0.8]))
                < 1e-15
        );
        let b = t.constant(Tensor::from_vec([2], vec![10., 20.]));
        let y = t.add_channel_bias(v, b);
        assert_eq!(t.value(y).data(), &[11., 12., 23., 24.]);
        let cat = t.concat(&[v, d, o]);
        assert_eq!(t.shape(cat), Shape::new(&[1, 5, 1, 2]));
        assert_eq!(
            t.value(cat).data(),
            &[1., 2., 3., 4., 26., 44., 130., 264., 182., 352.]
        );
        let s = t.slice(v, 1, 1);
        assert_eq!(t.value(s).data(), &[3., 4.]);
        // (N, 2) point sets: axis 1 is the coordinate.
        let pts = t.constant(Tensor::from_vec([3, 2], vec![1., 2., 3., 4., 5., 6.]));
        let ys = t.slice(pts, 1, 1);
        assert_eq!(t.value(ys).data(), &[2., 4., 6.]);
    }

    #[test]
    fn large_concat_and_bias_match_plain_loops() {
        // Big enough for several parallel tasks (MIN_TASK_ELEMS); integer values keep every
        // sum exact, so the results must agree exactly whatever the summation order.
        let (bn, ca, cb, inner) = (3, 5, 2, 70 * 90);
        let a = Tensor::from_fn([bn, ca, 70, 90], |i| ((i * 37) % 19) as f64 - 9.0);
        let b = Tensor::from_fn([bn, cb, 70, 90], |i| ((i * 11) % 23) as f64 - 11.0);
        let bias = Tensor::from_vec([ca + cb], (0..ca + cb).map(|k| k as f64).collect());
        let mut t = Tape::<f64>::new();
        let (av, bv, biasv) = (t.leaf(a.clone()), t.leaf(b.clone()), t.leaf(bias.clone()));
        let cat = t.concat(&[av, bv]);
        let y = t.add_channel_bias(cat, biasv);
        let c = ca + cb;
        let at = |bi: usize, k: usize, q: usize| {
            if k < ca {
                a.data()[(bi * ca + k) * inner + q]
            } else {
                b.data()[(bi * cb + k - ca) * inner + q]
            }
        };
        let want = Tensor::from_fn([bn, c, 70, 90], |f| {
            let (bi, k, q) = (f / (c * inner), (f / inner) % c, f % inner);
            at(bi, k, q) + k as f64
        });
        assert_eq!(t.value(y).data(), want.data());
        let dy = Tensor::from_fn(t.shape(y), |i| ((i * 29) % 13) as f64 - 6.0);
        t.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
        let mut gb = vec![0.0; c];
        for (p, plane) in dy.data().chunks_exact(inner).enumerate() {
            gb[p % c] += plane.iter().sum::<f64>();
        }
        assert_eq!(t.grad(biasv).unwrap().data(), &gb[..]);
        let pick = |bi: usize, k: usize| &dy.data()[(bi * c + k) * inner..][..inner];
        let ga: Vec<f64> = (0..bn)
            .flat_map(|bi| (0..ca).flat_map(move |k| pick(bi, k).to_vec()))
            .collect();
        let gbb: Vec<f64> = (0..bn)
            .flat_map(|bi| (ca..c).flat_map(move |k| pick(bi, k).to_vec()))
            .collect();
        assert_eq!(t.grad(av).unwrap().data(), &ga[..]);
        assert_eq!(t.grad(bv).unwrap().data(), &gbb[..]);
    }

    #[test]
    fn zero_vector_normalises_to_zero_with_finite_gradient() {
        let mut t = Tape::<f64>::new();
        let x = t.leaf(Tensor::zeros([1, 3, 1, 1]));
        let y = t.normalize_channels(x, 1e-5);
        assert_eq!(t.value(y).data(), &[0., 0., 0.]);
        t.backward_from(&[(y, Tensor::full([1, 3, 1, 1], 1.0))], &mut crate::NoHooks);
        // Only the 1/(‖x‖ + eps) term survives: ∂y/∂x = I / eps.
        assert!(
            t.grad(x)
                .unwrap()
                .max_abs_diff(&Tensor::full([1, 3, 1, 1], 1e5))
                < 1e-9
        );
    }

    #[test]
    #[should_panic(expected = "concat: shapes (2, 3, 4) and (2, 1, 5) differ outside axis 1")]
    fn concat_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let a = t.constant(Tensor::zeros([2, 3, 4]));
        let b = t.constant(Tensor::zeros([2, 1, 5]));
        t.concat(&[a, b]);
    }

    #[test]
    #[should_panic(expected = "channel_dot: shapes (2, 3, 4, 4) and (2, 2, 4, 4) do not fit")]
    fn channel_dot_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let a = t.constant(Tensor::zeros([2, 3, 4, 4]));
        let b = t.constant(Tensor::zeros([2, 2, 4, 4]));
        t.channel_dot(a, b);
    }

    #[test]
    #[should_panic(expected = "add_channel_bias: bias (2,) does not fit input (1, 3, 2)")]
    fn bias_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let a = t.constant(Tensor::zeros([1, 3, 2]));
        let b = t.constant(Tensor::zeros([2]));
        t.add_channel_bias(a, b);
    }

    #[test]
    #[should_panic(expected = "slice: channels 2..5 out of range for input (1, 4, 2)")]
    fn slice_out_of_range_panics() {
        let mut t = Tape::<f32>::new();
        let a = t.constant(Tensor::zeros([1, 4, 2]));
        t.slice(a, 2, 3);
    }
}
