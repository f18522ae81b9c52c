//! Lowering a convolution to GEMM through a padded copy of each image, plus the reusable
//! scratch buffers the kernels use.
//!
//! Padding: the image `(C, H, W)` is copied once into a padded plane per channel of size
//! `Hp × Wp = (H + 2p) × (W + 2p)`, `p = (k − 1)/2`, filled outside the image with zeros or
//! PyTorch `'reflect'` values (mirror without repeating the edge: index −1 reads 1, index H
//! reads H − 2). The buffer has `2p` zeros of slack after the last plane.
//!
//! Padded-width trick: outputs are computed at every position `q = i·Wp + j`, `j < Wp`; the
//! `2p` positions with `j ≥ W` per row are junk and dropped. Then the column-matrix row of
//! channel `c` and tap `(a, b)` is the *contiguous* window `xp[c·Hp·Wp + a·Wp + b + q]`, so
//! `im2col` is `C·k²` plain copies. A tile is output rows `r0..r1`, `P = (r1 − r0)·Wp`
//! positions; its column matrix is `(C·k²) × P` row-major, row `(c·k + a)·k + b`.
//!
//! Backward runs the same maps transposed: `col2im` adds each window back into a padded
//! gradient buffer, and `fold` adds every padded position into the pixel it was read from
//! (so reflect borders fold their gradient onto the interior). Junk positions carry zero
//! gradient because `expand` writes zeros there.

use crate::Float;
use std::any::Any;
use std::sync::Mutex;

/// How a "same" convolution reads outside the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Padding {
    /// Zeros outside the image (PyTorch `padding_mode='zeros'`).
    Zero,
    /// Mirror about the edge pixel without repeating it (PyTorch `padding_mode='reflect'`).
    /// Needs `(k − 1)/2 < H` and `< W`.
    Reflect,
}

/// Source index of padded coordinate `i` along an axis of length `n`, or `None` for a zero.
#[inline(always)]
pub(crate) fn source(i: isize, n: usize, mode: Padding) -> Option<usize> {
    let n = n as isize;
    if (0..n).contains(&i) {
        return Some(i as usize);
    }
    match mode {
        Padding::Zero => None,
        Padding::Reflect => {
            let r = if i < 0 { -i } else { 2 * (n - 1) - i };
            debug_assert!((0..n).contains(&r), "reflect padding wider than the image");
            Some(r as usize)
        }
    }
}

/// Geometry of one image's convolution: channels, size, kernel side, padding.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Geometry {
    pub c: usize,
    pub h: usize,
    pub w: usize,
    pub k: usize,
    pub mode: Padding,
}

impl Geometry {
    /// Half kernel width `p`.
    pub fn p(&self) -> usize {
        self.k / 2
    }

    /// Padded width `Wp = W + 2p`.
    pub fn wp(&self) -> usize {
        self.w + 2 * self.p()
    }

    /// Padded plane size `Hp·Wp`.
    fn plane(&self) -> usize {
        (self.h + 2 * self.p()) * self.wp()
    }

    /// Length of the padded buffer of one image (all planes plus slack).
    pub fn padded_len(&self) -> usize {
        self.c * self.plane() + 2 * self.p()
    }

    /// Rows of the column matrix, `C·k²`.
    pub fn col_rows(&self) -> usize {
        self.c * self.k * self.k
    }

    /// Copies image `x` (`C·H·W`) into the padded buffer `xp` (see the module docs).
    pub fn pad<T: Float>(&self, x: &[T], xp: &mut [T]) {
        let (h, w, p, wp) = (self.h, self.w, self.p(), self.wp());
        for (xc, pc) in x.chunks_exact(h * w).zip(xp.chunks_exact_mut(self.plane())) {
            for (u, row) in pc.chunks_exact_mut(wp).enumerate() {
                let Some(i) = source(u as isize - p as isize, h, self.mode) else {
                    row.fill(T::zero());
                    continue;
                };
                let src = &xc[i * w..(i + 1) * w];
                row[p..p + w].copy_from_slice(src);
                for v in (0..p).chain(p + w..wp) {
                    row[v] =
                        source(v as isize - p as isize, w, self.mode).map_or(T::zero(), |j| src[j]);
                }
            }
        }
        xp[self.c * self.plane()..].fill(T::zero());
    }

