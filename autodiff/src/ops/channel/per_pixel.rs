//! The per-pixel ops along the channel axis: `channel_dot`, `channel_outer` (the C bucket's
//! sampling and injection) and `normalize_channels`; shapes and broadcasting as in the parent
//! module's docs.

use super::*;

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
