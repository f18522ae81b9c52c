//! AVX-512 micro-kernels of the direct 3×3 convolution (x86-64 only; driven by
//! [`super::direct`]).
//!
//! Two register-blocked kernels, generic over the lane type [`Simd`] (16 × f32 or 8 × f64 in
//! one 512-bit register), so the f64 gradient checks run the same code as f32 training:
//! - [`corr_block`]: `MR` output channels × `NV` vectors of output positions, held in `MR·NV`
//!   registers while the loop runs over input channels and the 9 taps; each step loads `NV`
//!   input vectors and broadcasts `MR` weights (`MR·NV` FMAs per `NV + MR` loads). Used by the
//!   forward pass (input = padded image) and by `∂x` (input = padded `dy`, flipped kernel).
//! - [`dw_block`]: up to 3 vectors of output channels × up to 3 input channels × the 9 taps
//!   (≤ 27 registers), summed over output pixels: each step loads the channels-last `dy`
//!   vectors of one pixel and broadcasts the input values under each tap. Used by `∂w`.
//! - [`channels_last`]: `dy` transposed to pixel-major order by `L × L` register transposes.
//!
//! Addresses are element offsets into raw pointers; the tails of image rows (width not a
//! multiple of the lane count) are handled by masked stores, so no lane outside a row is
//! written (lanes past the tail are computed from padding or neighbouring rows and dropped).
//!
//! Safety: every function here is `unsafe`. The caller guarantees that the CPU supports
//! AVX-512F (checked by [`super::direct::kernels`] before any kernel is handed out) and that
//! every element a doc comment names lies inside the buffer behind the pointer (the drivers in
//! [`super::direct`] assert the extreme offsets of each call range before entering it).

use crate::Float;
use core::arch::x86_64::*;

/// One 512-bit register of `L` lanes of `S`. All methods need AVX-512F; pointer arguments must
/// be valid for the lanes they touch.
pub(crate) trait Simd: Copy {
    /// The scalar type.
    type S: Float;
    /// Lanes per register.
    const L: usize;
    /// All lanes zero.
    unsafe fn zero() -> Self;
    /// All lanes `x`.
    unsafe fn splat(x: Self::S) -> Self;
    /// `L` lanes from `p` (unaligned).
    unsafe fn load(p: *const Self::S) -> Self;
    /// The first `n ≤ L` lanes from `p`, the rest zero (lanes `≥ n` are not read).
    unsafe fn load_n(p: *const Self::S, n: usize) -> Self;
    /// `self + a·b`, fused.
    unsafe fn fma(self, a: Self, b: Self) -> Self;
    /// `max(self, 0)` lane-wise.
    unsafe fn relu(self) -> Self;
    /// Stores the first `n ≤ L` lanes at `p` (all `L` when `n == L`).
    unsafe fn store_n(self, p: *mut Self::S, n: usize);
    /// `self + a` lane-wise.
    unsafe fn add(self, a: Self) -> Self;
    /// Transposes the `L × L` block held in `rows` (`rows.len() == L`): lane `l` of row `k`
    /// moves to lane `k` of row `l`.
    unsafe fn transpose(rows: &mut [Self]);
    /// `self` where `y > 0`, else zero (lane-wise).
    unsafe fn where_positive(self, y: Self) -> Self;
}

/// 16 × f32.
#[derive(Clone, Copy)]
pub(crate) struct F32x16(__m512);

/// 8 × f64.
#[derive(Clone, Copy)]
pub(crate) struct F64x8(__m512d);

