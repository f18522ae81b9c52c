//! Convolutions: `conv2d` ("same" output, stride 1, odd square kernel, zero or reflect
//! padding, no bias) and `conv_transpose2x2` (stride 2, kernel 2, PyTorch weight layout).
//!
//! Shapes (row-major, NCHW):
//! - `conv2d(x, w, padding)`: `x (B, Cin, H, W)`, `w (Cout, Cin, k, k)` with odd `k` →
//!   `(B, Cout, H, W)`. `y[b,o,i,j] = Σ_{c,a,b'} w[o,c,a,b'] · x_pad[b,c,i+a−p,j+b'−p]`,
//!   `p = (k−1)/2` — a cross-correlation, as in PyTorch. Bias is a separate op
//!   ([`Tape::add_channel_bias`]).
//! - `conv_transpose2x2(x, w)`: `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` → `(B, Cout, 2H, 2W)`,
//!   `y[b,o,2i+a,2j+c] = Σ_ci x[b,ci,i,j] · w[ci,o,a,c]` (each output pixel has one source).
//!
//! Both declare their kernel as the weight input (`weight_inputs() == [1]`), so feedback
//! alignment can substitute a fixed random kernel in backward.
//!
//! `conv2d_relu(x, w, padding)` is `relu(conv2d(x, w, padding))` as one op (the U-Net's
//! building block): the ReLU is applied while the output is written, and its backward masks
//! `dy` by `y > 0` while `dy` is being re-laid out anyway, so it costs no extra pass.
//!
//! Implementation (see [`lowering`]): each image is copied once into a padded buffer; the
//! output is then `k²` accumulating faer GEMMs (inner size `Cin`) over shifted strided views of
//! that buffer, per row tile so the working set stays in L2 — no column matrix.
//! Backward computes `∂w` the same way against `dy` expanded to padded width, and `∂x` as a
//! full correlation of a zero-padded copy of `dy` with the flipped kernel (again `k²`
//! GEMMs per tile), folded back through the adjoint of the padding (reflect borders fold their
//! gradient onto the interior). Images run in parallel on rayon with sequential GEMMs inside;
//! a single image runs on the calling thread so faer may thread its GEMMs. Scratch comes from
//! a reused stash, and the output is not zero-filled first ([`Op::overwrites_output`]).

mod lowering;
mod transpose;

pub use lowering::Padding;
pub use transpose::ConvTranspose2x2;

use crate::gemm::MatView;
use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use lowering::{tiles, Geometry, Scratch};
use rayon::prelude::*;
use std::any::Any;

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["conv2d", "conv2d_relu", "conv_transpose2x2"];

/// Stride-1 "same" 2-D cross-correlation with an odd square kernel, optionally followed by
/// ReLU (see the module docs). Forward keeps the padded input for backward.
pub struct Conv2d {
    /// What the kernel reads outside the image.
    pub padding: Padding,
    /// Apply `max(·, 0)` to the output (op name `"conv2d_relu"`).
    pub relu: bool,
    /// The padded input of the last forward (a `SavedPad<T>`), reused by backward.
    saved: Option<Box<dyn Any + Send + Sync>>,
}

/// Padded copies of every image of the input at `x_addr` (compared in backward, so a backward
/// run with substituted inputs pads afresh).
struct SavedPad<T: Float> {
    x_addr: usize,
    buf: Scratch<T>,
}

impl Conv2d {
    /// The op; see [`Tape::conv2d`] and [`Tape::conv2d_relu`].
    pub fn new(padding: Padding, relu: bool) -> Self {
        Conv2d {
            padding,
            relu,
            saved: None,
        }
    }
}

impl std::fmt::Debug for Conv2d {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Conv2d")
            .field("padding", &self.padding)
            .field("relu", &self.relu)
            .finish()
    }
}

