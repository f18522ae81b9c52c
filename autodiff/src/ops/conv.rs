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
//! Implementation: each image is copied once into a padded buffer; row tiles of the output
//! are computed at padded width so that every row of the column matrix (`Cin·k² × pixels`,
//! see [`lowering`]) is one contiguous window of that buffer, and each tile is one faer GEMM
//! `W (Cout × Cin·k²) · col`. Backward re-gathers `col` for `∂W += dy · colᵀ`, and scatters
//! `dcol = Wᵀ · dy` back through the exact adjoints of the gather and the padding (so reflect
//! borders fold their gradient onto the interior). Images run in parallel on rayon with
//! sequential GEMMs inside; a single image runs on the calling thread so faer may thread its
//! GEMMs. Scratch comes from a reused stash: nothing large is allocated per call once warm.

mod lowering;
mod transpose;

pub use lowering::Padding;
pub use transpose::ConvTranspose2x2;

use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use lowering::{tiles, Geometry, Scratch};
use rayon::prelude::*;

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["conv2d", "conv_transpose2x2"];

/// Stride-1 "same" 2-D cross-correlation with an odd square kernel (see the module docs).
#[derive(Clone, Debug)]
pub struct Conv2d {
    /// What the kernel reads outside the image.
    pub padding: Padding,
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
        "conv2d"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "conv2d: takes (x, w)");
        check_conv_shapes(inputs[0].shape(), inputs[1].shape(), self.padding);
        let (b, _, h, w) = inputs[0].shape().bchw("conv2d");
        Shape::new(&[b, inputs[1].dims()[0], h, w])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (x, w) = (inputs[0], inputs[1]);
        let (_, co, g) = self.geometry(x, w);
        let (hw, kk) = (g.h * g.w, g.col_rows());
        let ws = w.data();
        let images = out
            .data_mut()
            .chunks_mut(co * hw)
            .zip(x.data().chunks(g.c * hw));
        if g.k == 1 {
            // A 1×1 kernel needs no gathering: y_b = W · x_b.
            for_each_image(
                images,
                || (),
                |_, (y, x)| T::gemm(y, false, ws, false, x, false, co, hw, g.c, T::one()),
            );
            return;
        }
        let tl = tiles(&g);
        let max_n = tl
            .iter()
            .map(|&(r0, r1)| (r1 - r0) * g.wp())
            .max()
            .unwrap_or(0);
        let bufs = || {
            [
                Scratch::<T>::take(g.padded_len()),
                Scratch::take(kk * max_n),
                Scratch::take(co * max_n),
            ]
        };
        for_each_image(images, bufs, |[xp, col, yt], (y, x)| {
            g.pad(x, xp);
            for &(r0, r1) in &tl {
                let n = (r1 - r0) * g.wp();
                let (col, yt) = (&mut col[..kk * n], &mut yt[..co * n]);
                g.im2col(xp, r0, r1, col);
                T::gemm(yt, false, ws, false, col, false, co, n, kk, T::one());
                g.compact(yt, r0, r1, y);
            }
        });
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (x, w, dy) = (cx.inputs[0], cx.inputs[1], cx.dy);
        let (batch, co, g) = self.geometry(x, w);
        let (hw, kk) = (g.h * g.w, g.col_rows());
        let (ws, want_w) = (w.data(), dx.wants(1));
        let mut gx: Vec<Option<&mut [T]>> = match dx.slot_data(0) {
            Some(s) => s.chunks_mut(g.c * hw).map(Some).collect(),
            None => (0..batch).map(|_| None).collect(),
        };
        let images = gx
            .iter_mut()
            .zip(x.data().chunks(g.c * hw))
            .zip(dy.data().chunks(co * hw));
        let partials: Vec<Scratch<T>> = if g.k == 1 {
            for_each_image_fold(
                images,
                || Scratch::<T>::zeroed(co * kk),
                |dw, ((gx, x), dy)| {
                    if let Some(gx) = gx.as_deref_mut() {
                        T::gemm(gx, true, ws, true, dy, false, g.c, hw, co, T::one());
                    }
                    if want_w {
                        T::gemm(dw, true, dy, false, x, true, co, g.c, hw, T::one());
                    }
                },
            )
        } else {
            let tl = tiles(&g);
            let max_n = tl
                .iter()
                .map(|&(r0, r1)| (r1 - r0) * g.wp())
                .max()
                .unwrap_or(0);
            let bufs = || {
                let b = [
                    Scratch::<T>::take(g.padded_len()),
                    Scratch::take(kk * max_n),
                    Scratch::take(co * max_n),
                ];
                (
                    b,
                    Scratch::<T>::take(g.padded_len()),
                    Scratch::<T>::zeroed(co * kk),
                )
            };
            let parts =
                for_each_image_fold(images, bufs, |([xp, col, dyt], dxp, dw), ((gx, x), dy)| {
                    if want_w {
                        g.pad(x, xp);
                    }
                    if gx.is_some() {
                        dxp.fill(T::zero());
                    }
                    for &(r0, r1) in &tl {
                        let n = (r1 - r0) * g.wp();
                        let (col, dyt) = (&mut col[..kk * n], &mut dyt[..co * n]);
                        g.expand(dy, r0, r1, dyt);
                        if want_w {
                            g.im2col(xp, r0, r1, col);
                            T::gemm(dw, true, dyt, false, col, true, co, kk, n, T::one());
                        }
                        if gx.is_some() {
                            T::gemm(col, false, ws, true, dyt, false, kk, n, co, T::one());
                            g.col2im_add(col, r0, r1, dxp);
                        }
                    }
                    if let Some(gx) = gx.as_deref_mut() {
                        g.fold_add(dxp, gx);
                    }
                });
            parts.into_iter().map(|(_, _, dw)| dw).collect()
        };
        drop(gx);
        if let (true, Some(gw)) = (want_w, dx.slot_data(1)) {
            for p in &partials {
                for (a, &v) in gw.iter_mut().zip(p.iter()) {
                    *a += v;
                }
            }
        }
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
        self.apply(Conv2d { padding }, &[x, w])
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