impl Simd for F32x16 {
    type S = f32;
    const L: usize = 16;
    #[inline(always)]
    unsafe fn zero() -> Self {
        F32x16(_mm512_setzero_ps())
    }
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        F32x16(_mm512_set1_ps(x))
    }
    #[inline(always)]
    unsafe fn load(p: *const f32) -> Self {
        F32x16(_mm512_loadu_ps(p))
    }
    #[inline(always)]
    unsafe fn load_n(p: *const f32, n: usize) -> Self {
        F32x16(_mm512_maskz_loadu_ps(((1u32 << n) - 1) as u16, p))
    }
    #[inline(always)]
    unsafe fn fma(self, a: Self, b: Self) -> Self {
        F32x16(_mm512_fmadd_ps(a.0, b.0, self.0))
    }
    #[inline(always)]
    unsafe fn relu(self) -> Self {
        F32x16(_mm512_max_ps(self.0, _mm512_setzero_ps()))
    }
    #[inline(always)]
    unsafe fn store_n(self, p: *mut f32, n: usize) {
        if n == 16 {
            _mm512_storeu_ps(p, self.0)
        } else {
            _mm512_mask_storeu_ps(p, ((1u32 << n) - 1) as u16, self.0)
        }
    }
    #[inline(always)]
    unsafe fn add(self, a: Self) -> Self {
        F32x16(_mm512_add_ps(self.0, a.0))
    }
    #[inline(always)]
    unsafe fn transpose(r: &mut [Self]) {
        debug_assert_eq!(r.len(), 16);
        // Interleave pairs of rows (32-bit), then pairs of pairs (64-bit): vector `4g + m`
        // then holds, in its 128-bit lane `q`, rows `4g..4g + 4` of column `4q + m`.
        let mut t = [_mm512_setzero_ps(); 16];
        for i in 0..8 {
            t[2 * i] = _mm512_unpacklo_ps(r[2 * i].0, r[2 * i + 1].0);
            t[2 * i + 1] = _mm512_unpackhi_ps(r[2 * i].0, r[2 * i + 1].0);
        }
        let (lo, hi) = (_mm512_unpacklo_pd, _mm512_unpackhi_pd);
        let mut u = [_mm512_setzero_ps(); 16];
        for g in 0..4 {
            let (a, b) = (_mm512_castps_pd(t[4 * g]), _mm512_castps_pd(t[4 * g + 2]));
            let (c, d) = (
                _mm512_castps_pd(t[4 * g + 1]),
                _mm512_castps_pd(t[4 * g + 3]),
            );
            u[4 * g] = _mm512_castpd_ps(lo(a, b));
            u[4 * g + 1] = _mm512_castpd_ps(hi(a, b));
            u[4 * g + 2] = _mm512_castpd_ps(lo(c, d));
            u[4 * g + 3] = _mm512_castpd_ps(hi(c, d));
        }
        // Gather lane q of vectors m, 4 + m, 8 + m, 12 + m into column 4q + m.
        for m in 0..4 {
            let v0 = _mm512_shuffle_f32x4::<0x88>(u[m], u[4 + m]);
            let v1 = _mm512_shuffle_f32x4::<0xdd>(u[m], u[4 + m]);
            let v2 = _mm512_shuffle_f32x4::<0x88>(u[8 + m], u[12 + m]);
            let v3 = _mm512_shuffle_f32x4::<0xdd>(u[8 + m], u[12 + m]);
            r[m] = F32x16(_mm512_shuffle_f32x4::<0x88>(v0, v2));
            r[8 + m] = F32x16(_mm512_shuffle_f32x4::<0xdd>(v0, v2));
            r[4 + m] = F32x16(_mm512_shuffle_f32x4::<0x88>(v1, v3));
            r[12 + m] = F32x16(_mm512_shuffle_f32x4::<0xdd>(v1, v3));
        }
    }
    #[inline(always)]
    unsafe fn where_positive(self, y: Self) -> Self {
        let k = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(y.0, _mm512_setzero_ps());
        F32x16(_mm512_maskz_mov_ps(k, self.0))
    }
}

impl Simd for F64x8 {
    type S = f64;
    const L: usize = 8;
    #[inline(always)]
    unsafe fn zero() -> Self {
        F64x8(_mm512_setzero_pd())
    }
    #[inline(always)]
    unsafe fn splat(x: f64) -> Self {
        F64x8(_mm512_set1_pd(x))
    }
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self {
        F64x8(_mm512_loadu_pd(p))
    }
    #[inline(always)]
    unsafe fn load_n(p: *const f64, n: usize) -> Self {
        F64x8(_mm512_maskz_loadu_pd(((1u32 << n) - 1) as u8, p))
    }
    #[inline(always)]
    unsafe fn fma(self, a: Self, b: Self) -> Self {
        F64x8(_mm512_fmadd_pd(a.0, b.0, self.0))
    }
    #[inline(always)]
    unsafe fn relu(self) -> Self {
        F64x8(_mm512_max_pd(self.0, _mm512_setzero_pd()))
    }
    #[inline(always)]
    unsafe fn store_n(self, p: *mut f64, n: usize) {
        if n == 8 {
            _mm512_storeu_pd(p, self.0)
        } else {
            _mm512_mask_storeu_pd(p, ((1u32 << n) - 1) as u8, self.0)
        }
    }
    #[inline(always)]
    unsafe fn add(self, a: Self) -> Self {
        F64x8(_mm512_add_pd(self.0, a.0))
    }
    #[inline(always)]
    unsafe fn transpose(r: &mut [Self]) {
        debug_assert_eq!(r.len(), 8);
        // Interleave pairs of rows: vector `2g + m` then holds, in its 128-bit lane `q`,
        // rows `2g, 2g + 1` of column `2q + m`.
        let mut t = [_mm512_setzero_pd(); 8];
        for i in 0..4 {
            t[2 * i] = _mm512_unpacklo_pd(r[2 * i].0, r[2 * i + 1].0);
            t[2 * i + 1] = _mm512_unpackhi_pd(r[2 * i].0, r[2 * i + 1].0);
        }
        // Gather lane q of vectors m, 2 + m, 4 + m, 6 + m into column 2q + m.
        for m in 0..2 {
            let v0 = _mm512_shuffle_f64x2::<0x88>(t[m], t[2 + m]);
            let v1 = _mm512_shuffle_f64x2::<0xdd>(t[m], t[2 + m]);
            let v2 = _mm512_shuffle_f64x2::<0x88>(t[4 + m], t[6 + m]);
            let v3 = _mm512_shuffle_f64x2::<0xdd>(t[4 + m], t[6 + m]);
            r[m] = F64x8(_mm512_shuffle_f64x2::<0x88>(v0, v2));
            r[4 + m] = F64x8(_mm512_shuffle_f64x2::<0xdd>(v0, v2));
            r[2 + m] = F64x8(_mm512_shuffle_f64x2::<0x88>(v1, v3));
            r[6 + m] = F64x8(_mm512_shuffle_f64x2::<0xdd>(v1, v3));
        }
    }
    #[inline(always)]
    unsafe fn where_positive(self, y: Self) -> Self {
        let k = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(y.0, _mm512_setzero_pd());
        F64x8(_mm512_maskz_mov_pd(k, self.0))
    }
}