impl Conv2d {
    fn geometry<T: Float>(&self, x: &Tensor<T>, w: &Tensor<T>) -> (usize, usize, Geometry) {
        let (b, c, h, wd) = x.shape().bchw("conv2d");
        let (co, ci, k, k2) = w.shape().bchw("conv2d weight");
        (
            b,
            co,
            Geometry {
                c: ci.max(c),
                h,
                w: wd,
                k: k.max(k2),
                mode: self.padding,
            },
        )
    }
}

#[track_caller]
fn check_conv_shapes(x: Shape, w: Shape, padding: Padding) {
    let (_, c, h, wd) = x.bchw("conv2d");
    let (_, ci, k, k2) = w.bchw("conv2d weight");
    assert!(
        ci == c && k == k2 && k % 2 == 1,
        "conv2d: input {x:?} and weight {w:?} do not fit (want weight (Cout, {c}, k, k), k odd)"
    );
    if padding == Padding::Reflect {
        assert!(
            k / 2 < h && k / 2 < wd,
            "conv2d: reflect padding {} needs an image larger than that, input {x:?}, weight {w:?}",
            k / 2
        );
    }
}

impl<T: Float> Op<T> for Conv2d {
    fn name(&self) -> &'static str {
        if self.relu {
            "conv2d_relu"
        } else {
            "conv2d"
        }
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "conv2d: takes (x, w)");
        check_conv_shapes(inputs[0].shape(), inputs[1].shape(), self.padding);
        let (b, _, h, w) = inputs[0].shape().bchw("conv2d");
        Shape::new(&[b, inputs[1].dims()[0], h, w])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (x, w) = (inputs[0], inputs[1]);
        let (batch, co, g) = self.geometry(x, w);
        let (hw, kk, cc) = (g.h * g.w, g.k * g.k, co * g.c);
        let relu = self.relu;
        let images = out
            .data_mut()
            .chunks_mut(co * hw)
            .zip(x.data().chunks(g.c * hw));
        if g.k == 1 {
            // A 1×1 kernel needs no padding: y_b = W · x_b.
            let ws = w.data();
            for_each_image(
                images,
                || (),
                |_, (y, x)| {
                    T::gemm(y, false, ws, false, x, false, co, hw, g.c, T::one());
                    if relu {
                        y.iter_mut().for_each(|v| *v = v.max(T::zero()));
                    }
                },
            );
            return;
        }
        let mut wf = Scratch::<T>::take(cc * kk);
        g.forward_weights(co, w.data(), &mut wf);
        let wf = &*wf;
        let tl = tiles(g.h, g.rw() * (co + g.c));
        let max_n = tl
            .iter()
            .map(|&(r0, r1)| (r1 - r0) * g.rw())
            .max()
            .unwrap_or(0);
        let mut saved = Scratch::<T>::take(batch * g.padded_len());
        let images = images.zip(saved.chunks_mut(g.padded_len()));
        let bufs = || Scratch::<T>::take(co * max_n);
        for_each_image(images, bufs, |yt, ((y, x), xp)| {
            g.pad(x, xp);
            for &(r0, r1) in &tl {
                let yt = &mut yt[..co * (r1 - r0) * g.rw()];
                for t in 0..kk {
                    let wt = MatView::row_major(&wf[t * cc..][..cc], co, g.c);
                    T::gemm_view(yt, t > 0, wt, g.x_view(xp, t, r0, r1), T::one());
                }
                g.compact(yt, r0, r1, y, relu);
            }
        });
        let x_addr = x.data().as_ptr() as usize;
        self.saved = Some(Box::new(SavedPad { x_addr, buf: saved }));
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (x, w, dy) = (cx.inputs[0], cx.inputs[1], cx.dy);
        let (batch, co, g) = self.geometry(x, w);
        let (hw, kk, cc) = (g.h * g.w, g.k * g.k, co * g.c);
        let want_w = dx.wants(1);
        let masks: Vec<Option<&[T]>> = if self.relu {
            cx.output.data().chunks(co * hw).map(Some).collect()
        } else {
            vec![None; batch]
        };
        let mut gx: Vec<Option<&mut [T]>> = match dx.slot_data(0) {
            Some(s) => s.chunks_mut(g.c * hw).map(Some).collect(),
            None => (0..batch).map(|_| None).collect(),
        };
        let want_x = gx.first().is_some_and(|g| g.is_some());
        let images = gx
            .iter_mut()
            .zip(x.data().chunks(g.c * hw))
            .zip(dy.data().chunks(co * hw))
            .zip(masks);
        let partials: Vec<Scratch<T>> = if g.k == 1 {
            let ws = w.data();
            let bufs = || {
                let masked = if self.relu { co * hw } else { 0 };
                (Scratch::<T>::zeroed(cc), Scratch::<T>::take(masked))
            };
            let parts = for_each_image_fold(images, bufs, |(dw, dym), (((gx, x), dy), mask)| {
                let dy = match mask {
                    Some(y) => {
                        for ((d, &g), &y) in dym.iter_mut().zip(dy).zip(y) {
                            *d = if y > T::zero() { g } else { T::zero() };
                        }
                        &dym[..]
                    }
                    None => dy,
                };
                if let Some(gx) = gx.as_deref_mut() {
                    T::gemm(gx, true, ws, true, dy, false, g.c, hw, co, T::one());
                }
                if want_w {
                    T::gemm(dw, true, dy, false, x, true, co, g.c, hw, T::one());
                }
            });
            parts.into_iter().map(|(dw, _)| dw).collect()
        } else {
            let mut wb = Scratch::<T>::take(if want_x { cc * kk } else { 0 });
            if want_x {
                g.backward_weights(co, w.data(), &mut wb);
            }
            let wb = &*wb;
            let wide = g.rw() == g.wz();
            let tw = tiles(g.h, g.rw() * (co + g.c * kk));
            let max_w = tw
                .iter()
                .map(|&(r0, r1)| (r1 - r0) * g.rw())
                .max()
                .unwrap_or(0);
            let (u_lo, u_hi) = g.grad_rows();
            let tx: Vec<(usize, usize)> = tiles(u_hi - u_lo, g.wz() * (co + g.c))
                .into_iter()
                .map(|(a, b)| (a + u_lo, b + u_lo))
                .collect();
            let max_x = tx
                .iter()
                .map(|&(u0, u1)| (u1 - u0) * g.wz())
                .max()
                .unwrap_or(0);
            let saved = self
                .saved
                .as_ref()
                .and_then(|b| b.downcast_ref::<SavedPad<T>>())
                .filter(|s| s.x_addr == x.data().as_ptr() as usize);
            let saved_xp: Vec<Option<&[T]>> = match saved {
                Some(s) => s.buf.chunks(g.padded_len()).map(Some).collect(),
                None => vec![None; batch],
            };
            let images = images.zip(saved_xp);
            let bufs = || {
                let (xw, xx) = (usize::from(want_w && saved.is_none()), usize::from(want_x));
                (
                    [
                        Scratch::<T>::take(xw * g.padded_len()),
                        Scratch::take(usize::from(want_w) * (g.c * kk + co) * max_w),
                        Scratch::take(usize::from(want_x || wide) * g.dyz_len(co)),
                        Scratch::take(xx * g.c * max_x),
                    ],
                    Scratch::<T>::zeroed(usize::from(want_w) * cc * kk),
                )
            };
            let parts = for_each_image_fold(
                images,
                bufs,
                |([xps, dyt, dyz, dxt], dwf), ((((gx, x), dy), mask), saved_xp)| {
                    if wide || gx.is_some() {
                        g.pad_dy(co, dy, mask, dyz);
                    }
                    if want_w {
                        let xp: &[T] = match saved_xp {
                            Some(xp) => xp,
                            None => {
                                g.pad(x, xps);
                                xps
                            }
                        };
                        for &(r0, r1) in &tw {
                            let n = (r1 - r0) * g.rw();
                            let (col, dyt) = dyt.split_at_mut(g.c * kk * n);
                            let dyv = if wide {
                                g.dy_view(co, dyz, r0, r1)
                            } else {
                                g.expand(co, dy, mask, r0, r1, &mut dyt[..co * n]);
                                MatView::row_major(&dyt[..co * n], co, n)
                            };
                            // One GEMM with a `C·k²`-wide result (k² GEMMs of width C run
                            // at half speed); ∂w comes out in the layout of w.
                            g.im2col(xp, r0, r1, col);
                            let colt = MatView::new(col, 0, n, g.c * kk, 1, n);
                            T::gemm_view(dwf, true, dyv, colt, T::one());
                        }
                    }
                    if let Some(gx) = gx.as_deref_mut() {
                        for &(u0, u1) in &tx {
                            let dxt = &mut dxt[..g.c * (u1 - u0) * g.wz()];
                            for t in 0..kk {
                                let wt = MatView::row_major(&wb[t * cc..][..cc], g.c, co);
                                let z = g.z_view(co, dyz, t, u0, u1);
                                T::gemm_view(dxt, t > 0, wt, z, T::one());
                            }
                            g.fold_rows_add(dxt, u0, u1, gx);
                        }
                    }
                },
            );
            parts.into_iter().map(|(_, dw)| dw).collect()
        };
        drop(gx);
        if let (true, Some(gw)) = (want_w, dx.slot_data(1)) {
            let mut parts = partials.into_iter();
            if let Some(mut total) = parts.next() {
                for p in parts {
                    total.iter_mut().zip(p.iter()).for_each(|(a, &b)| *a += b);
                }
                gw.iter_mut().zip(total.iter()).for_each(|(a, &b)| *a += b);
            }
        }
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn weight_inputs(&self) -> &'static [usize] {
        &[1]
    }
}

