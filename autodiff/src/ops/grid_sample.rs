//! Bilinear grid sampling (the warp of official §3.7), with gradients to the image **and** to
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
//! Work is split across the batch with rayon; per-sample taps are computed for a block of pixels
//! on the stack and reused for every channel, so the op allocates nothing beyond its output and
//! (in backward) one pooled scratch tensor for the grid gradient.

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Names of the ops in this family (see the registry rule in [`crate::ops`]).
pub const OPS: &[&str] = &["grid_sample"];

/// Output pixels whose taps are computed together and reused across channels.
const BLOCK: usize = 64;

/// The four bilinear taps of one sample: flat pixel indices, weights (0 for pixels outside the
/// image), in-image flags, and the fractional offsets.
#[derive(Clone, Copy, Default)]
struct Taps<T> {
    idx: [usize; 4],
    w: [T; 4],
    inside: [T; 4],
    fx: T,
    fy: T,
}

/// `(W − 1)/2` and `(H − 1)/2`: pixels per unit of grid coordinate.
fn scales<T: Float>(h: usize, w: usize) -> (T, T) {
    (T::of((w as f64 - 1.0) / 2.0), T::of((h as f64 - 1.0) / 2.0))
}

#[inline(always)]
fn taps<T: Float>(gx: T, gy: T, (h, w): (usize, usize), (sx, sy): (T, T)) -> Taps<T> {
    let one = T::one();
    let (px, py) = ((gx + one) * sx, (gy + one) * sy);
    let (x0f, y0f) = (px.floor(), py.floor());
    let (fx, fy) = (px - x0f, py - y0f);
    // Saturating float → int casts keep far-away samples far away (and outside).
    let (x0, y0) = (x0f.as_f64() as isize, y0f.as_f64() as isize);
    let corners = [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)];
    let weights = [
        (one - fx) * (one - fy),
        fx * (one - fy),
        (one - fx) * fy,
        fx * fy,
    ];
    let mut t = Taps {
        fx,
        fy,
        ..Taps::default()
    };
    for k in 0..4 {
        let (cx, cy) = corners[k];
        if cx >= 0 && cy >= 0 && (cx as usize) < w && (cy as usize) < h {
            t.idx[k] = cy as usize * w + cx as usize;
            t.inside[k] = one;
            t.w[k] = weights[k];
        }
    }
    t
}