/// `$body` once for each tap `$t = 0, …, 8` as a constant, so that accumulators indexed by the
/// tap stay in registers (a loop over taps is not reliably unrolled).
macro_rules! for_each_tap {
    (|$t:ident| $body:block) => {{
        {
            let $t = 0;
            $body
        }
        {
            let $t = 1;
            $body
        }
        {
            let $t = 2;
            $body
        }
        {
            let $t = 3;
            $body
        }
        {
            let $t = 4;
            $body
        }
        {
            let $t = 5;
            $body
        }
        {
            let $t = 6;
            $body
        }
        {
            let $t = 7;
            $body
        }
        {
            let $t = 8;
            $body
        }
    }};
}

/// How [`corr_block`] writes its results.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Store {
    /// Overwrite.
    Set,
    /// Overwrite with `max(·, 0)`.
    SetRelu,
    /// Add to what is there.
    Add,
}

/// Output side of one [`corr_block`] call.
#[derive(Clone, Copy)]
pub(crate) struct BlockOut<S> {
    /// Output channel 0 of the block.
    pub ptr: *mut S,
    /// Distance between output channels.
    pub ch_stride: usize,
    /// Output channels to store (`≤ MR`; the packed weights of the others are zero).
    pub channels: usize,
    pub store: Store,
}

/// For `v < NV`, `o < out.channels`, `l < lanes[v]`:
/// `out[o·ch_stride + yoff[v] + l] (=|+=) Σ_{c < cin, t < 9} w[(c·9 + t)·MR + o] ·
/// x[c·x_ch + xoff[v] + taps[t] + l]`.
///
/// Reads `x` at every such index for all `l < L` (lanes past `lanes[v]` are computed and
/// dropped), and `w[.. cin·9·MR]`. (The tap loop is left rolled: unrolled, the compiler hoists
/// all 9·NV input loads and runs out of registers.)
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn corr_block<V: Simd, const MR: usize, const NV: usize>(
    x: *const V::S,
    x_ch: usize,
    cin: usize,
    taps: &[usize; 9],
    w: *const V::S,
    xoff: &[usize; NV],
    yoff: &[usize; NV],
    lanes: &[usize; NV],
    out: BlockOut<V::S>,
) {
    let mut acc = [[V::zero(); NV]; MR];
    for c in 0..cin {
        let xc = x.add(c * x_ch);
        let wc = w.add(c * 9 * MR);
        for (t, &tap) in taps.iter().enumerate() {
            let xt = xc.add(tap);
            let xv: [V; NV] = core::array::from_fn(|v| V::load(xt.add(xoff[v])));
            let wt = wc.add(t * MR);
            for (o, acc_o) in acc.iter_mut().enumerate() {
                let wv = V::splat(*wt.add(o));
                for (a, &xv) in acc_o.iter_mut().zip(&xv) {
                    *a = a.fma(wv, xv);
                }
            }
        }
    }
    for (o, acc_o) in acc.iter().enumerate().take(out.channels) {
        let yo = out.ptr.add(o * out.ch_stride);
        for v in 0..NV {
            let (p, n) = (yo.add(yoff[v]), lanes[v]);
            let r = match out.store {
                Store::Set => acc_o[v],
                Store::SetRelu => acc_o[v].relu(),
                Store::Add => V::load_n(p, n).add(acc_o[v]),
            };
            r.store_n(p, n);
        }
    }
}

