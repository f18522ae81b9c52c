//! Bilinear grid sampling (the warp of the authors' code, docs/references.md#warp), with gradients to the image **and** to
//! the sampling grid, plus the nearest-neighbour validity mask.
//!
//! Shapes: `img (B, C, H, W)`, `grid (B, Ho, Wo, 2)` → `out (B, C, Ho, Wo)`. `grid[b, i, j]` is
//! the point `(x, y)` of `img[b]` that lands at output pixel `(i, j)`: `x` runs along the width
//! and `y` along the height, both in `[−1, 1]`.
//!
//! Semantics are PyTorch's `grid_sample(mode="bilinear", padding_mode="zeros",
//! align_corners=True)`:
//! - `x = −1` is the centre of column 0 and `x = +1` the centre of column `W − 1`, i.e. the pixel
//!   coordinate is `px = (x + 1)/2 · (W − 1)` (likewise `py` with `H`);
//! - the value is the bilinear blend of the four pixels around `(px, py)`, and pixels outside
//!   the image count as 0, so the output fades to 0 over the last pixel outside the border.
//!
//! Derivatives: with `x0 = ⌊px⌋`, `fx = px − x0` (likewise `y0`, `fy`) and corner values
//! `v00, v01 (x + 1), v10 (y + 1), v11`:
//! - `∂out/∂v` are the bilinear weights `(1−fx)(1−fy), fx(1−fy), (1−fx)fy, fx·fy` (a scatter-add);
//! - `∂out/∂x = (W − 1)/2 · [(v01 − v00)(1 − fy) + (v11 − v10) fy]`, likewise for `y`, summed
//!   over channels. The output is only piecewise smooth in the grid: the derivative jumps where
//!   `px` or `py` crosses an integer (a pixel centre), so gradient checks avoid those points.
//!
//! Work is split across the batch with rayon (each item owns its slices of the output and of
//! both gradients, so no atomics). Within an item, `kernel` computes each sample's taps once
//! and reuses them for every channel; backward runs a load-only grid-gradient pass and a
//! scatter for the image gradient, with interleaved accumulation chains. The
//! op allocates nothing beyond its output and (in backward) one pooled scratch tensor for the
//! grid gradient. Submodules: `kernel` (taps and loops), `tests`.

mod kernel;
#[cfg(test)]
mod tests;

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use kernel::{forward_item, grid_grad_item, image_grad_item, scales, Dims};
use rayon::prelude::*;

/// Names of the ops in this family (see the registry rule in [`crate::ops`]).
pub const OPS: &[&str] = &["grid_sample"];

/// `(b, c, h, w, ho, wo)` after checking the two input shapes.
#[track_caller]
fn dims(img: Shape, grid: Shape) -> (usize, usize, usize, usize, usize, usize) {
    let (b, c, h, w) = img.bchw("grid_sample");
    let g = grid.dims();
    assert!(
        g.len() == 4 && g[0] == b && g[3] == 2,
        "grid_sample: expected a grid (B, Ho, Wo, 2) with B = {b} for the image {img:?}, got {grid:?}"
    );
    (b, c, h, w, g[1], g[2])
}

struct GridSample;

