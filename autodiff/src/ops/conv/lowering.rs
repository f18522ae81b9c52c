//! Lowering a "same" convolution to GEMMs over shifted windows of a padded copy of each
//! image — no column matrix — plus the reusable scratch buffers.
//!
//! Layout. An image `x (C, H, W)` is copied once into planes `xp[c·Hp·Wp + u·Wp + v] =
//! x[c, src(u − p), src(v − p)]`, `Hp = H + 2p`, `Wp = W + 2p`, `p = (k − 1)/2`, where `src`
//! maps a padded coordinate to a zero or a PyTorch `'reflect'` mirror (index −1 reads 1, index
//! H reads H − 2). `2p` zeros of slack follow the last plane.
//!
//! Padded-width trick. Outputs are computed at positions `q = i·Wp + j`, `j < Wp`; the `2p`
//! positions with `j ≥ W` per row are junk and dropped. (Images at least [`WIDE_PX`] wide use
//! row width `Wz = W + 4p` instead of `Wp` everywhere, with zero extra columns, so that `∂w`
//! can read `dy` from `dyz` below without another copy; see [`Geometry::rw`].) Tap `(a, b)` of channel `c` then reads
//! `xp[c·Hp·Wp + a·Wp + b + q]`: for fixed `(a, b)` this is a strided `C × positions` view
//! `X_ab` (row stride `Hp·Wp`, column stride 1) of the padded buffer itself, so
//! `y_tile = Σ_ab Wf_ab · X_ab` with `Wf_ab[o, c] = w[o, c, a, b]` — `k²` accumulating GEMMs
//! that read the image in place.
//!
//! Backward. `∂w`: `∂Wf_ab += dy_t · X_abᵀ`, with `dy_t` the output gradient expanded to padded
//! width (zeros in the junk columns). `∂x`: the gradient of the padded image is a "full"
//! correlation of `dy` with the flipped kernel,
//! `∂xp[c, u, v] = Σ_{o,a,b} w[o, c, k−1−a, k−1−b] · dyz[o, u + a, v + b]`, with `dyz` = `dy`
//! zero-padded by `2p` on every side (width `Wz = W + 4p`, height `H + 4p`, `2p` slack). The
//! same trick gives `∂xp_tile = Σ_ab Wb_ab · Z_ab`, `Wb_ab[c, o] = w[o, c, k−1−a, k−1−b]`.
//! `fold` then adds each padded position into the pixel it was read from (the adjoint of the
//! padding: reflect borders fold onto the interior; zero borders are dropped).

use crate::gemm::MatView;
use crate::Float;

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