/// Rows of output pixels for [`dw_block`]: row `r` has `width` pixels, the first at
/// `x_rows[r]` in an input channel and at pixel index `dy_rows[r]` of the channels-last `dy`.
#[derive(Clone, Copy)]
pub(crate) struct Rows<'a> {
    pub x_rows: &'a [usize],
    pub dy_rows: &'a [usize],
    pub width: usize,
}

/// `∂w` of `OV` vectors of output channels × `CB` input channels × 9 taps, with `dyt` the
/// output gradient channels-last (pixel `p`, channel vector `v` at `dyt[p·px + v·L]`) and
/// `x` padded planes of row width `rw`: for `v < OV`, `cb < CB`, tap `t = a·3 + b`, `l < L`:
/// `dwt[cb·9·px + t·px + v·L + l] += Σ_r Σ_{j < width}
/// dyt[(dy_rows[r] + j)·px + v·L + l] · x[cb·x_ch + x_rows[r] + a·rw + b + j]`.
///
/// Accumulates lane-wise (no horizontal sums): `dwt` holds `∂w` as `[c][t][o]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn dw_block<V: Simd, const OV: usize, const CB: usize>(
    x: *const V::S,
    x_ch: usize,
    rw: usize,
    dyt: *const V::S,
    px: usize,
    rows: Rows<'_>,
    dwt: *mut V::S,
) {
    let mut acc = [[[V::zero(); 9]; CB]; OV];
    // Offsets of kernel row `a` of channel `cb` from a pixel's window corner; the column
    // shift `b` becomes a constant displacement.
    let rows_at: [[usize; 3]; CB] =
        core::array::from_fn(|cb| core::array::from_fn(|a| cb * x_ch + a * rw));
    for (&xr, &dr) in rows.x_rows.iter().zip(rows.dy_rows) {
        let (xr, dr) = (x.add(xr), dyt.add(dr * px));
        for j in 0..rows.width {
            // Opaque per pixel: otherwise the compiler notices that tap `b + 1` of pixel `j`
            // is tap `b` of pixel `j + 1`, carries broadcasts across iterations and spills.
            let xj = core::hint::black_box(xr.add(j));
            let dj = dr.add(j * px);
            let d: [V; OV] = core::array::from_fn(|v| V::load(dj.add(v * V::L)));
            for cb in 0..CB {
                for_each_tap!(|t| {
                    let xv = V::splat(*xj.add(rows_at[cb][t / 3] + t % 3));
                    for v in 0..OV {
                        acc[v][cb][t] = acc[v][cb][t].fma(d[v], xv);
                    }
                });
            }
        }
    }
    for (v, acc_v) in acc.iter().enumerate() {
        for (cb, acc_c) in acc_v.iter().enumerate() {
            for (t, a) in acc_c.iter().enumerate() {
                let p = dwt.add((cb * 9 + t) * px + v * V::L);
                V::load(p).add(*a).store_n(p, V::L);
            }
        }
    }
}

/// `dyt[p·co_l + o] = dy[o·stride + p]` for `p < npx`, `o < co` (times `[y > 0]` with `y` at
/// the same index as `dy` when given), zero for `co ≤ o < co_l` (`co_l` a multiple of `L`):
/// `npx` pixels of `dy` (channel stride `stride`) channels-last for [`dw_block`], by `L × L`
/// register transposes.
///
/// Reads `dy` (and `y`) at `o·stride + p`, `o < co`, `p < npx`; writes `dyt[.. npx·co_l]`.
#[inline(always)]
pub(crate) unsafe fn channels_last<V: Simd>(
    dy: *const V::S,
    y: Option<*const V::S>,
    (co, stride): (usize, usize),
    npx: usize,
    co_l: usize,
    dyt: *mut V::S,
) {
    let mut block = [V::zero(); 16];
    let block = &mut block[..V::L];
    for p in (0..npx).step_by(V::L) {
        let np = (npx - p).min(V::L);
        for o in (0..co_l).step_by(V::L) {
            for (k, row) in block.iter_mut().enumerate() {
                *row = if o + k < co {
                    let at = (o + k) * stride + p;
                    let v = V::load_n(dy.add(at), np);
                    match y {
                        Some(y) => v.where_positive(V::load_n(y.add(at), np)),
                        None => v,
                    }
                } else {
                    V::zero()
                };
            }
            V::transpose(block);
            for (k, col) in block.iter().enumerate().take(np) {
                col.store_n(dyt.add((p + k) * co_l + o), V::L);
            }
        }
    }
}