/// Runs `f(state, image)` over images: on rayon (one `init()` state per worker split) when
/// there are several, else on the calling thread so that faer may thread each GEMM itself.
pub(crate) fn for_each_image<I, S>(
    images: I,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, I::Item) + Sync + Send,
) where
    I: Iterator + Send,
    I::Item: Send,
    S: Send,
{
    for_each_image_fold(images, init, |s, item| f(s, item));
}

/// Like [`for_each_image`], returning every state used (to reduce per-worker partial sums).
pub(crate) fn for_each_image_fold<I, S>(
    images: I,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, I::Item) + Sync + Send,
) -> Vec<S>
where
    I: Iterator + Send,
    I::Item: Send,
    S: Send,
{
    let items: Vec<I::Item> = images.collect();
    if items.len() < 2 || rayon::current_num_threads() < 2 {
        let mut s = init();
        for item in items {
            f(&mut s, item);
        }
        return vec![s];
    }
    items
        .into_par_iter()
        .fold(&init, |mut s, item| {
            f(&mut s, item);
            s
        })
        .collect()
}

impl<T: Float> Tape<T> {
    /// Stride-1 "same" convolution (cross-correlation) of `x (B, Cin, H, W)` with
    /// `w (Cout, Cin, k, k)`, `k` odd, no bias → `(B, Cout, H, W)`. See [`Conv2d`].
    #[track_caller]
    pub fn conv2d(&mut self, x: Var, w: Var, padding: Padding) -> Var {
        self.apply(Conv2d::new(padding, false), &[x, w])
    }

    /// `relu(conv2d(x, w, padding))` as one op: same shapes as [`Tape::conv2d`], no extra
    /// pass for the ReLU in forward or backward. See [`Conv2d`].
    #[track_caller]
    pub fn conv2d_relu(&mut self, x: Var, w: Var, padding: Padding) -> Var {
        self.apply(Conv2d::new(padding, true), &[x, w])
    }

    /// Transposed convolution, kernel 2, stride 2: `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` →
    /// `(B, Cout, 2H, 2W)`, no bias. See [`ConvTranspose2x2`].
    #[track_caller]
    pub fn conv_transpose2x2(&mut self, x: Var, w: Var) -> Var {
        self.apply(ConvTranspose2x2, &[x, w])
    }
}

#[cfg(test)]
mod tests;