/// Geometry of one image's convolution: input channels, size, kernel side, padding.
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

    /// Padded height `Hp = H + 2p`.
    pub fn hp(&self) -> usize {
        self.h + 2 * self.p()
    }

    /// Width of the doubly padded output gradient, `Wz = W + 4p`.
    pub fn wz(&self) -> usize {
        self.w + 4 * self.p()
    }

    /// Row width of the padded image and of the output tiles: `Wz` for images at least
    /// [`WIDE_PX`] wide (the `2p` extra zero columns let `∂w` read `dyz` directly), else `Wp`
    /// (less junk on small images; `∂w` then reads an expanded copy of `dy`).
    pub fn rw(&self) -> usize {
        if self.w >= WIDE_PX {
            self.wz()
        } else {
            self.wp()
        }
    }

    /// Padded plane size `Hp·rw`.
    pub fn plane(&self) -> usize {
        self.hp() * self.rw()
    }

    /// Plane size of `dyz`, `(H + 4p)·Wz`.
    pub fn plane_z(&self) -> usize {
        (self.h + 4 * self.p()) * self.wz()
    }

    /// Length of `xp`, the padded image plus slack.
    pub fn padded_len(&self) -> usize {
        self.c * self.plane() + 2 * self.p()
    }

    /// Length of `dyz` for `co` output channels.
    pub fn dyz_len(&self, co: usize) -> usize {
        co * self.plane_z() + 2 * self.p()
    }

    /// Padded rows whose gradient reaches the image: all for reflect, the interior for zeros.
    pub fn grad_rows(&self) -> (usize, usize) {
        match self.mode {
            Padding::Reflect => (0, self.hp()),
            Padding::Zero => (self.p(), self.p() + self.h),
        }
    }

    /// Copies image `x` (`C·H·W`) into the padded buffer `xp` (see the module docs).
    pub fn pad<T: Float>(&self, x: &[T], xp: &mut [T]) {
        debug_assert_eq!(xp.len(), self.padded_len());
        self.pad_rows(x, (0, self.hp()), xp, self.plane());
        xp[self.c * self.plane()..].fill(T::zero());
    }

    /// Padded rows `u0..u1` of image `x` (`C·H·W`) into `dst`: channel `c` from `c·plane`,
    /// padded row `u` at `(u − u0)·rw` after that (`plane ≥ (u1 − u0)·rw`; elements past a
    /// channel's last row are left as they are). A row strip of [`Geometry::pad`]'s buffer.
    pub fn pad_rows<T: Float>(
        &self,
        x: &[T],
        (u0, u1): (usize, usize),
        dst: &mut [T],
        plane: usize,
    ) {
        let (h, w, p, wp, rw) = (self.h, self.w, self.p(), self.wp(), self.rw());
        assert!(
            u1 <= self.hp()
                && plane >= (u1 - u0) * rw
                && dst.len() >= (self.c - 1) * plane + (u1 - u0) * rw,
            "conv2d: padded rows {u0}..{u1} do not fit planes of {plane} in {}",
            dst.len()
        );
        for (xc, pc) in x.chunks_exact(h * w).zip(dst.chunks_mut(plane)) {
            for (u, row) in (u0..u1).zip(pc.chunks_exact_mut(rw)) {
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
                row[wp..].fill(T::zero());
            }
        }
    }

    /// Copies `dy` (`Co·H·W`, times `[y > 0]` when `mask` is the ReLU output `y`) into `dyz`,
    /// zero-padded by `2p` on every side (see the module docs).
    pub fn pad_dy<T: Float>(&self, co: usize, dy: &[T], mask: Option<&[T]>, dyz: &mut [T]) {
        debug_assert_eq!(dyz.len(), self.dyz_len(co));
        let rows = (0, self.h + 4 * self.p());
        self.pad_dy_rows(co, dy, mask, rows, dyz, self.plane_z());
        dyz[co * self.plane_z()..].fill(T::zero());
    }

    /// Rows `z0..z1` of [`Geometry::pad_dy`]'s `dyz` into `dst`: channel `o` from `o·plane`,
    /// row `z` at `(z − z0)·Wz` after that (`plane ≥ (z1 − z0)·Wz`; elements past a channel's
    /// last row are left as they are).
    pub fn pad_dy_rows<T: Float>(
        &self,
        co: usize,
        dy: &[T],
        mask: Option<&[T]>,
        (z0, z1): (usize, usize),
        dst: &mut [T],
        plane: usize,
    ) {
        let (h, w, p2, wz) = (self.h, self.w, 2 * self.p(), self.wz());
        assert!(
            z1 <= h + 2 * p2
                && plane >= (z1 - z0) * wz
                && dst.len() >= (co - 1) * plane + (z1 - z0) * wz,
            "conv2d: dy rows {z0}..{z1} do not fit planes of {plane} in {}",
            dst.len()
        );
        for (o, pc) in dst.chunks_mut(plane).take(co).enumerate() {
            for (z, row) in (z0..z1).zip(pc.chunks_exact_mut(wz)) {
                if z < p2 || z >= p2 + h {
                    row.fill(T::zero());
                    continue;
                }
                let i = z - p2;
                row[..p2].fill(T::zero());
                row[p2 + w..].fill(T::zero());
                let src = &dy[(o * h + i) * w..][..w];
                let dst = &mut row[p2..p2 + w];
                match mask {
                    None => dst.copy_from_slice(src),
                    Some(y) => {
                        let m = &y[(o * h + i) * w..][..w];
                        for ((d, &g), &y) in dst.iter_mut().zip(src).zip(m) {
                            *d = if y > T::zero() { g } else { T::zero() };
                        }
                    }
                }
            }
        }
    }

    /// Rows `r0..r1` of `dy` (masked like [`Geometry::pad_dy`]) as a padded-width tile
    /// `Co × (r1−r0)·Wp` with zeros in the junk columns.
    pub fn expand<T: Float>(
        &self,
        co: usize,
        dy: &[T],
        mask: Option<&[T]>,
        r0: usize,
        r1: usize,
        dyt: &mut [T],
    ) {
        let (h, w, wp) = (self.h, self.w, self.rw());
        let n = (r1 - r0) * wp;
        for (o, dst) in dyt[..co * n].chunks_exact_mut(n).enumerate() {
            for (i, d) in (r0..r1).zip(dst.chunks_exact_mut(wp)) {
                let src = &dy[(o * h + i) * w..][..w];
                match mask {
                    None => d[..w].copy_from_slice(src),
                    Some(y) => {
                        let m = &y[(o * h + i) * w..][..w];
                        for ((d, &g), &y) in d.iter_mut().zip(src).zip(m) {
                            *d = if y > T::zero() { g } else { T::zero() };
                        }
                    }
                }
                d[w..].fill(T::zero());
            }
        }
    }

    /// Copies the valid columns of a padded-width tile `yt` (`Co × (r1−r0)·Wp`) into rows
    /// `r0..r1` of the image `y` (`Co·H·W`), applying ReLU when `relu`.
    pub fn compact<T: Float>(&self, yt: &[T], r0: usize, r1: usize, y: &mut [T], relu: bool) {
        let (h, w, wp, n) = (self.h, self.w, self.rw(), (r1 - r0) * self.rw());
        for (src, dst) in yt.chunks_exact(n).zip(y.chunks_exact_mut(h * w)) {
            for (s, d) in src
                .chunks_exact(wp)
                .zip(dst[r0 * w..r1 * w].chunks_exact_mut(w))
            {
                if relu {
                    for (d, &s) in d.iter_mut().zip(&s[..w]) {
                        *d = s.max(T::zero());
                    }
                } else {
                    d.copy_from_slice(&s[..w]);
                }
            }
        }
    }

    /// Adds a tile of the padded-image gradient, rows `u0..u1` at row width `Wz` (`C ×
    /// (u1−u0)·Wz`, first `Wp` columns used), into the image gradient `dx`: the adjoint of
    /// [`Geometry::pad`].
    pub fn fold_rows_add<T: Float>(&self, dxt: &[T], u0: usize, u1: usize, dx: &mut [T]) {
        let (h, w, p, wp, wz) = (self.h, self.w, self.p(), self.wp(), self.wz());
        let n = (u1 - u0) * wz;
        for (gc, tc) in dx.chunks_exact_mut(h * w).zip(dxt.chunks_exact(n)) {
            for (u, row) in (u0..u1).zip(tc.chunks_exact(wz)) {
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

    /// `wf[t][o][c] = w[o, c, a, b]`, tap `t = a·k + b`: `k²` row-major `Co × C` matrices.
    pub fn forward_weights<T: Float>(&self, co: usize, w: &[T], wf: &mut [T]) {
        let (c, kk) = (self.c, self.k * self.k);
        for (oc, taps) in w.chunks_exact(kk).enumerate() {
            for (t, &v) in taps.iter().enumerate() {
                wf[t * co * c + oc] = v;
            }
        }
    }

    /// `wb[t][c][o] = w[o, c, k−1−a, k−1−b]`, tap `t = a·k + b`: `k²` row-major `C × Co`.
    pub fn backward_weights<T: Float>(&self, co: usize, w: &[T], wb: &mut [T]) {
        let (c, kk) = (self.c, self.k * self.k);
        for (oc, taps) in w.chunks_exact(kk).enumerate() {
            let (o, ch) = (oc / c, oc % c);
            for (t, &v) in taps.iter().rev().enumerate() {
                wb[(t * c + ch) * co + o] = v;
            }
        }
    }

    /// The column matrix of output rows `r0..r1`: row `c·k² + t` is row `c` of `X_t` (see
    /// [`Geometry::x_view`]), `C·k² × (r1−r0)·rw` — rows ordered like the weight `(c, a, b)`.
    pub fn im2col<T: Float>(&self, xp: &[T], r0: usize, r1: usize, col: &mut [T]) {
        let (k, rw) = (self.k, self.rw());
        let n = (r1 - r0) * rw;
        for (row, ct) in col.chunks_exact_mut(n).zip(0..) {
            let (c, a, b) = (ct / (k * k), (ct / k) % k, ct % k);
            let at = c * self.plane() + (r0 + a) * rw + b;
            row.copy_from_slice(&xp[at..at + n]);
        }
    }

    /// `X_ab` for output rows `r0..r1` (`C × (r1−r0)·Wp`, see the module docs), `t = a·k + b`.
    pub fn x_view<'a, T>(&self, xp: &'a [T], t: usize, r0: usize, r1: usize) -> MatView<'a, T> {
        let (a, b, wp) = (t / self.k, t % self.k, self.rw());
        MatView::new(
            xp,
            (r0 + a) * wp + b,
            self.c,
            (r1 - r0) * wp,
            self.plane(),
            1,
        )
    }

    /// `dy` rows `r0..r1` at row width `Wz` read straight from `dyz` (`Co × (r1−r0)·Wz`, zeros
    /// in the junk columns); only for `rw() == wz()`.
    pub fn dy_view<'a, T>(&self, co: usize, dyz: &'a [T], r0: usize, r1: usize) -> MatView<'a, T> {
        let (p2, wz) = (2 * self.p(), self.wz());
        debug_assert_eq!(self.rw(), wz);
        MatView::new(
            dyz,
            (r0 + p2) * wz + p2,
            co,
            (r1 - r0) * wz,
            self.plane_z(),
            1,
        )
    }

    /// `Z_ab` for padded-gradient rows `u0..u1` (`Co × (u1−u0)·Wz`).
    pub fn z_view<'a, T>(
        &self,
        co: usize,
        dyz: &'a [T],
        t: usize,
        u0: usize,
        u1: usize,
    ) -> MatView<'a, T> {
        let (a, b, wz) = (t / self.k, t % self.k, self.wz());
        MatView::new(
            dyz,
            (u0 + a) * wz + b,
            co,
            (u1 - u0) * wz,
            self.plane_z(),
            1,
        )
    }
}

/// Images at least this wide use row width `Wz` (see [`Geometry::rw`]).
pub(crate) const WIDE_PX: usize = 32;

/// Row tiles `r0..r1` of `0..rows` such that a tile touches about [`TILE_ELEMS`] elements
/// (`per_row` per row), so its working set stays in L2.
pub(crate) fn tiles(rows: usize, per_row: usize) -> Vec<(usize, usize)> {
    let target = TILE_ELEMS.load(std::sync::atomic::Ordering::Relaxed);
    let per = target.div_ceil(per_row.max(1)).clamp(1, rows.max(1));
    let n = rows.div_ceil(per).max(1);
    let per = rows.div_ceil(n).max(1);
    (0..rows)
        .step_by(per)
        .map(|r0| (r0, (r0 + per).min(rows)))
        .collect()
}

/// Target working set of one tile, in elements (tuning knob; results do not depend on it).
pub(crate) static TILE_ELEMS: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(1 << 17);

#[cfg(test)]
mod tests;
