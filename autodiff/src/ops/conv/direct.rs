//! The direct 3×3 convolution: register-blocked AVX-512 micro-kernels ([`super::kernels`])
//! instead of GEMMs, for the small channel counts of the U-Net (8–128), where a GEMM with inner
//! size `Cin` spends most of its time packing and in call overhead.
//!
//! Buffers (same layouts as [`super::lowering`]; `p = 1`, `rw` = its row width):
//! - `xp`: every image padded once (`Geometry::pad`), one per `xp_stride` elements
//!   (`padded_len` + [`SLACK`] zeros, so that full-vector loads near the end stay inside) —
//!   or, when there are at least as many images as threads (the usual case), only a row
//!   strip of one image at a time (`Geometry::pad_rows`, see [`strips`]), in a buffer that
//!   is reused for every strip and so stays in L2.
//! - `dyz`: `dy` (masked by `y > 0` for the fused ReLU) zero-padded by `2p` on every side at
//!   row width `Wz = W + 4p`, one per `dyz_stride` elements.
//!
//! - `dyt`: `dy` (masked likewise) channels-last, `dyt[p·Co_L + o]`, `Co_L` = `Co` rounded up
//!   to the lane count (zeros past `Co`).
//!
//! The three products, tap `t = a·3 + b`:
//! - forward: `y[o, i, j] = Σ_{c,t} w[o,c,t] · xp[c, i + a, j + b]`, over positions = rows ×
//!   vector-wide column blocks (row tails masked), written straight into `y` (ReLU on store).
//! - `∂x`: the gradient of the padded image is `∂xp[c, u, v] = Σ_{o,t} w[o,c,8−t] ·
//!   dyz[o, u + a, v + b]`. Its interior (one padded position per pixel) is accumulated
//!   straight into `∂x` by the forward kernel; under reflect padding the border ring of `∂xp`
//!   (padded rows 0 and `Hp − 1`, columns 0 and `Wp − 1`) is computed separately, vectorised
//!   over channels, and folded onto the pixels it was read from (the adjoint of the padding).
//! - `∂w`: `∂w[o,c,t] += Σ_{b,i,j} dy[o, i, j] · xp[c, i + a, j + b]` over all images at
//!   once, vectorised over output channels (`dyt` vectors times broadcast input pixels, no
//!   horizontal sums), in row tiles that stay in L2, in parallel over groups of input channels
//!   (each task owns its rows of the `[c][t][o]` accumulator, so there are no partial sums).
//!
//! Parallelism and memory: with at least as many images as threads, forward runs one rayon
//! task per image and backward one per run of images, each going through its images in row
//! strips of about half of L2 ([`strips`]): the strip's padded input (and in backward its
//! padded and channels-last `dy`) is made right before the kernels read it, so `x` and `dy`
//! are read from memory once per pass and no padded copy is written back. With fewer images
//! than threads, each image is split into channel groups instead, forward keeps the padded
//! images for backward, and backward works on the whole batch at once.
//!
//! Only `k = 3` on x86-64 CPUs with AVX-512F ([`kernels`] returns `None` otherwise and the op
//! uses the GEMM lowering).

use super::lowering::{tiles, Geometry};
use super::scratch::Scratch;
use crate::Float;

/// Zeros after each padded image / padded `dy` (at least the widest lane count, 16 × f32).
pub(crate) const SLACK: usize = 16;

/// Arguments of the forward pass (shapes as in [`super::Conv2d`]).
pub(crate) struct FwdArgs<'a, T> {
    pub g: Geometry,
    pub co: usize,
    /// `x (B, C, H, W)`.
    pub x: &'a [T],
    /// `w (Co, C, 3, 3)`.
    pub w: &'a [T],
    /// `y (B, Co, H, W)`, overwritten.
    pub y: &'a mut [T],
    pub relu: bool,
    /// `B · xp_stride(g)` elements that receive the padded images, kept for backward, when
    /// [`keeps_padded`]; else `None`.
    pub xp: Option<&'a mut [T]>,
}

/// Arguments of the backward pass.
pub(crate) struct BwdArgs<'a, T> {
    pub g: Geometry,
    pub co: usize,
    pub x: &'a [T],
    pub w: &'a [T],
    pub dy: &'a [T],
    /// The op output `y` when the ReLU is fused (`dy` is used where `y > 0`).
    pub mask: Option<&'a [T]>,
    /// The padded images written by forward for this `x`, if still valid.
    pub xp: Option<&'a [T]>,
    /// `∂x`, when wanted: added into when `gx_add`, else overwritten (every element).
    pub gx: Option<&'a mut [T]>,
    pub gx_add: bool,
    /// `∂w` accumulator (added into), when wanted.
    pub gw: Option<&'a mut [T]>,
}