impl<T: Float> Op<T> for GridSample {
    fn name(&self) -> &'static str {
        "grid_sample"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let (b, c, _, _, ho, wo) = dims(inputs[0].shape(), inputs[1].shape());
        Shape::new(&[b, c, ho, wo])
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, c, h, w, ho, wo) = dims(inputs[0].shape(), inputs[1].shape());
        let (img, grid) = (inputs[0].data(), inputs[1].data());
        let d = Dims {
            c,
            h,
            w,
            out_plane: ho * wo,
        };
        if d.out_plane == 0 || c == 0 {
            return;
        }
        if h * w == 0 {
            // Every sample is outside an empty image.
            out.data_mut().fill(T::zero());
            return;
        }
        out.data_mut()
            .par_chunks_mut(c * d.out_plane)
            .zip(img.par_chunks(c * h * w))
            .zip(grid.par_chunks(2 * d.out_plane))
            .for_each(|((out_b, img_b), grid_b)| forward_item(img_b, grid_b, out_b, d));
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (_, c, h, w, ho, wo) = dims(cx.inputs[0].shape(), cx.inputs[1].shape());
        let (img, grid, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        let d = Dims {
            c,
            h,
            w,
            out_plane: ho * wo,
        };
        let (want_img, want_grid) = (dx.wants(0), dx.wants(1));
        if d.out_plane == 0 || c * h * w == 0 || !(want_img || want_grid) {
            return;
        }
        let (img_len, grid_len, dy_len) = (c * h * w, 2 * d.out_plane, c * d.out_plane);
        // Both gradients are written in one pass, but `GradSlots` lends one slot at a time, so
        // the grid gradient goes to a scratch tensor first and is added into its slot after.
        let mut grid_grad = dx.scratch(if want_grid {
            cx.inputs[1].shape()
        } else {
            Shape::new(&[0])
        });
        // Two passes per batch item, the grid gradient (loads only) and the image gradient (a
        // scatter): kept apart, the scatter's stores never delay the other pass's loads.
        let items = img
            .par_chunks(img_len)
            .zip(grid.par_chunks(grid_len))
            .zip(dy.par_chunks(dy_len));
        match dx.slot_data(0) {
            Some(gi) if want_grid => items
                .zip(gi.par_chunks_mut(img_len))
                .zip(grid_grad.data_mut().par_chunks_mut(grid_len))
                .for_each(|((((i, g), y), gi), gg)| {
                    grid_grad_item(i, g, y, gg, d);
                    image_grad_item(g, y, gi, d);
                }),
            Some(gi) => items
                .zip(gi.par_chunks_mut(img_len))
                .for_each(|(((_, g), y), gi)| image_grad_item(g, y, gi, d)),
            None => items
                .zip(grid_grad.data_mut().par_chunks_mut(grid_len))
                .for_each(|(((i, g), y), gg)| grid_grad_item(i, g, y, gg, d)),
        }
        if want_grid {
            let slot = dx.slot_data(1).expect("wanted");
            slot.iter_mut()
                .zip(grid_grad.data())
                .for_each(|(a, &g)| *a += g);
        }
        dx.recycle(grid_grad);
    }
}

/// The validity mask of a warp: `(B, 1, Ho, Wo)`, 1 where the *nearest* pixel of the sample
/// (PyTorch `grid_sample(mode="nearest", align_corners=True)` of an all-ones image, rounding
/// half to even) lies inside the `h × w` image, else 0 (authors' code, docs/references.md#warp). No gradient.
#[track_caller]
pub fn grid_sample_mask<T: Float>(grid: &Tensor<T>, h: usize, w: usize) -> Tensor<T> {
    let mut mask = Tensor::zeros(mask_shape(grid));
    fill_grid_sample_mask(grid, h, w, &mut mask);
    mask
}

/// The shape `(B, 1, Ho, Wo)` of the mask of `grid (B, Ho, Wo, 2)`.
#[track_caller]
fn mask_shape<T: Float>(grid: &Tensor<T>) -> Shape {
    let g = grid.dims();
    assert!(
        g.len() == 4 && g[3] == 2,
        "grid_sample_mask: expected a grid (B, Ho, Wo, 2), got {:?}",
        grid.shape()
    );
    Shape::new(&[g[0], 1, g[1], g[2]])
}

/// [`grid_sample_mask`] written into `mask` (every element).
fn fill_grid_sample_mask<T: Float>(grid: &Tensor<T>, h: usize, w: usize, mask: &mut Tensor<T>) {
    let (sx, sy) = scales::<f64>(h, w);
    let inside = |v: T, s: f64, n: usize| {
        let p = ((v.as_f64() + 1.0) * s).round_ties_even();
        p >= 0.0 && p <= n as f64 - 1.0
    };
    for (p, m) in mask.data_mut().iter_mut().enumerate() {
        let (x, y) = (grid.data()[2 * p], grid.data()[2 * p + 1]);
        *m = if inside(x, sx, w) && inside(y, sy, h) {
            T::one()
        } else {
            T::zero()
        };
    }
}

impl<T: Float> Tape<T> {
    /// Bilinear sampling of `img (B, C, H, W)` at `grid (B, Ho, Wo, 2)` (`(x, y)` in `[−1, 1]`,
    /// align-corners, zeros outside) → `(B, C, Ho, Wo)`; differentiable in both inputs.
    #[track_caller]
    pub fn grid_sample(&mut self, img: Var, grid: Var) -> Var {
        self.apply(GridSample, &[img, grid])
    }

    /// [`grid_sample_mask`] of the value of `grid`, recorded as a constant. The mask is made in
    /// a buffer of the tape's pool, so that a step recording it every time takes back the buffer
    /// its last clear returned (a tensor made outside the pool would add one buffer to it per
    /// step).
    #[track_caller]
    pub fn grid_sample_mask(&mut self, grid: Var, h: usize, w: usize) -> Var {
        let shape = mask_shape(self.value(grid));
        let mut m = self.pool().uninit(shape);
        fill_grid_sample_mask(self.value(grid), h, w, &mut m);
        self.constant(m)
    }
}
