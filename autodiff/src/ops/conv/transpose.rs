//! `conv_transpose2x2`: transposed convolution, kernel 2, stride 2 (the U-Net's up-sampling).
//!
//! `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` (PyTorch `ConvTranspose2d` layout) →
//! `y (B, Cout, 2H, 2W)`, `y[b,o,2i+a,2j+c] = Σ_ci x[b,ci,i,j] · w[ci,o,a,c]`. No bias.
//! With `M = w` viewed as `Cin × (Cout·4)`, one image is the GEMM `Z = Mᵀ · x_b`
//! (`(Cout·4) × HW`) followed by a pixel shuffle `Z[(o,a,c), (i,j)] → y[o, 2i+a, 2j+c]`.
//! Backward un-shuffles `dy` into `dZ`, then `∂x_b += M · dZ` and `∂M += x_b · dZᵀ`.

use super::lowering::Scratch;
use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tensor};
use rayon::prelude::*;

/// The stride-2, 2×2 transposed convolution (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct ConvTranspose2x2;

/// `(batch, cin, cout, h, w)` after checking the shapes.
#[track_caller]
fn dims(x: Shape, w: Shape) -> (usize, usize, usize, usize, usize) {
    let (b, c, h, wd) = x.bchw("conv_transpose2x2");
    let (ci, co, k0, k1) = w.bchw("conv_transpose2x2 weight");
    assert!(
        ci == c && k0 == 2 && k1 == 2,
        "conv_transpose2x2: input {x:?} and weight {w:?} do not fit (want weight ({c}, Cout, 2, 2))"
    );
    (b, c, co, h, wd)
}

/// `dst[(o·4 + a·2 + c)·hw + i·w + j] ⇄ img[o, 2i+a, 2j+c]` for one image.
fn shuffle<T: Float>(z: &[T], y: &mut [T], co: usize, h: usize, w: usize) {
    for o in 0..co {
        let yo = &mut y[o * 4 * h * w..(o + 1) * 4 * h * w];
        for a in 0..2 {
            for c in 0..2 {
                let zr = &z[(o * 4 + a * 2 + c) * h * w..][..h * w];
                for i in 0..h {
                    let row = &mut yo[(2 * i + a) * 2 * w..][..2 * w];
                    for (j, &v) in zr[i * w..(i + 1) * w].iter().enumerate() {
                        row[2 * j + c] = v;
                    }
                }
            }
        }
    }
}

fn unshuffle<T: Float>(y: &[T], z: &mut [T], co: usize, h: usize, w: usize) {
    for o in 0..co {
        let yo = &y[o * 4 * h * w..(o + 1) * 4 * h * w];
        for a in 0..2 {
            for c in 0..2 {
                let zr = &mut z[(o * 4 + a * 2 + c) * h * w..][..h * w];
                for i in 0..h {
                    let row = &yo[(2 * i + a) * 2 * w..][..2 * w];
                    for (j, v) in zr[i * w..(i + 1) * w].iter_mut().enumerate() {
                        *v = row[2 * j + c];
                    }
                }
            }
        }
    }
}

impl<T: Float> Op<T> for ConvTranspose2x2 {
    fn name(&self) -> &'static str {
        "conv_transpose2x2"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "conv_transpose2x2: takes (x, w)");
        let (b, _, co, h, w) = dims(inputs[0].shape(), inputs[1].shape());
        Shape::new(&[b, co, 2 * h, 2 * w])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (x, w) = (inputs[0], inputs[1]);
        let (_, ci, co, h, wd) = dims(x.shape(), w.shape());
        let hw = h * wd;
        let ws = w.data();
        out.data_mut()
            .par_chunks_mut(co * 4 * hw)
            .zip(x.data().par_chunks(ci * hw))
            .for_each_init(
                || Scratch::<T>::take(co * 4 * hw),
                |z, (y, xb)| {
                    T::gemm(z, false, ws, true, xb, false, co * 4, hw, ci, T::one());
                    shuffle(z, y, co, h, wd);
                },
            );
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (x, w, dy) = (cx.inputs[0], cx.inputs[1], cx.dy);
        let (batch, ci, co, h, wd) = dims(x.shape(), w.shape());
        let hw = h * wd;
        let (xs, ws, dys) = (x.data(), w.data(), dy.data());
        let want_w = dx.wants(1);
        let mut gx_chunks: Vec<Option<&mut [T]>> = match dx.slot_data(0) {
            Some(g) => g.chunks_mut(ci * hw).map(Some).collect(),
            None => (0..batch).map(|_| None).collect(),
        };
        let partials: Vec<Option<Scratch<T>>> = gx_chunks
            .par_iter_mut()
            .enumerate()
            .fold(
                || (Scratch::<T>::take(co * 4 * hw), None),
                |(mut dz, mut dw_part), (b, gx)| {
                    unshuffle(
                        &dys[b * co * 4 * hw..(b + 1) * co * 4 * hw],
                        &mut dz,
                        co,
                        h,
                        wd,
                    );
                    if let Some(gx) = gx.as_deref_mut() {
                        T::gemm(gx, true, ws, false, &dz, false, ci, hw, co * 4, T::one());
                    }
                    if want_w {
                        let acc: &mut Scratch<T> =
                            dw_part.get_or_insert_with(|| Scratch::zeroed(ci * co * 4));
                        let xb = &xs[b * ci * hw..(b + 1) * ci * hw];
                        T::gemm(acc, true, xb, false, &dz, true, ci, co * 4, hw, T::one());
                    }
                    (dz, dw_part)
                },
            )
            .map(|(_, p)| p)
            .collect();
        drop(gx_chunks);
        if let Some(gw) = dx.slot_data(1) {
            for p in partials.iter().flatten() {
                for (a, &v) in gw.iter_mut().zip(p.iter()) {
                    *a += v;
                }
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