    /// Adds the padded gradient `dxp` into the image gradient `dx`: the adjoint of [`Geometry::pad`].
    pub fn fold_add<T: Float>(&self, dxp: &[T], dx: &mut [T]) {
        let (h, w, p, wp) = (self.h, self.w, self.p(), self.wp());
        for (gc, pc) in dx
            .chunks_exact_mut(h * w)
            .zip(dxp.chunks_exact(self.plane()))
        {
            for (u, row) in pc.chunks_exact(wp).enumerate() {
                let Some(i) = source(u as isize - p as isize, h, self.mode) else {
                    continue;
                };
                let dst = &mut gc[i * w..(i + 1) * w];
                for (d, &g) in dst.iter_mut().zip(&row[p..p + w]) {
                    *d += g;
                }
                for v in (0..p).chain(p + w..wp) {
                    if let Some(j) = source(v as isize - p as isize, w, self.mode) {
                        dst[j] += row[v];
                    }
                }
            }
        }
    }

    /// Gathers the column matrix of output rows `r0..r1` from the padded buffer `xp`.
    pub fn im2col<T: Float>(&self, xp: &[T], r0: usize, r1: usize, col: &mut [T]) {
        let (k, wp, n) = (self.k, self.wp(), (r1 - r0) * self.wp());
        debug_assert_eq!(col.len(), self.col_rows() * n);
        for (row, ck) in col.chunks_exact_mut(n).zip(0..) {
            let (c, a, b) = (ck / (k * k), (ck / k) % k, ck % k);
            let at = c * self.plane() + (r0 + a) * wp + b;
            row.copy_from_slice(&xp[at..at + n]);
        }
    }

    /// Adds the column matrix `col` of output rows `r0..r1` into the padded gradient `dxp`:
    /// the adjoint of [`Geometry::im2col`].
    pub fn col2im_add<T: Float>(&self, col: &[T], r0: usize, r1: usize, dxp: &mut [T]) {
        let (k, wp, n) = (self.k, self.wp(), (r1 - r0) * self.wp());
        debug_assert_eq!(col.len(), self.col_rows() * n);
        for (row, ck) in col.chunks_exact(n).zip(0..) {
            let (c, a, b) = (ck / (k * k), (ck / k) % k, ck % k);
            let at = c * self.plane() + (r0 + a) * wp + b;
            for (d, &g) in dxp[at..at + n].iter_mut().zip(row) {
                *d += g;
            }
        }
    }

    /// Copies the valid columns of a padded-width tile `yt` (`Cout × (r1−r0)·Wp`) into rows
    /// `r0..r1` of the image `y` (`Cout·H·W`).
    pub fn compact<T: Float>(&self, yt: &[T], r0: usize, r1: usize, y: &mut [T]) {
        let (h, w, wp, n) = (self.h, self.w, self.wp(), (r1 - r0) * self.wp());
        for (src, dst) in yt.chunks_exact(n).zip(y.chunks_exact_mut(h * w)) {
            for (s, d) in src
                .chunks_exact(wp)
                .zip(dst[r0 * w..r1 * w].chunks_exact_mut(w))
            {
                d.copy_from_slice(&s[..w]);
            }
        }
    }

    /// The transpose of [`Geometry::compact`]: rows `r0..r1` of `dy` into a padded-width tile
    /// with zeros in the junk columns.
    pub fn expand<T: Float>(&self, dy: &[T], r0: usize, r1: usize, dyt: &mut [T]) {
        let (h, w, wp, n) = (self.h, self.w, self.wp(), (r1 - r0) * self.wp());
        for (dst, src) in dyt.chunks_exact_mut(n).zip(dy.chunks_exact(h * w)) {
            for (d, s) in dst
                .chunks_exact_mut(wp)
                .zip(src[r0 * w..r1 * w].chunks_exact(w))
            {
                d[..w].copy_from_slice(s);
                d[w..].fill(T::zero());
            }
        }
    }
}

/// Output-row tiles `r0..r1` sized so a tile's column matrix stays in L2 (~512 KiB of f32).
pub(crate) fn tiles(g: &Geometry) -> Vec<(usize, usize)> {
    let target = TILE_ELEMS.load(std::sync::atomic::Ordering::Relaxed);
    let per_row = (g.col_rows() * g.wp()).max(1);
    let rows = target.div_ceil(per_row).clamp(1, g.h.max(1));
    let n = g.h.div_ceil(rows).max(1);
    let rows = g.h.div_ceil(n).max(1);
    (0..g.h)
        .step_by(rows)
        .map(|r0| (r0, (r0 + rows).min(g.h)))
        .collect()
}

/// Target size of one tile's column matrix, in elements (tuning knob; results do not depend
/// on it).
pub(crate) static TILE_ELEMS: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(1 << 17);

/// A process-wide stash of scratch vectors, so conv kernels running on rayon workers reuse
/// the same (already touched) pages every step instead of allocating per call.
static STASH: Mutex<Vec<Box<dyn Any + Send>>> = Mutex::new(Vec::new());
const STASH_MAX: usize = 32;