/// The direct path for scalar type `T`.
pub(crate) struct Table<T> {
    pub forward: fn(FwdArgs<'_, T>),
    pub backward: fn(BwdArgs<'_, T>),
}

/// Elements per padded image in `xp`.
pub(crate) fn xp_stride(g: &Geometry) -> usize {
    g.padded_len() + SLACK
}

/// The direct kernels for `T` and kernel side `k`, when this CPU and shape have them (the
/// tables are found by type: `T` is `f32` or `f64`).
pub(crate) fn kernels<T: Float>(k: usize) -> Option<&'static Table<T>> {
    #[cfg(target_arch = "x86_64")]
    if k == 3 && std::arch::is_x86_feature_detected!("avx512f") {
        use std::any::Any;
        let f32s: &dyn Any = &x86::F32;
        let f64s: &dyn Any = &x86::F64;
        return f32s.downcast_ref().or_else(|| f64s.downcast_ref());
    }
    let _ = k;
    None
}

fn zero<T: Float>() -> T {
    T::zero()
}

/// Channels per group when each image's `channels` (in blocks of `mr`) are split into groups
/// so that all threads have work: all of them when there are at least as many images as
/// threads, else whole blocks spread over `⌈threads / batch⌉` groups.
fn channels_per_group(channels: usize, batch: usize, mr: usize) -> usize {
    let threads = rayon::current_num_threads();
    let blocks = channels.div_ceil(mr);
    let groups = if batch >= threads {
        1
    } else {
        threads.div_ceil(batch.max(1)).min(blocks).max(1)
    };
    blocks.div_ceil(groups) * mr
}

/// Target working set of one row strip of an image, in elements (a tuning knob: 1 MiB in
/// f32, sized for half of a 2 MiB per-core L2; at 256² × 16 channels strips of 8 to 64 rows
/// time the same within noise). An image up to twice this size is one strip, so the U-Net's
/// images (64² with 16 channels, 32² with 32) stay whole. Tests shrink it to cut small images
/// into several strips; results do not depend on it beyond float rounding.
pub(crate) static STRIP_ELEMS: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(1 << 18);

/// Row strips `(r0, r1)` of an image of `h ≥ 1` rows whose buffers take `per_row` elements per
/// row: one strip when the image takes at most twice [`STRIP_ELEMS`], else strips of about
/// [`STRIP_ELEMS`], at least 2 rows each but for a last odd one (the strip holding row 0 must
/// hold row 1 too; see `GradX::rows`).
fn strips(h: usize, per_row: usize) -> Vec<(usize, usize)> {
    let target = STRIP_ELEMS.load(std::sync::atomic::Ordering::Relaxed);
    if h * per_row <= 2 * target {
        return vec![(0, h)];
    }
    let per = target.div_ceil(per_row.max(1)).max(2).min(h.max(1));
    let per = h.div_ceil(h.div_ceil(per));
    (0..h)
        .step_by(per)
        .map(|r0| (r0, (r0 + per).min(h)))
        .collect()
}

/// Whether the image-by-image backward is used: at least as many images as threads.
pub(crate) fn by_image(batch: usize) -> bool {
    batch >= rayon::current_num_threads().max(2)
}

/// The row strips of the image-by-image backward (per row: `dyz`, channels-last `dy` with
/// `co_l` lanes, the padded input, and the rows of `dy` and `∂x`).
fn backward_strips(g: &Geometry, co: usize, co_l: usize) -> Vec<(usize, usize)> {
    let per_row = co * g.wz() + co_l * g.w + g.c * g.rw() + (g.c + co) * g.w;
    strips(g.h, per_row)
}

/// Whether forward pads whole images into a buffer kept for backward (`FwdArgs::xp`): when
/// the batch is split into channel groups (fewer images than threads), and when backward
/// takes each image in one strip anyway (small images: the padded copy is then read back
/// instead of padding again). Otherwise forward pads each image in row strips that stay in
/// L2, and backward pads them again the same way (one more read of `x` instead of writing
/// and reading back a padded copy of every image).
pub(crate) fn keeps_padded(g: &Geometry, co: usize, batch: usize) -> bool {
    !by_image(batch) || backward_strips(g, co, co.next_multiple_of(16)).len() == 1
}

/// Repacks `w (Co, C, 3, 3)` into `⌈Co/mr⌉` blocks `[c][t][m]` (zero past `Co`): the forward
/// weights. With `flip`, the `∂x` weights instead: blocks of `mr` input channels,
/// `[o][t][m] = w[o, c, 8 − t]` (zero past `C`).
fn pack<T: Float>(co: usize, c: usize, w: &[T], mr: usize, flip: bool, out: &mut [T]) {
    let (rows, inner) = if flip { (c, co) } else { (co, c) };
    debug_assert_eq!(out.len(), rows.div_ceil(mr) * inner * 9 * mr);
    for (blk, dst) in out.chunks_exact_mut(inner * 9 * mr).enumerate() {
        for (n, taps) in dst.chunks_exact_mut(9 * mr).enumerate() {
            for (t, lanes) in taps.chunks_exact_mut(mr).enumerate() {
                for (m, v) in lanes.iter_mut().enumerate() {
                    let r = blk * mr + m;
                    *v = match (r < rows, flip) {
                        (false, _) => T::zero(),
                        (true, false) => w[(r * c + n) * 9 + t],
                        (true, true) => w[(n * c + r) * 9 + 8 - t],
                    };
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86;
#[cfg(target_arch = "x86_64")]
mod x86_backward;
#[cfg(target_arch = "x86_64")]
mod x86_by_image;
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) use x86_backward::BY_IMAGE;
