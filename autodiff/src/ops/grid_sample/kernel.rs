//! The per-batch-item kernels of [`super`]: bilinear taps, forward, and the two backward
//! passes (grid gradient, image gradient).
//!
//! Layout: one batch item at a time, `img (C, H, W)`, `grid (Ho, Wo, 2)` as `(x, y)` pairs,
//! `out`/`dy (C, Ho, Wo)`, all row-major. The taps of a sample (four flat indices, four
//! weights and their derivatives in `px`, `py`) are computed once per sample and used for every
//! channel: in registers (forward, grid gradient: sample outer, channel inner) or in a block
//! buffer (image gradient: channel outer, see [`image_grad_item`]).
//!
//! Outside corners get index 0 and zero weight (and zero weight derivatives): they read and add
//! nothing, which is PyTorch's `padding_mode="zeros"`.

use crate::Float;

/// The four bilinear taps of one sample, in corner order `(x0, y0), (x0+1, y0), (x0, y0+1),
/// (x0+1, y0+1)`: flat pixel indices (0 where outside), weights, and the weights' derivatives
/// in `px` and `py` (all 0 where outside).
#[derive(Clone, Copy, Debug)]
pub(super) struct Taps<T> {
    pub idx: [usize; 4],
    pub w: [T; 4],
    pub dwx: [T; 4],
    pub dwy: [T; 4],
}

/// `(⌊p⌋, p − ⌊p⌋)` without a libm call. The cast saturates, so far-away samples stay far away
/// (and outside); NaN maps to index 0 with a NaN fraction, as `floor` would give.
#[inline(always)]
fn floor_split<T: Float>(p: T) -> (isize, T) {
    let t = p.as_f64();
    let mut i = t as isize;
    if (i as f64) > t {
        i = i.saturating_sub(1);
    }
    (i, p - T::of(i as f64))
}

/// Taps of the grid point `(gx, gy)` in an `h × w` image; `(sx, sy)` are `((w−1)/2, (h−1)/2)`.
#[inline(always)]
pub(super) fn taps<T: Float>(gx: T, gy: T, (h, w): (usize, usize), (sx, sy): (T, T)) -> Taps<T> {
    let (zero, one) = (T::zero(), T::one());
    let (x0, fx) = floor_split((gx + one) * sx);
    let (y0, fy) = floor_split((gy + one) * sy);
    let (ex, ey) = (one - fx, one - fy);
    let x1 = x0.wrapping_add(1);
    let y1 = y0.wrapping_add(1);
    // Negative values wrap to huge unsigned ones, so one comparison checks both ends.
    let inx = [(x0 as usize) < w, (x1 as usize) < w];
    let iny = [(y0 as usize) < h, (y1 as usize) < h];
    let corner = [(0, 0), (1, 0), (0, 1), (1, 1)];
    let xs = [x0 as usize, x1 as usize];
    let ys = [y0 as usize, y1 as usize];
    let w_all = [ex * ey, fx * ey, ex * fy, fx * fy];
    let dwx_all = [-ey, ey, -fy, fy];
    let dwy_all = [-ex, -fx, ex, fx];
    let mut t = Taps {
        idx: [0; 4],
        w: [zero; 4],
        dwx: [zero; 4],
        dwy: [zero; 4],
    };
    for k in 0..4 {
        let (a, b) = corner[k];
        if inx[a] && iny[b] {
            t.idx[k] = ys[b] * w + xs[a];
            t.w[k] = w_all[k];
            t.dwx[k] = dwx_all[k];
            t.dwy[k] = dwy_all[k];
        }
    }
    t
}

/// `(W − 1)/2` and `(H − 1)/2`: pixels per unit of grid coordinate.
pub(super) fn scales<T: Float>(h: usize, w: usize) -> (T, T) {
    (T::of((w as f64 - 1.0) / 2.0), T::of((h as f64 - 1.0) / 2.0))
}

/// Shapes of one batch item: channels, image `(h, w)`, output pixels `ho·wo`.
#[derive(Clone, Copy)]
pub(super) struct Dims {
    pub c: usize,
    pub h: usize,
    pub w: usize,
    pub out_plane: usize,
}

