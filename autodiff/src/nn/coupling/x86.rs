//! x86-64 kernels for `f32` parameter gradients: [`outer`] with explicit vector registers,
//! one register of partial sums per parameter (the generic version's lane arrays are scheduled
//! poorly by the compiler: it hoists every load of the fully unrolled loop and spills).

use super::kernel::CHUNK;
use std::arch::x86_64::*;

/// `lanes[(j·K + k)·L + l] += Σ_i a[j, L·i + l] · b[k, L·i + l]` for row blocks `a (J, CHUNK)`,
/// `b (K, CHUNK)` (the generic `outer`), with `L = 8` (AVX2) or `16` (AVX-512) partial sums,
/// in tiles of 2 × 4 accumulators.
///
/// # Safety
/// The CPU must support AVX2 and FMA, and AVX-512F when `avx512`.
pub(super) unsafe fn outer(lanes: &mut [f32], a: &[f32], b: &[f32], avx512: bool) {
    let (j_a, k_b) = (a.len() / CHUNK, b.len() / CHUNK);
    let l = if avx512 { 16 } else { 8 };
    assert!(
        a.len() == j_a * CHUNK && b.len() == k_b * CHUNK && lanes.len() == j_a * k_b * l,
        "coupling: outer product blocks of {} and {} values into {} lanes",
        a.len(),
        b.len(),
        lanes.len()
    );
    let m = Outer {
        lanes: lanes.as_mut_ptr(),
        a: a.as_ptr(),
        b: b.as_ptr(),
        j_a,
        k_b,
    };
    if avx512 {
        m.run512()
    } else {
        m.run256()
    }
}

/// Raw views of [`outer`]'s operands, checked by it.
struct Outer {
    lanes: *mut f32,
    a: *const f32,
    b: *const f32,
    j_a: usize,
    k_b: usize,
}

/// The tile loops of [`outer`], the same for both register widths.
macro_rules! tiles {
    ($m:expr, $tile:ident) => {{
        let (j_a, k_b) = ($m.j_a, $m.k_b);
        let (j2, k4, k2) = (j_a - j_a % 2, k_b - k_b % 4, k_b - k_b % 2);
        // SAFETY (all tiles): j0 + JT ≤ j_a and k0 + KT ≤ k_b, so every row read lies in `a`,
        // `b` and every lane group written lies in `lanes` (lengths checked by `outer`).
        for j0 in (0..j2).step_by(2) {
            for k0 in (0..k4).step_by(4) {
                $m.$tile::<2, 4>(j0, k0);
            }
            for k0 in (k4..k2).step_by(2) {
                $m.$tile::<2, 2>(j0, k0);
            }
            for k0 in k2..k_b {
                $m.$tile::<2, 1>(j0, k0);
            }
        }
        for j0 in j2..j_a {
            for k0 in 0..k_b {
                $m.$tile::<1, 1>(j0, k0);
            }
        }
    }};
}

impl Outer {
    #[target_feature(enable = "avx2,fma")]
    unsafe fn run256(&self) {
        tiles!(self, tile256)
    }

    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn run512(&self) {
        tiles!(self, tile512)
    }

    /// Rows `j0..j0 + JT` of `a` against rows `k0..k0 + KT` of `b`, 8 partial sums each.
    ///
    /// # Safety
    /// AVX2 + FMA; the rows and lane groups must lie inside the operands.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn tile256<const JT: usize, const KT: usize>(&self, j0: usize, k0: usize) {
        let mut acc = [[_mm256_setzero_ps(); KT]; JT];
        for i in (0..CHUNK).step_by(8) {
            let mut xb = [_mm256_setzero_ps(); KT];
            for (kk, x) in xb.iter_mut().enumerate() {
                *x = _mm256_loadu_ps(self.b.add((k0 + kk) * CHUNK + i));
            }
            for (jj, acc) in acc.iter_mut().enumerate() {
                let xa = _mm256_loadu_ps(self.a.add((j0 + jj) * CHUNK + i));
                for (acc, &xb) in acc.iter_mut().zip(&xb) {
                    *acc = _mm256_fmadd_ps(xa, xb, *acc);
                }
            }
        }
        for (jj, acc) in acc.iter().enumerate() {
            for (kk, &acc) in acc.iter().enumerate() {
                let p = self.lanes.add(((j0 + jj) * self.k_b + k0 + kk) * 8);
                _mm256_storeu_ps(p, _mm256_add_ps(_mm256_loadu_ps(p), acc));
            }
        }
    }

    /// [`Outer::tile256`] with 16 partial sums each.
    ///
    /// # Safety
    /// AVX-512F + FMA; the rows and lane groups must lie inside the operands.
    #[target_feature(enable = "avx512f,avx2,fma")]
    #[inline]
    unsafe fn tile512<const JT: usize, const KT: usize>(&self, j0: usize, k0: usize) {
        let mut acc = [[_mm512_setzero_ps(); KT]; JT];
        for i in (0..CHUNK).step_by(16) {
            let mut xb = [_mm512_setzero_ps(); KT];
            for (kk, x) in xb.iter_mut().enumerate() {
                *x = _mm512_loadu_ps(self.b.add((k0 + kk) * CHUNK + i));
            }
            for (jj, acc) in acc.iter_mut().enumerate() {
                let xa = _mm512_loadu_ps(self.a.add((j0 + jj) * CHUNK + i));
                for (acc, &xb) in acc.iter_mut().zip(&xb) {
                    *acc = _mm512_fmadd_ps(xa, xb, *acc);
                }
            }
        }
        for (jj, acc) in acc.iter().enumerate() {
            for (kk, &acc) in acc.iter().enumerate() {
                let p = self.lanes.add(((j0 + jj) * self.k_b + k0 + kk) * 16);
                _mm512_storeu_ps(p, _mm512_add_ps(_mm512_loadu_ps(p), acc));
            }
        }
    }
}