/// A scratch vector borrowed from the stash; returned on drop. Contents are unspecified
/// unless taken with [`Scratch::zeroed`].
pub(crate) struct Scratch<T: Float> {
    buf: Vec<T>,
    len: usize,
}

impl<T: Float> Scratch<T> {
    /// A scratch slice of `len` elements with unspecified contents.
    pub fn take(len: usize) -> Self {
        let mut stash = STASH.lock().unwrap_or_else(|e| e.into_inner());
        let mut best: Option<(usize, usize)> = None;
        for (i, b) in stash.iter().enumerate() {
            if let Some(v) = b.downcast_ref::<Vec<T>>() {
                if v.len() >= len && best.is_none_or(|(_, l)| v.len() < l) {
                    best = Some((i, v.len()));
                }
            }
        }
        let buf = match best {
            Some((i, _)) => *stash
                .swap_remove(i)
                .downcast::<Vec<T>>()
                .expect("type checked"),
            None => vec![T::zero(); len],
        };
        Scratch { buf, len }
    }

    /// A scratch slice of `len` zeros.
    pub fn zeroed(len: usize) -> Self {
        let mut s = Self::take(len);
        s.fill(T::zero());
        s
    }
}

impl<T: Float> std::ops::Deref for Scratch<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[..self.len]
    }
}

impl<T: Float> std::ops::DerefMut for Scratch<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[..self.len]
    }
}

impl<T: Float> Drop for Scratch<T> {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.buf);
        let mut stash = STASH.lock().unwrap_or_else(|e| e.into_inner());
        if stash.len() < STASH_MAX {
            stash.push(Box::new(buf));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect_matches_pytorch_convention() {
        // PyTorch 'reflect' on [a b c d] with pad 2: [c b | a b c d | c b].
        let got: Vec<_> = (-2..6)
            .map(|i| source(i, 4, Padding::Reflect).unwrap())
            .collect();
        assert_eq!(got, vec![2, 1, 0, 1, 2, 3, 2, 1]);
        assert_eq!(source(-1, 4, Padding::Zero), None);
    }

    #[test]
    fn backward_maps_are_adjoint_to_forward_maps() {
        // <compact(im2col(pad x)), y> == <x, fold(col2im(expand y))> for random x, y.
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for mode in [Padding::Zero, Padding::Reflect] {
            for (h, w, k) in [(2, 2, 3), (3, 5, 3), (6, 4, 5), (5, 3, 1)] {
                let g = Geometry {
                    c: 2,
                    h,
                    w,
                    k,
                    mode,
                };
                let x: Vec<f64> = (0..2 * h * w).map(|_| rnd()).collect();
                let mut xp = vec![f64::NAN; g.padded_len()];
                g.pad(&x, &mut xp);
                for (r0, r1) in [(0, h), (1, h), (0, 1)] {
                    let n = (r1 - r0) * g.wp();
                    // One "output channel" per column-matrix row.
                    let rows = g.col_rows();
                    let y: Vec<f64> = (0..rows * h * w).map(|_| rnd()).collect();
                    let mut col = vec![0.0; rows * n];
                    g.im2col(&xp, r0, r1, &mut col);
                    let lhs: f64 = (0..rows)
                        .flat_map(|r| (r0..r1).flat_map(move |i| (0..w).map(move |j| (r, i, j))))
                        .map(|(r, i, j)| {
                            col[r * n + (i - r0) * g.wp() + j] * y[(r * h + i) * w + j]
                        })
                        .sum();
                    let mut yt = vec![0.0; rows * n];
                    g.expand(&y, r0, r1, &mut yt);
                    let mut dxp = vec![0.0; g.padded_len()];
                    g.col2im_add(&yt, r0, r1, &mut dxp);
                    let mut dx = vec![0.0; x.len()];
                    g.fold_add(&dxp, &mut dx);
                    let rhs: f64 = x.iter().zip(&dx).map(|(a, b)| a * b).sum();
                    assert!(
                        (lhs - rhs).abs() < 1e-12,
                        "{mode:?} {h}x{w} k{k} rows {r0}..{r1}: {lhs} vs {rhs}"
                    );
                }
            }
        }
    }

    #[test]
    fn tiles_cover_all_rows() {
        for (c, h, w, k) in [
            (16, 64, 64, 3),
            (64, 16, 16, 3),
            (16, 256, 256, 3),
            (1, 3, 2, 3),
        ] {
            let g = Geometry {
                c,
                h,
                w,
                k,
                mode: Padding::Zero,
            };
            let t = tiles(&g);
            assert_eq!(t.first().unwrap().0, 0);
            assert_eq!(t.last().unwrap().1, h);
            assert!(t.windows(2).all(|p| p[0].1 == p[1].0));
        }
    }
}
