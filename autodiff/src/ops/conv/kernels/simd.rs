//! One 512-bit AVX-512 register as a vector of lanes: the [`Simd`] trait the micro-kernels are
//! generic over, and its two lane types, 16 × f32 ([`F32x16`]) and 8 × f64 ([`F64x8`]).

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