/// Forward of one batch item: `out[ch, p] = Σ_k w_k · img[ch, idx_k]` (overwrites `out`).
pub(super) fn forward_item<T: Float>(img: &[T], grid: &[T], out: &mut [T], d: Dims) {
    let plane = d.h * d.w;
    let s = scales::<T>(d.h, d.w);
    assert!(img.len() == d.c * plane && out.len() == d.c * d.out_plane);
    for (p, g) in grid.chunks_exact(2).enumerate() {
        let t = taps(g[0], g[1], (d.h, d.w), s);
        for (src, o) in img
            .chunks_exact(plane)
            .zip(out[p..].iter_mut().step_by(d.out_plane))
        {
            *o = t.w[0] * src[t.idx[0]]
                + t.w[1] * src[t.idx[1]]
                + t.w[2] * src[t.idx[2]]
                + t.w[3] * src[t.idx[3]];
        }
    }
}

/// Independent accumulation chains of the image-gradient scatter (see [`image_grad_item`]).
const LANES: usize = 4;
/// Samples whose taps are computed together, then reused for every channel.
const BLOCK: usize = 512;

/// `gg[p] = (sx, sy) · Σ_ch dy[ch, p] · (Σ_k dw{x,y}_k · img[ch, idx_k])` (overwrites `gg`).
/// Loads only (no stores into the image-sized buffers), so nothing waits on a scatter.
pub(super) fn grid_grad_item<T: Float>(img: &[T], grid: &[T], dy: &[T], gg: &mut [T], d: Dims) {
    let plane = d.h * d.w;
    let s = scales::<T>(d.h, d.w);
    assert!(img.len() == d.c * plane && dy.len() == d.c * d.out_plane && gg.len() == grid.len());
    for (p, (g, out)) in grid.chunks_exact(2).zip(gg.chunks_exact_mut(2)).enumerate() {
        let t = taps(g[0], g[1], (d.h, d.w), s);
        let (mut ax, mut ay) = (T::zero(), T::zero());
        for (v, &dv) in img
            .chunks_exact(plane)
            .zip(dy[p..].iter().step_by(d.out_plane))
        {
            let vs = t.idx.map(|i| v[i]);
            let dot = |dw: &[T; 4]| dw[0] * vs[0] + dw[1] * vs[1] + dw[2] * vs[2] + dw[3] * vs[3];
            ax += dv * dot(&t.dwx);
            ay += dv * dot(&t.dwy);
        }
        out[0] = ax * s.0;
        out[1] = ay * s.1;
    }
}

/// Adds `w_k · dy[ch, p]` into `gi[ch, idx_k]` for every sample `p` and channel `ch`.
///
/// Neighbouring samples share corners, so a scatter in pixel order is one long chain of
/// read-modify-writes through memory. Per block of samples, the taps are computed once and
/// ordered so that [`LANES`] samples far apart in the block (different output rows for a
/// typical warp) alternate: the chains interleave and their latencies overlap. Channels go one
/// plane at a time, so the scatter stays within one plane's cache lines.
pub(super) fn image_grad_item<T: Float>(grid: &[T], dy: &[T], gi: &mut [T], d: Dims) {
    let plane = d.h * d.w;
    let s = scales::<T>(d.h, d.w);
    assert!(dy.len() == d.c * d.out_plane && gi.len() == d.c * plane);
    let mut idx = [[0usize; 4]; BLOCK];
    let mut wts = [[T::zero(); 4]; BLOCK];
    let mut pix = [0usize; BLOCK];
    for p0 in (0..d.out_plane).step_by(BLOCK) {
        let n = BLOCK.min(d.out_plane - p0);
        let lane = n / LANES;
        // Slot q < LANES·lane holds sample (q % LANES)·lane + q / LANES; the rest, in order.
        for q in 0..n {
            let local = if q < LANES * lane {
                (q % LANES) * lane + q / LANES
            } else {
                q
            };
            let p = p0 + local;
            let t = taps(grid[2 * p], grid[2 * p + 1], (d.h, d.w), s);
            (idx[q], wts[q], pix[q]) = (t.idx, t.w, p);
        }
        for (g, dyc) in gi.chunks_exact_mut(plane).zip(dy.chunks_exact(d.out_plane)) {
            for ((ix, wt), &p) in idx[..n].iter().zip(&wts[..n]).zip(&pix[..n]) {
                let dv = dyc[p];
                for k in 0..4 {
                    g[ix[k]] += wt[k] * dv;
                }
            }
        }
    }
}