/// Fills `taps[..n]` for the output pixels `p0..p0 + n` of one batch item's grid.
#[inline(always)]
fn block_taps<T: Float>(
    grid: &[T],
    p0: usize,
    taps_out: &mut [Taps<T>],
    hw: (usize, usize),
    s: (T, T),
) {
    for (k, t) in taps_out.iter_mut().enumerate() {
        let p = p0 + k;
        *t = taps(grid[2 * p], grid[2 * p + 1], hw, s);
    }
}

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

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, c, h, w, ho, wo) = dims(inputs[0].shape(), inputs[1].shape());
        let (img, grid) = (inputs[0].data(), inputs[1].data());
        let (plane, out_plane) = (h * w, ho * wo);
        if out_plane == 0 || c == 0 {
            return;
        }
        let s = scales::<T>(h, w);
        out.data_mut()
            .par_chunks_mut(c * out_plane)
            .enumerate()
            .for_each(|(b, out_b)| {
                let img_b = &img[b * c * plane..][..c * plane];
                let grid_b = &grid[b * 2 * out_plane..][..2 * out_plane];
                let mut tp = [Taps::<T>::default(); BLOCK];
                for p0 in (0..out_plane).step_by(BLOCK) {
                    let n = BLOCK.min(out_plane - p0);
                    block_taps(grid_b, p0, &mut tp[..n], (h, w), s);
                    for ch in 0..c {
                        let src = &img_b[ch * plane..][..plane];
                        let dst = &mut out_b[ch * out_plane + p0..][..n];
                        for (o, t) in dst.iter_mut().zip(&tp[..n]) {
                            *o = t.w[0] * src[t.idx[0]]
                                + t.w[1] * src[t.idx[1]]
                                + t.w[2] * src[t.idx[2]]
                                + t.w[3] * src[t.idx[3]];
                        }
                    }
                }
            });
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (_, c, h, w, ho, wo) = dims(cx.inputs[0].shape(), cx.inputs[1].shape());
        let (img, grid, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        let (plane, out_plane) = (h * w, ho * wo);
        let (want_img, want_grid) = (dx.wants(0), dx.wants(1));
        if out_plane == 0 || c == 0 || !(want_img || want_grid) {
            return;
        }
        let s = scales::<T>(h, w);
        let mut grid_grad = dx.scratch(if want_grid {
            cx.inputs[1].shape()
        } else {
            Shape::new(&[0])
        });
        let mut no_img_grad: [T; 0] = [];
        let img_grad: &mut [T] = match dx.slot_data(0) {
            Some(g) => g,
            None => &mut no_img_grad,
        };
        let img_chunk = if want_img { c * plane } else { 0 };
        let grid_chunk = if want_grid { 2 * out_plane } else { 0 };
        let one_batch = |b: usize, gi: &mut [T], gg: &mut [T]| {
            let img_b = &img[b * c * plane..][..c * plane];
            let grid_b = &grid[b * 2 * out_plane..][..2 * out_plane];
            let dy_b = &dy[b * c * out_plane..][..c * out_plane];
            let mut tp = [Taps::<T>::default(); BLOCK];
            let mut acc = [(T::zero(), T::zero()); BLOCK];
            for p0 in (0..out_plane).step_by(BLOCK) {
                let n = BLOCK.min(out_plane - p0);
                block_taps(grid_b, p0, &mut tp[..n], (h, w), s);
                acc[..n].fill((T::zero(), T::zero()));
                for ch in 0..c {
                    let d = &dy_b[ch * out_plane + p0..][..n];
                    if want_img {
                        let g = &mut gi[ch * plane..][..plane];
                        for (t, &d) in tp[..n].iter().zip(d) {
                            for k in 0..4 {
                                g[t.idx[k]] += t.w[k] * d;
                            }
                        }
                    }
                    if want_grid {
                        let v = &img_b[ch * plane..][..plane];
                        for ((t, &d), a) in tp[..n].iter().zip(d).zip(&mut acc[..n]) {
                            let [v00, v01, v10, v11] =
                                [0, 1, 2, 3].map(|k| t.inside[k] * v[t.idx[k]]);
                            let one = T::one();
                            a.0 += d * ((v01 - v00) * (one - t.fy) + (v11 - v10) * t.fy);
                            a.1 += d * ((v10 - v00) * (one - t.fx) + (v11 - v01) * t.fx);
                        }
                    }
                }
                if want_grid {
                    for (k, a) in acc[..n].iter().enumerate() {
                        gg[2 * (p0 + k)] = a.0 * s.0;
                        gg[2 * (p0 + k) + 1] = a.1 * s.1;
                    }
                }
            }
        };
        // Each batch item owns its slices of both gradients, so the items run in parallel.
        let gg = grid_grad.data_mut();
        match (want_img, want_grid) {
            (true, true) => img_grad
                .par_chunks_mut(img_chunk)
                .zip(gg.par_chunks_mut(grid_chunk))
                .enumerate()
                .for_each(|(b, (gi, gg))| one_batch(b, gi, gg)),
            (true, false) => img_grad
                .par_chunks_mut(img_chunk)
                .enumerate()
                .for_each(|(b, gi)| one_batch(b, gi, &mut [])),
            _ => gg
                .par_chunks_mut(grid_chunk)
                .enumerate()
                .for_each(|(b, gg)| one_batch(b, &mut [], gg)),
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
/// half to even) lies inside the `h × w` image, else 0 (official §3.7 step 5). No gradient.
#[track_caller]
pub fn grid_sample_mask<T: Float>(grid: &Tensor<T>, h: usize, w: usize) -> Tensor<T> {
    let g = grid.dims();
    assert!(
        g.len() == 4 && g[3] == 2,
        "grid_sample_mask: expected a grid (B, Ho, Wo, 2), got {:?}",
        grid.shape()
    );
    let (sx, sy) = scales::<f64>(h, w);
    let inside = |v: T, s: f64, n: usize| {
        let p = ((v.as_f64() + 1.0) * s).round_ties_even();
        p >= 0.0 && p <= n as f64 - 1.0
    };
    Tensor::from_fn([g[0], 1, g[1], g[2]], |p| {
        let (x, y) = (grid.data()[2 * p], grid.data()[2 * p + 1]);
        if inside(x, sx, w) && inside(y, sy, h) {
            T::one()
        } else {
            T::zero()
        }
    })
}

impl<T: Float> Tape<T> {
    /// Bilinear sampling of `img (B, C, H, W)` at `grid (B, Ho, Wo, 2)` (`(x, y)` in `[−1, 1]`,
    /// align-corners, zeros outside) → `(B, C, Ho, Wo)`; differentiable in both inputs.
    #[track_caller]
    pub fn grid_sample(&mut self, img: Var, grid: Var) -> Var {
        self.apply(GridSample, &[img, grid])
    }

    /// [`grid_sample_mask`] of the value of `grid`, recorded as a constant.
    #[track_caller]
    pub fn grid_sample_mask(&mut self, grid: Var, h: usize, w: usize) -> Var {
        let m = grid_sample_mask(self.value(grid), h, w);
        self.constant(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies, CheckConfig};
    use proptest::prelude::*;

    /// A grid coordinate in `[−lim, lim]` whose pixel position `(v + 1)/2·(n − 1)` is at least
    /// `margin` pixels away from every integer (the kinks of bilinear interpolation).
    fn coord(n: usize, lim: f64, margin: f64) -> impl Strategy<Value = f64> {
        (-lim..lim).prop_map(move |v| {
            let s = (n as f64 - 1.0) / 2.0;
            if s == 0.0 {
                return v;
            }
            let p = (v + 1.0) * s;
            let frac = p - p.floor();
            let p = if frac < margin {
                p.floor() + margin
            } else if frac > 1.0 - margin {
                p.floor() + 1.0 - margin
            } else {
                p
            };
            p / s - 1.0
        })
    }

    fn grid_for(
        b: usize,
        ho: usize,
        wo: usize,
        h: usize,
        w: usize,
        lim: f64,
    ) -> impl Strategy<Value = Tensor<f64>> {
        proptest::collection::vec((coord(w, lim, 0.02), coord(h, lim, 0.02)), b * ho * wo).prop_map(
            move |v| {
                Tensor::from_fn([b, ho, wo, 2], |i| {
                    if i % 2 == 0 {
                        v[i / 2].0
                    } else {
                        v[i / 2].1
                    }
                })
            },
        )
    }

    /// Image `(B, C, H, W)` and a grid reaching past the border (`|x|, |y| ≤ 1.3`), so samples
    /// fall inside, on the fading last pixel outside, and fully outside.
    fn case() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>)> {
        (
            1usize..=2,
            1usize..=3,
            1usize..=5,
            1usize..=5,
            1usize..=4,
            1usize..=4,
        )
            .prop_flat_map(|(b, c, h, w, ho, wo)| {
                (
                    strategies::tensor_of(vec![b, c, h, w]),
                    grid_for(b, ho, wo, h, w, 1.3),
                )
            })
    }

    proptest! {
        #![proptest_config(strategies::config())]

        #[test]
        fn grid_sample_gradient((img, grid) in case()) {
            check_gradients(|t, v| t.grid_sample(v[0], v[1]), &[img, grid], &CheckConfig::default())
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
        }

        /// Samples hugging the border from both sides: pixel positions in `(−1, 0)` and
        /// `(W − 1, W)`, where only one column (row) of taps is inside.
        #[test]
        fn grid_sample_gradient_at_the_edge(
            (img, grid) in (1usize..=2, 2usize..=5, 2usize..=5).prop_flat_map(|(c, h, w)| (
                strategies::tensor_of(vec![1, c, h, w]),
                proptest::collection::vec((0.02f64..0.98, any::<bool>(), 0.02f64..0.98, any::<bool>()), 6)
                    .prop_map(move |v| {
                        let edge = |f: f64, hi: bool, n: usize| {
                            let p = if hi { n as f64 - 1.0 + f } else { -f };
                            p / ((n as f64 - 1.0) / 2.0) - 1.0
                        };
                        Tensor::from_fn([1, 2, 3, 2], |i| {
                            let (fx, hx, fy, hy) = v[i / 2];
                            if i % 2 == 0 { edge(fx, hx, w) } else { edge(fy, hy, h) }
                        })
                    }),
            ))
        ) {
            check_gradients(|t, v| t.grid_sample(v[0], v[1]), &[img, grid], &CheckConfig::default())
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
        }
    }

    #[test]
    fn identity_grid_reproduces_the_image_and_corners_are_pixel_centres() {
        let (h, w) = (4, 5);
        let img = Tensor::from_fn([2, 3, h, w], |i| (i as f64 * 0.61).sin());
        let grid = Tensor::from_fn([2, h, w, 2], |i| {
            let p = (i / 2) % (h * w);
            let (y, x) = (p / w, p % w);
            if i % 2 == 0 {
                2.0 * x as f64 / (w - 1) as f64 - 1.0
            } else {
                2.0 * y as f64 / (h - 1) as f64 - 1.0
            }
        });
        let mut tape = Tape::<f64>::new();
        let (vi, vg) = (tape.constant(img.clone()), tape.constant(grid));
        let out = tape.grid_sample(vi, vg);
        assert!(tape.value(out).max_abs_diff(&img) < 1e-12);
    }

    #[test]
    fn bilinear_value_and_zero_padding() {
        // 2×2 image [[1, 2], [3, 4]]: the centre is the mean; half a pixel outside column 0 is
        // half of the left column blend; far outside is 0.
        let img = Tensor::from_vec([1, 1, 2, 2], vec![1.0, 2.0, 3.0, 4.0]);
        let grid = Tensor::from_vec([1, 1, 3, 2], vec![0.0, 0.0, -2.0, -1.0, 5.0, 0.0]);
        let mut tape = Tape::<f64>::new();
        let (vi, vg) = (tape.constant(img), tape.constant(grid));
        let out = tape.grid_sample(vi, vg);
        // x = −2 → px = −0.5: half of column 0 at row 0 (value 1).
        assert_eq!(tape.value(out).data(), &[2.5, 0.5, 0.0]);
    }

    #[test]
    fn mask_uses_nearest_pixel() {
        // Width 5: px = (x + 1)·2. Inside iff round(px) ∈ [0, 4].
        let xs = [-1.24, -1.26, 1.24, 1.26, 0.0];
        let grid = Tensor::from_fn([1, 1, 5, 2], |i| if i % 2 == 0 { xs[i / 2] } else { 0.0 });
        let m = grid_sample_mask(&grid, 3, 5);
        assert_eq!(m.dims(), &[1, 1, 1, 5]);
        assert_eq!(m.data(), &[1.0, 0.0, 1.0, 0.0, 1.0]);
    }

    #[test]
    #[should_panic(
        expected = "grid_sample: expected a grid (B, Ho, Wo, 2) with B = 2 for the image (2, 1, 4, 4), got (3, 4, 4, 2)"
    )]
    fn batch_mismatch_panics_with_both_shapes() {
        let mut tape = Tape::<f32>::new();
        let img = tape.constant(Tensor::zeros([2, 1, 4, 4]));
        let grid = tape.constant(Tensor::zeros([3, 4, 4, 2]));
        tape.grid_sample(img, grid);
    }
}
